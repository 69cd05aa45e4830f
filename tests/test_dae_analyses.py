"""Every analysis on a DAE (IDA) equals the same analysis on its ODE twin (issue 26).

The DAE is the shipped ``scenes/spur_pair_coupled_load.toml``: a spur pair with backlash whose
gear drives a load through a rigid coupling, the coupling torque ``tau_c`` an algebraic variable,
integrated by IDA.  The reference is its ODE twin written by hand
(``tests/data/spur_pair_coupled_load_ode.toml``: the coupling eliminated, gear and load one
inertia ``J2 + J_L``, the load torque on the gear; CVODE), whose states are the DAE's
differential states in the same order (``th1, th2, w1, w2``) and whose switching surfaces have
the same names.  The DAE's ``tau_c`` is compared with ``J_L w2' + T_L`` of the twin (the load's
own equation of motion, ``w2'`` from the twin's right-hand side).

How the comparisons are made (all to 1e-7):

* parameter values (branch points, located points) relative to the value;
* states relative to each state's magnitude over the orbit (``th1`` and ``w1`` differ by four
  orders of magnitude; a state is compared with its own size);
* Floquet multipliers (of modulus about 1) absolutely;
* sensitivities relative to the largest entry of the twin's sensitivity of that parameter.
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis import stability_map

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "spur_pair_coupled_load.toml"
TWIN = Path(__file__).resolve().parent / "data" / "spur_pair_coupled_load_ode_scene.toml"
#: the continuation's range: a grazing (contact loss appears at 13823.6 rad/s), a fold at
#: 14069.8 rad/s, and back on the unstable branch to the start
LO, HI = 13800.0, 14100.0
TOL = 1e-7


@pytest.fixture(scope="module")
def pair():
    dae = gearsym.load_scene(SCENE).compile()
    ode = gearsym.load_scene(TWIN).compile()
    assert dae.generated.algebraic == ["tau_c"] and dae.state_names[:4] == ode.state_names
    assert dae.surface_names == ode.surface_names
    return dae, ode


def twin_tau(ode, t, X, params=None) -> np.ndarray:
    """The coupling torque ``J_L w2' + T_L`` along the twin's states ``X`` (rows) at times ``t``."""
    p = ode.param_vector(params)
    acc = ode.engine.evaluate("rhs", np.atleast_1d(t), np.atleast_2d(X), p)[:, 3]
    pd = ode.param_dict(p)
    return pd["J_L"] * acc + pd["T_L"]


def orbit_scale(ode, x0, params=None) -> np.ndarray:
    """Every state's magnitude over one period of the twin's orbit through ``x0``."""
    tr = ode.simulate(t_end=ode.period(params), x0=x0, rtol=1e-10, atol=1e-14, n_out=129, params=params)
    return np.max(np.abs(tr.y), axis=0)


# ------------------------------------------------------------------ the model's vector field

def test_dae_evaluation_is_the_twins_vector_field(pair):
    """The engine's ``"dae"`` / ``"dae_jac"`` (the DAE as the ODE of its differential states, tau_c
    solved for) against the twin's right-hand side and Jacobian at states off any orbit."""
    dae, ode = pair
    rng = np.random.default_rng(3)
    x = dae.simulate(periods=5, rtol=1e-10, atol=1e-14).x_final
    X = x[None, :] * (1 + 0.3 * rng.standard_normal((6, 5)))
    X[:, 4] = 0.0  # tau_c is solved for: the value given is only the Newton start
    t = rng.uniform(0, dae.period(), 6)
    Y = dae.engine.evaluate("dae", t, X, dae.param_vector())
    f = ode.engine.evaluate("rhs", t, X[:, :4], ode.param_vector())
    J = ode.engine.evaluate("jac", t, X[:, :4], ode.param_vector())
    np.testing.assert_array_equal(Y[:, :4], X[:, :4])
    np.testing.assert_allclose(Y[:, 5:], f, rtol=1e-12, atol=1e-12 * np.max(np.abs(f)))
    np.testing.assert_allclose(Y[:, 4], twin_tau(ode, t, X[:, :4]), rtol=1e-12)
    Jd = dae.engine.evaluate("dae_jac", t, X, dae.param_vector())
    assert Jd.shape == (6, 5, 4)
    np.testing.assert_allclose(Jd[:, :4, :], J, rtol=1e-11, atol=1e-11 * np.max(np.abs(J)))
    np.testing.assert_allclose(Jd[:, 4, :], ode.params["J_L"] * J[:, 3, :], rtol=1e-11,
                               atol=1e-11 * np.max(np.abs(Jd[:, 4, :])))


