"""Does a continuation advance?  The stall tests of :func:`gearsym.continuation`.

An undamped system forced at resonance has no periodic orbit there: along the
frequency-response branch the amplitude grows like ``1 / |Omega - Omega_r|`` and the
pseudo-arclength continuation spends every step on the growing state while the
parameter converges to ``Omega_r`` -- before these tests it ran 5,000 points stuck at
``Omega = 1.00000000009`` and reported success.  A branch does not advance when

* the parameter stayed within ``tol`` (``stall_tol`` times the range, default 1e-5)
  over the last ``n`` points (``stall_points``, default 50): measured on a forced linear
  oscillator, damping ratios down to 1e-4 spread at least 1.9e-4 of the range over any
  50 points through their resonance peak; or
* the quick test (:data:`QUICK_STALL`): over the last 30 points the parameter stayed
  within 1e-3 of the range while the orbit grew monotonically by 1.5x or more and the
  multiplier nearest +1 was *neutral* (on the unit circle to the monodromy's accuracy,
  :func:`~gearsym.analysis.periodic.monodromy_error`) at every point -- a conservative
  system running into a resonance, whose amplitude no damping can bound (a damped peak
  has its multipliers inside the circle by ``2 pi zeta``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..periodic import monodromy_error

__all__ = ["QUICK_STALL", "stalled_branch"]

#: The quick stall test: points, parameter spread (fraction of the range), growth of the orbit.
QUICK_STALL = (30, 1e-3, 1.5)


def stalled_branch(points: Sequence[tuple[float, np.ndarray | None, np.ndarray]], n: int, tol: float,
                   lam_scale: float, rtol: float) -> tuple[int, float, float, float, float] | None:
    """Whether the last points of a branch show that it does not advance.

    Parameters
    ----------
    points
        ``(parameter, state magnitudes (or their maximum) or None, multipliers)`` of the branch's points, in
        order (at least the last ``max(n, 30) + 1``).
    n, tol
        The parameter staying within ``tol`` over ``n`` points is a stall.
    lam_scale
        The parameter range (for the quick test's spread).
    rtol
        The integrator's relative tolerance (the monodromy's accuracy).

    Returns
    -------
    tuple or None
        ``(points, lo, hi, size_before, size_now)`` of the stalled window, else ``None``.
    """
    def window(k: int) -> tuple[list[float], list[float]]:
        pts = points[-k - 1:]
        return ([float(p[0]) for p in pts],
                [p[1] if type(p[1]) is float else math.nan if p[1] is None else
                 (float(p[1]) if isinstance(p[1], (float, int)) or np.ndim(p[1]) == 0 else float(np.max(p[1])))
                 for p in pts])

    if len(points) > n:
        lam, size = window(n)
        if max(lam) - min(lam) <= tol:
            return n, min(lam), max(lam), size[0], size[-1]
    k, spread, growth = QUICK_STALL
    if len(points) <= k:
        return None
    lam, size = window(k)
    if max(lam) - min(lam) > spread * lam_scale or not size[-1] >= growth * size[0] or \
            not all(b >= a for a, b in zip(size[:-1], size[1:])):
        return None
    for _, _, mu in points[-k - 1:]:
        if not len(mu):
            return None
        m = mu[int(np.argmin(np.abs(mu - 1.0)))]
        if abs(abs(m) - 1.0) > monodromy_error(float(np.max(np.abs(mu))), rtol):
            return None
    return k, min(lam), max(lam), size[0], size[-1]
