"""Command-line interface: ``gearsym inspect|compile|simulate ...``.

Exit codes: 0 success, 2 bad input (message on stderr, no traceback), 1 internal
or numerical failure, or a command that did not do what was asked (an orbit that
does not converge, a continuation that stops before the end of its range, a map
whose every point failed).  ``--json`` prints one JSON object on stdout (strict
JSON: non-finite numbers are ``null``).  Every numeric option is checked before any
work (:mod:`gearsym.cli_checks`); every output file is written atomically
(:mod:`gearsym.files`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from . import cli_checks as checks
from .errors import ConvergenceError, GearsymError, ParameterError, SpecError
from .inspection import (  # a light module: no numpy/sympy at import
    branch_mesh_figure,
    inspect_structure,
    mesh_figure,
    print_branch_meshes,
    print_meshes,
    print_structure,
    print_trivial,
)

# typing, numpy, sympy, CasADi and the layers that use them: imported where needed (a light --version)
TYPE_CHECKING = False
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any


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
    p.add_argument("scene", help="scene file, or the name of a shipped scene (gearsym models lists them)")
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
    from .files import to_json

    print(to_json(obj))


def _unit_suffix(unit: str) -> str:
    """`` [unit]``-less suffix for printing a value: omitted for dimensionless ``1``."""
    return "" if unit in ("", "1") else f" {unit}"


# ---------------------------------------------------------------- commands
def cmd_inspect(args: argparse.Namespace) -> int:
    """Show a model's derived equations, states, parameters, effects, modes."""
    import sympy as sp

    from .catalog import find_spec_file
    from .cli_inspect import inspect_details, print_details
    from .facade import Scene
    from .spec.files import read_toml
    from .spec.model import load_model

    path = find_spec_file(args.path)
    head = read_toml(path, "file")  # regular file, size limit, before reading
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
                   "active": name in m.parameter_names
                   or any(name in args for _, args in m.bound_parameters.values())}
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
        **inspect_structure(m),
    }
    info.update(inspect_details(m, jacobian=args.jacobian))
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
    print_structure(info)
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
    print_details(info, [s.name for s in m.switching])
    if args.latex:
        print(info["latex"])
    return 0


def _model_scene(path: Path, model_spec, args):
    """A scene with the model's defaults, for ``inspect MODEL``."""
    import tempfile

    from .facade import Scene

    tmp = Path(tempfile.mkdtemp(prefix="gearsym-")) / f"{model_spec.name}.toml"
    import json

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
    checks.check_simulate(args)  # before any work: bad options and a bad --out are bad input
    scene = _load(args)
    plot_states = checks.state_list(args.plot_states, scene.resolved.state_names(), "--plot-states")
    system = scene.compile()
    kw: dict[str, Any] = {}
    rtol = args.rtol if args.rtol is not None else float(scene.spec.simulate.get("rtol", 1e-8))
    atol = args.atol if args.atol is not None else float(scene.spec.simulate.get("atol", 1e-10))
    if args.x0:
        kw["x0"] = checks.float_list(args.x0, "--x0")
    if args.max_steps is not None:
        kw["max_steps"] = args.max_steps
    from .engine.errors import TooMuchWorkError

    try:
        traj = system.simulate(t_end=args.t_end, periods=args.periods, rtol=rtol, atol=atol,
                               method=args.method, **kw)
    except TooMuchWorkError as exc:
        raise TooMuchWorkError(f"{exc}; raise the limit with --max-steps N") from None
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
    from .analysis.meshes import trajectory_meshes

    meshes = trajectory_meshes(system, traj)
    if meshes:
        info["meshes"] = meshes
    if args.out:
        from .files import save_npz
        from .plots import plot_all, plot_outputs, surface_levels

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        traj.save_npz(out / "trajectory.npz")
        files = plot_all(traj, out, title=scene.name, surfaces=surface_levels(system), states=plot_states)
        mesh_fig = mesh_figure(system, traj, out, scene.name, info)
        if mesh_fig is not None:
            files.append(mesh_fig)
        outputs = system.outputs(traj)
        if outputs:

            files.append(plot_outputs(traj.t, outputs, out, system.generated.output_units, scene.name))
            save_npz(out / "outputs.npz", t=traj.t, **outputs)
            files.append(out / "outputs.npz")
            info["outputs"] = {k: {"min": float(v.min()), "max": float(v.max())} for k, v in outputs.items()}
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


