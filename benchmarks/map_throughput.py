"""Throughput of maps and brute-force sweeps: the coexistence search's cost, processes and Dask.

On the benchmark oscillator (``scenes/kahraman_singh.toml``):

1. **map** over Omega 0.76..0.92 x Fa 0.05..0.6 (``--nx`` x ``--ny`` points): the map's own row sweep
   only (``search="none"``) and with the coexistence search (``"all"``: rows, columns and starts), each
   serially, on 2 local processes, and on a Dask ``LocalCluster`` with 1 and 2 worker processes;
   points per second, orbit solves, forcing periods integrated by the search, the cost ratio of the
   search (wall with / wall without), the speed-up of 2 processes and of 2 Dask workers over 1;
2. **sweep** (:func:`gearsym.analysis.sweeps.bifurcation_diagram`) of Omega 0.55..0.85 at Fa 0.4,
   forward and backward, without the Lyapunov exponent: values per second, serially and on 2
   processes, and the overhead as the ratio of its wall time to the bare integration
   (``System.simulate``) of the same forcing periods from the same states.

Times are wall seconds of one run each (the machine is shared: compare within a run).

Usage::

    .venv/bin/python benchmarks/map_throughput.py                 # -> out/bench/map_throughput.json
    .venv/bin/python benchmarks/map_throughput.py --nx 6 --ny 3 --no-dask
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import gearsym  # noqa: E402
from gearsym.analysis.sweeps import bifurcation_diagram, stability_map  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _map(system, nx: int, ny: int, search: str, **run) -> dict:
    ds = stability_map(system, ("Omega", 0.76, 0.92, nx), ("Fa", 0.05, 0.6, ny), quantity="rattle_state",
                       method="shooting", search=search, progress=False, **run)
    return {"wall_s": ds.attrs["wall_s"], "points_per_second": ds.attrs["points_per_second"],
            "orbit_solves": ds.attrs["orbit_solves"], "periods_integrated": ds.attrs["periods_integrated"],
            "runner": ds.attrs["runner"], "n_coexisting": int(ds.attrs.get("n_coexisting", 0)),
            "n_chaotic": int(ds.attrs.get("n_chaotic", 0))}


def maps(system, nx: int, ny: int, dask: bool) -> dict:
    out: dict = {}
    for search in ("none", "all"):
        row = {"serial": _map(system, nx, ny, search, workers=1),
               "processes_2": _map(system, nx, ny, search, workers=2)}
        if dask:
            from distributed import Client, LocalCluster

            for n in (1, 2):
                with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
                        Client(c) as client:
                    row[f"dask_{n}"] = _map(system, nx, ny, search, dask=client)
        out[search] = row
        print(f"map search={search}: " + ", ".join(f"{k} {v['wall_s']:.2f} s" for k, v in row.items()), flush=True)
    out["search_cost_ratio_serial"] = out["all"]["serial"]["wall_s"] / out["none"]["serial"]["wall_s"]
    out["speedup_processes_2"] = {s: out[s]["serial"]["wall_s"] / out[s]["processes_2"]["wall_s"]
                                  for s in ("none", "all")}
    if dask:
        out["speedup_dask_1_to_2"] = {s: out[s]["dask_1"]["wall_s"] / out[s]["dask_2"]["wall_s"]
                                      for s in ("none", "all")}
    return out


def sweeps(system, n: int) -> dict:
    kw = {"params": {"Fa": 0.4}, "transient": 200, "samples": 48, "lyapunov": False, "progress": False}
    out = {}
    for label, workers in (("serial", 1), ("processes_2", 2)):
        t = time.perf_counter()
        ds = bifurcation_diagram(system, "Omega", 0.55, 0.85, n, workers=workers, **kw)
        out[label] = {"wall_s": time.perf_counter() - t, "values_per_second": ds.attrs["values_per_second"]}
    # the bare integration of the same periods from the same states (forward direction, then backward)
    t = time.perf_counter()
    for values in (np.linspace(0.55, 0.85, n), np.linspace(0.85, 0.55, n)):
        x = system.x0
        for v in values:
            p = {"Fa": 0.4, "Omega": float(v)}
            x = system.simulate(periods=200, x0=x, params=p, n_out=2).x_final
            x = system.simulate(periods=48, x0=x, params=p, n_out=8 * 48 + 1).x_final
    bare = time.perf_counter() - t
    out["bare_integration_s"] = bare
    out["overhead_ratio_serial"] = out["serial"]["wall_s"] / bare
    out["speedup_processes_2"] = out["serial"]["wall_s"] / out["processes_2"]["wall_s"]
    print(f"sweep of {n} values x 2 directions: serial {out['serial']['wall_s']:.2f} s, 2 processes "
          f"{out['processes_2']['wall_s']:.2f} s, bare integration {bare:.2f} s", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=8)
    ap.add_argument("--ny", type=int, default=4)
    ap.add_argument("--sweep-n", type=int, default=20)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args()
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    res = {"scene": "kahraman_singh", "grid": [args.nx, args.ny], "cpu_count": os.cpu_count(),
           "load_average": os.getloadavg(), "maps": maps(system, args.nx, args.ny, not args.no_dask),
           "sweep": sweeps(system, args.sweep_n)}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "map_throughput.json").write_text(json.dumps(res, indent=1))
    print(f"wrote {out / 'map_throughput.json'}")


if __name__ == "__main__":
    main()
