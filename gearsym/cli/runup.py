"""``gearsym runup``: a run-up (or run-down) of a speed parameter, its waterfall and Campbell diagram."""

from __future__ import annotations

import argparse
from typing import Any

from ..budget import check_count
from ..errors import ParameterError
from .checks import _nonnegative, _out, _positive, _tol, emit, load, scene_args
from .helptext import examples

__all__ = ["add_runup_parser", "cmd_runup"]


def add_runup_parser(sub: Any) -> None:
    """The ``gearsym runup`` subcommand."""
    p = sub.add_parser(
        "runup", help="run a speed parameter up (or down) in time: waterfall, Campbell diagram, mesh orders",
        description="Simulate a linear ramp of a speed parameter, exact in the engine (the model's time functions "
                    "and schedules run on the phase of the speed, their breakpoints the roots of a quadratic), "
                    "and track the recorded signal's spectra against speed: the waterfall and the Campbell "
                    "diagram with the mesh orders and the natural frequencies of `gearsym modes` overlaid.",
        epilog=examples(
            ("gearsym runup kahraman_singh --param Omega --from 0.5 --to 1.5 --duration 300 --bins 20 --json",
             "the dimensionless oscillator through its mesh resonance (Omega = 1): mesh-order peaks, the crossings "
             "of the orders with the natural frequency, as JSON"),
            ("gearsym runup spur_pair_torsional --param omega --from 10000 --to 30000 --duration 0.2 --settle 20 "
             "--out sp_runup",
             "the dimensional pair with backlash through its 3291 Hz mesh resonance (contact loss: the peak bends "
             "to lower speed, impacts spread the spectrum): sp_runup/runup.nc (trajectory, spectra, order "
             "tracks), campbell.png, waterfall.png, orders.png (gearsym[maps])")))
    scene_args(p)
    p.add_argument("--param", metavar="NAME", help="the speed parameter (default: the scene's [runup] parameter)")
    p.add_argument("--from", dest="start", metavar="A", help="its value at the start, in its declared unit, or with a unit "
                   "('3000 rpm')")
    p.add_argument("--to", dest="stop", metavar="B", help="its value at the end (below --from: a run-down)")
    p.add_argument("--duration", type=float, metavar="T", help="length of the ramp (the model's time unit)")
    p.add_argument("--rate", type=float, metavar="R", help="instead of --duration: the ramp's slope, abs(to - from) / duration "
                   "(declared unit per time unit)")
    p.add_argument("--signal", metavar="mesh_deflection[MESH]|STATE", help="what is recorded: mesh_deflection[NAME] or a state (default: the first mesh's "
                   "dynamic deflection)")
    p.add_argument("--settle", type=float, metavar="N", help="forcing periods at the start speed before the ramp (default 0)")
    p.add_argument("--bins", type=int, metavar="N", help="speed bins: short-time spectra along the run (default 60)")
    p.add_argument("--orders", type=int, metavar="K", help="mesh orders tracked and drawn (default 3)")
    p.add_argument("--samples-per-period", type=int, metavar="N", help="samples per period of the fastest mesh at the highest "
                   "speed (default 16)")
    p.add_argument("--no-modes", action="store_true", help="skip the natural frequencies (modal analysis)")
    p.add_argument("--rtol", type=float, help="relative tolerance (default: the scene's, else 1e-8)")
    p.add_argument("--atol", type=float, help="absolute tolerance (default: the scene's, else 1e-10)")
    p.add_argument("--max-steps", type=int, metavar="N", help="limit on internal integrator steps")
    p.add_argument("--out", metavar="DIR", help="folder for runup.nc and the PNG figures")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.set_defaults(func=cmd_runup)


def _check(args: argparse.Namespace) -> None:
    """The options, before any work."""
    _positive("--duration", args.duration, "duration")
    _positive("--rate", args.rate, "rate")
    if args.duration is not None and args.rate is not None:
        raise ParameterError("--duration and --rate: give one of them")
    _nonnegative("--settle", args.settle)
    check_count("--bins", args.bins, rule="map_axis")
    check_count("--orders", args.orders, rule="harmonics", low=1)
    check_count("--samples-per-period", args.samples_per_period, rule="points_per_period")
    check_count("--max-steps", args.max_steps, low=1)
    _tol("--rtol", args.rtol, "rtol")
    _tol("--atol", args.atol, "atol")
    _out(args)


def _speed_value(system: Any, name: str | None, text: str | None, flag: str) -> float | None:
    """``--from`` / ``--to``: a number in the declared unit of the speed, or one with a unit."""
    if text is None:
        return None
    if name is None:
        raise ParameterError(f"{flag}: give --param (the speed parameter) too, or the scene's [runup] parameter")
    try:
        return float(system.units.declared_value(name, text))
    except ValueError as exc:
        raise ParameterError(f"{flag}: {exc}") from None


def cmd_runup(args: argparse.Namespace) -> int:
    """Run the ramp; print or emit the summary; write the dataset and the figures with --out."""
    _check(args)
    from ..analysis.sweeps import runup

    scene = load(args)
    system = scene.compile()
    name = args.param or (system.settings.get("runup") or {}).get("parameter")
    given = {"parameter": args.param, "start": _speed_value(system, name, args.start, "--from"),
             "stop": _speed_value(system, name, args.stop, "--to"), "duration": args.duration, "rate": args.rate,
             "signal": args.signal, "settle": args.settle, "bins": args.bins, "orders": args.orders,
             "samples_per_period": args.samples_per_period, "modes": False if args.no_modes else None,
             "rtol": args.rtol, "atol": args.atol, "max_steps": args.max_steps}
    res = runup(scene, progress=False if args.no_progress else None, **{k: v for k, v in given.items() if v is not None})
    info = res.to_dict()
    if args.out:
        info["files"] = [str(f) for f in res.save(args.out)]
    if args.json:
        emit(info)
        return 0
    u, tu, fu = _unit(res.unit), _unit(res.time_unit), _unit(res.frequency_unit)
    print(f"{res.scene}: {res.parameter} {res.start:g} -> {res.stop:g}{u} in {res.duration:g}{tu}, "
          f"{info['n_steps']} steps, {info['n_breaks']} breakpoints, {info['n_events']} events; spectra of "
          f"{res.signal_name} in {info['bins']} speed bins, resolution {res.resolution:.4g}{fu}")
    if info["natural_frequencies"]:
        print("natural frequencies: " + ", ".join(f"{f:.6g}" for f in info["natural_frequencies"]) + fu)
    for pk in info["peaks"]:
        print(f"  {pk['mesh']} order {pk['order']}: largest {pk['amplitude']:.4g} at {res.parameter} = "
              f"{pk['speed']:.6g}{u} ({pk['frequency']:.6g}{fu})")
    for c in info["crossings"]:
        print(f"  {c['mesh']} order {c['order']} crosses mode {c['mode']} ({c['frequency']:.6g}{fu}) at "
              f"{res.parameter} = {c['speed']:.6g}{u}")
    for note in res.notes:
        print(f"note: {note}")
    for f in info.get("files", []):
        print(f"wrote {f}")
    return 0


def _unit(unit: str | None) -> str:
    """A unit to print after a number (with its space); none for a dimensionless value (unit ``"1"``)."""
    return f" {unit}" if unit and unit != "1" else ""
