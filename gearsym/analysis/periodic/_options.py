"""The settings of the periodic-orbit solvers as frozen dataclasses.

:func:`gearsym.analysis.periodic.shoot` takes ``options=ShootingOptions(...)`` and
:func:`gearsym.analysis.periodic.harmonic_balance` takes
``options=HarmonicBalanceOptions(...)``; each setting is documented once, in its class, with
its default.  The same settings as keywords keep working (:func:`gearsym.analysis._options.resolve_options`:
a keyword given wins over the options object; one that is no setting is refused, naming the
closest).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...budget import check_amount, check_counts, check_harmonics

__all__ = ["HarmonicBalanceOptions", "ShootingOptions"]


@dataclass(frozen=True)
class ShootingOptions:
    """Settings of :func:`gearsym.analysis.periodic.shoot` (single and multiple shooting).

    Attributes
    ----------
    segments : int
        Number of shooting segments (1: single shooting).  Default 1.
    t0 : float
        Phase of the orbit's reference state (a multiple of the forcing period).  Default 0.
    transient : float or None
        Number of forcing periods to integrate before Newton, ending at a time congruent to
        ``t0``.  Default ``None``: 0 when ``x0`` is given, else the scene's
        ``transient_periods`` or 20.
    tol : float
        Convergence: ``max_i |residual_i| / s_i <= tol`` with ``s_i`` the largest ``|x_i|``
        along the trajectory, at least ``atol / tol`` (a relative tolerance per state, so
        states in different units are treated alike, and a residual below ``atol`` always
        converges); also accepted: a full Newton step below ``tol`` (relative) with the
        residual within ``100 tol`` (integration noise).  Default 1e-10.
    rtol, atol : float
        Integrator tolerances (the variational equations use them too).  Default 1e-11, 1e-13.
    max_iter : int
        Newton iteration limit.  Default 50.
    min_step : float
        Smallest damping factor tried before giving up.  Default ``2**-12``.
    raise_on_failure : bool
        Raise :class:`~gearsym.errors.ConvergenceError` if Newton fails (else return the last
        iterate with ``converged=False``).  Default ``True``.
    method : str or None
        Integrator (``"bdf"``, ``"adams"``; ``"ida"`` for implicit models).  Default ``None``:
        the scene's.
    relax_periods : float
        When the damped Newton step cannot reduce the residual, integrate blocks of forcing
        periods from the current iterate (this converges towards an attracting orbit) and
        resume Newton, up to this many periods in all (0: never; unstable orbits need a good
        ``x0`` instead).  Default 200.
    trivial : ndarray or None
        Known trivial directions of the state space (nx x k), e.g. the rigid-body mode of a
        semi-definite model: a multiplier +1 whose eigenvector lies in their span does not
        count against the orbit's isolation.  Default ``None``: the model's rigid-body
        subspace, if any.
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
class HarmonicBalanceOptions:
    """Settings of :func:`gearsym.analysis.periodic.harmonic_balance` (AFT harmonic balance).

    Attributes
    ----------
    harmonics : int, sequence of int or None
        Fixed harmonics: a number ``H`` (``1..H``) or the harmonic numbers to keep (a set,
        e.g. bands around the mesh harmonic).  Default ``None``: grow through the sets of
        :func:`gearsym.analysis.periodic._hbm_sets.growth_sets` (bands around the carriers
        found in the model's excitation spectrum, else ``1, 2, 4, ...``) up to
        ``max_harmonics`` until the time-domain defect is below ``defect_tol`` (and, if
        ``harmonics_tol`` is given, the series changed by less than it relative to each
        state's peak-to-peak).
    max_harmonics : int
        Highest harmonic of the automatic growth.  Default 512.
    harmonics_tol : float or None
        See ``harmonics``.  Default ``None``: the defect alone decides.
    samples : int or None
        AFT samples per period, fixed.  Default ``None``: a power of two >= 4(2H+1) (H the
        highest harmonic of the set or of the excitation), >= 64, doubled (up to 8 times, at
        most ``max_samples``) until the residual on a grid twice as fine implies a Newton
        correction below ``aft_tol`` of every state's size.
    t0 : float
        Time origin (the orbit's ``x0`` is ``x(t0)``).  Default 0.
    tol : float
        Residual tolerance of the algebraic system (relative to max(1, max|C|)).  Default 1e-10.
    max_iter : int
        Quasi-Newton iterations per solve.  Default 100.
    monodromy : bool
        Integrate the variational equations once from ``x(t0)`` for the Floquet multipliers,
        the events and the rattle state.  Default ``True``.
    rtol, atol : float
        Tolerances of that integration and of the time-domain defect.  Default 1e-11, 1e-13.
    raise_on_failure : bool
        Raise :class:`~gearsym.errors.ConvergenceError` if a solve fails.  Default ``True``.
    initial_guess : str
        ``"constant"``: continuation in the number of harmonics from the constant state
        ``x0``; ``"simulation"``: the harmonics of the last of ``transient`` forcing periods
        simulated from ``x0`` (an initial guess only: the solution is the harmonic
        balance's); ``"auto"``: the first, then the second if a solve stalls (the constant
        start may sit in the basin of a local minimum of the residual, e.g. below an
        impacting orbit; with contact surfaces the simulation comes first).  Default ``"auto"``.
    transient : float
        Forcing periods simulated for the ``"simulation"`` guess.  Default 50.
    floor_tol : float
        Accept a residual that no damped step can reduce if it is below
        ``floor_tol * max(1, max|C|)``: with a vector field that jumps across a switching
        surface (mesh damping only in contact) the AFT residual jumps whenever a sample
        changes side and has a floor of order jump/samples.  Recorded as ``"residual floor"``
        in the history.  Default 1e-5.
    trivial : ndarray or None
        Known trivial directions of the state space (nx x k), e.g. a rigid-body mode: a
        multiplier +1 with its eigenvector in their span does not make the orbit
        non-isolated.  Default ``None``: none.
    defect_tol : float
        One period integrated from the balanced ``x(t0)`` must close to ``defect_tol`` of
        every state's peak-to-peak (``info["defect_relative"]``; a state that vanishes on the
        orbit, below 1e-9 of the largest, counts as 1e-9 of the largest, and every state as at
        least ``atol / defect_tol``, so a defect below ``atol`` always passes, as in
        shooting): the automatic growth stops there, and a balance grown automatically that
        does not reach it has not converged.  With fixed ``harmonics`` the series is an
        approximation: it converges if the defect is at most ``max(defect_tol, 0.1)``
        (:data:`~gearsym.analysis.periodic._hbm_driver.FIXED_HARMONICS_DEFECT`): one that
        does not close to a tenth of the orbit's size is not the series of an orbit.
        Default 2e-3.
    aft_tol : float
        See ``samples``.  Default 1e-4.
    max_samples : int
        See ``samples``.  Default 65536.
    floor_rel : float
        Accept a residual floor (see ``floor_tol``) whose residual relative to the derivative
        it balances is below ``floor_rel`` (the kinked residual of a contact).  Default 1e-3.
    """

    harmonics: int | Sequence[int] | None = None
    max_harmonics: int = 512
    harmonics_tol: float | None = None
    samples: int | None = None
    t0: float = 0.0
    tol: float = 1e-10
    max_iter: int = 100
    monodromy: bool = True
    rtol: float = 1e-11
    atol: float = 1e-13
    raise_on_failure: bool = True
    initial_guess: str = "auto"
    transient: float = 50
    floor_tol: float = 1e-5
    trivial: np.ndarray | None = None
    defect_tol: float = 2e-3
    aft_tol: float = 1e-4
    max_samples: int = 1 << 16
    floor_rel: float = 1e-3

    def __post_init__(self) -> None:  # bounded work (gearsym.budget), before any allocation
        check_harmonics("harmonics", self.harmonics)
        check_counts({"samples": "aft_samples", "max_samples": "aft_samples"}, max_harmonics=self.max_harmonics,
                     samples=self.samples, max_samples=self.max_samples, max_iter=self.max_iter)
        check_amount("transient", self.transient)
