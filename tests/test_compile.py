"""Code generation, compile cache, run-time parameters, explicit vs implicit (IDA) form."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import gearsym

ROOT = Path(__file__).resolve().parents[1]
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"


def test_cache_miss_then_hit_and_parameters_do_not_recompile(tmp_path):
    scene = gearsym.load_scene(KS_SCENE)
    s1 = scene.compile(generated_dir=tmp_path)
    assert not s1.generated.cached
    so = Path(s1.generated.so_path)
    assert so.exists() and so.parent.name.startswith("kahraman_singh-")
    mtime = so.stat().st_mtime_ns
    s2 = gearsym.load_scene(KS_SCENE, Omega=0.7).compile(generated_dir=tmp_path)
    assert s2.generated.cached and s2.generated.so_path == str(so)
    assert so.stat().st_mtime_ns == mtime
    assert s2.params["Omega"] == 0.7
    # a parameter changes the result without recompiling
    a = s1.simulate(periods=5)
    b = s1.simulate(periods=5, params={"Omega": 0.7})
    assert a.period != b.period and not np.allclose(a.y[-1], b.y[-1])
    # switching an effect off is a different build
    s3 = gearsym.load_scene(KS_SCENE, effects={"backlash": False}).compile(generated_dir=tmp_path)
    assert not s3.generated.cached and s3.generated.so_path != str(so)
    assert len(sorted(tmp_path.iterdir())) == 2


def test_generated_sources_are_readable(tmp_path):
    gen = gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path)
    c = (Path(gen.directory) / "gs_model.c").read_text()
    h = (Path(gen.directory) / "gs_model.h").read_text()
    head = c[:2000]
    assert "States     x = [x, v]" in head
    assert "Parameters p = [zeta, Fm, Fa, eps, b, Omega]" in head
    for fn in ("gs_rhs", "gs_jac", "gs_sw", "gs_swx", "gs_swt", "gs_sched", "gs_period"):
        assert re.search(rf"\b{fn}\b.*\S", head), fn
        assert f"int {fn}(" in c
    assert "int gs_model_info(int* out, int len)" in h


def test_switched_off_effects_leave_no_parameters_or_code(tmp_path):
    full = gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path)
    lean = gearsym.load_scene(KS_SCENE, effects={"mesh_stiffness_variation": False, "backlash": False,
                                                 "static_transmission_error": False}
                              ).generate(generated_dir=tmp_path)
    assert full.param_names == ["zeta", "Fm", "Fa", "eps", "b", "Omega"]
    # the forcing period keeps Omega; eps, Fa and b are gone
    assert lean.param_names == ["zeta", "Fm", "Omega"]
    assert lean.nsw == 0 and full.nsw == 2
    assert lean.n_ops["gs_rhs"] < full.n_ops["gs_rhs"]
    c = (Path(lean.directory) / "gs_model.c").read_text()
    assert "cos(" not in c.split("int gs_model_info")[0].split("*/", 1)[1]


def _two_dof_model(tmp_path: Path, form: str) -> Path:
    """The dimensional spur pair without reduction (2 DOF, semi-definite), in a given form."""
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text = text[: text.index("[reduction]")] + "[initial]\nth1 = 0.0\nth2 = 0.0\n"
    text = text.replace('time_unit = "s"', f'time_unit = "s"\nform = "{form}"')
    model = tmp_path / f"pair_{form}.toml"
    model.write_text(text)
    scene = tmp_path / f"pair_{form}_scene.toml"
    scene.write_text(f'[scene]\nname = "pair_{form}"\nmodel = "{model.name}"\n')
    return scene


def test_explicit_and_implicit_forms_give_the_same_trajectory(tmp_path):
    ex = gearsym.load_scene(_two_dof_model(tmp_path, "explicit")).compile(generated_dir=tmp_path / "g")
    im = gearsym.load_scene(_two_dof_model(tmp_path, "implicit")).compile(generated_dir=tmp_path / "g")
    assert im.generated.implicit and not ex.generated.implicit
    si = ex.units.to_si(ex.params)  # SI: the states are in SI (b_m is declared in um)
    b_m = si["b_m"]
    # start in drive-side contact with a pinion velocity kick: impacts follow
    x0 = np.array([1.2 * b_m / si["rb1"], 0.0, 0.3, 0.0])
    kw = dict(periods=30, x0=x0, rtol=1e-10, atol=1e-13)
    a = ex.simulate(**kw)
    b = im.simulate(**kw)
    assert b.stats["n_steps"] > 0 and len(a.events) > 5
    assert [e.surface for e in a.events] == [e.surface for e in b.events]
    np.testing.assert_allclose([e.t for e in a.events], [e.t for e in b.events], rtol=0, atol=1e-9)
    # compare the mesh deflection (the rotations themselves drift as a rigid body)
    d_a = a.y[:, 0] * si["rb1"] - a.y[:, 1] * si["rb2"]
    d_b = b.y[:, 0] * si["rb1"] - b.y[:, 1] * si["rb2"]
    assert np.max(np.abs(d_a - d_b)) < 1e-6 * b_m
    np.testing.assert_allclose(a.y[:, 2:], b.y[:, 2:], rtol=0, atol=1e-6 * np.max(np.abs(a.y[:, 2:])))


def test_implicit_model_rejects_cvode(tmp_path):
    im = gearsym.load_scene(_two_dof_model(tmp_path, "implicit")).compile(generated_dir=tmp_path / "g")
    with pytest.raises(gearsym.ParameterError, match="implicit"):
        im.simulate(periods=1, method="bdf")
