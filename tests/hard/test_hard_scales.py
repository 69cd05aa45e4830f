"""Extreme scales: SI units without nondimensionalisation, zero damping, damping only in
contact, and a backlash 1e-6 / 1e3 times the vibration amplitude.

References: the hand-written event-located DOP853 and the exact closed form of
``tests/reference.py`` (mapped to SI by the hand derivation in tests/test_dimensional.py),
the conserved energy of the undamped free oscillator, and the exact free-flight solution.
"""

from __future__ import annotations

import cmath
import math
from pathlib import Path

import numpy as np
import pytest

import gearsym

from ._ref import hybrid_solve, ks

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"
KS = ROOT / "scenes" / "kahraman_singh.toml"
R = ks()


@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def spur():
    return gearsym.load_scene(DATA / "spur_pair_unreduced_scene.toml").compile()


def _si(k_m: float) -> dict[str, float]:
    """SI values giving the benchmark point zeta 0.05, Fm 0.1, Fa 0.05, eps 0.2, Omega 0.9 (b = 50 um)."""
    J, rb, b_m = 1.0e-3, 0.05, 50e-6
    m_e = 1.0 / (2 * rb**2 / J)
    wn = math.sqrt(k_m / m_e)
    T = 0.1 * k_m * b_m * J / (2 * rb * m_e)   # Fm = m_e*(rb*T1/J + rb*T2/J)/(k_m*b_m) with T1 = T2
    return {"J1": J, "J2": J, "rb1": rb, "rb2": rb, "k_m": k_m, "k_a": 0.2 * k_m,
            "c_m": 0.1 * math.sqrt(k_m * m_e), "b_m": b_m, "T1": T, "T2": T, "e_a": 0.05 * b_m,
            "omega": 0.9 * wn, "_wn": wn}


@pytest.mark.parametrize("k_m", [1e8, 1e9])
@pytest.mark.parametrize("method", ["adams", "bdf"])
def test_si_units_unreduced_pair_matches_the_dimensionless_reference(spur, k_m, method):
    """k_m/J = 1e11-1e12 s^-2 beside a rigid-body mode: no scaling, no reduction, 4 states."""
    v = _si(k_m)
    wn = v.pop("_wn")
    periods = 30
    T = 2 * math.pi / v["omega"]
    t = np.linspace(0.0, periods * T, periods * 16 + 1)
    # start at DTE x = 1.1 b_m (th2 = 0), at rest
    x0 = [(1.1 * v["b_m"] + v["e_a"]) / v["rb1"], 0.0, 0.0, 0.0]
    tr = spur.simulate(t_end=t[-1], t_out=t, x0=x0, params=spur.units.to_declared(v),  # v is SI; params= declared
                       rtol=1e-10, atol=1e-16, method=method)
    assert np.all(np.isfinite(tr.y))
    th1, th2 = tr.y[:, 0], tr.y[:, 1]
    dte = (v["rb1"] * th1 - v["rb2"] * th2 - v["e_a"] * np.cos(v["omega"] * t)) / v["b_m"]
    params = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": v["omega"] / wn}
    y_ref, ev_ref, _, _ = R.reference_solution(params, [1.1, 0.0], wn * t)
    assert np.max(np.abs(dte - y_ref[:, 0])) < 2e-6
    assert len(tr.events) == len(ev_ref) > 0
    np.testing.assert_allclose([e.t for e in tr.events], np.asarray(ev_ref) / wn, rtol=0, atol=2e-6 / wn)
    # the rigid-body mode stays a drift of the mean angle (balanced torques: no acceleration)
    mean_w = (v["J1"] * tr.y[:, 2] / v["rb1"] + v["J2"] * tr.y[:, 3] / v["rb2"])
    assert np.max(np.abs(mean_w)) < 1e-9 * np.max(np.abs(tr.y[:, 2]) * v["J1"] / v["rb1"])


def _closed(p, x0, t):
    y, ev, surf, d = R.closed_form_linear(p, x0, t)
    return y, np.asarray(ev)


def test_zero_damping_against_the_closed_form(ks_system):
    """Undamped impacts are sensitive (event-time errors grow ~3x per impact here), so the
    comparison with the exact solution covers the first 10 forcing periods (7 contact changes)."""
    p = {"zeta": 0.0, "Fm": 0.1, "Fa": 0.2, "eps": 0.0, "b": 1.0, "Omega": 1.5}
    T = 2 * math.pi / p["Omega"]
    t = np.linspace(0, 10 * T, 10 * 32 + 1)
    y_ref, ev_ref = _closed(p, [1.1, 0.0], t)
    tr = ks_system.simulate(t_end=t[-1], t_out=t, x0=[1.1, 0.0], params=p, rtol=1e-11, atol=1e-13)
    assert len(ev_ref) >= 6 and len(tr.events) == len(ev_ref)
    assert np.max(np.abs(tr.y - y_ref)) < 1e-8
    np.testing.assert_allclose([e.t for e in tr.events], ev_ref, rtol=0, atol=1e-8)


