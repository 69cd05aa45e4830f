"""Truncated Fourier series of periodic orbits: the coefficient layout and its two directions.

The layout of harmonic balance (:mod:`gearsym.analysis.periodic._hbm`): rows
``[a0, a1, b1, a2, b2, ...]`` of ``x(t) = a0 + sum_k a_k cos(k w (t - t0)) + b_k sin(k w (t - t0))``,
``w = 2 pi / period``; one column per state.
"""

from __future__ import annotations

import numpy as np

__all__ = ["coefficients", "synthesize"]


def synthesize(C: np.ndarray, n: int) -> np.ndarray:
    """The series on ``n`` evenly spaced points of one period (end excluded).

    Parameters
    ----------
    C
        Coefficients, shape ``(2H + 1,)`` or ``(2H + 1, nx)``.
    n
        Number of points.

    Returns
    -------
    ndarray
        Shape ``(n,)`` or ``(n, nx)``.
    """
    C = np.asarray(C, float)
    H = (C.shape[0] - 1) // 2
    th = 2 * np.pi * np.arange(n) / n
    k = np.arange(1, H + 1)
    cos, sin = np.cos(np.outer(th, k)), np.sin(np.outer(th, k))
    return C[0] + cos @ C[1::2] + sin @ C[2::2]


def coefficients(Y: np.ndarray, H: int) -> np.ndarray:
    """The first ``H`` harmonics of samples on ``n >= 2H + 1`` evenly spaced points of one period.

    Parameters
    ----------
    Y
        Samples, shape ``(n,)`` or ``(n, nx)`` (end of the period excluded).
    H
        Number of harmonics.

    Returns
    -------
    ndarray
        Shape ``(2H + 1,)`` or ``(2H + 1, nx)``.
    """
    Y = np.asarray(Y, float)
    Cf = np.fft.rfft(Y, axis=0) / Y.shape[0]
    out = np.zeros((2 * H + 1,) + Y.shape[1:])
    out[0] = Cf[0].real
    out[1::2] = 2 * Cf[1:H + 1].real
    out[2::2] = -2 * Cf[1:H + 1].imag
    return out