# ------------------------------------------------------------------ sensitivities

NAMES = ["omega", "T_L", "b_m", "J_L"]


@pytest.fixture(scope="module")
def start(pair):
    dae, _ = pair
    return dae.simulate(periods=30, rtol=1e-10, atol=1e-14).x_final


def twin_tau_derivative(ode, t: float, x: np.ndarray, Sx: np.ndarray, name: str, dt: float = 0.0) -> float:
    """``d tau_c / d name`` of the twin's ``J_L w2'(t, x; p) + T_L`` along a solution whose state
    moves by ``Sx`` and whose time moves by ``dt`` per unit of ``name``: the state part through the
    twin's Jacobian, the explicit parameter and time dependence by central differences of the
    right-hand side (function evaluations only: accurate to ~1e-10)."""
    v = ode.params[name]
    h, ht = 1e-6 * abs(v), 1e-6 * ode.period()
    dp = (twin_tau(ode, t, x, {name: v + h})[0] - twin_tau(ode, t, x, {name: v - h})[0]) / (2 * h)
    J = ode.engine.evaluate("jac", [t], x[None, :], ode.param_vector())[0]
    dxt = (twin_tau(ode, t + ht, x)[0] - twin_tau(ode, t - ht, x)[0]) / (2 * ht)
    return float(dp + ode.params["J_L"] * J[3] @ Sx + dxt * dt)


def test_sensitivities_through_contact_events(pair, start):
    """IDA's forward sensitivities (event-time jumps at 6 contact events; an inertia parameter,
    whose residual derivative is an acceleration) against CVODE's on the twin, and the algebraic
    row against the derivative of the twin's ``J_L w2' + T_L`` along the twin's sensitivities."""
    dae, ode = pair
    T = dae.period()
    tr = dae.simulate(t_end=3 * T, x0=start, rtol=1e-10, atol=1e-14, n_out=4, sensitivities=NAMES)
    ref = ode.simulate(t_end=3 * T, x0=start[:4], rtol=1e-12, atol=1e-16, t_out=tr.t, sensitivities=NAMES,
                       method="bdf")
    assert len(tr.events) == len(ref.events) == 6
    for name in NAMES:
        S, R = tr.sensitivities[name][1:], ref.sensitivities[name][1:]
        err = np.max(np.abs(S[:, :4] - R)) / np.max(np.abs(R))
        assert err < TOL, (name, err)  # (measured <= 6e-10)
        for k in range(1, len(tr.t)):
            tau = twin_tau_derivative(ode, tr.t[k], ref.y[k], ref.sensitivities[name][k], name)
            assert abs(tr.sensitivities[name][k, 4] - tau) < TOL * max(abs(tau), 1e-300), (name, k)


