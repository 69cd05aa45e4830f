"""Minimally augmented systems of the bifurcations of periodic orbits (fold, branch point, period doubling).

A bifurcation curve in two parameters ``lambda = (lambda_1, lambda_2)`` is the solution set of
the shooting residual ``F(x0, lambda) = phi(t0 + P(lambda), t0, x0; lambda) - x0 = 0`` together
with one scalar test function that vanishes at the bifurcation (Govaerts 2000; Kuznetsov,
*Elements of Applied Bifurcation Theory*; the formulation of BifurcationKit's
``MinAugFold`` / ``MinAugPD``): with ``A`` the matrix that is singular there (``M - I`` at a fold,
``M + I`` at a period doubling, ``M`` the monodromy with saltation) and two border vectors
``b``, ``c``,

    [[A, b], [c^T, 0]] [v; g] = [0; 1]          g(x0, lambda) = 0  <=>  A singular.

``g`` (divided by ``max(1, |M|)``: the integration's error in it is about ``rtol |M|``) is
smooth where the bordered matrix is regular (``b`` not in the range of ``A``, ``c`` not
orthogonal to its kernel: the borders are the left and right null vectors of the last accepted
point, updated after every point; ``g = 0`` does not depend on them).

**Derivatives of g.**  ``dg = -w^T (dA) v`` with ``w`` from the adjoint bordered system.  The
engine gives no second derivative of the flow, so ``dA = dM`` is a central difference of the
monodromy, taken in the form that costs the fewest integrations: the derivative of ``g`` in the
state is the directional derivative ``-D_v (M^T w)`` (``d M_ij / d x_k`` is symmetric in ``j, k``:
two integrations along ``v`` give every component, BifurcationKit's trick); in each parameter two
integrations.  So one row of the Jacobian costs 2 + 4 integrations with the monodromy, with the
relative step ``rtol^(1/3)`` (:func:`~gearsym.analysis.continuation._orbit_map.fd_step`): error
about ``rtol^(2/3)`` relative (2e-7 at ``rtol`` 1e-10).  That error only slows Newton; the
curve itself is where ``g`` (computed from the monodromy, error ~ ``rtol``) vanishes.  The
rows of ``F`` are exact: ``M - I`` and the engine's parameter sensitivities.

**Branch points** (a multiplier +1 on an orbit that persists through it: the trivial orbit
``x = 0`` of the Mathieu equation at its characteristic values ``a_m`` with ``m`` even, a
symmetric orbit at a pitchfork): there ``F_lambda`` lies in the range of ``F_x``, the fold
system above is singular.  The curve is continued as the singularity of the extended Jacobian
``E = [M - I, S_k]`` (``S_k = dF/dlambda_k``, ``n x (n+1)``) -- a two-dimensional kernel, two test
functions ``g_1, g_2`` from ``[[E, B], [C^T, 0]] [V; G] = [0; I_2]`` -- with the unfolding
``F + mu B = 0`` (``mu`` an extra unknown, zero on the curve) that makes the system regular
(as for branch points of systems with a symmetry: Govaerts, *Numerical Methods for Bifurcations of
Dynamical Equilibria*, 2000).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import ConvergenceError
from ._bifurcation import tau_branch_point, tau_period_doubling
from ._orbit_map import MapRun, OrbitMap

__all__ = ["SECTION_MARGIN", "AugEval", "Augmented", "BorderedSingular", "BranchPointSystem", "bordered"]

#: an event closer to the shooting section than this fraction of the period moves the section
SECTION_MARGIN = 0.02


@dataclass
class AugEval:
    """One evaluation of an augmented system at ``y`` (a work record of the tracer).

    Attributes
    ----------
    R : ndarray
        The residual (the orbit's rows, then the test functions).
    J_orbit : ndarray
        The exact rows of the orbit's equations.
    J_test : ndarray or None
        The rows of the test functions (finite differences; ``None`` when not asked for).
    M : ndarray
        The monodromy of the orbit.
    data : dict
        What the system keeps of the evaluation (null vectors, the split of the period).
    """

    R: np.ndarray
    J_orbit: np.ndarray
    J_test: np.ndarray | None
    M: np.ndarray
    data: dict[str, Any] = field(default_factory=dict)


def bordered(A: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(V, G, w)`` of ``[[A, b], [c^H, 0]] [V; G] = [0; I_k]`` and its adjoint ``[[A^H, c], [b^H, 0]] [w; h] = [0; 1]``.

    ``A`` is ``n x m`` (``m = n``, or ``n + 1`` for the extended Jacobian of a branch point), ``b``
    one column of ``n`` entries, ``c`` has ``k = n + 1 - m`` columns of ``m`` entries; ``V`` is
    ``(m, k)``, ``G`` ``(1, k)`` (the test functions) and ``w`` ``(n,)``.  Real or complex.

    Raises
    ------
    BorderedSingular
        The bordered matrix is singular (the borders lost the null vectors).
    """
    n, m = A.shape
    b = b.reshape(n, -1)
    c = c.reshape(m, -1)
    k = c.shape[1]
    K = np.zeros((n + k, m + b.shape[1]), dtype=np.result_type(A, b, c))
    K[:n, :m], K[:n, m:], K[n:, :m] = A, b, c.conj().T
    rhs = np.zeros((K.shape[0], k), dtype=K.dtype)
    rhs[n:, :] = np.eye(k)
    rhs_adj = np.zeros(K.shape[0], dtype=K.dtype)
    rhs_adj[m:] = 1.0
    try:
        sol = np.linalg.solve(K, rhs)
        adj = np.linalg.solve(K.conj().T, rhs_adj)
    except np.linalg.LinAlgError:
        raise BorderedSingular("the bordered matrix of the test function is singular") from None
    if not (np.all(np.isfinite(sol)) and np.all(np.isfinite(adj))):
        raise BorderedSingular("the bordered matrix of the test function is singular")
    return sol[:m, :], sol[m:, :], adj[:n]


class BorderedSingular(ConvergenceError):
    """The bordered matrix of a test function is singular (the borders must be renewed)."""


def null_vectors(A: np.ndarray, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The right and left singular vectors of the ``k`` smallest singular values of ``A``."""
    U, _, Vh = np.linalg.svd(A)
    return Vh[-k:, :].conj().T, U[:, -k:]


class Augmented:
    """A minimally augmented system ``G(y) = 0``, ``y = (x0, lambda_1, lambda_2, extras...)``.

    Subclasses define the test functions (:meth:`_test`, :meth:`_test_rows`), the extras and
    the codimension-2 test functions along the curve (:meth:`tests`).
    """

    kind = ""
    #: names of the extra unknowns (after the two parameters)
    extras: tuple[str, ...] = ()

    def __init__(self, omap: OrbitMap, fd: float):
        self.omap = omap
        self.nx = omap.nx
        self.fd = float(fd)
        self.x_scale = np.ones(self.nx)
        self.lam_scale = np.ones(2)

    @property
    def n(self) -> int:
        """Number of unknowns."""
        return self.nx + 2 + len(self.extras)

    def set_scales(self, x_scale: np.ndarray, lam_scale: np.ndarray) -> None:
        """The magnitudes of the states and the parameters (the differences' steps follow them)."""
        self.x_scale = np.maximum(np.asarray(x_scale, float), 1e-300)
        self.lam_scale = np.asarray(lam_scale, float)

    def extra_scales(self) -> np.ndarray:
        """Magnitudes of the extra unknowns."""
        return np.ones(len(self.extras))

    def residual_scales(self) -> np.ndarray:
        """Magnitudes of the residual's rows (the state's, then 1 for each test function)."""
        return np.concatenate([self.x_scale, np.ones(self.n - 1 - self.nx)])

    def split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x0, lambda, extras)`` of ``y``."""
        y = np.asarray(y, float)
        return y[:self.nx], y[self.nx:self.nx + 2], y[self.nx + 2:]

    # ---------------------------------------------------------------- evaluation
    def evaluate(self, y: np.ndarray, test_jac: bool) -> AugEval:
        """The residual, the exact rows of the orbit and (``test_jac``) the rows of the test functions."""
        x, lam, ext = self.split(y)
        run = self.omap.run(x, lam)
        F, Jo = self._orbit_rows(x, lam, ext, run)
        data: dict[str, Any] = {"x_end": run.x_end, "n_events": run.n_events, "S": run.S, "event_t": run.event_t,
                                "event_surface": run.event_surface, "t0": self.omap.t0}
        # relative to the size of the monodromy (the integration's error in the test functions is
        # about rtol |M|: strongly unstable orbits have large monodromies); exact where g = 0
        size = max(1.0, float(np.linalg.norm(run.M)))
        gvals = self._test(run.M, x, lam, ext, data) / size
        Jt = self._test_rows(run.M, x, lam, ext, data) / size if test_jac else None
        return AugEval(np.concatenate([F, gvals]), Jo, Jt, run.M, data)

    def _orbit_rows(self, x: np.ndarray, lam: np.ndarray, ext: np.ndarray, run: MapRun
                    ) -> tuple[np.ndarray, np.ndarray]:
        """``F = x_end - x0`` and its exact rows ``[M - I, S, 0]``."""
        J = np.zeros((self.nx, self.n))
        J[:, :self.nx] = run.M - np.eye(self.nx)
        J[:, self.nx:self.nx + 2] = run.S
        return run.x_end - x, J

    def _test(self, M: np.ndarray, x: np.ndarray, lam: np.ndarray, ext: np.ndarray, data: dict) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover

    def _test_rows(self, M: np.ndarray, x: np.ndarray, lam: np.ndarray, ext: np.ndarray, data: dict) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover

    def start(self, y: np.ndarray) -> np.ndarray:
        """Prepare the test functions at a first guess (borders from the null vectors); the guess
        (with the extras' first values filled in)."""
        raise NotImplementedError  # pragma: no cover

    def accept(self, y: np.ndarray, ev: AugEval) -> None:
        """Renew the borders at an accepted point (the solution set does not change)."""

    def tests(self, y: np.ndarray, ev: AugEval, multipliers: np.ndarray) -> dict[str, float]:
        """The codimension-2 test functions at an accepted point (sign changes mark special points)."""
        return {}

    def describe(self, y: np.ndarray, ev: AugEval) -> dict[str, float]:
        """The extras of a point for the result (``omega``, ``theta``, ``mu``, ...)."""
        _, _, ext = self.split(y)
        return {name: float(v) for name, v in zip(self.extras, ext, strict=True)}

    # ---------------------------------------------------------------- the section
    def reanchor(self, y: np.ndarray, ev: AugEval, margin: float = SECTION_MARGIN) -> np.ndarray | None:
        """Move the shooting section ``t0`` away from the orbit's events when one is within ``margin``
        of the period from it; the unknowns in the new section, or ``None`` (nothing moved).

        An event at the section makes the period map only once differentiable there (its Jacobian
        kinks when the event crosses ``t0``: the vector field's Jacobian jumps at a contact), so
        the test functions built on the monodromy kink and Newton crawls; the curve itself does
        not depend on the section.  The new section is the middle of the longest event-free part
        of the period; the state moves along the orbit to it and the borders with the state
        transition matrix of the shift (so that the orientation of the null vectors, which the
        signs of the test functions carry, is kept).
        """
        x, lam, ext = self.split(y)
        P, t0 = self.omap.period(lam), self.omap.t0
        te = np.sort(np.mod(np.asarray(ev.data.get("event_t", []), float) - t0, P))
        if len(te) == 0 or min(float(te[0]), P - float(te[-1])) >= margin * P:
            return None
        pts = np.concatenate([te, [te[0] + P]])
        k = int(np.argmax(np.diff(pts)))
        shift = float(0.5 * (pts[k] + pts[k + 1])) % P
        run = self.omap.run(x, lam, monodromy=True, sens=False, theta=(0.0, shift / P))
        self.omap.t0 = t0 + shift
        self.transform(run.M)
        return np.concatenate([run.x_end, lam, self.shift_extras(ext, shift / P)])

    def transform(self, Phi: np.ndarray) -> None:
        """Carry the borders to a section moved by the state transition matrix ``Phi``."""

    def shift_extras(self, ext: np.ndarray, dtheta: float) -> np.ndarray:
        """The extra unknowns in a section moved by ``dtheta`` of the period."""
        return ext

    # ---------------------------------------------------------------- differences
    def _x_step(self, d: np.ndarray) -> float:
        """The step along the state direction ``d`` (``fd`` of the state magnitudes)."""
        size = float(np.max(np.abs(d) / self.x_scale))
        return self.fd / size if size > 0 else self.fd

    def _lam_step(self, k: int) -> float:
        return self.fd * float(self.lam_scale[k])

    def _dir_deriv(self, fun, x: np.ndarray, lam: np.ndarray, dx: np.ndarray, dlam: np.ndarray) -> np.ndarray:
        """Central difference of ``fun(x, lam)`` along ``(dx, dlam)``."""
        scale = max(float(np.max(np.abs(dx) / self.x_scale)),
                    float(np.max(np.abs(dlam) / np.maximum(self.lam_scale, 1e-300))))
        h = self.fd / scale if scale > 0 else self.fd
        return (fun(x + h * dx, lam + h * dlam) - fun(x - h * dx, lam - h * dlam)) / (2 * h)


class BorderedSystem(Augmented):
    """Fold (``M - I`` singular) or period doubling (``M + I``): unknowns ``(x0, lambda_1, lambda_2)``."""

    def __init__(self, omap: OrbitMap, fd: float, kind: str):
        super().__init__(omap, fd)
        self.kind = kind
        self.shift = -1.0 if kind == "fold" else 1.0  # A = M + shift I
        self.b = np.zeros(self.nx)
        self.c = np.zeros(self.nx)

    def _A(self, M: np.ndarray) -> np.ndarray:
        return M + self.shift * np.eye(self.nx)

    def start(self, y: np.ndarray) -> np.ndarray:
        x, lam, _ = self.split(y)
        right, left = null_vectors(self._A(self.omap.monodromy(x, lam)))
        self.c, self.b = right[:, 0], left[:, 0]
        return np.asarray(y, float)

    def _test(self, M, x, lam, ext, data) -> np.ndarray:
        V, G, w = bordered(self._A(M), self.b, self.c)
        data["v"], data["w"] = V[:, 0], w
        return np.array([G[0, 0]])

    def _test_rows(self, M, x, lam, ext, data) -> np.ndarray:
        v, w = data["v"], data["w"]
        row = np.zeros(self.n)
        mono = self.omap.monodromy
        row[:self.nx] = -self._dir_deriv(lambda xx, ll: mono(xx, ll).T @ w, x, lam, v, np.zeros(2))
        for k in range(2):
            e = np.zeros(2)
            e[k] = 1.0
            row[self.nx + k] = -float(w @ self._dir_deriv(lambda xx, ll: mono(xx, ll) @ v, x, lam,
                                                           np.zeros(self.nx), e))
        return row[None, :]

    def accept(self, y, ev) -> None:
        v, w = ev.data["v"], ev.data["w"]
        self.c = v / np.linalg.norm(v)
        self.b = w / np.linalg.norm(w)

    def transform(self, Phi: np.ndarray) -> None:
        self.c, self.b = _carry(Phi, self.c, self.b)

    def tests(self, y, ev, multipliers) -> dict[str, float]:
        v, w = ev.data["v"], ev.data["w"]
        out = {"resonance": float(w @ v) / float(np.linalg.norm(w) * np.linalg.norm(v))}
        if self.kind == "fold":
            out["fold_flip"] = tau_period_doubling(_others(multipliers, 1.0))
            out["cusp"] = self._quadratic_coefficient(y, ev, v, w)
        else:
            out["fold_flip"] = tau_branch_point(_others(multipliers, -1.0))
        return out

    def _quadratic_coefficient(self, y, ev, v, w) -> float:
        """``w . B(v, v) / (|w| |v|^2)`` with ``B`` the second derivative of the period map (a
        central difference, two integrations): the fold's normal-form coefficient, up to a
        positive factor; zero at a cusp."""
        x, lam, _ = self.split(y)
        h = 10 * self._x_step(v)  # larger than the first derivatives' step: noise ~ rtol / h^2
        ends = [self.omap.run(x + s * h * v, lam, monodromy=False, sens=False).x_end for s in (1.0, -1.0)]
        B = (ends[0] + ends[1] - 2 * ev.data["x_end"]) / (h * h)
        return float(w @ B) / float(np.linalg.norm(w) * np.linalg.norm(v) ** 2)


class BranchPointSystem(Augmented):
    """Branch point (``[M - I, S_k]`` with a two-dimensional kernel): unknowns ``(x0, lambda, mu)``.

    Parameters
    ----------
    omap, fd
        As :class:`Augmented`.
    k
        The parameter whose column extends ``M - I`` (the one the multiplier crosses +1 with:
        the parameter of the branch the point was found on); ``None``: the one with the larger
        ``|w^T (dM/dlambda_k) v|`` at the start (the crossing speed, which keeps the system regular).
    """

    kind = "branch_point"
    extras = ("mu",)

    def __init__(self, omap: OrbitMap, fd: float, k: int | None = None):
        super().__init__(omap, fd)
        self.k = k
        self.B = np.zeros(self.nx)
        self.C = np.zeros((self.nx + 1, 2))

    def extra_scales(self) -> np.ndarray:
        return np.array([float(np.max(self.x_scale))])

    def _E(self, M: np.ndarray, S: np.ndarray) -> np.ndarray:
        return np.hstack([M - np.eye(self.nx), S[:, self.k:self.k + 1]])

    def start(self, y: np.ndarray) -> np.ndarray:
        x, lam, _ = self.split(y)
        run = self.omap.run(x, lam)
        right, left = null_vectors(run.M - np.eye(self.nx))
        if self.k is None:
            speed = [abs(float(left[:, 0] @ self._dir_deriv(lambda xx, ll: self.omap.monodromy(xx, ll) @ right[:, 0],
                                                             x, lam, np.zeros(self.nx), np.eye(2)[k])))
                     for k in range(2)]
            self.k = int(np.argmax(speed))
        self.B = left[:, 0]
        self.C = np.zeros((self.nx + 1, 2))
        self.C[:self.nx, 0] = right[:, 0]
        self.C[self.nx, 1] = 1.0
        y = np.asarray(y, float).copy()
        if len(y) == self.n - 1:
            y = np.concatenate([y, [0.0]])
        return y

    def _orbit_rows(self, x, lam, ext, run):
        F, J = super()._orbit_rows(x, lam, ext, run)
        J[:, -1] = self.B
        return F + ext[0] * self.B, J

    def _test(self, M, x, lam, ext, data) -> np.ndarray:
        V, G, w = bordered(self._E(M, data["S"]), self.B, self.C)
        data["V"], data["w"] = V, w
        return G[0, :].real.copy()

    def _test_rows(self, M, x, lam, ext, data) -> np.ndarray:
        V, w = data["V"], data["w"]
        rows = np.zeros((2, self.n))
        mono = self.omap.monodromy

        def ext_times(xx, ll, vec):
            r = self.omap.run(xx, ll)
            return self._E(r.M, r.S) @ vec

        ek = np.zeros(2)
        ek[self.k] = 1.0
        for j in range(2):
            yj, sj = V[:self.nx, j], V[self.nx, j]
            rows[j, :self.nx] = -self._dir_deriv(lambda xx, ll: mono(xx, ll).T @ w, x, lam, yj, sj * ek)
            for k in range(2):
                e = np.zeros(2)
                e[k] = 1.0
                rows[j, self.nx + k] = -float(w @ self._dir_deriv(lambda xx, ll, vec=V[:, j]: ext_times(xx, ll, vec),
                                                                  x, lam, np.zeros(self.nx), e))
        return rows

    def accept(self, y, ev) -> None:
        V, w = ev.data["V"], ev.data["w"]
        c = V[:self.nx, 0]
        if np.linalg.norm(c) > 0:
            self.C[:self.nx, 0] = c / np.linalg.norm(c)
        self.B = w / np.linalg.norm(w)

    def transform(self, Phi: np.ndarray) -> None:
        c, self.B = _carry(Phi, self.C[:self.nx, 0], self.B)
        self.C[:self.nx, 0] = c

    def tests(self, y, ev, multipliers) -> dict[str, float]:
        return {"fold_flip": tau_period_doubling(_others(multipliers, 1.0))}


def _carry(Phi: np.ndarray, right: np.ndarray, left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A right null vector carried by ``Phi`` and a left one by ``Phi^-T`` to a moved section (unit)."""
    r = Phi @ right
    lft = np.linalg.solve(Phi.T, left)
    return r / np.linalg.norm(r), lft / np.linalg.norm(lft)


def _others(mu: np.ndarray, at: float) -> np.ndarray:
    """The multipliers without the one nearest ``at`` (the one the curve keeps there)."""
    mu = np.asarray(mu, complex)
    if len(mu) == 0:
        return mu
    i = int(np.argmin(np.abs(mu - at)))
    return np.delete(mu, i)
