"""Per-mesh quantities: dynamic deflections, their extrema, and the rattle state of each mesh.

A model with several meshes (a gear train) reports every mesh: the dynamic deflection
``delta = deflection - error`` of mesh ``NAME`` along a trajectory (the generated
``gs_mesh``, :mod:`gearsym.codegen.extras`), its extrema and peak-to-peak value, and the
rattle state of the mesh (0 no contact loss, 1 contact loss only, 2 back-side contact,
from its own contact surfaces ``NAME.drive`` / ``NAME.back``).  The scalar
``rattle_state`` of a result is the worst mesh.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from ...results import Trajectory
    from ...system import CompiledSystem as System

__all__ = ["mesh_deflections", "mesh_extrema", "mesh_flanks", "mesh_names", "mesh_point", "mesh_report",
           "trajectory_meshes"]


def mesh_names(system: System) -> list[str]:
    """Names of the model's mesh elements (in model order)."""
    return list(getattr(system.generated, "meshes", []) or [])


def mesh_deflections(system: System, t: Sequence[float], Y: np.ndarray,
                     params: Mapping[str, float] | None = None, p: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Dynamic deflection of every mesh at the states ``Y[k]`` at times ``t[k]`` (SI); ``p``: a
    parameter vector instead of ``params`` (a run's, :meth:`CompiledSystem.run_vector`).

    Parameters
    ----------
    system
        The compiled system.
    t
        Times, shape (n,), in the model's time unit.
    Y
        States at ``t``, shape (n, nx), SI units (a trajectory's ``y``).
    params
        Parameter overrides (declared units), e.g. the trajectory's ``params``.
    p
        The parameter vector itself (SI), instead of ``params``: a run's
        (:meth:`CompiledSystem.run_vector` of its ``params``), whose bound functions keep the
        run's values.

    Returns
    -------
    dict
        Mesh name -> array like ``t``: the deflection along the line of action less the
        transmission error (m, or the model's length unit: SI), empty for a model without meshes.
    """
    names = mesh_names(system)
    if not names or "gs_mesh" not in system.generated.functions:
        return {}
    t = np.asarray(t, float)
    Y = np.asarray(Y, float).reshape(len(t), -1)
    D = system.mesh_deflections(t, Y, system.param_vector(params) if p is None else p).T  # generated C, in the engine
    return {name: D[i] for i, name in enumerate(names)}


def _refined(y: np.ndarray, sign: float) -> float:
    """Extremum of samples (max for sign=+1, min for -1) refined by a parabola."""
    z = sign * np.asarray(y, float)
    i = int(np.argmax(z))
    if 0 < i < len(z) - 1:
        a, b, c = z[i - 1], z[i], z[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return float(sign * (b - 0.125 * (c - a) ** 2 / den))
    return float(sign * z[i])


def _refined_periodic(d: np.ndarray, i: int, sign: float) -> float:
    """:func:`_refined` of ``append(d, d[0])`` (one period, its end the start again) at its
    extremum ``i`` (the first argmax of ``sign * d``)."""
    if i > 0:
        a, b, c = sign * float(d[i - 1]), sign * float(d[i]), sign * float(d[i + 1] if i + 1 < len(d) else d[0])
        den = a - 2 * b + c
        if den < 0:
            return float(sign * (b - 0.125 * (c - a) ** 2 / den))
    return float(d[i])


def mesh_extrema(deflections: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """``{mesh: {"min", "max", "peak_to_peak"}}`` of sampled deflections (parabolic refinement)."""
    out = {}
    for name, d in deflections.items():
        lo, hi = _refined(d, -1.0), _refined(d, +1.0)
        out[name] = {"min": lo, "max": hi, "peak_to_peak": hi - lo}
    return out


def mesh_report(system: System, t: np.ndarray, Y: np.ndarray, params: Mapping[str, float] | None,
                rattle: Mapping[str, int | None]) -> dict[str, dict[str, Any]]:
    """Per-mesh summary of one orbit: rattle state and deflection extrema, JSON-ready."""
    from ._rattle import RATTLE_STATES

    ext = mesh_extrema(mesh_deflections(system, t, Y, params))
    out: dict[str, dict[str, Any]] = {}
    for name in mesh_names(system):
        rs = rattle.get(name)
        e = ext.get(name, {"min": float("nan"), "max": float("nan"), "peak_to_peak": float("nan")})
        out[name] = {"rattle_state": rs, "rattle_state_meaning": RATTLE_STATES.get(rs) if rs is not None else None,
                     "deflection_min": e["min"], "deflection_max": e["max"],
                     "deflection_peak_to_peak": e["peak_to_peak"]}
    return out


def trajectory_meshes(system: System, traj: Trajectory, steady_fraction: float = 0.5) -> dict[str, dict[str, Any]]:
    """Per-mesh summary of the steady part of a simulation (``simulate --json``).

    The rattle state of each mesh comes from its located contact events in the steady
    window (:func:`gearsym.analysis.periodic.rattle_summary`), the deflection extrema from
    the output samples in that window.
    """
    from ._rattle import rattle_summary, steady_window

    names = mesh_names(system)
    if not names:
        return {}
    ts, te = steady_window(traj.t, steady_fraction, None, traj.period)
    on = traj.t >= ts - 1e-12 * max(1.0, abs(ts))
    defl = mesh_deflections(system, traj.t[on], traj.y[on], p=system.run_vector(traj.params))
    surfaces = {s["name"].rsplit(".", 1)[0] for s in system.generated.surfaces if s.get("kind") in ("drive", "back")}
    rattle: dict[str, int | None] = {}
    for name in names:
        rattle[name] = (rattle_summary(traj, system=system, element=name, steady_fraction=steady_fraction).state
                        if name in surfaces else None)
    from ._rattle import RATTLE_STATES

    out: dict[str, dict[str, Any]] = {}
    for name in names:
        d = defl.get(name)
        rs = rattle[name]
        out[name] = {"rattle_state": rs, "rattle_state_meaning": RATTLE_STATES.get(rs) if rs is not None else None,
                     "deflection_min": float(np.min(d)) if d is not None and d.size else float("nan"),
                     "deflection_max": float(np.max(d)) if d is not None and d.size else float("nan"),
                     "deflection_peak_to_peak": float(np.ptp(d)) if d is not None and d.size else float("nan")}
    return out


def mesh_flanks(system: System, t: Sequence[float], Y: np.ndarray, deflections: Mapping[str, np.ndarray],
                params: Mapping[str, float] | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Contact flank positions ``(lower, upper)`` of every backlash mesh at the samples.

    The contact surfaces are ``g = delta -/+ b`` (:class:`gearsym.symbolic.model.SwitchingFunction`),
    so the flank of surface ``g`` is ``delta - g``: ``+b`` and ``-b`` for a constant backlash,
    the moving flanks of a dynamic backlash.
    """
    gen = system.generated
    if not gen.nsw or not deflections:
        return {}
    t = np.asarray(t, float)
    Y = np.asarray(Y, float).reshape(len(t), -1)
    p = system.param_vector(params)
    n = len(t)
    G = system.switching(t, Y, p=p).reshape(n, gen.nsw).T
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, d in deflections.items():
        levels = [d - G[j] for j, s in enumerate(gen.surfaces)
                  if s.get("kind") in ("drive", "back") and s["name"].rsplit(".", 1)[0] == name]
        if len(levels) == 2:
            lo, hi = sorted(levels, key=lambda a: float(np.mean(a)))
            out[name] = (lo, hi)
    return out


def mesh_point(system: System, t: np.ndarray, Y: np.ndarray, params: Mapping[str, float],
               rattle: Mapping[str, int], deflections: np.ndarray | None = None,
               extrema_at: tuple[Sequence[int], Sequence[int]] | None = None) -> dict[str, dict[str, Any]]:
    """Per mesh: rattle state and extrema of the dynamic deflection over one period sampled at ``t``
    (end excluded; a branch point of :func:`gearsym.continuation`).  ``deflections``: the
    deflections at the samples when already evaluated (shape (len(t), number of meshes));
    ``extrema_at``: with them, the first argmin and argmax of each column when already known.

    A failure (an evaluation of the generated deflections) is raised, not turned into an empty
    summary: the continuation rejects the point instead of reporting it without its meshes."""
    names = mesh_names(system)
    if deflections is not None and extrema_at is not None and deflections.shape == (len(t), len(names)) \
            and len(extrema_at[0]) == len(extrema_at[1]) == len(names):
        ext = {}
        for k, name in enumerate(names):
            d = deflections[:, k]
            lo, hi = _refined_periodic(d, extrema_at[0][k], -1.0), _refined_periodic(d, extrema_at[1][k], +1.0)
            ext[name] = {"min": lo, "max": hi, "peak_to_peak": hi - lo}
        return {name: {"rattle_state": rattle.get(name), **e} for name, e in ext.items()}
    if deflections is not None and deflections.shape == (len(t), len(names)):
        defl = {name: deflections[:, i] for i, name in enumerate(names)}
    else:
        defl = mesh_deflections(system, t, Y, params)
    ext = mesh_extrema({k: np.append(d, d[:1]) for k, d in defl.items()})
    return {name: {"rattle_state": rattle.get(name), **{k: float(v) for k, v in e.items()}}
            for name, e in ext.items()}
