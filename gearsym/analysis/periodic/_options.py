"""Options of the periodic-orbit solvers as frozen dataclasses.

:func:`gearsym.analysis.periodic.shoot` takes ``options=ShootingOptions(...)`` and
:func:`gearsym.continuation` takes ``options=ContinuationOptions(...)``; the keyword
arguments of both keep working and override the options object (a keyword left at
its default takes the object's value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...budget import check_amount, check_counts

__all__ = ["ShootingOptions"]


@dataclass(frozen=True)
class ShootingOptions:
    """Settings of :func:`gearsym.analysis.periodic.shoot` (see there for each one).

    Attributes
    ----------
    segments : int
        Shooting segments (1: single shooting).
    t0 : float
        Phase of the orbit's reference state.
    transient : float or None
        Forcing periods integrated before Newton (default: 0 with ``x0``, else the scene's).
    tol : float
        Newton tolerance (relative to each state's magnitude).
    rtol, atol : float
        Integrator tolerances.
    max_iter : int
        Newton iteration limit.
    min_step : float
        Smallest damping factor.
    raise_on_failure : bool
        Raise when Newton fails (else return the last iterate, ``converged=False``).
    method : str or None
        Integrator.
    relax_periods : float
        Forcing periods of relaxation by integration allowed when Newton stalls.
    trivial : ndarray or None
        Known trivial directions of the state space.
    """

    segments: int = 1
    t0: float = 0.0
    transient: float | None = None
    tol: float = 1e-10
    rtol: float = 1e-11
    atol: float = 1e-13
    max_iter: int = 50
    min_step: float = 2.0 ** -12
    raise_on_failure: bool = True
    method: str | None = None
    relax_periods: float = 200
    trivial: np.ndarray | None = None

    def __post_init__(self) -> None:  # bounded work (gearsym.budget), also for keyword overrides
        check_counts(segments=self.segments, max_iter=self.max_iter)
        check_amount("transient", self.transient)
        check_amount("relax_periods", self.relax_periods)
