"""The interpolants of spec tables, as numbers: piecewise polynomials and Fourier series.

A table (:mod:`gearsym.spec.tables`) is data; what it *means* between its samples is
decided here, once, as plain numbers that the symbolic layer writes into the equations
(:mod:`gearsym.symbolic.tables`) and that :func:`evaluate` evaluates in Python.  Both read
the same coefficients, so the generated C evaluates the same interpolant as the Python
reference, to round-off.

* ``linear``: the pieces of :func:`numpy.interp` (on a piece ``[x_j, x_j+1]`` the value is
  ``y_j + s_j*(x - x_j)``, ``s_j = (y_j+1 - y_j)/(x_j+1 - x_j)``);
* ``cubic``: :class:`scipy.interpolate.CubicSpline`, ``bc_type="periodic"`` over a periodic
  domain without jumps, else ``"not-a-knot"`` (scipy's default) on every run of samples
  between two jumps (a run of two samples is a straight line, of three a parabola);
* ``fourier`` (periodic domains, equally spaced samples, no jumps): the trigonometric
  interpolant of the samples (the discrete Fourier transform), truncated to the fewest
  harmonics that reproduce every sample to the table's tolerance.

A **jump** is a knot written twice (``x_j = x_j+1``): the value before it is ``y_j``, after it
``y_j+1``.  A periodic domain of length ``P`` with the closing sample ``x_0 + P`` has a jump at
its wrap if the closing value differs from ``y_0``; without the closing sample the last piece
joins ``(x_N, y_N)`` to ``(x_0 + P, y_0)`` (``numpy.interp(..., period=P)``).

Outside a non-periodic domain a table holds its end values (``outside = "hold"``, as
``numpy.interp``) or continues its end pieces (``"extend"``, as ``CubicSpline(extrapolate=True)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Fourier", "Pieces", "evaluate", "fourier_fit", "linear_pieces", "cubic_pieces", "column_interpolant"]

#: Relative spacing error below which samples count as equally spaced (``fourier``).
UNIFORM_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Pieces:
    """A piecewise polynomial ``p_j(x - b_j)`` on ``[b_j, b_j+1)``.

    Attributes
    ----------
    breaks
        ``b_0 < b_1 < ... < b_M`` (strictly increasing).
    coefs
        ``M`` tuples, the coefficients of piece ``j``, highest degree first (as
        :class:`scipy.interpolate.PPoly`): ``p_j(u) = c_0 u^d + ... + c_d``.
    period
        ``P`` for a periodic domain (then ``b_M = b_0 + P``), else ``None``.
    outside
        Non-periodic: ``"hold"`` (the end values outside ``[b_0, b_M]``) or ``"extend"``
        (the first and last pieces continue).
    """

    breaks: tuple[float, ...]
    coefs: tuple[tuple[float, ...], ...]
    period: float | None = None
    outside: str = "hold"

    def left(self) -> float:
        """The value at ``b_0`` (from the right)."""
        return float(self.coefs[0][-1])

    def right(self) -> float:
        """The value at ``b_M`` (from the left)."""
        c = self.coefs[-1]
        u = self.breaks[-1] - self.breaks[-2]
        return float(_horner(c, u))


@dataclass(frozen=True)
class Fourier:
    """``mean + sum_k cos_k cos(2 pi k x/P) + sin_k sin(2 pi k x/P)``, ``k = 1 .. H``."""

    period: float
    mean: float
    cos: tuple[float, ...]
    sin: tuple[float, ...]

    @property
    def harmonics(self) -> int:
        return len(self.cos)


def _horner(c, u):
    out = c[0]
    for a in c[1:]:
        out = out * u + a
    return out


def _runs(x: np.ndarray) -> list[tuple[int, int]]:
    """``(first, last)`` index of every run of samples between jumps (a knot written twice)."""
    cuts = [0] + [j + 1 for j in range(len(x) - 1) if x[j + 1] == x[j]] + [len(x)]
    return [(a, b - 1) for a, b in zip(cuts, cuts[1:])]


def _periodic_samples(x: np.ndarray, y: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """The samples over one closed period ``[x_0, x_0 + P]`` (the closing sample appended if absent)."""
    if x[-1] < x[0] + period:
        return np.append(x, x[0] + period), np.append(y, y[0])
    return x, y


def _join(parts: list[tuple[np.ndarray, np.ndarray]], period: float | None, outside: str) -> Pieces:
    """One :class:`Pieces` from the pieces of consecutive runs ``(breaks, coefs)``."""
    breaks: list[float] = []
    coefs: list[tuple[float, ...]] = []
    for b, c in parts:
        if breaks and b[0] != breaks[-1]:  # pragma: no cover - runs are consecutive by construction
            raise ValueError("runs of a table are not consecutive")
        breaks = breaks[:-1] + [float(v) for v in b] if breaks else [float(v) for v in b]
        coefs += [tuple(float(v) for v in col) for col in c]
    return Pieces(tuple(breaks), tuple(coefs), period, outside)


def _rotated(x: np.ndarray, y: np.ndarray, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Periodic samples ``[x_0, x_0 + P]`` rotated to start at their first interior jump (so that
    no run of samples crosses the wrap); unchanged if the wrap is a jump or there is none."""
    if y[-1] != y[0]:
        return x, y  # a jump at the wrap
    jumps = [j for j in range(len(x) - 1) if x[j + 1] == x[j]]
    if not jumps:
        return x, y
    j = jumps[0] + 1  # the sample after the first jump starts the rotated cycle
    xs = np.concatenate([x[j:-1], x[:j] + period])
    ys = np.concatenate([y[j:-1], y[:j]])
    return xs, ys


