"""The gearsym command line: JSON output, files, exit codes, no tracebacks on bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
KS = str(ROOT / "scenes" / "kahraman_singh.toml")


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=300)


def test_help_lists_commands():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("inspect", "compile", "simulate"):
        assert cmd in r.stdout


def test_inspect_json_fields():
    r = run("inspect", KS, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["model"] == "kahraman_singh"
    assert info["states"] == ["x", "v"]
    assert info["parameters"]["Omega"]["value"] == 0.9
    assert {"backlash", "mesh_stiffness_variation", "static_transmission_error"} <= set(info["effects"])
    assert [s["name"] for s in info["switching_functions"]] == ["mesh.drive", "mesh.back"]
    assert [m["name"] for m in info["modes"]] == ["mesh: drive-side contact", "mesh: separation",
                                                  "mesh: back-side contact"]
    for key in ("breakpoints", "equations", "dimensionless_groups"):
        assert key in info


def test_inspect_model_file_with_latex():
    r = run("inspect", str(ROOT / "models" / "spur_pair_torsional.toml"), "--latex")
    assert r.returncode == 0, r.stderr
    assert "dimensionless form" in r.stdout and "zeta = " in r.stdout and "\\begin{aligned}" in r.stdout


def test_compile_json_reports_cost_and_drops_with_effects():
    full = json.loads(run("compile", KS, "--json").stdout)
    lean = json.loads(run("compile", KS, "--json", "--no-effect", "backlash").stdout)
    for key in ("n_states", "n_params", "n_ops", "n_switching_functions", "effects"):
        assert key in full
    assert full["n_states"] == 2 and full["n_switching_functions"] == 2
    assert lean["n_switching_functions"] == 0 and lean["n_params"] == full["n_params"] - 1
    assert lean["n_ops"] < full["n_ops"]


def test_simulate_json_and_out(tmp_path):
    r = run("simulate", KS, "--set", "Omega=0.8", "--periods", "20", "--json", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    for key in ("state_names", "final_state", "n_steps", "n_rhs", "n_events", "wall_s"):
        assert key in info
    assert info["params"]["Omega"] == 0.8
    data = np.load(tmp_path / "trajectory.npz")
    np.testing.assert_allclose(data["y"][-1], info["final_state"])
    for f in ("time_history.png", "phase_portrait.png", "poincare.png", "spectrum.png"):
        assert (tmp_path / f).stat().st_size > 1000


@pytest.mark.parametrize("args,needle", [
    (["simulate", "nope.toml"], "scene file not found"),
    (["simulate", KS, "--set", "Omega"], "--set expects NAME=VALUE"),
    (["simulate", KS, "--set", "Omega=abc"], "not a number"),
    (["simulate", KS, "--set", "Omegaa=1"], "unknown parameter 'Omegaa'"),
    (["simulate", KS, "--effect", "friction"], "effect 'friction' is not in model"),
    (["simulate", KS, "--no-effect", "mesh_stiffness_variation", "--set", "eps=0.3"],
     "switched-off effect"),
    (["simulate", KS, "--rtol", "-1"], "tolerances must be positive"),
    (["simulate", KS, "--rtol", "1e-20"], "below what double precision"),
    (["simulate", KS, "--x0", "1,2,3"], "x0 must have 2 entries"),
    (["inspect", str(ROOT / "Makefile")], "TOML syntax error"),
])
def test_bad_input_exit_2_without_traceback(args, needle):
    r = run(*args)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert needle in r.stderr
    assert "Traceback" not in r.stderr
    assert r.stdout == ""


def test_numerical_failure_exit_1(tmp_path):
    # too few steps allowed: a SimulationError, reported without a traceback (500 steps pass the
    # up-front budget of 8 steps per period for 50 periods, but the integration needs more)
    scene = tmp_path / "s.toml"
    scene.write_text(Path(KS).read_text().replace('model = "../models/kahraman_singh.toml"',
                                                   f'model = "{ROOT / "models" / "kahraman_singh.toml"}"')
                     .replace("points_per_period = 64", "points_per_period = 64\nmax_steps = 500"))
    r = run("simulate", str(scene), "--periods", "50")
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "gearsym: error" in r.stderr
    assert "--max-steps" in r.stderr  # the way out is named
