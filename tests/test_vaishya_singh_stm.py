"""Vaishya & Singh's own method (examples/vaishya_singh_stm.py): piecewise state-transition matrices.

* The Bessel pair of eq. 30 solves eq. 29 (read with delta for delta') only with the exponent 3/2
  in sigma; with the printed 2/3 it does not (models/vaishya_singh.toml records the reading).
* An Airy segment of the script (formulation B, single contact) against scipy's integration of
  the same equation.
* The product of the segments' matrices (eq. 31) is gearsym's monodromy of the model (variational
  equations), the forced response of eqs. 36-39 its periodic orbit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import jv

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
import vaishya_singh_stm as stm  # noqa: E402


def _bessel_pair(s: np.ndarray, b1: float, exponent: float) -> np.ndarray:
    sigma = 2 * s ** exponent / (3 * abs(b1))      # eq. 29 depends on b1^2 only (d/dt = b1 d/ds)
    return np.array([np.sqrt(s) * jv(1 / 3, sigma), np.sqrt(s) * jv(-1 / 3, sigma)])


@pytest.mark.parametrize("exponent, solves", [(1.5, True), (2 / 3, False)])
def test_eq30_solves_eq29_only_with_exponent_3_2(exponent, solves):
    # delta'' + (b1 t + b2) delta = 0 with b1, b2 of the Fig. 6(a) pair's single-contact segment
    pair = stm.pair_of("fig6a")
    seg = pair.segment(1)
    b2, b1 = seg["g0"] * seg["k"] / pair.m_e, seg["g1"] * seg["k"] / pair.m_e
    t = np.linspace(0.0, seg["dt"], 20001)
    h = t[1] - t[0]
    y = _bessel_pair(b1 * t + b2, b1, exponent)
    ydd = (y[:, 2:] - 2 * y[:, 1:-1] + y[:, :-2]) / h ** 2
    res = np.abs(ydd + (b1 * t[1:-1] + b2) * y[:, 1:-1]).max() / np.abs((b1 * t + b2) * y).max()
    assert (res < 1e-3) == solves, res


def test_airy_segment_against_scipy():
    pair = stm.pair_of("fig6b")
    seg = pair.segment(2)                       # after the pitch point: the coefficient falls with t
    taus = np.array([0.3, 1.0]) * seg["dt"]
    Phis, ds = stm.airy_segment(pair, seg, taus)
    a0, a1, F = seg["g0"] * seg["k"] / pair.m_e, seg["g1"] * seg["k"] / pair.m_e, pair.N0 / pair.m_e

    def f(tau, y):
        return [y[1], F - (a1 * tau + a0) * y[0]]

    for x0, col in (([1e-6, 0.0], 0), ([0.0, 1e-2], 1)):
        sol = solve_ivp(lambda t, y: [y[1], -(a1 * t + a0) * y[0]], (0, taus[-1]), x0, t_eval=taus,
                        rtol=1e-12, atol=1e-20)
        for k in range(2):
            assert np.allclose(Phis[k][:, col] * x0[col], sol.y[:, k], rtol=1e-7, atol=1e-12 * max(x0))
    sol = solve_ivp(f, (0, taus[-1]), [0.0, 0.0], t_eval=taus, rtol=1e-12, atol=1e-18)
    for k in range(2):
        assert np.allclose(ds[k], sol.y[:, k], rtol=1e-7, atol=1e-14)


@pytest.mark.parametrize("case", ["fig3", "fig6b"])
def test_piecewise_transition_matrix_is_gearsyms_monodromy(case):
    pair = stm.pair_of(case)
    per = stm.periodic_response(pair, per_segment=200)
    g = stm.gearsym_side(case)
    assert np.allclose(per["Phi"], g["monodromy"], rtol=1e-7, atol=1e-7 * np.abs(g["monodromy"]).max())
    assert np.ptp(per["dte"]) == pytest.approx(g["ppv"], rel=1e-3)
    assert np.allclose(per["x0"], g["x0"], rtol=1e-6, atol=1e-6 * np.abs(g["x0"]).max())
