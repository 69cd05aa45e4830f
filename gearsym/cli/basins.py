"""``gearsym basins``: basins of attraction over a grid of two states.

Registered by :mod:`gearsym.cli.parser`.  Exit 0 with a map, 1 when the run failed (every cell's
integration failed, or no attractor was found for cells that stayed bounded), 2 on bad input.
Cells that failed or did not settle are counted in the output (and a warning goes to stderr).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from ..budget import LIMITS
from ..errors import ConvergenceError, ParameterError
from .checks import emit, float_list, load, scene_args
from .helptext import examples

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

    from ..analysis.sweeps import BasinOptions, BasinResult

__all__ = ["add_basins_parser", "cmd_basins", "parse_axis"]

#: option field -> its flag
_FLAGS = {"phase": "--phase", "periods_max": "--periods-max", "seeds": "--seeds", "rtol": "--rtol",
          "chunk": "--chunk", "hits": "--hits", "transient": "--transient", "max_period": "--max-period",
          "x": "--x", "y": "--y", "base": "--base", "workers": "--workers"}


def add_basins_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``basins`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "basins", help="basins of attraction: which initial state leads to which attractor (netCDF + map)",
        description="Basins of attraction over a grid of two states (the others at the scene's initial state or "
                    "--base), all taken at --phase of the forcing period.  Attractors are found automatically "
                    "(periodic orbits by shooting from the first landings, matched by their Poincare points; "
                    "non-periodic ones classified by the largest Lyapunov exponent); each cell is integrated "
                    "until its Poincare point stays in one attractor's neighbourhood.  Exit 1 if every cell "
                    "failed or no attractor was found.",
        epilog=examples(
            ("gearsym basins kahraman_singh --set Omega=0.87 --x x,0.5,2.5,12 --y v,-0.5,0.5,8 --workers 1",
             "the two coexisting orbits of the benchmark oscillator (in contact and impacting) and which of "
             "96 initial states leads to which"),
            ("gearsym basins kahraman_singh --set Omega=0.87 --x x,-2,4,10 --y v,-2,2,8 --workers 1 --json "
             "--out basins",
             "a wider plane as JSON, with basins.nc, basins.json and basins.png (400 x 400 cells on 2 cores: a "
             "few minutes)")))
    scene_args(p)
    p.add_argument("--x", required=True, metavar="STATE,LO,HI,N", help="horizontal axis: a state, its range and "
                   "number of grid points (N >= 2)")
    p.add_argument("--y", required=True, metavar="STATE,LO,HI,N", help="vertical axis (another state)")
    p.add_argument("--phase", type=float, help="phase of the forcing period of the initial states and the "
                   "Poincare section, in [0, 1) (default 0)")
    p.add_argument("--periods-max", type=int, help="forcing periods a cell is integrated at most (default 500)")
    p.add_argument("--seeds", type=int, help="cells integrated to find the attractors first (default 16)")
    p.add_argument("--transient", type=int, help="forcing periods from a seed before its attractor is identified "
                   "(default 300)")
    p.add_argument("--max-period", type=int, help="longest periodic orbit looked for, in forcing periods "
                   "(default 12)")
    p.add_argument("--chunk", type=int, help="forcing periods per C call between checks (default 2)")
    p.add_argument("--hits", type=int, help="consecutive Poincare points near an attractor that settle a cell "
                   "(default 3)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default 1e-8)")
    p.add_argument("--base", help="state of every cell before the two grid states are set, comma-separated "
                   "(default: the scene's initial state)")
    p.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--dask", metavar="ADDRESS", help="run on this Dask scheduler (default: local processes)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--out", help="folder for basins.nc, basins.json and basins.png")
    p.set_defaults(func=cmd_basins)


def parse_axis(text: str, flag: str) -> tuple[str, float, float, int]:
    """``STATE,LO,HI,N`` -> ``(state, lo, hi, n)``, the numbers checked (the state is checked
    against the scene later).

    Raises
    ------
    ParameterError
        Naming ``flag``: not four fields, non-numeric or non-finite LO/HI, LO >= HI, N not an
        integer >= 2 or above the limit of a map axis.
    """
    parts = [s.strip() for s in text.split(",")]
    if len(parts) != 4 or not parts[0]:
        raise ParameterError(f"{flag} expects STATE,LO,HI,N (e.g. x,-2,4,100), got '{text}'")
    lo, hi = float_list(",".join(parts[1:3]), flag)
    try:
        n = int(parts[3])
    except ValueError:
        raise ParameterError(f"{flag}: N must be an integer, got '{parts[3]}'") from None
    if not lo < hi:
        raise ParameterError(f"{flag}: need LO < HI, got {lo:g}, {hi:g}")
    if not 2 <= n <= LIMITS["map_axis"].high:
        raise ParameterError(f"{flag}: N must be in [2, {LIMITS['map_axis'].high:,}], got {n}")
    return parts[0], lo, hi, n


def _options(args: argparse.Namespace) -> BasinOptions:
    from ..analysis.sweeps import BasinOptions

    given = {name: getattr(args, name) for name in ("phase", "periods_max", "seeds", "rtol", "chunk", "hits",
                                                      "transient", "max_period")
             if getattr(args, name, None) is not None}
    try:
        return BasinOptions(**given)
    except ParameterError as exc:
        raise _flagged(exc) from None


def _flagged(exc: ParameterError) -> ParameterError:
    """The error with the option's flag in front when its message starts with an option's name."""
    msg = str(exc)
    for name, flag in _FLAGS.items():
        if msg.startswith(f"{name}:"):
            return ParameterError(f"{flag}{msg[len(name):]}")
        if msg.startswith((f"{name} ", f"{name}=")):
            return ParameterError(f"{flag}: {msg}")
    return exc


def _check(args: argparse.Namespace) -> tuple[tuple[str, float, float, int], tuple[str, float, float, int],
                                              list[float] | None, int]:
    """Every option before any work (exit 2 naming it)."""
    xa, ya = parse_axis(args.x, "--x"), parse_axis(args.y, "--y")
    if xa[0] == ya[0]:
        raise ParameterError(f"--x and --y must be different states, both are '{xa[0]}'")
    if xa[3] * ya[3] > LIMITS["map_points"].high:
        raise ParameterError(f"--x/--y: a basin of {xa[3]} x {ya[3]} cells is above the limit of "
                             f"{LIMITS['map_points'].high:,} cells")
    if args.rtol is not None and not (math.isfinite(args.rtol) and 1e-15 <= args.rtol < 1):
        raise ParameterError(f"--rtol must be in [1e-15, 1), got {args.rtol:g}")
    base = float_list(args.base, "--base") if args.base else None
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    if not 1 <= workers <= LIMITS["workers"].high:
        raise ParameterError(f"--workers must be in [1, {LIMITS['workers'].high}], got {workers}")
    if args.out:
        from ..extras import require
        from ..files import check_out_dir

        check_out_dir(args.out)
        require("maps", "gearsym basins --out (netCDF and figure)")
    if args.dask:
        from ..extras import require

        require("maps", "gearsym basins --dask")
    return xa, ya, base, workers


def cmd_basins(args: argparse.Namespace) -> int:
    """Basins of attraction of a scene over a grid of two states."""
    from ..analysis.sweeps import FAILED, UNBOUNDED, UNRESOLVED, basins

    xa, ya, base, workers = _check(args)
    opts = _options(args)
    scene = load(args)
    system = scene.compile()
    try:
        res = basins(system, xa, ya, options=opts, base=base, workers=workers, dask=args.dask,
                     progress=False if args.no_progress else None)
    except ParameterError as exc:
        raise _flagged(exc) from None
    n = res.labels.size
    failed, unbounded, unresolved = res.count(FAILED), res.count(UNBOUNDED), res.count(UNRESOLVED)
    if failed == n:
        raise ConvergenceError(f"the integration of every one of the {n} cells failed; first error: "
                               f"{res.stats.get('first_error') or 'none recorded'}")
    if not res.attractors and unbounded < n:
        raise ConvergenceError(f"no attractor found: {unresolved} cells did not settle within "
                               f"{opts.periods_max} forcing periods, {failed} failed"
                               + (f" (first error: {res.stats['first_error']})" if res.stats.get("first_error")
                                  else ""))
    info: dict[str, Any] = res.as_dict()
    if args.out:
        info["files"] = [str(f) for f in res.save(Path(args.out))]
    if args.json:
        emit(info)
    else:
        _print(res, info.get("files", []))
    if failed or unresolved:
        print(f"gearsym: warning: {failed} cell(s) failed, {unresolved} did not settle within {opts.periods_max} "
              f"forcing periods" + (f"; first error: {res.stats['first_error']}" if res.stats.get("first_error")
                                    else ""), file=sys.stderr)
    return 0


def _print(res: BasinResult, files: list[str]) -> None:
    st = res.stats
    print(f"{res.scene}: basins over ({res.x_state}, {res.y_state}), {res.x_values.size} x {res.y_values.size} "
          f"cells at phase {res.phase:g}, {st['wall_s']:.3g} s ({st['runner']}), {st['periods_integrated']:,} "
          f"forcing periods integrated (a cell settled after {res.periods.mean():.3g} on average)")
    for a in res.attractors:
        extra = (f"max|mu| = {a.max_multiplier:.6g}" if a.kind == "periodic"
                 else f"lambda_1 = {a.lyapunov:.4g} +- {a.lyapunov_error:.2g}")
        x0 = ", ".join(f"{n} = {v:.8g}" for n, v in zip(res.state_names, a.x0, strict=True))
        print(f"  {res.label_name(a.index)}: {res.count(a.index) / res.labels.size:.1%} of the cells; {extra}; {x0}")
    for lab, name in ((-1, "unresolved"), (-2, "unbounded"), (-3, "failed")):
        if res.count(lab):
            print(f"  {name}: {res.count(lab)} cell(s)")
    for f in files:
        print(f"wrote {f}")
