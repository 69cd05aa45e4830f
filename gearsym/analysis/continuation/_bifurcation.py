"""Test functions of the bifurcations of periodic orbits, and a bracketing root finder.

Along a branch every test function is evaluated at every point; a sign change
between two neighbouring points brackets a special point, which
:mod:`gearsym.analysis.continuation._api` then *locates* by solving
``tau(sigma) = 0`` in the arclength ``sigma`` between the two points (every
evaluation is a corrected point on the branch).

==================  =========================================================
type                test function (zero at the bifurcation)
==================  =========================================================
fold                ``t_lambda``: parameter component of the unit tangent
period_doubling     ``prod (mu_i + 1) / (1 + |mu_i|)`` -- a real mu through -1
neimark_sacker      ``prod_{i<j} (mu_i mu_j - 1) / (1 + |mu_i mu_j|)`` -- a complex
                    pair through the unit circle (a real pair with product 1, a
                    neutral saddle, is rejected when classifying)
branch_point        ``prod (mu_i - 1) / (1 + |mu_i|)`` without a turning point
grazing             ``min_t g_j`` and ``max_t g_j`` of every switching function
                    over the orbit (the orbit starts or stops touching surface j)
==================  =========================================================

The products are normalised factor by factor so that they stay finite for very
unstable orbits; only their sign and continuity matter.
"""

from __future__ import annotations

import cmath
import functools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["bracket_root", "count_unstable", "crossing_multiplier", "tau_branch_point",
           "tau_neimark_sacker", "tau_period_doubling"]


def count_unstable(mu: np.ndarray, tol: float = 0.0) -> int:
    """Number of multipliers with ``|mu| > 1 + tol``."""
    return int(np.sum(np.abs(np.asarray(mu)) > 1.0 + tol))


def _tau_shift(mu: np.ndarray, shift: float) -> float:
    """``Re prod (mu_i + shift) / (1 + |mu_i|)`` (NaN for no or non-finite multipliers); in Python
    arithmetic for the few multipliers of a small model, where numpy's per-call cost dominates."""
    vals = np.asarray(mu, complex).tolist()
    if not vals or not all(cmath.isfinite(v) for v in vals):
        return math.nan
    if len(vals) > 32:
        a = np.asarray(vals)
        return float(np.real(np.prod((a + shift) / (1.0 + np.abs(a)))))
    prod = complex(1.0)
    for v in vals:
        prod *= (v + shift) / (1.0 + abs(v))
    return float(prod.real)


def tau_period_doubling(mu: np.ndarray) -> float:
    """Sign-carrying test function of a real multiplier through -1."""
    return _tau_shift(mu, 1.0)


def tau_branch_point(mu: np.ndarray) -> float:
    """Sign-carrying test function of a real multiplier through +1 (``det(M - I)``)."""
    return _tau_shift(mu, -1.0)


