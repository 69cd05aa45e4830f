"""What a work-precision run measures of each method's output: the normalised error, the
statistics of a chaotic run, and whether gearsym is on the Pareto front."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .model import PythonModel

__all__ = ["pareto_report"]


def _normalised_error(y: np.ndarray, y_ref: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Per output time: ``max_i |y_i - y_ref_i| / scale_i``."""
    return np.max(np.abs(y - y_ref) / scale[None, :], axis=1)


def _statistics(y: np.ndarray, state_names: Sequence[str], skip: int) -> dict[str, dict[str, float]]:
    z = y[skip:]
    return {n: {"mean": float(np.mean(z[:, i])), "rms": float(np.sqrt(np.mean(z[:, i] ** 2)))}
            for i, n in enumerate(state_names)}


def _grid_crossings(pm: PythonModel | None, grid: np.ndarray, y: np.ndarray, skip: int) -> int | None:
    """Sign changes of the switching functions between output points (any method alike)."""
    if pm is None or pm.nsw == 0:
        return None
    g = np.array([pm.switching(t, yy) for t, yy in zip(grid[skip:], y[skip:])])
    s = np.where(g >= 0, 1, -1)
    return int(np.sum(s[1:] != s[:-1]))


def _stat_deviation(row: Mapping[str, Any], ref: Mapping[str, Mapping[str, float]], ref_cross: int | None,
                    scale: np.ndarray, names: Sequence[str]) -> dict[str, float | None]:
    st = row["statistics"]
    dev = max(max(abs(st[n]["mean"] - ref[n]["mean"]), abs(st[n]["rms"] - ref[n]["rms"])) / scale[i]
              for i, n in enumerate(names))
    cr = row.get("grid_crossings")
    dc = abs(cr - ref_cross) / max(ref_cross, 1) if (cr is not None and ref_cross is not None) else None
    return {"mean_rms": float(dev), "crossings": dc}


def pareto_report(data: Mapping[str, Any]) -> dict[str, Any]:
    """Is each gearsym point on the Pareto front of (time, error) over all methods?

    A point is dominated when another method has a point (at any tolerance) that is
    faster **and** more accurate; errors below ten times the reference floor are
    treated as equal (they cannot be told apart).
    """
    floor = float(data["reference"]["floor"])
    pts = [r for r in data["results"] if "best_s" in r and math.isfinite(r.get("error", math.nan))]

    def eff(e: float) -> float:
        return max(e, 10 * floor)

    out: dict[str, Any] = {"by_rtol": {}, "all_on_front": True}
    for r in pts:
        if r["method"] != "gearsym":
            continue
        dom = [o for o in pts if not o["gearsym"] and o["best_s"] < r["best_s"]
               and eff(o["error"]) < eff(r["error"])]
        key = f"{r['rtol']:g}"
        out["by_rtol"][key] = {"on_front": not dom,
                               "dominated_by": [f"{o['method']} @ rtol {o['rtol']:g} ({o['best_s'] * 1e3:.3g} ms, "
                                                f"err {o['error']:.2g})" for o in dom][:5]}
        if dom:
            out["all_on_front"] = False
    return out