def test_period_map_derivative_with_the_algebraic_rate(pair, start):
    """``flow(span_derivative=(0, dT/domega))``: the total derivative of ``x(T(omega); omega)``, whose
    algebraic row needs ``tau_c'`` at the end (from the time derivative of the residual along the
    solution, ``gs_rest``), against the twin's flow with the same span derivative."""
    dae, ode = pair
    T = dae.period()
    p = dae.param_vector()
    dT = float(dae.period_gradient(["omega"], p)[0])
    assert dT == pytest.approx(-T / ode.params["omega"], rel=1e-12)
    kw = {"rtol": 1e-11, "sensitivities": ["omega"]}
    fl = dae.flow(start, 0.0, T, p, atol=1e-15, span_derivative=([0.0], [dT]), **kw)
    fo = ode.flow(start[:4], 0.0, T, ode.param_vector(), atol=1e-16, span_derivative=([0.0], [dT]), **kw)
    S, R = fl.sensitivity[:, 0], fo.sensitivity[:, 0]
    assert np.max(np.abs(S[:4] - R)) < TOL * np.max(np.abs(R))
    tau = twin_tau_derivative(ode, T, fo.x_final, R, "omega", dt=dT)
    assert abs(S[4] - tau) < TOL * abs(tau), (S[4], tau)
    # the end time's term matters in that row: at the fixed end it is far off
    fixed = dae.flow(start, 0.0, T, p, atol=1e-15, **kw).sensitivity[4, 0]
    assert abs(fixed - tau) > 1e3 * TOL * abs(tau)


# ------------------------------------------------------------------ continuation

@pytest.fixture(scope="module")
def branches(pair):
    dae, ode = pair
    kw = {"ds_max": 0.05}
    return gearsym.continuation(dae, "omega", LO, HI, **kw), gearsym.continuation(ode, "omega", LO, HI, **kw)


def test_continuation_located_points_equal_the_twins(branches):
    bd, bo = branches
    assert bd.complete and bo.complete
    assert [b.type for b in bd.bifurcations] == [b.type for b in bo.bifurcations] == ["grazing", "fold"]
    for a, b in zip(bd.bifurcations, bo.bifurcations, strict=True):
        assert abs(a.value - b.value) < TOL * abs(b.value), (a.type, a.value, b.value)  # (measured 1.4e-9)
        scale = np.maximum(np.abs(b.point.x0), 1e-300)
        assert np.max(np.abs(a.point.x0[:4] - b.point.x0) / scale) < TOL, a.type
    # the multipliers at the fold (at the grazing point the monodromy jumps: the saltation matrix of
    # a crossing whose speed vanishes there, so they depend on the side each solve lands on)
    fold_d, fold_o = bd.bifurcations[1].point, bo.bifurcations[1].point
    assert np.max(np.abs(np.sort_complex(fold_d.multipliers) - np.sort_complex(fold_o.multipliers))) < TOL
    assert fold_d.stability == fold_o.stability
    # the branch turns at the fold and leaves through its start, both
    assert bd.stop_value == bo.stop_value == LO
    assert max(p.value for p in bd.points) == pytest.approx(max(p.value for p in bo.points), rel=TOL)


def test_every_dae_branch_point_is_an_orbit_of_the_twin(pair, branches):
    """Each point of the DAE's branch, taken to the twin: one period of the twin from its
    differential states closes to 1e-7 of every state's size, the twin's multipliers there are the
    point's, and its tau_c is the twin's reaction torque."""
    dae, ode = pair
    bd, _ = branches
    assert len(bd.points) > 20
    scale = orbit_scale(ode, bd.points[0].x0[:4], {"omega": bd.points[0].value})
    for pt in bd.points:
        params = {"omega": pt.value}
        x = pt.x0[:4]
        fl = ode.flow(x, 0.0, ode.period(params), ode.param_vector(params), rtol=1e-12, atol=1e-16)
        assert np.max(np.abs(fl.x_final - x) / scale) < TOL, pt.value
        if pt.bifurcation != "grazing":  # (there the monodromy jumps: see above)
            mu = np.linalg.eigvals(fl.monodromy)
            assert np.max(np.abs(np.sort_complex(mu) - np.sort_complex(pt.multipliers))) < TOL, pt.value
        tau = twin_tau(ode, 0.0, x, params)[0]
        assert abs(pt.x0[4] - tau) < TOL * abs(tau)


def test_continuation_of_the_dae_runs_in_c(branches):
    """The DAE's corrector is THE Newton iteration with its residuals evaluated in C (IDA with its
    sensitivities, the algebraic variables carried between segments), as the ODE twin's."""
    bd, bo = branches
    assert bd.info["corrector"] == bo.info["corrector"] == "C"


