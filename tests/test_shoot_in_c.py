"""THE Newton iteration of shooting and of the continuation's corrector (``gs_newton.c``) and its
C evaluators (``gs_shoot_ws``, ``gs_correct_ws``) against independent references.

References: the hand-written scipy DOP853 flow of the backlash oscillator with contact events and
saltation (``tests/test_shooting.py``, rtol 1e-13) for orbits and monodromies; ``System.flow``
(the problem's own evaluation) for the corrector's residual, ``F_lambda`` and samples; numpy's
linear algebra for the tangent; ``multiplier_tolerances`` / ``isolation`` for the verdicts.  The
iteration is written once: single and multiple shooting, damped steps, relaxation restarts and
the corrector of every problem (harmonic balance included) run it, and the only thing that may
move to Python is the evaluation of a residual, which the branch then reports.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
import test_shooting
from _corrector_spy import python_corrector_only, spy_on_c_corrector
from test_shooting import P0, ROOT, SCENE, ref_flow

import gearsym
import gearsym.analysis.continuation._corrector as corrector_mod
import gearsym.engine.shoot as shoot_mod
from gearsym.engine.driver import METHODS
from gearsym.engine.newton import EVAL_FAILED
from gearsym.engine.shoot import shoot_in_c
from gearsym.errors import ConvergenceError

#: the fixtures of tests/test_shooting.py (the benchmark scene, and with contact damping)
ks, ks_cd = test_shooting.ks, test_shooting.ks_cd


def _shoot_settings(T: float, **kw) -> dict:
    out = dict(method=METHODS["adams"], rtol=1e-11, atol=1e-13, max_step=T / 8, max_steps=0, tol=1e-10,
               max_iter=50, trunc_level=100 * 1e-11, scale_floor=1e-3)
    out.update(kw)
    return out


def _flow_kw(s, param: str, lam: float, **kw) -> dict:
    """The corrector's C evaluator settings on the single-shooting residual at ``lam``."""
    from gearsym.sensitivity import directions

    p0 = s.param_vector({param: lam})
    out = dict(method=METHODS["adams"], rtol=1e-10, atol=1e-12, max_steps=0, periods=1.0, t0=0.0, lam0=lam, p0=p0,
               D=directions(s, [param], p0)[:, 0])
    out.update(kw)
    return out


# ------------------------------------------------------------------ shooting's Newton
@pytest.mark.parametrize("fixture", ["ks", "ks_cd"])
def test_orbit_matches_scipy(request, fixture):
    system = request.getfixturevalue(fixture)
    cd = fixture == "ks_cd"
    ref = system.periodic_orbit()
    guess = ref.x0 + np.array([2e-3, -1e-3])
    orbit = system.periodic_orbit(x0=guess, transient=0)
    assert orbit.info["newton"] == "C" and orbit.history[-1].get("engine") == "C"
    assert orbit.converged and orbit.iterations >= 2
    # the orbit is a fixed point of the independent flow map, its monodromy that flow's
    T = 2 * np.pi / P0["Omega"]
    xT, M_ref, n_ev = ref_flow(P0, orbit.x0, 0.0, T, cd, variational=True)
    assert n_ev == len(orbit.events) == 2
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9
    assert np.max(np.abs(orbit.monodromy - M_ref)) < 1e-7 * max(1.0, np.abs(M_ref).max())
    mu_ref = np.sort_complex(np.linalg.eigvals(M_ref))
    assert np.max(np.abs(np.sort_complex(orbit.multipliers) - mu_ref)) < 1e-7


@pytest.mark.parametrize("segments", [2, 3])
def test_multiple_shooting_runs_in_c_and_matches_scipy(ks, segments):
    """Multiple shooting is THE iteration with the C evaluator (it was the Python iteration's):
    every segment start is the reference flow's image of the previous one, the product of the
    segment monodromies is the reference monodromy."""
    ref = ks.periodic_orbit()
    o = ks.periodic_orbit(x0=ref.x0 + np.array([2e-3, -1e-3]), transient=0, segments=segments)
    assert o.info["newton"] == "C" and o.converged and o.info["verification"]["ok"]
    T = 2 * np.pi / P0["Omega"]
    s = np.linspace(0.0, T, segments + 1)
    X = np.asarray(o.segment_states)
    assert X.shape == (segments, 2)
    for i in range(segments):
        xi, _ = ref_flow(P0, X[i], s[i], s[i + 1])
        assert np.max(np.abs(xi - X[(i + 1) % segments])) < 1e-9, i
    _, M_ref, _ = ref_flow(P0, o.x0, 0.0, T, variational=True)
    assert np.max(np.abs(o.monodromy - M_ref)) < 1e-7 * max(1.0, np.abs(M_ref).max())
    assert np.max(np.abs(np.sort_complex(o.multipliers) - np.sort_complex(np.linalg.eigvals(M_ref)))) < 1e-7


