"""Newton's method of single shooting in one C call (``gs_shoot_ws``) against references.

References: the hand-written scipy DOP853 flow of the backlash oscillator with contact
events and saltation (``tests/test_shooting.py``, rtol 1e-13) for the orbit and its
monodromy, and the Python Newton iteration of :func:`gearsym.analysis.periodic.shoot`
(the C iteration switched off) for everything else the result carries.  Where the C
iteration gives up (a step that must be damped, a singular Newton matrix) the Python
iteration must take over from the same guess and give the answer it always gave.
"""

from __future__ import annotations

import numpy as np
import pytest
import test_shooting
from _corrector_spy import python_corrector_only, spy_on_c_corrector
from test_shooting import P0, ROOT, SCENE, ref_flow

import gearsym
import gearsym.analysis.periodic._shooting as shooting_mod
from gearsym.engine.driver import METHODS
from gearsym.engine.shoot import shoot_in_c
from gearsym.errors import ConvergenceError

#: the fixtures of tests/test_shooting.py (the benchmark scene, and with contact damping)
ks, ks_cd = test_shooting.ks, test_shooting.ks_cd


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
    assert not out.converged and out.reason.startswith("the residual did not decrease")
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


# ------------------------------------------------------------------ the continuation's corrector in C
def test_corrector_in_c_matches_python_corrector(ks, monkeypatch):
    """The benchmark's frequency response with the corrector in C and in Python: the same special
    points (to 1e-8) and the same orbits; F_lambda and the residual at a corrected point equal
    the Python path's (System.flow with the parameter sensitivity)."""
    from gearsym.analysis.periodic import exact_f_lambda

    calls = spy_on_c_corrector(monkeypatch)
    br_c = gearsym.continuation(ks, "Omega", 0.8, 1.0, progress=False)
    assert sum(calls) >= 0.9 * len(calls) and len(calls) > 20  # the C corrector did the work
    python_corrector_only(monkeypatch)
    br_py = gearsym.continuation(ks, "Omega", 0.8, 1.0, progress=False)
    kinds = lambda br: sorted((b.type, round(b.value, 6)) for b in br.bifurcations)  # noqa: E731
    assert kinds(br_c) == kinds(br_py) and len(br_c.bifurcations) >= 3
    for a, b in zip(sorted(br_c.bifurcations, key=lambda b: b.value), sorted(br_py.bifurcations, key=lambda b: b.value),
                    strict=True):
        assert abs(a.value - b.value) < 1e-8
    # every C point is an orbit of the Python corrector's branch (same parameter -> same orbit)
    for p in br_c.points[::7]:
        o = ks.periodic_orbit(x0=p.x0, params={"Omega": p.value}, transient=0)
        assert np.max(np.abs(o.x0 - p.x0)) < 1e-8
        assert abs(o.peak_to_peak() - p.peak_to_peak) < 1e-5
    # the C corrector's F_lambda, residual and monodromy at a branch point against System.flow's
    # (the state, monodromy and parameter sensitivity integrated by the Python path)
    from gearsym.analysis.periodic import ShootingResidual
    from gearsym.engine.shoot import correct_in_c
    from gearsym.sensitivity import directions

    p = br_c.points[len(br_c.points) // 2]
    rtol, atol = br_c.info["rtol"], br_c.info["atol"]
    res = ShootingResidual(ks, "Omega", 1, {}, 1, 0.0, rtol, atol)
    ev = res.evaluate(p.x0, p.value)
    fl = exact_f_lambda(res, p.x0, p.value)
    p0 = res.pvec(p.value)
    z = np.concatenate([p.x0, [p.value]])
    row = np.zeros(3)
    row[-1] = 1.0
    out = correct_in_c(ks.derivative_engine(), z, row, p.value, np.ones(3), np.ones(2), tol=1e-6, max_iter=5,
                       min_damping=0.125, periods=1.0, lam0=p.value, p0=p0,
                       D=directions(ks, ["Omega"], p0)[:, 0], atol=atol, t0=0.0, method=METHODS["adams"], rtol=rtol,
                       max_steps=0)
    assert out.converged and out.iterations == 0 and out.n_runs == 1
    assert np.max(np.abs(out.f_lambda - fl)) < 1e-6 * max(1.0, np.abs(fl).max())
    assert np.max(np.abs(out.f_lambda - ev.Flam)) < 1e-6 * max(1.0, np.abs(fl).max())
    assert np.max(np.abs(out.R - ev.R)) < 1e-9
    assert np.max(np.abs(out.monodromy - ev.monodromy)) < 1e-7 * max(1.0, np.abs(ev.monodromy).max())
    assert len(out.run.events) == len(ev.events)


def test_corrector_samples_are_the_flow_samples(ks):
    """The corrected orbit's samples made in the corrector's C call equal what the Python path
    computes for a branch point (System.flow without the monodromy on the same grid, then the
    switching functions and mesh deflections at the samples), and taking them leaves the
    corrected point's run (its events, residual, monodromy) as it was."""
    from gearsym.engine.shoot import correct_in_c
    from gearsym.sensitivity import directions

    o = ks.periodic_orbit(params={"Omega": 0.9})
    assert o.rattle_state >= 1  # contact loss: events along the orbit
    rtol, atol = 1e-10, 1e-12
    p0 = ks.param_vector({"Omega": 0.9})
    z = np.concatenate([o.x0, [0.9]])
    row = np.zeros(3)
    row[-1] = 1.0
    kw = dict(tol=1e-6, max_iter=5, min_damping=0.125, periods=1.0, lam0=0.9, p0=p0,
              D=directions(ks, ["Omega"], p0)[:, 0], atol=atol, t0=0.0, method=METHODS["adams"], rtol=rtol,
              max_steps=0)
    eng = ks.derivative_engine()
    plain = correct_in_c(eng, z, row, 0.9, np.ones(3), np.ones(2), **kw)
    n = 257
    out = correct_in_c(eng, z, row, 0.9, np.ones(3), np.ones(2), n_samples=n, **kw)
    assert plain.converged and out.converged and plain.samples is None and out.samples is not None
    # the corrected point's own run is untouched by the sampling run
    assert np.array_equal(out.z, plain.z) and np.array_equal(out.R, plain.R)
    assert np.array_equal(out.monodromy, plain.monodromy)
    assert np.array_equal(out.run.events.t, plain.run.events.t) and len(out.run.events) >= 2
    assert np.array_equal(out.run.x_final, plain.run.x_final)
    # the samples: the Python path's System.flow on the same grid
    x, lam = out.z[:2], float(out.z[2])
    T = ks.period({"Omega": lam})
    fl = ks.flow(x, 0.0, T, ks.param_vector({"Omega": lam}), rtol=rtol, atol=atol, monodromy=False,
                 method="adams", max_step=T / 8, n_samples=n)
    smp = out.samples
    assert np.array_equal(smp.t, np.linspace(0.0, T, n))
    assert np.max(np.abs(smp.y - fl.samples)) <= 1e-14 * np.abs(fl.samples).max()
    assert np.array_equal(smp.y[0], x)
    assert np.array_equal(smp.g, ks.switching(smp.t, smp.y, p=ks.param_vector({"Omega": lam})))
    H = ks.mesh_deflections(smp.t, smp.y, ks.param_vector({"Omega": lam}))
    assert H.shape == smp.mesh.shape and H.shape[1] >= 1 and np.array_equal(smp.mesh, H)
    # their statistics, made in the same call: numpy's reductions of the samples (end excluded)
    st, Y, G = out.samples.stats, smp.y[:-1], smp.g[:-1]
    assert st is not None and plain.samples is None
    assert np.array_equal(st.max, Y.max(axis=0)) and np.array_equal(st.min, Y.min(axis=0))
    assert np.array_equal(st.argmax, Y.argmax(axis=0)) and np.array_equal(st.argmin, Y.argmin(axis=0))
    assert np.allclose(st.sum_squares, (Y ** 2).sum(axis=0), rtol=1e-13, atol=0)
    assert np.array_equal(st.g_argmin, G.argmin(axis=0)) and np.array_equal(st.g_argmax, G.argmax(axis=0))
    assert st.mesh_argmin == list(H[:-1].argmin(axis=0)) and st.mesh_argmax == list(H[:-1].argmax(axis=0))
    assert out.period == T == plain.period


def test_corrector_tangent_in_c_is_the_python_tangent(ks):
    """The tangent the corrector in C solves for at the converged point is the one
    Continuer.tangent computes from the same point's Jacobian (numpy's solve of the bordered
    system), for a tangent reference along the parameter and a skew one, with unequal scales."""
    from gearsym.analysis.continuation._corrector import Continuer
    from gearsym.analysis.periodic import Evaluation, segment_jacobian
    from gearsym.engine.shoot import correct_in_c
    from gearsym.sensitivity import directions

    o = ks.periodic_orbit(params={"Omega": 0.9})
    p0 = ks.param_vector({"Omega": 0.9})
    z = np.concatenate([o.x0, [0.9]])
    S, Rs = np.array([3e-1, 2.0, 0.5]), np.array([0.7, 4.0])
    kw = dict(tol=1e-8, max_iter=5, min_damping=0.125, periods=1.0, lam0=0.9, p0=p0,
              D=directions(ks, ["Omega"], p0)[:, 0], atol=1e-12, t0=0.0, method=METHODS["adams"], rtol=1e-10,
              max_steps=0)
    eng = ks.derivative_engine()
    row = np.array([0.0, 0.0, 1.0])
    for t_ref in (row, np.array([0.3, -0.8, 0.52])):
        out = correct_in_c(eng, z, row, 0.9 / S[-1], S, Rs, t_ref=t_ref, **kw)
        assert out.converged and out.tangent is not None
        no_ref = correct_in_c(eng, z, row, 0.9 / S[-1], S, Rs, **kw)
        assert no_ref.tangent is None and np.array_equal(no_ref.z, out.z)
        # the Python tangent from the same Jacobian, without the C solution
        C = Continuer.__new__(Continuer)
        C.S, C.Rs = S, Rs
        C.scaled_anchor = lambda lam: None
        ev = Evaluation(out.R, segment_jacobian([out.monodromy]), out.f_lambda, monodromy=out.monodromy)
        t_py = C.tangent(ev, t_ref, float(out.z[-1]))
        ev.tangent = (t_ref, out.tangent)
        t_c = C.tangent(ev, t_ref, float(out.z[-1]))
        assert np.max(np.abs(t_c - t_py)) < 1e-13 and abs(np.linalg.norm(t_c) - 1) < 1e-15
        # and it solves the bordered system: J_s t = 0, t_ref . t > 0
        Js = np.hstack([out.monodromy - np.eye(2), out.f_lambda[:, None]]) * S[None, :] / Rs[:, None]
        assert np.max(np.abs(Js @ t_c)) < 1e-12 * np.abs(Js).max() and t_c @ t_ref > 0


def test_branch_points_from_c_samples_equal_the_python_points(ks, monkeypatch):
    """A branch point built from the corrector's C samples carries what the Python path gives
    (extrema, surface extrema, mesh deflection extrema, rattle state) for the same orbit."""
    import gearsym.analysis.continuation._corrector as corrector_mod

    br_c = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)
    orig = corrector_mod.Continuer._correct_in_c

    def without_samples(self, z, row, target, t_ref=None):
        out = orig(self, z, row, target, t_ref)
        if out is not None:
            out[1].samples = None
        return out

    monkeypatch.setattr(corrector_mod.Continuer, "_correct_in_c", without_samples)
    br_py = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)
    assert len(br_c.points) == len(br_py.points) > 10
    for a, b in zip(br_c.points, br_py.points, strict=True):
        assert a.value == b.value and np.array_equal(a.x0, b.x0)
        assert a.max == b.max and a.min == b.min and a.rattle_state == b.rattle_state
        assert a.surface_extrema == b.surface_extrema and a.meshes == b.meshes
    assert {p.rattle_state for p in br_c.points} >= {0, 1}  # both sides of the contact-loss boundary


