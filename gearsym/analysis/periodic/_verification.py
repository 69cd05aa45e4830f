"""A periodic orbit returns after a whole number of forcing periods, and is verified.

Two rules every periodic-orbit solver follows before it reports an orbit:

* **whole periods** (:func:`orbit_period`): an orbit of a forced system has a period of
  ``k`` forcing periods with ``k`` a positive integer.  A state that returns after half a
  forcing period is a fixed point of the half-period map, not a periodic orbit (the
  forcing is in another phase when the state comes back): ``periods=0.5`` was solved,
  reported converged and stable, and the state did not return after a forcing period
  (``|x(T) - x0| = 0.07`` on the benchmark oscillator).
* **closure** (:func:`closure`): a converged orbit is integrated once more over its
  period, without the variational equations (a different step sequence from the solve's,
  a different code path from harmonic balance's), and must return to its start:
  ``|phi(t0 + P, t0, x0) - x0|_i <= A (F (rtol s_i + atol) + 100 tol s_i)`` for every
  state ``i``, with ``s_i`` the state's magnitude along the orbit, ``F`` =
  :data:`VERIFY_FACTOR` (the integration's own error: measured at most 383 (rtol s_i +
  atol) over eight shipped scenes, single and multiple shooting, rtol 1e-11 and 1e-8) and
  ``A = max(1, max |mu|)`` (an unstable orbit amplifies the integration error).  The
  absolute floor ``F atol`` is tied to the integrator's ``atol``: the orbit ``x = 0``
  passes on round-off.  With several shooting segments each segment is integrated from its
  own start state (the orbit is what the segments represent: one integration over a long
  unstable orbit would diverge from it).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError, ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["VERIFY_FACTOR", "Closure", "closure", "orbit_period", "runs_closure", "segment_closure", "whole_periods"]

#: The closure of a verified orbit may exceed the integration's own error estimate
#: ``rtol |x| + atol`` by this factor (the largest ratio measured on the shipped scenes was 383).
VERIFY_FACTOR = 1e4


def whole_periods(periods: Any, what: str = "periods") -> int:
    """``periods`` as a positive whole number of forcing periods.

    Parameters
    ----------
    periods
        The number of forcing periods of an orbit (an integer, or a float with an integer value).
    what
        The name in the message (e.g. ``"--periods"``).

    Returns
    -------
    int

    Raises
    ------
    ParameterError
        Not a number, not finite, not a whole number or below 1.
    """
    if isinstance(periods, bool) or not isinstance(periods, numbers.Real):
        raise ParameterError(f"{what} must be a whole number of forcing periods, got {periods!r}")
    v = float(periods)
    if not (math.isfinite(v) and v >= 1 and v == math.floor(v)):
        raise ParameterError(
            f"{what} must be a positive whole number of forcing periods (1, 2, 3, ...), got {periods:g}: a periodic "
            f"orbit of a forced system returns to its state after a whole number of forcing periods")
    return int(v)


def orbit_period(system: CompiledSystem, params: Mapping[str, float] | None, period: float | None, periods: Any,
                 what: str = "a periodic orbit") -> tuple[float, float]:
    """The period of an orbit and its number of forcing periods, checked.

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units).
    period
        The period given by the caller, or ``None``: ``periods`` forcing periods.
    periods
        Forcing periods of the orbit (a positive whole number; ignored when ``period`` is given).
    what
        What needs the period (for the message when the scene has none).

    Returns
    -------
    tuple of float
        ``(period, periods)``; ``periods`` is 1 for a system without a forcing period.

    Raises
    ------
    ParameterError
        No forcing period and no ``period``; ``periods`` not a positive whole number; a
        ``period`` that is not finite and positive, or not a whole number of forcing periods.
    """
    T = system.period(params)
    if period is None:
        if not T and system.has_forcing_period:
            system.require_period(params, what)  # raises: says why
        if not T:
            raise ParameterError("the scene has no forcing period: give period= (autonomous orbits need a phase "
                                 "condition, not supported yet)")
        k = whole_periods(periods)
        return k * float(T), float(k)
    P = float(period)
    if not (math.isfinite(P) and P > 0):
        raise ParameterError(f"orbit period must be finite and > 0, got {period}")
    if not T:
        return P, 1.0
    k = P / float(T)
    if not (round(k) >= 1 and abs(k - round(k)) <= 1e-9 * max(1.0, k)):
        raise ParameterError(f"period={P:.10g} is {k:.10g} forcing periods (T = {float(T):.10g}): the period of an "
                             f"orbit of a forced system is a positive whole number of forcing periods")
    return P, float(round(k))


@dataclass(frozen=True)
class Closure:
    """The verification of one orbit: one more integration over its period.

    Attributes
    ----------
    residual : float
        ``max_i |phi(t0 + P, t0, x0) - x0|_i`` (with segments: the largest mismatch at a
        segment end), absolute.
    relative : float
        The largest ratio of a state's mismatch to what it is allowed (module docstring):
        verified when at most 1.
    ok : bool
        ``relative <= 1``.
    state : int
        The state with the largest ratio.
    how : str
        Which integration verified the orbit.
    error : str
        Why the verification integration failed (empty when it ran).
    """

    residual: float
    relative: float
    ok: bool
    state: int = 0
    how: str = "plain integration over one period (no variational equations)"
    error: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {"residual": self.residual, "relative": self.relative, "ok": self.ok, "state": self.state,
                "how": self.how, **({"error": self.error} if self.error else {})}

    def message(self, names: list[str] | None = None) -> str:
        """Why the orbit failed its verification (for an error message)."""
        if self.error:
            return f"the verification integration over one period failed: {self.error}"
        name = names[self.state] if names and 0 <= self.state < len(names) else f"state {self.state}"
        return (f"the state does not return after one period when integrated once more (|x(t0 + P) - x0| = "
                f"{self.residual:.3g}, largest for {name}: {self.relative:.3g} times what the integration's error "
                f"allows)")


def closure(starts: np.ndarray, ends: np.ndarray, amplitude: np.ndarray, *, rtol: float, atol: float | np.ndarray,
            tol: float, amplification: float = 1.0, how: str | None = None) -> Closure:
    """Judge the ends of one more integration over an orbit.

    Parameters
    ----------
    starts
        The orbit's segment start states, shape (segments, nx) (one row: single shooting).
    ends
        The integrated state at the end of each segment, same shape.
    amplitude
        The magnitude of every state along the orbit (``s_i``), shape (nx,).
    rtol, atol
        Tolerances of the verification integration.
    tol
        The solver's own tolerance (relative to ``s_i``).
    amplification
        ``max |mu|`` of the orbit (values below 1 count as 1).
    how
        Description of the integration (:attr:`Closure.how`).

    Returns
    -------
    Closure
    """
    # on Python floats: called at every branch point, where numpy's per-call overhead on a few
    # states cost more than the rest of the check
    X = np.atleast_2d(np.asarray(starts, float)).tolist()
    E = np.atleast_2d(np.asarray(ends, float)).tolist()
    sizes = np.abs(np.asarray(amplitude, float)).tolist()
    atols = np.broadcast_to(np.asarray(atol, float), (len(sizes),)).tolist()
    amp = amplification if math.isfinite(amplification) and amplification > 1 else 1.0
    N = len(X)
    worst, k, d_max = -1.0, 0, 0.0
    for i, (s_i, a_i) in enumerate(zip(sizes, atols, strict=True)):
        d = max(abs(E[j][i] - X[(j + 1) % N][i]) for j in range(N))
        ratio = d / (amp * (VERIFY_FACTOR * (rtol * s_i + a_i) + 100.0 * tol * s_i)) if math.isfinite(d) else math.inf
        if not ratio <= worst:  # (NaN: the worst)
            worst, k = (ratio if ratio == ratio else math.inf), i
        d_max = d if not d <= d_max else d_max
    kw = {"how": how} if how else {}
    return Closure(d_max, worst, worst <= 1.0, k, **kw)


def runs_closure(starts: np.ndarray, ends: np.ndarray | None, error: str, amplitude: np.ndarray, *, rtol: float,
                 atol: float, tol: float, amplification: float = 1.0) -> Closure:
    """:func:`segment_closure` of verification runs made elsewhere: shooting's, in the C call
    that solved the orbit (:class:`gearsym.engine.shoot.VerifyRuns`, the same runs).

    Parameters
    ----------
    starts
        The segment start states the runs started from, shape (segments, nx).
    ends
        Each run's end state, same shape; ``None`` when a run failed.
    error
        The failed run's error (with ``ends`` ``None``).
    amplitude, rtol, atol, tol, amplification
        As for :func:`closure`.

    Returns
    -------
    Closure
        Not ``ok`` (with :attr:`Closure.error`) when a run failed.
    """
    if ends is None:
        return Closure(math.inf, math.inf, False, 0, error=error)
    return closure(starts, ends, amplitude, rtol=rtol, atol=atol, tol=tol, amplification=amplification)


def segment_closure(system: CompiledSystem, starts: np.ndarray, times: np.ndarray, p: np.ndarray, *, rtol: float,
                    atol: float, tol: float, amplification: float = 1.0, method: str | None = None,
                    max_step: float | None = None, amplitude: np.ndarray | None = None) -> Closure:
    """Verify an orbit by one plain integration over its period (:func:`closure`).

    One :meth:`~gearsym.system.System.flow` without the variational equations per segment,
    from each segment's start state ``starts[i]`` over ``[times[i], times[i + 1]]``.

    Parameters
    ----------
    system
        The compiled system.
    starts
        Segment start states, shape (segments, nx).
    times
        Segment boundaries ``t0 = s_0 < ... < s_N = t0 + P``.
    p
        Parameter vector.
    rtol, atol, tol, amplification
        As for :func:`closure`.
    method, max_step
        As for :meth:`~gearsym.system.System.flow`.
    amplitude
        The states' magnitudes along the orbit; default: the largest ``|x_i|`` the
        verification integration passes (at 9 samples per segment).

    Returns
    -------
    Closure
        Not ``ok`` (with :attr:`Closure.error`) when the integration fails.
    """
    X = np.atleast_2d(np.asarray(starts, float))
    ends = np.empty_like(X)
    amp = np.abs(X).max(axis=0)
    try:
        for i in range(len(X)):
            fl = system.flow(X[i], float(times[i]), float(times[i + 1]), p, rtol=rtol, atol=atol, monodromy=False,
                             method=method, max_step=max_step, n_samples=2 if amplitude is not None else 9)
            ends[i] = fl.x_final
            if amplitude is None:
                amp = np.maximum(amp, fl.amplitude)
    except GearsymError as exc:
        return Closure(math.inf, math.inf, False, 0, error=str(exc))
    return closure(X, ends, amp if amplitude is None else amplitude, rtol=rtol, atol=atol, tol=tol,
                   amplification=amplification)
