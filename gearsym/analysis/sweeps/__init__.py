"""Sweeps and global dynamics: many solves over a grid of parameters or initial states.

The public face (the modules behind it are private): :func:`lyapunov_exponents` (the
Lyapunov exponents of the hybrid system at a parameter point: :class:`LyapunovOptions`,
:class:`LyapunovResult`, the windowed averages and batch errors behind them); :func:`stability_map` (the
two-parameter stability / response map, :class:`MapOptions`, :data:`QUANTITIES`, :data:`MAP_METHODS`) and
:func:`save_map`; :func:`map_point` (the response at one grid point: never an unstable
orbit, :data:`RESPONSE`, :data:`SEARCH`); the coexistence search of a map (every stable periodic
orbit and classified non-periodic attractor at each point: :class:`SearchOptions`, :class:`MapAttractor`,
:data:`ATTRACTOR_KINDS`, :data:`FOUND_BY`, :data:`SEARCHES`, :func:`closed_curve`);
:func:`run_tasks`, the process pool (or Dask cluster) every sweep runs its tasks on
(:class:`TaskFailure`, :class:`WorkerStartError`, :func:`report` of a task's progress).

:func:`runup` (a linear ramp of a speed parameter, exact in the engine, with its waterfall,
Campbell diagram and mesh-order tracks: :class:`RunupOptions`, :class:`RunupResult`).

:func:`basins` (basins of attraction over a grid of two states: :class:`BasinOptions`,
:class:`BasinResult`, the labels :data:`UNRESOLVED`, :data:`UNBOUNDED`, :data:`FAILED`, and the
:class:`Attractor` table, its :data:`KINDS`).  Brute-force bifurcation diagrams:
:func:`bifurcation_diagram` (:class:`DiagramOptions`, :func:`save_bifurcation_diagram`,
:func:`diagram_summary`).  Sweeps may import the periodic-orbit and the linear analysis, never
continuation.

Basins, maps and diagrams recognise attractors by one set of rules
(``gearsym.analysis.sweeps._attractor_id``): the period of a sequence of Poincare points, the
units of a distance between states, the kinds of attractor (:data:`ATTRACTOR_KINDS` by code,
:data:`KINDS` by name -- periodic, quasi-periodic, chaotic, unclassified -- one criterion each),
when two orbits are the same, and the description of a stable orbit.
"""

from __future__ import annotations

from ._attractor_id import ATTRACTOR_KINDS, KINDS, closed_curve
from ._attractors import Attractor
from ._basins import FAILED, UNBOUNDED, UNRESOLVED, BasinOptions, BasinResult, basins
from ._bifurcation_diagram import (
    DIRECTIONS,
    DiagramOptions,
    bifurcation_diagram,
    diagram_summary,
    save_bifurcation_diagram,
)
from ._coexist import COEXIST_DEFAULT_POINTS
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
from ._map_attractors import FOUND_BY, SEARCHES, MapAttractor, SearchOptions
from ._map_points import RESPONSE, SEARCH, map_point
from ._maps import MAP_METHODS, QUANTITIES, MapOptions, save_map, stability_map
from ._runup import RunupOptions, runup
from ._runup_result import RunupResult
from ._workers import TaskFailure, WorkerStartError, report, run_tasks

__all__ = ["ATTRACTOR_KINDS", "COEXIST_DEFAULT_POINTS", "DIRECTIONS", "FAILED", "FOUND_BY", "KINDS", "MAP_METHODS",
           "QUANTITIES", "RESPONSE", "SEARCH", "SEARCHES", "UNBOUNDED", "UNRESOLVED", "Attractor", "BasinOptions",
           "BasinResult", "DiagramOptions", "LyapunovOptions", "LyapunovResult", "MapAttractor", "MapOptions",
           "RunupOptions", "RunupResult", "SearchOptions", "TaskFailure", "WorkerStartError", "basins", "batch_errors",
           "bifurcation_diagram", "closed_curve", "diagram_summary", "format_estimate", "kaplan_yorke",
           "lyapunov_exponents", "map_point", "report", "run_tasks", "runup", "save_bifurcation_diagram", "save_map",
           "stability_map", "weighted_average", "window"]
