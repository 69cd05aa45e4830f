"""Options of the periodic-orbit solvers as frozen dataclasses.

:func:`gearsym.analysis.shooting.shoot` takes ``options=ShootingOptions(...)`` and
:func:`gearsym.continuation` takes ``options=ContinuationOptions(...)``; the keyword
arguments of both keep working and override the options object (a keyword left at
its default takes the object's value).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from typing import Any, TypeVar

import numpy as np

from ..budget import check_amount, check_counts
from ..errors import ParameterError

__all__ = ["ContinuationOptions", "ShootingOptions", "resolve_options"]


@dataclass(frozen=True)
class ShootingOptions:
    """Settings of :func:`gearsym.analysis.shooting.shoot` (see there for each one).

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


@dataclass(frozen=True)
class ContinuationOptions:
    """Numerical settings of :func:`gearsym.continuation` (see there for each one).

    Attributes
    ----------
    ds, ds_min, ds_max : float
        Initial, smallest and largest arclength step (scaled variables).
    max_angle : float
        Largest angle (rad) between consecutive tangents.
    max_points : int
        Limit on the number of points.
    tol : float
        Corrector tolerance.
    rtol : float
        Integrator relative tolerance.
    atol : float or None
        Integrator absolute tolerance (default from the first orbit).
    max_newton : int
        Newton steps per correction.
    detect : bool or sequence of str
        Bifurcation types to detect.
    locate : bool
        Locate the detected points.
    state : int or str
        The observed state.
    n_dense : int or None
        Samples per forcing period for extrema and grazing tests.
    switch : int
        Depth of automatic branch switching at period doublings.
    progress : bool or None
        Progress bar on stderr (default: when stderr is a terminal).
    transient : float or None
        Forcing periods before the first Newton solve.
    state_weight : float
        Weight of the states against the parameter in the arclength.
    stall_points : int
        Points over which a stalled parameter ends the branch.
    stall_tol : float
        Relative spread of the parameter below which it counts as stalled.
    display : tuple or None
        ``(value of one display unit in the parameter's declared unit, unit name)`` for messages.
    """

    ds: float = 0.005
    ds_min: float = 1e-7
    ds_max: float = 0.02
    max_angle: float = 0.3
    max_points: int = 5000
    tol: float = 1e-9
    rtol: float = 1e-10
    atol: float | None = None
    max_newton: int = 7
    detect: Sequence[str] | bool = True
    locate: bool = True
    state: int | str = 0
    n_dense: int | None = None
    switch: int = 0
    progress: bool | None = None
    transient: float | None = None
    state_weight: float = 1.0
    stall_points: int = 50
    stall_tol: float = 1e-5
    display: tuple[float, str] | None = None

    def __post_init__(self) -> None:  # bounded work (gearsym.budget), also for keyword overrides
        check_counts(max_points=self.max_points, max_newton=self.max_newton, n_dense=self.n_dense,
                     switch=self.switch, stall_points=self.stall_points)
        check_amount("transient", self.transient)


T = TypeVar("T", ShootingOptions, ContinuationOptions)


def _same(a: Any, b: Any) -> bool:
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return False
    try:
        return bool(a == b) and type(a) is type(b)
    except (TypeError, ValueError):
        return False


def resolve_options(options: T | None, cls: type[T], **keywords: Any) -> T:
    """The options in effect: ``options`` (default ``cls()``) with every keyword that is not
    at its default overriding it.

    Parameters
    ----------
    options
        An options object, or ``None``.
    cls
        Its class.
    **keywords
        The keyword arguments of the call (one per field).

    Returns
    -------
    ShootingOptions or ContinuationOptions
    """
    if options is not None and not isinstance(options, cls):
        raise ParameterError(f"options must be a {cls.__name__}, got {type(options).__name__}")
    if options is None:  # the same keywords give the same (frozen) options: kept for reuse
        try:
            key = (cls, *((k, type(v), v) for k, v in keywords.items()))
            hit = _RESOLVED.get(key)
        except TypeError:  # an unhashable value (an array)
            key = hit = None
        if hit is not None:
            return hit
        out = _resolve(None, cls, keywords)
        if key is not None:
            if len(_RESOLVED) >= 256:
                _RESOLVED.clear()
            _RESOLVED[key] = out
        return out
    return _resolve(options, cls, keywords)


_RESOLVED: dict[tuple, Any] = {}


def _resolve(options: T | None, cls: type[T], keywords: dict[str, Any]) -> T:
    default, names = _defaults(cls)
    base = options if options is not None else default
    changes = {k: v for k, v in keywords.items() if k in names and not _same(v, getattr(default, k))}
    return replace(base, **changes) if changes else base


@functools.cache
def _defaults(cls: type[T]) -> tuple[T, frozenset[str]]:
    """The default instance of an options class (frozen: one can be shared) and its field names."""
    return cls(), frozenset(f.name for f in fields(cls))
