"""Exact parameter sensitivities against central finite differences at tight tolerance.

The reference is an independent computation: central differences of the state at the
end of separate integrations (rtol 1e-11 or tighter) at ``p +- h`` and ``p +- h/2``,
Richardson-extrapolated (error ``O(h^4)`` plus the integration noise over ``h``).  The
cases:

* a smooth one (the spur pair in a regime without contact loss: no events), for a
  stiffness, a damping and the forcing frequency;
* a rattling one (the dimensional spur pair, contact loss and re-contact inside the
  interval): the half backlash moves every event time, the forcing frequency moves
  them and the period of the period map ``x0 -> phi(T(omega), x0)`` (whose derivative
  needs ``f dT/domega``);
* scheduled breakpoints (Meissner's rectangular stiffness): the duty and the period move
  the times where the vector field jumps;
* ``F_lambda`` of the continuation residual (multiple shooting, segment times following
  the period) against a central difference of the residual, and the fold location of a
  shipped scene unchanged against the finite-difference ``F_lambda``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def spur():
    return gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml").compile()


@pytest.fixture(scope="module")
def meissner():
    return gearsym.load_scene(ROOT / "scenes" / "meissner.toml").compile()


def richardson(fun, v, rel=1e-3):
    """Central difference of ``fun`` at ``v`` with steps ``h`` and ``h/2``, extrapolated."""
    h = rel * abs(v)
    d1 = (fun(v + h) - fun(v - h)) / (2 * h)
    d2 = (fun(v + h / 2) - fun(v - h / 2)) / h
    return (4 * d2 - d1) / 3


def rel_err(got, ref):
    """Largest error per state, relative to the state's largest reference entry."""
    got, ref = np.atleast_2d(got), np.atleast_2d(ref)
    return float(np.max(np.abs(got - ref) / np.max(np.abs(ref), axis=0)))


# ------------------------------------------------------------------ smooth (no events)
@pytest.mark.parametrize("name", ["k_m", "c_m", "omega"])
def test_smooth_sensitivities_match_central_differences(spur, name):
    params = {"e_a": 0.2, "T1": 120.0, "T2": 150.0}  # small error (um), high load: never loses contact
    kw = dict(t_end=3e-3, atol=1e-17, method="bdf", n_out=7)
    tr = spur.simulate(params=params, sensitivities=[name], rtol=1e-11, **kw)
    assert not tr.events
    ref = richardson(lambda v: spur.simulate(params={**params, name: v}, rtol=1e-13, **kw).y, spur.params[name])
    assert tr.sensitivities[name].shape == tr.y.shape
    assert rel_err(tr.sensitivities[name][1:], ref[1:]) < 1e-6


# ------------------------------------------------------------------ contact loss (events)
@pytest.mark.parametrize("name", ["b_m", "omega", "T1"])
def test_sensitivities_across_contact_events(spur, name):
    kw = dict(t_end=2.2e-3, atol=1e-17, method="bdf", n_out=5)
    tr = spur.simulate(sensitivities=[name], rtol=1e-11, **kw)
    assert len(tr.events) >= 6  # contact loss and back-side / drive-side re-contact inside the interval
    ref = richardson(lambda v: spur.simulate(params={name: v}, rtol=1e-13, **kw).y, spur.params[name])
    assert rel_err(tr.sensitivities[name][1:], ref[1:]) < 2e-6


@pytest.mark.parametrize("name", ["b", "Omega", "zeta"])
def test_sensitivities_across_events_where_the_vector_field_jumps(name):
    """The benchmark oscillator with damping only in contact: the vector field jumps by
    ``2 zeta x'`` at every contact event, so the sensitivities jump there by the event-time
    term ``(f- - f+) d tau/dp`` (``d tau/dp`` involves ``dg/dp``: the backlash ``b`` moves the
    surfaces themselves).  (The dimensional spur pair's force is continuous at contact loss:
    there the term vanishes.)"""
    ks = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", effects={"contact_damping": True}).compile()
    kw = dict(t_end=8.3 * ks.period(), atol=1e-14, method="bdf", n_out=5)
    tr = ks.simulate(sensitivities=[name], rtol=1e-11, **kw)
    assert len(tr.events) >= 4
    ref = richardson(lambda v: ks.simulate(params={name: v}, rtol=1e-13, **kw).y, ks.params[name], 1e-4)
    assert rel_err(tr.sensitivities[name][1:], ref[1:]) < 1e-6