@functools.lru_cache(maxsize=64)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``i < j`` of ``n`` multipliers (cached: asked at every branch point)."""
    i, j = np.triu_indices(n, 1)
    i.flags.writeable = False
    j.flags.writeable = False
    return i, j


def tau_neimark_sacker(mu: np.ndarray) -> float:
    """Sign-carrying test function of a pair with ``mu_i mu_j = 1`` (complex pair on the circle)."""
    mu = np.asarray(mu, complex)
    n = len(mu)
    if n <= 32:  # Python arithmetic (as _tau_shift)
        vals = mu.tolist()
        if not all(cmath.isfinite(v) for v in vals):
            return math.nan
        prod = complex(1.0)
        for a in range(n):
            for b in range(a + 1, n):
                q = vals[a] * vals[b]
                prod *= (q - 1.0) / (1.0 + abs(q))
        return float(prod.real)
    if not np.all(np.isfinite(mu)):
        return math.nan
    i, j = _pairs(n)
    q = mu[i] * mu[j]
    return float(np.real(np.prod((q - 1.0) / (1.0 + np.abs(q)))))


def crossing_multiplier(mu_a: np.ndarray, mu_b: np.ndarray) -> dict[str, Any]:
    """Which multiplier crossed the unit circle between two points, and how.

    Returns a dictionary with ``kind`` (``"+1"``, ``"-1"``, ``"complex"`` or
    ``None``) and the multiplier at each side (the one nearest the circle on the
    side where it is outside).
    """
    na, nb = count_unstable(mu_a), count_unstable(mu_b)
    out: dict[str, Any] = {"n_unstable_before": na, "n_unstable_after": nb, "kind": None}
    if na == nb:
        return out
    outside = np.asarray(mu_b if nb > na else mu_a, complex)
    cand = outside[np.abs(outside) > 1.0]
    if len(cand) == 0:
        return out
    m = cand[np.argmin(np.abs(cand))]
    if abs(m.imag) > 1e-7 * max(1.0, abs(m)):
        out["kind"] = "complex"
    else:
        out["kind"] = "+1" if m.real > 0 else "-1"
    out["multiplier"] = complex(m)
    return out


def bracket_root(f: Callable[[float], float], a: float, fa: float, b: float, fb: float,
                 xtol: float, max_iter: int = 60) -> tuple[float, float, float, float, float]:
    """Root of ``f`` in ``[a, b]`` with ``sign(fa) != sign(fb)``: Illinois regula falsi with
    a bisection safeguard (a bisection whenever two steps did not halve the bracket).

    Returns ``(x, a, fa, b, fb)``: the estimate and the final bracket (so that a
    jump of ``f`` -- a discontinuous test function -- can be told from a root).
    ``f`` may return NaN (a failed evaluation): the bracket is then bisected.

    The iteration also stops at a point whose value is at most ``1e-6`` of the end values
    and whose distance to the root, by the slope of the current bracket, is below
    ``xtol / 2`` (the bracket need not shrink to ``xtol`` around a root already found:
    that cost two to four more evaluations, each a corrected branch point).  A jump of
    ``f`` never stops it that way: its values near the jump are not small.
    """
    if fa == 0:
        return a, a, fa, a, fa
    if fb == 0:
        return b, b, fb, b, fb
    small = 1e-6 * max(abs(fa), abs(fb))
    ga, gb = fa, fb  # Illinois-modified values for the secant
    side = 0
    width0 = abs(b - a)
    for it in range(max_iter):
        if abs(b - a) <= xtol:
            break
        lo, hi = min(a, b), max(a, b)
        if it % 2 == 0:
            if it > 0 and abs(b - a) > 0.5 * width0:
                c = 0.5 * (a + b)
            else:
                c = (a * gb - b * ga) / (gb - ga) if gb != ga else 0.5 * (a + b)
            width0 = abs(b - a)
        else:
            c = (a * gb - b * ga) / (gb - ga) if gb != ga else 0.5 * (a + b)
        margin = 0.02 * (hi - lo)
        c = min(max(c, lo + margin), hi - margin)
        fc = f(c)
        if not math.isfinite(fc):
            c = 0.5 * (a + b)
            fc = f(c)
            if not math.isfinite(fc):
                break
        if fc == 0:
            return c, c, fc, c, fc
        if (fc > 0) == (fa > 0):
            a, fa, ga = c, fc, fc
            if side == -1:
                gb *= 0.5
            side = -1
        else:
            b, fb, gb = c, fc, fc
            if side == 1:
                ga *= 0.5
            side = 1
        if abs(fc) <= small and fb != fa and abs(fc) * abs(b - a) / abs(fb - fa) <= 0.5 * xtol:
            return c, a, fa, b, fb
    x = a if abs(fa) < abs(fb) else b
    return x, a, fa, b, fb


def unit_circle_pair(mu: Sequence[complex], tol: float = 1e-3) -> complex | None:
    """The complex multiplier (upper half plane) nearest the unit circle, if within ``tol``."""
    mu = np.asarray(mu, complex)
    c = mu[(mu.imag > 1e-9 * np.maximum(1, np.abs(mu)))]
    if len(c) == 0:
        return None
    m = c[np.argmin(np.abs(np.abs(c) - 1.0))]
    return complex(m) if abs(abs(m) - 1.0) <= tol else None
