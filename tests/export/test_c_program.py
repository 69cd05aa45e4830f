"""The exported standalone C program (built with the scikit-sundae wheel's SUNDIALS, run
without Python) against System.simulate: same trajectory, same events, same outputs."""

from __future__ import annotations

import re

import numpy as np
import pytest

REGIMES = {"no_impact": {"Omega": 0.6}, "single_sided": {"Omega": 0.9},
           "double_sided": {"Omega": 0.8, "Fa": 0.6}}


def _read(path):
    return np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")


@pytest.mark.parametrize("regime", list(REGIMES))
def test_ks_program_matches_system_simulate(ks, tmp_path, regime):
    params = REGIMES[regime]
    settings = [f"{k}={v!r}" for k, v in params.items()]
    proc = ks.run(*settings, "periods=200", "n_out=201", "rtol=1e-10", "atol=1e-12",
                  "--out", str(tmp_path / "run.csv"))
    assert proc.returncode == 0, proc.stderr
    ref = ks.system.simulate(periods=200, n_out=201, rtol=1e-10, atol=1e-12, params=params)
    got = _read(tmp_path / "run.csv")
    assert got.dtype.names == ("t", "x", "v")
    np.testing.assert_allclose(got["t"], ref.t, rtol=1e-15, atol=0)
    err = max(np.abs(got["x"] - ref.y[:, 0]).max(), np.abs(got["v"] - ref.y[:, 1]).max())
    assert err < 1e-7
    ev = _read(tmp_path / "run_events.csv")
    ev = np.atleast_1d(ev) if ev.size else []
    assert len(ev) == len(ref.events)
    if len(ref.events):
        np.testing.assert_allclose(ev["t"], [e.t for e in ref.events], rtol=0, atol=1e-7)
        assert list(ev["surface"]) == [e.surface for e in ref.events]
        assert list(ev["direction"]) == [e.direction for e in ref.events]
    if regime == "no_impact":
        assert len(ref.events) == 0
    else:
        assert len(ref.events) > 100


def test_ks_program_defaults_are_the_scenes(ks):
    # no settings: the scene's parameters, initial state, periods, rtol/atol, points per period
    proc = ks.run()
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    ref = ks.system.simulate(rtol=1e-8, atol=1e-10)  # scene: 200 periods x 64 points, rtol 1e-8
    assert len(lines) == len(ref.t) + 1 == 200 * 64 + 2
    last = np.array([float(v) for v in lines[-1].split(",")])
    np.testing.assert_allclose(last[0], ref.t[-1], rtol=1e-15)
    assert np.abs(last[1:] - ref.y[-1]).max() < 1e-7


def test_settings_file_and_stdout(ks, tmp_path):
    f = tmp_path / "p.txt"
    f.write_text("# regime\nOmega = 0.9   # single-sided\nperiods=3\n\nn_out=7\nx=1.0\n")
    proc = ks.run("--file", str(f), "v=0.1")
    assert proc.returncode == 0, proc.stderr
    ref = ks.system.simulate(periods=3, n_out=7, x0=[1.0, 0.1], params={"Omega": 0.9}, rtol=1e-8, atol=1e-10)
    rows = np.array([[float(v) for v in ln.split(",")] for ln in proc.stdout.strip().splitlines()[1:]])
    assert rows.shape == (7, 3)
    assert np.abs(rows[:, 1:] - ref.y).max() < 1e-7


def test_schedules_program_matches(vs, tmp_path):
    # rectangular mesh stiffness and friction reversal: breakpoints inside the driver
    proc = vs.run("periods=10", "rtol=1e-10", "atol=1e-15", "--out", str(tmp_path / "vs.csv"))
    assert proc.returncode == 0, proc.stderr
    ref = vs.system.simulate(periods=10, rtol=1e-10, atol=1e-15)
    assert int(re.search(r"(\d+) breakpoints", proc.stderr).group(1)) == ref.stats["n_breaks"]
    got = _read(tmp_path / "vs.csv")
    scale = np.abs(ref.y).max(axis=0)
    for i, name in enumerate(vs.system.state_names):
        assert np.abs(got[name] - ref.y[:, i]).max() < 1e-7 * scale[i]
    assert ref.stats["n_breaks"] > 20


def test_bound_function_recorded_and_outputs(yu, tmp_path):
    # wm_mean_height(D, G, ...) is evaluated at export; the outputs are generated C
    proc = yu.run("periods=20", "--out", str(tmp_path / "yu.csv"))
    assert proc.returncode == 0, proc.stderr
    ref = yu.system.simulate(periods=20, rtol=1e-8, atol=1e-14)
    got = _read(tmp_path / "yu.csv")
    assert got.dtype.names[-2:] == ("backlash_B", "mesh_force")
    scale = np.abs(ref.y).max(axis=0)
    for i, name in enumerate(yu.system.state_names):
        assert np.abs(got[name] - ref.y[:, i]).max() < 1e-7 * scale[i]
    outs = yu.system.outputs(ref)
    for name, vals in outs.items():
        assert np.abs(got[name] - vals).max() < 1e-7 * np.abs(vals).max()
    listing = yu.run("--list").stdout
    assert "wm_mean_height(D = 1.4" in listing
    readme = (yu.c_dir / "README.md").read_text()
    assert "evaluated by gearsym" in readme and "wm_mean_height" in readme


@pytest.mark.parametrize("args, message", [
    (["D=1.5"], "D is fixed: argument of wm_mean_height"),
    (["wm_mean_height_D_G_lam_L_c_l_a=1e-7"], "was evaluated by gearsym at export time"),
    (["nonsense=1"], "unknown name 'nonsense'"),
    (["Omega=abc"], "not a finite number"),
    (["Omega"], "expected NAME=VALUE"),
    (["rtol=0"], "rtol must be"),
    (["method=rk4"], "method must be"),
    (["--file", "/nonexistent/params.txt"], "cannot read /nonexistent/params.txt"),
    (["--bogus"], "unknown option '--bogus'"),
])
def test_program_bad_arguments_exit_2(yu, args, message):
    proc = yu.run(*args)
    assert proc.returncode == 2
    assert message in proc.stderr
    assert proc.stdout == "" or "usage" in proc.stderr


def test_program_same_value_of_a_fixed_argument_is_accepted(yu):
    proc = yu.run("D=1.4", "periods=0.5", "n_out=2")
    assert proc.returncode == 0, proc.stderr


def test_integration_failure_exit_1(ks):
    proc = ks.run("max_steps=10")
    assert proc.returncode == 1
    assert "integration failed" in proc.stderr and "max_steps" in proc.stderr