def test_harmonic_balance_continuation_fold_equals_the_twins(pair):
    """Continuation by harmonic balance (the algebraic variable's harmonics among the unknowns):
    the fold of the truncated balance is the twin's."""
    dae, ode = pair
    kw = {"method": "hbm", "harmonics": 8, "ds_max": 0.1}
    bd = gearsym.continuation(dae, "omega", 14000.0, 14100.0, **kw)
    bo = gearsym.continuation(ode, "omega", 14000.0, 14100.0, **kw)
    folds = [[b.value for b in br.bifurcations if b.type == "fold"] for br in (bd, bo)]
    assert len(folds[0]) == len(folds[1]) == 1
    assert abs(folds[0][0] - folds[1][0]) < TOL * folds[1][0], folds


# ------------------------------------------------------------------ maps

def test_map_equals_the_twins(pair):
    dae, ode = pair
    grid = (("omega", 13600.0, 14200.0, 3), ("e_a", 4.0, 6.0, 3))
    md = stability_map(dae, *grid, "peak_to_peak", workers=1)
    mo = stability_map(ode, *grid, "peak_to_peak", workers=1)
    assert md.attrs["n_failed"] == mo.attrs["n_failed"] == 0
    for v in ("rattle_state", "response", "stability"):
        np.testing.assert_array_equal(md[v].values, mo[v].values)
    assert set(md["rattle_state"].values.ravel()) == {0, 1}  # contact loss on part of the grid
    for v in ("max_multiplier", "peak_to_peak"):
        a, b = md[v].values, mo[v].values
        assert np.max(np.abs(a - b) / np.abs(b)) < TOL, v  # (measured 4e-12, 5e-10)


# ------------------------------------------------------------------ harmonic balance

def test_harmonic_balance_equals_the_twins(pair):
    """The same harmonics (grown automatically: the DAE's algebraic variable does not ask for
    more), the same coefficients of the differential states, and tau_c's series is that of the
    twin's reaction torque along the balanced orbit."""
    dae, ode = pair
    hd = dae.periodic_orbit(method="hbm")
    ho = ode.periodic_orbit(method="hbm")
    assert hd.converged and ho.converged and hd.harmonics == ho.harmonics
    Cd, Co = hd.coefficients, ho.coefficients
    assert np.max(np.abs(Cd[:, :4] - Co) / np.max(np.abs(Co), axis=0)) < TOL
    np.testing.assert_allclose(np.sort_complex(hd.multipliers), np.sort_complex(ho.multipliers), rtol=0, atol=TOL)
    # tau_c's coefficients: the DFT of J_L w2' + T_L sampled on the balance's own AFT grid
    M = hd.info["samples"]
    t = hd.period * np.arange(M) / M
    th = 2 * np.pi * np.arange(M) / M
    E = np.ones((M, Co.shape[0]))
    for k in range(1, hd.harmonics + 1):
        E[:, 2 * k - 1], E[:, 2 * k] = np.cos(k * th), np.sin(k * th)
    tau = twin_tau(ode, t, E @ Co)
    ref = np.linalg.lstsq(E, tau, rcond=None)[0]
    assert np.max(np.abs(Cd[:, 4] - ref)) < TOL * np.max(np.abs(ref))
    assert abs(hd.x0[4] - twin_tau(ode, 0.0, hd.x0[:4])[0]) < TOL * abs(hd.x0[4])


# ------------------------------------------------------------------ shooting and the CLI

def test_shooting_of_the_dae_runs_in_c(pair, caplog):
    """THE Newton iteration and the residual's integrations (IDA) in C: nothing to report at the
    info level (no fallback)."""
    dae, ode = pair
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        od = dae.periodic_orbit(transient=20)
    oo = ode.periodic_orbit(transient=20)
    assert od.info["newton"] == oo.info["newton"] == "C"
    assert od.to_dict(extrema=False)["newton"] == od.info["newton"]
    msgs = [r.getMessage() for r in caplog.records if r.name == "gearsym.analysis.periodic._shooting"]
    assert msgs == []
    x = od.x0[:4]  # the DAE's orbit is one of the twin's
    fl = ode.flow(x, 0.0, ode.period(), ode.param_vector(), rtol=1e-12, atol=1e-16)
    assert np.max(np.abs(fl.x_final - x) / orbit_scale(ode, x)) < TOL


