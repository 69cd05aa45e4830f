"""Monodromy (variational equations + saltation matrices) against finite
differences of the flow map, on an impacting orbit where the vector field
jumps at the switching surface (damping only in contact)."""

from __future__ import annotations

import numpy as np
import pytest
from reference import backlash_reference

from gearsym.engine.errors import EngineInputError

# damping 2*zeta*x' only for |x| > b: the vector field jumps at x = +-b
P_JUMP = [0.1, 0.2, 0.8, 0.1, 1.0, 1.0]  # zeta, eps, Om, Fm, Fa, b
X0 = np.array([0.3, 0.9])


def flow(engine, x0, t_end, **kw):
    return engine.run(x0, P_JUMP, 0.0, t_end, rtol=1e-12, atol=1e-14, **kw)


def fd_monodromy(engine, x0, t_end, h=1e-6):
    cols = []
    n_ev = None
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        rp, rm = flow(engine, x0 + e, t_end), flow(engine, x0 - e, t_end)
        assert len(rp.events) == len(rm.events)  # no event appears/disappears
        n_ev = len(rp.events)
        cols.append((rp.x_final - rm.x_final) / (2 * h))
    return np.array(cols).T, n_ev


@pytest.mark.parametrize("method", ["bdf", "adams"])
def test_monodromy_with_saltation_vs_fd(backlash_jump_engine, method):
    T = 2 * np.pi / P_JUMP[2]
    t_end = 2 * T
    r = backlash_jump_engine.run(
        X0, P_JUMP, 0.0, t_end, rtol=1e-10, atol=1e-12, want_monodromy=True, method=method
    )
    M_fd, n_ev = fd_monodromy(backlash_jump_engine, X0, t_end)
    assert len(r.events) == n_ev >= 2
    # the events are transversal (no grazing)
    assert np.min(np.abs(r.events.speed)) > 1e-2
    scale = np.max(np.abs(M_fd))
    err = np.max(np.abs(r.monodromy - M_fd)) / scale
    assert err < 1e-5, (err, r.monodromy, M_fd)

    # independent scipy variational reference, with and without saltation
    _, _, _, M_salt = backlash_reference(P_JUMP, X0, t_end, [], jump_damping=True, variational=True)
    _, _, _, M_nosalt = backlash_reference(
        P_JUMP, X0, t_end, [], jump_damping=True, variational=True, saltation=False
    )
    assert np.max(np.abs(M_salt - M_fd)) / scale < 1e-5
    assert np.max(np.abs(r.monodromy - M_salt)) / scale < 1e-6
    # leaving the saltation matrices out would be a visible error
    assert np.max(np.abs(M_nosalt - M_fd)) / scale > 1e-2


def test_monodromy_continuous_field_and_state_unchanged(backlash_engine, backlash_jump_engine):
    """The augmented run gives the same trajectory as a plain run, and on the
    continuous backlash field (saltation = identity) it matches FD too."""
    T = 2 * np.pi / P_JUMP[2]
    t_out = np.linspace(0, 2 * T, 41)
    a = backlash_jump_engine.run(X0, P_JUMP, 0.0, 2 * T, t_out, rtol=1e-10, atol=1e-12)
    b = backlash_jump_engine.run(X0, P_JUMP, 0.0, 2 * T, t_out, rtol=1e-10, atol=1e-12, want_monodromy=True)
    assert np.max(np.abs(a.y - b.y)) < 1e-7
    np.testing.assert_allclose(a.events.t, b.events.t, atol=1e-8)
    M_fd, _ = fd_monodromy(backlash_engine, X0, 2 * T)
    c = backlash_engine.run(X0, P_JUMP, 0.0, 2 * T, rtol=1e-10, atol=1e-12, want_monodromy=True)
    assert np.max(np.abs(c.monodromy - M_fd)) / np.max(np.abs(M_fd)) < 1e-5


@pytest.mark.parametrize("linear_solver", ["blockdiag", "dense"])
def test_monodromy_on_ida_vs_fd(backlash_jump_engine, backlash_engine, backlash_ida_engine, linear_solver):
    """IDA integrates the DAE's variational equations F_y S + F_y' S' = 0 with the
    saltation matrices: the explicit model run through IDA (jumping vector field) and the
    implicit residual model agree with finite differences of the flow."""
    T = 2 * np.pi / P_JUMP[2]
    t_end = 2 * T
    r = backlash_jump_engine.run(X0, P_JUMP, 0.0, t_end, rtol=1e-10, atol=1e-12, want_monodromy=True,
                                 method="ida", linear_solver=linear_solver)
    M_fd, n_ev = fd_monodromy(backlash_jump_engine, X0, t_end)
    assert len(r.events) == n_ev >= 2
    assert np.max(np.abs(r.monodromy - M_fd)) / np.max(np.abs(M_fd)) < 1e-5
    M_fd2, _ = fd_monodromy(backlash_engine, X0, t_end)
    s = backlash_ida_engine.run(X0, P_JUMP, 0.0, t_end, rtol=1e-10, atol=1e-12, want_monodromy=True,
                                method="ida", linear_solver=linear_solver)
    assert np.max(np.abs(s.monodromy - M_fd2)) / np.max(np.abs(M_fd2)) < 1e-5


def test_monodromy_atol_vec_size_on_ida(backlash_ida_engine):
    with pytest.raises(EngineInputError, match="atol_vec"):
        backlash_ida_engine.run(X0, P_JUMP, 0.0, 1.0, method="ida", want_monodromy=True, atol_vec=np.ones(3))
