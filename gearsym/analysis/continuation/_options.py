"""The settings of :func:`gearsym.continuation` as a frozen dataclass."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ...budget import check_amount, check_counts, check_harmonics
from ...errors import ParameterError
from ..periodic import F_LAMBDA

__all__ = ["SCENE_DEFAULTS", "ContinuationOptions"]

#: The defaults of the settings that the scene's ``[continue]`` table may set (a ``None`` in a
#: :class:`ContinuationOptions` means: the scene's value, else this one).
SCENE_DEFAULTS: dict[str, object] = {"periods": 1, "method": "shooting", "segments": 1, "harmonics": None,
                                     "switch": 0, "ds_max": 0.02, "max_points": 5000, "tol": 1e-9,
                                     "rtol": 1e-10, "atol": None}


@dataclass(frozen=True)
class ContinuationOptions:
    """Settings of :func:`gearsym.continuation` (each documented here once, with its default).

    ``periods``, ``method``, ``segments``, ``harmonics``, ``switch``, ``ds_max``,
    ``max_points``, ``tol``, ``rtol`` and ``atol`` left at ``None`` take the values of the
    scene's ``[continue]`` table, else the defaults below (:data:`SCENE_DEFAULTS`; one
    resolution with ``gearsym continue``: :func:`gearsym.spec.settings.resolve_settings`).

    Attributes
    ----------
    periods : float or None
        Forcing periods per orbit (``k`` for period-``k`` orbits): a positive whole number.
        Default 1.
    method : str or None
        ``"shooting"`` (single / multiple shooting, ``segments``) or ``"hbm"`` (harmonic
        balance with ``harmonics`` harmonics).  Default ``"shooting"``.
    segments : int or None
        Shooting segments.  Default 1.
    harmonics : int or None
        Harmonics of the harmonic-balance residual.  Default: those with which the starting
        harmonic balance meets ``defect_tol`` (its harmonics grown until one period integrated
        from the balanced state closes to ``defect_tol`` of the orbit's size): a margin for the
        orbit's growth along the branch.
    t0 : float
        Phase of ``x0`` (a multiple of the forcing period).  Default 0.
    ds, ds_min, ds_max : float
        Initial, smallest and largest arclength step in scaled variables (the parameter
        scaled by ``|stop - start|``, every state by its magnitude on the branch):
        ``ds_max = 0.02`` gives at least 50 points over the range.  Default 0.005 (at most
        ``ds_max`` when left at its default), 1e-7, 0.02.
    max_angle : float
        Largest angle (rad) between consecutive tangents before a step is refused.  Default 0.3.
    max_points : int or None
        Limit on the number of points.  Default 5000.
    tol : float or None
        Corrector tolerance on the residual scaled by the state magnitudes.  Default 1e-9.
    rtol, atol : float or None
        Integrator tolerances.  ``rtol`` default 1e-10.  ``atol`` default: ``rtol * 1e-2 *``
        the smallest state magnitude on the first orbit; a state that is identically zero
        there (the trivial orbit ``x = 0``) takes its magnitude from the scene instead: the
        largest entry of its initial state, else the magnitude its ``[simulate]`` tolerances
        imply (``atol / (1e-2 * rtol)``), else 1.  When some states vanish on the orbit while
        others do not (at most 1e-9 of the largest magnitude: round-off, e.g. the centre
        translations of a planetary set with equally spaced planets), the scene's
        ``[simulate]`` ``atol`` is the default, and without one
        :class:`~gearsym.errors.ParameterError` asks for ``atol``.
    max_newton : int
        Newton steps per correction.  Default 7.
    detect : bool or sequence of str
        Bifurcation types to detect (``True``: all of ``fold``, ``period_doubling``,
        ``neimark_sacker``, ``grazing``, ``branch_point``; ``False``: none).  Default ``True``.
    locate : bool
        Locate detected points (else only flag the point after the change).  Default ``True``.
    state : int or str
        The observed state for ``max``, ``min``, ``rms`` (index or name).  Default 0.
    n_dense : int or None
        Samples per forcing period for extrema, RMS and grazing tests.  Default
        ``max(1024, 8 * points_per_period of the scene)``.
    switch : int or None
        Depth of automatic branch switching at period doublings (0: none; 1: the doubled
        branches; 2: also their doublings, ...).  Default 0.
    progress : bool or None
        Show a progress bar (:func:`gearsym.progress.progress_bar`: ``tqdm.auto``, a widget in a
        notebook).  Default: in a terminal or a Jupyter kernel, not in a worker process.
    transient : float or None
        Forcing periods integrated before the first Newton solve when no ``x0`` or ``orbit``
        is given.  Default: the scene's ``transient_periods``, else 20.
    state_weight : float
        Weight of the states against the parameter in the arclength (1: a step of one state
        magnitude counts as much as a step of the whole parameter range).  Smaller values
        take larger parameter steps where the orbit changes quickly (rattling orbits with
        many impacts).  Default 1.
    stall_points, stall_tol : int, float
        The branch does not advance (``complete = False``) when the parameter stays within
        ``stall_tol * |stop - start|`` over ``stall_points`` consecutive points.  Measured on
        a forced linear oscillator: with damping ratios down to 1e-4 the smallest spread over
        50 points through the resonance peak is 1.9e-4 of the range; undamped, the parameter
        converges to the resonance and the branch stalls.  Default 50, 1e-5.
    display : tuple or None
        ``(value of one display unit, unit name)`` for the parameter values in
        ``stop_reason``.  Default: the parameter's declared unit (the unit of ``start``,
        ``stop`` and every value of the branch).
    defect_tol : float
        Time-domain defect of the starting harmonic balance (``method="hbm"``, see
        ``harmonics``).  Default 1e-5.
    f_lambda : str
        ``"exact"``: the parameter derivative of the residual from the engine's parameter
        sensitivities where they are available (shooting), else a finite difference;
        ``"finite_difference"``: always the finite difference (comparisons).  Default ``"exact"``.
    """

    periods: float | None = None
    method: str | None = None
    segments: int | None = None
    harmonics: int | None = None
    t0: float = 0.0
    ds: float = 0.005
    ds_min: float = 1e-7
    ds_max: float | None = None
    max_angle: float = 0.3
    max_points: int | None = None
    tol: float | None = None
    rtol: float | None = None
    atol: float | None = None
    max_newton: int = 7
    detect: Sequence[str] | bool = True
    locate: bool = True
    state: int | str = 0
    n_dense: int | None = None
    switch: int | None = None
    progress: bool | None = None
    transient: float | None = None
    state_weight: float = 1.0
    stall_points: int = 50
    stall_tol: float = 1e-5
    display: tuple[float, str] | None = None
    defect_tol: float = 1e-5
    f_lambda: str = "exact"

    def __post_init__(self) -> None:  # bounded work (gearsym.budget), also for keyword overrides
        check_counts(max_points=self.max_points, max_newton=self.max_newton, n_dense=self.n_dense,
                     switch=self.switch, stall_points=self.stall_points, segments=self.segments)
        check_harmonics("harmonics", self.harmonics)
        check_amount("transient", self.transient)
        if self.f_lambda not in F_LAMBDA:
            raise ParameterError(f"f_lambda must be one of {', '.join(F_LAMBDA)}, got '{self.f_lambda}'")