def test_python_iteration_resumes_from_the_last_c_iterate(ks, monkeypatch):
    """When the C iteration gives up after accepted steps (here: its budget cut to one step),
    the Python iteration takes over from its last accepted iterate, with its history, and ends
    where the Python iteration alone ends (the same steps, taken by the other engine)."""
    ref = ks.periodic_orbit()
    guess = ref.x0 + np.array([2e-3, -1e-3])
    orig = shooting_mod._newton_in_c
    seen = []

    def one_step(*a, **k):
        out = orig(*a, **dict(k, max_iter=1))
        seen.append(out)
        return out

    monkeypatch.setattr(shooting_mod, "_newton_in_c", one_step)
    orbit = ks.periodic_orbit(x0=guess, transient=0)
    assert seen and not seen[0].converged and seen[0].iterations == 1
    engines = [h.get("engine") for h in orbit.history]
    assert engines[:2] == ["C", "C"] and all(e is None for e in engines[2:]) and len(engines) >= 3
    assert [h["iteration"] for h in orbit.history] == list(range(len(orbit.history)))
    python_only(monkeypatch)
    py = ks.periodic_orbit(x0=guess, transient=0)
    assert orbit.iterations == py.iterations and len(orbit.history) == len(py.history)
    assert np.max(np.abs(orbit.x0 - py.x0)) < 1e-10
    for a_, b_ in zip(orbit.history, py.history, strict=True):
        assert a_["residual"] == pytest.approx(b_["residual"], rel=1e-3, abs=1e-12)


