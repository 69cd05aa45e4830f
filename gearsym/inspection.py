"""What the CLI reports for gear trains: rigid-body modes, reductions, trivial multipliers, meshes.

Kept apart from :mod:`gearsym.cli` (argument handling and output files): the text and
figures of ``inspect``, ``orbit``, ``simulate`` and ``continue`` for several meshes and
rigid-body modes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["branch_mesh_figure", "inspect_structure", "mesh_figure", "print_branch_meshes", "print_meshes",
           "print_structure", "print_trivial"]


def inspect_structure(m) -> dict[str, Any]:
    """Rigid-body modes, reduction and meshes of a symbolic model (``inspect --json`` keys).

    Returns
    -------
    dict
        ``rigid_body_modes``: ``[{coordinate: coefficient}]`` (text) of the final
        coordinates; ``meshes``: the mesh elements; with a reduction, ``reduction``:
        ``mode``, the reduced ``coordinates`` (name, velocity, definition, meaning,
        equivalent mass), the ``eliminated_rigid_body_modes`` of the model's own
        coordinates and the ``rigid_coordinates_left_out``; with ``[constraints]``,
        ``algebraic``: one entry per algebraic variable (``name``, ``unit``, ``meaning``,
        ``constraint`` and the relation it ``ties``).
    """
    import sympy as sp

    def modes(ms: list[dict]) -> list[dict[str, str]]:
        return [{k: sp.sstr(v) for k, v in mode.items()} for mode in ms]

    out: dict[str, Any] = {"rigid_body_modes": modes(m.rigid_body_modes), "meshes": list(m.mesh_deflections)}
    rr = m.reduction_result
    if rr is not None:
        rcs = {c.name: c for c in m.spec.reduction.coordinates}
        out["reduction"] = {
            "mode": m.spec.reduction.mode,
            "coordinates": [{"name": str(x), "velocity": str(xd), "definition": sp.sstr(
                sum(rr.A[i, j] * q for j, q in enumerate(m.unreduced_coordinates)) + rr.shifts[i]),
                "meaning": rcs[str(x)].meaning, "equivalent_mass": sp.sstr(rr.masses[i])}
                for i, (x, xd) in enumerate(zip(rr.coordinates, rr.velocities))],
            "eliminated_rigid_body_modes": modes(m.unreduced_rigid_body_modes),
            "rigid_coordinates_left_out": [str(q) for q in rr.kept],
        }
    if m.spec.constraints:
        alg = m.spec.algebraic
        out["algebraic"] = [{"name": c.multiplier, "unit": alg[c.multiplier].unit, "meaning": alg[c.multiplier].meaning,
                             "constraint": c.name, "ties": f"{c.coordinate} = {c.equals}"}
                            for c in m.spec.constraints.values()]
    return out


def print_structure(info: dict[str, Any]) -> None:
    """Print the reduction and the rigid-body modes of :func:`inspect_structure` (text ``inspect``)."""
    red = info.get("reduction")
    if red:
        print(f"reduction ({red['mode']}):")
        for c in red["coordinates"]:
            print(f"  {c['name']} = {c['definition']}   (velocity {c['velocity']}; {c['meaning']})")
        for mode in red["eliminated_rigid_body_modes"]:
            print("  eliminates the rigid-body mode " + ", ".join(f"{k}: {v}" for k, v in mode.items()))
    for a in info.get("algebraic", []):
        print(f"algebraic variable {a['name']} [{a['unit']}]: reaction of constraint {a['constraint']} "
              f"({a['ties']}); {a['meaning']}")
    if info["rigid_body_modes"]:
        print("rigid-body modes (coordinate combinations no element sees; trivial Floquet multipliers):")
        for mode in info["rigid_body_modes"]:
            print("  " + ", ".join(f"{k}: {v}" for k, v in mode.items()))


def mesh_figure(system, traj, out: Path, title: str, info: dict[str, Any]) -> Path | None:
    """``mesh_deflections.png`` of a simulation (every mesh, with its contact flanks)."""
    from .analysis.periodic import mesh_deflections, mesh_flanks
    from .plots import plot_mesh_deflections

    params = {k: v for k, v in traj.params.items() if k in system.params} | dict(traj.inputs)
    defl = mesh_deflections(system, traj.t, traj.y, p=system.run_vector(traj.params))
    if not defl:
        return None
    flanks = mesh_flanks(system, traj.t, traj.y, defl, params)
    rattle = {k: v["rattle_state"] for k, v in info.get("meshes", {}).items()}
    return plot_mesh_deflections(traj.t, defl, out, flanks, title, rattle)


def print_trivial(trivial) -> None:
    """The trivial (rigid-body) multipliers of an orbit, if any (text ``orbit``)."""
    if len(trivial):
        print("trivial multipliers (rigid-body modes, not judged): "
              + ", ".join(f"{m.real:.8g}{m.imag:+.3g}j" for m in trivial))


def print_meshes(meshes: dict[str, dict[str, Any]]) -> None:
    """One line per mesh of an orbit: deflection range, peak-to-peak, rattle state."""
    for name, mi in meshes.items():
        rs = "" if mi["rattle_state"] is None else f", rattle state {mi['rattle_state']}"
        print(f"  mesh {name}: deflection in [{mi['deflection_min']:.6g}, {mi['deflection_max']:.6g}], "
              f"peak-to-peak {mi['deflection_peak_to_peak']:.6g}{rs}")


def print_branch_meshes(br) -> None:
    """One line per mesh of a branch: range of the deflection peak-to-peak, rattle states met."""
    import numpy as np

    for mesh in br.mesh_names:
        ptp = br.mesh_quantity(mesh, "peak_to_peak")
        rs = sorted({int(v) for v in br.mesh_quantity(mesh, "rattle_state") if v >= 0})
        print(f"  mesh {mesh}: deflection peak-to-peak {np.nanmin(ptp):.4g} .. {np.nanmax(ptp):.4g}"
              + (f", rattle states {rs}" if rs else ""))


def branch_mesh_figure(branch, out: Path, si: float, xlabel: str, title: str) -> list[Path]:
    """``meshes.png`` of ``continue --out``: every mesh's deflection along the branch."""
    if not branch.mesh_names:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = branch.plot_meshes(xscale=1 / si, yscale=1e6, yunit="um", xlabel=xlabel)
    fig = axes[0].figure
    axes[0].set_title(title)
    fig.tight_layout()
    from .files import save_figure

    save_figure(fig, out / "meshes.png", dpi=110)
    plt.close(fig)
    return [out / "meshes.png"]
