"""The two-stage gear train: rigid-body mode, reduction to deflections, trivial multipliers,
several meshes.

References: the kinematics of the gear train (the rigid-body mode is the ratio of the
tooth numbers); an event-located DOP853 integration of equations written by hand
(tests/_two_stage_reference.py); the same train reduced to its deflections (its
multipliers are the non-trivial multipliers of the free train).
"""

from __future__ import annotations

import importlib.util
import itertools
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from _corrector_spy import python_corrector_only, spy_on_c_corrector

import gearsym
from gearsym.analysis.periodic import mesh_deflections, rigid_state_basis

ROOT = Path(__file__).resolve().parents[1]
FREE = ROOT / "scenes" / "two_stage_train.toml"
REDUCED = ROOT / "scenes" / "two_stage_train_deflections.toml"
RPM = 2 * math.pi / 60

_spec = importlib.util.spec_from_file_location("two_stage_reference", ROOT / "tests" / "_two_stage_reference.py")
ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ref)


@pytest.fixture(scope="module")
def free():
    return gearsym.load_scene(FREE).compile()


@pytest.fixture(scope="module")
def reduced():
    return gearsym.load_scene(REDUCED).compile()


@pytest.fixture(scope="module")
def reduced_model():
    return gearsym.load_scene(REDUCED).model


@pytest.fixture(scope="module")
def reduced_orbit(reduced):
    return reduced.periodic_orbit()


def _to_free(model: ref.TwoStageTrain, x: np.ndarray, t: float = 0.0, th4: float = 0.0) -> np.ndarray:
    """A free-train state with the given deflections (x_mesh1, x_shaft, x_mesh2 and rates)."""
    rb1, rb2, rb3, rb4 = model.rb
    x1, xs, x2, v1, vs, v2 = x
    om = [model.w1, model.w2]
    e = [model.e[i] * math.cos(om[i] * t + model.phase[i]) for i in range(2)]
    ed = [-model.e[i] * om[i] * math.sin(om[i] * t + model.phase[i]) for i in range(2)]
    th3 = (x2 + e[1] + rb4 * th4) / rb3
    th2 = th3 + xs
    th1 = (x1 + e[0] + rb2 * th2) / rb1
    w3 = (v2 + ed[1]) / rb3
    w2 = w3 + vs
    w1 = (v1 + ed[0] + rb2 * w2) / rb1
    return np.array([th1, th2, th3, th4, w1, w2, w3, 0.0])


def test_model_files_differ_only_in_the_reduction():
    free = (ROOT / "models" / "two_stage_train.toml").read_text()
    red = (ROOT / "models" / "two_stage_train_deflections.toml").read_text()
    body = free[free.index("\n[model]\n"):free.rindex("\n[initial]")]
    rbody = red[red.index("\n[model]\n"):red.rindex("\n[reduction]")]
    assert rbody == body.replace('name = "two_stage_train"', 'name = "two_stage_train_deflections"').replace(
        'free: rigid-body mode kept"', 'reduced to its deflections"')
    assert tomllib.loads(red)["reduction"] == {"mode": "deflections"}


def test_rigid_body_mode_is_the_gear_train_kinematics(free):
    scene = gearsym.load_scene(FREE)
    modes = scene.model.rigid_body_modes
    z1, z2, z3, z4 = sp.symbols("z1 z2 z3 z4", real=True)
    assert len(modes) == 1
    want = {"th1": 1, "th2": z1 / z2, "th3": z1 / z2, "th4": z1 * z3 / (z2 * z4)}
    assert {str(k): v for k, v in modes[0].items()}.keys() == want.keys()
    for k, v in modes[0].items():
        assert sp.simplify(v - want[str(k)]) == 0
    # the generated Jacobian does not see it, in every contact mode of both meshes:
    # J [R; 0] = 0 and J [0; R] = [R; 0] (the Jordan block of the monodromy)
    V = rigid_state_basis(free)
    assert V.shape == (8, 2)
    assert np.allclose(V[:4, 0], [1, 0.5, 0.5, 0.25], rtol=1e-15)
    rng = np.random.default_rng(3)
    for sigma in itertools.product((-1.0, 1.0), repeat=4):
        x = rng.normal(size=8) * np.array([1e-3] * 4 + [1.0] * 4)
        J = free.jacobian(float(rng.uniform(0, 0.01)), x, sigma=sigma)
        scale = np.max(np.abs(J))
        assert np.max(np.abs(J @ V[:, 0])) <= 1e-15 * scale
        assert np.max(np.abs(J @ V[:, 1] - V[:, 0])) <= 1e-15 * scale


