"""``gearsym stiffness`` (issue 27 item 3): prints, ``--json``, ``--out`` (CSV, JSON, PNG), units on
the command line, exit 2 naming the parameter for bad geometry, a missing ``plots`` extra named."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from gearsym.cli import main
from gearsym.gears import Gear, GearPair, mesh_stiffness

YU = ["stiffness", "--z1", "50", "--z2", "50", "--module", "3", "--face-width", "20"]


def run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


def test_prints_the_summary(capsys):
    rc, out, err = run(YU, capsys)
    assert rc == 0 and err == ""
    assert "contact ratio 1.754673" in out
    assert "phase [0.0000, 0.7547]: 2 pairs in contact" in out and "phase [0.7547, 1.0000]: 1 pair in contact" in out
    assert "mean 4.39012e+08 N/m" in out
    assert "c_gamma_alpha = 22.009 N/(mm um) -> 4.40187e+08 N/m" in out


def test_json_equals_the_python_api(capsys):
    rc, out, err = run([*YU, "--samples", "32", "--json", "--poisson", "0.3", "--youngs", "206GPa"], capsys)
    assert rc == 0
    d = json.loads(out)
    ref = mesh_stiffness(GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3), samples=32)
    assert d["contact_ratio"] == ref.contact_ratio
    assert d["mean_N_per_m"] == ref.mean
    assert d["stiffness_N_per_m"] == ref.stiffness.tolist()
    assert d["iso6336"]["mesh_stiffness_N_per_m"] == ref.iso.mesh_stiffness
    assert d["line_load_N_per_mm"] is None and d["files"] == []


@pytest.mark.parametrize("argv_units", [
    ["--module", "0.003m", "--face-width", "2cm"],
    ["--module", "3 mm", "--face-width", "20mm", "--youngs", "2.06e11Pa"],
    ["--module", "3e-3 m", "--face-width", "0.02m", "--youngs", "206000MPa", "--bore", "35.625mm"],
])
def test_units_on_the_command_line(argv_units, capsys):
    base = ["stiffness", "--z1", "50", "--z2", "50", "--samples", "16", "--json"]
    rc, out, _ = run([*base, *argv_units], capsys)
    assert rc == 0
    rc, ref, _ = run([*base, "--module", "3", "--face-width", "20"], capsys)
    assert json.loads(out)["mean_N_per_m"] == pytest.approx(json.loads(ref)["mean_N_per_m"], rel=1e-14)


def test_per_gear_options_and_torque(capsys):
    argv = ["stiffness", "--z1", "19", "--z2", "48", "--module", "3.2", "--face-width", "16", "--profile-shift",
            "0.3,-0.1", "--youngs", "210,110", "--poisson", "0.29,0.34", "--bore", "12,30", "--torque", "20",
            "--samples", "16", "--json"]
    rc, out, _ = run(argv, capsys)
    assert rc == 0
    d = json.loads(out)
    pair = GearPair(module=3.2e-3, face_width=16e-3,
                    pinion=Gear(19, profile_shift=0.3, youngs_modulus=2.1e11, poisson=0.29, bore_radius=0.012),
                    wheel=Gear(48, profile_shift=-0.1, youngs_modulus=1.1e11, poisson=0.34, bore_radius=0.03))
    line_load = 20 / (3.2e-3 * 19 / 2) / 16  # F_t / b in N/mm: 41 N/mm, below 100
    ref = mesh_stiffness(pair, samples=16, line_load=line_load)
    assert d["line_load_N_per_mm"] == pytest.approx(line_load, rel=1e-14)
    assert d["iso6336"]["factors"]["load"] == pytest.approx((line_load / 100) ** 0.25, rel=1e-14)
    assert d["mean_N_per_m"] == pytest.approx(ref.mean, rel=1e-14)
    assert d["iso6336"]["mesh_stiffness_N_per_m"] == pytest.approx(ref.iso.mesh_stiffness, rel=1e-14)


def test_out_writes_csv_json_png(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "tvms"
    rc, text, err = run([*YU, "--samples", "50", "--out", str(out)], capsys)
    assert rc == 0, err
    assert {p.name for p in out.iterdir()} == {"stiffness.csv", "stiffness.json", "stiffness.png"}
    with open(out / "stiffness.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["mesh_phase", "stiffness_N_per_m", "pairs_in_contact"]
    phase = np.array([float(r[0]) for r in rows[1:]])
    k = np.array([float(r[1]) for r in rows[1:]])
    ref = mesh_stiffness(GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3), samples=50)
    assert np.array_equal(phase, np.arange(50) / 50) and np.array_equal(k, ref.stiffness)  # repr: exact
    assert json.loads((out / "stiffness.json").read_text())["mean_N_per_m"] == ref.mean
    assert (out / "stiffness.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {out / 'stiffness.png'}" in text


@pytest.mark.parametrize("extra, needles", [
    (["--z1", "12"], ["x1=0", "undercut", "z1=12"]),
    (["--profile-shift", "1.5,0", "--z1", "12"], ["x1=1.5", "pointed tooth"]),
    (["--addendum", "0.4"], ["contact ratio", "< 1"]),
    (["--z1", "30", "--profile-shift", "0.8"], ["interference"]),
    (["--centre-distance", "149"], ["centre_distance=0.149", "tight-mesh"]),
    (["--module", "3kg"], ["--module", "'kg' is not a unit of length"]),
    (["--face-width", "wide"], ["--face-width", "'wide' is not a number with a unit"]),
    (["--youngs", "2.06e11"], ["--youngs", "not a plausible Young's modulus", "GPa"]),
    (["--poisson", "0.3,0.3,0.3"], ["--poisson", "one value (both gears) or two"]),
    (["--profile-shift", "nan"], ["--profile-shift", "non-finite"]),
    (["--samples", "1"], ["--samples", "[2, 100,000]"]),
    (["--torque", "-5"], ["--torque must be positive"]),
    (["--pressure-angle", "60"], ["pressure_angle_deg must be < 45"]),
    (["--bore", "80"], ["bore1=0.08 m", "root radius"]),
])
def test_bad_input_exits_2_naming_the_parameter(extra, needles, tmp_path, capsys):
    out = tmp_path / "out"
    rc, text, err = run([*YU, *extra, "--out", str(out)], capsys)
    assert rc == 2 and text == ""
    assert err.startswith("gearsym: error: ") and err.count("\n") == 1
    for n in needles:
        assert n in err, (n, err)
    assert not out.exists()  # nothing written


def test_missing_plots_extra_is_named_before_any_work(tmp_path, capsys, monkeypatch):
    import gearsym.extras as extras

    monkeypatch.setattr(extras, "_installed", lambda m: m != "matplotlib")
    rc, text, err = run([*YU, "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and text == ""
    assert "gearsym[plots]" in err and "matplotlib" in err and "stiffness" in err
    assert not (tmp_path / "o").exists()
    from gearsym.errors import GearsymError
    from gearsym.gears.report import plot_mesh_stiffness

    res = mesh_stiffness(GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3), samples=8)
    with pytest.raises(GearsymError, match=r"gearsym\[plots\]"):
        plot_mesh_stiffness(res, tmp_path / "k.png")
    assert not (tmp_path / "k.png").exists()


def test_help_has_examples(capsys):
    with pytest.raises(SystemExit) as info:
        main(["stiffness", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "Examples:" in out and "gearsym stiffness --z1 50 --z2 50 --module 3 --face-width 20" in out
    assert math.isfinite(len(out))
