"""The options of :func:`gearsym.continuation` as a frozen dataclass."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ...budget import check_amount, check_counts

__all__ = ["ContinuationOptions"]


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
