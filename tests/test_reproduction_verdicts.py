"""The verdicts of docs/reproduction.md are computed from their rows' numbers (examples/_verdicts.py).

Three rows are re-derived from numbers fed in place of their commands (LIU-F11, LIU-F12, YU-F10):
the verdict follows the numbers, and a feature the numbers do not show (a jump at a transition, a
trend with D) is not claimed.  One cheap row runs end to end (LIU-F8-10: three shooting orbits).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
import _verdicts as V  # noqa: E402
import reproduce  # noqa: E402
import yu_readings  # noqa: E402


def _row(rid: str) -> reproduce.Row:
    return next(r for r in reproduce.ROWS if r.id == rid)


def _claim(res: reproduce.Result, start: str) -> dict:
    return next(c for c in res.data["claims"] if c["text"].startswith(start))


# ----------------------------------------------------------------------------- the criteria
def test_a_fold_at_the_transition_is_a_jump_a_steep_rise_before_it_is_not():
    values = [160.0, 163.0, 166.0, 167.0, 170.0]
    amps = [0.15, 0.40, 0.65, 0.67, 0.68]
    states = [1, 1, 1, 2, 2]
    smooth = V.jump_at(166.0, [("grazing", 166.0)], values, amps, states)
    assert not smooth.holds
    assert smooth.steepest.state_lo == smooth.steepest.state_hi == 1       # the rise is inside state 1
    assert smooth.ratio == pytest.approx(0.67 / 0.65)
    folded = V.jump_at(166.0, [("grazing", 166.0), ("fold", 166.9)], values, amps, states)
    assert folded.holds and folded.near == [("fold", 166.9)]
    assert not V.jump_at(166.0, [("fold", 170.0)], values, amps, states).holds     # 2.4 % away: not at it


def test_transitions_succession_trends_and_kinds():
    trs = V.transitions([0, 1, 2, 3, 4], [0, None, 1, 1, 2])
    assert [(t.lo, t.hi, t.before, t.after) for t in trs] == [(0, 2, 0, 1), (3, 4, 1, 2)]
    assert V.succession([0, 1, None, 1, 2, 2], [0, 1, 2]) and not V.succession([0, 2, 1], [0, 1, 2])
    assert V.transition_holds(146.87, 150) and not V.transition_holds(192.6, 170)
    assert V.trend([115, 30, 18, 16]) == "falls" and V.trend([13.75, 13.75, 13.76]) == "flat"
    assert V.trend([39.2, 37.7, 37.7, 37.7]) == "mixed"
    assert V.tendency([0.807, 0.794, 0.883, 0.912, 1.048, 1.206]) == "grows"
    assert V.kind_of(1) == "periodic" and V.kind_of(4) == "P4" and V.kind_of(100) == "non-periodic"
    assert V.kind_of(100, 5.0, 0.5, 0.1) == "chaotic"
    assert V.kind_of(100, 1e-4, 1e-3, 0.1) == "quasi-periodic"
    assert V.kind_of(100, -90.0, 0.7, 0.16) == "converging"
    assert V.verdict([V.Claim("a", True), V.Claim("b", True)])[0] == V.REPRODUCED
    assert V.verdict([V.Claim("a", True), V.Claim("b", True)], cap="no numbers")[0] == V.QUALITATIVELY
    assert V.verdict([V.Claim("a", True), V.Claim("b", False)])[0] == V.QUALITATIVELY
    assert V.verdict([V.Claim("a", False), V.Claim("b", None)])[0] == V.NOT_REPRODUCED


# ----------------------------------------------------------------------------- LIU-F11 from numbers
def _f11_numbers(extra_bifurcation: tuple[str, float] | None = None) -> dict:
    """The continued branch near the transitions and the brute-force states, as nfg_rattle.py writes them
    (numbers of the run of 2026-11-23, rounded)."""
    pts = [(140.84, 0, 0.1497), (146.871, 0, 0.1503), (149.73, 1, 0.1507), (155.72, 1, 0.1515), (161.72, 1, 0.1525),
           (164.72, 1, 0.3779), (166.663, 1, 0.6491), (167.72, 2, 0.6655), (170.72, 2, 0.6838), (173.72, 2, 0.6960)]
    bifs = [{"type": "grazing", "value": 146.871, "surface": "mesh.drive"},
            {"type": "grazing", "value": 166.663, "surface": "mesh.back"}]
    if extra_bifurcation:
        bifs.append({"type": extra_bifurcation[0], "value": extra_bifurcation[1]})
    speeds = [140.0, 145.0, 150.0, 155.0, 160.0, 165.0, 170.0, 175.0]
    return {"points": [{"value": v, "rattle_state": s, "max": a * 1e-3, "min": 0.0} for v, s, a in pts],
            "bifurcations": bifs, "stop_reason": "reached omega1 = 250 rad/s",
            "brute_force": {"omega1": speeds, "rattle_state": [0, 0, 1, 1, 1, 1, 2, 2],
                            "peak_to_peak": [x * 1e-3 for x in (0.1496, 0.1501, 0.1507, 0.1514, 0.1522, 0.4201,
                                                                 0.6783, 0.697)]}}


def test_liu_f11_verdict_from_its_numbers(monkeypatch):
    monkeypatch.setattr(reproduce, "script", lambda name, *a, tag="": _f11_numbers())
    res = _row("LIU-F11").run(_row("LIU-F11"))
    assert res.verdict == V.QUALITATIVELY
    assert _claim(res, "unilateral rattle from 150")["holds"] is True          # 146.87: 2.1 % from 150
    assert _claim(res, "bilateral rattle from 170")["holds"] is True           # 166.66: 2.0 % from 170
    jump = _claim(res, "a jump of ppv")
    assert jump["holds"] is False
    assert "inside state 1" in jump["because"] and "x1.03 across it" in jump["because"]
    # the same numbers with a fold at the onset: the jump is shown, and every claim holds
    monkeypatch.setattr(reproduce, "script", lambda name, *a, tag="": _f11_numbers(("fold", 166.9)))
    res = _row("LIU-F11").run(_row("LIU-F11"))
    assert _claim(res, "a jump of ppv")["holds"] is True
    assert res.verdict == V.REPRODUCED


# ----------------------------------------------------------------------------- LIU-F12 from numbers
def test_liu_f12_verdict_from_its_numbers(monkeypatch):
    def sample(v, s, p, sim=False):
        x = {"value": v, "rattle_state": s, "ppv": p * 1e-3, "method": "orbit", "kind": "periodic"}
        if sim:
            x |= {"method": "simulation", "kind": V.kind_of(1, -129.4, 0.74, 0.157), "poincare_points": 1,
                  "poincare_spread": 9e-6, "lyapunov": -129.4, "lyapunov_error": 0.74}
        return x
    data = {"param": "er", "samples": [sample(0, 0, 0.151), sample(0.8, 1, 0.152), sample(4, 1, 0.588),
                                       sample(5, 1, 0.572, True), sample(5.5, 1, 0.698), sample(6, 2, 0.807, True),
                                       sample(7, 2, 0.883), sample(15, 2, 1.206)],
            "branch": {"points": [{"value": 0.0, "rattle_state": 0, "ppv": 1.509e-4, "stability": "x"},
                                  {"value": 4.42, "rattle_state": 1, "ppv": 4.685e-4, "stability": "x"}],
                       "bifurcations": [{"type": "grazing", "value": 0.0674, "surface": "mesh.drive"}],
                       "stop_reason": "the branch cannot advance: step size below ds_min=1e-07 at er = 4.42 um",
                       "complete": False}}
    monkeypatch.setattr(reproduce, "script", lambda name, *a, tag="": data)
    res = _row("LIU-F12").run(_row("LIU-F12"))
    assert res.verdict == V.QUALITATIVELY
    assert _claim(res, "no rattle, unilateral, bilateral")["holds"] is True
    jump = _claim(res, "a jump of ppv")
    assert jump["holds"] is False and "stops at 4.42" in jump["because"] and "x1.16 across it" in jump["because"]
    assert "shooting failed" not in res.gives and "simulated, periodic: 1 Poincare point" in res.gives


# ----------------------------------------------------------------------------- YU-F10 from numbers
def _yu_rows(ppv02: list[float], impacts: list[float], poincare: list[int]) -> dict:
    rows = {}
    for backlash in ("dynamic", "constant"):
        for w in (0.2, 0.31):
            for i, D in enumerate(yu_readings.DS):
                dyn = backlash == "dynamic" and w == 0.2
                rows[f"{backlash}/w{w}/D{D}"] = {
                    "mean_um": 30.0 - i, "ppv_um": ppv02[i] if dyn else 3.0, "impacts_per_period": impacts[i] if dyn else 0,
                    "poincare_points": poincare[i] if dyn else 1, "mean_B_um": 20.0 + (7 if backlash == "dynamic" else 0),
                    "off_harmonic_share": 0.0}
                if dyn and poincare[i] > 16:
                    rows[f"{backlash}/w{w}/D{D}"] |= {"lyapunov": 50.0, "lyapunov_error": 1.0, "period": 5e-4}
    for G in yu_readings.GS:
        rows[f"dynamic/w0.31/D1.4/G{G:g}"] = {"ppv_um": 8.0}
    return rows


def test_yu_f10_verdict_from_its_numbers(monkeypatch):
    flat = _yu_rows([13.75] * 4, [0] * 4, [1] * 4)                 # the shipped reading's numbers
    paper = _yu_rows([115, 30, 18, 16], [4] * 4, [1, 1, 4, 400])    # numbers with Fig. 10's trends
    readings = {"shipped": {"scene": "s", "note": "", "criteria": yu_readings.figure_criteria(flat), "rows": flat}}
    monkeypatch.setattr(reproduce, "cached", lambda rid: {"readings": readings})
    res = _row("YU-F10").run(_row("YU-F10"))
    assert res.verdict == V.QUALITATIVELY                      # only "dynamic larger than constant" holds
    assert [c["holds"] for c in res.data["claims"]] == [False, False, False, True]
    readings["paper"] = {"scene": "p", "note": "", "criteria": yu_readings.figure_criteria(paper), "rows": paper}
    res = _row("YU-F10").run(_row("YU-F10"))
    assert res.verdict == V.REPRODUCED and "(paper)" in res.why


# ----------------------------------------------------------------------------- one row end to end
def test_one_row_end_to_end(monkeypatch, tmp_path):
    monkeypatch.setattr(reproduce, "CACHE", tmp_path / "reproduction.json")
    out = reproduce.run_row(_row("LIU-F8-10"))
    assert out["verdict"] == V.REPRODUCED, out
    assert [out["data"][s]["rattle_state"] for s in ("140", "160", "180")] == [0, 1, 2]
    assert out["data"]["180"]["ppv"] > 2 * out["data"]["160"]["ppv"]
    json.dumps(out, default=float)          # what the cache stores


# ----------------------------------------------------------------------------- response kinds: gearsym sweep's rule
def _classify_main(P, lam, err, T):
    """The classification of gearsym sweep, basins and maps (one rule) for section points P."""
    from gearsym.analysis.sweeps import KINDS
    from gearsym.analysis.sweeps._attractor_id import classify_exponent

    return list(KINDS)[classify_exponent(lam, err, T, P)[0]]   # the kinds' names, by code


@pytest.mark.parametrize(("lam", "err", "T"), [(5.0, 0.5, 0.1), (1e-4, 1e-3, 0.1), (0.05, 1e-3, 0.1),
                                               (-90.0, 0.7, 0.16), (0.5, 0.3, 1.0), (1e-4, 0.2, 0.1),
                                               (0.15, 0.2, 0.1)])
def test_kinds_follow_gearsym_sweep(lam, err, T):
    from gearsym.analysis.sweeps import closed_curve

    rng = np.random.default_rng(1)
    circle = np.column_stack([np.cos(np.arange(200) * 2 * np.pi * 0.618034), np.sin(np.arange(200) * 2 * np.pi * 0.618034)])
    cloud = rng.uniform(-1, 1, (200, 2))
    for P in (circle, cloud):
        n = V.poincare_count(P, np.ptp(P, axis=0))
        mine = V.kind_of(n, lam, err, T, bool(closed_curve(P)))
        main = _classify_main(P, lam, err, T)
        assert mine == main or (mine == "converging" and main == "unclassified"), (lam, err, T, mine, main)
    assert V.kind_of(100, 1e-4, 1e-3, 0.1, closed=False) == "unclassified"     # zero exponent, a cloud


# ----------------------------------------------------------------------------- YU-F14 from numbers
def test_yu_f14_rms_is_eq_21_and_nothing_is_claimed(monkeypatch):
    wn = 22000.0
    rpm = [wn * w / (50 * 2 * np.pi / 60) for w in (0.55, 0.65, 0.75, 0.85)]
    harm = [[3e-6, 4e-6, 0, 0, 0], [1e-6, 0, 0, 0, 0], [0, 2e-6, 2e-6, 0, 0], [5e-6, 0, 0, 0, 0]]
    pts = [{"value": v, "stability": "asymptotically_stable", "rattle_state": 0,
            "gear_quantities": {"mesh": {"dte_harmonics": h}}} for v, h in zip(rpm, harm)]
    monkeypatch.setattr(reproduce, "gearsym", lambda cmd: {"points": pts, "bifurcations": []})
    monkeypatch.setattr(reproduce, "_f14_omega_n", lambda: wn)
    res = _row("YU-F14").run(_row("YU-F14"))
    rms = [p["rms_um"] for p in res.data["points"]]
    assert rms == pytest.approx([np.sqrt((9 + 16) / 5), np.sqrt(1 / 5), np.sqrt(8 / 5), np.sqrt(25 / 5)])
    # omega* = 0.6 lies halfway between the first two points: linear interpolation on the branch
    assert f"0.6: {(rms[0] + rms[1]) / 2:.2f}" in res.gives
    assert res.verdict == V.NOT_REPRODUCED and all(c["holds"] is None for c in res.data["claims"])


def test_readings_table_says_where_the_dynamic_backlash_closes():
    rows = _yu_rows([40.0] * 4, [4] * 4, [1] * 4)
    for key, m in rows.items():
        m.update(mean_B_um=m.get("mean_B_um", 20.0), min_B_um=-16.2 if key == "dynamic/w0.31/D1.4" else 5.0,
                 impacts_per_period=m.get("impacts_per_period", 0), mean_um=m.get("mean_um", 0.0))
    crit = yu_readings.figure_criteria(rows)
    results = {"YU-READINGS": {"data": {"readings": {"r": {"scene": "s", "note": "n", "criteria": crit, "rows": rows}},
                                        "none": []}}}
    text = "\n".join(reproduce._yu_readings_table(results))
    assert "closes" in text and "r at omega* = 0.31, D = 1.4 (min B -16.2 um)" in text
    assert text.count("min B") == 1