def cmd_bench(args: argparse.Namespace) -> int:
    """Work-precision benchmark of a scene: error vs wall time for gearsym and the peers."""
    from . import bench

    rtols = bench.parse_rtols(args.rtols) if args.rtols else None
    methods = bench.parse_methods(args.methods) if args.methods else None
    checks.check_bench(args)
    out = Path(args.out) if args.out else None
    scene = _load(args)
    data = bench.bench_scene(scene, rtols=rtols, methods=methods, periods=args.periods,
                             points_per_period=args.points_per_period, rounds=args.rounds,
                             compile_timing=not args.no_compile_times, analyses=not args.no_analyses,
                             progress=None if args.json else (lambda s: print(s, file=sys.stderr)))
    if out is not None:
        data["files"] = bench.write_outputs(data, out, f"work_precision_{scene.name}")
    if args.json:
        _emit(data)
    else:
        print(bench.format_table(data["case"]))
        for f in data.get("files", []):
            print(f"wrote {f}")
    return 0


def cmd_continue(args: argparse.Namespace) -> int:
    """Continue periodic orbits in one parameter: branch, stability, located bifurcations."""
    import numpy as np

    from .analysis.continuation import continuation
    from .files import write_json

    checks.check_continue(args)
    scene = _load(args)
    name = args.param
    spec_p = scene.model_spec.parameters.get(name)
    if spec_p is None:
        raise ParameterError(f"--param {name}: not a parameter of model '{scene.model_spec.name}' (have: "
                             f"{', '.join(scene.model_spec.parameters)})")
    si = float(spec_p.si_scale)
    unit = _unit_suffix(spec_p.unit)
    system = scene.compile()
    kw: dict[str, Any] = {}
    if args.x0:
        kw["x0"] = checks.float_list(args.x0, "--x0")
    for key in ("rtol", "atol", "harmonics"):
        if getattr(args, key) is not None:
            kw[key] = getattr(args, key)
    if args.ds_max is not None:
        kw["ds_max"] = args.ds_max
        kw["ds"] = min(0.005, args.ds_max)
        kw["ds_min"] = min(1e-7, kw["ds"])
    branch = continuation(system, name, args.start * si, args.stop * si, periods=args.periods,
                          method=args.method, segments=args.segments, max_points=args.max_points,
                          switch=args.switch, progress=False if args.no_progress else None,
                          display=(si, spec_p.unit), **kw)
    data = branch.to_dict()

    def to_declared(d: dict[str, Any]) -> None:
        if si != 1.0:
            for item in d["points"] + d["bifurcations"]:
                item["value"] = item["value"] / si
            for k in ("start", "stop", "stop_value", "switched_at"):
                if isinstance(d.get(k), (int, float)):
                    d[k] = d[k] / si
            if isinstance(d.get("switched_at"), dict):
                d["switched_at"]["value"] = d["switched_at"]["value"] / si
        d["unit"] = spec_p.unit
        for c in d.get("children", []):
            to_declared(c)

    to_declared(data)
    data["scene"] = scene.name
    if args.out:
        from .files import save_figure

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_json(out / "branch.json", data)
        files = [out / "branch.json"]
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        label = f"{name} [{spec_p.unit}]" if spec_p.unit not in ("", "1") else name
        for fname, draw in (("response.png", lambda ax: branch.plot(ax, quantity=["max", "min"], xscale=1 / si)),
                            ("multipliers.png", lambda ax: branch.plot_multipliers(ax, children=True,
                                                                                    xscale=1 / si))):
            fig, ax = plt.subplots(figsize=(7, 4.2))
            draw(ax)
            ax.set_xlabel(label)
            ax.set_title(f"{scene.name}: continuation in {name}")
            fig.tight_layout()
            save_figure(fig, out / fname, dpi=110)
            plt.close(fig)
            files.append(out / fname)
        files += branch_mesh_figure(branch, out, si, label, f"{scene.name}: mesh deflections against {name}")
        data["files"] = [str(f) for f in files]
    if args.json:
        _emit(data)
    else:
        for br in branch.all_branches():
            print(f"{scene.name}: period-{br.periods:g} branch in {name}, {len(br.points)} points, "
                  f"{br.values.min() / si:.6g} .. {br.values.max() / si:.6g}{unit}, "
                  f"{int(np.sum(br.stable))} stable; {br.stop_reason}")
            for b in br.bifurcations:
                mu = b.point.multipliers
                big = mu[np.argsort(-np.abs(mu))][:2]
                extra = f" ({b.info['surface']}, {b.info['side']} g)" if b.type == "grazing" else ""
                print(f"  {b.type:16s} {name} = {b.value / si:.8g}{unit}{extra}  multipliers "
                      + ", ".join(f"{m.real:.4f}{m.imag:+.4f}j" for m in big))
            print_branch_meshes(br)
        for f in data.get("files", []):
            print(f"wrote {f}")
    if not branch.complete:
        # the command did not cover the range it was asked for: never exit 0
        print(f"gearsym: error: the continuation stopped before the end of the range: {branch.stop_reason}",
              file=sys.stderr)
        return ConvergenceError.exit_code
    return 0


