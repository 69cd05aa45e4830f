"""``gearsym bench`` (the work-precision benchmark behind benchmarks/work_precision.py): it
writes its JSON and plot, and the errors it reports agree with an independent
computation against the exact solution of the damped Meissner equation."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.linalg import expm

import gearsym

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "meissner.toml"


def _exact(p, x0, t):
    """x'' + 2 zeta w0 x' + w0^2 (1 +- a) x = 0, stiff on [nT, (n + d)T), soft after (by hand)."""
    A = {s: np.array([[0.0, 1.0], [-p["w0"] ** 2 * (1 + s * p["a"]), -2 * p["zeta"] * p["w0"]]]) for s in (1, -1)}
    T, d = p["T"], p["d"]
    knots = np.unique(np.concatenate([np.arange(0, t[-1] / T + 1) * T, (np.arange(0, t[-1] / T + 1) + d) * T]))
    y, x, out = 0.0, np.asarray(x0, float), np.empty((t.size, 2))
    for k in range(knots.size - 1):
        ts, te = knots[k], knots[k + 1]
        Ak = A[1] if ((ts / T) % 1.0) < d - 1e-12 else A[-1]
        sel = (t >= ts) & (t <= te)
        out[sel] = np.array([expm(Ak * (tt - ts)) @ x for tt in t[sel]])
        x = expm(Ak * (te - ts)) @ x
        y = te
    assert y >= t[-1]
    return out


def test_bench_cli_reports_errors_against_the_exact_solution(tmp_path):
    out = tmp_path / "bench"
    r = subprocess.run([sys.executable, "-m", "gearsym.cli", "bench", str(SCENE), "--periods", "5", "--rtols",
                        "1e-4,1e-8", "--methods", "gearsym,scipy DOP853", "--rounds", "0", "--no-compile-times",
                        "--no-analyses", "--points-per-period", "16", "--json", "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert sorted(p.name for p in out.iterdir()) == ["work_precision_meissner.json", "work_precision_meissner.png"]
    assert json.loads((out / "work_precision_meissner.json").read_text())["case"]["rtols"] == [1e-4, 1e-8]
    case = data["case"]
    assert case["reference"]["kind"] == "exact"
    rows = {(row["method"], row["rtol"]): row for row in case["results"]}
    assert set(rows) == {(m, r) for m in ("gearsym", "scipy DOP853") for r in (1e-4, 1e-8)}
    # recompute gearsym's error at rtol 1e-8 independently (same grid, same normalisation)
    system = gearsym.load_scene(SCENE).compile()
    p = dict(system.params)
    t = np.linspace(0.0, 5 * p["T"], 5 * 16 + 1)
    y_ex = _exact(p, system.x0, t)
    tr = system.simulate(t_end=t[-1], t_out=t, rtol=1e-8, atol=1e-8 * case_atol_ratio(case))
    scale = np.max(np.abs(y_ex), axis=0)
    err = float(np.max(np.abs(tr.y - y_ex) / scale))
    np.testing.assert_allclose(case["state_scale"], scale, rtol=1e-9)
    assert abs(rows[("gearsym", 1e-8)]["error"] - err) <= 1e-3 * err + 1e-14
    assert rows[("gearsym", 1e-8)]["error"] < 1e-6 < rows[("gearsym", 1e-4)]["error"]
    for row in rows.values():
        assert row["best_s"] > 0 and np.isfinite(row["error"])
    assert "gearsym" in r.stdout and data["analysis"] is None
    # the tables of docs/performance.md are rendered from such records
    (out / "work_precision.json").write_text(json.dumps({"benchmark": "work_precision", "cases": [data]}))
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "work_precision.py"), "--render", "--out", str(out)],
                       capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert r.returncode == 0, r.stderr
    table = (out / "work_precision_table.md").read_text()
    assert f"| 1e-08 | {rows[('gearsym', 1e-8)]['error']:.0e} (" in table      # the tolerance table
    assert "| meissner | exact (1e-14) | 5 periods |" in table                   # the summary


def case_atol_ratio(case) -> float:
    return float(case["atol_rule"].split("*")[1].split("(")[0])


def test_analysis_costs_against_the_exact_monodromy():
    """The shooting / continuation costs of ``gearsym bench``: the reference multipliers are
    those of the exact monodromy of the damped Meissner equation (a product of two matrix
    exponentials), the per-tolerance multiplier errors shrink with rtol, and the multiplier
    matching does not depend on the order of the multipliers."""
    from gearsym.bench import _multiplier_error, analysis_costs

    mu = np.array([0.3 + 0.4j, 0.3 - 0.4j, -0.2])
    assert _multiplier_error(mu, mu[::-1]) == 0.0
    assert abs(_multiplier_error(mu, mu + 1e-3) - 1e-3) < 1e-12

    system = gearsym.load_scene(SCENE).compile()
    p = dict(system.params)
    A = {s: np.array([[0.0, 1.0], [-p["w0"] ** 2 * (1 + s * p["a"]), -2 * p["zeta"] * p["w0"]]]) for s in (1, -1)}
    M = expm(A[-1] * (1 - p["d"]) * p["T"]) @ expm(A[1] * p["d"] * p["T"])
    out = analysis_costs(system, [1e-5, 1e-9], None, 1e-2)
    ref = np.array([complex(m) for m in out["shooting"]["orbit_multipliers"]])
    assert _multiplier_error(ref, np.linalg.eigvals(M)) < 1e-9
    rows = {r["rtol"]: r for r in out["shooting"]["rows"]}
    assert rows[1e-9]["multiplier_error"] < 1e-7 and rows[1e-9]["multiplier_error"] < rows[1e-5]["multiplier_error"] < 1e-3
    co = out["continuation"]
    assert co["available"] and {r["param"] for r in co["rows"]} == {"T"}
    assert all(r["steps"] >= 1 and r["wall_per_step_s"] > 0 for r in co["rows"])
