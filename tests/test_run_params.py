"""A run's parameters reach the evaluations made from its trajectory (outputs, rattle states,
mesh deflections), including the value of a bound function whose inputs the run changed.

Regression: ``gearsym simulate`` on every Yu scene exited 2 ("'wm_mean_height(D, G, lam, L_c,
l_a)' is not a run-time parameter") since the mesh report, and ``System.outputs`` of a run with
``params={"D": 1.2}`` evaluated the backlash with the system's own D (its bound value).
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.cli import main as cli_main
from gearsym.fractal import wm_mean_height

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "yu_constant_backlash.toml"


@pytest.fixture(scope="module")
def system():
    return gearsym.load_scene(SCENE).compile()


def test_outputs_use_the_runs_bound_value(system):
    tr = system.simulate(periods=3, params={"D": 1.2})
    B = system.outputs(tr)["backlash_B"]
    # constant backlash: B = b_0 - 2 b_i(D) (eq. 5), here with the run's D = 1.2, not the scene's 1.4
    expected = 20e-6 - 2 * wm_mean_height(1.2, 1e-11, 1.5, 150e-6, 100e-6)
    assert np.allclose(B, expected, rtol=1e-12, atol=0)
    assert abs(expected - (20e-6 - 2 * wm_mean_height(1.4, 1e-11, 1.5, 150e-6, 100e-6))) > 5e-6


def test_run_vector_is_the_inverse_of_param_dict(system):
    p = system.param_vector({"D": 1.2, "b_0": 25.0})
    assert np.array_equal(system.run_vector(system.param_dict(p)), p)


def test_cli_simulate_on_a_model_with_a_bound_function():
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli_main(["simulate", str(SCENE), "--set", "D=1.2", "--periods", "2", "--json"])
    assert rc == 0, err.getvalue()
    assert json.loads(out.getvalue())["meshes"]["mesh"]["rattle_state"] in (0, 1, 2)


def test_gear_quantities_of_a_run_use_its_bound_value():
    """The gear quantities of a run at D = 1.2 of the D = 1.4 scene equal those of the D = 1.2
    scene (the run's backlash and its static equilibrium at the run's D; before, they used the
    system's own D for the static deflection and the flanks)."""
    own = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D12.toml").compile()
    other = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml").compile()
    ref = own.simulate(periods=8).gear_quantities()
    run = other.simulate(periods=8, params={"D": 1.2})
    assert run.inputs == {"D": 1.2}
    got = run.gear_quantities()
    for key in ("static_deflection", "static_force", "dte_mean", "dte_rms", "dte_peak_to_peak", "force_mean",
                "dynamic_factor", "contact_loss_ratio", "back_contact_ratio"):
        a, b = getattr(ref.meshes["mesh"], key), getattr(got.meshes["mesh"], key)
        assert a == pytest.approx(b, rel=1e-9, abs=1e-15), (key, a, b)
