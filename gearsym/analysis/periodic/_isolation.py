"""Is a periodic orbit isolated?  A Floquet multiplier at +1 to working precision.

Newton on the periodic-orbit residual ``phi(P, x0) - x0`` needs ``M - I`` (``M`` the
monodromy) to be invertible.  When a multiplier sits at +1 *within the accuracy of the
computed monodromy*, ``M - I`` is singular to working precision and a Newton step along
its null direction is noise divided by noise: the undamped oscillator at exact
resonance (``x'' + x = F cos t``) has no periodic orbit at all, yet plain Newton
"converges" to ``x0 ~ 1e9`` -- the resonant orbit of the integrator's own numerical
damping.  This module gives the two tools that keep the solvers honest:

* :func:`isolation`: the smallest singular value ``sigma`` of ``M - I`` in scaled
  variables (each state by its magnitude on the orbit), outside the *trivial*
  directions (a known null space, e.g. the rigid-body mode of a semi-definite gear
  train: ``trivial`` takes those directions in state space; default none), compared
  with :func:`monodromy_error`;
* :func:`truncated_solve`: the Newton step as the minimum-norm least-squares solution
  with the singular values below that error level dropped, so that a step never
  moves the state along a direction the monodromy cannot resolve.

The error model of the monodromy (measured against exact monodromies, the undamped
oscillator's identity and the Meissner equation's matrix exponentials, rtol 1e-6 .. 1e-13;
pinned by ``tests/test_honest_results.py``): the variational equations integrated at
relative tolerance ``rtol`` give ``M`` with an error of 0.3 to 22 ``max(rtol, 1e-12)``
relative to ``max(1, |M|)`` (rounding sets the floor near 1e-12); the threshold is 100
times ``max(rtol, 1e-12) * max(1, |M|_2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["ERROR_FACTOR", "Isolation", "isolation", "monodromy_error", "truncated_solve"]

#: Safety factor of :func:`monodromy_error` over the integrator's relative tolerance.
ERROR_FACTOR = 100.0
#: Floor of the relative tolerance in the error model (rounding in the variational equations).
RTOL_FLOOR = 1e-12


def monodromy_error(norm: float, rtol: float) -> float:
    """Error level below which a singular value of (scaled) ``M - I`` is indistinguishable from 0.

    ``ERROR_FACTOR * max(rtol, RTOL_FLOOR) * max(1, norm)`` with ``norm`` the 2-norm of the
    scaled monodromy (or Newton matrix).
    """
    r = rtol if math.isfinite(rtol) and rtol > 0 else 1e-8
    return ERROR_FACTOR * max(r, RTOL_FLOOR) * max(1.0, float(norm))


@dataclass(frozen=True)
class Isolation:
    """Verdict of :func:`isolation`.

    Attributes
    ----------
    sigma : float
        Smallest singular value of the scaled ``M - I`` outside the trivial directions.
    threshold : float
        The monodromy's error level (:func:`monodromy_error`).
    isolated : bool
        ``sigma > threshold``: no multiplier at +1 to working precision (outside the
        trivial directions).
    direction : ndarray
        Right singular vector of ``sigma`` in state space (unscaled, unit 2-norm of the
        scaled vector): the direction along which the orbit is not determined.
    n_trivial : int
        Number of trivial directions excluded.
    """

    sigma: float
    threshold: float
    isolated: bool
    direction: np.ndarray = field(repr=False)
    n_trivial: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {"isolated": bool(self.isolated), "sigma_min": float(self.sigma),
                "threshold": float(self.threshold), "n_trivial": int(self.n_trivial)}

    def reason(self) -> str:
        """One line for error messages (empty when isolated)."""
        if self.isolated:
            return ""
        return ("no isolated periodic orbit: a Floquet multiplier at +1 to the accuracy of the monodromy "
                f"(smallest singular value of M - I {self.sigma:.2g} <= its error level {self.threshold:.2g}; "
                "resonance of an undamped system?)")


def _complement(V: np.ndarray, n: int) -> np.ndarray:
    """Orthonormal basis of the orthogonal complement of the columns of ``V`` (n x k)."""
    if V.size == 0:
        return np.eye(n)
    U, s, _ = np.linalg.svd(V, full_matrices=True)
    rank = int(np.sum(s > 1e-12 * max(1.0, float(s[0]))))
    return U[:, rank:]


def isolation(monodromy: np.ndarray, scale: np.ndarray | None, rtol: float,
              trivial: np.ndarray | None = None) -> Isolation:
    """Whether a periodic orbit with this monodromy is isolated to working precision.

    Parameters
    ----------
    monodromy
        ``M`` (nx x nx).
    scale
        Magnitude of each state on the orbit (the scaling ``D``: ``M_s = D^-1 M D``);
        ``None``: unscaled.
    rtol
        Relative tolerance the monodromy was integrated with.
    trivial
        Known trivial directions in state space (nx x k, or a list of k vectors), e.g. the
        rigid-body mode of a semi-definite model: singular directions of ``M - I`` inside
        their span are expected and not held against the orbit.  Default: none.

    Returns
    -------
    Isolation
    """
    M = np.asarray(monodromy, float)
    n = M.shape[0]
    d = np.ones(n) if scale is None else np.asarray(scale, float)
    d = np.where(np.isfinite(d) & (d > 0), d, 1.0)
    Ms = M * d[None, :] / d[:, None]
    A = Ms - np.eye(n)
    V = np.zeros((n, 0))
    if trivial is not None:
        V = np.asarray(trivial, float)
        if V.ndim == 1:
            V = V[:, None]
        elif V.shape[0] != n:
            V = V.T
        V = V / d[:, None]
    Q = _complement(V, n)
    threshold = monodromy_error(float(np.linalg.svd(Ms, compute_uv=False)[0]) if n and np.all(np.isfinite(Ms))
                                else (0.0 if not n else math.inf), rtol)
    if Q.shape[1] == 0:
        return Isolation(math.inf, threshold, True, np.zeros(n), V.shape[1])
    if not np.all(np.isfinite(A)):
        return Isolation(math.nan, threshold, False, np.zeros(n), V.shape[1])
    _, s, Vt = np.linalg.svd(A @ Q)
    sigma = float(s[-1])
    direction = d * (Q @ Vt[-1])
    return Isolation(sigma, threshold, bool(sigma > threshold), direction, V.shape[1])


def truncated_solve(J: np.ndarray, rhs: np.ndarray, scale: np.ndarray, rtol: float
                    ) -> tuple[np.ndarray, int]:
    """Newton step ``J dz = rhs`` without the directions ``J`` cannot resolve.

    In scaled variables (``J_s = D^-1 J D``, ``D = diag(scale)``) the singular values of
    ``J_s`` below :func:`monodromy_error` of ``|J_s|`` are dropped (minimum-norm least
    squares); a well-conditioned ``J`` gives the plain Newton step.

    Returns
    -------
    (step, n_dropped)
        The step (unscaled) and the number of singular values dropped.
    """
    d = np.asarray(scale, float)
    d = np.where(np.isfinite(d) & (d > 0), d, 1.0)
    Js = J * d[None, :] / d[:, None]
    b = rhs / d
    if not (np.all(np.isfinite(Js)) and np.all(np.isfinite(b))):
        return np.full_like(rhs, np.nan), 0
    U, s, Vt = np.linalg.svd(Js)
    thr = monodromy_error(float(s[0]) if s.size else 0.0, rtol)
    keep = s > thr
    c = (U.T @ b)[keep] / s[keep]
    return d * (Vt[keep].T @ c), int(np.sum(~keep))
