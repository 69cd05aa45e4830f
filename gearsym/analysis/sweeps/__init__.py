"""Sweeps and global dynamics: many solves over a grid of parameters or initial states.

The public face (the modules behind it are private): :func:`lyapunov_exponents` (the
Lyapunov exponents of the hybrid system at a parameter point: :class:`LyapunovOptions`,
:class:`LyapunovResult`, the windowed averages and batch errors behind them); :func:`stability_map` (the
two-parameter stability / response map, :data:`QUANTITIES`, :data:`MAP_METHODS`) and
:func:`save_map`; :func:`map_point` (the response at one grid point: never an unstable
orbit, :data:`RESPONSE`, :data:`SEARCH`); :func:`run_tasks`, the process pool (or Dask
cluster) every sweep runs its tasks on (:class:`TaskFailure`, :class:`WorkerStartError`).

:func:`basins` (basins of attraction over a grid of two states: :class:`BasinOptions`,
:class:`BasinResult`, the labels :data:`UNRESOLVED`, :data:`UNBOUNDED`, :data:`FAILED`, and the
:class:`Attractor` table).  Brute-force bifurcation diagrams belong here too (one private module,
re-exported below).  Sweeps may import the periodic-orbit and the linear analysis, never
continuation.
"""

from __future__ import annotations

from ._attractors import KINDS, Attractor
from ._basins import FAILED, UNBOUNDED, UNRESOLVED, BasinOptions, BasinResult, basins
from ._lyapunov import (
    LyapunovOptions,
    LyapunovResult,
    batch_errors,
    format_estimate,
    kaplan_yorke,
    lyapunov_exponents,
    weighted_average,
    window,
)
from ._map_points import RESPONSE, SEARCH, map_point
from ._maps import MAP_METHODS, QUANTITIES, save_map, stability_map
from ._workers import TaskFailure, WorkerStartError, run_tasks

__all__ = ["FAILED", "KINDS", "MAP_METHODS", "QUANTITIES", "RESPONSE", "SEARCH", "UNBOUNDED", "UNRESOLVED", "Attractor",
           "BasinOptions", "BasinResult", "LyapunovOptions", "LyapunovResult", "TaskFailure", "WorkerStartError",
           "basins", "batch_errors", "format_estimate", "kaplan_yorke", "lyapunov_exponents", "map_point",
           "run_tasks", "save_map", "stability_map", "weighted_average", "window"]
