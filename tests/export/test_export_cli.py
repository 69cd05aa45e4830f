"""`gearsym export` from the command line: success, bad input (exit 2, one line, no
traceback, nothing written), a model feature the FMU cannot carry, and the Makefile's
refusal of SUNDIALS 6."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.cli import main

from .conftest import ROOT, make, scene_path

KS = str(scene_path("kahraman_singh"))


def run_cli(args, cwd: Path, gen: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    if gen is not None:
        env["GEARSYM_GENERATED"] = str(gen)
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=600)


def assert_bad_input(r: subprocess.CompletedProcess, *needles: str) -> None:
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gearsym: error: "), r.stderr
    assert "Traceback" not in r.stderr and r.stdout == ""
    for n in needles:
        assert n in r.stderr, r.stderr


def main_bad_input(capsys, args, *needles: str) -> None:
    """``gearsym.cli.main(args)`` in this process (no interpreter start-up per case)."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert_bad_input(subprocess.CompletedProcess(args, code, out, err), *needles)


def test_export_json(tmp_path, capsys):
    r = run_cli(["export", KS, "--c", tmp_path / "ks_c", "--fmu", tmp_path / "out" / "ks.fmu", "--json"],
                tmp_path)
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    assert info["scene"] == "kahraman_singh" and info["fmu"]["n_states"] == 2
    assert info["fmu"]["n_event_indicators"] == 2 and info["fmu"]["model_identifier"] == "kahraman_singh"
    assert (tmp_path / "out" / "ks.fmu").is_file()
    for f in ("main.c", "gs_driver.c", "gs_model.c", "sundials7.h", "Makefile", "README.md", "find_sundials.sh"):
        assert (tmp_path / "ks_c" / f).is_file(), f
    # an existing non-empty folder / file is refused without --force, accepted with it
    before = sorted(p.name for p in (tmp_path / "ks_c").iterdir())
    main_bad_input(capsys, ["export", KS, "--c", tmp_path / "ks_c"], "exists and is not empty", "--force")
    main_bad_input(capsys, ["export", KS, "--fmu", tmp_path / "out" / "ks.fmu"], "exists", "--force")
    assert sorted(p.name for p in (tmp_path / "ks_c").iterdir()) == before
    assert main(["export", KS, "--c", str(tmp_path / "ks_c"), "--force"]) == 0


@pytest.mark.parametrize("case", ["unknown_scene", "c_under_a_file", "fmu_under_a_file", "fmu_suffix",
                                  "nothing", "c_is_a_file", "unknown_parameter"])
def test_bad_input(tmp_path, capsys, case):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    args, needles = {
        "unknown_scene": (["export", tmp_path / "nope.toml", "--c", tmp_path / "d"], ["nope.toml"]),
        "c_under_a_file": (["export", KS, "--c", blocker / "d"], ["--c", "is not a folder"]),
        "fmu_under_a_file": (["export", KS, "--fmu", blocker / "m.fmu"], ["--fmu", "is not a folder"]),
        "fmu_suffix": (["export", KS, "--fmu", tmp_path / "m.zip"], ["must end with .fmu"]),
        "nothing": (["export", KS], ["--c DIR", "--fmu"]),
        "c_is_a_file": (["export", KS, "--c", blocker], ["is not a folder"]),
        "unknown_parameter": (["export", KS, "--set", "Omegaa=1", "--c", tmp_path / "d"], ["Omegaa"]),
    }[case]
    before = sorted(p.name for p in tmp_path.iterdir())
    main_bad_input(capsys, args, *needles)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def _implicit_scene(tmp_path: Path) -> Path:
    """The dimensional spur pair in implicit (mass-matrix) form, without reduction."""
    text = (ROOT / "models" / "spur_pair_torsional.toml").read_text()
    text = text[: text.index("[reduction]")] + "[initial]\nth1 = 0.0\nth2 = 0.0\n"
    text = text.replace('time_unit = "s"', 'time_unit = "s"\nform = "implicit"')
    (tmp_path / "pair.toml").write_text(text)
    scene = tmp_path / "pair_scene.toml"
    scene.write_text('[scene]\nname = "pair_implicit"\nmodel = "pair.toml"\n')
    return scene


