"""``gearsym continue --follow ...``: bifurcation curves of periodic orbits in two parameters."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ..errors import ConvergenceError, ParameterError
from . import checks
from .checks import emit, load

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["add_curve_arguments", "cmd_continue_curve", "wants_curve"]

#: what ``--follow`` takes (gearsym.analysis.continuation.CURVE_TYPES, without importing it here)
FOLLOW = ("fold", "branch_point", "period_doubling", "neimark_sacker", "grazing")


def add_curve_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``gearsym continue`` that continue a bifurcation curve in two parameters."""
    g = p.add_argument_group("bifurcation curves in two parameters (--follow)")
    g.add_argument("--follow", choices=FOLLOW, help="continue this bifurcation curve in (--param, --param2) "
                   "(default with --start-from: the type of the special point)")
    g.add_argument("--param2", help="the second parameter (the vertical axis of the plane)")
    g.add_argument("--from2", dest="start2", type=float, help="lower end of --param2's range (default: unbounded)")
    g.add_argument("--to2", dest="stop2", type=float, help="upper end of --param2's range (default: unbounded)")
    g.add_argument("--start-from", metavar="BRANCH.json:INDEX", help="start at the special point INDEX (its "
                   "index in 'bifurcations') of a branch written by gearsym continue --json or --out")
    g.add_argument("--guess", metavar="VALUE,VALUE2", help="start near (--param, --param2) = (VALUE, VALUE2) "
                   "(the orbit's state from --x0, else a transient)")
    g.add_argument("--surface", help="grazing: the switching surface (default: the start's, else the one "
                   "whose extremum is nearest zero)")
    g.add_argument("--side", choices=("min", "max"), help="grazing: the extremum of the switching function that "
                   "touches zero (min: from g > 0)")
    g.add_argument("--direction", choices=("both", "forward", "backward"), default="both",
                   help="continue in both directions from the start (default), or with --param increasing "
                        "(forward) or decreasing (backward)")
    g.add_argument("--map", metavar="MAP.nc", help="draw the curve over this stability map of the same plane "
                   "(gearsym map --out writes map.nc); with --out")
    g.add_argument("--map-quantity", metavar="NAME", help="the map's variable drawn below the curve (default: "
                   "n_stable, the number of coexisting stable responses, where the map has it, else max_multiplier)")


def wants_curve(args: argparse.Namespace) -> bool:
    """Whether a ``gearsym continue`` command line asks for a bifurcation curve."""
    return any(getattr(args, k, None) is not None for k in ("follow", "param2", "start_from", "guess"))


def _check(args: argparse.Namespace) -> None:
    """The curve's options, before any work (exit 2 on bad input)."""
    if args.param2 is None:
        raise ParameterError("--param2 is needed for a bifurcation curve (--follow, --start-from, --guess)")
    if (args.start_from is None) == (args.guess is None):
        raise ParameterError("a bifurcation curve starts from one of --start-from BRANCH.json:INDEX or "
                             "--guess VALUE,VALUE2")
    if args.guess is not None and args.follow is None:
        raise ParameterError("--guess needs --follow (the type of the curve)")
    for flag, bad in (("--switch", args.switch is not None), ("--harmonics", args.harmonics is not None),
                      ("--quantity", getattr(args, "quantity", None) is not None),
                      ("--method hbm", args.method == "hbm"), ("--segments > 1", (args.segments or 1) > 1)):
        if bad:
            raise ParameterError(f"{flag} does not apply to bifurcation curves (single shooting with the monodromy)")
    for flag, v in (("--from2", args.start2), ("--to2", args.stop2)):
        if v is not None and not math.isfinite(v):
            raise ParameterError(f"{flag}: non-finite value {v}")
    if args.start2 is not None and args.stop2 is not None and not args.start2 < args.stop2:
        raise ParameterError(f"--from2 must be below --to2, got {args.start2:g} .. {args.stop2:g}")
    if args.map and not args.out:
        raise ParameterError("--map draws the curve over a map into --out: give --out")
    if args.map_quantity and not args.map:
        raise ParameterError("--map-quantity names a variable of --map: give --map")
    if args.map and not Path(args.map).is_file():
        raise ParameterError(f"--map: no such file '{args.map}'")


