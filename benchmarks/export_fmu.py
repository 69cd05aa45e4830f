"""Exported models (``gearsym export``): cost and agreement with ``System.simulate``.

For each case (the benchmark scene's three regimes at rtol 1e-10, Vaishya & Singh Fig. 3
with its schedules, the Yu et al. 6-DOF pair at its scene value and rattling) this

* exports the scene (C project + FMU; the scene's compile is cached, so this is the
  export's own cost: evaluating the bound functions, writing the files, building the
  FMU binary) and builds the C project with ``make`` (scikit-sundae wheel's SUNDIALS);
* runs the C program, ``System.simulate`` and fmpy's ``simulate_fmu`` (its own CVODE,
  BDF, driven from Python callbacks) on the same output grid;
* records wall times and the agreement: the largest per-period state difference
  (absolute and relative to each state's largest value) and the event counts.

Usage::

    .venv/bin/python benchmarks/export_fmu.py [--out DIR] [--rounds 3]

Writes ``DIR/export_fmu.json`` (default ``out/bench``) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu

import gearsym
from gearsym.export import export_scene

ROOT = Path(__file__).resolve().parents[1]

#: (label, scene, params, periods, rtol, points per period)
CASES = [
    ("ks no impact", "kahraman_singh", {"Omega": 0.6}, 200, 1e-10, 64),
    ("ks single-sided", "kahraman_singh", {"Omega": 0.9}, 200, 1e-10, 64),
    ("ks double-sided (chaotic)", "kahraman_singh", {"Omega": 0.8, "Fa": 0.6}, 200, 1e-10, 64),
    ("vaishya_singh_fig3 (schedules)", "vaishya_singh_fig3", {}, 40, 1e-9, 400),
    ("yu_dynamic_D14", "yu_dynamic_D14", {}, 200, 1e-8, 64),
    ("yu_dynamic_D14 Omega=1 (rattling)", "yu_dynamic_D14", {"Omega": 1.0}, 200, 1e-8, 64),
]


def _best(fn, rounds: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(max(1, rounds)):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def export_case(scene_name: str, work: Path) -> dict:
    """Export one scene and build its C program."""
    scene = gearsym.load_scene(ROOT / "scenes" / f"{scene_name}.toml")
    scene.compile()  # warm the build cache: the export's own cost is measured below
    t = time.perf_counter()
    info = export_scene(scene, c_dir=work / f"{scene_name}_c", fmu=work / f"{scene_name}.fmu")
    export_s = time.perf_counter() - t
    t = time.perf_counter()
    proc = subprocess.run(["make", "-C", str(work / f"{scene_name}_c")], capture_output=True, text=True)
    make_s = time.perf_counter() - t
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    return {"export_s": export_s, "fmu_build_s": info["fmu"]["build_seconds"], "make_s": make_s,
            "program": str(work / f"{scene_name}_c" / info["c"]["program"]), "fmu": info["fmu"]["fmu"],
            "system": scene.compile()}


def run_case(label, scene_name, params, periods, rtol, ppp, ex, rounds) -> dict:
    system = ex["system"]
    ratio = system.defaults.get("atol", 1e-10) / system.defaults.get("rtol", 1e-8)
    atol = rtol * ratio
    T = system.period(params)
    n_out = int(periods * ppp) + 1
    py_s, traj = _best(lambda: system.simulate(periods=periods, n_out=n_out, rtol=rtol, atol=atol,
                                               params=params), rounds)
    args = [ex["program"], *(f"{k}={v!r}" for k, v in params.items()), f"periods={periods}", f"n_out={n_out}",
            f"rtol={rtol!r}", f"atol={atol!r}"]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.csv"
        c_s, proc = _best(lambda: subprocess.run(args + ["--out", str(out)], capture_output=True, text=True),
                          rounds)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr)
        got = np.genfromtxt(out, delimiter=",", names=True)
    c_inner_ms = float(re.search(r"([0-9.]+) ms", proc.stderr).group(1))
    fmu_s, res = _best(lambda: simulate_fmu(ex["fmu"], start_values=params, stop_time=periods * T,
                                            output_interval=T / ppp, relative_tolerance=rtol,
                                            output=system.state_names + ["n_events"], record_events=False),
                       1)
    idx = np.arange(0, n_out, ppp)
    scale = np.abs(traj.y).max(axis=0)
    names = system.state_names
    d_fmu = np.array([np.abs(res[s][idx] - traj.y[idx, i]) for i, s in enumerate(names)])
    d_c = np.array([np.abs(got[s] - traj.y[:, i]) for i, s in enumerate(names)])
    per_period = (d_fmu / scale[:, None]).max(axis=0)
    beyond = np.nonzero(d_fmu.max(axis=0) > 1e-6 * max(1.0, float(scale.max())))[0]
    return {
        "case": label, "scene": scene_name, "params": params, "periods": periods, "rtol": rtol, "atol": atol,
        "n_events_system": len(traj.events), "n_events_fmu": int(res["n_events"][-1]),
        "system_simulate_s": py_s, "c_program_s": c_s, "c_program_integration_ms": c_inner_ms,
        "fmpy_s": fmu_s, "fmpy_over_system": fmu_s / py_s,
        "c_max_abs_err": float(d_c.max()), "c_max_rel_err": float((d_c / scale[:, None]).max()),
        "fmu_max_abs_err": float(d_fmu.max()), "fmu_max_rel_err": float(per_period.max()),
        "fmu_first_period_over_1e-6": int(beyond[0]) if len(beyond) else None,
        "fmu_rel_err_at_period": {str(k): float(per_period[k]) for k in (5, 10, 20, 50, 100, 200)
                                  if k < len(per_period)},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--rounds", type=int, default=3, help="timing repeats of the C program and System.simulate")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()
    exports: dict[str, dict] = {}
    rows = []
    with tempfile.TemporaryDirectory(prefix="gearsym_export_bench_") as tmp:
        for label, scene_name, params, periods, rtol, ppp in CASES:
            if scene_name not in exports:
                exports[scene_name] = export_case(scene_name, Path(tmp))
                e = exports[scene_name]
                print(f"{scene_name}: export {e['export_s']:.2f} s (FMU build {e['fmu_build_s']:.2f} s), "
                      f"make {e['make_s']:.2f} s", flush=True)
            r = run_case(label, scene_name, params, periods, rtol, ppp, exports[scene_name], args.rounds)
            rows.append(r)
            print(f"  {label:36s} events {r['n_events_system']:4d}/{r['n_events_fmu']:4d}  "
                  f"C err {r['c_max_rel_err']:.1e}  FMU err {r['fmu_max_rel_err']:.1e} "
                  f"(>1e-6 from period {r['fmu_first_period_over_1e-6']})  "
                  f"simulate {r['system_simulate_s'] * 1e3:.0f} ms  C {r['c_program_s'] * 1e3:.0f} ms  "
                  f"fmpy {r['fmpy_s']:.2f} s ({r['fmpy_over_system']:.0f}x)", flush=True)
    data = {
        "benchmark": "export_fmu",
        "environment": {"python": platform.python_version(), "machine": platform.machine(),
                        "loadavg_start": load0, "loadavg_end": os.getloadavg(),
                        "fmpy": __import__("fmpy").__version__, "gearsym": gearsym.__version__},
        "exports": {k: {kk: vv for kk, vv in v.items() if kk not in ("system", "program", "fmu")}
                    for k, v in exports.items()},
        "cases": rows,
    }
    (out / "export_fmu.json").write_text(json.dumps(data, indent=1))
    print(f"wrote {out / 'export_fmu.json'}")


if __name__ == "__main__":
    main()
