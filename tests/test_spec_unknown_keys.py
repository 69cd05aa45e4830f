"""Every table of a model or scene file rejects an unknown key, naming the file and the field and
suggesting the closest known key (issue 24, item 15: ``descriptoin`` / ``time_unti`` in ``[model]``
were accepted silently, and ``time_unti`` became a confusing unit error elsewhere)."""

from __future__ import annotations

from pathlib import Path

import pytest

import gearsym
from gearsym.errors import SpecError

ROOT = Path(__file__).resolve().parents[1]
KS = (ROOT / "models" / "kahraman_singh.toml").read_text()
SPUR = (ROOT / "models" / "spur_pair_torsional.toml").read_text()


def _sub(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _load(tmp_path: Path, model_text: str, scene_extra: str = "") -> None:
    (tmp_path / "m.toml").write_text(model_text)
    s = tmp_path / "s.toml"
    s.write_text(f'[scene]\nname = "s"\nmodel = "m.toml"\n{scene_extra}')
    gearsym.load_scene(s)


MODEL_CASES = [
    # (model text, field, suggestion)
    (_sub(KS, "description =", "descriptoin ="), "model.descriptoin", "description"),
    (_sub(KS, 'time_unit = "1"', 'time_unti = "1"'), "model.time_unti", "time_unit"),
    (_sub(KS, "[coordinates.x]\n", "[coordinates.x]\nveloctiy = \"w\"\n"), "coordinates.x.veloctiy", "velocity"),
    (_sub(KS, 'zeta  = { value = 0.05,', 'zeta  = { valeu = 1, value = 0.05,'), "parameters.zeta.valeu", "value"),
    (_sub(KS, 'drive_side = "positive"', 'drive_sid = "positive"'), "elements.mesh.drive_sid", "drive_side"),
    (_sub(KS, '{ expr = "b", effect = "backlash" }', '{ expr = "b", efect = "backlash" }'),
     "elements.mesh.backlash.efect", "effect"),
    (_sub(KS, '[forcing]\nperiod =', '[forcing]\nperoid = "1"\nperiod ='), "forcing.peroid", "period"),
    (_sub(KS, "[effects.backlash]\n", "[effects.backlash]\ndefualt = true\n"), "effects.backlash.defualt", "default"),
    (_sub(KS, "[forcing]", "[forcin]\n[forcing]"), "forcin", "forcing"),
    (_sub(SPUR, "[reduction]\n", "[reduction]\ndefinitoin = \"x\"\n"), "reduction.definitoin", "definition"),
    # a typed excitation takes only its own keys (a sinusoid has no 'cos'; 'phse' is not 'phase')
    (_sub(KS, '{ expr = "Fa*Omega**2*cos(Omega*t)", effect', '{ type = "sinusoid", amplitude = "Fa*Omega**2", '
          'frequency = "Omega", phse = "0", effect'), "elements.load.value[1].phse", "phase"),
    (_sub(KS, '{ expr = "Fa*Omega**2*cos(Omega*t)", effect', '{ type = "sinusiod", amplitude = "Fa", effect'),
     "elements.load.value[1].type", "sinusoid"),
    (_sub(KS, '{ expr = "eps*cos(Omega*t)", effect', '{ expr = "eps*cos(Omega*t)", amplitude = "1", effect'),
     "elements.mesh.stiffness[1].amplitude", None),
]


@pytest.mark.parametrize("text,field,suggestion", MODEL_CASES, ids=[c[1] for c in MODEL_CASES])
def test_model_tables_reject_unknown_keys(tmp_path, text, field, suggestion):
    with pytest.raises(SpecError) as info:
        _load(tmp_path, text)
    err = info.value
    assert err.file == str(tmp_path / "m.toml") and err.field == field, str(err)
    if suggestion is not None:
        assert f"did you mean '{suggestion}'?" in str(err), str(err)
    else:
        assert "unknown field 'amplitude'" in str(err), str(err)


SCENE_CASES = [
    ("[simulat]\nperiods = 2\n", "simulat", "simulate"),
    ("[simulate]\nrtoll = 1e-8\n", "simulate.rtoll", "rtol"),
    ("[simulate]\npoints_per_perid = 8\n", "simulate.points_per_perid", "points_per_period"),
    ("[orbit]\nsegmets = 2\n", "orbit.segmets", "segments"),
    ("[continue]\nds_mx = 0.1\n", "continue.ds_mx", "ds_max"),
    ("[map]\nquantiy = \"rattle_state\"\n", "map.quantiy", "quantity"),
    ("[parameters]\nOmegaa = 1.0\n", "parameters.Omegaa", "Omega"),
    ("[effects]\nbacklsh = true\n", "effects.backlsh", "backlash"),
    ("[initial]\nxx = 1.0\n", "initial.xx", "x"),
]


@pytest.mark.parametrize("extra,field,suggestion", SCENE_CASES, ids=[c[1] for c in SCENE_CASES])
def test_scene_tables_reject_unknown_keys(tmp_path, extra, field, suggestion):
    with pytest.raises(SpecError) as info:
        _load(tmp_path, KS, extra)
    err = info.value
    assert err.file == str(tmp_path / "s.toml") and err.field == field, str(err)
    assert f"did you mean '{suggestion}'?" in str(err), str(err)


def test_scene_header_rejects_unknown_keys(tmp_path):
    (tmp_path / "m.toml").write_text(KS)
    s = tmp_path / "s.toml"
    s.write_text('[scene]\nname = "s"\nmodel = "m.toml"\ndescripton = "x"\n')
    with pytest.raises(SpecError, match=r"field 'scene.descripton': unknown field 'descripton'; did you mean "
                                        r"'description'\?"):
        gearsym.load_scene(s)


def test_settings_values_are_checked(tmp_path):
    with pytest.raises(SpecError, match=r"field 'orbit.method': must be one of shooting, hbm, got 'newton'"):
        _load(tmp_path, KS, '[orbit]\nmethod = "newton"\n')
    with pytest.raises(SpecError, match=r"field 'continue.segments': wrong type: expected an integer"):
        _load(tmp_path, KS, '[continue]\nsegments = 1.5\n')
    with pytest.raises(SpecError, match=r"field 'simulate.method': must be one of adams, bdf, ida"):
        _load(tmp_path, KS, '[simulate]\nmethod = "rk45"\n')


def test_no_suggestion_for_a_far_name(tmp_path):
    with pytest.raises(SpecError) as info:
        _load(tmp_path, _sub(KS, "description =", "zzzqqq ="))
    assert "did you mean" not in str(info.value) and "(allowed: description, form, name, notes, reference, " \
        "time_unit)" in str(info.value)
