"""The cost of each effect of the Yu et al. 6-DOF model: RHS operations and simulate time.

For ``models/yu_6dof.toml`` this compiles the model with

* no optional effect (the bare torsional pair),
* each effect switched on alone (together with the effects it requires),
* all effects together,

and reports for each build the number of states, run-time parameters and switching
functions, the operation count of the generated right-hand side (``gs_rhs``), and the
wall time of a simulation (best of ``--repeats``).  Since effects are compile-time, an
effect that is off costs nothing: its terms, states and parameters are not in the C.

Run: ``python benchmarks/effects_cost.py [--periods 100] [--out out/bench]``.
Writes ``effects_cost.json`` and ``effects_cost.png``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gearsym  # noqa: E402
from gearsym.spec.model import load_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "yu_dynamic_D14.toml"


def closure(model, names: set[str]) -> set[str]:
    """The effects ``names`` together with everything they require (transitively)."""
    out = set(names)
    todo = list(names)
    while todo:
        for req in model.effects[todo.pop()].requires:
            if req not in out:
                out.add(req)
                todo.append(req)
    return out


def measure(effects_on: set[str], all_effects: list[str], periods: float, repeats: int,
            omega: float) -> dict:
    """Compile the model with exactly ``effects_on`` and time a simulation."""
    choice = {e: (e in effects_on) for e in all_effects}
    scene = gearsym.load_scene(SCENE, effects=choice)
    t0 = time.perf_counter()
    system = scene.compile()
    compile_s = time.perf_counter() - t0
    params = {"Omega": omega} if "Omega" in system.params else {}
    times = []
    traj = None
    for _ in range(repeats):
        traj = system.simulate(periods=periods, params=params, rtol=1e-8, atol=1e-14)
        times.append(traj.stats["wall_s"])
    gen = system.generated
    return {
        "effects": sorted(effects_on),
        "n_states": gen.nx,
        "n_params": len(gen.param_names),
        "n_switching_functions": gen.nsw,
        "n_ops_rhs": gen.n_ops["gs_rhs"],
        "n_ops_jac": gen.n_ops["gs_jac"],
        "simulate_best_s": min(times),
        "simulate_median_s": float(np.median(times)),
        "n_steps": traj.stats["n_steps"],
        "n_events": traj.stats["n_events"],
        "compile_s": compile_s,
        "compile_cached": gen.cached,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=float, default=100, help="forcing periods per simulation")
    parser.add_argument("--repeats", type=int, default=5, help="timing repeats (best is reported)")
    parser.add_argument("--omega", type=float, default=1.0,
                        help="dimensionless mesh frequency (1.0: the pair rattles)")
    parser.add_argument("--out", default="out/bench", help="output folder")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    model = load_model(gearsym.load_scene(SCENE).spec.model_path)
    effects = list(model.effects)
    # a meaningful base: backlash stays on (it is the physics of the model); the rest vary
    base = {"backlash"}
    cases = [("base (backlash only)", base)]
    for e in effects:
        if e in base:
            continue
        cases.append((f"+ {e}", closure(model, base | {e})))
    cases.append(("all effects", set(effects)))
    rows = []
    for label, on in cases:
        r = measure(on, effects, args.periods, args.repeats, args.omega)
        r["case"] = label
        rows.append(r)
        print(f"{label:38s} states {r['n_states']:2d}  params {r['n_params']:2d}  "
              f"surfaces {r['n_switching_functions']}  rhs ops {r['n_ops_rhs']:5d}  "
              f"simulate {r['simulate_best_s'] * 1e3:8.2f} ms  ({r['n_steps']} steps, "
              f"{r['n_events']} events)", flush=True)
    result = {
        "model": "yu_6dof",
        "scene": str(SCENE.relative_to(ROOT)),
        "periods": args.periods,
        "omega": args.omega,
        "machine": {"platform": platform.platform(), "processor": platform.processor(),
                    "python": platform.python_version()},
        "rows": rows,
    }
    (out / "effects_cost.json").write_text(json.dumps(result, indent=1))
    fig, axes = plt.subplots(1, 2, figsize=(12, 0.45 * len(rows) + 1.5), sharey=True)
    labels = [r["case"] for r in rows]
    y = np.arange(len(rows))
    axes[0].barh(y, [r["n_ops_rhs"] for r in rows], color="C0")
    axes[0].set_xlabel("operations in the generated right-hand side")
    axes[1].barh(y, [r["simulate_best_s"] * 1e3 for r in rows], color="C1")
    axes[1].set_xlabel(f"simulate {args.periods:g} periods [ms] (best of {args.repeats})")
    axes[0].set_yticks(y, labels)
    axes[0].invert_yaxis()
    fig.suptitle("yu_6dof: the cost of each effect (effects are compile-time)")
    fig.tight_layout()
    fig.savefig(out / "effects_cost.png", dpi=110)
    print(f"wrote {out / 'effects_cost.json'} and {out / 'effects_cost.png'}")


if __name__ == "__main__":
    main()