def test_wrong_sizes_are_refused_before_c_reads_them(ks):
    """Arrays of the wrong length never reach the C iterations (they would be read out of bounds)."""
    from gearsym.engine.errors import EngineInputError
    from gearsym.engine.shoot import correct_in_c

    p = ks.param_vector()
    T = ks.period()
    kw = dict(method=METHODS["adams"], rtol=1e-10, atol=1e-12, max_step=T / 8, max_steps=0, tol=1e-10,
              scale_floor=1e-3, pivot_tol=1e-6, max_iter=5)
    with pytest.raises(EngineInputError, match="x0 has 3 entries"):
        shoot_in_c(ks.engine, np.zeros(3), p, 0.0, T, np.linspace(0, T, 5), **kw)
    with pytest.raises(EngineInputError, match="p has"):
        shoot_in_c(ks.engine, np.zeros(2), p[:-1], 0.0, T, np.linspace(0, T, 5), **kw)
    with pytest.raises(EngineInputError, match="sample times"):
        shoot_in_c(ks.engine, np.zeros(2), p, 0.0, T, np.array([T]), **kw)
    ckw = dict(tol=1e-9, max_iter=5, min_damping=0.125, periods=1.0, lam0=0.9, p0=p, D=np.zeros(len(p)), atol=1e-12,
               t0=0.0, method=METHODS["adams"], rtol=1e-10, max_steps=0)
    with pytest.raises(EngineInputError, match="row has 2 entries"):
        correct_in_c(ks.derivative_engine(), np.zeros(3), np.zeros(2), 0.0, np.ones(3), np.ones(2), **ckw)
    with pytest.raises(EngineInputError, match="Rs has 3 entries"):
        correct_in_c(ks.derivative_engine(), np.zeros(3), np.zeros(3), 0.0, np.ones(3), np.ones(3), **ckw)


