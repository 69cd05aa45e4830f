"""Tables in the spec layer (issue 27): reading, checking and evaluating them.

Bad tables are bad input: a :class:`~gearsym.errors.SpecError` naming the file, the row and the
column (exit 2 on the command line), before anything is compiled; no NaN or infinity reaches
the equations.  The interpolants equal numpy's and scipy's.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from gearsym.errors import SpecError
from gearsym.spec.model import load_model

MODEL = '''[model]
name = "tp"
[coordinates.x]
unit = "m"
velocity = "v"
[parameters]
m = { value = 0.5, unit = "kg" }
T_m = { value = 1e-3, unit = "s" }
T = { value = 200.0, unit = "N*m" }
[schedules.mesh]
period = "T_m"
[forcing]
period = "T_m"
[elements.mass]
type = "inertia"
coordinate = "x"
value = "m"
[elements.spring]
type = "spring"
deflection = "x"
stiffness = "STIFFNESS"
[tables.k]
TABLE
'''

CSV_TABLE = 'unit = "N/m"\ndomain = "phase"\nfile = "k.csv"'
GOOD_CSV = "mesh_phase,stiffness\n0.0,1e8\n0.25,1.2e8\n0.5,0.9e8\n0.75,1.1e8\n"


def write(folder: Path, table: str = CSV_TABLE, csv: str | None = GOOD_CSV, stiffness: str = "k(mesh_phase)",
          extra: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    if csv is not None:
        (folder / "k.csv").write_text(csv)
    p = folder / "m.toml"
    p.write_text(MODEL.replace("STIFFNESS", stiffness).replace("TABLE", table) + extra)
    return p


def spec_error(path: Path) -> str:
    with pytest.raises(SpecError) as info:
        load_model(path)
    return str(info.value)


def test_a_good_csv_table_reads_and_evaluates_like_numpy(tmp_path):
    spec = load_model(write(tmp_path))
    t = spec.tables["k"]
    assert t.axes[0].knots == (0.0, 0.25, 0.5, 0.75) and t.period == 1.0
    q = np.linspace(-1.3, 2.7, 301)
    assert np.allclose(t(q), np.interp(q, [0, 0.25, 0.5, 0.75], [1e8, 1.2e8, 0.9e8, 1.1e8], period=1.0),
                       rtol=1e-15, atol=0)


@pytest.mark.parametrize("csv, needles", [
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,1.2e8,7\n", ["k.csv", "row 3 has 3 cells", "header (row 1) has 2"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,abc\n", ["k.csv", "row 3, column 2 ('stiffness')", "'abc' is not a number"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,nan\n", ["k.csv", "row 3, column 2", "'nan' is not a number"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,inf\n", ["k.csv", "row 3, column 2", "'inf' is not a number"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,1e999\n", ["k.csv", "row 3, column 2", "not a finite number"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.25,\n", ["k.csv", "row 3, column 2", "empty cell"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0.5,1.2e8\n0.25,0.9e8\n", ["k.csv", "row 4, column 1 ('mesh_phase')",
                                                                "must increase"]),
    ("mesh_phase,stiffness\n0.0,1e8\n0x10,1.2e8\n", ["k.csv", "row 3, column 1", "'0x10' is not a number"]),
    ("mesh_phase,stiffness\n0.0,1e8\n\n0.5,1.2e8\n", ["k.csv", "row 3 is empty"]),
    ("mesh_phase,stiffness\n", ["k.csv", "header row and at least one row"]),
    ("mesh_phase,stiffness\n0.0,1e8\n1.5,1e8\n", ["k.csv", "row 3, column 1", "the knots lie in [0, 1]"]),
    ('mesh_phase,stiffness\n0.0,"1e8\n', ["k.csv", "row"]),
])
def test_bad_csv_names_file_row_and_column(tmp_path, csv, needles):
    msg = spec_error(write(tmp_path, csv=csv))
    for n in needles:
        assert n in msg, msg


@pytest.mark.parametrize("table, needles", [
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5, 0.25]\nvalues = [1e8, 2e8, 3e8]',
     ["m.toml", "tables.k", "x[2] (row 3)", "must increase"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, nan]', ["tables.k.values[1]", "non-finite"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8]', ["tables.k.values", "one entry per knot"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, "a"]', ["tables.k.values[1]", "expected a number"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, 2e8]\ninterpolaton = "cubic"',
     ["tables.k.interpolaton", "did you mean 'interpolation'"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, 2e8]\ninterpolation = "spline"',
     ["tables.k.interpolation", "linear, cubic, fourier"]),
    ('unit = "furlong"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, 2e8]', ["tables.k.unit", "unknown unit"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.1, 0.5]\nvalues = [1e8, 2e8, 1e8]\ninterpolation = "fourier"',
     ["tables.k", "equally spaced"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.2, 0.2, 0.6]\nvalues = [1, 2, 3, 4]\ninterpolation = "fourier"',
     ["tables.k", "no jumps"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5, 0.5, 0.5]\nvalues = [1, 2, 3, 4]', ["x[3] (row 4)", "three times"]),
    ('unit = "N/m"\ndomain = "um"\nx = [0.0, 1e-300]\nvalues = [1e300, -1e300]',
     ["tables.k", "not finite"]),
    ('unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.5]\nvalues = [1e8, 2e8]\nscale = "v"', ["tables.k.scale",
                                                                                        "parameters"]),
])
def test_bad_inline_table_names_the_field_and_row(tmp_path, table, needles):
    msg = spec_error(write(tmp_path, table=table, csv=None))
    for n in needles:
        assert n in msg, msg


@pytest.mark.parametrize("stiffness, needles", [
    ("k(t)", ["elements.spring.stiffness", "argument 1 of table 'k'", "phase of a schedule"]),
    ("k(mesh_phase, 1)", ["elements.spring.stiffness", "takes 1 argument"]),
    ("k", ["elements.spring.stiffness", "declares no arguments"]),
    ("kk(mesh_phase)", ["elements.spring.stiffness", "unknown function 'kk'", "tables: k"]),
])
def test_bad_table_calls_name_the_field(tmp_path, stiffness, needles):
    msg = spec_error(write(tmp_path, stiffness=stiffness))
    for n in needles:
        assert n in msg, msg


def test_wrong_table_unit_is_a_unit_mismatch_of_the_field(tmp_path):
    msg = spec_error(write(tmp_path, table=CSV_TABLE.replace('"N/m"', '"m"')))
    assert "elements.spring.stiffness" in msg and "unit mismatch" in msg, msg


def test_table_argument_of_the_wrong_unit(tmp_path):
    table = 'unit = "N/m"\ndomain = "um"\nx = [0.0, 5.0]\nvalues = [1e8, 2e8]'
    msg = spec_error(write(tmp_path, table=table, csv=None, stiffness="k(T_m)"))
    assert "elements.spring.stiffness" in msg and "the table's domain is um" in msg, msg


def test_a_path_outside_the_model_folder_is_refused(tmp_path):
    (tmp_path / "k.csv").write_text(GOOD_CSV)
    msg = spec_error(write(tmp_path / "sub", table=CSV_TABLE.replace('"k.csv"', '"../k.csv"'), csv=None))
    assert "tables.k.file" in msg and "outside the model file's folder" in msg, msg


def test_an_absolute_path_is_refused(tmp_path):
    (tmp_path / "k.csv").write_text(GOOD_CSV)
    msg = spec_error(write(tmp_path / "sub", table=CSV_TABLE.replace('"k.csv"', f'"{tmp_path / "k.csv"}"'),
                           csv=None))
    assert "tables.k.file" in msg and "absolute path" in msg, msg


def test_a_symlink_that_leaves_the_folder_is_refused(tmp_path):
    (tmp_path / "outside.csv").write_text(GOOD_CSV)
    folder = tmp_path / "sub"
    path = write(folder, csv=None)
    os.symlink(tmp_path / "outside.csv", folder / "k.csv")
    msg = spec_error(path)
    assert "tables.k.file" in msg and "outside the model file's folder" in msg and "after following links" in msg


def test_a_symlink_inside_the_folder_is_read(tmp_path):
    path = write(tmp_path, csv=None)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "real.csv").write_text(GOOD_CSV)
    os.symlink(tmp_path / "data" / "real.csv", tmp_path / "k.csv")
    assert load_model(path).tables["k"].axes[0].knots[-1] == 0.75


def test_a_1gb_table_file_is_refused_by_its_size_before_reading(tmp_path):
    path = write(tmp_path, csv=None)
    with open(tmp_path / "k.csv", "wb") as fh:  # sparse: no gigabyte is written
        fh.truncate(2 ** 30)
    msg = spec_error(path)
    assert "k.csv" in msg and "too large (1073741824 bytes" in msg, msg


def test_a_table_file_that_is_a_folder_or_missing(tmp_path):
    path = write(tmp_path, csv=None)
    assert "not found" in spec_error(path)
    (tmp_path / "k.csv").mkdir()
    assert "regular file" in spec_error(path)


def _cli(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("case", ["ragged", "outside", "huge"])
def test_bad_tables_exit_2_on_the_command_line(tmp_path, case):
    if case == "ragged":
        path = write(tmp_path, csv="mesh_phase,stiffness\n0.0,1e8\n0.25,1.2e8,7\n")
        needles = ["k.csv", "row 3 has 3 cells"]
    elif case == "outside":
        (tmp_path / "k.csv").write_text(GOOD_CSV)
        path = write(tmp_path / "sub", table=CSV_TABLE.replace('"k.csv"', '"../k.csv"'), csv=None)
        needles = ["tables.k.file", "outside"]
    else:
        path = write(tmp_path, csv=None)
        with open(tmp_path / "k.csv", "wb") as fh:
            fh.truncate(2 ** 30)
        needles = ["k.csv", "too large"]
    r = _cli(["inspect", str(path)])
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr and r.stderr.startswith("gearsym: error: ")
    for n in needles:
        assert n in r.stderr, r.stderr


# ------------------------------------------------------------------ interpolants


def _inline(x, v, interpolation="linear", extra="") -> str:
    return (f'unit = "N/m"\ndomain = "phase"\nx = {list(map(float, x))}\nvalues = {list(map(float, v))}\n'
            f'interpolation = "{interpolation}"\n{extra}')


def test_cubic_table_is_scipys_periodic_spline(tmp_path):
    x = np.arange(12) / 12
    v = 1e8 * (1 + 0.3 * np.cos(2 * np.pi * x) + 0.2 * (x > 0.4))
    t = load_model(write(tmp_path, table=_inline(x, v, "cubic"), csv=None)).tables["k"]
    cs = CubicSpline(np.append(x, 1.0), np.append(v, v[0]), bc_type="periodic")
    q = np.linspace(-0.5, 1.5, 401)
    assert np.max(np.abs(t(q) - cs(np.mod(q, 1.0)))) < 1e-15 * v.max() * 4


def test_fourier_table_takes_the_fewest_harmonics_within_its_tolerance(tmp_path):
    x = np.arange(32) / 32
    v = 1e8 + 3e7 * np.cos(2 * np.pi * x) + 1e6 * np.sin(6 * np.pi * x) + 1e3 * np.cos(14 * np.pi * x)
    for tol, harmonics in ((1e4, 3), (10.0, 7), (0.0, 16)):
        t = load_model(write(tmp_path, table=_inline(x, v, "fourier", f"tolerance = {tol}"),
                             csv=None)).tables["k"]
        f = t.interpolants[0]
        assert f.harmonics == harmonics
        assert np.max(np.abs(t(x) - v)) <= max(tol, 1e-7)


def test_a_jump_is_a_knot_written_twice(tmp_path):
    x = [0.0, 0.3, 0.6, 0.6, 1.0]
    v = [2e8, 2.2e8, 2.4e8, 1.2e8, 1.4e8]     # a jump at 0.6 and one at the wrap (1 -> 0)
    t = load_model(write(tmp_path, table=_inline(x, v), csv=None)).tables["k"]
    assert np.allclose(t([0.0, 0.15, 0.6 - 1e-12, 0.6, 0.8, 1.0 - 1e-12, 1.0]),
                       [2e8, 2.1e8, 2.4e8, 1.2e8, 1.3e8, 1.4e8, 2e8], rtol=1e-9)
    c = load_model(write(tmp_path, table=_inline(x, v, "cubic"), csv=None)).tables["k"]
    assert np.allclose(c([0.6 - 1e-12, 0.6, 1.0 - 1e-12]), [2.4e8, 1.2e8, 1.4e8], rtol=1e-9)


def test_two_axis_table_is_bilinear_interpolation(tmp_path):
    table = ('unit = "N/m"\ndomain = ["phase", "N*m"]\nx = [0.0, 0.5]\ny = [100.0, 300.0]\n'
             'values = [[1e8, 3e8], [2e8, 6e8]]')
    t = load_model(write(tmp_path, table=table, csv=None, stiffness="k(mesh_phase, T)")).tables["k"]
    assert np.allclose(t(0.25, 200.0), np.mean([1e8, 3e8, 2e8, 6e8]), rtol=1e-15)
    assert np.allclose(t(0.0, 50.0), 1e8) and np.allclose(t(0.5, 1000.0), 6e8)   # held outside


def test_two_axis_csv_grid(tmp_path):
    csv = "phase,100,300\n0.0,1e8,3e8\n0.5,2e8,6e8\n"
    table = 'unit = "N/m"\ndomain = ["phase", "N*m"]\nfile = "k.csv"'
    t = load_model(write(tmp_path, table=table, csv=csv, stiffness="k(mesh_phase, T)")).tables["k"]
    assert t.axes[1].knots == (100.0, 300.0) and np.allclose(t(0.25, 200.0), 3e8)
    bad = "phase,100,100\n0.0,1e8,3e8\n0.5,2e8,6e8\n"
    msg = spec_error(write(tmp_path, table=table, csv=bad, stiffness="k(mesh_phase, T)"))
    assert "row 1, column 3" in msg and "increase strictly" in msg, msg


def test_table_data_is_part_of_the_build_key(tmp_path):
    a = load_model(write(tmp_path)).data_digest()
    b = load_model(write(tmp_path, csv=GOOD_CSV.replace("1.2e8", "1.3e8"))).data_digest()
    assert a and b and a != b


# ------------------------------------------------------------------ gear geometry

GEARS = '''unit = "N/m"
interpolation = "cubic"
[tables.k.gears]
module = "3 mm"
teeth = [50, 50]
face_width = "20 mm"
youngs_modulus = "206 GPa"
samples = 32
'''


def test_a_table_from_gear_geometry_is_the_geometry_stiffness(tmp_path):
    """The 50/50, 3 mm pair of Yu et al.: the table equals gearsym.gears' stiffness between the samples
    (a cubic spline per contact zone) and jumps where a pair enters or leaves."""
    from gearsym.gears import Gear, GearPair, mesh_stiffness

    t = load_model(write(tmp_path, table=GEARS, csv=None)).tables["k"]
    res = mesh_stiffness(GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3), samples=32)
    q = np.linspace(0.0, 1.0, 2001)[:-1]
    assert np.max(np.abs(t(q) - res.at(q))) / res.mean < 1e-6
    jump = res.contact_ratio - 1
    before, after = t([jump - 1e-13, jump])
    assert before > 4.5e8 and after < 2.9e8                    # two pairs, then one
    assert t.info["contact_ratio"] == pytest.approx(1.7546732846981046, rel=1e-12)
    assert t.info["mean_N_per_m"] == pytest.approx(res.mean, rel=1e-12)
    assert t.info["iso6336_c_gamma_N_per_m"] == pytest.approx(res.iso.mesh_stiffness, rel=1e-12)
    assert t.source == "gears" and t.period == 1.0


@pytest.mark.parametrize("change, needles", [
    (('module = "3 mm"', "module = 3"), ["tables.k.gears.module", "with its unit"]),
    (('teeth = [50, 50]', "teeth = [8, 50]"), ["tables.k.gears", "refused"]),
    (('samples = 32', "samples = 3"), ["tables.k.gears.samples", "4 to 1024"]),
    (('samples = 32', 'bore_radius = "1 mm"\nmodul = "3 mm"'), ["tables.k.gears.modul", "did you mean 'module'"]),
    (('face_width = "20 mm"', 'face_width = "20 N"'), ["tables.k.gears.face_width", "[kg*m*s^-2]"]),
])
def test_bad_gear_geometry_names_the_key(tmp_path, change, needles):
    msg = spec_error(write(tmp_path, table=GEARS.replace(*change), csv=None))
    for n in needles:
        assert n in msg, msg


# ------------------------------------------------------------------ shipped models with tables


def test_init_from_a_scene_with_a_table_file_copies_the_table(tmp_path):
    r = _cli(["init", "mine", "--from", "ltca_pair", "--dir", str(tmp_path)])
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "models" / "ltca_pair_k.csv").is_file()
    spec = load_model(tmp_path / "models" / "mine.toml")
    assert spec.tables["k_ltca"].axes[1].knots == (50.0, 100.0, 200.0, 400.0, 700.0)


def test_the_geometry_pair_starts_from_its_static_deflection():
    """yu_fig14_geometry: the static start is b_m + F/k_mean, k_mean the geometry's mean stiffness
    (integrated zone by zone by gearsym.gears, independently of the table's spline)."""
    import gearsym

    root = Path(__file__).resolve().parents[1]
    scene = gearsym.load_scene(root / "scenes" / "yu_fig14_geometry.toml")
    k_mean = scene.model_spec.tables["k_mesh"].info["mean_N_per_m"]
    rb1 = 70.47694656e-3
    expected = 50e-6 + 340.0 / rb1 / k_mean
    system = scene.compile()
    assert system.x0[0] == pytest.approx(expected, rel=1e-6)
    tr = system.simulate(periods=5)
    assert tr.stats["n_breaks"] >= 5 * 65 - 1   # 64 samples and the jump: 65 breaks a mesh cycle


# ------------------------------------------------------------------ in the symbolic model (no compile)


def _scene(folder: Path, model_text: str, effects: dict | None = None):
    import gearsym

    (folder / "m.toml").write_text(model_text)
    (folder / "s.toml").write_text('[scene]\nmodel = "m.toml"\n')
    return gearsym.load_scene(folder / "s.toml", effects=effects)


def test_an_effect_switched_off_removes_its_table_and_breakpoints(tmp_path):
    text = MODEL.replace('stiffness = "STIFFNESS"', 'stiffness = ["1e8*k_u", { expr = "s_k*k(mesh_phase)", '
                                                    'effect = "ltca" }]') \
        .replace("TABLE", 'unit = "N/m"\ndomain = "phase"\nx = [0.0, 0.25, 0.5]\nvalues = [1e8, 2e8, 1e8]') \
        .replace("T = { value", 's_k = { value = 1.0 }\nk_u = { value = 1.0, unit = "N/m" }\nT = { value') \
        + '[effects.ltca]\nmeaning = "LTCA stiffness"\n'
    on = _scene(tmp_path, text, {"ltca": True}).model
    assert [s.name for s in on.schedules] == ["k@mesh"] and len(on.schedules[0].breaks) == 3
    assert "s_k" in on.parameter_names
    off = _scene(tmp_path, text, {"ltca": False}).model
    assert off.schedules == [] and "s_k" not in off.parameter_names


def test_a_table_over_a_state_has_a_surface_per_knot(tmp_path):
    table = 'unit = "N"\ndomain = "um"\nx = [-10.0, 0.0, 10.0, 20.0]\nvalues = [-1000.0, 0.0, 500.0, 2000.0]'
    text = MODEL.replace('type = "spring"\ndeflection = "x"\nstiffness = "STIFFNESS"',
                         'type = "force"\ncoordinate = "x"\nvalue = "-k(x)"').replace("TABLE", table)
    m = _scene(tmp_path, text).model
    assert [s.name for s in m.switching] == [f"spring.k.knot{j}" for j in range(4)]
    assert m.schedules == []
    ext = _scene(tmp_path, text.replace('values = [', 'outside = "extend"\nvalues = [')).model
    assert [s.name for s in ext.switching] == ["spring.k.knot0", "spring.k.knot1"]  # the interior knots


def test_a_two_axis_table_over_phase_and_deflection(tmp_path):
    table = ('unit = "N/m"\ndomain = ["phase", "um"]\nx = [0.0, 0.5]\ny = [0.0, 10.0, 20.0]\n'
             'values = [[1e8, 2e8, 3e8], [2e8, 3e8, 4e8]]')
    m = _scene(tmp_path, MODEL.replace("STIFFNESS", "k(mesh_phase, x)").replace("TABLE", table)).model
    assert [s.name for s in m.switching] == ["spring.k.y0", "spring.k.y1", "spring.k.y2"]
    assert [s.name for s in m.schedules] == ["k@mesh"]


def test_too_many_knots_over_a_state_are_refused(tmp_path):
    xs = list(range(200))
    table = f'unit = "N"\ndomain = "um"\nx = {xs}\nvalues = {xs}'
    text = MODEL.replace('type = "spring"\ndeflection = "x"\nstiffness = "STIFFNESS"',
                         'type = "force"\ncoordinate = "x"\nvalue = "-k(x)"').replace("TABLE", table)
    with pytest.raises(SpecError, match="200 knots .limit 128"):
        _scene(tmp_path, text).model  # noqa: B018


@pytest.mark.parametrize("name, needle", [("for", "keyword"), ("T", "duplicate name 'T'"), ("sin", "reserved")])
def test_table_names_obey_the_identifier_rule(tmp_path, name, needle):
    text = MODEL.replace("[tables.k]", f"[tables.{name}]").replace("TABLE", CSV_TABLE)
    (tmp_path / "k.csv").write_text(GOOD_CSV)
    (tmp_path / "m.toml").write_text(text)
    msg = spec_error(tmp_path / "m.toml")
    assert f"tables.{name}" in msg and needle in msg, msg


def test_a_table_read_only_by_an_output_gets_its_schedule(tmp_path):
    text = MODEL.replace("STIFFNESS", "1e8*k_u").replace("TABLE", CSV_TABLE) \
        .replace("T = { value", 'k_u = { value = 1.0, unit = "N/m" }\nT = { value') \
        + '[outputs]\nk_out = { value = "k(mesh_phase)", unit = "N/m" }\n'
    (tmp_path / "k.csv").write_text(GOOD_CSV)
    m = _scene(tmp_path, text).model
    assert [s.name for s in m.schedules] == ["k@mesh"]


def _fine_csv(n: int) -> str:
    ph = np.arange(n) / n
    k = 1e8 * (1 + 0.1 * np.cos(2 * np.pi * ph))
    return "mesh_phase,stiffness\n" + "".join(f"{a:.12g},{b:.12g}\n" for a, b in zip(ph, k))


def test_a_table_too_fine_for_pieces_is_refused_with_the_way_out(tmp_path):
    """A 513-phase linear table is refused up front (its 513 pieces would take minutes to derive:
    2,000 phases took over 400 s), naming the file and the table, and saying what to do; the
    same data as a fourier table (harmonics, not pieces) is read."""
    msg = spec_error(write(tmp_path, csv=_fine_csv(513)))
    assert "k.csv" in msg and "tables.k" in msg and "513 knots along the first axis (limit 512)" in msg
    assert "resample" in msg and "fourier" in msg
    ok = load_model(write(tmp_path / "f", table=CSV_TABLE + '\ninterpolation = "fourier"', csv=_fine_csv(1024)))
    t = ok.tables["k"]
    q = np.linspace(0.0, 1.0, 97)
    assert np.allclose(t(q), 1e8 * (1 + 0.1 * np.cos(2 * np.pi * q)), rtol=1e-9, atol=0)
    assert load_model(write(tmp_path / "l", csv=_fine_csv(512))).tables["k"].axes[0].knots[-1] == 511 / 512