def test_damped_steps_and_relaxation_stay_in_the_one_iteration(ks):
    """A guess far from the orbit: damped steps, two relaxations by integration where no damped step
    helps (the iteration goes on from there, its steps counted), all in C; the orbit is the
    reference's."""
    orbit = ks.periodic_orbit(x0=[10.0, 0.0], transient=0)
    assert orbit.info["newton"] == "C" and orbit.converged
    assert any(h["step"] not in (None, 1.0) for h in orbit.history)  # damped
    stalls = [h for h in orbit.history if str(h.get("note", "")).startswith("Newton stalled")]
    assert [h["note"] for h in stalls] == ["Newton stalled: integrated 10 forcing periods"] * 2
    steps = [h["iteration"] for h in orbit.history if h["step"] not in (None, 0.0)]
    assert steps == sorted(steps) and steps[-1] == orbit.iterations
    xT, _ = ref_flow(P0, orbit.x0, 0.0, ks.period())
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9


def test_singular_newton_matrix_is_truncated_and_reported():
    """The undamped linear oscillator forced at resonance: M = I, so M - I is singular.  The
    truncated step drops both directions (it moves nothing, so no step is accepted), the
    relaxations by integration cannot remove the residual either, and the orbit is reported as no
    isolated orbit."""
    scene = gearsym.load_scene(SCENE, zeta=0.0, eps=0.0, b=0.0, Fm=0.0, Omega=1.0)
    system = scene.compile()
    with pytest.raises(ConvergenceError, match="isolated"):
        system.periodic_orbit(x0=[0.1, 0.0], transient=0)
    o = system.periodic_orbit(x0=[0.1, 0.0], transient=0, raise_on_failure=False)
    assert not o.converged and o.info["newton"] == "C"
    assert o.info["failure"].startswith("no isolated periodic orbit")
    assert not [h for h in o.history if h["step"] not in (None, 0.0)]  # no step accepted
    notes = [h.get("note") for h in o.history[1:]]
    assert notes == ["Newton stalled: integrated 10 forcing periods"] * 20  # relax_periods = 200


def test_first_integration_failure_is_the_engines_error(ks):
    """A step budget that the first run exhausts: the iteration ends (EVAL_FAILED) and its error is
    the engine's, as the run raises it."""
    p = ks.param_vector()
    T = ks.period()
    out = shoot_in_c(ks.engine, np.array([0.5, 0.0]), p, np.array([0.0, T]), **_shoot_settings(T, max_steps=5))
    assert out.code == EVAL_FAILED and not out.converged
    with pytest.raises(gearsym.errors.SimulationError, match="max_steps"):
        raise out.error()


def test_every_solve_and_correction_runs_the_one_iteration(ks, monkeypatch, caplog):
    """Shooting (single and multiple), the shooting corrector and the harmonic-balance corrector all
    run THE iteration of gs_newton.c (engine.shoot.Shooter / Corrector); where the residuals are
    not the C evaluator's (harmonic balance) the branch says so, with the reason, and it is logged."""
    solves, corrections = [], []
    orig_solve, orig_call = shoot_mod.Shooter.solve, shoot_mod.Corrector.__call__
    monkeypatch.setattr(shoot_mod.Shooter, "solve", lambda self, *a, **k: solves.append(1) or orig_solve(self, *a, **k))
    monkeypatch.setattr(shoot_mod.Corrector, "__call__",
                        lambda self, *a, **k: corrections.append(self.flow is not None) or orig_call(self, *a, **k))
    for seg in (1, 2):
        assert ks.periodic_orbit(segments=seg).converged
    assert len(solves) == 2
    br = gearsym.continuation(ks, "Omega", 0.85, 0.86, progress=False)
    assert br.info["corrector"] == "C" and corrections and all(corrections)
    corrections.clear()
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        hb = gearsym.continuation(ks, "Omega", 0.6, 0.62, progress=False, method="hbm", harmonics=8)
    assert corrections and not any(corrections)  # the same iteration, the residuals HBResidual's
    why = "HBResidual is not the shooting residual over the flow"
    assert hb.info["corrector"] == f"C, residuals in Python: {why}"
    msgs = [r.getMessage() for r in caplog.records if r.name == corrector_mod.__name__]
    assert msgs and set(msgs) == {f"continuation corrector: residuals evaluated in Python: {why}"}


