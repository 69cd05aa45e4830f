"""Basins of attraction: time, throughput, overhead, Dask speed-up, and agreement with a reference.

The scene: the benchmark oscillator (``scenes/kahraman_singh.toml``) at ``Omega = 0.87``, where a
stable orbit in permanent contact and a stable impacting orbit coexist; the plane ``x`` in
[-2, 4], ``v`` in [-2, 2] at phase 0.  Measured, in one run:

1. **batch**: the cost per trajectory of integrating 2 forcing periods from each of 400 states
   by one :meth:`System.flow` per state, one :meth:`Engine.run` per state, and one
   :func:`gearsym.engine.batch.run_batch` for all (the per-call overhead the batched C entry
   removes);
2. **main**: an ``N x N`` basin (default 400 x 400) on the local cores (``--workers``, default 2):
   wall time, CPU time, forcing periods and events integrated, and the throughput:
   trajectories (cells) and events per second per core (wall time x workers) and per CPU second;
3. **overhead**: the *bare* integration time of the same periods -- for a random sample of cells
   (``--bare-sample``), one :meth:`Engine.run` per cell over exactly the periods that cell was
   integrated until it settled, no output grid, no checks -- extrapolated to all cells; the
   overhead ratio is the run's CPU time (and wall time x workers) over it.  Everything else is
   overhead: the attractor discovery (seeds, shooting, a Lyapunov run for a non-periodic
   attractor), the periods a cell runs past its settling inside its last chunk, restarts of the
   integrator between chunks, the neighbourhood checks and the task plumbing;
4. **dask**: an ``M x M`` basin (``--dask-n``, default 200) on a ``dask.distributed.LocalCluster``
   with 1 and then 2 worker processes (one thread each): the speed-up; the same basin serially
   in this process for reference;
5. **agreement**: 300 random initial states in the plane classified by the hand-written
   scipy reference of ``tests/test_basins.py`` (``solve_ivp`` DOP853 with terminal events at the
   backlash surfaces, integrated until the Poincare point stays within 0.01 of one of the two
   orbits), compared with the main map except within one cell of a boundary.

Usage::

    .venv/bin/python benchmarks/basins_speed.py                       # -> out/bench/basins_speed.json + .png
    .venv/bin/python benchmarks/basins_speed.py --n 100 --dask-n 60   # a quick run
    .venv/bin/python benchmarks/basins_speed.py --skip dask,agreement

On this shared 2-core machine the wall times depend on the load of other processes (recorded:
the load average at start and end); CPU times are the steadier measure.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OMEGA = 0.87
BOX = (("x", -2.0, 4.0), ("v", -2.0, 2.0))


def _system():
    import gearsym

    return gearsym.load_scene(str(ROOT / "scenes" / "kahraman_singh.toml"), Omega=OMEGA).compile()


def _axes(n: int) -> tuple[tuple[str, float, float, int], tuple[str, float, float, int]]:
    return (*BOX[0], n), (*BOX[1], n)


# ------------------------------------------------------------------ 1. batch vs per call
def bench_batch(system: Any, n: int = 400, periods: int = 2) -> dict[str, Any]:
    """Per-trajectory cost of ``periods`` forcing periods from ``n`` states, three ways."""
    from gearsym.engine.batch import run_batch

    T, p = system.period(), system.param_vector()
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(-2, 4, n), rng.uniform(-2, 2, n)])
    grid = T * np.arange(1, periods + 1)
    kw = {"rtol": 1e-8, "atol": 1e-10, "max_step": T / 8}

    def flow() -> None:
        for x in X:
            system.flow(x, 0.0, periods * T, p, monodromy=False, n_samples=periods + 1, **kw)

    def run() -> None:
        for x in X:
            system.engine.run(x, p, 0.0, periods * T, grid, method="adams", **kw)

    def batch() -> None:
        run_batch(system.engine, X, p, 0.0, periods * T, grid, method="adams", **kw)

    out: dict[str, Any] = {"states": n, "periods": periods}
    for name, fn in (("System.flow per state", flow), ("Engine.run per state", run), ("run_batch", batch)):
        fn()  # warm-up
        best, cpu = np.inf, np.inf
        for _ in range(5):
            t, c = time.perf_counter(), time.process_time()
            fn()
            best, cpu = min(best, time.perf_counter() - t), min(cpu, time.process_time() - c)
        out[name] = {"us_per_trajectory": best / n * 1e6, "cpu_us_per_trajectory": cpu / n * 1e6}
    base = out["run_batch"]["cpu_us_per_trajectory"]
    for name in ("System.flow per state", "Engine.run per state"):
        out[name]["overhead_us_vs_batch"] = out[name]["cpu_us_per_trajectory"] - base
    return out


# ------------------------------------------------------------------ 2-3. the main map and its overhead
def bench_main(system: Any, n: int, workers: int, out_dir: Path) -> tuple[Any, dict[str, Any]]:
    from gearsym.analysis.sweeps import basins

    xa, ya = _axes(n)
    t, c = time.perf_counter(), time.process_time()
    res = basins(system, xa, ya, workers=workers, progress=None)
    wall, parent_cpu = time.perf_counter() - t, time.process_time() - c
    st = res.stats
    cpu = st["cpu_seconds"] + parent_cpu if workers > 1 else parent_cpu
    cores = min(workers, os.cpu_count() or 1)
    files = res.save(out_dir, stem="basins_speed_map")
    info = {"n": n, "cells": int(res.labels.size), "workers": workers, "wall_s": wall, "cpu_s": cpu,
            "parent_cpu_s": parent_cpu, "stats": st,
            "attractors": [a.as_dict(res.state_names) for a in res.attractors],
            "fractions": {res.label_name(k): v for k, v in res.fractions.items()},
            "periods_until_settled": {"sum": int(res.periods.sum()), "mean": float(res.periods.mean()),
                                      "median": float(np.median(res.periods)), "max": int(res.periods.max())},
            "throughput": {
                "trajectories_per_s_per_core": res.labels.size / (wall * cores),
                "events_per_s_per_core": st["events"] / (wall * cores),
                "trajectories_per_cpu_s": res.labels.size / cpu,
                "events_per_cpu_s": st["events"] / cpu,
                "periods_per_cpu_s": st["periods_integrated"] / cpu},
            "files": [str(f) for f in files]}
    return res, info


def bench_bare(system: Any, res: Any, sample: int) -> dict[str, Any]:
    """The bare integration time of the periods the cells needed, from a sample, extrapolated."""
    T, p = system.period(), system.param_vector()
    rng = np.random.default_rng(1)
    flat = np.argsort(rng.random(res.labels.size))[:sample]
    X = np.array([[res.x_values[i % res.x_values.size], res.y_values[i // res.x_values.size]] for i in flat])
    P = res.periods.ravel()[flat]
    # the run's tolerances: 1e-2 rtol times each state's magnitude on the grid, the base state and the attractors
    mag = np.max(np.abs(np.vstack([[res.x_values[[0, -1]].max(), res.y_values[[0, -1]].max()],
                                   [abs(res.x_values[0]), abs(res.y_values[0])], np.abs(res.base)]
                                  + [np.abs(a.minimum) for a in res.attractors]
                                  + [np.abs(a.maximum) for a in res.attractors])), axis=0)
    atol = 1e-2 * res.options.rtol * mag
    kw = {"method": "adams", "rtol": res.options.rtol, "atol": float(atol.min()), "atol_vec": atol, "max_step": T / 8}
    t, c = time.perf_counter(), time.process_time()
    for x, k in zip(X, P, strict=True):
        system.engine.run(x, p, 0.0, int(k) * T, None, **kw)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    scale = res.periods.sum() / max(P.sum(), 1)
    return {"sample_cells": int(sample), "sample_periods": int(P.sum()), "bare_wall_s": wall * scale,
            "bare_cpu_s": cpu * scale, "us_per_period": cpu / max(P.sum(), 1) * 1e6,
            "how": "one Engine.run per sampled cell over the periods it needed until it settled (no output, "
                   "no checks), extrapolated by the total periods until settled"}


# ------------------------------------------------------------------ 4. Dask
def bench_dask(system: Any, n: int) -> dict[str, Any]:
    """An ``n x n`` basin serially, then on LocalClusters of 1, 2, 2 and 1 worker processes (ABBA order
    against drifting load; the best of each count, wall time and the CPU time of the settling tasks)."""
    from distributed import Client, LocalCluster

    from gearsym.analysis.sweeps import basins

    xa, ya = _axes(n)
    out: dict[str, Any] = {"n": n, "cells": n * n, "runs": []}
    t = time.perf_counter()
    ref = basins(system, xa, ya)
    out["serial_in_process_s"] = time.perf_counter() - t
    for k in (1, 2, 2, 1):
        with LocalCluster(n_workers=k, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            client.run(lambda: __import__("gearsym"))  # imports on the workers are not timed
            t = time.perf_counter()
            res = basins(system, xa, ya, dask=client)
            out["runs"].append({"workers": k, "wall_s": time.perf_counter() - t,
                                "task_cpu_s": res.stats["cpu_seconds"], "load": os.getloadavg()[0],
                                "same_labels": bool(np.array_equal(res.labels, ref.labels))})
    for k in (1, 2):
        out[f"dask_{k}_workers_s"] = min(r["wall_s"] for r in out["runs"] if r["workers"] == k)
    out["speedup_1_to_2"] = out["dask_1_workers_s"] / out["dask_2_workers_s"]
    out["same_labels"] = all(r["same_labels"] for r in out["runs"])
    return out


# ------------------------------------------------------------------ 5. agreement with the reference
def _reference_module() -> Any:
    spec = importlib.util.spec_from_file_location("gearsym_tests_basins", ROOT / "tests" / "test_basins.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def bench_agreement(res: Any, n_states: int = 300) -> dict[str, Any]:
    tb = _reference_module()
    refs = [tb.reference_poincare(x0, tb.KS, 200)[-1] for x0 in ([3.0, 1.0], [1.15, 0.0])]
    to_map = [int(np.argmin([np.max(np.abs(a.x0 - r)) for a in res.attractors])) for r in refs]
    lab = res.labels
    rng = np.random.default_rng(28)
    X = np.column_stack([rng.uniform(*BOX[0][1:], n_states), rng.uniform(*BOX[1][1:], n_states)])
    dx, dv = res.x_values[1] - res.x_values[0], res.y_values[1] - res.y_values[0]
    near = agree = disagree = 0
    bad: list[list[float]] = []
    t = time.perf_counter()
    for x in X:
        j = int(np.clip(round((x[0] - res.x_values[0]) / dx), 0, lab.shape[1] - 1))
        i = int(np.clip(round((x[1] - res.y_values[0]) / dv), 0, lab.shape[0] - 1))
        block = lab[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2]
        if np.any(block != block.flat[0]):
            near += 1
            continue
        k = tb.reference_label(x, refs, tb.KS)
        if k >= 0 and to_map[k] == lab[i, j]:
            agree += 1
        else:
            disagree += 1
            bad.append([float(x[0]), float(x[1]), int(k), int(lab[i, j])])
    return {"states": n_states, "within_one_cell_of_a_boundary": near, "compared": agree + disagree,
            "agree": agree, "disagree": disagree, "disagreements": bad, "reference_s": time.perf_counter() - t,
            "reference": "tests/test_basins.py: reference_label (solve_ivp DOP853, terminal events at x = +-b)"}


def _main_and_overhead(system: Any, args: argparse.Namespace, report: dict[str, Any], out_dir: Path) -> Any:
    res, report["main"] = bench_main(system, args.n, args.workers, out_dir)
    print(f"main: {args.n} x {args.n} in {report['main']['wall_s']:.1f} s", flush=True)
    report["bare"] = bench_bare(system, res, min(args.bare_sample, res.labels.size))
    m, b = report["main"], report["bare"]
    cores = min(args.workers, os.cpu_count() or 1)
    report["overhead"] = {"cpu_ratio": m["cpu_s"] / b["bare_cpu_s"],
                          "wall_x_cores_ratio": m["wall_s"] * cores / b["bare_wall_s"],
                          "c_cpu_ratio": m["stats"]["c_cpu_seconds"] / b["bare_cpu_s"],
                          "periods_integrated_per_period_needed":
                              m["stats"]["periods_integrated"] / m["periods_until_settled"]["sum"]}
    print("overhead:", report["overhead"], flush=True)
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=400, help="grid points per axis of the main map (default 400)")
    ap.add_argument("--workers", type=int, default=2, help="local worker processes of the main map (default 2)")
    ap.add_argument("--dask-n", type=int, default=200, help="grid points per axis of the Dask runs (default 200)")
    ap.add_argument("--bare-sample", type=int, default=2000, help="cells of the bare-integration sample")
    ap.add_argument("--skip", default="", help="comma-separated: batch, main, dask, agreement (main: also "
                    "skips agreement and the overhead)")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"), help="output folder")
    args = ap.parse_args(argv)
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    system = _system()
    report: dict[str, Any] = {"scene": "kahraman_singh", "Omega": OMEGA, "box": BOX, "python": sys.version.split()[0],
                              "machine": platform.machine(), "cpus": os.cpu_count(), "load_start": os.getloadavg()}
    if "batch" not in skip:
        report["batch"] = bench_batch(system)
        print("batch:", json.dumps(report["batch"], indent=1), flush=True)
    if "main" not in skip:
        res = _main_and_overhead(system, args, report, out_dir)
    if "agreement" not in skip and "main" not in skip:
        report["agreement"] = bench_agreement(res)
        print("agreement:", {k: v for k, v in report["agreement"].items() if k != "disagreements"}, flush=True)
    if "dask" not in skip:
        report["dask"] = bench_dask(system, args.dask_n)
        print("dask:", report["dask"], flush=True)
    report["load_end"] = os.getloadavg()
    path = out_dir / "basins_speed.json"
    path.write_text(json.dumps(report, indent=1, default=str) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
