"""Command-line interface: ``gearsym inspect|compile|simulate ...``.

Exit codes: 0 success, 2 bad input (message on stderr, no traceback), 1 internal
or numerical failure.  ``--json`` prints one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tomllib
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from .errors import GearsymError, ParameterError, SpecError


# ----------------------------------------------------------------- arguments
def _parse_set(items: list[str] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or []:
        if "=" not in item:
            raise ParameterError(f"--set expects NAME=VALUE, got '{item}'")
        name, value = item.split("=", 1)
        try:
            v = float(value)
        except ValueError:
            raise ParameterError(f"--set {name}: '{value}' is not a number") from None
        if not math.isfinite(v):
            raise ParameterError(f"--set {name}: non-finite value {value}")
        out[name.strip()] = v
    return out


def _parse_effects(on: list[str] | None, off: list[str] | None) -> dict[str, bool | str]:
    eff: dict[str, bool | str] = {}
    for item in on or []:
        if "=" in item:
            name, variant = item.split("=", 1)
            eff[name.strip()] = variant.strip()
        else:
            eff[item.strip()] = True
    for item in off or []:
        eff[item.strip()] = False
    return eff


def _scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="scene file (scenes/*.toml)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a parameter (in the model's declared unit); repeatable")
    p.add_argument("--effect", action="append", metavar="NAME[=VARIANT]",
                   help="switch an effect on (optionally choosing a variant); repeatable")
    p.add_argument("--no-effect", action="append", metavar="NAME", help="switch an effect off; repeatable")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def _load(args: argparse.Namespace):
    from .facade import load_scene

    return load_scene(args.scene, effects=_parse_effects(args.effect, args.no_effect) or None,
                      **_parse_set(args.set))


def _emit(obj: dict[str, Any]) -> None:
    print(json.dumps(obj, indent=1, default=_json_default))


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


# ---------------------------------------------------------------- commands
def cmd_inspect(args: argparse.Namespace) -> int:
    """Show a model's derived equations, states, parameters, effects, modes."""
    import sympy as sp

    from .facade import Scene
    from .spec.model import load_model

    path = Path(args.path)
    try:
        head = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SpecError("file not found", file=str(path)) from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"TOML syntax error: {exc}", file=str(path)) from None
    if "scene" in head:
        scene = Scene(path, _parse_effects(args.effect, args.no_effect) or None, _parse_set(args.set))
    elif "model" in head:
        model_spec = load_model(path)
        scene = _model_scene(path, model_spec, args)
    else:
        raise SpecError("neither a scene ([scene]) nor a model ([model]) file", file=str(path))
    m = scene.model
    ms = scene.model_spec
    info: dict[str, Any] = {
        "model": ms.name,
        "scene": scene.name if "scene" in head else None,
        "description": ms.description,
        "states": m.state_names,
        "parameters": {
            name: {"value": p.value, "unit": p.unit, "meaning": p.meaning,
                   "active": name in m.parameter_names}
            for name, p in ms.parameters.items()
        },
        "effects": {
            name: {"on": scene.resolved.effects[name] is not False,
                   "variant": scene.resolved.effects[name] if isinstance(scene.resolved.effects[name], str)
                   else None,
                   "variants": list(e.variants), "requires": list(e.requires), "meaning": e.meaning}
            for name, e in ms.effects.items()
        },
        "modes": [{"name": mo.name, "condition": mo.condition} for mo in m.modes],
        "switching_functions": [
            {"name": s.name, "expr": sp.sstr(s.expr), "meaning": s.meaning, "kind": s.kind}
            for s in m.switching
        ],
        "breakpoints": [
            {"schedule": s.name, "period": sp.sstr(s.period), "breaks": [sp.sstr(b) for b in s.breaks]}
            for s in m.schedules
        ],
        "forcing_period": sp.sstr(m.forcing_period) if m.forcing_period is not None else None,
        "equations": [sp.sstr(e.lhs) + " = " + sp.sstr(e.rhs) for e in m.equations()],
        "dimensionless_groups": {},
    }
    if ms.dimensionless is not None and m.form == "explicit":
        d = m.dimensionless()
        info["dimensionless_groups"] = {k: sp.sstr(v) for k, v in d.groups.items()}
        info["dimensionless_equations"] = [
            f"{d.states[i]}'' = {sp.sstr(d.accelerations[i])}" for i in range(len(d.states) // 2)]
        info["dimensionless_scales"] = {k: sp.sstr(v) for k, v in d.scales.items()}
    if args.latex:
        info["latex"] = m.latex()
    if args.json:
        _emit(info)
        return 0
    print(f"model {ms.name}: {ms.description}")
    if ms.reference:
        print(f"  reference: {ms.reference}")
    print(f"states: {', '.join(info['states'])}")
    print("parameters:")
    for name, p in info["parameters"].items():
        mark = "" if p["active"] else "   (not used: effect off)"
        print(f"  {name:10s} = {p['value']:<12g} [{p['unit']}]  {p['meaning']}{mark}")
    print("effects:")
    for name, e in info["effects"].items():
        state = ("on" + (f" ({e['variant']})" if e["variant"] else "")) if e["on"] else "off"
        print(f"  {name:28s} {state:10s} {e['meaning']}")
    print("equations of motion:")
    for eq in info["equations"]:
        print(f"  {eq}")
    if info["switching_functions"]:
        print("switching functions:")
        for s in info["switching_functions"]:
            print(f"  g[{s['name']}] = {s['expr']}   ({s['meaning']})")
        print("modes:")
        for mo in info["modes"]:
            print(f"  {mo['name']}: {mo['condition']}")
    for b in info["breakpoints"]:
        print(f"breakpoints: schedule {b['schedule']}, period {b['period']}, breaks at {b['breaks']}")
    if info["forcing_period"]:
        print(f"forcing period: {info['forcing_period']}")
    if info["dimensionless_groups"]:
        print("dimensionless form:")
        for eq in info["dimensionless_equations"]:
            print(f"  {eq}")
        print("  with")
        for k, v in info["dimensionless_groups"].items():
            print(f"    {k} = {v}")
        for k, v in info["dimensionless_scales"].items():
            print(f"    reference {k}: {v}")
    if args.latex:
        print(info["latex"])
    return 0


def _model_scene(path: Path, model_spec, args):
    """A scene with the model's defaults, for ``inspect MODEL``."""
    import tempfile

    from .facade import Scene

    tmp = Path(tempfile.mkdtemp(prefix="gearsym-")) / f"{model_spec.name}.toml"
    tmp.write_text(f'[scene]\nname = "{model_spec.name}"\nmodel = {json.dumps(str(path.resolve()))}\n')
    return Scene(tmp, _parse_effects(args.effect, args.no_effect) or None, _parse_set(args.set),
                 model_spec=model_spec)


def cmd_compile(args: argparse.Namespace) -> int:
    """Generate and compile a scene's C code (reusing the cache)."""
    scene = _load(args)
    gen = scene.generate(force=args.force)
    info = {
        "scene": scene.name,
        "model": scene.model_spec.name,
        "directory": gen.directory,
        "shared_object": gen.so_path,
        "cached": gen.cached,
        "compile_seconds": gen.compile_seconds,
        "n_states": gen.nx,
        "n_params": len(gen.param_names),
        "params": gen.param_names,
        "n_ops": gen.n_ops.get("gs_rhs", gen.n_ops.get("gs_res")),
        "n_ops_by_function": gen.n_ops,
        "n_switching_functions": gen.nsw,
        "n_schedules": len(gen.schedules),
        "effects": {k: v for k, v in scene.resolved.effects.items() if v is not False},
        "implicit": gen.implicit,
    }
    if args.json:
        _emit(info)
    else:
        state = "reused cached build" if gen.cached else f"compiled in {gen.compile_seconds:.2f} s"
        print(f"{scene.name}: {state}\n  {gen.so_path}")
        print(f"  {info['n_states']} states, {info['n_params']} parameters, "
              f"{info['n_switching_functions']} switching functions, rhs {info['n_ops']} operations")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate a scene; print statistics, optionally write the trajectory and plots."""
    scene = _load(args)
    system = scene.compile()
    kw: dict[str, Any] = {}
    rtol = args.rtol if args.rtol is not None else float(scene.spec.simulate.get("rtol", 1e-8))
    atol = args.atol if args.atol is not None else float(scene.spec.simulate.get("atol", 1e-10))
    if args.x0:
        kw["x0"] = [float(v) for v in args.x0.split(",")]
    traj = system.simulate(t_end=args.t_end, periods=args.periods, rtol=rtol, atol=atol,
                           method=args.method, **kw)
    info = {
        "scene": scene.name,
        "state_names": traj.state_names,
        "final_state": traj.final_state.tolist(),
        "t_end": float(traj.t[-1]),
        "period": traj.period,
        "n_steps": traj.stats["n_steps"],
        "n_rhs": traj.stats["n_rhs"],
        "n_events": traj.stats["n_events"],
        "n_breaks": traj.stats.get("n_breaks", 0),
        "wall_s": traj.stats["wall_s"],
        "max": traj.y[len(traj.t) // 2:, 0].max().item(),
        "min": traj.y[len(traj.t) // 2:, 0].min().item(),
        "params": traj.params,
        "rtol": rtol,
        "atol": atol,
    }
    if args.out:
        from .plots import plot_all

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        traj.save_npz(out / "trajectory.npz")
        surfaces = _surface_levels(system, traj)
        files = plot_all(traj, out, title=scene.name, surfaces=surfaces)
        info["files"] = [str(out / "trajectory.npz")] + [str(f) for f in files]
    if args.json:
        _emit(info)
    else:
        print(f"{scene.name}: t = 0 .. {info['t_end']:g}, {info['n_steps']} steps, {info['n_rhs']} rhs, "
              f"{info['n_events']} events, {info['wall_s'] * 1e3:.1f} ms")
        print("final state: " + ", ".join(f"{n} = {v:.10g}" for n, v in zip(traj.state_names,
                                                                           traj.final_state)))
        for f in info.get("files", []):
            print(f"wrote {f}")
    return 0


def _surface_levels(system, traj) -> list[float]:
    """Coordinate levels of surfaces of the form x -/+ b (for plots)."""
    levels = []
    try:
        fn = system.generated.casadi_function("gs_sw")
        p = system.param_vector()
        x = np.zeros(system.generated.nx)
        g0 = np.asarray(fn(0.0, x, p)).ravel()
        x[0] = 1.0
        g1 = np.asarray(fn(0.0, x, p)).ravel()
        for a, b in zip(g0, g1):
            slope = b - a
            if abs(slope - 1.0) < 1e-12:
                levels.append(-a)
    except Exception:  # plots are a convenience; never fail the command for them
        return []
    return levels


# -------------------------------------------------------------------- main
def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``gearsym`` command."""
    parser = argparse.ArgumentParser(
        prog="gearsym",
        description="Symbolic model compiler for gear-transmission dynamics.",
        epilog="Exit codes: 0 success, 2 bad input, 1 internal or numerical failure.",
    )
    parser.add_argument("--version", action="version", version=f"gearsym {_version()}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("inspect", help="show derived equations, states, parameters, effects, modes")
    p.add_argument("path", help="scene or model file")
    p.add_argument("--latex", action="store_true", help="also print the equations as LaTeX")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter")
    p.add_argument("--effect", action="append", metavar="NAME[=VARIANT]", help="switch an effect on")
    p.add_argument("--no-effect", action="append", metavar="NAME", help="switch an effect off")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("compile", help="generate C and compile it (cached by content)")
    _scene_args(p)
    p.add_argument("--force", action="store_true", help="rebuild even if cached")
    p.set_defaults(func=cmd_compile)

    p = sub.add_parser("simulate", help="simulate a scene with the C engine")
    _scene_args(p)
    p.add_argument("--periods", type=float, help="number of forcing periods")
    p.add_argument("--t-end", type=float, help="final time (instead of --periods)")
    p.add_argument("--rtol", type=float, help="relative tolerance (default: scene, else 1e-8)")
    p.add_argument("--atol", type=float, help="absolute tolerance (default: scene, else 1e-10)")
    p.add_argument("--method", choices=["bdf", "adams", "ida"], help="integrator")
    p.add_argument("--x0", help="initial state, comma-separated")
    p.add_argument("--out", help="folder for trajectory.npz and PNG plots")
    p.set_defaults(func=cmd_simulate)
    return parser


def _version() -> str:
    from . import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``gearsym`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except GearsymError as exc:
        print(f"gearsym: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("gearsym: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # internal error: short message, traceback on request
        if args.debug:
            traceback.print_exc()
        print(f"gearsym: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the "
              f"traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
