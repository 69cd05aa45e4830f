"""``gearsym orbit`` and ``continue``: periodic orbits, their stability, and their continuation."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import ConvergenceError, ParameterError
from ..inspection import branch_mesh_figure, print_branch_meshes, print_meshes, print_trivial
from . import checks
from .checks import emit, load, unit_suffix
from .curves import cmd_continue_curve, wants_curve
from .quantities import add_branch_quantity, check_quantities, print_quantities, quantity_values

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["cmd_continue", "cmd_orbit"]


def cmd_orbit(args: argparse.Namespace) -> int:
    """Find a periodic orbit (shooting or harmonic balance) and its Floquet multipliers."""
    from ..files import write_json

    checks.check_orbit(args)
    quantities = check_quantities(args.quantity, "--quantity")
    scene = load(args)
    system = scene.compile()
    if quantities and not system.generated.meshes:
        raise ParameterError(f"--quantity: model '{scene.model_spec.name}' has no mesh elements")
    x0 = checks.float_list(args.x0, "--x0") if args.x0 else None
    # only the options the user typed: System.periodic_orbit resolves the rest from the scene's [orbit]
    opts = {k: getattr(args, k) for k in ("segments", "transient", "harmonics", "tol", "rtol", "atol")
            if getattr(args, k) is not None}
    orbit = system.periodic_orbit(periods=args.periods, x0=x0, method=args.method, **opts)
    info: dict[str, Any] = {"scene": scene.name, **orbit.to_dict()}
    info.setdefault("isolation", orbit.info.get("isolation"))  # smallest singular value of M - I, threshold
    gq = orbit.gear_quantities() if system.generated.meshes else None  # per mesh (gearsym.quantities)
    if gq is not None:
        info["gear_quantities"] = gq.to_dict()
        if quantities:
            info["quantities"] = quantity_values(gq, quantities)
    if args.out:
        out = Path(args.out)
        files = orbit.save_plots(out, title=f"{scene.name}: periodic orbit ({orbit.method})")
        write_json(out / "orbit.json", info)
        info["files"] = [str(out / "orbit.json")] + [str(f) for f in files]
    if args.json:
        emit(info)
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
        if gq is not None:
            print_quantities(gq, quantities)
        for f in info.get("files", []):
            print(f"wrote {f}")
    return 0



def cmd_continue(args: argparse.Namespace) -> int:
    """Continue periodic orbits in one parameter: branch, stability, located bifurcations."""
    import numpy as np

    from ..analysis.continuation import continuation
    from ..files import write_json

    checks.check_continue(args)
    quantity = (check_quantities([args.quantity], "--quantity") or [None])[0] if args.quantity else None
    if wants_curve(args):  # --follow / --param2 / --start-from / --guess: a curve in two parameters
        return cmd_continue_curve(args)
    scene = load(args)
    name = args.param
    spec_p = scene.model_spec.parameters.get(name)
    if spec_p is None:
        raise ParameterError(f"--param {name}: not a parameter of model '{scene.model_spec.name}' (have: "
                             f"{', '.join(scene.model_spec.parameters)})")
    unit = unit_suffix(spec_p.unit)  # --from, --to and every value of the branch: in the declared unit
    system = scene.compile()
    if quantity and not system.generated.meshes:
        raise ParameterError(f"--quantity: model '{scene.model_spec.name}' has no mesh elements")
    # only the options the user typed: continuation() resolves the rest from the scene's [continue]
    kw: dict[str, Any] = {k: getattr(args, k) for k in ("periods", "method", "segments", "harmonics", "switch",
                                                         "ds_max", "max_points", "rtol", "atol")
                          if getattr(args, k) is not None}
    if args.x0:
        kw["x0"] = checks.float_list(args.x0, "--x0")
    branch = continuation(system, name, args.start, args.stop, progress=False if args.no_progress else None, **kw)
    data = branch.to_dict()

    def with_unit(d: dict[str, Any]) -> None:
        d["unit"] = spec_p.unit
        for c in d.get("children", []):
            with_unit(c)

    with_unit(data)
    data["scene"] = scene.name
    if quantity:
        add_branch_quantity(branch, data, quantity)
    if args.out:
        from ..files import save_figure

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_json(out / "branch.json", data)
        files = [out / "branch.json"]
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        label = f"{name} [{spec_p.unit}]" if spec_p.unit not in ("", "1") else name
        for fname, draw in (("response.png", lambda ax: branch.plot(ax, quantity=[quantity] if quantity else ["max", "min"])),
                            ("multipliers.png", lambda ax: branch.plot_multipliers(ax, children=True))):
            fig, ax = plt.subplots(figsize=(7, 4.2))
            draw(ax)
            ax.set_xlabel(label)
            ax.set_title(f"{scene.name}: continuation in {name}")
            fig.tight_layout()
            save_figure(fig, out / fname, dpi=110)
            plt.close(fig)
            files.append(out / fname)
        files += branch_mesh_figure(branch, out, 1.0, label, f"{scene.name}: mesh deflections against {name}")
        data["files"] = [str(f) for f in files]
    if args.json:
        emit(data)
    else:
        for br in branch.all_branches():
            print(f"{scene.name}: period-{br.periods:g} branch in {name}, {len(br.points)} points, "
                  f"{br.values.min():.6g} .. {br.values.max():.6g}{unit}, "
                  f"{int(np.sum(br.stable))} stable; {br.stop_reason}")
            for b in br.bifurcations:
                mu = b.point.multipliers
                big = mu[np.argsort(-np.abs(mu))][:2]
                extra = f" ({b.info['surface']}, {b.info['side']} g)" if b.type == "grazing" else ""
                if b.info.get("located") is False:  # detected, its location failed: the bracket
                    lo_b, hi_b = b.info["bracket"]
                    print(f"  {b.type:16s} between the branch points at {name} = {lo_b:.8g} and {hi_b:.8g}{unit}"
                          f"{extra}  detected, NOT located: {b.info.get('reason', '')}")
                    continue
                print(f"  {b.type:16s} {name} = {b.value:.8g}{unit}{extra}  multipliers "
                      + ", ".join(f"{m.real:.4f}{m.imag:+.4f}j" for m in big))
            print_branch_meshes(br)
            if quantity:
                q = br.quantity(quantity)
                ok = q[np.isfinite(q)]
                print(f"  {quantity}: " + (f"{ok.min():.6g} .. {ok.max():.6g} along the branch" if ok.size else
                                           "not computed (see the log)"))
        for f in data.get("files", []):
            print(f"wrote {f}")
    return _continue_exit(branch)


def _continue_exit(branch: Any) -> int:
    """1 (with the reasons on stderr) when a branch stopped before its end or a requested branch
    switch failed: the command did not do what it was asked; else 0."""
    problems = [f"the period-{br.periods:g} branch stopped before the end of the range: {br.stop_reason}"
                for br in branch.all_branches() if not br.complete]
    problems += [f"branch switching at the period doubling at {f['value']:.8g} failed: {f['error']}"
                 for f in branch.info.get("switch_failures", [])]
    for msg in problems:
        print(f"gearsym: error: {msg}", file=sys.stderr)
    return ConvergenceError.exit_code if problems else 0
