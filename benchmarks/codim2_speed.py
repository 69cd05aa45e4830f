"""The fold curve in two parameters: one curve vs. repeated one-parameter continuations.

The fold curve of the benchmark oscillator (``scenes/kahraman_singh.toml``, its impacting
frequency response) in the ``(Omega, Fa)`` plane, computed

* by ``continue_bifurcation`` (one call: the minimally augmented fold system on the
  monodromy with saltation, pseudo-arclength in ``(x0, Omega, Fa)``, both folds of the
  response and the cusp where they meet), and
* the way it was pieced together before (issue 28): one ``gearsym.continuation`` in Omega
  per value of Fa, each locating the folds of that frequency response.

The one-parameter continuations run at the values of Fa of ``--n`` points of the curve, so
their folds can be compared with the curve's points directly (the difference is reported:
both locate the same folds to the integration's accuracy).  Timing: ``--rounds`` rounds, the
two ways interleaved (the machine's load hits both), minimum and median reported.

Usage::

    .venv/bin/python benchmarks/codim2_speed.py [--out out/bench] [--n 7] [--rounds 3]

Writes ``OUT/codim2_speed.json`` and prints a table.
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
from gearsym.analysis.continuation import continue_bifurcation  # noqa: E402

SCENE = ROOT / "scenes" / "kahraman_singh.toml"
OMEGA = (0.5, 1.3)
FA = (0.0, 0.2)


def curve_run(system, branch, index):
    t = time.perf_counter()
    c = continue_bifurcation(system, "fold", "Omega", "Fa", *OMEGA, start_from=(branch, index), bounds2=FA)
    return time.perf_counter() - t, c


def repeated_runs(system, fas, omega_range):
    t = time.perf_counter()
    out, n_int = [], 0
    for fa in fas:
        br = gearsym.continuation(system, "Omega", *omega_range, params={"Fa": float(fa)}, progress=False)
        out.append([b.value for b in br.of_type("fold")])
        n_int += int(br.info.get("n_integrations", 0))
    return time.perf_counter() - t, out, n_int


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/bench", help="output folder (default out/bench)")
    ap.add_argument("--n", type=int, default=7, help="points of the curve whose Fa the one-parameter continuations take "
                    "(default 7; those within 0.005 of the cusp are left out)")
    ap.add_argument("--rounds", type=int, default=3, help="timing rounds (default 3)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    system = gearsym.load_scene(SCENE).compile()
    branch = gearsym.continuation(system, "Omega", 0.6, 1.3, params={"Fa": 0.05}, progress=False)
    index = min((k for k, b in enumerate(branch.bifurcations) if b.type == "fold"),
                key=lambda k: branch.bifurcations[k].value)
    _, curve = curve_run(system, branch, index)  # warm-up (and the curve the comparison is made on)
    cusp = curve.of_type("cusp")[0]
    picks = [k for k in np.linspace(2, len(curve) - 3, args.n).astype(int)
             if abs(curve.points[k].value2 - cusp.value2) > 0.005]
    fas = [curve.points[k].value2 for k in picks]
    repeated_runs(system, fas[:1], OMEGA)  # warm-up
    t_curve, t_rep = [], []
    for _ in range(args.rounds):
        dt, c = curve_run(system, branch, index)
        t_curve.append(dt)
        dt, folds, n_int = repeated_runs(system, fas, OMEGA)
        t_rep.append(dt)
    diffs = []
    for k, found in zip(picks, folds, strict=True):
        pt = curve.points[k]
        diffs.append(min(abs(f - pt.value) for f in found) if found else float("nan"))
    res = {
        "scene": str(SCENE.relative_to(ROOT)), "plane": ["Omega", "Fa"], "omega_range": OMEGA, "fa_range": FA,
        "curve": {"wall_s_min": min(t_curve), "wall_s_median": float(np.median(t_curve)), "points": len(curve),
                  "n_integrations": curve.info["n_integrations"], "complete": curve.complete,
                  "cusp": [cusp.value, cusp.value2]},
        "repeated": {"n_continuations": len(fas), "fa_values": fas, "wall_s_min": min(t_rep),
                     "wall_s_median": float(np.median(t_rep)), "n_integrations": n_int,
                     "folds_found": [len(f) for f in folds]},
        "ratio_repeated_to_curve": min(t_rep) / min(t_curve),
        "max_fold_difference": float(np.nanmax(diffs)),
        "rounds": args.rounds, "python": platform.python_version(), "machine": platform.machine(),
        "cpus": os.cpu_count(),
    }
    (out / "codim2_speed.json").write_text(json.dumps(res, indent=1) + "\n")
    print(f"fold curve in (Omega, Fa), {len(curve)} points, cusp at Omega = {cusp.value:.8f}, Fa = {cusp.value2:.8f}")
    print(f"{'':32s} {'wall s (min)':>12s} {'median':>8s} {'integrations':>13s}")
    print(f"{'one fold curve':32s} {min(t_curve):12.2f} {np.median(t_curve):8.2f} {curve.info['n_integrations']:13d}")
    print(f"{f'{len(fas)} continuations in Omega':32s} {min(t_rep):12.2f} {np.median(t_rep):8.2f} {n_int:13d}")
    print(f"ratio {res['ratio_repeated_to_curve']:.2f}; the folds of the continuations differ from the curve's "
          f"points by at most {res['max_fold_difference']:.2e}")
    print(f"wrote {out / 'codim2_speed.json'}")


if __name__ == "__main__":
    main()
