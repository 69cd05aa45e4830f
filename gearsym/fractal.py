"""Surface topography: mean asperity height of a Weierstrass-Mandelbrot profile.

Yu et al. (2021, eqs. 2-5) describe a tooth-flank profile by the modified
Weierstrass-Mandelbrot (W-M) function

.. math::

    z(l) = G^{D-1} \\sum_{k=k_{min}}^{\\infty} \\lambda^{(D-2)k} \\cos(2\\pi\\lambda^k l),
    \\qquad \\lambda^{k_{min}} = 1/l_a,

and take as the effective asperity height the mean of its absolute value over the
sampling (contact) length ``L``, eq. (4):

.. math::

    b = \\frac{1}{L}\\int_0^L |z(l)|\\,dl .

This module evaluates ``b`` numerically (numpy only: it runs when parameters are
bound, never inside the integrator).

How the series is truncated
    ``k`` runs over ``k_min + j`` for ``j = 0, 1, ..., N-1`` (``k_min`` real, so the
    lowest spatial frequency is exactly ``1/l_a``, the largest asperity).  ``N`` is
    increased in steps of 2 until the estimated remainder
    ``|b_N - b_{N-2}| q/(1-q)`` is below ``max(rtol*b, atol)``, where ``q`` is the
    larger of the observed ratio of successive differences and the asymptotic rate
    ``lambda^(4(D-2))`` (two levels; adding a small fast component of amplitude
    ``eps`` changes the mean of ``|z|`` by ``O(eps^2)``, and the amplitudes fall by
    ``lambda^(D-2)`` per level).  The rigorous but pessimistic first-order bound
    ``sup|z - z_N| <= G^(D-1) lambda^((D-2)k_N) / (1 - lambda^(D-2))`` is reported
    as well.  If the work limit is reached first, :class:`~gearsym.errors.ConvergenceError`
    is raised (it names the parameters).

How much work is allowed
    Before any evaluation, the number of levels the tolerance needs at the asymptotic
    rate, ``log(rtol) / (2 (D-2) log(lam))``, and the grid of the first truncation are
    compared with the limits (``max_levels`` levels, ``max_points`` grid points): a
    ``lam`` close to 1 (``1.000001`` needs about ten million levels: the series
    converges almost never) or a sampling length of millions of asperities is refused at
    once with a :class:`~gearsym.errors.ParameterError` naming the parameter, instead of
    an evaluation that does not end.  The levels are capped during the evaluation too,
    and the work of one truncation (grid points times levels) by ``max_work``.

How the integral is evaluated
    Not by quadrature: the antiderivative of the truncated series is known in
    closed form, ``Z(l) = sum a_k sin(2 pi f_k l)/(2 pi f_k)``, so
    ``int_0^L |z| = sum_i |Z(r_{i+1}) - Z(r_i)|`` over the sign changes ``r_i`` of
    ``z`` (with ``r_0 = 0`` and the last one ``L``).  The sign changes are bracketed
    on a grid of ``points_per_wavelength`` points per shortest wavelength and
    refined by safeguarded Newton iterations; an error ``e`` in a root changes the
    result only by ``O(|z'| e^2)``.  A root pair closer than the grid spacing would
    be missed; the result is therefore recomputed on a grid twice as fine and the
    two must agree within the tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .errors import ConvergenceError, ParameterError

_CHUNK = 1 << 16


@dataclass(frozen=True)
class MeanHeight:
    """Result of :func:`wm_mean_height_report`.

    Attributes
    ----------
    value
        Mean absolute height ``b`` (same length unit as ``G``, ``L``, ``l_a``).
    levels
        Number of series levels ``N`` used.
    tail_estimate
        Estimated remainder ``|b_inf - b_N|``.
    tail_bound
        Rigorous bound of ``sup |z - z_N|`` (and hence of ``|b_inf - b_N|``).
    grid_check
        ``|b_N - b_N(grid twice as fine)|``.
    n_roots
        Number of sign changes of the truncated profile in ``[0, L]``.
    history
        ``(N, b_N)`` for every truncation evaluated.
    """

    value: float
    levels: int
    tail_estimate: float
    tail_bound: float
    grid_check: float
    n_roots: int
    history: tuple[tuple[int, float], ...]


def _check(D: float, G: float, lam: float, L: float, l_a: float) -> None:
    for name, v in (("D", D), ("G", G), ("lam", lam), ("L", L), ("l_a", l_a)):
        if not math.isfinite(v):
            raise ParameterError(f"wm_mean_height: {name} = {v} is not finite")
    if not 1.0 < D < 2.0:
        raise ParameterError(f"wm_mean_height: the fractal dimension D must lie in (1, 2), got {D}")
    if not lam > 1.0:
        raise ParameterError(f"wm_mean_height: the frequency density lam must exceed 1, got {lam}")
    for name, v in (("G", G), ("L", L), ("l_a", l_a)):
        if not v > 0.0:
            raise ParameterError(f"wm_mean_height: {name} must be positive, got {v}")


def wm_levels(D: float, G: float, lam: float, l_a: float, n_levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Spatial frequencies ``f_j = lam**j / l_a`` and amplitudes ``G**(D-1) * f_j**(D-2)``.

    ``f_j = lam**k`` with ``k = k_min + j`` and ``lam**k_min = 1/l_a``.
    """
    j = np.arange(int(n_levels), dtype=float)
    f = lam**j / l_a
    return f, G ** (D - 1.0) * f ** (D - 2.0)