def test_reused_corrector_outcomes_do_not_share_its_buffers(ks):
    """A Corrector reuses its ctypes structs and buffers across calls: an outcome must keep its
    own arrays (equal to a fresh corrector's for the same point) after later calls."""
    from gearsym.engine.shoot import Corrector, correct_in_c
    from gearsym.sensitivity import directions

    p0 = ks.param_vector({"Omega": 0.9})
    kw = dict(tol=1e-8, max_iter=8, min_damping=0.125, periods=1.0, lam0=0.9, p0=p0,
              D=directions(ks, ["Omega"], p0)[:, 0], atol=1e-12, t0=0.0, method=METHODS["adams"], rtol=1e-10,
              max_steps=0, n_samples=65)
    S, Rs, row = np.ones(3), np.ones(2), np.array([0.0, 0.0, 1.0])
    corr = Corrector(ks.derivative_engine(), **kw)
    o = ks.periodic_orbit(params={"Omega": 0.9})
    first = corr(np.concatenate([o.x0, [0.9]]), row, 0.9, S, Rs, t_ref=row)
    kept = {k: np.array(getattr(first, k), copy=True) for k in ("z", "R", "monodromy", "f_lambda", "tangent")}
    kept["y"], kept["ev_t"] = first.samples.y.copy(), first.events.t.copy()
    o2 = ks.periodic_orbit(params={"Omega": 0.95})
    second = corr(np.concatenate([o2.x0, [0.95]]), row, 0.95, S, Rs, t_ref=row)
    assert first.converged and second.converged and abs(second.z[-1] - 0.95) < 1e-12
    assert not np.allclose(second.samples.y, kept["y"])  # a different orbit went through the buffers
    for k in ("z", "R", "monodromy", "f_lambda", "tangent"):
        assert np.array_equal(getattr(first, k), kept[k]), k
    assert np.array_equal(first.samples.y, kept["y"]) and np.array_equal(first.events.t, kept["ev_t"])
    fresh = correct_in_c(ks.derivative_engine(), np.concatenate([o.x0, [0.9]]), row, 0.9, S, Rs, t_ref=row, **kw)
    assert np.array_equal(fresh.z, first.z) and np.array_equal(fresh.samples.y, first.samples.y)
    assert np.array_equal(fresh.tangent, first.tangent) and fresh.period == first.period


