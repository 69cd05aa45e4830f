"""The DAE scene on IDA against its explicit reduction on CVODE: work and accuracy.

``scenes/spur_pair_coupled_load.toml`` (the coupling torque an algebraic variable, IDA)
against ``tests/data/spur_pair_lumped_load.toml`` (the load lumped into the gear, hand
written, CVODE BDF) over ``--periods`` mesh periods at several ``rtol``: internal steps,
residual / right-hand side evaluations, wall time (min of ``--runs``), the relative error
of the differential states against the lumped model at ``rtol = 1e-12``, the relative
error of ``tau_c`` against ``J_L*w2' + T_L`` of that reference, and the monodromy (one
period, from the orbit) of both with its Floquet multipliers.

Run: ``.venv/bin/python benchmarks/ida_dae.py [--periods 100] [--runs 3] [--out out/bench]``;
writes ``ida_dae.json``.  Compare the rows with each other (same run, same machine).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import gearsym

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--periods", type=int, default=100)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--out", default="out/bench")
    args = parser.parse_args()
    dae = gearsym.load_scene(ROOT / "scenes" / "spur_pair_coupled_load.toml").compile()
    ode = gearsym.load_scene(ROOT / "tests" / "data" / "spur_pair_lumped_load_scene.toml").compile()
    grid = np.linspace(0.0, args.periods * dae.period(), 64 * args.periods + 1)
    ref = ode.simulate(t_out=grid, rtol=1e-12, atol=1e-16, method="bdf")
    acc = ode.engine.evaluate("rhs", ref.t, ref.y, ode.param_vector())[:, 3]
    tau = ode.params["J_L"] * acc + ode.params["T_L"]
    scale = np.max(np.abs(ref.y), axis=0)
    rows = []
    for rtol in (1e-6, 1e-8, 1e-10):
        for name, system, method in (("IDA (DAE)", dae, "ida"), ("CVODE BDF (lumped)", ode, "bdf")):
            walls = []
            for _ in range(args.runs):
                t = time.perf_counter()
                tr = system.simulate(t_out=grid, rtol=rtol, atol=1e-14, method=method)
                walls.append(time.perf_counter() - t)
            row = {"solver": name, "rtol": rtol, "steps": tr.stats["n_steps"], "evaluations": tr.stats["n_rhs"],
                   "events": len(tr.events), "wall_ms": 1e3 * min(walls),
                   "state_error": float(np.max(np.abs(tr.y[:, :4] - ref.y) / scale))}
            if system is dae:
                row["tau_c_error"] = float(np.max(np.abs(tr.y[:, 4] - tau)) / np.max(np.abs(tau)))
            rows.append(row)
            print(json.dumps(row))
    oi = dae.periodic_orbit(transient=40, rtol=1e-11, atol=1e-14)
    oc = ode.periodic_orbit(transient=40, rtol=1e-11, atol=1e-14)
    floq = {"ida": [[m.real, m.imag] for m in np.sort_complex(oi.multipliers)],
            "cvode": [[m.real, m.imag] for m in np.sort_complex(oc.multipliers)],
            "max_difference": float(np.max(np.abs(np.sort_complex(oi.multipliers) - np.sort_complex(oc.multipliers)))),
            "monodromy_difference": float(np.max(np.abs(oi.monodromy[:4, :4] - oc.monodromy))
                                          / np.max(np.abs(oc.monodromy)))}
    print(json.dumps(floq))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "ida_dae.json").write_text(json.dumps({"periods": args.periods, "rows": rows, "floquet": floq},
                                                 indent=1))
    print(f"wrote {out / 'ida_dae.json'}")


if __name__ == "__main__":
    main()
