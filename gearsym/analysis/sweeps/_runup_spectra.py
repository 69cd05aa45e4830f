"""The signal processing of a run-up: short-time spectra in speed bins, order tracking.

Pure numpy (no model): :mod:`gearsym.analysis.sweeps._runup` samples the run-up and calls
these.

* :func:`speed_bins`: the run is cut into ``bins`` windows of ``L`` samples each (the largest
  even ``L`` with ``L <= 2 n / (bins + 1)``: half-overlapping windows cover the run), their
  starts evenly spread from the first sample to ``n - L``;
* :func:`short_time_spectra`: the amplitude spectrum of each window, ``A(f_k) = 2 |X_k| /
  sum(w)`` with ``X`` the DFT of ``w (x - mean(x))`` and ``w`` a periodic Hann window (a
  sinusoid of amplitude ``a`` at a bin frequency reads ``a``), frequencies ``k / (L dt)``:
  the waterfall and the Campbell diagram;
* :func:`order_amplitudes`: order tracking in the angle domain.  The run is sampled at
  equal steps of the phase time ``tau`` (equal angles of the speed's phase: the engine's
  output at the exact times ``t(tau_j)``), ``q`` samples per forcing period; in each window a
  whole number ``K`` of forcing periods is taken, so that mesh order ``h`` of a mesh with
  ``c`` cycles per forcing period is DFT bin ``h K c`` exactly (no leakage, whatever the
  speed): amplitude ``2 |E_{hKc}| / (K q)``, the same definition as the gear quantities'
  ``dte_harmonic_<h>`` (:mod:`gearsym.quantities`).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError

__all__ = ["angle_windows", "order_amplitudes", "short_time_spectra", "speed_bins"]

#: The shortest window (samples) of a short-time spectrum.
MIN_WINDOW = 16


def speed_bins(n: int, bins: int) -> tuple[np.ndarray, int]:
    """The windows of the short-time spectra: ``(starts, L)``.

    Parameters
    ----------
    n
        Samples of the run.
    bins
        Number of windows (speed bins).

    Returns
    -------
    starts : ndarray of int
        First sample of each window, ascending.
    L : int
        Samples per window (even).

    Raises
    ------
    ParameterError
        Windows shorter than ``MIN_WINDOW`` samples.
    """
    L = int(2 * n // (bins + 1)) // 2 * 2
    if L < MIN_WINDOW:
        raise ParameterError(f"{bins} speed bins over {n} samples leave {L} samples per spectrum (need at least "
                             f"{MIN_WINDOW}): use fewer bins, a longer run or more samples_per_period")
    starts = np.round(np.linspace(0, n - L, bins)).astype(int)
    return starts, L


def short_time_spectra(x: np.ndarray, dt: float, starts: np.ndarray, L: int) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectra of the windows ``x[s:s+L]`` (module docstring).

    Parameters
    ----------
    x
        The signal at equal time steps ``dt``.
    dt
        The time step.
    starts, L
        The windows (:func:`speed_bins`).

    Returns
    -------
    frequencies : ndarray
        ``k / (L dt)``, ``k = 0 .. L/2`` (cycles per time unit).
    amplitudes : ndarray, shape (len(starts), L/2 + 1)
        The amplitude spectrum of each window (0 at ``k = 0``: the mean is removed).
    """
    w = 0.5 - 0.5 * np.cos(2.0 * math.pi * np.arange(L) / L)  # periodic Hann
    segs = np.asarray(x, float)[np.asarray(starts)[:, None] + np.arange(L)[None, :]]
    segs = segs - segs.mean(axis=1, keepdims=True)
    amp = 2.0 * np.abs(np.fft.rfft(segs * w, axis=1)) / w.sum()
    amp[:, 0] = 0.0
    return np.fft.rfftfreq(L, dt), amp


def angle_windows(tau_a: np.ndarray, tau_b: np.ndarray, dtau: float, q: int) -> tuple[np.ndarray, np.ndarray]:
    """The angle-domain windows inside the phase-time windows ``[tau_a, tau_b]``: ``(first, K)``.

    Angle sample ``j`` is at ``tau = j dtau``, ``q`` samples per forcing period; window ``i``
    starts at the first sample at or after ``tau_a[i]`` and holds ``K[i] q`` samples, the
    most whole forcing periods that end by ``tau_b[i]`` (``K = 0``: none fits).
    """
    first = np.ceil(np.asarray(tau_a, float) / dtau - 1e-9).astype(int)
    K = np.floor((np.asarray(tau_b, float) / dtau - first + 1e-9) / q).astype(int)
    return first, np.maximum(K, 0)


def order_amplitudes(xa: np.ndarray, first: np.ndarray, K: np.ndarray, q: int, cycles: list[int],
                     orders: int) -> np.ndarray:
    """Amplitudes of the mesh orders in each angle-domain window (module docstring).

    Parameters
    ----------
    xa
        The signal at the angle samples.
    first, K
        The windows (:func:`angle_windows`).
    q
        Angle samples per forcing period.
    cycles
        Mesh cycles per forcing period, one per mesh.
    orders
        Orders ``1 .. orders``.

    Returns
    -------
    ndarray, shape (len(cycles), orders, len(first))
        NaN where a window holds no whole forcing period, or the order is at or above the
        window's Nyquist bin.
    """
    out = np.full((len(cycles), orders, len(first)), math.nan)
    for i, (j0, k) in enumerate(zip(first, K)):
        m = int(k) * q
        if k < 1 or j0 + m > len(xa):
            continue
        E = np.fft.rfft(np.asarray(xa[j0:j0 + m], float))
        for mi, c in enumerate(cycles):
            for h in range(1, orders + 1):
                b = h * int(k) * int(c)
                if 2 * b < m:
                    out[mi, h - 1, i] = 2.0 * abs(E[b]) / m
    return out