@pytest.mark.parametrize("scene, param", [("kahraman_singh", "Omega"), ("yu_constant_backlash", "Omega")])
def test_corrector_multipliers_in_c_are_the_stability_rule_s(scene, param):
    """The multipliers and tolerances the corrector computes in C (scipy's LAPACK through
    cython_lapack) are multiplier_tolerances' for the same monodromy: the 2-state benchmark
    and the 10-state six-degree-of-freedom pair (complex pairs, unequal state units)."""
    from gearsym.analysis.periodic import floquet, multiplier_tolerances, verdict
    from gearsym.engine.shoot import correct_in_c, lapack_pointers
    from gearsym.sensitivity import directions

    assert set(lapack_pointers()) == {"dgebal", "dgesdd", "dgeev", "dgelsd"}
    s = gearsym.load_scene(ROOT / "scenes" / f"{scene}.toml").compile()
    o = s.periodic_orbit()
    nx, lam, p0 = s.generated.nx, float(s.params[param]), s.param_vector()
    row = np.zeros(nx + 1)
    row[-1] = 1.0
    out = correct_in_c(s.derivative_engine(), np.concatenate([o.x0, [lam]]), row, lam, np.ones(nx + 1), np.ones(nx),
                       tol=1e-6, max_iter=5, min_damping=0.125, periods=1.0, lam0=lam, p0=p0,
                       D=directions(s, [param], p0)[:, 0], atol=1e-12, t0=0.0, method=METHODS["bdf"], rtol=1e-10,
                       max_steps=0)
    assert out.converged and out.multipliers is not None
    mu, tol, delta = out.multipliers
    mu_py, tol_py, delta_py = multiplier_tolerances(out.monodromy, 1e-10)
    assert np.sum(np.abs(mu.imag) > 0) >= 2  # complex pairs: the pair branch of the condition numbers
    assert np.allclose(mu, mu_py, rtol=1e-13, atol=1e-15) and np.allclose(tol, tol_py, rtol=1e-12, atol=0)
    assert delta == pytest.approx(delta_py, rel=1e-13)
    a, b = verdict(mu, tol, delta), floquet(out.monodromy, 1e-10)
    assert a.stability == b.stability and a.n_unstable == b.n_unstable and np.allclose(a.multipliers, b.multipliers)


