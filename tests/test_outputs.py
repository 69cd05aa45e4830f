"""Model [outputs]: quantities evaluated along trajectories (yu_6dof's dynamic backlash B(t))."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.errors import SpecError

ROOT = Path(__file__).resolve().parents[1]


def test_dynamic_backlash_output_matches_hand_formula():
    """B = b_s + (a - a0)*sqrt(1 - kappa^2) with a, kappa recomputed from the translations."""
    scene = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml",
                               effects={"fractal_backlash": False})
    system = scene.compile()
    traj = system.simulate(periods=10, rtol=1e-9, atol=1e-14)
    B = system.outputs(traj)["backlash_B"]
    v = scene.resolved.values
    a0 = v["R_p"] + v["R_g"]
    a_b = a0 * math.cos(v["alpha0"])
    R_pb = v["R_p"] * math.cos(v["alpha0"])
    u = traj["xp"] - traj["xg"]
    w = traj["yp"] - traj["yg"]
    a = np.sqrt((a0 - u) ** 2 + w**2)
    kappa = R_pb * (a + a0) / (2 * a_b**2)
    hand = v["b_0"] + (a - a0) * np.sqrt(np.maximum(0.0, 1 - kappa**2))
    # a - a0 cancels: round-off ~ 1e-16 m * a0/(a - a0) is the floor
    np.testing.assert_allclose(B, hand, rtol=1e-10, atol=1e-15)
    assert np.ptp(B) > 1e-7  # it really moves with the centres


def test_constant_backlash_output_is_constant():
    scene = gearsym.load_scene(ROOT / "scenes" / "yu_constant_backlash.toml",
                               effects={"fractal_backlash": False})
    system = scene.compile()
    traj = system.simulate(periods=5)
    B = system.outputs(traj)["backlash_B"]
    assert np.all(B == pytest.approx(scene.resolved.values["b_0"], rel=1e-15))


def test_output_on_a_reduced_away_coordinate_is_an_error(tmp_path):
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text += '\n[outputs]\nangle = { value = "th2", unit = "rad" }\n'
    model = tmp_path / "m.toml"
    model.write_text(text)
    scene = tmp_path / "s.toml"
    scene.write_text('[scene]\nname = "s"\nmodel = "m.toml"\n')
    with pytest.raises(SpecError, match="output 'angle' uses th2") as info:
        _ = gearsym.load_scene(scene).model
    assert info.value.field == "outputs.angle"


def test_output_unit_mismatch(tmp_path):
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text += '\n[outputs]\nforce = { value = "k_m*x", unit = "m" }\n'
    model = tmp_path / "m.toml"
    model.write_text(text)
    with pytest.raises(SpecError, match="unit mismatch") as info:
        gearsym.spec.load_model(model)
    assert info.value.field == "outputs.force.value"
