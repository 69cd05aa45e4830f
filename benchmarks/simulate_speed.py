"""Simulation speed and accuracy of gearsym against peer integrators.

200 forcing periods of the benchmark scene (scenes/kahraman_singh.toml: backlash
oscillator, Omega = 0.9, x0 = [1.1, 0], single-sided impacts, 395 contact
transitions) at rtol 1e-6, 1e-8, 1e-10 (atol = rtol/100), all in one run:

* gearsym ``System.simulate`` (one C call; compile excluded, reported separately:
  cold in a fresh ``GEARSYM_GENERATED`` temporary folder, and cached);
* scipy ``solve_ivp`` DOP853 and LSODA with a Python RHS (no events);
* scikit-sundae ``CVODE`` (BDF) with a Python RHS (no events);
* CasADi ``integrator('cvodes')``, one call with an output grid, ``if_else`` dead zone.

Each is timed as the best (and median) of repeats interleaved round-robin over the
methods (so load from other processes hits all of them alike); its error is the largest
state difference over the per-period states against the event-located DOP853
reference of ``tests/reference.py`` (rtol 1e-13).

Usage::

    .venv/bin/python benchmarks/simulate_speed.py [--out DIR] [--periods 200] [--rounds 5] [--slot 0.15]

Writes ``DIR/simulate_speed.json`` and ``DIR/simulate_speed.png`` (default
``out/bench``) and prints a table.  See ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
for _p in (ROOT, ROOT / "tests", HERE):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import reference  # noqa: E402  (tests/reference.py)
from peers import PEERS, Peer, PeerRun  # noqa: E402

import gearsym  # noqa: E402

SCENE = ROOT / "scenes" / "kahraman_singh.toml"
X0 = [1.1, 0.0]
#: Done-when of the issue, at rtol 1e-8.
DONE_WHEN = {"rtol": 1e-8, "min_ratio_dop853": 20.0, "min_ratio_casadi": 5.0}


class GearsymRun(Peer):
    """gearsym ``System.simulate`` on the same grid (compile done beforehand)."""

    def __init__(self, system, params, x0, grid, method: str = "adams"):
        super().__init__(params, x0, grid)
        self.system = system
        self.method = method
        self.name = "gearsym" if method == "adams" else f"gearsym ({method})"
        self.description = (f"gearsym System.simulate(method='{method}'): generated C + CVODE "
                            "with located contact events, one C call")

    def run(self) -> PeerRun:
        traj = self.system.simulate(t_end=float(self.grid[-1]), x0=self.x0, rtol=self.rtol,
                                    atol=self.atol, t_out=self.grid, method=self.method)
        s = traj.stats
        return PeerRun(np.asarray(traj.y), {"n_steps": int(s["n_steps"]), "n_rhs": int(s["n_rhs"]),
                                            "n_jac": int(s["n_jac"]), "n_events": len(traj.events)})


def time_round_robin(fns: list[Callable[[], PeerRun]], rounds: int, slot: float,
                     max_per_slot: int = 50
                     ) -> tuple[list[PeerRun | Exception], list[list[float]], list[list[float]]]:
    """Time several runs fairly on a busy machine.

    Each function is run once (warm-up; its output is kept for the error), then in
    each of ``rounds`` rounds every function runs back to back for about ``slot``
    seconds (at least once).  Interleaving the methods spreads load bursts from
    other processes over all of them instead of penalising whichever ran at the
    wrong moment.  Failures are returned in place of the output.  Returns the outputs,
    the wall times and the process CPU times of the timed runs.
    """
    firsts: list[PeerRun | Exception] = []
    reps: list[int] = []
    for fn in fns:
        t = time.perf_counter()
        try:
            firsts.append(fn())
        except Exception as exc:  # a failing peer must not lose the others' numbers
            firsts.append(exc)
        est = time.perf_counter() - t
        reps.append(int(min(max_per_slot, max(1, math.ceil(slot / max(est, 1e-6))))))
    times: list[list[float]] = [[] for _ in fns]
    cpu: list[list[float]] = [[] for _ in fns]
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            if isinstance(firsts[i], Exception):
                continue
            for _ in range(reps[i]):
                gc.collect()
                c = time.process_time()
                t = time.perf_counter()
                fn()
                times[i].append(time.perf_counter() - t)
                cpu[i].append(time.process_time() - c)
    return firsts, times, cpu


def compile_times() -> tuple[dict, object, Path]:
    """Cold (fresh GEARSYM_GENERATED folder) and cached compile times.

    The first cold compile of the process also pays the lazy imports (sympy,
    CasADi code generation); a second cold compile in another fresh folder gives
    the compile cost alone.
    """
    old = os.environ.get("GEARSYM_GENERATED")
    dirs = [Path(tempfile.mkdtemp(prefix="gearsym_bench_")) for _ in range(2)]
    out: dict[str, float] = {}
    try:
        for key, d in zip(("cold_first_in_process_s", "cold_s"), dirs, strict=True):
            os.environ["GEARSYM_GENERATED"] = str(d)
            t = time.perf_counter()
            scene = gearsym.load_scene(SCENE)
            system = scene.compile()
            out[key] = time.perf_counter() - t
            if getattr(system.generated, "cached", False):
                raise RuntimeError(f"compile in the fresh folder {d} was served from a cache")
        cached = []
        for _ in range(5):
            t = time.perf_counter()
            system = gearsym.load_scene(SCENE).compile()
            cached.append(time.perf_counter() - t)
        out["cached_s"] = min(cached)
        out["cached_median_s"] = statistics.median(cached)
        out["cached_hit"] = bool(getattr(system.generated, "cached", False))
    finally:
        if old is None:
            os.environ.pop("GEARSYM_GENERATED", None)
        else:
            os.environ["GEARSYM_GENERATED"] = old
    shutil.rmtree(dirs[0], ignore_errors=True)
    return out, system, dirs[1]


def environment(system) -> dict:
    import casadi
    import scipy
    import sksundae

    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {"python": platform.python_version(), "platform": platform.platform(),
            "machine": platform.machine(), "cpu_count": os.cpu_count(), "loadavg_at_start": load,
            "numpy": np.__version__, "scipy": scipy.__version__, "casadi": casadi.__version__,
            "sksundae": getattr(sksundae, "__version__", "?"), "gearsym": gearsym.__version__,
            "sundials_gearsym": getattr(system.engine, "sundials_version", "?")}


def fmt(v, spec=".3g"):
    return "-" if v is None else format(v, spec)


def print_table(results: list[dict], rtols: list[float]) -> None:
    head = (f"{'method':18s} {'best ms':>9s} {'median ms':>9s} {'x gearsym':>9s} {'x (cpu)':>8s} "
            f"{'steps':>8s} {'rhs':>8s} {'max err':>9s} {'final err':>9s} {'events':>6s}")
    for rtol in rtols:
        rows = [r for r in results if r["rtol"] == rtol]
        print(f"\nrtol = {rtol:g}, atol = {rows[0]['atol']:g}")
        print(head)
        print("-" * len(head))
        for r in rows:
            if r.get("failed"):
                print(f"{r['method']:18s} FAILED: {r['failed']}")
                continue
            print(f"{r['method']:18s} {r['best_s'] * 1e3:9.2f} {r['median_s'] * 1e3:9.2f} "
                  f"{r['ratio_to_gearsym']:9.1f} {r['cpu_ratio_to_gearsym']:8.1f} "
                  f"{fmt(r['n_steps'], 'd'):>8s} {fmt(r['n_rhs'], 'd'):>8s} "
                  f"{r['max_err']:9.2e} {r['final_err']:9.2e} {fmt(r.get('n_events'), 'd'):>6s}")


def plot(results: list[dict], rtols: list[float], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = ["o", "s", "^", "D", "v", "P"]
    fig, ax = plt.subplots(figsize=(9.0, 5.2))
    methods = list(dict.fromkeys(r["method"] for r in results))
    for i, m in enumerate(methods):
        rows = [r for r in results if r["method"] == m and not r.get("failed")]
        if not rows:
            continue
        color = f"C{i}"
        ax.plot([r["best_s"] for r in rows], [max(r["max_err"], 1e-16) for r in rows], "-", color=color,
                label=m, lw=1.2)
        for r in rows:
            ax.plot(r["best_s"], max(r["max_err"], 1e-16), markers[rtols.index(r["rtol"]) % len(markers)],
                    color=color, ms=7)
    for k, rtol in enumerate(rtols):
        ax.plot([], [], markers[k % len(markers)], color="0.4", label=f"rtol {rtol:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time, best of repeats [s] (compile excluded)")
    ax.set_ylabel("max state error over per-period states")
    ax.set_title("Backlash oscillator, 200 forcing periods (kahraman_singh)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def done_when(results: list[dict]) -> dict:
    rtol = DONE_WHEN["rtol"]
    row = {r["method"]: r for r in results if r["rtol"] == rtol and not r.get("failed")}
    g, d, c = row.get("gearsym"), row.get("scipy DOP853"), row.get("CasADi cvodes")
    if not (g and d and c):
        return {"evaluated": False, "reason": "a required method is missing or failed"}
    out = {
        "evaluated": True, "rtol": rtol,
        "ratio_dop853": d["ratio_to_gearsym"], "required_ratio_dop853": DONE_WHEN["min_ratio_dop853"],
        "ratio_casadi_cvodes": c["ratio_to_gearsym"], "required_ratio_casadi": DONE_WHEN["min_ratio_casadi"],
        "err_gearsym": g["max_err"], "err_dop853": d["max_err"], "err_casadi_cvodes": c["max_err"],
        "cpu_ratio_dop853": d["cpu_ratio_to_gearsym"], "cpu_ratio_casadi_cvodes": c["cpu_ratio_to_gearsym"],
    }
    out["speed_dop853_ok"] = d["ratio_to_gearsym"] >= DONE_WHEN["min_ratio_dop853"]
    out["speed_casadi_ok"] = c["ratio_to_gearsym"] >= DONE_WHEN["min_ratio_casadi"]
    out["error_ok"] = g["max_err"] <= min(d["max_err"], c["max_err"])
    out["holds"] = bool(out["speed_dop853_ok"] and out["speed_casadi_ok"] and out["error_ok"])
    out["holds_on_cpu_time"] = bool(d["cpu_ratio_to_gearsym"] >= DONE_WHEN["min_ratio_dop853"]
                                    and c["cpu_ratio_to_gearsym"] >= DONE_WHEN["min_ratio_casadi"]
                                    and out["error_ok"])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"), help="output folder (default out/bench)")
    ap.add_argument("--periods", type=int, default=200, help="forcing periods (default 200)")
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-6, 1e-8, 1e-10])
    ap.add_argument("--atol-factor", type=float, default=1e-2, help="atol = factor * rtol (default 1e-2)")
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (default 5)")
    ap.add_argument("--slot", type=float, default=0.15,
                    help="seconds each method runs back to back per round, at least one run (default 0.15)")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)

    print("compiling (cold, fresh GEARSYM_GENERATED) ...", flush=True)
    comp, system, tmp_dir = compile_times()
    try:
        params = dict(system.params)
        T = system.period()
        grid = T * np.arange(args.periods + 1)
        t = time.perf_counter()
        y_ref, ev_t, ev_s, ev_d = reference.reference_solution(params, X0, grid)
        ref_s = time.perf_counter() - t
        print(f"reference: {len(ev_t)} events, {ref_s:.2f} s", flush=True)
        env = environment(system)

        results: list[dict] = []
        for rtol in args.rtols:
            atol = rtol * args.atol_factor
            runners: list[Peer] = [GearsymRun(system, params, X0, grid, "adams"),
                                   GearsymRun(system, params, X0, grid, "bdf")]
            runners += [cls(params, X0, grid) for cls in PEERS]
            rows, ready = [], []
            for runner in runners:
                row = {"method": runner.name, "description": runner.description, "rtol": rtol, "atol": atol}
                try:
                    t = time.perf_counter()
                    runner.setup(rtol, atol)
                    row["setup_s"] = time.perf_counter() - t
                    ready.append((row, runner))
                except Exception as exc:
                    row["failed"] = f"setup: {type(exc).__name__}: {exc}"
                rows.append(row)
            print(f"  rtol {rtol:g}: timing {', '.join(r.name for _, r in ready)} ...", flush=True)
            firsts, times, cpus = time_round_robin([r.run for _, r in ready], args.rounds, args.slot)
            for (row, _runner), first, ts, cs in zip(ready, firsts, times, cpus, strict=True):
                if isinstance(first, Exception):
                    row["failed"] = f"{type(first).__name__}: {first}"
                    continue
                err = np.max(np.abs(first.y - y_ref), axis=1)
                row.update(best_s=min(ts), median_s=statistics.median(ts), repeats=len(ts),
                           cpu_best_s=min(cs), cpu_median_s=statistics.median(cs),
                           max_err=float(err.max()), final_err=float(err[-1]),
                           argmax_err_period=int(err.argmax()), **first.stats)
                for k in ("n_steps", "n_rhs", "n_jac", "n_events"):
                    row.setdefault(k, None)
            g = next(r for r in rows if r["method"] == "gearsym")
            for r in rows:
                if not r.get("failed"):
                    r["ratio_to_gearsym"] = r["best_s"] / g["best_s"] if not g.get("failed") else None
                    r["ratio_median_to_gearsym"] = (r["median_s"] / g["median_s"]
                                                    if not g.get("failed") else None)
                    r["cpu_ratio_to_gearsym"] = (r["cpu_best_s"] / g["cpu_best_s"]
                                                 if not g.get("failed") else None)
            results += rows

        dw = done_when(results)
        env["loadavg_at_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None
        data = {
            "benchmark": "simulate_speed",
            "scene": str(SCENE.relative_to(ROOT)), "params": params, "x0": X0, "periods": args.periods,
            "forcing_period": T, "output_grid": "one point per forcing period (periods + 1 points)",
            "atol_rule": f"atol = {args.atol_factor:g} * rtol",
            "timing": (f"one warm-up run each, then {args.rounds} round-robin rounds over the methods, "
                       f"each method running back to back for ~{args.slot:g} s (at least once) per round; "
                       "best and median over all timed runs"),
            "error": "max over per-period states of max(|x - x_ref|, |v - v_ref|)",
            "reference": {"method": "tests/reference.py reference_solution: event-located DOP853, "
                                    "rtol 1e-13, atol 1e-15, restarted at every contact",
                          "wall_s": ref_s, "n_events": int(len(ev_t))},
            "compile": comp, "environment": env, "results": results, "done_when": dw,
        }
        jpath = out_dir / "simulate_speed.json"
        jpath.write_text(json.dumps(data, indent=1))
        print_table(results, args.rtols)
        load = env.get("loadavg_at_start")
        if load and load[0] > 0.5 * (os.cpu_count() or 1):
            print(f"\nnote: machine busy during the run (1-min load average {load[0]:.2f} at start, "
                  f"{env['loadavg_at_end'][0]:.2f} at end, {os.cpu_count()} CPUs): absolute times are "
                  "inflated; compare ratios, above all the CPU-time ratios (x (cpu)), which "
                  "contention biases least")
        print(f"\ncompile: cold {comp['cold_s']:.2f} s (first in process, with imports: "
              f"{comp['cold_first_in_process_s']:.2f} s), cached {comp['cached_s'] * 1e3:.1f} ms")
        print(f"reference: {len(ev_t)} contact transitions over {args.periods} periods")
        if dw.get("evaluated"):
            print(f"\ndone-when at rtol {dw['rtol']:g}: DOP853/gearsym = {dw['ratio_dop853']:.1f} "
                  f"(need >= {dw['required_ratio_dop853']:g}: {'ok' if dw['speed_dop853_ok'] else 'NO'}), "
                  f"CasADi/gearsym = {dw['ratio_casadi_cvodes']:.1f} "
                  f"(need >= {dw['required_ratio_casadi']:g}: {'ok' if dw['speed_casadi_ok'] else 'NO'}), "
                  f"error {dw['err_gearsym']:.2e} vs DOP853 {dw['err_dop853']:.2e}, CasADi "
                  f"{dw['err_casadi_cvodes']:.2e} ({'ok' if dw['error_ok'] else 'NO'})"
                  f"  => {'HOLDS' if dw['holds'] else 'DOES NOT HOLD'}")
            print(f"  on process CPU time: DOP853/gearsym = {dw['cpu_ratio_dop853']:.1f}, CasADi/gearsym = "
                  f"{dw['cpu_ratio_casadi_cvodes']:.1f} => "
                  f"{'holds' if dw['holds_on_cpu_time'] else 'does not hold'}")
        else:
            print(f"\ndone-when not evaluated: {dw.get('reason')}")
        if not args.no_plot:
            plot(results, args.rtols, out_dir / "simulate_speed.png")
        print(f"wrote {jpath}" + ("" if args.no_plot else f" and {out_dir / 'simulate_speed.png'}"))
    finally:
        shutil.rmtree(tmp_dir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