def test_reduced_model_is_closed_and_has_no_rigid_body_mode(reduced, reduced_model):
    model = reduced_model
    assert reduced.state_names == ["x_mesh1", "x_shaft", "x_mesh2", "v_mesh1", "v_shaft", "v_mesh2"]
    assert model.rigid_body_modes == []
    assert len(model.unreduced_rigid_body_modes) == 1
    assert rigid_state_basis(reduced) is None
    assert [str(q) for q in model.reduction_result.kept] == ["th4"]


def test_contact_events_of_both_meshes_match_the_event_located_reference(free, reduced):
    """One forcing period from a state that sends both meshes through drive and back contact."""
    model = ref.TwoStageTrain()
    x0 = np.array([0, 0, 0, 0, 0, 4.0, -6.0, 3.0])
    T = model.period
    assert free.period() == pytest.approx(T, rel=1e-15)
    t_out = np.linspace(0, T, 9)
    x_ref, events, y_ref = ref.reference_solution(model, x0, 0.0, T, t_eval=t_out)
    assert {s for _, s, _ in events} == set(ref.SURFACES)
    tr = free.simulate(t_end=T, x0=x0, rtol=1e-12, atol=1e-16, t_out=t_out)
    assert [(e.surface, e.direction) for e in tr.events] == [(s, d) for _, s, d in events]
    assert np.max(np.abs(np.array([e.t for e in tr.events]) - [t for t, _, _ in events])) < 1e-11 * T
    scale = np.max(np.abs(y_ref), axis=0)
    assert np.max(np.abs(tr.y - y_ref) / scale) < 1e-8
    # the reduced model: the same deflections from the same state
    d0 = [*model.deflections(0.0, x0)[0][:1], x0[1] - x0[2], model.deflections(0.0, x0)[0][1]]
    dd0 = [*model.deflections(0.0, x0)[1][:1], x0[5] - x0[6], model.deflections(0.0, x0)[1][1]]
    tr_r = reduced.simulate(t_end=T, x0=d0 + dd0, rtol=1e-12, atol=1e-16, t_out=t_out)
    assert [(e.surface, e.direction) for e in tr_r.events] == [(s, d) for _, s, d in events]
    d_ref = np.array([model.deflections(t, y)[0] for t, y in zip(t_out, y_ref)])
    assert np.max(np.abs(tr_r.y[:, [0, 2]] - d_ref)) < 1e-8 * np.max(np.abs(d_ref))
    # per-mesh deflections of the free train (gs_mesh) are the same quantity
    defl = mesh_deflections(free, t_out, tr.y)
    assert np.max(np.abs(np.column_stack([defl["mesh1"], defl["mesh2"]]) - d_ref)) < 1e-8 * np.max(np.abs(d_ref))


def test_free_train_multipliers_equal_the_reduced_train(free, reduced_orbit):
    """Issue 11 done-when: the same non-trivial multipliers to 1e-8, a verdict that is
    not 'unstable' where they are inside the circle, the Jordan pair reported apart."""
    model = ref.TwoStageTrain()
    od = reduced_orbit
    assert od.converged and len(od.trivial_multipliers) == 0
    of = free.periodic_orbit(x0=_to_free(model, od.x0))
    assert of.converged
    assert len(of.multipliers) == 6 and len(of.trivial_multipliers) == 2
    diff = np.abs(np.sort_complex(of.multipliers) - np.sort_complex(od.multipliers))
    assert np.max(diff) < 1e-8
    assert np.max(np.abs(of.multipliers)) < 1 - 1e-3
    assert of.stability == od.stability == "asymptotically_stable" and of.stable
    assert np.max(np.abs(of.trivial_multipliers - 1)) < 1e-5
    assert of.info["invariance_defect"] < 1e-9
    # a plain eigenvalue computation smears the Jordan pair (by the square root of its error)
    mu = np.linalg.eigvals(of.monodromy)
    pair = mu[np.argsort(np.abs(mu - 1))[:2]]
    assert np.max(np.abs(pair - 1)) > 1e-8


def test_orbit_per_mesh_results_against_the_reference(free, reduced_orbit):
    """Per-mesh rattle states and deflection extrema of an orbit, against the reference
    integration of one period from its x0."""
    model = ref.TwoStageTrain()
    of = free.periodic_orbit(x0=_to_free(model, reduced_orbit.x0))
    T = model.period
    t = np.linspace(0, T, 4097)
    x_end, events, Y = ref.reference_solution(model, of.x0, 0.0, T, t_eval=t)
    assert np.max(np.abs(x_end - of.x0) / np.maximum(np.abs(of.x0), 1e-6)) < 1e-6  # periodic
    d = np.array([model.deflections(tt, y)[0] for tt, y in zip(t, Y)])
    info = of.meshes()
    for i, name in enumerate(("mesh1", "mesh2")):
        assert info[name]["deflection_max"] == pytest.approx(d[:, i].max(), abs=2e-9)
        assert info[name]["deflection_min"] == pytest.approx(d[:, i].min(), abs=2e-9)
        lost = any(s == f"{name}.drive" for _, s, _ in events) or d[0, i] < model.b[i]
        back = any(s == f"{name}.back" for _, s, _ in events)
        want = 2 if back else (1 if lost else 0)
        assert of.rattle_states[name] == want == info[name]["rattle_state"]
    assert of.rattle_state == max(of.rattle_states.values())


