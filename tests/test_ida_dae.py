"""IDA for real: a shipped DAE scene (scenes/spur_pair_coupled_load.toml, the coupling's reaction
torque an algebraic variable) against CVODE on its explicit reduction, written independently by
hand (tests/data/spur_pair_lumped_load.toml: the load inertia lumped into the gear, hand-written
equations, no mesh element).  References: the lumped model's trajectory and events at tight
tolerance, the reaction torque J_L*w2' + T_L computed from the lumped model's right-hand side,
and its Floquet multipliers from CVODE's variational equations."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.errors import ParameterError, SpecError
from gearsym.spec.model import parse_model

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "spur_pair_coupled_load.toml"
MODEL = ROOT / "models" / "spur_pair_coupled_load.toml"
LUMPED = Path(__file__).resolve().parent / "data" / "spur_pair_lumped_load_scene.toml"
PERIODS = 60


@pytest.fixture(scope="module")
def pair():
    dae = gearsym.load_scene(SCENE).compile()
    ode = gearsym.load_scene(LUMPED).compile()
    return dae, ode


@pytest.fixture(scope="module")
def runs(pair):
    dae, ode = pair
    tr = dae.simulate(periods=PERIODS)  # the scene's defaults: IDA, rtol 1e-8
    ref = ode.simulate(periods=PERIODS, rtol=1e-12, atol=1e-16, method="bdf", t_out=tr.t)
    return tr, ref


def reaction_torque(ode, ref) -> np.ndarray:
    """tau_c = J_L*w2' + T_L from the explicit reduction (the load's equation of motion)."""
    acc = ode.engine.evaluate("rhs", ref.t, ref.y, ode.param_vector())[:, 3]
    return ode.params["J_L"] * acc + ode.params["T_L"]


def test_scene_is_a_dae_on_ida_by_default(pair, runs):
    dae, _ = pair
    tr, _ = runs
    assert dae.generated.implicit and dae.generated.algebraic == ["tau_c"]
    assert dae.state_names == ["th1", "th2", "w1", "w2", "tau_c"] and dae.differential_states == 4
    assert dae.defaults["method"] == "ida"
    assert tr.stats["n_steps"] > 0 and tr.stats["n_reinit"] == len(tr.events)
    with pytest.raises(ParameterError, match="ida"):
        dae.simulate(periods=1, method="bdf")
    from gearsym.inspection import inspect_structure

    info = inspect_structure(gearsym.load_scene(SCENE).model)
    assert info["algebraic"] == [{"name": "tau_c", "unit": "N*m", "constraint": "coupling", "ties": "th_L = th2",
                                  "meaning": info["algebraic"][0]["meaning"]}]


def test_ida_matches_cvode_on_the_explicit_reduction(runs):
    tr, ref = runs
    # contact loss and re-contact every mesh period, the same events at the same times
    assert len(tr.events) == len(ref.events) >= 2 * PERIODS - 2
    # (the hand-written model's surfaces may be oriented the other way: g and -g)
    same = np.array([e.direction for e in tr.events]) * np.array([e.direction for e in ref.events])
    assert abs(same.sum()) == len(same)
    np.testing.assert_allclose([e.t for e in tr.events], [e.t for e in ref.events], rtol=0, atol=1e-9)
    scale = np.max(np.abs(ref.y), axis=0)
    err = np.max(np.abs(tr.y[:, :4] - ref.y), axis=0) / scale
    assert np.all(err < 1e-6), err  # rtol 1e-8 over 60 periods, 120 events (measured 2.5e-7)


def test_algebraic_variable_is_the_reaction_torque(pair, runs):
    _, ode = pair
    tr, ref = runs
    tau = reaction_torque(ode, ref)
    assert np.ptp(tau) > 10.0  # the reaction torque varies (N*m), contact loss included
    assert np.max(np.abs(tr.y[:, 4] - tau)) / np.max(np.abs(tau)) < 1e-6  # measured 1.9e-7
    out = pair[0].outputs(tr)["coupling_torque"]
    np.testing.assert_array_equal(out, tr.y[:, 4])


@pytest.mark.parametrize("guess", [0.0, -1.0e4])
def test_consistent_initial_conditions_from_an_inconsistent_guess(pair, guess):
    dae, ode = pair
    x0 = dae.x0.copy()
    assert x0[4] == 0.0  # the scene does not give tau_c
    x0[4] = guess
    T = dae.period()
    tr = dae.simulate(t_end=2 * T, x0=x0, rtol=1e-10, atol=1e-14, n_out=9)
    ref = ode.simulate(t_end=2 * T, x0=x0[:4], rtol=1e-12, atol=1e-16, method="bdf", t_out=tr.t)
    tau = reaction_torque(ode, ref)
    assert abs(tr.y[0, 4] - tau[0]) < 1e-8 * abs(tau[0])  # reported at t0: the consistent value
    assert np.max(np.abs(tr.y[:, 4] - tau)) < 1e-6 * np.max(np.abs(tau))
    assert tr.y[0, 4] != guess


def test_floquet_multipliers_ida_vs_cvode(pair):
    dae, ode = pair
    oi = dae.periodic_orbit(transient=40, rtol=1e-11, atol=1e-14)
    oc = ode.periodic_orbit(transient=40, rtol=1e-11, atol=1e-14)
    assert oi.converged and oc.converged and len(oi.events) == len(oc.events) == 2
    np.testing.assert_allclose(oi.x0[:4], oc.x0, rtol=1e-7, atol=1e-12)
    assert oi.monodromy.shape == (5, 5) and np.all(oi.monodromy[:, 4] == 0.0)
    mi = np.sort_complex(oi.multipliers)
    mc = np.sort_complex(oc.multipliers)
    assert len(mi) == len(mc) == 4  # over the differential states: no multiplier for tau_c
    assert np.max(np.abs(mi - mc)) < 1e-8, (mi, mc)  # measured 3e-11
    assert oi.stability == oc.stability == "asymptotically_stable"
    # the DAE's monodromy is the explicit reduction's, entry by entry
    np.testing.assert_allclose(oi.monodromy[:4, :4], oc.monodromy, rtol=0,
                               atol=1e-6 * np.max(np.abs(oc.monodromy)))


def test_harmonic_balance_on_the_dae(pair, capsys):
    """Harmonic balance on the DAE (issue 26; it refused the model before, naming shooting): the
    coupling torque is solved for at every AFT sample, and the balance with 40 harmonics is the
    orbit of the hand-written explicit reduction's shooting to the series' truncation; the CLI
    runs it (exit 0)."""
    import json

    from gearsym.cli import main

    dae, ode = pair
    hb = dae.periodic_orbit(method="hbm", harmonics=40)
    ref = ode.periodic_orbit(transient=40, rtol=1e-11, atol=1e-14)
    assert hb.converged and hb.coefficients.shape == (81, 5)
    scale = np.max(np.abs(ref.trajectory().y), axis=0)
    assert np.max(np.abs(hb.x0[:4] - ref.x0) / scale) < 1e-5  # (measured 1.7e-6: 40 harmonics of a contact orbit)
    tau0 = ode.params["J_L"] * ode.engine.evaluate("rhs", [0.0], hb.x0[None, :4], ode.param_vector())[0, 3] + \
        ode.params["T_L"]
    assert abs(hb.x0[4] - tau0) < 1e-9 * abs(tau0)  # x(t0)'s tau_c: consistent with its differential states
    assert main(["orbit", str(SCENE), "--method", "hbm", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["method"] == "hbm"


# ------------------------------------------------------------------ bad input

def _model(edit) -> dict:
    data = tomllib.loads(MODEL.read_text())
    edit(data)
    return data


def _expect(edit, field: str, *words: str) -> None:
    with pytest.raises(SpecError) as info:
        parse_model(_model(edit), str(MODEL))
    msg = str(info.value)
    assert f"'{field}'" in msg and str(MODEL) in msg, msg
    for w in words:
        assert w in msg, msg


def test_algebraic_variable_without_constraint():
    def edit(d):
        d["algebraic"]["tau_x"] = {"unit": "N*m"}
    _expect(edit, "algebraic.tau_x", "tau_x", "not the multiplier")


def test_constraint_with_unknown_names():
    _expect(lambda d: d["constraints"]["coupling"].update(equals="th3"), "constraints.coupling.equals",
            "th3")
    _expect(lambda d: d["constraints"]["coupling"].update(coordinate="th9"),
            "constraints.coupling.coordinate", "th9")
    _expect(lambda d: d["constraints"]["coupling"].update(multiplier="tau_q"),
            "constraints.coupling.multiplier", "tau_q")
    _expect(lambda d: d["constraints"]["coupling"].update(equals="w2"), "constraints.coupling.equals", "w2")


def test_constraint_misuse():
    _expect(lambda d: d["model"].update(form="explicit"), "constraints.coupling", "implicit")
    _expect(lambda d: d["constraints"]["coupling"].update(equals="rb2*th2"), "constraints.coupling.equals",
            "unit mismatch")
    def wrong_unit(d):
        d["algebraic"]["tau_c"]["unit"] = "N"
        del d["outputs"]["coupling_torque"]
    _expect(wrong_unit, "algebraic.tau_c.unit", "unit mismatch")
    _expect(lambda d: d["elements"]["load"].update(value="-T_L - tau_c"), "elements.load.value",
            "tau_c", "only in [outputs]")
    _expect(lambda d: d["constraints"]["coupling"].update(stiffness="k_s"), "constraints.coupling.stiffness",
            "unknown field")


def test_flow_on_ida_with_scaled_variational_tolerances(pair):
    """System.flow (the orbit solvers' path) on the DAE: per-state atol with the variational
    entries scaled by the differential states' magnitudes, against central differences."""
    dae, _ = pair
    T = dae.period()
    x0 = dae.simulate(periods=30, rtol=1e-10, atol=1e-14).x_final
    scales = np.abs(x0) + 1e-3
    f = dae.flow(x0, 0.0, T, rtol=1e-10, atol=np.full(5, 1e-14), scales=scales)
    assert f.monodromy.shape == (5, 5) and np.all(f.monodromy[:, 4] == 0.0)
    for j in range(4):
        h = 1e-6 * scales[j]
        e = np.zeros(5)
        e[j] = h
        xp = dae.flow(x0 + e, 0.0, T, rtol=1e-12, atol=1e-16, monodromy=False).x_final
        xm = dae.flow(x0 - e, 0.0, T, rtol=1e-12, atol=1e-16, monodromy=False).x_final
        col = (xp - xm) / (2 * h)
        # error of d x_i / d x0_j relative to scales_i / scales_j (measured <= 1.4e-5, tau_c's row included)
        assert np.max(np.abs(f.monodromy[:, j] - col) * scales[j] / scales) < 1e-4, j


RATIO_MODEL = """
[model]
name = "ratio_constraint"
form = "implicit"
[coordinates.qa]
unit = "rad"
velocity = "wa"
[coordinates.qb]
unit = "rad"
velocity = "wb"
[parameters]
Ja = { value = 0.3, unit = "kg*m^2" }
Jb = { value = 0.7, unit = "kg*m^2" }
k = { value = 40.0, unit = "N*m/rad" }
r = { value = 2.5, unit = "1" }
A = { value = 0.2, unit = "rad" }
w = { value = 3.0, unit = "rad/s" }
Tb = { value = 1.5, unit = "N*m" }
cb = { value = 0.4, unit = "N*m*s/rad" }
[algebraic]
lam = { unit = "N*m" }
[constraints.ratio]
coordinate = "qb"
equals = "r*qa + A*sin(w*t)"
multiplier = "lam"
[elements.a]
type = "inertia"
coordinate = "qa"
value = "Ja"
[elements.b]
type = "inertia"
coordinate = "qb"
value = "Jb"
[elements.spring]
type = "spring"
deflection = "qa"
stiffness = "k"
[elements.load]
type = "force"
coordinate = "qb"
value = "-Tb - cb*wb"
[initial]
qa = 0.1
"""


def test_time_dependent_ratio_constraint_vs_scipy(tmp_path, monkeypatch):
    """A constraint q_b = r*q_a + A*sin(w*t) (a ratio plus a prescribed motion) with a
    velocity-dependent force on the tied coordinate, against the reduced ODE derived by hand
    and integrated by scipy:  (Ja + r^2 Jb) qa'' = -k qa - r (Tb + cb qb' - Jb A w^2 sin(w t)),
    qb' = r qa' + A w cos(w t), and the reaction lam = Jb qb'' + Tb + cb qb'."""
    from scipy.integrate import solve_ivp

    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path / "gen"))
    (tmp_path / "m.toml").write_text(RATIO_MODEL)
    (tmp_path / "s.toml").write_text('[scene]\nname = "ratio"\nmodel = "m.toml"\n[simulate]\nt_end = 5.0\n')
    sysm = gearsym.load_scene(tmp_path / "s.toml").compile()
    Ja, Jb, k, r, A, w, Tb, cb = (sysm.params[n] for n in ("Ja", "Jb", "k", "r", "A", "w", "Tb", "cb"))
    tr = sysm.simulate(t_end=5.0, n_out=201, rtol=1e-10, atol=1e-12)

    def f(t, y):
        qa, wa = y
        wb = r * wa + A * w * np.cos(w * t)
        return [wa, (-k * qa - r * (Tb + cb * wb - Jb * A * w**2 * np.sin(w * t))) / (Ja + r**2 * Jb)]

    ref = solve_ivp(f, (0.0, 5.0), [0.1, 0.0], t_eval=tr.t, rtol=1e-12, atol=1e-14, method="DOP853")
    assert np.max(np.abs(tr.y[:, :2].T - ref.y)) < 1e-7
    acc = np.array([f(t, y)[1] for t, y in zip(ref.t, ref.y.T)])
    wb = r * ref.y[1] + A * w * np.cos(w * ref.t)
    lam = Jb * (r * acc - A * w**2 * np.sin(w * ref.t)) + Tb + cb * wb
    assert np.max(np.abs(tr.y[:, 2] - lam)) < 1e-6 * np.max(np.abs(lam))


def test_cli_bad_constraint_exits_2_with_one_line(tmp_path):
    import os
    import subprocess
    import sys

    text = MODEL.read_text().replace('equals = "th2"', 'equals = "th2 + th_unknown"')
    (tmp_path / "bad.toml").write_text(text)
    env = dict(os.environ, GEARSYM_GENERATED=str(tmp_path / "gen"))
    res = subprocess.run([sys.executable, "-m", "gearsym", "inspect", str(tmp_path / "bad.toml")],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert res.returncode == 2 and res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "constraints.coupling.equals" in lines[0] and "th_unknown" in lines[0], lines


def test_static_start_is_refused_with_algebraic_variables(tmp_path, monkeypatch):
    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path / "gen"))
    scene = tmp_path / "s.toml"
    scene.write_text(f'[scene]\nname = "static_dae"\nmodel = "{MODEL}"\n[initial]\nstatic = true\n')
    with pytest.raises(SpecError, match="initial.static"):
        gearsym.load_scene(scene).compile()
    assert not (tmp_path / "gen").exists() or not any((tmp_path / "gen").iterdir())  # refused before building
