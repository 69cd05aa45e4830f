"""``gearsym continue --follow ...``: bifurcation curves from the command line (issue 28).

The curve continued from a branch written by ``gearsym continue --json`` is checked against
``scipy.special.mathieu_a``; the exit codes: 0 for a complete curve, 1 when it stops before the
end of its range (the reason on stderr), 2 for bad input (naming the option)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.special import mathieu_a

import gearsym
from gearsym.cli import main

ROOT = Path(__file__).resolve().parents[1]
MATHIEU = str(ROOT / "scenes" / "mathieu.toml")
CURVE = ["continue", MATHIEU, "--param", "q", "--param2", "a", "--from", "0.5", "--to", "10", "--from2", "-20",
         "--to2", "20", "--ds-max", "0.1"]


@pytest.fixture(scope="module")
def branch_json(tmp_path_factory) -> Path:
    """The branch of x = 0 in a at q = 1 (its special point 6 is a_3(1), a period doubling)."""
    system = gearsym.load_scene(MATHIEU).compile()
    br = gearsym.continuation(system, "a", -1.0, 10.0, x0=[0.0, 0.0], params={"q": 1.0}, atol=1e-12, progress=False)
    assert [b.type for b in br.bifurcations][6] == "period_doubling"
    path = tmp_path_factory.mktemp("codim2") / "branch.json"
    br.save_json(path)
    return path


def _run(capsys, *args: str) -> tuple[int, str, str]:
    rc = main([str(a) for a in args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_curve_from_a_branch_json(capsys, branch_json, tmp_path):
    rc, out, err = _run(capsys, *CURVE, "--start-from", f"{branch_json}:6", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["type"] == "period_doubling" and d["complete"] is True and d["scene"] == "mathieu"
    q = np.array([p["value"] for p in d["points"]])
    a = np.array([p["value2"] for p in d["points"]])
    assert float(np.max(np.abs(a - mathieu_a(3, q)))) < 1e-7
    assert q.min() == pytest.approx(0.5) and q.max() == pytest.approx(10.0)
    assert all(r.split(": ", 1)[1].startswith("reached the boundary") for r in d["stop_reasons"])
    assert {"special_points", "start_index", "formulation", "derivatives", "n_integrations"} <= set(d)


def test_curve_drawn_over_a_map(capsys, branch_json, tmp_path):
    xr = pytest.importorskip("xarray")
    qs, As = np.linspace(0.5, 10, 6), np.linspace(-20, 20, 5)
    xr.Dataset({"max_multiplier": (("a", "q"), np.ones((5, 6)))}, coords={"q": qs, "a": As}).to_netcdf(
        tmp_path / "map.nc")
    rc, out, err = _run(capsys, *CURVE, "--start-from", f"{branch_json}:6", "--out", tmp_path / "o",
                        "--map", tmp_path / "map.nc")
    assert rc == 0, err
    assert (tmp_path / "o" / "curve.png").stat().st_size > 1000
    assert json.loads((tmp_path / "o" / "curve.json").read_text())["type"] == "period_doubling"
    assert "period doubling curve in (q, a)" in out
    # a map of another plane is refused, naming its axes
    xr.Dataset({"max_multiplier": (("c", "q"), np.ones((5, 6)))}, coords={"q": qs, "c": As}).to_netcdf(
        tmp_path / "other.nc")
    rc, out, err = _run(capsys, *CURVE, "--start-from", f"{branch_json}:6", "--out", tmp_path / "p",
                        "--map", tmp_path / "other.nc")
    assert rc == 2 and "--map: the stability map's axes ('c', 'q') are not the curves' parameters (q, a)" in err
    rc, out, err = _run(capsys, *CURVE, "--start-from", f"{branch_json}:6", "--out", tmp_path / "p",
                        "--map", tmp_path / "map.nc", "--map-quantity", "n_stable")
    assert rc == 2 and "--map: the stability map has no variable 'n_stable' (have: max_multiplier)" in err


def test_curve_that_stops_early_exits_1_with_the_reason(capsys, branch_json):
    rc, out, err = _run(capsys, *CURVE, "--start-from", f"{branch_json}:6", "--max-points", "3", "--json")
    assert rc == 1
    assert json.loads(out)["complete"] is False
    assert "the period_doubling curve stopped before its end" in err and "max_points=3 reached" in err


@pytest.mark.parametrize("extra, needle", [
    (["--start-from", "{br}:6", "--guess", "1,9"], "one of --start-from BRANCH.json:INDEX or --guess"),
    (["--guess", "1,9"], "--guess needs --follow"),
    (["--follow", "fold", "--guess", "1"], "--guess expects VALUE,VALUE2"),
    (["--start-from", "{br}:17"], "special point index 17 out of range: the branch has 7"),
    (["--start-from", "{br}:x"], "INDEX must be an integer"),
    (["--start-from", "{br}"], "expects BRANCH.json:INDEX"),
    (["--start-from", "/nonexistent/b.json:0"], "cannot read '/nonexistent/b.json'"),
    (["--start-from", "{br}:6", "--segments", "2"], "--segments > 1 does not apply to bifurcation curves"),
    (["--start-from", "{br}:6", "--map", "m.nc"], "--map draws the curve over a map into --out"),
    (["--start-from", "{br}:6", "--follow", "grazing"], "follow grazing: the special point started from is a "
                                                       "period_doubling"),
])
def test_bad_curve_input_exits_2(capsys, branch_json, extra, needle):
    args = [a.replace("{br}", str(branch_json)) for a in extra]
    rc, out, err = _run(capsys, *CURVE, *args)
    assert rc == 2, err
    assert needle in err and "Traceback" not in err


def test_curve_needs_param2(capsys, branch_json):
    rc, out, err = _run(capsys, "continue", MATHIEU, "--param", "q", "--from", "0.5", "--to", "10",
                        "--start-from", f"{branch_json}:6")
    assert rc == 2 and "--param2 is needed" in err


def test_branch_of_another_parameter_is_refused(capsys, branch_json):
    rc, out, err = _run(capsys, "continue", MATHIEU, "--param", "q", "--param2", "b_x", "--from", "0.5", "--to",
                        "10", "--start-from", f"{branch_json}:6")
    assert rc == 2 and "the branch in" in err and "varies 'a', which is neither" in err
