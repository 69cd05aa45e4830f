"""IDA with algebraic variables (id vector 0 for the last states): consistent initial
conditions from IDACalcIC, events and the DAE's variational equations, against the same
oscillator written as an ODE (CVODE)."""

from __future__ import annotations

import numpy as np

P = [0.05, 0.2, 0.8, 0.1, 1.0, 1.0]  # zeta, eps, Om, Fm, Fa, b: double-sided impacts
X0 = np.array([1.1, 0.0])


def force(x, v, t, p=P):
    """F(t, x, v) of the backlash oscillator (the algebraic variable's value)."""
    zeta, eps, Om, Fm, Fa, b = p
    f = x - b if x > b else (x + b if x < -b else 0.0)
    return -2 * zeta * v - (1 + eps * np.cos(Om * t)) * f + Fm + Fa * Om**2 * np.cos(Om * t)


def test_dae_matches_ode_and_algebraic_is_consistent(backlash_engine, backlash_dae_engine):
    assert backlash_dae_engine.nalg == 1 and backlash_engine.nalg == 0
    T = 2 * np.pi / P[2]
    t_out = np.linspace(0, 20 * T, 401)
    cv = backlash_engine.run(X0, P, 0.0, 20 * T, t_out, method="bdf", rtol=1e-10, atol=1e-12)
    # an inconsistent guess of the algebraic variable: IDACalcIC corrects it
    da = backlash_dae_engine.run([*X0, 123.0], P, 0.0, 20 * T, t_out, method="ida", rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(da.y[:, :2] - cv.y)) < 1e-6
    z_ref = [force(x, v, t) for t, (x, v) in zip(t_out, cv.y)]
    assert np.max(np.abs(da.y[:, 2] - z_ref)) < 1e-5
    assert abs(da.y[0, 2] - force(*X0, 0.0)) < 1e-10  # the output at t0 is the consistent value
    assert len(da.events) == len(cv.events) > 10
    np.testing.assert_allclose(da.events.t, cv.events.t, atol=1e-6)


def test_dae_monodromy_matches_ode(backlash_engine, backlash_dae_engine):
    T = 2 * np.pi / P[2]
    cv = backlash_engine.run(X0, P, 0.0, 2 * T, method="bdf", rtol=1e-11, atol=1e-13, want_monodromy=True)
    for ls in ("blockdiag", "dense"):
        da = backlash_dae_engine.run([*X0, 0.0], P, 0.0, 2 * T, method="ida", rtol=1e-11, atol=1e-13,
                                     want_monodromy=True, linear_solver=ls)
        M = da.monodromy
        assert np.all(M[:, 2] == 0.0)  # z(t0) is not free
        scale = np.max(np.abs(cv.monodromy))
        assert np.max(np.abs(M[:2, :2] - cv.monodromy)) / scale < 1e-6, (ls, M, cv.monodromy)


def test_dae_monodromy_from_inside_the_gap(backlash_engine, backlash_dae_engine):
    """Start in the backlash gap (no restoring force: the algebraic variable is the forcing alone)."""
    T = 2 * np.pi / P[2]
    x0 = np.array([0.3, 0.9])
    cv = backlash_engine.run(x0, P, 0.0, 2 * T, method="bdf", rtol=1e-11, atol=1e-13, want_monodromy=True)
    da = backlash_dae_engine.run([*x0, 0.0], P, 0.0, 2 * T, method="ida", rtol=1e-11, atol=1e-13,
                                 want_monodromy=True)
    assert np.max(np.abs(da.monodromy[:2, :2] - cv.monodromy)) / np.max(np.abs(cv.monodromy)) < 1e-6


def test_dae_monodromy_with_saltation(backlash_jump_engine, backlash_dae_jump_engine):
    """Damping only in contact: the vector field jumps at the surfaces, the saltation matrices
    (from consistent derivatives of both modes, algebraic variable solved for) are not the identity."""
    p = [0.1, 0.2, 0.8, 0.1, 1.0, 1.0]
    x0 = np.array([0.3, 0.9])
    T = 2 * np.pi / p[2]
    cv = backlash_jump_engine.run(x0, p, 0.0, 2 * T, method="bdf", rtol=1e-11, atol=1e-13, want_monodromy=True)
    da = backlash_dae_jump_engine.run([*x0, 0.0], p, 0.0, 2 * T, method="ida", rtol=1e-11, atol=1e-13,
                                      want_monodromy=True)
    assert len(da.events) == len(cv.events) >= 2
    scale = np.max(np.abs(cv.monodromy))
    assert np.max(np.abs(da.monodromy[:2, :2] - cv.monodromy)) / scale < 1e-6, (da.monodromy, cv.monodromy)