def test_a_correction_in_c_is_one_driver_call(ks, monkeypatch):
    """A correction whose residuals the C evaluator makes is one driver call (gs_correct_ws),
    with nothing else in C per point: the choice of F_lambda's source for Python evaluations
    (a period gradient, gs_eval_period_grad) is made only when Python evaluates (it was made at
    every correction: twice main's C calls per continuation)."""
    ks.derivative_engine()
    eng = ks._derivative_engine
    lib, calls = eng._lib, []

    class Spy:
        def __getattr__(self, name):
            fn = getattr(lib, name)
            if not name.startswith(("gs_correct", "gs_simulate", "gs_eval", "gs_shoot")):
                return fn

            def spied(*args):
                calls.append(name)
                return fn(*args)

            return spied

    monkeypatch.setattr(eng, "_lib", Spy())
    br = gearsym.continuation(ks, "Omega", 0.6, 0.7, progress=False)
    monkeypatch.undo()
    assert br.complete and br.info["corrector"] == "C" and len(br.points) > 10
    assert calls.count("gs_correct_ws") >= len(br.points)
    assert calls.count("gs_eval_period_grad") <= 2 and len(set(calls) - {"gs_correct_ws", "gs_eval_period_grad"}) == 0


def test_a_residual_handed_back_to_python_is_reported_and_logged(ks, monkeypatch, caplog):
    """The C evaluator that cannot evaluate a request (here every one: its parameter direction made
    NaN) hands it to the problem's own evaluation; the same iteration goes on, the branch equals the
    one evaluated in C, and the branch's info counts the hand-backs, with the reason, logged."""
    ref = gearsym.continuation(ks, "Omega", 0.85, 0.87, progress=False)
    orig = corrector_mod.Continuer._flow_setup

    def broken(self, lam):
        import dataclasses

        fl = orig(self, lam)
        return dataclasses.replace(fl, D=fl.D * np.nan)

    monkeypatch.setattr(corrector_mod.Continuer, "_flow_setup", broken)
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        br = gearsym.continuation(ks, "Omega", 0.85, 0.87, progress=False)
    info = br.info["corrector"]
    assert info.startswith("C (") and " residuals evaluated in Python: " in info
    n = int(info[3:].split()[0])
    assert n >= len(br.points)
    msgs = [r.getMessage() for r in caplog.records if r.name == corrector_mod.__name__]
    assert any(m.startswith("continuation corrector: a residual evaluated in Python: ") for m in msgs)
    assert len(br.points) == len(ref.points)
    for a, b in zip(br.points, ref.points, strict=True):
        assert abs(a.value - b.value) < 1e-9 and np.max(np.abs(a.x0 - b.x0)) < 1e-8


