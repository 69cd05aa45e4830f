"""Work-precision diagrams: error against a reference versus wall time, for every shipped scene.

For each case (every scene in ``scenes/``, plus two variants of the benchmark
oscillator and a rattling regime of ``yu_dynamic_D14`` at omega* = 1), at rtol 1e-3 ... 1e-10 (and 1e-11, 1e-12 where the reference allows),
all in one run:

* gearsym ``System.simulate`` (CVODE Adams, the default, and BDF): generated C, located
  events, scheduled breakpoints;
* scipy DOP853 with located events in Python (the same algorithm as gearsym, no C);
* the peers a user would otherwise write, stepping over the kinks with one right-hand
  side: scipy ``solve_ivp`` RK45 / DOP853 / LSODA / Radau and scikit-sundae CVODE
  with a Python (numpy) right-hand side, and CasADi's ``integrator('cvodes')``.

The machinery is :mod:`gearsym.bench` (also behind ``gearsym bench SCENE``).  This
script adds the references that need more than the generic ones:

* ``kahraman_singh eps=0``: the exact piecewise closed form of
  ``tests/reference.py:closed_form_linear`` (linear between contacts; contact times by
  a root solve);
* ``kahraman_singh`` and ``kahraman_singh chaotic`` (Omega = 0.8, Fa = 0.6):
  ``tests/reference.py:reference_solution``, a hand-written event-located DOP853 at
  rtol 1e-13 (independent of gearsym's symbolic layer), with a second run at 1e-12
  for the floor and the divergence horizon;
* ``meissner``: the exact matrix-exponential solution (found automatically);
* every other scene: the generic event-located DOP853 reference of gearsym.bench.

It also records cold and cached compile times per scene, and the cost of one
shooting solve per tolerance when ``System.periodic_orbit`` exists.

Usage::

    .venv/bin/python benchmarks/work_precision.py [--out DIR] [--cases NAME ...] [--quick]

Writes ``DIR/work_precision.json``, one ``DIR/wp_<case>.png`` per case and
``DIR/work_precision_table.md`` (default ``out/bench``); ``--docs`` also copies the
plots to ``docs/performance/``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "tests"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import reference as ks_reference  # noqa: E402  (tests/reference.py)

import gearsym  # noqa: E402
from gearsym import bench  # noqa: E402

KS = ROOT / "scenes" / "kahraman_singh.toml"


def ks_reference_for(system, x0, grid, exact: bool) -> bench.Reference:
    """The hand-written references of tests/reference.py on the grid."""
    p = dict(system.params)
    t = time.perf_counter()
    if exact:
        y, ev, _, _ = ks_reference.closed_form_linear(p, x0, grid)
        y_chk = None
        kind = "exact"
        desc = ("piecewise closed form for eps = 0 (tests/reference.py closed_form_linear): exact between "
                "contacts, contact times by brentq to ~1e-15")
    else:
        y, ev, _, _ = ks_reference.reference_solution(p, x0, grid)
        y_chk, _, _, _ = ks_reference.reference_solution(p, x0, grid, rtol=1e-12, atol=1e-14)
        kind = "tight"
        desc = ("hand-written event-located DOP853, rtol 1e-13 / atol 1e-15, restarted in the new contact mode "
                "at every crossing (tests/reference.py reference_solution); floor from a run at rtol 1e-12")
    return bench.Reference(y, kind, desc, y_chk, time.perf_counter() - t, int(len(ev)))


def cases() -> list[dict]:
    """The benchmark cases: label, scene, overrides, horizon, reference."""
    out = [
        {"label": "kahraman_singh", "scene": KS, "ks": "tight"},
        {"label": "kahraman_singh eps=0", "scene": KS, "overrides": {"eps": 0.0}, "ks": "exact"},
        {"label": "kahraman_singh chaotic", "scene": KS, "overrides": {"Omega": 0.8, "Fa": 0.6}, "ks": "tight",
         "periods": 500},
    ]
    for f in sorted((ROOT / "scenes").glob("*.toml")):
        if f.name == KS.name:
            continue
        c = {"label": f.stem, "scene": f}
        if f.stem.startswith("yu_"):
            c["periods"] = 40   # of the scenes' 200: the 10-state Python references would take hours
        out.append(c)
        if f.stem == "yu_dynamic_D14":
            # the shipped scene stays in contact after the transient (one event in 40 periods);
            # at omega* = 1 the same pair rattles: ~100 double-sided impacts in 40 periods
            out.append({"label": "yu_dynamic_D14 rattling", "scene": f, "overrides": {"Omega": 1.0},
                        "periods": 40})
    return out


def run_case(c: dict, args) -> dict:
    scene = gearsym.load_scene(c["scene"], **c.get("overrides", {}))
    system = scene.compile()
    T = system.period()
    periods = c.get("periods") or float(scene.spec.simulate.get("periods", 100))
    if args.max_periods:
        periods = min(periods, args.max_periods)
    if args.quick:
        periods = min(periods, 20)
    ref = None
    if "ks" in c:
        n = int(round(periods * args.points_per_period))
        grid = np.linspace(0.0, periods * T, n + 1)
        ref = ks_reference_for(system, system.x0, grid, c["ks"] == "exact")
    return bench.bench_scene(scene, label=c["label"], periods=periods, points_per_period=args.points_per_period,
                             rounds=args.rounds, reference=ref, rtols=args.rtols,
                             progress=lambda s: print(f"  [{c['label']}] {s}", flush=True),
                             max_seconds=args.max_seconds, single_run_s=args.single_run_s)


def event_effect(case: dict) -> list[dict]:
    """Error of stepping over the kinks relative to locating the events, same integrator."""
    rows = []
    by = {(r["method"], r["rtol"]): r for r in case["results"] if "best_s" in r}
    for rtol in case["rtols"]:
        row = {"rtol": rtol}
        for plain, located in (("scipy DOP853", "scipy DOP853 + events"), ("CasADi cvodes", "gearsym (bdf)")):
            a, b = by.get((plain, rtol)), by.get((located, rtol))
            if a and b:
                row[f"{plain} / {located}"] = {
                    "error_ratio": a["error"] / max(b["error"], 1e-300), "time_ratio": a["best_s"] / b["best_s"],
                    "rhs_ratio": (a["n_rhs"] / b["n_rhs"]) if a.get("n_rhs") and b.get("n_rhs") else None}
        rows.append(row)
    return rows


def event_table(all_cases: list[dict], rtols=(1e-4, 1e-6, 1e-8, 1e-10)) -> str:
    """Located events against stepping over the kinks, each pair with the same integrator.

    Cells: error ratio (stepped / located) and time ratio of scipy DOP853 (Python RHS in
    both), and error ratio and ratio of right-hand-side evaluations of CVODES BDF (CasADi's
    cvodes stepping over, gearsym's BDF locating: two implementations, so their time
    ratio would not measure the cost of locating).
    """
    pairs = (("scipy DOP853", "scipy DOP853 + events"), ("CasADi cvodes", "gearsym (bdf)"))
    head = ["| case | rtol | DOP853: error ratio stepped / located | DOP853: time ratio "
            "| CVODES BDF: error ratio stepped / located | CVODES BDF: RHS evaluations ratio |", "|---" * 6 + "|"]
    lines = list(head)
    for res in all_cases:
        c = res["case"]
        by = {r["rtol"]: r for r in event_effect(c)}
        for rtol in rtols:
            row = by.get(rtol)
            if not row:
                continue
            cells = []
            for plain, located in pairs:
                v = row.get(f"{plain} / {located}")
                if v is None:
                    cells += ["-", "-"]
                    continue
                cost = v["time_ratio"] if plain == "scipy DOP853" else v["rhs_ratio"]
                cells += [f"{v['error_ratio']:.2g}", "-" if cost is None else f"{cost:.2g}"]
            lines.append(f"| {c['case']} | {rtol:.0e} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def not_on_front(all_cases: list[dict]) -> list[str]:
    """``"case at rtol X (dominated by ...)"`` for every tolerance where gearsym is off the front."""
    out = []
    for res in all_cases:
        for rtol, v in res["case"]["pareto"]["by_rtol"].items():
            if not v["on_front"]:
                out.append(f"{res['case']['case']} at rtol {rtol} (dominated by {'; '.join(v['dominated_by'][:2])})")
    return out


def render_tables(good: list[dict]) -> str:
    """The markdown of every table, in the order of docs/performance.md."""
    return ("## Summary\n\n" + summary_table(good) + "\n\n## gearsym error (wall ms) by rtol\n\n"
            + "Use it to choose a tolerance: the error is the largest normalised state error over the "
              "whole horizon (up to the error horizon in chaotic regimes); `≤` marks errors at the "
              "reference's floor.\n\n"
            + tolerance_table(good) + "\n\n## Event location against stepping over the kinks\n\n"
            + "Ratios > 1 in the error columns: stepping over is less accurate than locating the "
              "switches with the same integrator at the same rtol; the cost ratios say what locating "
              "costs (< 1: stepping over is cheaper).\n\n"
            + event_table(good) + "\n\n## Periodic-orbit analyses\n\n" + analysis_table(good)
            + "\n\n## Every method\n\n" + markdown_table(good))


def machine_text(all_cases: list[dict]) -> str:
    """Which machine, which versions, how loaded, when (from the JSON's environment records)."""
    envs = [r.get("environment") or {} for r in all_cases]
    e = envs[0] if envs else {}
    loads = [x["loadavg"][0] for x in envs if x.get("loadavg")]
    load = f"{min(loads):.1f}-{max(loads):.1f}" if loads else "unknown"
    return (f"Machine: {e.get('cpu', '?')}, {e.get('cpu_count', '?')} cores, {e.get('platform', '?')}; "
            f"Python {e.get('python', '?')}, numpy {e.get('numpy', '?')}, scipy {e.get('scipy', '?')}, "
            f"casadi {e.get('casadi', '?')}, scikit-sundae {e.get('sksundae', '?')}, gearsym {e.get('gearsym', '?')}. "
            f"1-minute load average when each case started: {load} (2 cores, shared: read ratios within a row, "
            f"not absolute times).")


def write_docs(all_cases: list[dict], out: Path, total_wall_s: float | None) -> Path:
    """Copy the plots to docs/performance/ and rewrite docs/performance.md below its GENERATED marker."""
    good = [r for r in all_cases if "failed" not in r]
    dest = ROOT / "docs" / "performance"
    dest.mkdir(parents=True, exist_ok=True)
    for r in good:
        if "plot" in r:
            shutil.copy(out / r["plot"], dest / r["plot"])
    page = ROOT / "docs" / "performance.md"
    text = page.read_text()
    marker = "<!-- GENERATED -->"
    if marker not in text:
        raise SystemExit(f"{page}: no '{marker}' line to write below")
    off = not_on_front(good)
    front = ("gearsym is on the Pareto front (no other method both faster and more accurate) at every "
             "tolerance of every case." if not off else
             "gearsym is on the Pareto front at every tolerance except: " + "; ".join(off) + ".")
    failed = [r["case"]["case"] for r in all_cases if "failed" in r]
    when = time.strftime("%Y-%m-%d")
    body = [marker, "", f"## Results (one run, {when})", "",
            f"{len(good)} cases" + (f" in {total_wall_s / 60:.0f} min" if total_wall_s else "") + ". "
            + machine_text(good), "", front]
    if failed:
        body += ["", "Cases that failed to run: " + ", ".join(failed) + "."]
    body += ["", render_tables(good), "", "## Work-precision diagrams", ""]
    body += [f"![{r['plot'][:-4]}](performance/{r['plot']})" for r in good if "plot" in r]
    page.write_text(text.split(marker)[0] + "\n".join(body) + "\n")
    return page


def markdown_table(all_cases: list[dict]) -> str:
    """One table per case: rtol -> time and error of gearsym and each peer, Pareto status."""
    lines = []
    for res in all_cases:
        case = res["case"]
        meths = list(dict.fromkeys(r["method"] for r in case["results"]))
        lines.append(f"### {case['case']}\n")
        ref = case["reference"]
        div = case["divergence"]
        note = (f"; chaotic: error over the first {div['horizon_periods']:.3g} periods"
                if div["chaotic"] and div["horizon_periods"] else "")
        lines.append(f"{case['periods']:g} periods, {ref['kind']} reference (floor {ref['floor']:.0e}){note}. "
                     f"Each cell: wall ms / max normalised error.\n")
        lines.append("| rtol | " + " | ".join(meths) + " | gearsym on front |")
        lines.append("|---" * (len(meths) + 2) + "|")
        by = {(r["method"], r["rtol"]): r for r in case["results"]}
        par = case["pareto"]["by_rtol"]
        for rtol in case["rtols"]:
            cells = []
            for m in meths:
                r = by.get((m, rtol), {})
                if "best_s" in r:
                    cells.append(f"{r['best_s'] * 1e3:.3g} / {r['error']:.1e}")
                elif r.get("skipped"):
                    cells.append("skipped")
                else:
                    cells.append("failed" if r.get("failed") else "-")
            pr = par.get(f"{rtol:g}")
            front = "-" if pr is None else ("yes" if pr["on_front"] else "no: " + "; ".join(pr["dominated_by"][:2]))
            lines.append(f"| {rtol:.0e} | " + " | ".join(cells) + f" | {front} |")
        lines.append("")
    return "\n".join(lines)


def tolerance_table(all_cases: list[dict]) -> str:
    """Choosing a tolerance: gearsym's error (and wall ms) at each rtol, one column per case."""
    cases_ = [r["case"] for r in all_cases]
    rtols = sorted({t for c in cases_ for t in c["rtols"]}, reverse=True)
    lines = ["| rtol | " + " | ".join(c["case"] for c in cases_) + " |", "|---" * (len(cases_) + 1) + "|"]
    for rtol in rtols:
        cells = []
        for c in cases_:
            r = next((r for r in c["results"] if r["method"] == "gearsym" and r["rtol"] == rtol), None)
            if r is None or "best_s" not in r:
                cells.append("-")
            else:
                floor = "≤" if r.get("below_floor") else ""
                cells.append(f"{floor}{r['error']:.0e} ({r['best_s'] * 1e3:.2g} ms)")
        lines.append(f"| {rtol:.0e} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_table(all_cases: list[dict]) -> str:
    """One row per case: reference, horizon, compile, speed and error at rtol 1e-8, Pareto status."""
    lines = ["| case | reference (floor) | horizon | cold / cached compile | gearsym at 1e-8 | fastest peer at 1e-8 "
             "| most accurate peer at 1e-8 | gearsym on the front |", "|---" * 8 + "|"]
    for res in all_cases:
        c = res["case"]
        at = {r["method"]: r for r in c["results"] if r["rtol"] == 1e-8 and "best_s" in r}
        g = at.get("gearsym")
        peers = [r for m, r in at.items() if not r["gearsym"]]
        fast = min(peers, key=lambda r: r["best_s"]) if peers else None
        acc = min(peers, key=lambda r: r["error"]) if peers else None
        comp = res.get("compile") or {}
        div = c["divergence"]
        hor = f"{c['periods']:g} periods" + (f" (error over {div['horizon_periods']:.3g})" if div["chaotic"] else "")
        bad = [k for k, v in c["pareto"]["by_rtol"].items() if not v["on_front"]]

        def cell(r):
            return "-" if r is None else f"{r['method']}: {r['best_s'] * 1e3:.3g} ms, {r['error']:.0e}"
        lines.append(
            f"| {c['case']} | {c['reference']['kind']} ({c['reference']['floor']:.0e}) | {hor} | "
            f"{comp.get('cold_s', float('nan')):.1f} s / {comp.get('cached_s', float('nan')) * 1e3:.0f} ms | "
            f"{cell(g)} | {cell(fast)}" + (f" ({fast['best_s'] / g['best_s']:.0f}x)" if g and fast else "")
            + f" | {cell(acc)} | " + ("yes" if not bad else "no at rtol " + ", ".join(bad)) + " |")
    return "\n".join(lines)


def analysis_table(all_cases: list[dict]) -> str:
    """Shooting solve and continuation step: wall ms and multiplier error at each rtol."""
    dates = sorted({r["analysis_measured"]["date"] for r in all_cases if r.get("analysis_measured")})
    lines = []
    if dates:
        when = dates[0] if len(dates) == 1 else f"{dates[0]} to {dates[-1]}"
        lines.append(f"(Re-measured {when}, separately from the work-precision run.)\n")
    lines += ["| case | rtol | shooting ms (Newton its) | multiplier error (abs / rel. to max abs mu) "
             "| continuation ms/step |", "|---" * 5 + "|"]
    for res in all_cases:
        an = res.get("analysis") or {}
        sh = (an.get("shooting") or {})
        co = {r["rtol"]: r for r in ((an.get("continuation") or {}).get("rows") or [])}
        if not sh.get("rows"):
            reason = sh.get("failed") or sh.get("reason") or "not available"
            lines.append(f"| {res['case']['case']} | - | {reason[:80]} | - | - |")
            continue
        for r in sh["rows"]:
            if r["rtol"] not in (1e-4, 1e-6, 1e-8, 1e-10):
                continue
            c = co.get(r["rtol"], {})
            shc = "failed" if "failed" in r else f"{r['wall_s'] * 1e3:.3g} ({r['iterations']})"
            me = "-" if r.get("multiplier_error") is None else f"{r['multiplier_error']:.0e}"
            if r.get("multiplier_error_rel") is not None:
                me += f" / {r['multiplier_error_rel']:.0e}"
            cc = "failed" if "failed" in c else (f"{c['wall_per_step_s'] * 1e3:.3g}" if c else "-")
            lines.append(f"| {res['case']['case']} | {r['rtol']:.0e} | {shc} | {me} | {cc} |")
    return "\n".join(lines)


def remeasure_analyses(jfile: Path, labels: list[str] | None) -> int:
    """Re-measure the periodic-orbit analysis costs of the recorded cases (the work-precision
    data is kept), stamped with their own date and environment; rewrite the tables."""
    if not jfile.exists():
        print(f"--analyses-only: {jfile} does not exist (run the benchmark first)", file=sys.stderr)
        return 2
    data = json.loads(jfile.read_text())
    by_label = {c["label"]: c for c in cases()}
    for res in data["cases"]:
        label = res["case"]["case"]
        if "failed" in res or (labels and label not in labels) or label not in by_label:
            continue
        c = by_label[label]
        print(f"{label}: periodic-orbit analyses ...", flush=True)
        scene = gearsym.load_scene(c["scene"], **c.get("overrides", {}))
        system = scene.compile()
        res["analysis"] = bench.analysis_costs(system, res["case"]["rtols"], None, bench.scene_atol_ratio(scene))
        res["analysis_measured"] = {"date": time.strftime("%Y-%m-%d %H:%M"), "environment": bench.environment()}
    jfile.write_text(json.dumps(data, indent=1, default=bench._json_default))
    good = [r for r in data["cases"] if "failed" not in r]
    (jfile.parent / "work_precision_table.md").write_text(render_tables(good))
    print(f"wrote {jfile}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--cases", nargs="+", help="labels of the cases to run (default: all)")
    ap.add_argument("--quick", action="store_true", help="20 periods per case, one timing round")
    ap.add_argument("--rtols", type=float, nargs="+", help="override the tolerances")
    ap.add_argument("--points-per-period", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--max-periods", type=float, help="cap the horizon of every case")
    ap.add_argument("--max-seconds", type=float, default=20.0,
                    help="a method slower than this at one rtol is skipped at tighter ones")
    ap.add_argument("--single-run-s", type=float, default=0.5,
                    help="a method slower than this is timed by its first run alone")
    ap.add_argument("--docs", action="store_true",
                    help="copy the plots to docs/performance/ and rewrite the generated part of docs/performance.md")
    ap.add_argument("--analyses-only", action="store_true",
                    help="re-measure only the shooting / continuation costs of the cases in DIR/work_precision.json")
    ap.add_argument("--render", action="store_true",
                    help="run nothing: rewrite the tables (and with --docs the page) from DIR/work_precision.json")
    ap.add_argument("--append", action="store_true",
                    help="keep the other cases of an existing DIR/work_precision.json (re-running some cases)")
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds = 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jfile = out / "work_precision.json"
    if args.render:
        if not jfile.exists():
            print(f"--render: {jfile} does not exist (run the benchmark first)", file=sys.stderr)
            return 2
        data = json.loads(jfile.read_text())
        good = [r for r in data["cases"] if "failed" not in r]
        (out / "work_precision_table.md").write_text(render_tables(good))
        if args.docs:
            print(f"wrote {write_docs(data['cases'], out, data.get('total_wall_s'))}")
        return 0
    if args.analyses_only:
        return remeasure_analyses(jfile, args.cases)
    known = [c["label"] for c in cases()]
    for label in args.cases or []:
        if label not in known:
            print(f"--cases: unknown case '{label}' (have: {', '.join(known)})", file=sys.stderr)
            return 2
    selected = [c for c in cases() if not args.cases or c["label"] in args.cases]
    results = []
    kept: list[dict] = []
    if args.append and jfile.exists():
        labels = {c["label"] for c in selected}
        kept = [r for r in json.loads(jfile.read_text())["cases"] if r["case"]["case"] not in labels]
    t_all = time.perf_counter()
    for c in selected:
        print(f"{c['label']} ...", flush=True)
        t = time.perf_counter()
        try:
            res = run_case(c, args)
        except Exception as exc:  # one broken scene must not lose the others
            print(f"  FAILED: {type(exc).__name__}: {exc}", flush=True)
            results.append({"case": {"case": c["label"]}, "failed": f"{type(exc).__name__}: {exc}"})
            continue
        res["case"]["event_effect"] = event_effect(res["case"])
        res["wall_s"] = time.perf_counter() - t
        stem = "wp_" + c["label"].replace(" ", "_").replace("=", "")
        bench.plot_work_precision(res["case"], out / f"{stem}.png")
        res["plot"] = f"{stem}.png"
        results.append(res)
        print(bench.format_table(res["case"]), flush=True)
        # write after every case: a long run that is interrupted keeps what it measured
        good = [r for r in kept + results if "failed" not in r]
        jfile.write_text(json.dumps(
            {"benchmark": "work_precision", "environment": bench.environment(),
             "total_wall_s": time.perf_counter() - t_all, "cases": kept + results}, indent=1,
            default=bench._json_default))
        (out / "work_precision_table.md").write_text(render_tables(good))
    if args.docs:
        print(f"wrote {write_docs(kept + results, out, time.perf_counter() - t_all)}")
    n_fail = sum(1 for r in results if "failed" in r)
    print(f"done in {time.perf_counter() - t_all:.0f} s, {n_fail} failed case(s); wrote {out}")
    return 1 if n_fail and n_fail == len(results) else 0


if __name__ == "__main__":
    sys.exit(main())