def test_zero_damping_conserves_energy_over_many_impacts(ks_system):
    """Unforced, undamped: E = v^2/2 + F(x) (F the dead-zone potential) is exactly conserved."""
    p = {"zeta": 0.0, "Fm": 0.0, "Fa": 0.0, "eps": 0.0, "b": 1.0, "Omega": 0.9}
    T = 2 * math.pi / p["Omega"]

    def energy(y):
        x, v = y[..., 0], y[..., 1]
        over = np.maximum(np.abs(x) - 1.0, 0.0)
        return 0.5 * v**2 + 0.5 * over**2

    drift = {}
    for rtol in (1e-8, 1e-11):
        tr = ks_system.simulate(t_end=500 * T, n_out=2001, x0=[1.5, 0.0], params=p, rtol=rtol, atol=rtol * 1e-2)
        E = energy(tr.y)
        assert len(tr.events) > 600     # a contact change every ~4.5 time units
        assert np.all(np.isfinite(tr.y)) and np.max(np.abs(tr.y[:, 0])) < 1.5 + 1e-6
        drift[rtol] = np.max(np.abs(E - E[0])) / E[0]
    # not symplectic: the energy drifts with the number of contacts, and shrinks with the tolerance
    assert drift[1e-8] < 1e-4 and drift[1e-11] < 1e-7
    assert drift[1e-11] < 1e-2 * drift[1e-8]


def test_damping_only_in_contact(ks_system):
    """contact_damping effect: the damping force vanishes in the gap (a jump of the vector field)."""
    sysc = gearsym.load_scene(KS, effects={"contact_damping": True}).compile()
    p = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.6, "eps": 0.2, "b": 1.0, "Omega": 0.8}
    zeta, Fm, Fa, eps, b, Om = (p[k] for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega"))

    def rhs(t, y, s):
        x, v = y
        k = 1 + eps * math.cos(Om * t)
        if s[0] > 0:
            f, c = x - b, 2 * zeta
        elif s[1] < 0:
            f, c = x + b, 2 * zeta
        else:
            f, c = 0.0, 0.0
        return np.array([v, Fm + Fa * Om**2 * math.cos(Om * t) - c * v - k * f])

    T = 2 * math.pi / Om
    t = np.linspace(0, 8 * T, 8 * 32 + 1)
    y_ref, ev = hybrid_solve(rhs, lambda t, y: np.array([y[0] - b, y[0] + b]), [1.1, 0.0], t, rtol=1e-13,
                             atol=1e-15, max_step=T / 16)
    tr = sysc.simulate(t_end=t[-1], t_out=t, x0=[1.1, 0.0], params=p, rtol=1e-11, atol=1e-13)
    assert len(ev) > 10 and len(tr.events) == len(ev)
    assert np.max(np.abs(tr.y - y_ref)) < 1e-7
    # and the damping really is off in the gap: this is not the always-damped solution
    tr_always = ks_system.simulate(t_end=t[-1], t_out=t, x0=[1.1, 0.0], params=p, rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(tr_always.y - y_ref)) > 1e-3


def test_backlash_1e_minus_6_of_the_amplitude(ks_system):
    """Two surfaces 2e-6 apart crossed at speed ~1: both crossings located in one step."""
    p = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.6, "eps": 0.2, "b": 1e-6, "Omega": 0.9}
    T = 2 * math.pi / p["Omega"]
    t = np.linspace(0, 10 * T, 10 * 32 + 1)
    y_ref, ev_ref, surf_ref, dir_ref = R.reference_solution(p, [0.5, 0.0], t)
    tr = ks_system.simulate(t_end=t[-1], t_out=t, x0=[0.5, 0.0], params=p, rtol=1e-11, atol=1e-13)
    amp = np.max(np.abs(y_ref[:, 0]))
    assert amp > 1.0                        # the backlash is ~1e-6 of the amplitude
    assert len(ev_ref) >= 4 * 9 and len(tr.events) == len(ev_ref)
    assert [e.surface for e in tr.events] == list(surf_ref)
    assert [e.direction for e in tr.events] == list(dir_ref)
    np.testing.assert_allclose([e.t for e in tr.events], ev_ref, rtol=0, atol=1e-8)
    assert np.max(np.abs(tr.y - y_ref)) < 1e-8


def test_backlash_1e3_times_the_amplitude_is_free_flight(ks_system):
    """b = 1e3 x amplitude: never in contact; the exact free-flight solution (k = 0)."""
    Fa, Om, zeta = 0.05, 0.9, 0.05
    X = Fa * Om**2 / complex(-Om**2, 2 * zeta * Om)     # particular amplitude in free flight
    p = {"zeta": zeta, "Fm": 0.0, "Fa": Fa, "eps": 0.2, "b": 1e3 * abs(X), "Omega": Om}
    T = 2 * math.pi / Om
    t = np.linspace(0, 50 * T, 50 * 32 + 1)
    x0 = [0.01, -0.02]
    # free flight: x'' + 2 zeta x' = Fa Om^2 cos(Om t)
    Xe = X * np.exp(1j * Om * t)
    c2 = (x0[1] - (1j * Om * X).real) / (-2 * zeta)
    c1 = x0[0] - X.real - c2
    x_ex = Xe.real + c1 + c2 * np.exp(-2 * zeta * t)
    v_ex = (1j * Om * Xe).real - 2 * zeta * c2 * np.exp(-2 * zeta * t)
    tr = ks_system.simulate(t_end=t[-1], t_out=t, x0=x0, params=p, rtol=1e-10, atol=1e-13)
    assert tr.events == []
    assert np.max(np.abs(tr.y[:, 0] - x_ex)) < 1e-9
    assert np.max(np.abs(tr.y[:, 1] - v_ex)) < 1e-9
    assert abs(cmath.phase(X)) > 0 and np.all(np.isfinite(tr.y))
