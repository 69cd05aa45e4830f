"""A non-periodic response is quasi-periodic only when its exponent is known to be zero.

Found by probing: a brute-force diagram of the DAE pair with a coupled load with a short transient
and few Lyapunov periods called the response "quasi-periodic" at both values (exit 0), where it is a
transient still converging to the period-1 orbit (the default settings find period 1): its largest
exponent, -257 +- 650 per second, is "zero within its error" only because the error is wider than
the zero band, and the Poincare points of a converging spiral lie on one curve.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearsym
from gearsym.analysis.sweeps._attractor_id import (
    QUASI_PERIODIC,
    UNCLASSIFIED,
    ZERO_RATE,
    classify_exponent,
    closed_curve,
)


def _spiral(n: int) -> np.ndarray:
    """Poincare points converging at 0.8 per period to the fixed point (1, 2) while turning 2 rad."""
    k = np.arange(n)
    r = 0.8 ** k
    return np.c_[1 + r * np.cos(2.0 * k), 2 + r * np.sin(2.0 * k)]


def test_an_exponent_with_an_error_wider_than_the_zero_band_is_not_zero():
    T = 2 * math.pi / 15000
    P = _spiral(20)
    assert closed_curve(P)  # the spiral's points look like one curve: the exponent must decide
    code, why = classify_exponent(-257.0, 650.0, T, P)
    assert code == UNCLASSIFIED and "not known to be zero" in why
    # known to the zero band: a zero exponent on one curve is quasi-periodic, as before
    assert classify_exponent(0.1 * ZERO_RATE / T, 0.5 * ZERO_RATE / T, T, P)[0] == QUASI_PERIODIC


@pytest.fixture(scope="module")
def coupled():
    return gearsym.load_scene("spur_pair_coupled_load").compile()


def test_a_converging_transient_is_not_called_quasi_periodic(coupled):
    ds = gearsym.bifurcation_diagram(coupled, "omega", 15000.0, 15000.0, 1, transient=20, samples=20,
                                     lyapunov_periods=32, directions=("forward",), workers=1, progress=False)
    assert int(ds.attrs["n_failed"]) == 0
    assert int(ds["kind"].values.ravel()[0]) == UNCLASSIFIED
    # the reference: integrated long enough, the Poincare points settle on one point (period 1)
    T = 2 * math.pi / 15000
    traj = coupled.simulate(t_end=400 * T, n_out=401, params={"omega": 15000.0})
    P = np.asarray(traj.y)[:, :4]
    scale = np.ptp(P, axis=0)
    late = np.max(np.abs(P[-1] - P[-2]) / scale)
    at_20 = np.max(np.abs(P[21] - P[20]) / scale)  # where the short diagram stopped its transient
    assert late < 1e-6 and at_20 > 1e-3
