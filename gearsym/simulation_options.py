"""The settings of :meth:`gearsym.System.simulate` and :meth:`gearsym.System.flow` as frozen objects.

Both methods take ``options=`` and, for every caller written before the objects existed, the
same fields as keywords (:func:`gearsym.options.merge_options`: a keyword overrides the
object's field; an unknown keyword is a :class:`~gearsym.errors.ParameterError` naming it
with the closest field).  The defaults are documented here, once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["FlowOptions", "SimulateOptions"]


@dataclass(frozen=True)
class SimulateOptions:
    """How :meth:`gearsym.System.simulate` integrates (everything but the horizon, the initial
    state and the parameter values).

    ``None`` means "the scene's ``[simulate]`` setting, else the default" where a setting has
    one (:func:`gearsym.spec.settings.resolve_settings`).

    Parameters
    ----------
    rtol, atol
        Integrator tolerances (default: the scene's ``rtol`` / ``atol``, else 1e-8 / 1e-10).
    n_out
        Number of evenly spaced output points from ``t0`` to ``t_end`` (both included);
        default: the scene's ``points_per_period`` (else 64) per forcing period (or 1001).
    t0
        Start time (default 0).
    method
        An integration method of :data:`gearsym.integrators.INTEGRATION_METHODS` offered for the
        model's form: ``"adams"`` (default for explicit models unless the scene says otherwise:
        non-stiff gear models take fewer, more accurate steps with it), ``"bdf"`` (stiff
        models), ``"adams_fixedpoint"`` (no Jacobian: large non-stiff models) or ``"ida"``
        (implicit models, their only method).
    max_step
        Largest internal step; default an eighth of the forcing period, so that no pair of
        surface crossings hides inside one step.
    monodromy
        Also integrate the variational equations and return ``d x(t_end)/d x0`` (with
        saltation matrices at the events); see :meth:`gearsym.System.simulate`.
    sigma0
        Side (+1/-1) of each switching surface at ``t0``; from the state if ``None``.
    max_steps
        Limit on internal steps (0: the scene's ``max_steps``, else ten million).
    t_out
        Explicit output times (ascending, in ``[t0, t_end]``; overrides ``n_out``).
    nonlinear, linear_solver
        CVODE's nonlinear iteration (``"newton"``, ``"fixedpoint"``) and Newton's linear solver
        (``"dense"``, ``"blockdiag"``); ``"auto"``: the method's own (see
        :class:`gearsym.engine.run_settings.RunSettings`).
    sensitivities
        Run-time parameters whose sensitivities ``d x(t) / d p`` to return along the
        trajectory (methods that integrate them:
        :func:`gearsym.integrators.supports_sensitivities`).
    """

    rtol: float | None = None
    atol: float | None = None
    n_out: int | None = None
    t0: float = 0.0
    method: str | None = None
    max_step: float | None = None
    monodromy: bool = False
    sigma0: Sequence[float] | None = None
    max_steps: int = 0
    t_out: Sequence[float] | None = None
    nonlinear: str = "auto"
    linear_solver: str = "auto"
    sensitivities: Sequence[str] | None = None


@dataclass(frozen=True)
class FlowOptions:
    """How :meth:`gearsym.System.flow` integrates (the cheap path of the orbit solvers).

    Parameters
    ----------
    rtol, atol
        Tolerances; ``atol`` a number or one per state (default 1e-10 / 1e-12).
    monodromy
        Integrate the variational equations (default True).
    method
        An integration method (:data:`gearsym.integrators.INTEGRATION_METHODS`); default: the
        scene's, else the default of the model's form (Adams; IDA for implicit models).
    max_step
        Largest internal step; default an eighth of the forcing period.
    n_samples
        Evenly spaced samples from ``t0`` to ``t1`` (default 2: the ends).
    max_steps
        Step budget (0: the scene's, else ten million).
    """

    rtol: float = 1e-10
    atol: float | np.ndarray | Any = 1e-12
    monodromy: bool = True
    method: str | None = None
    max_step: float | None = None
    n_samples: int = 2
    max_steps: int = 0