def test_implicit_model_fmu_refused_c_program_uses_ida(tmp_path, capsys, monkeypatch):
    scene = _implicit_scene(tmp_path)
    gen = tmp_path / "gen"
    monkeypatch.setenv("GEARSYM_GENERATED", str(gen))
    main_bad_input(capsys, ["export", scene, "--fmu", tmp_path / "pair.fmu"], "implicit (mass-matrix) form",
                   "--c")
    assert not (tmp_path / "pair.fmu").exists()
    assert main(["export", str(scene), "--c", str(tmp_path / "pair_c")]) == 0
    assert make(tmp_path / "pair_c").returncode == 0
    system = gearsym.load_scene(scene).compile(generated_dir=gen)
    p = system.units.to_si(system.params)  # the C program takes SI
    b_m = p["b_m"]
    x0 = [1.2 * b_m / p["rb1"], 0.0, 0.3, 0.0]
    proc = subprocess.run([str(tmp_path / "pair_c" / "pair_implicit"), "periods=5", "n_out=51", "rtol=1e-10",
                           "atol=1e-13", *(f"{s}={v!r}" for s, v in zip(system.state_names, x0)),
                           "--out", str(tmp_path / "pair.csv")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    ref = system.simulate(periods=5, n_out=51, rtol=1e-10, atol=1e-13, x0=x0)
    got = np.genfromtxt(tmp_path / "pair.csv", delimiter=",", names=True)
    assert len(ref.events) > 0
    for i, s in enumerate(system.state_names):
        assert np.abs(got[s] - ref.y[:, i]).max() <= 1e-7 * np.abs(ref.y[:, i]).max()


def _fake_sundials(root: Path, major: int, index64: bool = False, core: bool = True) -> Path:
    """A SUNDIALS install tree with a config header and empty library files."""
    (root / "include" / "sundials").mkdir(parents=True)
    (root / "include" / "sundials" / "sundials_config.h").write_text(
        f'#define SUNDIALS_VERSION "{major}.4.1"\n#define SUNDIALS_VERSION_MAJOR {major}\n'
        f"#define SUNDIALS_DOUBLE_PRECISION 1\n#define SUNDIALS_INT{64 if index64 else 32}_T 1\n")
    (root / "lib").mkdir()
    for stem in ("cvode", "ida", "sunlinsoldense", "sunmatrixdense", "nvecserial") + (("core",) if core else ()):
        (root / "lib" / f"libsundials_{stem}.so.{major}.4.1").write_text("")
    return root


@pytest.mark.parametrize("kind, message", [
    ("v6", "SUNDIALS 6.4.1"), ("index64", "64-bit sunindextype"), ("no_core", "no libsundials_core")])
def test_makefile_refuses_unusable_sundials(ks, tmp_path, kind, message):
    project = tmp_path / "ks_c"
    shutil.copytree(ks.c_dir, project, ignore=shutil.ignore_patterns(ks.program.name, "*.csv"))
    if kind == "no_core":
        fake = _fake_sundials(tmp_path / "sd", 6, core=False)
        r = make(project, f"SUNDIALS_LIBDIR={fake / 'lib'}")
    else:
        fake = _fake_sundials(tmp_path / "sd", 6 if kind == "v6" else 7, index64=kind == "index64")
        r = make(project, f"SUNDIALS_DIR={fake}")
    assert r.returncode != 0
    assert message in r.stderr, r.stderr
    assert "needs SUNDIALS >= 7" in r.stderr or "32-bit" in r.stderr
    assert not (project / ks.program.name).exists()