# ------------------------------------------------------------------ the continuation's corrector
def test_corrector_c_evaluator_matches_the_problems_evaluation(ks, monkeypatch):
    """The benchmark's frequency response with the residuals evaluated in C and by the problem
    (System.flow), under the one iteration: the same special points (to 1e-8) and the same orbits;
    F_lambda and the residual at a corrected point equal the problem's."""
    from gearsym.analysis.periodic import ShootingResidual, exact_f_lambda
    from gearsym.engine.shoot import correct_in_c

    calls = spy_on_c_corrector(monkeypatch)
    br_c = gearsym.continuation(ks, "Omega", 0.8, 1.0, progress=False)
    assert sum(calls) >= 0.9 * len(calls) and len(calls) > 20  # the C evaluator did the work
    python_corrector_only(monkeypatch)
    br_py = gearsym.continuation(ks, "Omega", 0.8, 1.0, progress=False)
    assert br_py.info["corrector"] == "C, residuals in Python: forced by the test"
    kinds = lambda br: sorted((b.type, round(b.value, 6)) for b in br.bifurcations)  # noqa: E731
    assert kinds(br_c) == kinds(br_py) and len(br_c.bifurcations) >= 3
    for a, b in zip(sorted(br_c.bifurcations, key=lambda b: b.value), sorted(br_py.bifurcations, key=lambda b: b.value),
                    strict=True):
        assert abs(a.value - b.value) < 1e-8
    for p in br_c.points[::7]:  # every C point is an orbit (same parameter -> same orbit)
        o = ks.periodic_orbit(x0=p.x0, params={"Omega": p.value}, transient=0)
        assert np.max(np.abs(o.x0 - p.x0)) < 1e-8
        assert abs(o.peak_to_peak() - p.peak_to_peak) < 1e-5
    p = br_c.points[len(br_c.points) // 2]
    rtol, atol = br_c.info["rtol"], br_c.info["atol"]
    res = ShootingResidual(ks, "Omega", 1, {}, 1, 0.0, rtol, atol)
    ev = res.evaluate(p.x0, p.value)
    fl = exact_f_lambda(res, p.x0, p.value)
    z = np.concatenate([p.x0, [p.value]])
    row = np.array([0.0, 0.0, 1.0])
    out = correct_in_c(ks.derivative_engine(), z, row, p.value, np.ones(3), np.ones(2), tol=1e-6, max_iter=5,
                       **_flow_kw(ks, "Omega", p.value, rtol=rtol, atol=atol))
    assert out.converged and out.iterations == 0 and out.n_runs == 1 and out.n_python == 0
    assert np.max(np.abs(out.f_lambda - fl)) < 1e-6 * max(1.0, np.abs(fl).max())
    assert np.max(np.abs(out.f_lambda - ev.Flam)) < 1e-6 * max(1.0, np.abs(fl).max())
    assert np.max(np.abs(out.R - ev.R)) < 1e-9
    M = out.monodromies[0]
    assert np.max(np.abs(M - ev.monodromy)) < 1e-7 * max(1.0, np.abs(ev.monodromy).max())
    assert len(out.events) == len(ev.events)


def test_corrector_samples_are_the_flow_samples(ks):
    """The corrected orbit's samples made in the corrector's C call equal System.flow's on the
    same grid (then the switching functions and mesh deflections there), and taking them leaves
    the corrected point's evaluation (its events, residual, monodromy) as it was."""
    from gearsym.engine.shoot import correct_in_c

    o = ks.periodic_orbit(params={"Omega": 0.9})
    assert o.rattle_state >= 1  # contact loss: events along the orbit
    rtol, atol = 1e-10, 1e-12
    z = np.concatenate([o.x0, [0.9]])
    row = np.array([0.0, 0.0, 1.0])
    eng = ks.derivative_engine()
    kw = dict(tol=1e-6, max_iter=5)
    plain = correct_in_c(eng, z, row, 0.9, np.ones(3), np.ones(2), **kw, **_flow_kw(ks, "Omega", 0.9))
    n = 257
    out = correct_in_c(eng, z, row, 0.9, np.ones(3), np.ones(2), **kw, **_flow_kw(ks, "Omega", 0.9, n_samples=n))
    assert plain.converged and out.converged and plain.samples is None and out.samples is not None
    assert np.array_equal(out.z, plain.z) and np.array_equal(out.R, plain.R)
    assert np.array_equal(out.monodromies[0], plain.monodromies[0])
    assert np.array_equal(out.events.t, plain.events.t) and len(out.events) >= 2
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
    st, Y, G = out.samples.stats, smp.y[:-1], smp.g[:-1]
    assert st is not None
    assert np.array_equal(st.max, Y.max(axis=0)) and np.array_equal(st.min, Y.min(axis=0))
    assert np.array_equal(st.argmax, Y.argmax(axis=0)) and np.array_equal(st.argmin, Y.argmin(axis=0))
    assert np.allclose(st.sum_squares, (Y ** 2).sum(axis=0), rtol=1e-13, atol=0)
    assert np.array_equal(st.g_argmin, G.argmin(axis=0)) and np.array_equal(st.g_argmax, G.argmax(axis=0))
    assert st.mesh_argmin == list(H[:-1].argmin(axis=0)) and st.mesh_argmax == list(H[:-1].argmax(axis=0))
    assert out.period == T == plain.period


def test_corrector_tangent_is_the_null_vector_of_the_scaled_jacobian(ks):
    """The tangent the iteration computes at the corrected point, and Continuer.tangent's for the
    same Jacobian, are numpy's solution of the bordered system [J_s; t_ref] t = e_n, normalised and
    along t_ref, for a reference along the parameter and a skew one, with unequal scales."""
    from gearsym.analysis.continuation._corrector import Continuer
    from gearsym.analysis.periodic import Evaluation, segment_jacobian
    from gearsym.engine.shoot import correct_in_c

    o = ks.periodic_orbit(params={"Omega": 0.9})
    z = np.concatenate([o.x0, [0.9]])
    S, Rs = np.array([3e-1, 2.0, 0.5]), np.array([0.7, 4.0])
    eng = ks.derivative_engine()
    row = np.array([0.0, 0.0, 1.0])
    for t_ref in (row, np.array([0.3, -0.8, 0.52])):
        out = correct_in_c(eng, z, row, 0.9 / S[-1], S, Rs, t_ref=t_ref, tol=1e-8, max_iter=5,
                           **_flow_kw(ks, "Omega", 0.9))
        assert out.converged and out.tangent is not None
        no_ref = correct_in_c(eng, z, row, 0.9 / S[-1], S, Rs, tol=1e-8, max_iter=5, **_flow_kw(ks, "Omega", 0.9))
        assert no_ref.tangent is None and np.array_equal(no_ref.z, out.z)
        M = out.monodromies[0]
        Js = np.hstack([M - np.eye(2), out.f_lambda[:, None]]) * S[None, :] / Rs[:, None]
        t_np = np.linalg.solve(np.vstack([Js, t_ref]), np.array([0.0, 0.0, 1.0]))
        t_np /= np.linalg.norm(t_np)
        t_np = -t_np if t_np @ t_ref < 0 else t_np
        assert np.max(np.abs(out.tangent - t_np)) < 1e-13 and abs(np.linalg.norm(out.tangent) - 1) < 1e-15
        # Continuer.tangent from the same Jacobian, without the iteration's solution
        C = Continuer.__new__(Continuer)
        C.res = type("R", (), {"n": 2, "system": ks, "anchor_rows": lambda self, lam: None})()
        C.S, C.Rs = S, Rs
        C.scaled_anchor = lambda lam: None
        C.__dict__.update(_corrector_obj=shoot_mod.Corrector(ks.engine, 2, tol=1e-8, max_iter=5), _flow=None,
                          _n_anchor=0)
        ev = Evaluation(out.R, segment_jacobian([M]), out.f_lambda, monodromy=M)
        assert np.max(np.abs(C.tangent(ev, t_ref, float(out.z[-1])) - t_np)) < 1e-13
        assert np.max(np.abs(Js @ t_np)) < 1e-12 * np.abs(Js).max() and t_np @ t_ref > 0


def test_branch_points_from_c_samples_equal_the_python_points(ks, monkeypatch):
    """A branch point built from the corrector's C samples carries what make_node computes from
    the problem's own dense output (extrema, surface extrema, mesh deflection extrema, rattle
    state) for the same orbit."""
    br_c = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)
    orig = corrector_mod.Continuer.correct

    def without_samples(self, *args, **kwargs):
        z, ev, it = orig(self, *args, **kwargs)
        ev.samples = None
        return z, ev, it

    monkeypatch.setattr(corrector_mod.Continuer, "correct", without_samples)
    br_py = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)
    assert len(br_c.points) == len(br_py.points) > 10
    for a, b in zip(br_c.points, br_py.points, strict=True):
        assert a.value == b.value and np.array_equal(a.x0, b.x0)
        assert a.max == b.max and a.min == b.min and a.rattle_state == b.rattle_state
        assert a.surface_extrema == b.surface_extrema and a.meshes == b.meshes
    assert {p.rattle_state for p in br_c.points} >= {0, 1}  # both sides of the contact-loss boundary


