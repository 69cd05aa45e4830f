"""``[initial]``: expressions of the parameters and ``static = true`` (the static equilibrium).

References are hand computations from the models' parameters: the spur pair's static
deflection ``x_s = F/k_m + b_m`` with ``F = T1/rb1``; the template's with the average of
``k(t)*e(t)``; Vaishya & Singh's rectangular stiffness averaged over the mesh cycle
(``k_mean`` of their eq. 3, which the quadrature must hit exactly across the breakpoints);
and an integration from the static state with the excitations off, which must not move.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.cli.catalog import init_files
from gearsym.errors import SpecError

REPO = Path(__file__).resolve().parents[1]
BUILDS = REPO / "generated"  # the scenes below share the shipped scenes' builds (same model and effects)


def scene_file(tmp_path: Path, model: str | Path, body: str, name: str) -> Path:
    model_path = model if isinstance(model, Path) else REPO / "models" / f"{model}.toml"
    path = tmp_path / f"{name}.toml"
    path.write_text(f'[scene]\nname = "{name}"\nmodel = {json.dumps(str(model_path))}\n{body}')
    return path


def spur_static() -> float:
    """Hand computation: the pinion torque over its base radius against the mean stiffness."""
    T1, rb1, k_m, b_m = 60.0, 0.04, 3.0e8, 50e-6
    assert T1 / rb1 == pytest.approx(75.0 / 0.05)  # the load torque balances it: F = 1500 N
    return T1 / rb1 / k_m + b_m


def test_spur_pair_static_deflection_is_F_over_k_plus_b(tmp_path):
    path = scene_file(tmp_path, "spur_pair_torsional", "[initial]\nstatic = true\nx = 1e-6\n",
                      "spur_pair_torsional")
    system = gearsym.load_scene(path).compile(generated_dir=BUILDS)
    assert system.x0 == pytest.approx([spur_static(), 0.0], rel=1e-12, abs=1e-18)


def test_static_state_does_not_move_without_excitation(tmp_path):
    body = ("[effects]\nmesh_stiffness_variation = false\nstatic_transmission_error = false\n"
            "[initial]\nstatic = true\n")
    scene = gearsym.load_scene(scene_file(tmp_path, "spur_pair_torsional", body, "spur_pair_static_rest"))
    system = scene.compile(generated_dir=BUILDS)
    traj = system.simulate(periods=20, rtol=1e-10, atol=1e-16)
    assert system.x0[0] == pytest.approx(spur_static(), rel=1e-12)
    assert np.abs(traj.y[:, 0] - spur_static()).max() < 1e-12 * spur_static()
    assert np.abs(traj.y[:, 1]).max() < 1e-9  # m/s; the DTE's velocity scale is omega*x ~ 1 m/s
    assert traj.stats["n_events"] == 0


def test_initial_expressions_of_parameters_follow_overrides(tmp_path):
    body = '[initial]\nx = "T1/rb1/k_m + b_m"\n'
    path = scene_file(tmp_path, "spur_pair_torsional", body, "spur_pair_torsional")
    assert gearsym.load_scene(path).initial_state() == pytest.approx([spur_static(), 0.0], rel=1e-14)
    # --set T1=30 (declared unit N*m) changes the expression's value; b_m is in um, used in SI
    moved = gearsym.load_scene(path, T1=30.0).initial_state()[0]
    assert moved == pytest.approx(30.0 / 0.04 / 3e8 + 50e-6, rel=1e-14)


def test_template_static_state_includes_the_average_of_k_times_e(tmp_path):
    model_text, scene_text = init_files("tmpl")
    (tmp_path / "models").mkdir()
    (tmp_path / "scenes").mkdir()
    (tmp_path / "models" / "tmpl.toml").write_text(model_text)
    (tmp_path / "scenes" / "tmpl.toml").write_text(scene_text)
    scene = gearsym.load_scene(tmp_path / "scenes" / "tmpl.toml")
    system = scene.compile(generated_dir=tmp_path / "builds")
    v = scene.resolved.values
    # mean of (k_m + k_a cos)(x - b - e_a cos) = k_m (x - b) - k_a e_a / 2 = F_m
    x_s = v["b_m"] + (v["F_m"] + v["k_a"] * v["e_a"] / 2) / v["k_m"]
    assert system.x0 == pytest.approx([x_s, 0.0], rel=1e-12, abs=1e-18)
    # the template's scene runs and the mesh stays in contact on average: x oscillates about x_s
    traj = system.simulate(periods=50)
    late = traj.y[len(traj.t) // 2:, 0]
    assert late.min() < x_s < late.max()


def test_rectangular_stiffness_is_averaged_exactly_across_breakpoints(tmp_path):
    body = ("[effects]\nmesh_stiffness_variation = true\nstatic_transmission_error = false\n"
            "sliding_friction = false\nbacklash = false\n[parameters]\nzeta = 0.05\n[initial]\nstatic = true\n")
    path = scene_file(tmp_path, "vaishya_singh", body, "vaishya_singh_parametric")
    system = gearsym.load_scene(path).compile(generated_dir=BUILDS)
    # Vaishya & Singh Table 1: N_0 = T_p/R_p over k_mean = k_max (Gamma - 1) + k_min (2 - Gamma)
    R_p = 88.9e-3 * 25 / (25 + 31) * math.cos(math.radians(25.0))
    k_max, k_min, Gamma = 7.2e8, 7.2e8 / 1.667, 1.433
    x_s = 226.0 / R_p / (k_max * (Gamma - 1) + k_min * (2 - Gamma))
    assert system.x0 == pytest.approx([x_s, 0.0], rel=1e-12, abs=1e-18)


def test_implicit_form_gives_the_same_static_state(tmp_path):
    text = (REPO / "models" / "spur_pair_torsional.toml").read_text()
    model = tmp_path / "model_spur_implicit.toml"
    model.write_text(text.replace('name = "spur_pair_torsional"', 'name = "spur_implicit"\nform = "implicit"', 1))
    system = gearsym.load_scene(scene_file(tmp_path, model, "[initial]\nstatic = true\n", "spur_implicit")
                                ).compile(generated_dir=tmp_path / "builds")
    assert system.generated.implicit
    assert system.x0 == pytest.approx([spur_static(), 0.0], rel=1e-12, abs=1e-18)


def test_reversed_load_rests_on_the_back_flank(tmp_path):
    """Reversed torques press the back flanks: x_s = -(F/k_m + b_m) (this was refused as "not in
    drive-side contact" before the static solve took the contact state from the mean load)."""
    path = scene_file(tmp_path, "spur_pair_torsional", "[parameters]\nT1 = -60\nT2 = -75\n[initial]\nstatic = true\n",
                      "spur_pair_torsional")
    system = gearsym.load_scene(path).compile(generated_dir=BUILDS)
    assert system.x0 == pytest.approx([-spur_static(), 0.0], rel=1e-12, abs=1e-18)


FREE_PAIR = """
[model]
name = "free_pair"
[coordinates.a]
unit = "rad"
[coordinates.c]
unit = "rad"
[parameters]
J = { value = 1.0, unit = "kg*m^2" }
k = { value = 100.0, unit = "N*m" }
T = { value = 1.0, unit = "N*m" }
[elements.ja]
type = "inertia"
coordinate = "a"
value = "J"
[elements.jc]
type = "inertia"
coordinate = "c"
value = "J"
[elements.s]
type = "spring"
deflection = "a - c"
stiffness = "k"
[elements.ta]
type = "force"
coordinate = "a"
value = "T"
[elements.tc]
type = "force"
coordinate = "c"
value = "-T"
"""


def test_rigid_body_mode_is_refused(tmp_path):
    model = tmp_path / "model_free_pair.toml"
    model.write_text(FREE_PAIR)
    path = scene_file(tmp_path, model, "[initial]\nstatic = true\n", "free_pair")
    with pytest.raises(SpecError, match=r"initial\.static.*singular.*rigid-body"):
        gearsym.load_scene(path).compile(generated_dir=tmp_path / "builds")


@pytest.mark.parametrize("initial, needle", [
    ('x = "T1"', r"initial\.x.*unit mismatch: the state is \[m\], the expression \[kg\*m\^2\*s\^-2\]"),
    ('x = "T9/k_m"', r"initial\.x.*'T9' is not a parameter"),
    ('x = "__import__(1)"', r"initial\.x"),
    ('x = "b_m - b_m/0"', r"initial\.x"),
    ("static = 1", r"initial\.static.*true or false"),
    ("static = true\nv = 0.5", r"initial\.v.*starts at rest"),
    ('x = [1]', r"initial\.x.*finite number or an expression"),
])
def test_bad_initial_tables_name_the_field(tmp_path, initial, needle):
    path = scene_file(tmp_path, "spur_pair_torsional", f"[initial]\n{initial}\n", "spur_pair_torsional")
    with pytest.raises(SpecError, match=needle):
        gearsym.load_scene(path)


def test_cli_static_failure_is_one_line_exit_2(tmp_path):
    # the free pair of test_rigid_body_mode_is_refused with both torques one way: no equilibrium
    model = tmp_path / "model_free_pair.toml"
    model.write_text(FREE_PAIR.replace('value = "-T"', 'value = "T"'))
    path = scene_file(tmp_path, model, "[initial]\nstatic = true\n", "free_pair")
    res = subprocess.run([sys.executable, "-m", "gearsym.cli", "simulate", str(path), "--periods", "1"],
                         capture_output=True, text=True, cwd=tmp_path,
                         env={"GEARSYM_GENERATED": str(tmp_path / "builds"), "PATH": "/usr/bin:/bin",
                              "PYTHONPATH": str(REPO)})
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "field 'initial.static'" in lines[0] and res.stdout == ""
    assert "do not balance along a rigid-body mode (the coordinates a, c)" in lines[0]
