"""The cost of the periodic-orbit analyses at each tolerance: one shooting solve (and its
multiplier error) and one continuation step."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["analysis_costs", "multiplier_error"]


def analysis_costs(system, rtols: Sequence[float], params: Mapping[str, float] | None = None,
                   atol_ratio: float = 1e-2, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Cost of one periodic-orbit (shooting) solve and of one continuation step at each tolerance.

    The period-1 orbit is first found at rtol 1e-11 (untimed, the reference for the
    multipliers).  Then, at each rtol: one shooting solve from that orbit's state
    perturbed by 1e-2 of its magnitude, Newton tolerance ``max(10 rtol, 1e-10)`` (wall
    time, Newton iterations, error of the Floquet multipliers), and a continuation of two steps in the parameter the forcing
    period depends on most (largest ``|d ln T / d ln p|``: the speed, not an inertia that
    enters a dimensionless speed), from the orbit (wall time per step).
    """
    say = progress or (lambda s: None)
    out: dict[str, Any] = {"shooting": None, "continuation": None}
    T = system.period(params)
    if not T or not hasattr(system, "periodic_orbit"):
        out["shooting"] = {"available": False, "reason": "no forcing period" if not T else "no periodic_orbit"}
        return out
    try:
        base = system.periodic_orbit(params=params, rtol=1e-11, atol=1e-11 * atol_ratio, tol=1e-10)
    except Exception as exc:
        out["shooting"] = {"available": True, "failed": f"reference orbit: {type(exc).__name__}: {exc}"[:300]}
        return out
    mu_ref = np.asarray(base.multipliers, complex)
    scale = np.maximum(np.abs(base.x0), 1e-300)
    guess = base.x0 + 1e-2 * scale * np.where(np.arange(scale.size) % 2, -1.0, 1.0)
    rows = []
    for rtol in rtols:
        say(f"shooting at rtol {rtol:g}")
        row: dict[str, Any] = {"rtol": rtol}
        try:
            walls = []
            for _ in range(3):  # best of three
                t = time.perf_counter()
                orb = system.periodic_orbit(x0=guess, params=params, rtol=rtol, atol=rtol * atol_ratio,
                                            tol=max(10 * rtol, 1e-10), relax_periods=0)
                walls.append(time.perf_counter() - t)
            row["wall_s"] = min(walls)
            mu = np.asarray(orb.multipliers, complex)
            err = multiplier_error(mu, mu_ref)
            row.update(iterations=int(orb.iterations), residual=float(orb.residual),
                       max_multiplier=float(np.max(np.abs(mu))), multiplier_error=err,
                       multiplier_error_rel=None if err is None else err / max(float(np.max(np.abs(mu_ref))), 1e-300),
                       state_error=float(np.max(np.abs(orb.x0 - base.x0) / scale)), stable=bool(orb.stable))
        except Exception as exc:
            row["failed"] = f"{type(exc).__name__}: {exc}"[:300]
        rows.append(row)
    out["shooting"] = {"available": True, "orbit_multipliers": [str(m) for m in mu_ref],
                       "stable": bool(base.stable), "rows": rows,
                       "what": "one shooting solve from the orbit's state perturbed by 1e-2 (relative), best of 3"}
    try:
        from ..analysis.continuation import continuation
    except ImportError:
        out["continuation"] = {"available": False}
        return out
    p0 = dict(system.params) | dict(params or {})
    param, best = None, 1e-9
    for name in system.params:   # the parameter the forcing period depends on most (|d ln T / d ln p|)
        try:
            sens = abs(math.log(system.period({**(params or {}), name: p0[name] * 1.01}) / T)) / math.log(1.01)
        except Exception:
            continue
        if sens > best * (1 + 1e-6):
            param, best = name, sens
    if param is None:
        out["continuation"] = {"available": False, "reason": "the forcing period depends on no parameter"}
        return out
    crow = []
    for rtol in rtols:
        say(f"continuation at rtol {rtol:g}")
        row = {"rtol": rtol, "param": param}
        try:
            t = time.perf_counter()
            br = continuation(system, param, p0[param], p0[param] * 1.05, orbit=base, params=params, rtol=rtol,
                              atol=rtol * atol_ratio, tol=max(10 * rtol, 1e-9), max_points=3, detect=False,
                              locate=False, progress=False)
            wall = time.perf_counter() - t
            steps = max(len(br.points) - 1, 1)
            row.update(wall_s=wall, steps=steps, wall_per_step_s=wall / steps)
        except Exception as exc:
            row["failed"] = f"{type(exc).__name__}: {exc}"[:300]
        crow.append(row)
    out["continuation"] = {"available": True, "rows": crow,
                           "what": f"pseudo-arclength continuation in {param} from the orbit, 2 steps"}
    return out


def multiplier_error(mu: np.ndarray, mu_ref: np.ndarray) -> float | None:
    """Largest ``|mu - mu_ref|`` over the best one-to-one matching of the two sets
    (sorting is not enough: a perturbation can swap two multipliers with close real parts)."""
    from scipy.optimize import linear_sum_assignment

    if mu.shape != mu_ref.shape:
        return None
    cost = np.abs(mu[:, None] - mu_ref[None, :])
    i, j = linear_sum_assignment(cost)
    return float(np.max(cost[i, j]))



_multiplier_error = multiplier_error  # the former private name (tests, scripts)
