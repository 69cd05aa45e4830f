"""Exact vs finite-difference ``F_lambda`` in continuation: fold locations, Newton iterations, cost.

The continuation's parameter column ``F_lambda = d/dlambda [phi(T(lambda), x0; lambda) - x0]``
was a forward difference with step ``sqrt(rtol)`` of the parameter range; it is now the
exact derivative from the engine's parameter sensitivities (the parameter variational
equations with event-time terms, plus ``f dT/dlambda`` for the moving period).  Measured
here, in the same run:

1. ``F_lambda`` itself at one impacting orbit of the benchmark scene
   (``scenes/kahraman_singh.toml``, Omega = 1.2, and the dimensional
   ``scenes/spur_pair_torsional.toml`` in omega at its rattling point), at rtol 1e-6,
   1e-8, 1e-10, against a Richardson-extrapolated central difference of the residual at
   rtol 1e-13 (an independent reference), with the cost of one evaluation;
2. the benchmark scene's whole frequency response (Omega 0.6 -> 1.4, two folds, two
   grazings) continued with each ``F_lambda`` at rtol 1e-6, 1e-8, 1e-10: the fold
   locations against those of an exact-``F_lambda`` continuation at rtol 1e-12, the
   total corrector (Newton) iterations, the rejected steps, the integrations and the
   wall / CPU time (the two variants interleaved).

Usage::

    .venv/bin/python benchmarks/sensitivity_continuation.py [--out out/bench] [--rtols 1e-6 1e-8 1e-10]

Writes ``OUT/sensitivity_continuation.json`` and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gearsym  # noqa: E402
from gearsym.analysis.continuation._api import _fd_step  # noqa: E402
from gearsym.analysis.periodic import ShootingResidual, exact_f_lambda  # noqa: E402

KS = ROOT / "scenes" / "kahraman_singh.toml"
SPUR = ROOT / "scenes" / "spur_pair_torsional.toml"


def _richardson(fun, v: float, h: float) -> np.ndarray:
    d1 = (fun(v + h) - fun(v - h)) / (2 * h)
    d2 = (fun(v + h / 2) - fun(v - h / 2)) / h
    return (4 * d2 - d1) / 3


def f_lambda_accuracy(system, param: str, value: float, span: tuple[float, float], rtols: list[float],
                      repeats: int = 20) -> dict:
    """Error and cost of one F_lambda, exact and forward difference, at several tolerances."""
    orb = system.periodic_orbit(params={param: value}, rtol=1e-12, tol=1e-11)
    x = orb.x0
    scale = np.maximum(np.abs(x), 1e-300)
    tight = ShootingResidual(system, param, rtol=1e-13, atol=float(1e-15 * np.min(scale)))
    ref = _richardson(lambda v: tight.evaluate(x, v, jac=False).R, value, 1e-4 * abs(value))
    rows = []
    for rtol in rtols:
        res, res_fd = (ShootingResidual(system, param, rtol=rtol, atol=float(rtol * 1e-2 * np.min(scale)),
                                        fd_step=_fd_step(*span, rtol), f_lambda=f) for f in ("exact", "finite_difference"))
        R = res.evaluate(x, value, jac=False).R
        row = {"rtol": rtol}
        for kind in ("exact", "fd"):
            def one(kind=kind, res=res, res_fd=res_fd, R=R):
                if kind == "exact":
                    return exact_f_lambda(res, x, value)
                return res_fd._fd_lambda(x, value, R)
            got = one()
            t0 = time.perf_counter()
            for _ in range(repeats):
                one()
            row[kind] = {"max_rel_err": float(np.max(np.abs(got - ref) / np.max(np.abs(ref)))),
                         "ms_per_evaluation": 1e3 * (time.perf_counter() - t0) / repeats}
        rows.append(row)
    return {"scene": system.name, "param": param, "value": value, "orbit_x0": [float(v) for v in x],
            "reference": "Richardson-extrapolated central difference of the residual at rtol 1e-13",
            "rows": rows}


def run_branch(system, rtol: float, fd: bool) -> dict:
    kw = dict(progress=False, rtol=rtol, f_lambda="finite_difference" if fd else "exact")
    c0, t0 = time.process_time(), time.perf_counter()
    br = gearsym.continuation(system, "Omega", 0.6, 1.4, **kw)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"folds": sorted(b.value for b in br.of_type("fold")),
            "grazings": sorted(b.value for b in br.of_type("grazing")),
            "n_points": len(br.points), "newton_iterations": int(sum(p.iterations for p in br.points)),
            "complete": bool(br.complete), "info": {k: v for k, v in br.info.items() if np.isscalar(v)},
            "wall_s": wall, "cpu_s": cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-6, 1e-8, 1e-10])
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()
    ks = gearsym.load_scene(KS).compile()
    spur = gearsym.load_scene(SPUR).compile()

    acc = [f_lambda_accuracy(ks, "Omega", 1.2, (0.6, 1.4), args.rtols),
           f_lambda_accuracy(spur, "omega", spur.params["omega"], (0.8 * spur.params["omega"],
                                                                   1.2 * spur.params["omega"]), args.rtols)]
    ref = run_branch(ks, 1e-12, fd=False)
    branches = []
    for rtol in args.rtols:
        row = {"rtol": rtol}
        for fd in (False, True):  # interleaved: load hits both alike
            b = run_branch(ks, rtol, fd)
            if len(b["folds"]) == len(ref["folds"]):
                b["fold_err"] = [abs(a - r) for a, r in zip(b["folds"], ref["folds"], strict=True)]
                b["max_fold_err"] = max(b["fold_err"])
            row["fd" if fd else "exact"] = b
        branches.append(row)
    result = {
        "benchmark": "sensitivity_continuation",
        "f_lambda": acc,
        "continuation": {"scene": "kahraman_singh", "param": "Omega", "range": [0.6, 1.4],
                         "reference": {"rtol": 1e-12, "f_lambda": "exact", **ref}, "rows": branches},
        "environment": {"python": platform.python_version(), "platform": platform.platform(),
                        "cpu_count": os.cpu_count(), "loadavg_at_start": load0,
                        "loadavg_at_end": os.getloadavg()},
    }
    path = out / "sensitivity_continuation.json"
    path.write_text(json.dumps(result, indent=1))
    print("F_lambda: max relative error against the rtol 1e-13 reference, ms per evaluation")
    for a in acc:
        for r in a["rows"]:
            print(f"  {a['scene']:22s} rtol {r['rtol']:.0e}: exact {r['exact']['max_rel_err']:.2e} "
                  f"({r['exact']['ms_per_evaluation']:.2f} ms)   fd {r['fd']['max_rel_err']:.2e} "
                  f"({r['fd']['ms_per_evaluation']:.2f} ms)")
    print(f"continuation Omega 0.6 -> 1.4, reference folds {ref['folds']}")
    for row in branches:
        for kind in ("exact", "fd"):
            b = row[kind]
            print(f"  rtol {row['rtol']:.0e} {kind:5s}: fold err {b.get('max_fold_err', float('nan')):.2e}, "
                  f"Newton {b['newton_iterations']}, points {b['n_points']}, "
                  f"rejected {b['info'].get('n_rejected_steps')}, integrations {b['info'].get('n_integrations')}, "
                  f"wall {b['wall_s']:.2f} s, cpu {b['cpu_s']:.2f} s")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
