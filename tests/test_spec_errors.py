"""Bad input gives a clear SpecError/ParameterError naming file, field and problem."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import gearsym
from gearsym.errors import ParameterError, SpecError
from gearsym.spec.model import load_model

ROOT = Path(__file__).resolve().parents[1]
KS = (ROOT / "models" / "kahraman_singh.toml").read_text()


def _model(tmp_path: Path, text: str, name: str = "m.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _scene(tmp_path: Path, model: Path, extra: str = "") -> Path:
    p = tmp_path / "s.toml"
    p.write_text(f'[scene]\nname = "s"\nmodel = "{model.name}"\n{extra}')
    return p


CASES = [
    # (description, substitution on the KS model text, expected field, expected words)
    ("unknown symbol", ('value = "1"\n', 'value = "1 + zetta"\n'), "elements.inertia.value",
     "unknown symbol 'zetta'"),
    ("unit mismatch", ('zeta  = { value = 0.05, meaning', 'zeta  = { value = 0.05, unit = "N", meaning'),
     "elements.mesh.damping", "unit mismatch"),
    ("missing parameter value", ("b     = { value = 1.0,  meaning", "b     = { meaning"),
     "parameters.b.value", "missing value"),
    ("effect not in model", ('effect = "backlash" }', 'effect = "backlasch" }'),
     "elements.mesh.backlash", "effect 'backlasch' is not in the model"),
    ("duplicate name", ('velocity = "v"', 'velocity = "x"'), "coordinates.x.velocity", "duplicate name 'x'"),
    ("wrong type", ('value = "1"\n', "value = true\n"), "elements.inertia.value", "wrong type"),
    ("syntax error in expression", ('value = "1"\n', 'value = "(1"\n'), "elements.inertia.value",
     "syntax error"),
    ("unknown function", ('value = "1"\n', 'value = "foo(1)"\n'), "elements.inertia.value",
     "unknown function 'foo'"),
    ("unknown element type", ('type = "mesh"', 'type = "gearmesh"'), "elements.mesh.type",
     "unknown element type"),
    ("unknown unit", ('zeta  = { value = 0.05, meaning', 'zeta  = { value = 0.05, unit = "furlong", meaning'),
     "parameters.zeta.unit", "unknown unit 'furlong'"),
    ("forcing period with a length", ('Omega = { value = 0.9,  meaning', 'Omega = { value = 0.9, unit = "m", meaning'),
     "forcing.period", "must be a time"),
    ("nan parameter", ("eps   = { value = 0.2,", "eps   = { value = nan,"), "parameters.eps.value", "non-finite"),
    ("unknown field", ('drive_side = "positive"', 'drive_sid = "positive"'), "elements.mesh.drive_sid",
     "unknown field"),
    ("forcing period not a time", ('period = "2*pi/Omega"', 'period = "2*pi/Omega*zeta + x"'),
     "forcing.period", "must depend on parameters only, not on x"),
    ("unknown coordinate", ('coordinate = "x"\nvalue = "1"', 'coordinate = "y"\nvalue = "1"'),
     "elements.inertia.coordinate", "unknown coordinate 'y'"),
    ("reserved name", ("eps   = { value", "lambda = { value"), "parameters.lambda", "keyword"),
    ("initial not a state", ("v = 0.0\n", "w = 0.0\n"), "initial.w", "not a state"),
]


@pytest.mark.parametrize("desc,sub,field,words", CASES, ids=[c[0] for c in CASES])
def test_model_errors_name_file_and_field(tmp_path, desc, sub, field, words):
    old, new = sub
    assert old in KS, f"test setup: '{old}' not in the model"
    path = _model(tmp_path, KS.replace(old, new, 1))
    with pytest.raises(SpecError) as info:
        load_model(path)
    err = info.value
    assert err.file == str(path)
    assert err.field == field, str(err)
    assert words.lower() in str(err).lower()
    assert str(path) in str(err)


def test_toml_syntax_error(tmp_path):
    path = _model(tmp_path, KS + "\n[broken\n")
    with pytest.raises(SpecError, match="TOML syntax error") as info:
        load_model(path)
    assert info.value.file == str(path)


def test_circular_derived(tmp_path):
    text = KS.replace("[effects.backlash]", '[derived]\na1 = "a2 + 1"\na2 = "2*a1"\n\n[effects.backlash]')
    with pytest.raises(SpecError, match="circular definition") as info:
        load_model(_model(tmp_path, text))
    assert info.value.field.startswith("derived.a")


def test_empty_model(tmp_path):
    with pytest.raises(SpecError, match=r"missing section \[model\]"):
        load_model(_model(tmp_path, ""))


def test_missing_model_file(tmp_path):
    with pytest.raises(SpecError, match="not found"):
        load_model(tmp_path / "nope.toml")


def test_no_inertia(tmp_path):
    text = re.sub(r"\[elements\.inertia\][^\[]*", "", KS)
    with pytest.raises(SpecError, match="no inertia") as info:
        load_model(_model(tmp_path, text))
    assert info.value.field == "coordinates.x"


def test_scene_effect_not_in_model(tmp_path):
    m = _model(tmp_path, KS)
    s = _scene(tmp_path, m, "[effects]\nfriction = true\n")
    with pytest.raises(SpecError, match="effect 'friction' is not in model 'kahraman_singh'") as info:
        gearsym.load_scene(s)
    assert info.value.field == "effects.friction"
    assert info.value.file == str(s)


def test_effect_override_not_in_model():
    with pytest.raises(SpecError, match="effect 'nonsense' is not in model"):
        gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", effects={"nonsense": True})


def test_unknown_parameter_override():
    with pytest.raises(ParameterError, match="unknown parameter 'Omegaa'"):
        gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", Omegaa=1.0)


def test_parameter_of_switched_off_effect_names_both():
    with pytest.raises(ParameterError) as info:
        gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml",
                           effects={"mesh_stiffness_variation": False}, eps=0.3)
    assert "'eps'" in str(info.value) and "mesh_stiffness_variation" in str(info.value)


def test_nan_override():
    with pytest.raises(ParameterError, match="non-finite"):
        gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", Omega=float("nan"))


def test_requires_unmet(tmp_path):
    text = KS.replace('[effects.backlash]\n', '[effects.backlash]\nrequires = ["static_transmission_error"]\n')
    m = _model(tmp_path, text)
    s = _scene(tmp_path, m, "[effects]\nstatic_transmission_error = false\n")
    with pytest.raises(SpecError, match="requires effect 'static_transmission_error'"):
        gearsym.load_scene(s)


def test_bad_variant(tmp_path):
    text = KS.replace("[effects.backlash]\n", '[effects.backlash]\nvariants = ["A", "B"]\n')
    m = _model(tmp_path, text)
    s = _scene(tmp_path, m, '[effects]\nbacklash = "C"\n')
    with pytest.raises(SpecError, match="'C' is not a variant of effect 'backlash'"):
        gearsym.load_scene(s)


def test_scene_missing_model(tmp_path):
    s = _scene(tmp_path, tmp_path / "absent.toml")
    with pytest.raises(SpecError, match="model file not found"):
        gearsym.load_scene(s)


def test_scene_bad_simulate_field(tmp_path):
    m = _model(tmp_path, KS)
    s = _scene(tmp_path, m, "[simulate]\nrtol = -1.0\n")
    with pytest.raises(SpecError, match="must be positive") as info:
        gearsym.load_scene(s)
    assert info.value.field == "simulate.rtol"


def test_dimensional_argument_of_cos(tmp_path):
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text = text.replace('expr = "k_a*cos(omega*t)"', 'expr = "k_a*cos(omega)"')
    with pytest.raises(SpecError, match="argument of cos\\(\\) must be dimensionless") as info:
        load_model(_model(tmp_path, text))
    assert info.value.field == "elements.mesh.stiffness[1]"


def test_typed_excitations_with_units(tmp_path):
    """sinusoid / fourier fields with dimensional amplitudes pass the unit check (no '0' mean)."""
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text = text.replace('{ expr = "k_a*cos(omega*t)", effect = "mesh_stiffness_variation" }',
                        '{ type = "fourier", frequency = "omega", cos = ["k_a"], '
                        'effect = "mesh_stiffness_variation" }')
    text = text.replace('stiffness = ["k_m", ', 'stiffness = [{ type = "sinusoid", mean = "k_m", '
                        'amplitude = "0*k_m", frequency = "omega" }, ')
    spec = load_model(_model(tmp_path, text))
    terms = spec.elements["mesh"].fields["stiffness"]
    assert [t.effect for t in terms] == [None, "mesh_stiffness_variation"]
    assert "cos(1*(omega)*t)" in terms[1].expr.replace(" ", "")


def test_reduction_with_time_dependent_coefficient_is_rejected(tmp_path):
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text = text.replace('definition = "rb1*th1 - rb2*th2 - e_s"',
                        'definition = "rb1*(1 + 0.1*cos(omega*t))*th1 - rb2*th2 - e_s"')
    scene = _scene(tmp_path, _model(tmp_path, text))
    with pytest.raises(SpecError, match="must not depend on time") as info:
        _ = gearsym.load_scene(scene).model
    assert info.value.field == "reduction.definition"
