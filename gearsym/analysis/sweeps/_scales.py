"""Units of distance between states along an attractor: the scale of each state from samples or extrema.

One rule for every sweep (:mod:`gearsym.analysis.sweeps._attractor_id`, where it is explained) and for
the tangent space of the Lyapunov exponents (:mod:`gearsym.analysis.sweeps._lyapunov`): a state's scale
is its range (peak-to-peak) along the attractor, at least :data:`SIZE_FLOOR` of its magnitude; a state
identically zero gets :data:`SIZE_FLOOR` of the largest magnitude (1 when every state is zero).
"""

from __future__ import annotations

import numpy as np

__all__ = ["SIZE_FLOOR", "project", "relative_distances", "sample_scale", "state_scale"]

#: Smallest scale of a state, relative to its magnitude along the attractor.
SIZE_FLOOR = 1e-3


def state_scale(minimum: np.ndarray, maximum: np.ndarray) -> np.ndarray:
    """Each state's unit of distance along an attractor (module docstring).

    Parameters
    ----------
    minimum, maximum
        Each state's least and largest value along it.

    Returns
    -------
    ndarray
        ``max(maximum - minimum, SIZE_FLOOR * magnitude)``, positive.
    """
    lo, hi = np.asarray(minimum, float), np.asarray(maximum, float)
    mag = np.maximum(np.abs(lo), np.abs(hi))
    s = np.maximum(hi - lo, SIZE_FLOOR * mag)
    top = float(np.max(mag)) if mag.size else 0.0
    return np.where(s > 0, s, SIZE_FLOOR * top if top > 0 else 1.0)


def sample_scale(samples: np.ndarray) -> np.ndarray:
    """:func:`state_scale` of samples along an attractor, shape (n, nx)."""
    Y = np.asarray(samples, float)
    return state_scale(Y.min(axis=0), Y.max(axis=0))


def project(d: np.ndarray, V: np.ndarray | None) -> np.ndarray:
    """``d`` (a vector or rows of vectors) without its components along the rigid-body directions ``V``."""
    if V is None:
        return d
    D = np.atleast_2d(d)
    out = D - (V @ np.linalg.lstsq(V, D.T, rcond=None)[0]).T
    return out if np.ndim(d) > 1 else out[0]


def relative_distances(X: np.ndarray, points: np.ndarray, inv_scale: np.ndarray, V: np.ndarray | None = None
                       ) -> np.ndarray:
    """Distances of states to Poincare points in units of the scale (module docstring).

    Parameters
    ----------
    X
        States, shape (m, nx) (or one state).
    points
        Poincare points, shape (K, nx).
    inv_scale
        ``1 / scale``, shape (nx,) or (K, nx) (one scale per point).
    V
        Rigid-body directions projected out of the differences, or ``None``.

    Returns
    -------
    ndarray, shape (m, K)
        ``max_i |X_i - P_i| / scale_i``.
    """
    X2 = np.atleast_2d(np.asarray(X, float))
    P = np.asarray(points, float)
    D = X2[:, None, :] - P[None, :, :]
    if V is not None:
        D = project(D.reshape(-1, D.shape[2]), V).reshape(D.shape)
    return np.max(np.abs(D) * np.asarray(inv_scale, float), axis=2)