def cmd_modes(args: argparse.Namespace) -> int:
    """Natural frequencies and mode shapes about the static equilibrium (mean mesh stiffness)."""
    from .analysis.modes import modal_analysis
    from .analysis.planetary import classify_planetary

    if args.samples < 1:
        raise ParameterError(f"--samples must be >= 1, got {args.samples}")
    scene = _load(args)
    res = classify_planetary(modal_analysis(scene.compile(), samples=args.samples))
    if args.json:
        _emit({"scene": scene.name, **res.to_dict()})
    else:
        print(res.table(scene.name, "Hz" if scene.model_spec.time_unit == "s" else "1/time"))
    return 0


def cmd_orbit(args: argparse.Namespace) -> int:
    """Find a periodic orbit (shooting or harmonic balance) and its Floquet multipliers."""
    from .files import write_json

    checks.check_orbit(args)
    scene = _load(args)
    system = scene.compile()
    opts: dict[str, Any] = {}
    x0 = checks.float_list(args.x0, "--x0") if args.x0 else None
    if args.method == "shooting":
        opts["segments"] = args.segments
        if args.transient is not None:
            opts["transient"] = args.transient
    elif args.harmonics is not None:
        opts["harmonics"] = args.harmonics
    for key in ("tol", "rtol", "atol"):
        if getattr(args, key) is not None:
            opts[key] = getattr(args, key)
    orbit = system.periodic_orbit(periods=args.periods, x0=x0, method=args.method, **opts)
    info: dict[str, Any] = {"scene": scene.name, **orbit.to_dict()}
    info.setdefault("isolation", orbit.info.get("isolation"))  # smallest singular value of M - I, threshold
    if args.out:
        out = Path(args.out)
        files = orbit.save_plots(out, title=f"{scene.name}: periodic orbit ({orbit.method})")
        write_json(out / "orbit.json", info)
        info["files"] = [str(out / "orbit.json")] + [str(f) for f in files]
    if args.json:
        _emit(info)
    else:
        verdict = {"asymptotically_stable": "asymptotically stable", "neutral": "neutral (stable, multipliers on "
                   "the unit circle within the monodromy's error)", "unstable": "UNSTABLE"}.get(orbit.stability,
                                                                                               orbit.stability)
        print(f"{scene.name}: periodic orbit by {orbit.method}, period {orbit.period:.10g} "
              f"({orbit.periods:g} forcing period(s)), {orbit.iterations} iterations, residual "
              f"{orbit.residual:.3g}")
        print("x0: " + ", ".join(f"{n} = {v:.12g}" for n, v in zip(orbit.state_names, orbit.x0)))
        print("multipliers: " + ", ".join(f"{m.real:.8g}{m.imag:+.8g}j (|mu| = {abs(m):.8g})"
                                          for m in orbit.multipliers))
        print_trivial(orbit.trivial_multipliers)
        print(f"{verdict}, max|mu| = {orbit.max_multiplier:.10g}; {orbit.state_names[0]} in "
              f"[{info['min']:.10g}, {info['max']:.10g}]"
              + (f"; rattle state {orbit.rattle_state}" if orbit.rattle_state is not None else ""))
        print_meshes(info.get("meshes", {}))
        for f in info.get("files", []):
            print(f"wrote {f}")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    """Two-parameter stability / response map (netCDF + heat-map PNG)."""
    import numpy as np

    from .analysis.maps import save_map, stability_map

    xa, ya = checks.check_map(args)
    scene = _load(args)
    opts: dict[str, Any] = {}
    if args.harmonics is not None:
        opts["harmonics"] = args.harmonics
    if args.rtol is not None:
        opts["rtol"] = args.rtol
    ds = stability_map(scene, xa, ya, quantity=args.quantity, method=args.method, periods=args.periods,
                       dask=args.dask, workers=args.workers, orbit_options=opts)
    if int(ds.attrs["n_failed"]) >= int(ds.attrs["n_points"]):
        # nothing computed: no all-NaN map files, exit 1 with the first errors
        first = str(ds.attrs.get("errors", "")).splitlines()[:1]
        raise ConvergenceError(f"every one of the {int(ds.attrs['n_points'])} points of the map failed"
                               + (f"; first error at {first[0]}" if first else ""))
    files = save_map(ds, args.out)
    q = ds[args.quantity].values
    mm = ds["max_multiplier"].values
    info = {
        "scene": scene.name,
        "x": {"name": xa[0], "lo": xa[1], "hi": xa[2], "n": xa[3]},
        "y": {"name": ya[0], "lo": ya[1], "hi": ya[2], "n": ya[3]},
        "quantity": args.quantity,
        "min": float(np.nanmin(q)) if np.isfinite(q).any() else None,
        "max": float(np.nanmax(q)) if np.isfinite(q).any() else None,
        "fraction_unstable": float(np.mean(ds["stable"].values[np.isfinite(mm)] == 0))
        if np.isfinite(mm).any() else None,
        "n_points": int(ds.attrs["n_points"]),
        "n_failed": int(ds.attrs["n_failed"]),
        "methods_used": ds.attrs["methods_used"],
        "runner": ds.attrs["runner"],
        "wall_s": float(ds.attrs["wall_s"]),
        "files": [str(f) for f in files],
    }
    if args.json:
        _emit(info)
    else:
        print(f"{scene.name}: {args.quantity} on {xa[3]} x {ya[3]} points ({info['methods_used']}, "
              f"{info['runner']}) in {info['wall_s']:.2f} s; range [{info['min']}, {info['max']}], "
              f"unstable fraction {info['fraction_unstable']}, failed {info['n_failed']}")
        for f in info["files"]:
            print(f"wrote {f}")
    return 0


