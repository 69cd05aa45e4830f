"""``gearsym bench``: the work-precision benchmark (the only command that imports :mod:`gearsym.bench`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import checks
from .checks import emit, load

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = ["cmd_bench"]


def cmd_bench(args: argparse.Namespace) -> int:
    """Work-precision benchmark of a scene: error vs wall time for gearsym and the peers."""
    from .. import bench

    rtols = bench.parse_rtols(args.rtols) if args.rtols else None
    methods = bench.parse_methods(args.methods) if args.methods else None
    checks.check_bench(args)
    out = Path(args.out) if args.out else None
    scene = load(args)
    data = bench.bench_scene(scene, rtols=rtols, methods=methods, periods=args.periods,
                             points_per_period=args.points_per_period, rounds=args.rounds,
                             compile_timing=not args.no_compile_times, analyses=not args.no_analyses,
                             progress=None if args.json else (lambda s: print(s, file=sys.stderr)))
    if out is not None:
        data["files"] = bench.write_outputs(data, out, f"work_precision_{scene.name}")
    if args.json:
        emit(data)
    else:
        print(bench.format_table(data["case"]))
        for f in data.get("files", []):
            print(f"wrote {f}")
    return 0