def linear_pieces(x: np.ndarray, y: np.ndarray, period: float | None = None, outside: str = "hold") -> Pieces:
    """The pieces of linear interpolation (those of :func:`numpy.interp`), jumps kept.

    Parameters
    ----------
    x, y
        Knots (non-decreasing; a knot written twice is a jump) and values.
    period
        The period of a periodic domain (``None``: not periodic).
    outside
        ``"hold"`` or ``"extend"`` (non-periodic).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if period is not None:
        x, y = _rotated(*_periodic_samples(x, y, period), period)
    parts = []
    for a, b in _runs(x):
        xs, ys = x[a:b + 1], y[a:b + 1]
        with np.errstate(over="ignore", invalid="ignore"):  # checked by the caller (finite)
            slope = (ys[1:] - ys[:-1]) / (xs[1:] - xs[:-1])
        parts.append((xs, np.stack([slope, ys[:-1]], axis=1)))
    return _join(parts, period, outside)


def cubic_pieces(x: np.ndarray, y: np.ndarray, period: float | None = None, outside: str = "hold") -> Pieces:
    """The pieces of a cubic spline (:class:`scipy.interpolate.CubicSpline`), jumps kept.

    A periodic domain without jumps: ``bc_type="periodic"``.  Otherwise every run between
    jumps is a ``"not-a-knot"`` spline (two samples: a line; three: a parabola).
    """
    from scipy.interpolate import CubicSpline

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if period is not None:
        x, y = _rotated(*_periodic_samples(x, y, period), period)
        if len(_runs(x)) == 1 and y[-1] == y[0]:
            with np.errstate(over="ignore", invalid="ignore"):
                cs = CubicSpline(x, y, bc_type="periodic")
            return _join([(x, cs.c.T)], period, outside)
    parts = []
    for a, b in _runs(x):
        xs, ys = x[a:b + 1], y[a:b + 1]
        with np.errstate(over="ignore", invalid="ignore"):
            cs = CubicSpline(xs, ys, bc_type="not-a-knot")
        c = cs.c.T
        if c.shape[1] < 4:  # two samples: scipy's line (degree 1), padded to a cubic
            c = np.hstack([np.zeros((c.shape[0], 4 - c.shape[1])), c])
        parts.append((xs, c))
    return _join(parts, period, outside)


def uniform(x: np.ndarray, period: float) -> bool:
    """Whether the samples ``x`` (without the closing one) are equally spaced over ``period``."""
    h = period / len(x)
    return bool(np.all(np.abs(np.diff(x) - h) <= UNIFORM_TOLERANCE * period))


def fourier_fit(x: np.ndarray, y: np.ndarray, period: float, tolerance: float) -> Fourier:
    """The trigonometric interpolant of equally spaced periodic samples, truncated.

    Parameters
    ----------
    x, y
        ``N`` equally spaced samples over one period (without the closing sample).
    period
        ``P``.
    tolerance
        Largest deviation from a sample allowed (the table's unit, SI).

    Returns
    -------
    Fourier
        The fewest harmonics ``H`` (``0 <= H <= N/2``) whose series is within
        ``tolerance`` of every sample; ``H = N/2`` reproduces them all (to round-off).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    n = len(y)
    c = np.fft.rfft(y) / n                      # c_k of y_i = sum_k c_k exp(2 pi i k i/N)
    k = np.arange(len(c))
    c = c * np.exp(-2j * np.pi * k * x[0] / period)  # referred to x = 0 instead of x_0
    weight = np.where((k == 0) | ((n % 2 == 0) & (k == n // 2)), 1.0, 2.0)
    a = weight * c.real
    b = -weight * c.imag
    theta = 2 * np.pi * np.outer(x / period, k[1:])
    approx = np.full(n, a[0])
    best = len(k) - 1
    for h in range(len(k)):
        if h > 0:
            approx = approx + a[h] * np.cos(theta[:, h - 1]) + b[h] * np.sin(theta[:, h - 1])
        if np.max(np.abs(approx - y)) <= tolerance:
            best = h
            break
    return Fourier(float(period), float(a[0]), tuple(float(v) for v in a[1:best + 1]),
                   tuple(float(v) for v in b[1:best + 1]))


def column_interpolant(x: np.ndarray, y: np.ndarray, kind: str, period: float | None, outside: str,
                       tolerance: float) -> Pieces | Fourier:
    """The interpolant of one column of a table (see the module docstring)."""
    if kind == "linear":
        return linear_pieces(x, y, period, outside)
    if kind == "cubic":
        return cubic_pieces(x, y, period, outside)
    if kind == "fourier":
        assert period is not None
        xs, ys = (x[:-1], y[:-1]) if x[-1] == x[0] + period else (x, y)
        return fourier_fit(xs, ys, period, tolerance)
    raise ValueError(f"unknown interpolation '{kind}'")  # pragma: no cover - checked by the spec


def evaluate(f: Pieces | Fourier, x: np.ndarray | float) -> np.ndarray:
    """Evaluate an interpolant (the Python reference of what the generated C computes).

    Parameters
    ----------
    f
        A :class:`Pieces` or :class:`Fourier`.
    x
        Where (the table's domain, SI; a phase in cycles).

    Returns
    -------
    numpy.ndarray
    """
    x = np.atleast_1d(np.asarray(x, float))
    if isinstance(f, Fourier):
        th = 2 * np.pi * x / f.period
        out = np.full(x.shape, f.mean)
        for k, (a, b) in enumerate(zip(f.cos, f.sin), start=1):
            out = out + a * np.cos(k * th) + b * np.sin(k * th)
        return out
    b = np.asarray(f.breaks)
    if f.period is not None:
        x = b[0] + np.mod(x - b[0], f.period)
    j = np.clip(np.searchsorted(b, x, side="right") - 1, 0, len(b) - 2)
    c = np.asarray(f.coefs)[j]
    out = _horner(c.T, x - b[j])
    if f.period is None and f.outside == "hold":
        out = np.where(x < b[0], f.left(), np.where(x >= b[-1], f.right(), out))
    return out


def finite(f: Pieces | Fourier) -> bool:
    """Whether every coefficient of an interpolant is a finite number."""
    nums = [f.mean, *f.cos, *f.sin] if isinstance(f, Fourier) else [v for c in f.coefs for v in c]
    return all(math.isfinite(v) for v in nums)
