"""The solvers of the variational equations: the block-diagonal linear solver (one
n x n LU for the state and every column of the variational matrix) against the dense
(n + n^2)^2 formulation it replaces, and both, with the fixed-point iteration, against
central finite differences of the flow -- on impacting orbits whose events carry
saltation matrices."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_monodromy import P_JUMP, X0, fd_monodromy

import gearsym
from gearsym.engine.errors import EngineInputError


def test_blockdiag_equals_dense_on_jump_model(backlash_jump_engine):
    """Same modified-Newton matrix, factored once per block instead of as one
    (n + n^2)^2 matrix: the monodromies agree to round-off."""
    T = 2 * np.pi / P_JUMP[2]
    for method in ("bdf", "adams"):
        runs = {ls: backlash_jump_engine.run(X0, P_JUMP, 0.0, 2 * T, rtol=1e-10, atol=1e-12, want_monodromy=True,
                                             method=method, linear_solver=ls)
                for ls in ("dense", "blockdiag", "auto")}
        assert len(runs["dense"].events) >= 2
        M = runs["dense"].monodromy
        assert np.max(np.abs(runs["blockdiag"].monodromy - M)) <= 1e-13 * np.max(np.abs(M))
        assert np.array_equal(runs["auto"].monodromy, runs["blockdiag"].monodromy)
        assert runs["blockdiag"].stats["n_steps"] == runs["dense"].stats["n_steps"]


def test_fixedpoint_monodromy_vs_fd(backlash_jump_engine):
    T = 2 * np.pi / P_JUMP[2]
    r = backlash_jump_engine.run(X0, P_JUMP, 0.0, 2 * T, rtol=1e-10, atol=1e-12, want_monodromy=True,
                                 method="adams", nonlinear="fixedpoint")
    M_fd, n_ev = fd_monodromy(backlash_jump_engine, X0, 2 * T)
    assert len(r.events) == n_ev >= 2
    assert np.max(np.abs(r.monodromy - M_fd)) / np.max(np.abs(M_fd)) < 1e-5


def test_bad_solver_options(backlash_jump_engine):
    with pytest.raises(EngineInputError, match="variational"):
        backlash_jump_engine.run(X0, P_JUMP, 0.0, 1.0, linear_solver="blockdiag")
    with pytest.raises(EngineInputError, match="unknown linear solver"):
        backlash_jump_engine.run(X0, P_JUMP, 0.0, 1.0, linear_solver="band")
    with pytest.raises(EngineInputError, match="unknown nonlinear solver"):
        backlash_jump_engine.run(X0, P_JUMP, 0.0, 1.0, nonlinear="anderson")


CHAIN = """
[model]
name = "chain3"
time_unit = "1"
[coordinates.q0]
velocity = "w0"
[coordinates.q1]
velocity = "w1"
[coordinates.q2]
velocity = "w2"
[coordinates.q3]
velocity = "w3"
[parameters]
zeta = 0.05
eps = 0.5
b = 1.0
Omega = 0.9
Fm = 0.1
kg = 1.0
[forcing]
period = "2*pi/Omega"
[elements.J0]
type = "inertia"
coordinate = "q0"
value = "1"
[elements.J1]
type = "inertia"
coordinate = "q1"
value = "1"
[elements.J2]
type = "inertia"
coordinate = "q2"
value = "1"
[elements.J3]
type = "inertia"
coordinate = "q3"
value = "1"
[elements.ground]
type = "spring"
deflection = "q0"
stiffness = "kg"
[elements.ground_damper]
type = "damper"
deflection = "q0"
coefficient = "2*zeta"
[elements.m0]
type = "mesh"
deflection = "q0 - q1"
stiffness = "1 + eps*cos(Omega*t)"
damping = "2*zeta"
backlash = "b"
[elements.m1]
type = "mesh"
deflection = "q1 - q2"
stiffness = "1 + eps*cos(Omega*t)"
damping = "2*zeta"
backlash = "b"
[elements.m2]
type = "mesh"
deflection = "q2 - q3"
stiffness = "1 + eps*cos(Omega*t)"
damping = "2*zeta"
backlash = "b"
[elements.load]
type = "force"
coordinate = "q3"
value = "-Fm"
"""


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    d: Path = tmp_path_factory.mktemp("chain")
    (d / "chain3.toml").write_text(CHAIN)
    (d / "scene.toml").write_text('[scene]\nname = "chain3"\nmodel = "chain3.toml"\n'
                                  '[initial]\nq1 = -1.1\nq2 = -2.2\nq3 = -3.3\n')
    system = gearsym.load_scene(d / "scene.toml").compile(generated_dir=d / "gen")
    x0 = system.simulate(periods=60, rtol=1e-9, atol=1e-11).x_final  # on the rattling attractor
    return system, x0


def test_chain_monodromy_solvers_vs_fd(chain):
    """8 states, a sparse Jacobian, three backlash meshes losing contact within the
    period: block-diagonal == dense formulation, and both == central differences."""
    system, x0 = chain
    kw = {"periods": 1, "x0": x0, "rtol": 1e-12, "atol": 1e-14, "n_out": 2}
    ref = system.simulate(monodromy=True, linear_solver="dense", **kw)
    bd = system.simulate(monodromy=True, linear_solver="blockdiag", **kw)
    fp = system.simulate(monodromy=True, nonlinear="fixedpoint", **kw)
    assert ref.stats["n_events"] >= 4
    assert np.min(np.abs(ref.event_speed)) > 1e-2  # transversal crossings: FD is meaningful
    scale = np.max(np.abs(ref.monodromy))
    assert np.max(np.abs(bd.monodromy - ref.monodromy)) <= 1e-12 * scale
    n = len(x0)
    fd = np.empty((n, n))
    h = 1e-6
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        xp = system.simulate(**{**kw, "x0": x0 + e})
        xm = system.simulate(**{**kw, "x0": x0 - e})
        assert xp.stats["n_events"] == xm.stats["n_events"] == ref.stats["n_events"]
        fd[:, j] = (xp.x_final - xm.x_final) / (2 * h)
    assert np.max(np.abs(bd.monodromy - fd)) / scale < 1e-5
    assert np.max(np.abs(fp.monodromy - fd)) / scale < 1e-5
    # the fixed-point iteration follows the same trajectory
    assert np.max(np.abs(fp.x_final - ref.x_final)) < 1e-9 * max(1.0, np.max(np.abs(ref.x_final)))
