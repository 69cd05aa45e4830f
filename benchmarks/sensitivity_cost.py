"""What generating the parameter derivatives costs at compile time (and per step).

For the parameter sensitivities the code generator emits, for explicit models, in a
second build made on the first sensitivity request,
``gs_jacp = d f / d p`` for *all* parameters (sparse), ``gs_swp = d g / d p``,
``gs_schedp`` and ``gs_periodp``.  The alternative, generating them only for the
parameters a call asks for, would recompile whenever another parameter is asked for
(parameters are run-time, effects compile-time).  Measured here on shipped scenes
(interleaved, best of ``--rounds``): building the CasADi functions, writing the C and
compiling it (gcc, the driver object cached) with and without the four functions, and
their operation counts against ``gs_rhs`` / ``gs_jac``.

Usage::

    .venv/bin/python benchmarks/sensitivity_cost.py [--out out/bench] [--rounds 2]

Writes ``OUT/sensitivity_cost.json`` and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gearsym  # noqa: E402
from gearsym.codegen.generate import ENGINE_DIR, build_functions, model_c_sources  # noqa: E402
from gearsym.engine import build as engine_build  # noqa: E402

SCENES = ["kahraman_singh", "spur_pair_torsional", "vaishya_singh_fig3", "two_stage_train", "yu_dynamic_D14",
          "planetary_n6"]
SENS = ("gs_jacp", "gs_swp", "gs_schedp", "gs_periodp")


def compile_seconds(model, fns, tmp: Path, driver: Path) -> float:
    t0 = time.perf_counter()
    c_text, h_text = model_c_sources(model, fns, "bench", "0" * 64)
    (tmp / "gs_model.c").write_text(c_text)
    (tmp / "gs_model.h").write_text(h_text)
    engine_build.build_shared_object([Path("gs_model.c"), driver], [Path("."), ENGINE_DIR], tmp / "gs_model.so",
                                     cwd=tmp, extra_cflags=engine_build.model_cflags(len(c_text)))
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--scenes", nargs="+", default=SCENES)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="gearsym-senscost-") as td:
        driver = engine_build.driver_object(engine_build.driver_cache_dir(Path(td) / ".driver"))
        for name in args.scenes:
            scene = gearsym.load_scene(ROOT / "scenes" / f"{name}.toml")
            model = scene.model
            t0 = time.perf_counter()
            without = build_functions(model)
            build_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            fns = build_functions(model, derivatives=True)
            build_with_s = time.perf_counter() - t0
            best = {"with": float("inf"), "without": float("inf")}
            for _ in range(args.rounds):
                for kind, f in (("without", without), ("with", fns)):
                    d = Path(td) / f"{name}-{kind}"
                    d.mkdir(exist_ok=True)
                    best[kind] = min(best[kind], compile_seconds(model, f, d, driver))
            ops = {k: int(v.n_instructions()) for k, v in fns.items() if k in SENS or k in ("gs_rhs", "gs_jac")}
            row = {"scene": name, "nx": len(model.states), "np": len(model.parameters),
                   "build_functions_s": build_s, "build_functions_with_s": build_with_s, "compile_without_s": best["without"],
                   "compile_with_s": best["with"], "extra_fraction": best["with"] / best["without"] - 1,
                   "n_ops": ops}
            rows.append(row)
            print(f"{name:22s} nx={row['nx']:3d} np={row['np']:3d}  C+gcc without {best['without']:.2f} s, "
                  f"with {best['with']:.2f} s (+{100 * row['extra_fraction']:.0f} %)  ops {ops}")
    path = out / "sensitivity_cost.json"
    path.write_text(json.dumps({"benchmark": "sensitivity_cost", "rounds": args.rounds, "rows": rows,
                                "loadavg": os.getloadavg()}, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
