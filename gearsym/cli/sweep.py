"""``gearsym sweep``: a brute-force bifurcation diagram of one parameter (forward and backward).

Registered by :mod:`gearsym.cli.parser`.  At each of ``--n`` values from ``--from`` to ``--to``
(and back), the state where the previous value ended is integrated ``--transient`` forcing
periods, then ``--samples`` Poincare points are kept and the largest Lyapunov exponent is
computed (:func:`gearsym.analysis.sweeps.bifurcation_diagram`).  Writes ``sweep.nc``,
``sweep.json`` and ``sweep.png`` into ``--out``.  Exit 0 when every value was computed, 1 when
every value failed (or some did: the others are still written, the reason goes to stderr), 2 on
bad input.
"""

from __future__ import annotations

import argparse
import math
import re
import sys

from ..budget import check_count
from ..errors import ConvergenceError, ParameterError
from .checks import emit, float_list, load, scene_args
from .helptext import examples

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["add_sweep_parser", "cmd_sweep"]


def add_sweep_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``sweep`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "sweep", help="brute-force bifurcation diagram of one parameter (Poincare points after a transient, "
                      "forward and backward, largest Lyapunov exponent)",
        description="Sweep one parameter forward and backward; at each value integrate --transient forcing "
                    "periods from where the previous value ended, keep --samples Poincare points (the state at "
                    "whole forcing periods) and compute the largest Lyapunov exponent.  The period of the response "
                    "(the smallest k whose section points repeat) and its kind (periodic, quasi-periodic, chaotic) "
                    "are reported per value.",
        epilog=examples(
            ("gearsym sweep kahraman_singh --set Fa=0.4 --param Omega --from 0.55 --to 0.64 --n 2 --transient 50 "
             "--samples 20 --lyapunov-periods 32 --workers 1 --out sweep",
             "two values either side of the period doubling at Omega = 0.6 (period 1, then 2), forward and "
             "backward; sweep.nc, sweep.json, sweep.png in sweep/ (gearsym[maps])"),
            ("gearsym sweep kahraman_singh --set Fa=0.4 --param Omega --from 0.55 --to 0.85 --n 16 --no-lyapunov "
             "--direction forward --workers 1 --out cascade",
             "the period-doubling cascade into chaos, forward only and without the Lyapunov exponent (quick; with "
             "it, and --n 61, about a minute)")))
    scene_args(p)
    p.add_argument("--param", required=True, help="the parameter to sweep")
    p.add_argument("--from", dest="start", type=float, required=True, help="first value (declared unit)")
    p.add_argument("--to", dest="stop", type=float, required=True, help="last value (declared unit)")
    p.add_argument("--n", type=int, required=True, help="number of values")
    p.add_argument("--direction", choices=["both", "forward", "backward"], default="both",
                   help="sweep directions (default both)")
    p.add_argument("--transient", type=int, help="forcing periods integrated at each value first (default 200)")
    p.add_argument("--samples", type=int, help="Poincare points kept per value (default 64)")
    p.add_argument("--no-lyapunov", action="store_true", help="no Lyapunov exponent")
    p.add_argument("--lyapunov-periods", type=int, help="forcing periods of the exponent (default 400, at least 32)")
    p.add_argument("--state", help="the state the figure shows (default: the first)")
    p.add_argument("--x0", help="the state at the first value of each direction, comma-separated (default: the "
                                "scene's initial state)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default: the scene's [simulate])")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default: the scene's [simulate])")
    p.add_argument("--workers", type=int, help="local processes (default: one per direction)")
    p.add_argument("--dask", metavar="ADDRESS", help="run on this Dask scheduler")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--out", required=True, help="folder for sweep.nc, sweep.json, sweep.png")
    p.set_defaults(func=cmd_sweep)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of :func:`bifurcation_diagram` from the command line, checked (exit 2 naming the flag)."""
    check_count("--n", args.n, rule="sweep_values")
    for flag, v in (("--rtol", args.rtol), ("--atol", args.atol)):
        if v is not None and not (math.isfinite(v) and 0 < v < 1):
            raise ParameterError(f"{flag}: tolerances must be positive, finite and below 1, got {v:g}")
    kw: dict[str, Any] = {"directions": ("forward", "backward") if args.direction == "both" else (args.direction,),
                          "lyapunov": not args.no_lyapunov, "progress": False if args.no_progress else None,
                          "dask": args.dask}
    for name in ("transient", "samples", "lyapunov_periods", "workers", "rtol", "atol"):
        v = getattr(args, name)
        if v is not None:
            kw[name] = v
    if args.x0:
        kw["x0"] = float_list(args.x0, "--x0")
    from ..analysis.sweeps import DiagramOptions

    try:
        DiagramOptions(**{k: v for k, v in kw.items() if k not in ("dask",)})
    except ParameterError as exc:
        msg = str(exc)
        name = re.match(r"[a-z_]*", msg).group(0)
        raise ParameterError(f"--{name.replace('_', '-')}: {msg}" if name else msg) from None
    return kw


def cmd_sweep(args: argparse.Namespace) -> int:
    """A brute-force bifurcation diagram; exit 1 when values failed."""
    from ..analysis.sweeps import bifurcation_diagram, diagram_summary, save_bifurcation_diagram
    from ..files import check_out_dir

    kw = _options(args)
    check_out_dir(args.out)
    scene = load(args)
    system = scene.compile()
    if args.state is not None and args.state not in system.state_names:
        raise ParameterError(f"--state: '{args.state}' is not a state (have: {', '.join(system.state_names)})")
    if "x0" in kw and len(kw["x0"]) != len(system.state_names):
        raise ParameterError(f"--x0: {len(kw['x0'])} values given, the model has {len(system.state_names)} states "
                             f"({', '.join(system.state_names)})")
    ds = bifurcation_diagram(system, args.param, args.start, args.stop, args.n, **kw)
    n_values = int(ds.sizes["direction"] * ds.sizes[args.param])
    if int(ds.attrs["n_failed"]) >= n_values:
        first = str(ds.attrs.get("errors", "")).splitlines()[:1]
        raise ConvergenceError(f"every one of the {n_values} values of the sweep failed"
                               + (f"; first error at {first[0]}" if first else ""))
    files = save_bifurcation_diagram(ds, args.out, state=args.state)
    info = {"scene": scene.name, **diagram_summary(ds), "files": [str(f) for f in files]}
    if args.json:
        emit(info)
    else:
        _print(info, args.param)
    if int(ds.attrs["n_failed"]):
        print(f"gearsym: error: {ds.attrs['n_failed']} value(s) failed: {ds.attrs['errors']}", file=sys.stderr)
        return 1
    return 0


def _print(info: dict[str, Any], param: str) -> None:
    from ..analysis.sweeps import ATTRACTOR_KINDS

    print(f"{info['scene']}: sweep of {param} over {len(info['values'])} values ({info['runner']}) in "
          f"{info['wall_s']:.2f} s ({info['values_per_second']:.3g} values/s)")
    for d in ("forward", "backward"):
        if d not in info:
            continue
        kinds = info[d]["kind"]
        per = info[d]["period"]
        counts = {f"period {k}": sum(1 for p, q in zip(per, kinds, strict=True) if q == 0 and p == k)
                  for k in sorted({p for p, q in zip(per, kinds, strict=True) if q == 0})}
        for code in (1, 2, 3):
            n = sum(1 for q in kinds if q == code)
            if n:
                counts[ATTRACTOR_KINDS[code].split(" (")[0]] = n
        print(f"  {d}: " + ", ".join(f"{k}: {v}" for k, v in counts.items()))
    for f in info["files"]:
        print(f"wrote {f}")
