"""Malformed model and scene files through ``gearsym simulate|inspect|compile``: exit 2, a
one-line message naming the file and the field (or value), no traceback, nothing written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import gearsym

from ._helpers import DATA, KS_MODEL, KS_SCENE, SPUR_MODEL, Case, check_case, model, scene, sub

M = "m.toml"


def _sim(work: Path, text: str, extra: str = "", *more: str) -> list[str]:
    """simulate a scene over a modified KS model, with --out (which must not appear)."""
    model(work, text)
    s = scene(work, M, extra)
    return ["simulate", str(s), "--periods", "2", "--out", str(work / "out"), *more]


CASES = [
    Case("toml syntax error in the model (stored fixture)",
         lambda w: ["inspect", str(DATA / "broken_syntax_model.toml")],
         ["broken_syntax_model.toml", "TOML syntax error", "line 8"]),
    Case("toml syntax error in the scene (stored fixture)",
         lambda w: ["simulate", str(DATA / "broken_syntax_scene.toml"), "--out", str(w / "out")],
         ["broken_syntax_scene.toml", "TOML syntax error"]),
    Case("unknown symbol (stored fixture)",
         lambda w: ["simulate", str(DATA / "unknown_symbol_scene.toml"), "--out", str(w / "out")],
         ["unknown_symbol_model.toml", "elements.damper.coefficient", "unknown symbol 'cc'"]),
    Case("toml syntax error written in the working folder",
         lambda w: _sim(w, KS_MODEL + "\n[broken\n"), [M, "TOML syntax error"]),
    Case("unit mismatch",
         lambda w: _sim(w, sub(KS_MODEL, 'zeta  = { value = 0.05, meaning', 'zeta  = { value = 0.05, unit = "N", meaning')),
         [M, "elements.mesh.damping", "unit mismatch"]),
    Case("negative inertia in the model",
         lambda w: _sim(w, sub(KS_MODEL, 'value = "1"\n', 'value = "-1"\n')),
         [M, "elements.inertia.value", "inertia must be positive", "-1"]),
    Case("zero inertia through a derived quantity",
         lambda w: _sim(w, sub(KS_MODEL, "[effects.backlash]", '[derived]\nm0 = { value = "b - 1" }\n\n[effects.backlash]')
                        .replace('value = "1"\n', 'value = "m0"\n', 1)),
         [M, "elements.inertia.value", "inertia must be positive", "b = 1"]),
    Case("negative inertia from a scene parameter",
         lambda w: (model(w, SPUR_MODEL), ["compile", str(scene(w, M, "[parameters]\nJ2 = -4.0e-3\n"))])[1],
         [M, "elements.gear.value", "inertia must be positive", "J2 = -0.004"]),
    Case("NaN parameter value in the model",
         lambda w: _sim(w, sub(KS_MODEL, "eps   = { value = 0.2,", "eps   = { value = nan,")),
         [M, "parameters.eps.value", "non-finite"]),
    Case("NaN parameter value in the scene",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[parameters]\nOmega = nan\n"))])[1],
         ["s.toml", "parameters.Omega", "non-finite value nan"]),
    Case("infinite initial state in the scene",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[initial]\nx = inf\n"))])[1],
         ["s.toml", "initial.x", "inf"]),
    Case("circular derived definitions",
         lambda w: _sim(w, sub(KS_MODEL, "[effects.backlash]", '[derived]\na1 = "a2 + 1"\na2 = "2*a1"\n\n[effects.backlash]')),
         [M, "derived.a", "circular definition"]),
    Case("empty model",
         lambda w: _sim(w, ""), [M, "missing section [model]"]),
    Case("empty scene",
         lambda w: ["simulate", str(model(w, "", "s.toml"))], ["s.toml", "missing section [scene]"]),
    Case("model without coordinates' inertia",
         lambda w: _sim(w, re.sub(r"\[elements\.inertia\][^\[]*", "", KS_MODEL)),
         [M, "coordinates.x", "no inertia"]),
    Case("effect that does not exist (scene)",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[effects]\nfriction = true\n"))])[1],
         ["s.toml", "effects.friction", "effect 'friction' is not in model"]),
    Case("term tagged with an effect the model does not declare",
         lambda w: _sim(w, sub(KS_MODEL, 'effect = "backlash" }', 'effect = "backlasch" }')),
         [M, "elements.mesh.backlash", "backlasch"]),
    Case("unknown function",
         lambda w: _sim(w, sub(KS_MODEL, 'value = "1"\n', 'value = "foo(1)"\n')),
         [M, "elements.inertia.value", "unknown function 'foo'"]),
    Case("syntax error in an expression",
         lambda w: _sim(w, sub(KS_MODEL, 'value = "1"\n', 'value = "(1"\n')),
         [M, "elements.inertia.value", "syntax error"]),
    Case("unknown element type",
         lambda w: _sim(w, sub(KS_MODEL, 'type = "mesh"', 'type = "gearmesh"')),
         [M, "elements.mesh.type", "gearmesh"]),
    Case("unknown unit",
         lambda w: _sim(w, sub(KS_MODEL, 'zeta  = { value = 0.05, meaning', 'zeta  = { value = 0.05, unit = "furlong", meaning')),
         [M, "parameters.zeta.unit", "furlong"]),
    Case("argument of cos with a dimension",
         lambda w: (model(w, sub(SPUR_MODEL, 'expr = "k_a*cos(omega*t)"', 'expr = "k_a*cos(omega)"')),
                    ["compile", str(scene(w, M))])[1],
         [M, "elements.mesh.stiffness[1]", "must be dimensionless"]),
    Case("Python keyword as a parameter name",
         lambda w: _sim(w, sub(KS_MODEL, "eps   = { value", "lambda = { value")), [M, "parameters.lambda"]),
    Case("scene points to a missing model",
         lambda w: ["simulate", str(scene(w, "absent.toml"))], ["absent.toml", "model file not found"]),
    Case("scene points to a folder as its model",
         lambda w: (Path(w / "d.toml").mkdir(), ["simulate", str(scene(w, "d.toml"))])[1],
         ["d.toml", "cannot read model file"]),
    Case("binary file as a scene",
         lambda w: (Path(w / "bin.toml").write_bytes(bytes(range(200, 256)) * 4), ["simulate", str(w / "bin.toml")])[1],
         ["bin.toml", "not a text (UTF-8) file"]),
    Case("unknown section in a scene",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[simulat]\nperiods = 3\n"))])[1],
         ["s.toml", "unknown section 'simulat'"]),
    Case("wrong type of a scene parameter",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, '[parameters]\nOmega = "fast"\n'))])[1],
         ["s.toml", "parameters.Omega", "wrong type"]),
    Case("scene parameter the model does not have",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[parameters]\nOmegaa = 0.8\n"))])[1],
         ["s.toml", "parameters.Omegaa", "unknown parameter 'Omegaa'"]),
    Case("initial value of a state the model does not have",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[initial]\nw = 1.0\n"))])[1],
         ["s.toml", "initial.w", "not a state"]),
    Case("impossible tolerance in the scene",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[simulate]\nrtol = 0.0\n"))])[1],
         ["s.toml", "simulate.rtol", "must be positive"]),
    Case("unmet effect requirement in the scene",
         lambda w: (model(w, KS_MODEL), ["simulate", str(scene(w, M, "[effects]\ncontact_damping = true\nbacklash = false\n"))])[1],
         ["s.toml", "effects.contact_damping", "requires effect 'backlash'"]),
    Case("deflection that depends on no coordinate (fails while deriving)",
         lambda w: _sim(w, sub(KS_MODEL, 'deflection = "x"', 'deflection = "b"')),
         [M, "elements.mesh.deflection", "does not depend on any coordinate"]),
    Case("time-dependent condition without a schedule (fails while deriving)",
         lambda w: _sim(w, sub(KS_MODEL, 'value = ["Fm",', 'value = ["Fm*Piecewise((1, t > 3), (0, True))",')),
         [M, "depends on time", "[schedules]"]),
]


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("gen")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_spec(case: Case, tmp_path: Path, gen: Path):
    check_case(case, tmp_path, gen)


def test_bad_specs_are_also_rejected_through_the_api(tmp_path):
    """The same checks hold for ``gearsym.load_scene`` (the CLI adds nothing to them)."""
    model(tmp_path, sub(KS_MODEL, 'value = "1"\n', 'value = "-1"\n'))
    with pytest.raises(gearsym.SpecError) as info:
        gearsym.load_scene(scene(tmp_path, M))
    assert info.value.field == "elements.inertia.value"
    with pytest.raises(gearsym.SpecError, match="inertia must be positive"):
        gearsym.load_scene(ROOT_SPUR_SCENE, J1=-1e-3)
    assert gearsym.load_scene(KS_SCENE).model_spec.name == "kahraman_singh"  # good input still loads


ROOT_SPUR_SCENE = KS_SCENE.parent / "spur_pair_torsional.toml"