def test_period_map_sensitivity_includes_the_moving_period(spur):
    """d/domega of phi(T(omega), x0; omega): the forcing frequency moves the events and the
    end time; the f * dT/domega term is part of the derivative."""
    x0 = spur.simulate(periods=5, rtol=1e-11, atol=1e-17, method="bdf").x_final
    p = spur.param_vector()
    k = spur.param_names.index("omega")

    def period_map(v):
        q = p.copy()
        q[k] = v
        return spur.flow(x0, 0.0, spur.period_of(q), q, rtol=1e-12, atol=1e-17, method="bdf").x_final

    dT = spur.period_gradient(["omega"], p)
    assert dT[0] == pytest.approx(-2 * np.pi / p[k] ** 2, rel=1e-12)
    fl = spur.flow(x0, 0.0, spur.period_of(p), p, rtol=1e-12, atol=1e-17, method="bdf", sensitivities=["omega"],
                   span_derivative=(0.0, dT))
    assert len(fl.event_t) >= 2
    ref = richardson(period_map, p[k])
    assert rel_err(fl.sensitivity[:, 0], ref) < 1e-6
    # with the monodromy in the same integration: the same two derivatives
    both = spur.flow(x0, 0.0, spur.period_of(p), p, rtol=1e-12, atol=1e-17, method="bdf", monodromy=True,
                     sensitivities=["omega"], span_derivative=(0.0, dT))
    alone = spur.flow(x0, 0.0, spur.period_of(p), p, rtol=1e-12, atol=1e-17, method="bdf", monodromy=True)
    np.testing.assert_allclose(both.monodromy, alone.monodromy, rtol=1e-7, atol=1e-9 * np.abs(alone.monodromy).max())
    assert rel_err(both.sensitivity[:, 0], ref) < 1e-6
    # at a fixed end time the derivative differs (by f dT/domega)
    fixed = spur.flow(x0, 0.0, spur.period_of(p), p, rtol=1e-12, atol=1e-17, method="bdf",
                      sensitivities=["omega"])
    assert rel_err(fixed.sensitivity[:, 0], ref) > 1e-2


# ------------------------------------------------------------------ breakpoints
@pytest.mark.parametrize("name", ["d", "T", "w0"])
def test_sensitivities_across_moving_breakpoints(meissner, name):
    kw = dict(t_end=11.3, rtol=1e-12, atol=1e-14, method="bdf", n_out=4)
    tr = meissner.simulate(sensitivities=[name], **kw)
    assert tr.stats["n_breaks"] >= 7
    ref = richardson(lambda v: meissner.simulate(params={name: v}, **kw).y, meissner.params[name])
    assert rel_err(tr.sensitivities[name][1:], ref[1:]) < 1e-6


def test_sensitivities_with_monodromy_and_dense_solver(meissner):
    """Monodromy and sensitivities in one integration, with either linear solver."""
    kw = dict(t_end=7.0, rtol=1e-12, atol=1e-14, method="bdf", n_out=2)
    a = meissner.simulate(sensitivities=["d", "T"], monodromy=True, **kw)
    b = meissner.simulate(sensitivities=["T", "d"], monodromy=True, linear_solver="dense", **kw)
    c = meissner.simulate(monodromy=True, **kw)
    np.testing.assert_allclose(a.monodromy, c.monodromy, rtol=1e-8, atol=1e-10)
    for name in ("d", "T"):
        np.testing.assert_allclose(a.sensitivities[name], b.sensitivities[name], rtol=1e-8, atol=1e-10)


