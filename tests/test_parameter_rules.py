"""Physical ranges of parameter values, derived from the element that uses each value and
checked for the values actually used: the scene, ``--set``, ``params=``, map grids and
continuation ranges (issue 24, item 4: ``--set b_m=-20`` ran with exit 0, and a schedule break
outside [0, 1) in a schedule the scene does not use was accepted)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis.continuation import continuation
from gearsym.analysis.sweeps import stability_map
from gearsym.errors import ParameterError, SpecError

ROOT = Path(__file__).resolve().parents[1]
KS = (ROOT / "models" / "kahraman_singh.toml").read_text()
SPUR = str(ROOT / "scenes" / "spur_pair_torsional.toml")  # b_m in um, c_m in N*s/m, J1 in kg*m^2


def _sub(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _scene(tmp_path: Path, model_text: str, extra: str = "") -> Path:
    (tmp_path / "m.toml").write_text(model_text)
    s = tmp_path / "s.toml"
    s.write_text(f'[scene]\nname = "s"\nmodel = "m.toml"\n{extra}')
    return s


def _cli(*args: str) -> subprocess.CompletedProcess:
    src = str(Path(gearsym.__file__).resolve().parents[1])  # the gearsym under test
    env = dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True, env=env,
                          cwd=src, timeout=300)


def test_cli_negative_backlash_is_refused():
    r = _cli("inspect", SPUR, "--set", "b_m=-20", "--json")
    assert r.returncode == 2 and r.stdout == "", r.stdout[:200]
    model = Path(gearsym.__file__).resolve().parents[1] / "models" / "spur_pair_torsional.toml"
    assert r.stderr.strip() == (f"gearsym: error: --set b_m: half backlash of mesh 'mesh' ({model}: "
                                f"elements.mesh.backlash) must be >= 0, got b_m = -20 um")


@pytest.mark.parametrize("name,value,words", [
    ("b_m", -1e-3, ["half backlash of mesh 'mesh'", "b_m = -0.001 um"]),
    ("J1", 0.0, ["spur_pair_torsional.toml: field 'elements.pinion.value': inertia must be positive, got "
                 "J1 = 0 kg*m^2"]),
    ("c_m", -5.0, ["field 'elements.mesh.damping': damping of mesh 'mesh' must be >= 0, got c_m = -5 N*s/m"]),
])
def test_api_overrides_are_checked(name, value, words):
    with pytest.raises(ParameterError) as info:
        gearsym.load_scene(SPUR, **{name: value})
    for w in words:
        assert w in str(info.value), str(info.value)


def test_zero_backlash_is_fine():
    assert gearsym.load_scene(SPUR, b_m=0.0).resolved.values["b_m"] == 0.0


def test_a_value_from_the_scene_names_the_model_field_and_the_scene(tmp_path):
    s = _scene(tmp_path, KS, "[parameters]\nb = -0.5\n")
    with pytest.raises(SpecError) as info:
        gearsym.load_scene(s)
    e = info.value
    assert e.file == str(tmp_path / "m.toml") and e.field == "elements.mesh.backlash"
    assert "half backlash of mesh 'mesh' must be >= 0, got b = -0.5 (set in the scene" in str(e), str(e)


def test_backlash_of_a_switched_off_effect_is_not_checked(tmp_path):
    # the backlash term belongs to the effect 'backlash': off, the value is not used
    s = _scene(tmp_path, KS, "[effects]\nbacklash = false\n")
    gearsym.load_scene(s)


def test_a_compound_value_names_every_parameter(tmp_path):
    text = _sub(KS, 'b     = { value = 1.0,  meaning = "half backlash" }',
                'b     = { value = 1.0,  meaning = "half backlash" }\nbi = { value = 0.2 }')
    text = _sub(text, '[effects.backlash]', '[derived]\nbh = "b - 2*bi"\n\n[effects.backlash]')
    text = _sub(text, '{ expr = "b", effect = "backlash" }', '{ expr = "bh", effect = "backlash" }')
    s = _scene(tmp_path, text)
    gearsym.load_scene(s)  # b - 2*bi = 0.6
    with pytest.raises(ParameterError, match=r"m.toml: field 'elements.mesh.backlash': half backlash of mesh 'mesh' "
                                             r"must be >= 0, got -0.2 from 'bh' with b = 1, bi = 0.6"):
        gearsym.load_scene(s, bi=0.6)


@pytest.mark.parametrize("breaks,words", [
    ('["1.5"]', ["break 0 of schedule 'spare' must be in (0, 1)", "got 1.5"]),
    ('["0"]', ["break 0 of schedule 'spare' must be in (0, 1)"]),
    ('["0.6", "eps"]', ["break 1 of schedule 'spare' must be greater than break 0", "with eps = 0.2"]),
])
def test_schedule_breaks_even_of_an_unused_schedule(tmp_path, breaks, words):
    text = _sub(KS, "[forcing]", f'[schedules.spare]\nperiod = "2*pi/Omega"\nbreaks = {breaks}\n\n[forcing]')
    with pytest.raises(SpecError) as info:
        gearsym.load_scene(_scene(tmp_path, text))
    assert info.value.field.startswith("schedules.spare.breaks["), str(info.value)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_declared_ranges(tmp_path):
    text = _sub(KS, 'eps   = { value = 0.2,  meaning', 'eps   = { value = 0.2, min = 0, max = 0.9, meaning')
    text = _sub(text, 'zeta  = { value = 0.05, meaning', 'zeta  = { value = 0.05, positive = true, meaning')
    s = _scene(tmp_path, text)
    gearsym.load_scene(s, eps=0.9)
    with pytest.raises(ParameterError, match=r"field 'parameters.eps': parameter 'eps' must be <= 0.9 \(its max\), "
                                             r"got eps = 0.95"):
        gearsym.load_scene(s, eps=0.95)
    with pytest.raises(ParameterError, match=r"field 'parameters.zeta': parameter 'zeta' must be positive"):
        gearsym.load_scene(s, zeta=0.0)
    with pytest.raises(SpecError, match=r"field 'parameters.eps.value': the value 1.2 of 'eps' must be <= 0.9"):
        gearsym.load_scene(_scene(tmp_path, _sub(text, "value = 0.2, min", "value = 1.2, min")))


@pytest.fixture(scope="module")
def spur():
    return gearsym.load_scene(SPUR).compile()


def test_every_parameter_vector_is_checked(spur):
    assert spur.param_vector({"b_m": 10.0})[spur.param_names.index("b_m")] == pytest.approx(1e-5, rel=1e-15)
    with pytest.raises(ParameterError, match=r"half backlash of mesh 'mesh' \(elements.mesh.backlash\) must be "
                                             r">= 0, got b_m = -3 um"):
        spur.param_vector({"b_m": -3.0})
    with pytest.raises(ParameterError, match="b_m = -3 um"):
        spur.simulate(periods=1, params={"b_m": -3.0})


def test_map_grid_is_checked_before_any_work(spur):
    with pytest.raises(ParameterError, match=r"half backlash .* got b_m = -10 um"):
        stability_map(spur, ("b_m", -10.0, 50.0, 3), ("c_m", 1000.0, 2000.0, 2), workers=1)
    with pytest.raises(ParameterError, match=r"damping of mesh 'mesh' .* got c_m = -1 N\*s/m"):
        stability_map(spur, ("b_m", 10.0, 50.0, 3), ("c_m", -1.0, 2000.0, 2), workers=1)


def test_continuation_range_is_checked_before_any_work(spur):
    with pytest.raises(ParameterError, match=r"half backlash .* got b_m = -10 um"):
        continuation(spur, "b_m", 50.0, -10.0, progress=False)


def test_pickled_system_keeps_the_rules(spur):
    import pickle

    again = pickle.loads(pickle.dumps(spur))
    with pytest.raises(ParameterError, match="b_m = -3 um"):
        again.param_vector({"b_m": -3.0})
    assert np.array_equal(again.param_vector(), spur.param_vector())