def test_wrong_sizes_are_refused_before_c_reads_them(ks):
    """Arrays of the wrong length never reach the C iteration (they would be read out of bounds)."""
    from gearsym.engine.errors import EngineInputError
    from gearsym.engine.shoot import correct_in_c

    p = ks.param_vector()
    T = ks.period()
    kw = _shoot_settings(T)
    with pytest.raises(EngineInputError, match="X0 of 1 x 2 states"):
        shoot_in_c(ks.engine, np.zeros(3), p, np.array([0.0, T]), **kw)
    with pytest.raises(EngineInputError, match="p of"):
        shoot_in_c(ks.engine, np.zeros(2), p[:-1], np.array([0.0, T]), **kw)
    with pytest.raises(EngineInputError, match="segment times"):
        shoot_in_c(ks.engine, np.zeros(2), p, np.array([T]), **kw)
    ckw = dict(tol=1e-9, max_iter=5, **_flow_kw(ks, "Omega", 0.9))
    with pytest.raises(EngineInputError, match="row has 2 entries"):
        correct_in_c(ks.derivative_engine(), np.zeros(3), np.zeros(2), 0.0, np.ones(3), np.ones(2), **ckw)
    with pytest.raises(EngineInputError, match="Rs has 3 entries"):
        correct_in_c(ks.derivative_engine(), np.zeros(3), np.zeros(3), 0.0, np.ones(3), np.ones(3), **ckw)
    with pytest.raises(EngineInputError, match="p0 and D need"):
        correct_in_c(ks.derivative_engine(), np.zeros(3), np.zeros(3), 0.0, np.ones(3), np.ones(2),
                     **dict(ckw, D=np.zeros(2)))