def test_unknown_sensitivity_parameter(meissner):
    with pytest.raises(ParameterError, match="nope"):
        meissner.simulate(t_end=1.0, sensitivities=["nope"])


# ------------------------------------------------------------------ continuation
def test_exact_f_lambda_of_the_multiple_shooting_residual():
    """The exact F_lambda of a 2-segment shooting residual in the forcing frequency (the
    segment times move with the period) against a central difference at rtol 1e-13."""
    from gearsym.analysis.continuation._api import ShootingResidual
    from gearsym.analysis.periodic import exact_f_lambda

    ks = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    orb = ks.periodic_orbit(params={"Omega": 1.2}, rtol=1e-12, atol=1e-14, tol=1e-11)
    res = ShootingResidual(ks, "Omega", segments=2, rtol=1e-13, atol=1e-15)
    u = res.u_from_orbit(orb.x0, 1.2)
    assert len(res.evaluate(u, 1.2, jac=False).events) >= 2
    got = exact_f_lambda(res, u, 1.2)
    ref = richardson(lambda v: res.evaluate(u, v, jac=False).R, 1.2, 1e-4)
    assert np.max(np.abs(got - ref)) < 1e-6 * np.max(np.abs(ref))


def test_fold_location_unchanged_against_finite_difference_f_lambda():
    """A fold of the shipped benchmark scene located with the exact F_lambda agrees with the
    one located with the finite difference (the location itself only depends on F = 0 and
    the fold test function; F_lambda changes the path of the corrector)."""
    ks = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    kw = dict(progress=False, detect=["fold"])
    exact = [b.value for b in gearsym.continuation(ks, "Omega", 0.8, 0.95, **kw).of_type("fold")]
    fd = [b.value for b in gearsym.continuation(ks, "Omega", 0.8, 0.95, f_lambda="finite_difference",
                                                **kw).of_type("fold")]
    assert len(exact) == 2 and len(fd) == 2
    np.testing.assert_allclose(exact, fd, atol=1e-5)


def test_derivatives_are_a_separate_build_made_on_demand(spur):
    """The default build carries no parameter derivatives (their compile cost is paid only by
    users who ask for sensitivities); the first request makes or finds the second build, and
    compiling with ``derivatives=True`` gives a system whose own build has them."""
    assert "gs_jacp" not in spur.generated.functions and spur.has_derivatives
    eng = spur.derivative_engine()
    assert eng is not spur.engine and eng is spur.derivative_engine()
    both = gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml").compile(derivatives=True)
    assert "gs_jacp" in both.generated.functions and both.derivative_engine() is both.engine
    assert both.generated.so_path == str(eng.path) or Path(both.generated.so_path).resolve() == eng.path
    kw = dict(t_end=1e-3, rtol=1e-10, atol=1e-16, method="bdf", sensitivities=["b_m"])
    np.testing.assert_array_equal(spur.simulate(**kw).sensitivities["b_m"], both.simulate(**kw).sensitivities["b_m"])


def test_parameter_entering_through_a_bound_function():
    """Yu's fractal dimension D enters only through the numeric bound function
    wm_mean_height(D, ...) (the fractal backlash): its direction is that function's
    derivative (a central difference of the scalar function), everything after it exact.
    Also at an overridden value of D (the derivative is taken at the run's inputs)."""
    yu = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml").compile()
    assert "D" not in yu.param_names and "D" in yu.params
    kw = dict(t_end=0.7 * yu.period(), atol=1e-14, method="bdf", n_out=3)
    for ov in ({}, {"D": 1.45}):
        tr = yu.simulate(sensitivities=["D"], rtol=1e-11, params=ov, **kw)
        assert tr.events
        ref = richardson(lambda v, ov=ov: yu.simulate(params={**ov, "D": v}, rtol=1e-13, **kw).y,
                         ov.get("D", yu.params["D"]))
        assert rel_err(tr.sensitivities["D"][1:], ref[1:]) < 1e-5
