"""Newton's method of single shooting in one C call (``gs_shoot_ws``) against references.

References: the hand-written scipy DOP853 flow of the backlash oscillator with contact
events and saltation (``tests/test_shooting.py``, rtol 1e-13) for the orbit and its
monodromy, and the Python Newton iteration of :func:`gearsym.analysis.shooting.shoot`
(the C iteration switched off) for everything else the result carries.  Where the C
iteration gives up (a step that must be damped, a singular Newton matrix) the Python
iteration must take over from the same guess and give the answer it always gave.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_shooting import P0, SCENE, ref_flow

import gearsym
import gearsym.analysis.shooting as shooting_mod
from gearsym.engine.driver import METHODS
from gearsym.engine.shoot import shoot_in_c
from gearsym.errors import ConvergenceError


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(SCENE).compile()


@pytest.fixture(scope="module")
def ks_cd():
    return gearsym.load_scene(SCENE, effects={"contact_damping": True}).compile()


def python_only(monkeypatch):
    monkeypatch.setattr(shooting_mod, "_newton_in_c", lambda *a, **k: None)


@pytest.mark.parametrize("fixture", ["ks", "ks_cd"])
def test_orbit_from_c_matches_scipy_and_python_newton(request, monkeypatch, fixture):
    system = request.getfixturevalue(fixture)
    cd = fixture == "ks_cd"
    ref = system.periodic_orbit()
    guess = ref.x0 + np.array([2e-3, -1e-3])
    orbit = system.periodic_orbit(x0=guess, transient=0)
    assert orbit.history[-1].get("engine") == "C"
    assert orbit.converged and orbit.iterations >= 2
    # the orbit is a fixed point of the independent flow map, its monodromy that flow's
    T = 2 * np.pi / P0["Omega"]
    xT, M_ref, n_ev = ref_flow(P0, orbit.x0, 0.0, T, cd, variational=True)
    assert n_ev == len(orbit.events) == 2
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9
    assert np.max(np.abs(orbit.monodromy - M_ref)) < 1e-7 * max(1.0, np.abs(M_ref).max())
    # the Python iteration from the same guess: the same orbit, iterations, history and verdict
    python_only(monkeypatch)
    py = system.periodic_orbit(x0=guess, transient=0)
    assert "engine" not in py.history[-1]
    assert np.max(np.abs(py.x0 - orbit.x0)) < 1e-10
    assert py.iterations == orbit.iterations and len(py.history) == len(orbit.history)
    for a, b in zip(py.history, orbit.history, strict=True):
        assert a["residual"] == pytest.approx(b["residual"], rel=1e-3, abs=1e-12)
        assert a["step"] == b["step"]
    assert np.max(np.abs(np.sort_complex(py.multipliers) - np.sort_complex(orbit.multipliers))) < 1e-9
    assert py.stable == orbit.stable and py.rattle_state == orbit.rattle_state
    assert py.info["state_scales"] == pytest.approx(orbit.info["state_scales"], rel=1e-8)


def test_damped_steps_fall_back_to_python(ks, monkeypatch):
    """A guess far from the orbit needs damped steps: the C iteration gives up and the Python
    iteration, from the same guess, converges as it did before the C path existed."""
    guess = np.array([3.0, 2.0])
    p = ks.param_vector()
    T = ks.period()
    grid = np.linspace(0.0, T, 17)
    out = shoot_in_c(ks.engine, guess, p, 0.0, T, grid, method=METHODS["adams"], rtol=1e-11, atol=1e-13,
                     max_step=T / 8, max_steps=0, tol=1e-10, scale_floor=1e-3, pivot_tol=1e-6, max_iter=50)
    assert not out.converged and out.reason == "a full Newton step did not decrease the residual"
    orbit = ks.periodic_orbit(x0=guess, transient=0)
    assert "engine" not in orbit.history[-1]
    assert any(h["step"] not in (None, 1.0) for h in orbit.history)  # damped
    python_only(monkeypatch)
    py = ks.periodic_orbit(x0=guess, transient=0)
    assert np.max(np.abs(orbit.x0 - py.x0)) == 0.0  # the very same iteration
    assert orbit.converged
    xT, _ = ref_flow(P0, orbit.x0, 0.0, ks.period())
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9


def test_singular_newton_matrix_gives_up_and_is_reported():
    """The undamped linear oscillator forced at resonance: M - I is singular.  The C iteration
    gives up on the pivot; the Python path reports 'no isolated periodic orbit'."""
    scene = gearsym.load_scene(SCENE, zeta=0.0, eps=0.0, b=0.0, Fm=0.0, Omega=1.0)
    system = scene.compile()
    p = system.param_vector()
    T = system.period()
    out = shoot_in_c(system.engine, np.array([0.1, 0.0]), p, 0.0, T, np.linspace(0.0, T, 17),
                     method=METHODS["adams"], rtol=1e-11, atol=1e-13, max_step=T / 8, max_steps=0, tol=1e-10,
                     scale_floor=1e-3, pivot_tol=1e3 * 100 * 1e-11, max_iter=50)
    assert not out.converged and out.reason == "the Newton matrix is nearly singular"
    with pytest.raises(ConvergenceError, match="isolated"):
        system.periodic_orbit(x0=[0.1, 0.0], transient=0)


def test_first_integration_failure_raises_like_the_python_path(ks):
    """A step budget that the first run exhausts: the engine's error, not a silent fallback."""
    p = ks.param_vector()
    T = ks.period()
    with pytest.raises(gearsym.errors.SimulationError, match="max_steps"):
        shoot_in_c(ks.engine, np.array([0.5, 0.0]), p, 0.0, T, np.linspace(0.0, T, 17), method=METHODS["adams"],
                   rtol=1e-11, atol=1e-13, max_step=T / 8, max_steps=5, tol=1e-10, scale_floor=1e-3,
                   pivot_tol=1e-6, max_iter=50)