def wm_profile(pos: np.ndarray, D: float, G: float, lam: float, l_a: float, n_levels: int) -> np.ndarray:
    """The truncated W-M profile ``z(l)`` with ``n_levels`` levels (eq. 2)."""
    f, a = wm_levels(D, G, lam, l_a, n_levels)
    pos = np.asarray(pos, dtype=float)
    return np.cos(2.0 * np.pi * np.multiply.outer(pos, f)) @ a


def _angle(pos: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``2*pi*f*l`` reduced to [-pi, pi] (whole cycles removed before the trig call)."""
    ph = np.multiply.outer(pos, f)
    ph -= np.round(ph)
    ph *= 2.0 * np.pi
    return ph


def _z(pos: np.ndarray, f: np.ndarray, a: np.ndarray) -> np.ndarray:
    return np.cos(_angle(pos, f)) @ a


def _dz(pos: np.ndarray, f: np.ndarray, a: np.ndarray) -> np.ndarray:
    return -np.sin(_angle(pos, f)) @ (2.0 * np.pi * f * a)


def _Z(pos: np.ndarray, f: np.ndarray, a: np.ndarray) -> np.ndarray:
    return np.sin(_angle(pos, f)) @ (a / (2.0 * np.pi * f))


def _roots(f: np.ndarray, a: np.ndarray, L: float, ppw: int) -> np.ndarray:
    """Sign changes of the truncated profile in (0, L), ascending."""
    h = 1.0 / (f[-1] * ppw)
    n = max(int(math.ceil(L / h)), 2)
    out = []
    prev_l = prev_z = None
    for start in range(0, n + 1, _CHUNK):
        idx = np.arange(start, min(start + _CHUNK, n + 1))
        pos = idx * (L / n)
        z = _z(pos, f, a)
        if prev_l is not None:
            pos = np.concatenate([[prev_l], pos])
            z = np.concatenate([[prev_z], z])
        s = z >= 0.0
        k = np.nonzero(s[:-1] != s[1:])[0]
        if k.size:
            lo, hi, zlo, zhi = pos[k], pos[k + 1], z[k], z[k + 1]
            x = lo - zlo * (hi - lo) / (zhi - zlo)  # secant start inside the bracket
            slo = zlo >= 0.0
            for _ in range(40):
                zx = _z(x, f, a)
                left = (zx >= 0.0) == slo
                lo = np.where(left, x, lo)
                hi = np.where(left, hi, x)
                step = zx / _dz(x, f, a)
                xn = x - step
                bad = ~((xn >= lo) & (xn <= hi)) | ~np.isfinite(xn)
                xn = np.where(bad, 0.5 * (lo + hi), xn)
                done = np.abs(xn - x) <= 1e-10 * h  # result error ~ |z'| * (1e-10 h)^2
                x = xn
                if np.all(done):
                    break
            out.append(x)
        prev_l, prev_z = pos[-1], z[-1]
    return np.sort(np.concatenate(out)) if out else np.zeros(0)


def wm_mean_height_truncated(D: float, G: float, lam: float, L: float, l_a: float, n_levels: int,
                             points_per_wavelength: int = 24) -> tuple[float, int]:
    """Mean of ``|z|`` over ``[0, L]`` for the W-M series truncated to ``n_levels`` levels.

    Returns
    -------
    value, n_roots
    """
    _check(D, G, lam, L, l_a)
    f, a = wm_levels(D, G, lam, l_a, n_levels)
    r = _roots(f, a, L, int(points_per_wavelength))
    pts = np.concatenate([[0.0], r, [L]])
    Zp = np.concatenate([_Z(pts[i:i + _CHUNK], f, a) for i in range(0, pts.size, _CHUNK)])
    return float(np.sum(np.abs(np.diff(Zp))) / L), int(r.size)


def wm_mean_height_report(D: float, G: float, lam: float, L: float, l_a: float, *, rtol: float = 1e-6,
                          atol: float = 1e-11, points_per_wavelength: int = 24,
                          max_points: float = 2e7, n_start: int = 6, max_levels: int = 400,
                          max_work: float = 2e9) -> MeanHeight:
    """Mean absolute height of the infinite W-M series (eq. 4), with its convergence record.

    Parameters
    ----------
    D, G, lam, L, l_a
        Fractal dimension (1 < D < 2), fractal roughness [m], frequency density
        (> 1, 1.5 for most surfaces), sampling length [m], largest asperity base
        diameter [m] (``lam**k_min = 1/l_a``).
    rtol, atol
        Tolerance on the truncation remainder: ``max(rtol*b, atol)`` [m].  The
        default ``atol`` (1e-11 m, a hundredth of an atomic spacing) matters only
        for smooth surfaces (D near 2), whose mean height is itself below a
        nanometre and whose series converges slowly.
    points_per_wavelength
        Grid density that brackets the sign changes.
    max_points
        Work limit (grid points of the finest truncation).
    n_start
        First truncation tried.
    max_levels
        Most levels of the series.
    max_work
        Most grid points times levels of one truncation.

    Raises
    ------
    ParameterError
        If the parameters need more levels or grid points than the limits allow, before
        any evaluation (see the module docstring).
    ConvergenceError
        If the tolerance is not met within the work limit, or the grid check fails.
    """
    _check(D, G, lam, L, l_a)
    N = max(int(n_start), 2)
    _check_work(D, G, lam, L, l_a, (rtol, atol), points_per_wavelength, max_points, N, max_levels)
    rho = lam ** (4.0 * (D - 2.0))  # asymptotic ratio of successive differences (2 levels)
    hist: list[tuple[int, float]] = []
    tail = math.inf
    n_roots = 0
    while True:
        points = L * lam ** (N - 1) / l_a * points_per_wavelength
        if points > max_points or N > max_levels or points * N > max_work:
            last = hist[-1][1] if hist else float("nan")
            raise ConvergenceError(
                f"wm_mean_height(D={D}, G={G}, lam={lam}, L={L}, l_a={l_a}): the W-M series did not "
                f"converge to max({rtol}*b, {atol}) within the work limit ({max_points:g} grid points, "
                f"{max_levels} levels, {max_work:g} points x levels): "
                f"b = {last:.6g} with {N - 2} levels, estimated remainder {tail:.3g}")
        b, n_roots = wm_mean_height_truncated(D, G, lam, L, l_a, N, points_per_wavelength)
        hist.append((N, b))
        if len(hist) >= 3:
            d1 = hist[-1][1] - hist[-2][1]
            d0 = hist[-2][1] - hist[-3][1]
            q_obs = abs(d1 / d0) if d0 != 0.0 else 0.0
            q = max(rho, q_obs)
            tail = abs(d1) * q / (1.0 - q) if q < 1.0 else math.inf
            if tail <= max(rtol * abs(b), atol):
                break
        N += 2
    b2, _ = wm_mean_height_truncated(D, G, lam, L, l_a, N, 2 * points_per_wavelength)
    grid = abs(b2 - b)
    if grid > max(rtol * abs(b), atol):
        raise ConvergenceError(
            f"wm_mean_height(D={D}, G={G}, lam={lam}, L={L}, l_a={l_a}): the root grid is too coarse "
            f"(b = {b:.10g} with {points_per_wavelength} and {b2:.10g} with {2 * points_per_wavelength} "
            f"points per wavelength)")
    _, a = wm_levels(D, G, lam, l_a, N + 1)
    bound = float(a[-1] / (1.0 - lam ** (D - 2.0)))
    return MeanHeight(b, N, tail, bound, grid, n_roots, tuple(hist))


def _check_work(D: float, G: float, lam: float, L: float, l_a: float, tol: tuple[float, float], ppw: int,
                max_points: float, n_start: int, max_levels: int) -> None:
    """Refuse parameters whose series needs more levels or grid points than the limits."""
    rtol, atol = tol
    rate = 2.0 * (2.0 - D) * math.log(lam)  # decay (log) of the differences per level, asymptotically
    first_amplitude = G ** (D - 1.0) * l_a ** (2.0 - D)  # of the first level: the size of b
    reduction = min(1.0 / max(rtol, 1e-300), first_amplitude / max(atol, 1e-300))
    needed = math.log(max(reduction, 1.0)) / rate if rate > 0 else math.inf
    if needed > max_levels:
        raise ParameterError(
            f"wm_mean_height: the W-M series with the frequency density lam = {lam!r} and the fractal "
            f"dimension D = {D!r} needs about {needed:.3g} levels to converge (limit {max_levels}): lam "
            f"is too close to 1 (surfaces use lam = 1.5)")
    first = L / l_a * lam ** (n_start - 1) * ppw
    if not first <= max_points:
        raise ParameterError(
            f"wm_mean_height: the sampling length L = {L!r} spans {L / l_a:.3g} times the largest asperity "
            f"l_a = {l_a!r}: even the first truncation needs {first:.3g} grid points (limit {max_points:g})")


@lru_cache(maxsize=256)
def wm_mean_height(D: float, G: float, lam: float, L: float, l_a: float) -> float:
    """Mean absolute height of a W-M profile (Yu et al. eq. 4), in the unit of ``G``.

    Converged to ``max(1e-6*b, 1e-11 m)``; see :func:`wm_mean_height_report` and the
    module docstring for the truncation of the series and of the integral.

    Examples
    --------
    >>> round(wm_mean_height(1.2, 1e-11, 1.5, 1.5e-4, 1e-4) * 1e6, 2)  # doctest: +SKIP
    3.2
    """
    return wm_mean_height_report(float(D), float(G), float(lam), float(L), float(l_a)).value