@pytest.mark.parametrize("scene", ["kahraman_singh", "yu_constant_backlash"])
def test_shooting_multipliers_in_c_are_the_stability_rule_s(scene, monkeypatch):
    """The orbit solve's multipliers come from its C call (scipy's LAPACK): the same numbers as
    multiplier_tolerances of the orbit's monodromy, and the orbit's verdict is floquet's; on the
    benchmark and the 10-state pair."""
    from gearsym.analysis.periodic import floquet, multiplier_tolerances

    s = gearsym.load_scene(ROOT / "scenes" / f"{scene}.toml").compile()
    seen = []
    orig = shooting_mod._newton_in_c

    def spy(*a, **k):
        out = orig(*a, **k)
        seen.append(out)
        return out

    monkeypatch.setattr(shooting_mod, "_newton_in_c", spy)
    o = s.periodic_orbit()
    assert seen and seen[-1].converged and seen[-1].multipliers is not None
    mu, tol, delta = seen[-1].multipliers
    mu_py, tol_py, _ = multiplier_tolerances(o.monodromy, o.info["rtol"])
    assert np.allclose(mu, mu_py, rtol=1e-13, atol=1e-15) and np.allclose(tol, tol_py, rtol=1e-12, atol=0)
    ref = floquet(o.monodromy, o.info["rtol"])
    assert o.stability == ref.stability and np.allclose(o.multipliers, ref.multipliers, rtol=1e-13, atol=1e-15)
    assert np.allclose(o.multiplier_tolerances, ref.tolerances, rtol=1e-12, atol=0)
    # the isolation verdict comes from the same call: isolation()'s numbers for the orbit's
    # monodromy in the orbit's scales (numpy's svd)
    from gearsym.analysis.periodic import isolation

    assert seen[-1].isolation is not None
    iso = isolation(o.monodromy, np.array(o.info["state_scales"]), o.info["rtol"])
    got = o.info["isolation"]
    assert got["isolated"] and iso.isolated and got["n_trivial"] == 0
    assert got["sigma_min"] == pytest.approx(iso.sigma, rel=1e-12)
    assert got["threshold"] == pytest.approx(iso.threshold, rel=1e-12)
    # and the switching functions at the orbit's start (its rattle state), gs_eval's numbers
    assert np.array_equal(seen[-1].g0, s.switching(0.0, o.x0).ravel())
    direction = seen[-1].isolation[2]
    assert min(np.max(np.abs(direction - iso.direction)), np.max(np.abs(direction + iso.direction))) \
        <= 1e-10 * np.max(np.abs(iso.direction))


@pytest.mark.parametrize("mirror, struct", [("GsShootArgs", "gs_shoot_args"), ("GsCorrectArgs", "gs_correct_args")])
def test_newton_struct_mirrors_are_size_checked_at_load(ks, monkeypatch, mirror, struct):
    """The Newton iterations' argument structs grow with the driver: a ctypes mirror one field
    short of the C struct is refused when the engine loads (it would be read out of bounds)."""
    import ctypes

    import gearsym.engine.driver as drv
    from gearsym.engine.errors import EngineABIError

    drv.load_engine(ks.engine.path)  # the real mirrors load
    short = type("Short", (ctypes.Structure,), {"_fields_": getattr(drv, mirror)._fields_[:-1]})
    monkeypatch.setattr(drv, mirror, short)
    with pytest.raises(EngineABIError, match=f"sizeof\\({struct}\\) is"):
        drv.load_engine(ks.engine.path)


def test_an_orbit_solve_leaves_no_cycle_that_keeps_the_engine_alive():
    """The shooting arguments are cached per engine and thread (Shooter); they must not keep
    the engine, and so its C workspaces, alive after the system is gone (freed at once by
    reference counting, without a garbage collection)."""
    import gc
    import weakref

    gc.disable()
    try:
        s = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
        o = s.periodic_orbit()
        assert o.history[-1].get("engine") == "C"  # the cached C path was taken
        ref = weakref.ref(s.engine)
        del s, o
        assert ref() is None
    finally:
        gc.enable()