def test_continuation_of_the_free_train_covers_the_speed_range(free):
    """Issue 11: 3400..3700 rpm used to stop after 15 points at 3400.0002 rpm (exit 0)."""
    br = gearsym.continuation(free, "n_in", 3400, 3700, progress=False, rtol=1e-9, ds_max=0.1)  # rpm, declared
    assert br.values.min() == pytest.approx(3400, rel=1e-12)
    assert br.values.max() == pytest.approx(3700, rel=1e-12)
    assert np.all(np.diff(br.values) > 0)
    assert all(p.stability == "asymptotically_stable" for p in br.points)
    assert all(len(p.trivial_multipliers) == 2 for p in br.points)
    assert {b.type for b in br.bifurcations} <= {"grazing"}
    # every mesh reported at every point; mesh 1 starts to lose contact inside the range
    assert all(set(p.meshes) == {"mesh1", "mesh2"} for p in br.points)
    rs1 = br.mesh_quantity("mesh1", "rattle_state")
    assert rs1[0] == 0 and rs1[-1] == 1
    graz = br.of_type("grazing")
    assert len(graz) == 1 and graz[0].info["surface"] == "mesh1.drive"
    assert graz[0].point.meshes["mesh1"]["min"] == pytest.approx(30e-6, abs=1e-10)


def test_free_train_corrector_in_c_is_the_anchored_python_corrector(free, monkeypatch):
    """Rigid-body modes: the corrector in C solves the anchored bordered systems by least squares
    (dgelsd, with the anchor rows of Continuer.scaled_anchor) as the Python corrector does
    (numpy's lstsq).  The same branch with either; every C point is an orbit of the free train."""
    calls = spy_on_c_corrector(monkeypatch)
    br_c = gearsym.continuation(free, "n_in", 3500, 3560, progress=False, rtol=1e-9, ds_max=0.1)
    assert len(calls) > 5 and sum(calls) >= 0.9 * len(calls)  # the C corrector did the work
    python_corrector_only(monkeypatch)
    br_py = gearsym.continuation(free, "n_in", 3500, 3560, progress=False, rtol=1e-9, ds_max=0.1)
    graz = [(b.type, b.info.get("surface")) for b in br_c.bifurcations]
    assert graz == [(b.type, b.info.get("surface")) for b in br_py.bifurcations] == [("grazing", "mesh1.drive")]
    assert br_c.bifurcations[0].value == pytest.approx(br_py.bifurcations[0].value, rel=1e-9)
    assert [p.stability for p in br_c.points] == [p.stability for p in br_py.points]
    assert all(len(p.trivial_multipliers) == 2 for p in br_c.points)
    scale = np.max(np.abs(br_c.points[0].x0))
    for p in br_c.points[::3]:
        o = free.periodic_orbit(x0=p.x0, params={"n_in": p.value}, transient=0)  # anchored shooting
        assert np.max(np.abs(o.x0 - p.x0)) <= 1e-8 * scale


def test_cli_reports_rigid_modes_trivial_multipliers_and_meshes(capsys, tmp_path, reduced_model):
    from gearsym.cli import main
    from gearsym.inspection import inspect_structure

    assert main(["inspect", str(ROOT / "models" / "two_stage_train.toml"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["rigid_body_modes"] == [{"th1": "1", "th2": "z1/z2", "th3": "z1/z2", "th4": "z1*z3/(z2*z4)"}]
    assert info["meshes"] == ["mesh1", "mesh2"]
    info = json.loads(json.dumps(inspect_structure(reduced_model)))  # what inspect --json adds
    assert info["rigid_body_modes"] == []
    assert [c["name"] for c in info["reduction"]["coordinates"]] == ["x_mesh1", "x_shaft", "x_mesh2"]
    assert info["reduction"]["rigid_coordinates_left_out"] == ["th4"]
    out = tmp_path / "sim"
    assert main(["simulate", str(FREE), "--periods", "6", "--json", "--out", str(out)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert set(info["meshes"]) == {"mesh1", "mesh2"}
    assert all(m["rattle_state"] in (0, 1, 2) for m in info["meshes"].values())
    assert (out / "mesh_deflections.png").exists()