def _start(args: argparse.Namespace) -> Any:
    """The :class:`~gearsym.analysis.continuation.CurveStart` of the command line."""
    from ..analysis.continuation import CurveStart

    if args.guess is not None:
        vals = checks.float_list(args.guess, "--guess")
        if len(vals) != 2:
            raise ParameterError(f"--guess expects VALUE,VALUE2 (of --param and --param2), got '{args.guess}'")
        x0 = checks.float_list(args.x0, "--x0") if args.x0 else None
        return CurveStart.guess({args.param: vals[0], args.param2: vals[1]}, x0)
    path, sep, index = args.start_from.rpartition(":")
    if not sep or not path:
        raise ParameterError(f"--start-from expects BRANCH.json:INDEX, got '{args.start_from}'")
    try:
        i = int(index)
    except ValueError:
        raise ParameterError(f"--start-from: INDEX must be an integer, got '{index}'") from None
    import json

    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise ParameterError(f"--start-from: cannot read '{path}': {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ParameterError(f"--start-from: '{path}' is not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ParameterError(f"--start-from: '{path}' holds no branch (a JSON object of gearsym continue)")
    if data.get("param") not in (args.param, args.param2):
        raise ParameterError(f"--start-from: the branch in '{path}' varies '{data.get('param')}', which is neither "
                             f"--param {args.param} nor --param2 {args.param2}")
    return CurveStart.from_branch(data, i)


def cmd_continue_curve(args: argparse.Namespace) -> int:
    """Continue a bifurcation curve in two parameters: the curve, its codimension-2 points, JSON, figure."""
    from ..analysis.continuation import continue_bifurcation

    _check(args)
    start = _start(args)
    scene = load(args)
    for flag, name in (("--param", args.param), ("--param2", args.param2)):
        if name not in scene.model_spec.parameters:
            raise ParameterError(f"{flag} {name}: not a parameter of model '{scene.model_spec.name}' (have: "
                                 f"{', '.join(scene.model_spec.parameters)})")
    system = scene.compile()
    kw: dict[str, Any] = {k: getattr(args, k) for k in ("periods", "max_points", "rtol", "atol", "surface", "side")
                          if getattr(args, k) is not None}
    if args.ds_max is not None:
        kw["ds_max"] = args.ds_max
        kw["ds"] = min(0.01, args.ds_max)
    bounds2 = None
    if args.start2 is not None or args.stop2 is not None:
        bounds2 = (-math.inf if args.start2 is None else args.start2, math.inf if args.stop2 is None else args.stop2)
    curve = continue_bifurcation(system, args.follow, args.param, args.param2, args.start, args.stop,
                                 start_from=start, bounds2=bounds2, direction=args.direction, **kw)
    data = curve.as_dict()
    data["scene"] = scene.name
    if args.out:
        data["files"] = [str(f) for f in _write(curve, args, scene.name, data)]
    if args.json:
        emit(data)
    else:
        _print(curve, scene.name, data.get("files", []))
    if not curve.complete:
        for reason in curve.stop_reasons:
            print(f"gearsym: error: the {curve.type} curve stopped before its end: {reason}", file=sys.stderr)
        return ConvergenceError.exit_code
    return 0


def _write(curve: Any, args: argparse.Namespace, scene: str, data: dict[str, Any]) -> list[Path]:
    """``curve.json`` and ``curve.png`` (over ``--map``) into ``--out``."""
    import matplotlib

    matplotlib.use("Agg")
    from ..analysis.continuation import plot_curves
    from ..files import write_json

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    files = [write_json(out / "curve.json", data)]
    ds = None
    if args.map:
        import xarray as xr

        try:
            ds = xr.load_dataset(args.map)
        except (OSError, ValueError) as exc:
            raise ParameterError(f"--map: cannot read '{args.map}' as a netCDF map: {exc}") from None
    quantity = args.map_quantity or ("n_stable" if ds is not None and "n_stable" in ds else "max_multiplier")
    try:
        plot_curves([curve], stability_map=ds, quantity=quantity, path=out / "curve.png",
                    title=f"{scene}: {curve.type.replace('_', ' ')} curve")
    except ValueError as exc:
        raise ParameterError(f"--map: {exc}") from None
    files.append(out / "curve.png")
    return files


def _print(curve: Any, scene: str, files: list[str]) -> None:
    v1, v2 = curve.value, curve.value2
    print(f"{scene}: {curve.type.replace('_', ' ')} curve in ({curve.param}, {curve.param2}), {len(curve.points)} "
          f"points, {curve.param} {v1.min():.8g} .. {v1.max():.8g}, {curve.param2} {v2.min():.8g} .. {v2.max():.8g}; "
          f"{curve.info.get('formulation', '')}")
    for reason in curve.stop_reasons:
        print(f"  {reason}")
    for s in curve.special_points:
        where = f"({curve.param}, {curve.param2}) = ({s.value:.10g}, {s.value2:.10g})"
        extra = f" ({s.info['surface']}, {s.info['side']} g)" if "surface" in s.info else ""
        if s.info.get("located") is False:
            lo, hi = s.info["bracket"]
            print(f"  {s.type:24s} between {lo} and {hi}{extra}  detected, NOT located: {s.info.get('reason', '')}")
        else:
            print(f"  {s.type:24s} {where}{extra}")
    for f in files:
        print(f"wrote {f}")
