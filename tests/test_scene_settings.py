"""One scene, one answer: the command line and the Python API resolve a scene's settings tables
(``[simulate]``, ``[orbit]``, ``[continue]``, ``[map]``) in one place (issue 24, item 6:
``System.simulate()`` took the scene's ``periods`` but not its ``rtol`` / ``atol``, so Python and
the CLI gave different trajectories)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis.continuation import continuation
from gearsym.analysis.sweeps import stability_map
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]
KS_MODEL = ROOT / "models" / "kahraman_singh.toml"

#: every [simulate] setting away from its default (method, tolerances, horizon, output grid)
SETTINGS = """
[simulate]
periods = 7
rtol = 1e-9
atol = 1e-11
points_per_period = 16
method = "bdf"
transient_periods = 3

[orbit]
segments = 2
transient = 20
rtol = 1e-9
atol = 1e-11
tol = 1e-8

[continue]
max_points = 3
ds_max = 0.004
rtol = 1e-9

[map]
quantity = "rattle_state"
method = "shooting"
"""


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("settings")
    s = d / "ks_settings.toml"
    s.write_text(f'[scene]\nname = "ks_settings"\nmodel = "{KS_MODEL}"\n[initial]\nx = 1.1\n{SETTINGS}')
    return s


@pytest.fixture(scope="module")
def system(scene_file):
    return gearsym.load_scene(scene_file).compile()


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    src = str(Path(gearsym.__file__).resolve().parents[1])  # the gearsym under test
    env = dict(os.environ, PYTHONPATH=src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600)


def test_simulate_cli_and_api_agree_bit_for_bit(scene_file, system, tmp_path):
    r = _cli("simulate", str(scene_file), "--json", "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    with np.load(tmp_path / "out" / "trajectory.npz") as f:
        t_cli, y_cli = f["t"], f["y"]
    traj = system.simulate()  # no argument: the scene's settings, as the command line
    assert np.array_equal(traj.t, t_cli) and np.array_equal(traj.y, y_cli)
    assert info["n_steps"] == traj.stats["n_steps"] and info["final_state"] == traj.final_state.tolist()
    # and they are the scene's settings, not the defaults
    T = 2 * np.pi / 0.9
    assert t_cli.size == 7 * 16 + 1 and t_cli[-1] == pytest.approx(7 * T, rel=1e-14)
    assert (info["rtol"], info["atol"], info["method"]) == (1e-9, 1e-11, "bdf")
    assert traj.settings["rtol"] == 1e-9 and traj.settings["atol"] == 1e-11 and traj.settings["method"] == "bdf"
    # max/min summarise the run after the scene's transient_periods
    assert info["steady_from"] == pytest.approx(3 * T, rel=1e-12)
    steady = y_cli[t_cli >= 3 * T - 1e-9 * T, 0]
    assert info["max"] == steady.max() and info["min"] == steady.min()


def test_a_keyword_overrides_the_scene(system):
    a = system.simulate(periods=2, rtol=1e-7, method="adams")
    assert a.settings["rtol"] == 1e-7 and a.settings["atol"] == 1e-11 and a.settings["method"] == "adams"
    assert a.t.size == 2 * 16 + 1


def test_orbit_cli_and_api_agree(scene_file, system, tmp_path):
    r = _cli("orbit", str(scene_file), "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    orbit = system.periodic_orbit()
    assert (info["segments"], info["rtol"], info["atol"], info["tol"]) == (2, 1e-9, 1e-11, 1e-8)
    assert info["x0"] == orbit.x0.tolist() and info["iterations"] == orbit.iterations


def test_continue_and_map_use_the_scene_tables(system):
    branch = continuation(system, "Omega", 0.9, 0.95, progress=False)
    assert len(branch.points) == 3 and branch.info["rtol"] == 1e-9  # max_points, rtol of [continue]
    ds = stability_map(system, ("Omega", 0.9, 0.95, 2), ("Fm", 0.1, 0.1, 1), workers=1)
    assert ds.attrs["quantity"] == "rattle_state" and ds.attrs["methods_used"] == "shooting"


def test_resolution_order():
    from gearsym.spec.settings import resolve_settings

    scene = {"rtol": 1e-9, "method": "bdf"}
    s = resolve_settings("simulate", scene, rtol=None, atol=None, method="adams")
    assert (s["rtol"], s["atol"], s["method"], s["points_per_period"]) == (1e-9, 1e-10, "adams", 64)
    o = resolve_settings("orbit", {"harmonics": 8, "segments": 3}, method="hbm")
    assert o["harmonics"] == 8 and o["segments"] is None  # the scene's shooting setting does not apply to hbm
    with pytest.raises(ParameterError, match="segments applies to method 'shooting', not 'hbm'"):
        resolve_settings("orbit", {}, method="hbm", segments=2)
