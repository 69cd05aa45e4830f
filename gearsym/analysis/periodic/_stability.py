"""One stability rule for periodic orbits: trivial multipliers, tolerance, verdict.

Every analysis that judges an orbit (``orbit``, ``continue``, ``map`` and the Python
API) calls :func:`floquet`:

1. **Trivial multipliers.**  A model that keeps rigid-body modes (a free gear train
   in absolute rotations; :mod:`gearsym.symbolic.rigid`) has, for each mode ``r``, the
   invariant state subspace ``V = span{[r; 0], [0; r]}`` on which the monodromy is the
   Jordan block ``[[1, T], [0, 1]]`` (a shift of the rigid coordinate stays a shift; a
   rigid velocity adds ``T`` times itself).  ``numpy.linalg.eigvals`` smears such a
   block into ``1 +- 3.5e-7j`` (the square root of the rounding error), which a plain
   ``max |mu| < 1`` calls unstable.  Instead, with ``Q = [Q_V, Q_W]`` an orthonormal
   basis whose first columns span ``V``, ``Q^T M Q`` is block upper triangular (its
   lower-left block is the *invariance defect*, zero up to the integration error);
   the eigenvalues of the ``V`` block are the **trivial multipliers** (reported apart),
   those of the ``W`` block -- the monodromy of the quotient by the rigid-body motion,
   i.e. of the relative coordinates -- are the **multipliers** the verdict is based on.
   They equal the multipliers of the same model reduced to its deflections.

2. **Tolerance.**  The monodromy comes from an integration with relative tolerance
   ``rtol``.  It is first balanced (``scipy.linalg.matrix_balance``: a diagonal
   similarity, so that the rule does not depend on the units of the states: m, rad,
   m/s); the absolute error of the balanced ``M`` is estimated as

       delta = C * max(rtol, eps) * max(1, ||M||_2),      C = 100

   (the global error of the variational equations is one to two orders above the
   local tolerance; measured on the Mathieu equation, tests/test_stability.py).  A
   simple multiplier ``mu_i`` with eigenvalue condition number
   ``kappa_i = |y_i| |x_i| / |y_i^H x_i|`` (left / right eigenvectors) moves by at most
   about ``kappa_i * delta``; a multiple, defective one by about
   ``sqrt(delta * max(1, ||M||_2))``.  Its tolerance is

       tol_i = max(min(kappa_i * delta, sqrt(delta * max(1, ||M||_2))), 16 eps).

3. **Verdict.**  ``"unstable"`` if some ``|mu_i| > 1 + tol_i``; else ``"neutral"`` if
   some ``|mu_i| >= 1 - tol_i`` (on the unit circle within the monodromy's error:
   conservative systems, the stable intervals of the Mathieu equation); else
   ``"asymptotically_stable"``.  ``stable`` is ``stability != "unstable"``.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ERROR_FACTOR", "STABILITY", "FloquetResult", "balance", "complex_sides", "floquet", "multiplier_tolerances", "norm2",
           "neutral_step_limit", "rigid_state_basis", "split_trivial", "verdict"]

#: The three verdicts.
STABILITY = ("asymptotically_stable", "neutral", "unstable")
#: ``C`` of the monodromy error estimate ``delta = C * rtol * max(1, ||M||)``.
ERROR_FACTOR = 100.0
_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class FloquetResult:
    """Multipliers of a monodromy, split and judged by the stability rule.

    Attributes
    ----------
    multipliers : ndarray (complex)
        The non-trivial multipliers, by decreasing modulus.
    trivial : ndarray (complex)
        The multipliers of the rigid-body subspace (two per rigid-body mode, at +1).
    tolerances : ndarray
        Tolerance of each non-trivial multiplier (same order).
    stability : str
        ``"asymptotically_stable"``, ``"neutral"`` or ``"unstable"``.
    stable : bool
        ``stability != "unstable"``.
    n_unstable : int
        Multipliers outside the circle beyond their tolerance.
    n_neutral : int
        Multipliers on the circle within their tolerance.
    monodromy_error : float
        ``delta``, the estimated absolute error of the monodromy.
    invariance_defect : float
        ``||Q_W^T M Q_V|| / max(1, ||M||)`` (0 without rigid-body modes).
    info : dict
        ``"rigid_split"``: ``"ok"``, ``"none"`` (no rigid-body modes) or why it was not done.
    """

    multipliers: np.ndarray
    trivial: np.ndarray
    tolerances: np.ndarray
    stability: str
    stable: bool
    n_unstable: int
    n_neutral: int
    monodromy_error: float
    invariance_defect: float = 0.0
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def max_multiplier(self) -> float:
        """``max |mu|`` of the non-trivial multipliers (NaN if there are none)."""
        return float(np.max(np.abs(self.multipliers))) if len(self.multipliers) else math.nan

    def status(self) -> np.ndarray:
        """Per multiplier: -1 inside the circle, 0 neutral, +1 outside (beyond the tolerances)."""
        a = np.abs(self.multipliers)
        return np.where(a > 1 + self.tolerances, 1, np.where(a >= 1 - self.tolerances, 0, -1))


def _finite(a: np.ndarray) -> bool:
    """Whether every entry of the real array ``a`` is finite (on Python floats for a small one:
    numpy's per-call cost is several times the work there)."""
    if a.size <= 1024:
        return all(map(math.isfinite, a.ravel().tolist()))
    return bool(np.isfinite(a).all())


def _sort(mu: np.ndarray, *others: np.ndarray) -> tuple[np.ndarray, ...]:
    order = np.lexsort((-mu.imag, -np.abs(mu)))
    return (mu[order],) + tuple(o[order] for o in others)


def rigid_state_basis(system: CompiledSystem, params: Mapping[str, float] | None = None) -> np.ndarray | None:
    """``[[R, 0], [0, R]]``: the rigid-body subspace of the state at these parameters.

    ``None`` when the compiled model has no rigid-body modes (``gs_rigid`` absent) or its
    states are not ``coordinates + velocities``.
    """
    gen = system.generated
    if not getattr(gen, "rigid_modes", None) or "gs_rigid" not in gen.functions:
        return None
    R = np.asarray(system.generated_map("gs_rigid", 1)(system.param_vector(params)), float)
    nq, k = R.shape
    if 2 * nq != gen.nx or k == 0 or not np.all(np.isfinite(R)):
        return None
    V = np.zeros((gen.nx, 2 * k))
    V[:nq, :k] = R
    V[nq:, k:] = R
    return V


def rigid_anchor_rows(V: np.ndarray, n: int, index: Sequence[int]) -> np.ndarray:
    """The anchor rows of a Newton step on a model with rigid-body modes: one row per mode that
    pins its coordinates (the unit columns of the coordinate block of ``V``,
    :func:`rigid_state_basis`), placed on the unknowns ``index`` (one per state) among ``n``.

    Without them the Newton matrix is singular along the rigid-body shift (a Jordan block of the
    monodromy at +1); with them the step is the least-squares solution that keeps the rigid
    coordinates where they are (THE Newton iteration, ``gearsym/engine/gs_newton.c``).  Used by
    shooting and by the continuation's problems.

    Returns
    -------
    ndarray, shape (k, n)
    """
    k = V.shape[1] // 2
    Pq = V[:, :k] / np.linalg.norm(V[:, :k], axis=0)
    out = np.zeros((k, int(n)))
    for j, i in enumerate(index):
        out[:, i] = Pq[j]
    return out


def split_trivial(M: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Split a monodromy along its invariant rigid-body subspace ``span(V)``.

    Returns
    -------
    quotient : ndarray
        The monodromy on the complement (``Q_W^T M Q_W``): its eigenvalues are the
        non-trivial multipliers.
    trivial : ndarray (complex)
        Eigenvalues of the ``V`` block.
    defect : float
        ``||Q_W^T M Q_V||_2 / max(1, ||M||_2)`` (0 for an exactly invariant ``V``).
    """
    M = np.asarray(M, float)
    Q, _ = np.linalg.qr(np.asarray(V, float), mode="complete")
    r = int(np.linalg.matrix_rank(V))
    B = Q.T @ M @ Q
    defect = norm2(B[r:, :r]) / max(1.0, norm2(M)) if r else 0.0
    return B[r:, r:], np.linalg.eigvals(B[:r, :r]).astype(complex), defect


def balance(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(D^-1 M D, diag(D))``: LAPACK's balancing without permutations (``dgebal``, as
    ``scipy.linalg.matrix_balance(M, permute=False)`` but without its per-call overhead,
    which was most of the cost of a small matrix's multipliers)."""
    from scipy.linalg import lapack

    M = np.asarray(M, float)
    if M.size and _finite(M):
        Mb, _, _, scale, info = lapack.dgebal(M, permute=0, scale=1)
        if info == 0:
            return np.asarray(Mb, float), np.asarray(scale, float)
    import scipy.linalg

    Mb, (scale, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    return Mb, scale


def norm2(M: np.ndarray) -> float:
    """The 2-norm (largest singular value) of ``M`` (0 for an empty matrix)."""
    M = np.asarray(M, float)
    if M.size == 0:
        return 0.0
    if M.ndim == 2 and M.dtype == np.float64:
        from scipy.linalg import lapack

        _, sv, _, info = lapack.dgesdd(M, compute_uv=0)
        if info == 0:
            return float(sv[0])
    return float(np.linalg.svd(M, compute_uv=False)[0])


#: Up to this many multipliers the verdict and the test functions work on Python floats: numpy's
#: per-call cost (microseconds per operation) was nine tenths of a small monodromy's stability rule.
SMALL = 32


def _eig_kappa(M: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenvalues of a real square ``M`` and their condition numbers ``kappa_i = 1 / |y_i^H x_i|``
    (unit left / right eigenvectors) from one LAPACK ``dgeev`` call; ``None`` if it fails.

    ``dgeev`` stores a complex pair's vectors as two real columns ``a +- i b`` (each of unit
    norm as a complex vector), so ``y^H x = (a_l . a_r + b_l . b_r) + i (a_l . b_r - b_l . a_r)``.
    """
    from scipy.linalg import lapack

    wr, wi, vl, vr, info = lapack.dgeev(M, compute_vl=1, compute_vr=1)
    if info != 0:
        return None
    den = np.abs((vl * vr).sum(axis=0))
    first = np.flatnonzero(wi > 0)  # a complex pair: columns j (positive imaginary part) and j + 1
    first = first[first + 1 < len(wr)]
    if len(first):
        a_l, b_l, a_r, b_r = vl[:, first], vl[:, first + 1], vr[:, first], vr[:, first + 1]
        d = np.hypot((a_l * a_r + b_l * b_r).sum(axis=0), (a_l * b_r - b_l * a_r).sum(axis=0))
        den[first] = d
        den[first + 1] = d
    kappa = np.full(len(wr), np.inf)
    nz = den > 0
    kappa[nz] = 1.0 / den[nz]
    return wr + 1j * wi, kappa


def multiplier_tolerances(M: np.ndarray, rtol: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Eigenvalues of ``M`` and their tolerances (module docstring, rule 2).

    Returns
    -------
    mu : ndarray (complex)
        Eigenvalues (unsorted, as ``scipy.linalg.eig`` returns them).
    tol : ndarray
        Tolerance of each.
    delta : float
        The estimated absolute error of ``M``.
    """
    M = np.asarray(M, float)
    if M.size == 0:
        return np.zeros(0, complex), np.zeros(0), ERROR_FACTOR * max(float(rtol), _EPS)
    # states in different units (m, rad, m/s) make the norm and the eigenvector angles
    # depend on the units: balance first (a diagonal similarity, same eigenvalues)
    M = balance(M)[0]
    nM = norm2(M)
    delta = ERROR_FACTOR * max(float(rtol), _EPS) * max(1.0, nM)
    ek = _eig_kappa(M)
    if ek is not None:
        mu, kappa = ek
    else:
        import scipy.linalg

        mu, vl, vr = scipy.linalg.eig(M, left=True, right=True)
        den = np.abs(np.sum(np.conj(vl) * vr, axis=0))
        num = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            kappa = np.where(den > 0, num / den, np.inf)
    cap = math.sqrt(delta * max(1.0, nM))
    tol = np.maximum(np.minimum(kappa * delta, cap), 16 * _EPS)
    return np.asarray(mu, complex), tol, delta


def floquet(monodromy: np.ndarray | None, rtol: float, basis: np.ndarray | None = None) -> FloquetResult:
    """The stability rule (module docstring): split, tolerances, verdict.

    Parameters
    ----------
    monodromy
        The monodromy matrix.
    rtol
        Relative tolerance of the integration it came from (the error estimate).
    basis
        The rigid-body subspace of the state (:func:`rigid_state_basis`), or ``None``.

    Returns
    -------
    FloquetResult
        Without a (finite) monodromy: no verdict, ``stability = "unknown"``, ``stable`` False.
    """
    M = None if monodromy is None else np.asarray(monodromy, float)
    if M is None or M.size == 0:
        return FloquetResult(np.zeros(0, complex), np.zeros(0, complex), np.zeros(0), "unknown", False, 0, 0,
                             math.nan, 0.0, {"rigid_split": "none"})
    if not _finite(M):
        nan = np.full(M.shape[0], complex(math.nan, math.nan))
        return FloquetResult(nan, np.zeros(0, complex), np.full(M.shape[0], math.nan), "unknown", False, 0, 0,
                             math.nan, math.nan, {"rigid_split": "non-finite monodromy"})
    trivial = np.zeros(0, complex)
    defect = 0.0
    info: dict[str, Any] = {"rigid_split": "none"}
    Mq = M
    if basis is not None and basis.shape[0] == M.shape[0] and basis.shape[1]:
        # in balanced variables (x = D y), where the subspace is span(D^-1 V)
        Mb, scale = balance(M)
        quot, triv, defect = split_trivial(Mb, np.asarray(basis, float) / scale[:, None])
        limit = max(1e-6, 1e3 * ERROR_FACTOR * max(float(rtol), _EPS))
        if defect <= limit:
            Mq, trivial = quot, triv
            info["rigid_split"] = "ok"
        else:
            info["rigid_split"] = (f"not done: the rigid-body subspace is not invariant under the monodromy "
                                   f"(defect {defect:.3g} > {limit:.3g})")
    mu, tol, delta = multiplier_tolerances(Mq, rtol)
    return verdict(mu, tol, delta, trivial, defect, info)


def verdict(mu: np.ndarray, tol: np.ndarray, delta: float, trivial: np.ndarray | None = None,
            defect: float = 0.0, info: dict[str, Any] | None = None) -> FloquetResult:
    """Rule 3 on multipliers and tolerances (:func:`multiplier_tolerances`' outputs, or the same
    computed by the driver): sorted by decreasing modulus, counted, judged."""
    trivial = np.zeros(0, complex) if trivial is None else trivial
    info = {"rigid_split": "none"} if info is None else info
    if len(mu) <= SMALL and all(map(cmath.isfinite, mu.tolist())):
        # as _sort and the counts below, on Python numbers (a stable sort by -|mu|, then -Im mu)
        ml, tl = mu.tolist(), tol.tolist()
        order = sorted(range(len(ml)), key=lambda i: (-abs(ml[i]), -ml[i].imag))
        mu, tol = np.array([ml[i] for i in order], complex), np.array([tl[i] for i in order])
        n_unst = n_neut = 0
        for m, t in zip(ml, tl):
            a = abs(m)
            n_unst += a > 1 + t
            n_neut += 1 - t <= a <= 1 + t
    else:
        mu, tol = _sort(mu, tol)
        a = np.abs(mu)
        n_unst = int(np.sum(a > 1 + tol))
        n_neut = int(np.sum((a <= 1 + tol) & (a >= 1 - tol)))
    stability = "unstable" if n_unst else ("neutral" if n_neut else "asymptotically_stable")
    trivial = _sort(trivial)[0] if len(trivial) else trivial
    return FloquetResult(mu, trivial, tol, stability, stability != "unstable", n_unst, n_neut, delta, defect,
                         info)


# ------------------------------------------------ continuation along neutral branches
def complex_sides(point: Any) -> tuple[int, int]:
    """Complex (non-real) multipliers of a branch point inside / outside the circle beyond their
    tolerances: a Neimark-Sacker point is only where these counts change (pairs sitting on
    the circle of a conservative branch flip the sign of its test function by noise)."""
    mu = np.asarray(point.multipliers, complex)
    tol = np.asarray(point.multiplier_tolerances, float)
    if len(tol) != len(mu):
        tol = np.zeros(len(mu))
    if len(mu) <= SMALL:  # Python arithmetic (numpy's per-call cost dominates for a few multipliers)
        inside = outside = 0
        for m, t in zip(mu.tolist(), tol.tolist()):
            a = abs(m)
            if abs(m.imag) > 1e-9 * max(1.0, a):
                inside += a < 1 - t
                outside += a > 1 + t
        return inside, outside
    cplx = np.abs(mu.imag) > 1e-9 * np.maximum(1.0, np.abs(mu))
    a = np.abs(mu)
    return int(np.sum(cplx & (a < 1 - tol))), int(np.sum(cplx & (a > 1 + tol)))


def neutral_step_limit(A: Any, B: Any, h: float, h_used: float, ds_min: float) -> float:
    """Limit the next step where multipliers sit on the unit circle (a conservative branch).

    There a whole instability tongue (a pair meeting at +1 or -1, leaving the circle as
    a real pair and coming back) can hide inside one step, with the same multipliers at
    both ends.  For every neutral multiplier of ``B`` that moved in the last step (more
    than a thousand times its tolerance), the next step is at most half of what its last
    rate predicts for reaching +1 or -1: far from a tongue that halves the distance to
    it per step, and near its edge, where the pair moves like the square root of the
    distance, the step overshoots the edge by a fraction of the distance left and lands
    inside the tongue (measured on the Mathieu equation: tongues 0.03 wide are found).
    """
    if B.stability != "neutral":
        return h
    ma, mb = np.asarray(A.multipliers, complex), np.asarray(B.multipliers, complex)
    tol = np.asarray(B.multiplier_tolerances, float)
    if not len(ma) or len(tol) != len(mb) or h_used <= 0:
        return h
    for i, m in enumerate(mb):
        if abs(abs(m) - 1.0) > tol[i]:
            continue
        moved = float(np.min(np.abs(ma - m)))
        if not math.isfinite(moved) or moved <= 1e3 * tol[i]:
            continue
        dist = min(abs(m - 1.0), abs(m + 1.0))
        h = min(h, 0.5 * dist * h_used / moved)
    return max(h, ds_min)