def test_reused_corrector_outcomes_do_not_share_its_buffers(ks):
    """A Corrector reuses its ctypes structs and buffers across calls: an outcome must keep its
    own arrays (equal to a fresh corrector's for the same point) after later calls."""
    from gearsym.engine.shoot import Corrector, CorrectorFlow, correct_in_c

    fkw = _flow_kw(ks, "Omega", 0.9, n_samples=65)
    S, Rs, row = np.ones(3), np.ones(2), np.array([0.0, 0.0, 1.0])
    eng = ks.derivative_engine()
    corr = Corrector(eng, 2, tol=1e-8, max_iter=8, flow=CorrectorFlow(engine=eng, segments=1, nd=2, **fkw))
    o = ks.periodic_orbit(params={"Omega": 0.9})
    first = corr(np.concatenate([o.x0, [0.9]]), row, 0.9, S, Rs, t_ref=row)
    kept = {k: np.array(getattr(first, k), copy=True) for k in ("z", "R", "F_u", "f_lambda", "tangent")}
    kept["y"], kept["ev_t"], kept["M"] = first.samples.y.copy(), first.events.t.copy(), first.monodromies[0].copy()
    o2 = ks.periodic_orbit(params={"Omega": 0.95})
    second = corr(np.concatenate([o2.x0, [0.95]]), row, 0.95, S, Rs, t_ref=row)
    assert first.converged and second.converged and abs(second.z[-1] - 0.95) < 1e-12
    assert not np.allclose(second.samples.y, kept["y"])  # a different orbit went through the buffers
    for k in ("z", "R", "F_u", "f_lambda", "tangent"):
        assert np.array_equal(getattr(first, k), kept[k]), k
    assert np.array_equal(first.samples.y, kept["y"]) and np.array_equal(first.events.t, kept["ev_t"])
    assert np.array_equal(first.monodromies[0], kept["M"])
    fresh = correct_in_c(eng, np.concatenate([o.x0, [0.9]]), row, 0.9, S, Rs, t_ref=row, tol=1e-8, max_iter=8,
                         **fkw)
    assert np.array_equal(fresh.z, first.z) and np.array_equal(fresh.samples.y, first.samples.y)
    assert np.array_equal(fresh.tangent, first.tangent) and fresh.period == first.period