# -------------------------------------------------------------------- main
def cmd_export(args: argparse.Namespace) -> int:
    """Export a scene as a standalone C project (--c DIR) and/or an FMI 2.0 ME FMU (--fmu FILE)."""
    from .export import ExportError, export_scene

    if not args.c and not args.fmu:
        raise ExportError("export: give --c DIR and/or --fmu FILE.fmu")
    info = export_scene(_load(args), c_dir=args.c, fmu=args.fmu, force=args.force)
    if args.json:
        _emit(info)
    else:
        if "c" in info:
            print(f"wrote the C project {info['c']['directory']} (build: make -C {info['c']['directory']}; "
                  f"run: ./{info['c']['program']} --help)")
        if "fmu" in info:
            print(f"wrote {info['fmu']['fmu']} (FMI 2.0 Model Exchange, linux64 binary built in "
                  f"{info['fmu']['build_seconds']:.2f} s)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``gearsym`` command."""
    parser = checks.GearsymArgumentParser(
        prog="gearsym",
        description="Symbolic model compiler for gear-transmission dynamics.",
        epilog="Exit codes: 0 success, 2 bad input, 1 internal or numerical failure.",
    )
    parser.add_argument("--version", action="version", version=f"gearsym {_version()}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=checks.GearsymArgumentParser)

    p = sub.add_parser("inspect", help="show derived equations, states, parameters, effects, modes")
    p.add_argument("path", help="scene or model file, or the name of a shipped scene or model")
    p.add_argument("--latex", action="store_true", help="also print the equations as LaTeX")
    p.add_argument("--jacobian", action="store_true", help="also print the symbolic Jacobian")
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
    p.add_argument("--max-steps", type=int, help="limit on internal integrator steps (default: the scene's, "
                   "else 10,000,000)")
    p.add_argument("--out", help="folder for trajectory.npz and PNG plots")
    p.add_argument("--plot-states", metavar="NAMES", help="comma-separated states the time-history figure "
                   "shows (default: every state)")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("bench", help="work-precision benchmark: error vs wall time, gearsym vs peer integrators")
    _scene_args(p)
    p.add_argument("--out", help="folder for work_precision_<scene>.json and .png (written at the end)")
    p.add_argument("--rtols", help="comma-separated relative tolerances (default 1e-3 .. 1e-10, and 1e-11, "
                   "1e-12 where the reference allows)")
    p.add_argument("--periods", type=float, help="horizon in forcing periods (default: the scene's)")
    p.add_argument("--points-per-period", type=int, default=32, help="output grid density (default 32)")
    p.add_argument("--methods", help="comma-separated subset of the methods (default: all)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (default 3)")
    p.add_argument("--no-compile-times", action="store_true", help="skip the cold/cached compile timing")
    p.add_argument("--no-analyses", action="store_true", help="skip the shooting / continuation costs")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("continue", help="continue periodic orbits in one parameter (branch, folds, period "
                       "doubling, Neimark-Sacker, grazing)")
    _scene_args(p)
    p.add_argument("--param", required=True, help="the parameter to vary")
    p.add_argument("--from", dest="start", type=float, required=True,
                   help="start value (in the model's declared unit)")
    p.add_argument("--to", dest="stop", type=float, required=True, help="end value")
    p.add_argument("--periods", type=float, default=1, help="forcing periods per orbit (default 1)")
    p.add_argument("--method", choices=["shooting", "hbm"], default="shooting", help="periodic-orbit residual")
    p.add_argument("--segments", type=int, default=1, help="shooting segments (default 1)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm)")
    p.add_argument("--switch", type=int, default=0,
                   help="branch switching depth at period doublings (default 0: none)")
    p.add_argument("--ds-max", type=float, help="largest step in scaled arclength (default 0.02)")
    p.add_argument("--max-points", type=int, default=5000, help="limit on branch points (default 5000)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default 1e-10)")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default: rtol * 1e-2 * the smallest "
                   "state magnitude on the first orbit; for the orbit x = 0 the scene's scale)")
    p.add_argument("--x0", help="initial guess of the orbit's state at t = 0, comma-separated")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--out", help="folder for branch.json, response.png, multipliers.png")
    p.set_defaults(func=cmd_continue)

    p = sub.add_parser("orbit", help="periodic orbit by shooting or harmonic balance, Floquet multipliers")
    _scene_args(p)
    p.add_argument("--periods", type=float, default=1, help="forcing periods per orbit (default 1)")
    p.add_argument("--method", choices=["shooting", "hbm"], default="shooting", help="periodic solver")
    p.add_argument("--segments", type=int, default=1, help="shooting segments (default 1: single shooting)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm; default: grown until converged)")
    p.add_argument("--x0", help="initial guess of the state at t = 0, comma-separated")
    p.add_argument("--transient", type=float, help="forcing periods integrated before Newton (shooting)")
    p.add_argument("--tol", type=float, help="residual tolerance (default 1e-10)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default 1e-11)")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default 1e-13)")
    p.add_argument("--out", help="folder for orbit.json, orbit_phase.png, orbit_multipliers.png")
    p.set_defaults(func=cmd_orbit)

    p = sub.add_parser("export", help="standalone C project (--c DIR) and/or FMI 2.0 Model Exchange FMU "
                       "(--fmu FILE.fmu) of a scene")
    _scene_args(p)
    p.add_argument("--c", metavar="DIR", help="folder for the C project (main.c, driver, Makefile, README)")
    p.add_argument("--fmu", metavar="FILE", help="FMU file to write (.fmu)")
    p.add_argument("--force", action="store_true", help="write into an existing non-empty folder / over a file")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("modes", help="natural frequencies and mode shapes about the static equilibrium "
                       "(mean mesh stiffness)")
    _scene_args(p)
    p.add_argument("--samples", type=int, default=32,
                   help="samples per forcing period for the mean stiffness and loads (default 32)")
    p.set_defaults(func=cmd_modes)

    p = sub.add_parser("map", help="two-parameter stability / response map (netCDF + heat map)")
    _scene_args(p)
    p.add_argument("--x", nargs=4, required=True, metavar=("NAME", "LO", "HI", "N"),
                   help="horizontal axis: parameter (declared unit), range and number of points")
    p.add_argument("--y", nargs=4, required=True, metavar=("NAME", "LO", "HI", "N"), help="vertical axis")
    p.add_argument("--quantity", choices=["max_multiplier", "peak_to_peak", "rattle_state"],
                   default="max_multiplier", help="what the heat map shows (default max_multiplier)")
    p.add_argument("--method", choices=["auto", "exact", "shooting", "hbm"], default="auto",
                   help="auto: exact matrix exponentials for piecewise-constant LTV models, else shooting")
    p.add_argument("--periods", type=float, default=1, help="forcing periods per orbit (default 1)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance")
    p.add_argument("--dask", metavar="ADDRESS", help="run on this Dask scheduler (default: local processes)")
    p.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--out", required=True, help="folder for map.nc and map.png")
    p.set_defaults(func=cmd_map)

    from .cli_cache import add_cache_parser
    from .cli_catalog import add_catalog_parsers

    add_cache_parser(sub)
    add_catalog_parsers(sub)
    return parser


def _version() -> str:
    from . import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``gearsym`` console script."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except checks.UsageError as exc:  # one line, exit 2 (argparse would print the usage and exit)
        print(f"gearsym: error: {exc}", file=sys.stderr)
        return exc.exit_code
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        from .extras import require_for_command

        require_for_command(args)  # a missing optional dependency: exit 2, naming the extra
        return int(args.func(args) or 0)
    except GearsymError as exc:
        print(f"gearsym: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("gearsym: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`): no traceback, no message
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except Exception as exc:  # internal error: short message, traceback on request
        if args.debug:
            import traceback

            traceback.print_exc()
        print(f"gearsym: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the "
              f"traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
