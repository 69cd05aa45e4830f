"""Periodic orbits: the problems, the solvers, Floquet multipliers and the stability rule.

The public face of the periodic-orbit analysis (the modules behind it are private):

* **solvers**: :func:`periodic_orbit` dispatches to :func:`shoot` (single / multiple
  shooting with the engine's variational monodromy) or :func:`harmonic_balance`
  (alternating frequency/time); both return a :class:`PeriodicOrbit`, verified by one
  independent integration over its period (:func:`whole_periods`, :func:`orbit_period`);
  their settings are :class:`ShootingOptions` and :class:`HarmonicBalanceOptions`;
* **problems** (what continuation drives): :class:`PeriodicOrbitProblem`, the interface
  (residual, Jacobian, parameter derivative), implemented by :class:`ShootingResidual` and
  :class:`HBResidual`; one evaluation is an :class:`Evaluation`; shooting and the
  continuation's corrector run THE damped Newton iteration of the engine
  (``gearsym/engine/gs_newton.c``, :class:`NewtonPolicy`; ``docs/contributing.md``, "Where
  each numerical rule lives");
* **Floquet and stability**: :func:`floquet` (the three-answer stability rule),
  :func:`multiplier_tolerances`, :func:`verdict`, :func:`rigid_state_basis`; the exact
  monodromy of piecewise-constant linear systems (:class:`PiecewiseLTV`,
  :func:`exact_multipliers`); isolation of an orbit (:func:`isolation`);
* **what an orbit does at its meshes**: the rattle state (:func:`rattle_state`,
  :func:`mesh_rattle_states`, :func:`peak_to_peak`) and the mesh deflections
  (:func:`mesh_deflections`, :func:`trajectory_meshes`).

This package imports no other kind of analysis (continuation, sweeps, linear analysis).
"""

from __future__ import annotations

from ...engine.newton import NewtonPolicy
from ._floquet import NotPiecewiseConstantError, PiecewiseLTV, exact_multipliers, monodromy_product
from ._hb_problem import HBResidual
from ._hbm import HarmonicBalance
from ._hbm_driver import harmonic_balance
from ._isolation import Isolation, isolation, monodromy_error
from ._meshes import mesh_deflections, mesh_flanks, mesh_names, mesh_point, mesh_report, trajectory_meshes
from ._options import HarmonicBalanceOptions, ShootingOptions
from ._orbit import VANISHING, PeriodicOrbit
from ._parameter_derivative import F_LAMBDA, exact_f_lambda
from ._problems import Evaluation, PeriodicOrbitProblem, ShootingResidual, log_events, segment_jacobian
from ._rattle import (
    RATTLE_STATES,
    RattleSummary,
    mesh_rattle_states,
    peak_to_peak,
    rattle_state,
    rattle_summary,
)
from ._shooting import shoot
from ._solve import ORBIT_METHODS, periodic_orbit
from ._stability import (
    ERROR_FACTOR,
    STABILITY,
    FloquetResult,
    complex_sides,
    floquet,
    multiplier_tolerances,
    neutral_step_limit,
    rigid_anchor_rows,
    rigid_state_basis,
    verdict,
)
from ._verification import orbit_period, whole_periods

__all__ = [
    "ERROR_FACTOR", "F_LAMBDA", "ORBIT_METHODS", "RATTLE_STATES", "STABILITY", "VANISHING",
    "Evaluation", "FloquetResult", "HBResidual", "HarmonicBalance", "HarmonicBalanceOptions", "Isolation", "NewtonPolicy",
    "NotPiecewiseConstantError", "PeriodicOrbit", "PeriodicOrbitProblem", "PiecewiseLTV", "RattleSummary",
    "ShootingOptions", "ShootingResidual",
    "complex_sides", "exact_f_lambda", "exact_multipliers", "floquet", "harmonic_balance",
    "isolation", "log_events", "mesh_deflections", "mesh_flanks", "mesh_names", "mesh_point", "mesh_rattle_states",
    "mesh_report", "monodromy_error", "monodromy_product", "multiplier_tolerances", "neutral_step_limit",
    "orbit_period", "peak_to_peak", "periodic_orbit", "rattle_state", "rattle_summary", "rigid_anchor_rows", "rigid_state_basis",
    "segment_jacobian", "shoot", "trajectory_meshes", "verdict", "whole_periods",
]