@pytest.mark.parametrize("scene, param", [("kahraman_singh", "Omega"), ("yu_constant_backlash", "Omega")])
def test_corrector_multipliers_in_c_are_the_stability_rule_s(scene, param):
    """The multipliers and tolerances the corrector computes in C (scipy's LAPACK through
    cython_lapack) are multiplier_tolerances' for the same monodromy: the 2-state benchmark
    and the 10-state six-degree-of-freedom pair (complex pairs, unequal state units)."""
    from gearsym.analysis.periodic import floquet, multiplier_tolerances, verdict
    from gearsym.engine.shoot import correct_in_c, lapack_pointers

    assert set(lapack_pointers()) == {"dgebal", "dgesdd", "dgeev", "dgelsd", "dgetrf", "dgetrs"}
    s = gearsym.load_scene(ROOT / "scenes" / f"{scene}.toml").compile()
    o = s.periodic_orbit()
    nx, lam = s.generated.nx, float(s.params[param])
    row = np.zeros(nx + 1)
    row[-1] = 1.0
    out = correct_in_c(s.derivative_engine(), np.concatenate([o.x0, [lam]]), row, lam, np.ones(nx + 1), np.ones(nx),
                       tol=1e-6, max_iter=5, **_flow_kw(s, param, lam, method=METHODS["bdf"]))
    assert out.converged and out.multipliers is not None
    M = out.monodromies[0]
    mu, tol, delta = out.multipliers
    mu_py, tol_py, delta_py = multiplier_tolerances(M, 1e-10)
    assert np.sum(np.abs(mu.imag) > 0) >= 2  # complex pairs: the pair branch of the condition numbers
    assert np.allclose(mu, mu_py, rtol=1e-13, atol=1e-15) and np.allclose(tol, tol_py, rtol=1e-12, atol=0)
    assert delta == pytest.approx(delta_py, rel=1e-13)
    a, b = verdict(mu, tol, delta), floquet(M, 1e-10)
    assert a.stability == b.stability and a.n_unstable == b.n_unstable and np.allclose(a.multipliers, b.multipliers)


@pytest.mark.parametrize("scene", ["kahraman_singh", "yu_constant_backlash"])
def test_shooting_multipliers_in_c_are_the_stability_rule_s(scene, monkeypatch):
    """The orbit solve's multipliers come from its C call (scipy's LAPACK): the same numbers as
    multiplier_tolerances of the orbit's monodromy, and the orbit's verdict is floquet's; on the
    benchmark and the 10-state pair."""
    from gearsym.analysis.periodic import floquet, isolation, multiplier_tolerances

    s = gearsym.load_scene(ROOT / "scenes" / f"{scene}.toml").compile()
    seen = []
    orig = shoot_mod.Shooter._outcome

    def spy(self, *a, **k):
        out = orig(self, *a, **k)
        seen.append(out)
        return out

    monkeypatch.setattr(shoot_mod.Shooter, "_outcome", spy)
    o = s.periodic_orbit()
    assert seen and seen[-1].converged and seen[-1].multipliers is not None
    mu, tol, delta = seen[-1].multipliers
    mu_py, tol_py, _ = multiplier_tolerances(o.monodromy, o.info["rtol"])
    assert np.allclose(mu, mu_py, rtol=1e-13, atol=1e-15) and np.allclose(tol, tol_py, rtol=1e-12, atol=0)
    ref = floquet(o.monodromy, o.info["rtol"])
    assert o.stability == ref.stability and np.allclose(o.multipliers, ref.multipliers, rtol=1e-13, atol=1e-15)
    assert np.allclose(o.multiplier_tolerances, ref.tolerances, rtol=1e-12, atol=0)
    # the isolation verdict from the same call: isolation()'s numbers in the orbit's scales
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


@pytest.mark.parametrize("mirror, struct", [("GsNewton", "gs_newton"), ("GsOrbitFlow", "gs_orbit_flow"),
                                            ("GsCorrectorFlow", "gs_corrector_flow")])
def test_newton_struct_mirrors_are_size_checked_at_load(ks, monkeypatch, mirror, struct):
    """The Newton iteration's structs grow with the driver: a ctypes mirror one field short of the
    C struct is refused when the engine loads (it would be read out of bounds)."""
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