def test_cli_continue_and_map_on_the_dae(tmp_path, capsys):
    from gearsym.cli import main

    rc = main(["continue", str(SCENE), "--param", "omega", "--from", "14000", "--to", "14100", "--ds-max", "0.2",
               "--json", "--no-progress", "--out", str(tmp_path / "c")])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    assert d["complete"] and [b["type"] for b in d["bifurcations"]] == ["fold"]
    assert d["state_names"][-1] == "tau_c" and len(d["points"][0]["x0"]) == 5
    assert d["corrector"] == "C"
    rc = main(["map", str(SCENE), "--x", "omega", "13600", "14200", "3", "--y", "e_a", "4", "6", "3",
               "--workers", "1", "--json", "--out", str(tmp_path / "m")])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    assert d["n_points"] == 9 and d["n_failed"] == 0 and math.isfinite(d["max"])


# ------------------------------------------------------------------ implicit form without algebraic variables

@pytest.fixture(scope="module")
def ks_pair(tmp_path_factory):
    """The benchmark oscillator (scenes/kahraman_singh.toml) in implicit (mass-matrix) form, on
    IDA, and as shipped (CVODE): the IDA paths of a model without algebraic variables."""
    d = tmp_path_factory.mktemp("ks_implicit")
    text = (ROOT / "models" / "kahraman_singh.toml").read_text()
    (d / "m.toml").write_text(text.replace('name = "kahraman_singh"', 'name = "ks_implicit"\nform = "implicit"', 1))
    scene = (ROOT / "scenes" / "kahraman_singh.toml").read_text()
    (d / "s.toml").write_text(scene.replace('model = "../models/kahraman_singh.toml"', 'model = "m.toml"'))
    imp = gearsym.load_scene(d / "s.toml").compile()
    exp = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    assert imp.generated.implicit and not imp.generated.algebraic and imp.state_names == exp.state_names
    return imp, exp


def test_implicit_form_sensitivities_continuation_and_balance(ks_pair, caplog):
    imp, exp = ks_pair
    T = exp.period()
    x0 = exp.simulate(periods=20).x_final
    names = ["zeta", "Fa", "eps", "Omega"]
    a = imp.simulate(t_end=3 * T, x0=x0, rtol=1e-10, atol=1e-12, n_out=3, sensitivities=names)
    b = exp.simulate(t_end=3 * T, x0=x0, rtol=1e-12, atol=1e-14, t_out=a.t, sensitivities=names, method="bdf")
    assert len(a.events) == len(b.events) == 6
    for n in names:
        err = np.max(np.abs(a.sensitivities[n] - b.sensitivities[n])) / np.max(np.abs(b.sensitivities[n]))
        assert err < TOL, (n, err)  # (measured <= 7e-9)
    kw = {"ds_max": 0.1}
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        bi = gearsym.continuation(imp, "Omega", 0.885, 0.9, **kw)
    msgs = [r.getMessage() for r in caplog.records if r.name == "gearsym.analysis.continuation._corrector"]
    assert bi.info["corrector"] == "C" and msgs == []  # IDA in the C evaluator: no fallback to report
    be = gearsym.continuation(exp, "Omega", 0.885, 0.9, **kw)
    assert [x.type for x in bi.bifurcations] == [x.type for x in be.bifurcations] == ["grazing", "fold"]
    for u, v in zip(bi.bifurcations, be.bifurcations, strict=True):
        assert abs(u.value - v.value) < TOL * v.value, (u.type, u.value, v.value)
    hi, he = (s.periodic_orbit(method="hbm", params={"Omega": 0.7}) for s in (imp, exp))
    assert hi.converged and he.converged and hi.harmonics == he.harmonics
    assert np.max(np.abs(hi.coefficients - he.coefficients)) < TOL * np.max(np.abs(he.coefficients))
