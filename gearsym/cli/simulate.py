"""``gearsym compile``, ``simulate`` and ``export``: build a scene, run it, export it."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..inspection import mesh_figure
from . import checks
from .checks import emit, load
from .quantities import check_quantities, print_quantities, quantity_values

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["cmd_compile", "cmd_export", "cmd_simulate"]


def cmd_compile(args: argparse.Namespace) -> int:
    """Generate and compile a scene's C code (reusing the cache)."""
    scene = load(args)
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
        emit(info)
    else:
        state = "reused cached build" if gen.cached else f"compiled in {gen.compile_seconds:.2f} s"
        print(f"{scene.name}: {state}\n  {gen.so_path}")
        print(f"  {info['n_states']} states, {info['n_params']} parameters, "
              f"{info['n_switching_functions']} switching functions, rhs {info['n_ops']} operations")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate a scene; print statistics, optionally write the trajectory and plots."""
    checks.check_simulate(args)  # before any work: bad options and a bad --out are bad input
    quantities = check_quantities(args.quantity, "--quantity")
    scene = load(args)
    plot_states = checks.state_list(args.plot_states, scene.resolved.state_names(), "--plot-states")
    system = scene.compile()
    x0 = checks.float_list(args.x0, "--x0") if args.x0 else None
    from ..engine.errors import TooMuchWorkError

    try:  # only the options the user typed: System.simulate resolves the rest from the scene, as from Python
        traj = system.simulate(t_end=args.t_end, periods=args.periods, x0=x0, rtol=args.rtol, atol=args.atol,
                               method=args.method, max_steps=args.max_steps or 0)
    except TooMuchWorkError as exc:
        raise TooMuchWorkError(f"{exc}; raise the limit with --max-steps N") from None
    steady = _steady_start(traj)
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
        "max": traj.y[steady:, 0].max().item(),
        "min": traj.y[steady:, 0].min().item(),
        "steady_from": float(traj.t[steady]),
        "params": traj.params,
        "rtol": traj.settings["rtol"],
        "atol": traj.settings["atol"],
        "method": traj.settings["method"],
    }
    from ..analysis.periodic import trajectory_meshes

    meshes = trajectory_meshes(system, traj)
    if meshes:
        info["meshes"] = meshes
    gq = traj.gear_quantities() if args.gear_quantities or quantities else None
    if gq is not None and args.gear_quantities:
        info["gear_quantities"] = gq.to_dict()
    if gq is not None and quantities:
        info["quantities"] = quantity_values(gq, quantities)
    if args.out:
        from ..files import save_npz
        from ..plots import plot_all, plot_outputs, surface_levels

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
        emit(info)
    else:
        print(f"{scene.name}: t = 0 .. {info['t_end']:g}, {info['n_steps']} steps, {info['n_rhs']} rhs, "
              f"{info['n_events']} events, {info['wall_s'] * 1e3:.1f} ms")
        print("final state: " + ", ".join(f"{n} = {v:.10g}" for n, v in zip(traj.state_names,
                                                                           traj.final_state)))
        if gq is not None:
            print_quantities(gq, quantities)
        for f in info.get("files", []):
            print(f"wrote {f}")
    return 0


def _steady_start(traj: Any) -> int:
    """First output index of the window ``max`` / ``min`` summarise: after the scene's
    ``transient_periods`` when the run is longer than that, else the second half of the run."""
    import numpy as np

    tp = traj.settings.get("transient_periods")
    if tp and traj.period:
        start = int(np.searchsorted(traj.t, traj.t[0] + float(tp) * traj.period - 1e-12 * traj.period))
        if start < len(traj.t) - 1:
            return start
    return len(traj.t) // 2


def cmd_export(args: argparse.Namespace) -> int:
    """Export a scene as a standalone C project (--c DIR) and/or an FMI 2.0 FMU (--fmu FILE), Model
    Exchange and Co-Simulation."""
    from ..export import ExportError, export_scene

    if not args.c and not args.fmu:
        raise ExportError("export: give --c DIR and/or --fmu FILE.fmu")
    info = export_scene(load(args), c_dir=args.c, fmu=args.fmu, force=args.force)
    if args.json:
        emit(info)
    else:
        if "c" in info:
            print(f"wrote the C project {info['c']['directory']} (build: make -C {info['c']['directory']}; "
                  f"run: ./{info['c']['program']} --help)")
        if "fmu" in info:
            print(f"wrote {info['fmu']['fmu']} (FMI 2.0 Model Exchange and Co-Simulation, "
                  f"{info['fmu']['n_outputs']} continuous outputs, linux64 binary built in "
                  f"{info['fmu']['build_seconds']:.2f} s)")
    return 0
