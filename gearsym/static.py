"""Static equilibrium: the state a geared system rests in under its mean loads.

Definition (what ``[initial] static = true`` and ``gearsym modes`` solve for): the
coordinates ``q_s`` at rest (velocities zero) where the generalised accelerations,
averaged over one forcing period ``T``, vanish::

    (1/T) * integral_0^T  a(t, q_s, 0; sigma) dt = 0,     a = M(q)^-1 Q(t, q, v)

for **every** coordinate of the compiled model (all reduced coordinates and every kept
coordinate of a reduction, or all coordinates of an unreduced model), with the mean
over the cycle of every time-varying term (a product of two time functions, e.g. a
varying stiffness times a transmission error, contributes the mean of the product).
A model without a forcing period is evaluated at ``t = 0``.

**Contact state.**  ``sigma`` holds one contact state per backlash mesh (every element whose
contact surfaces are a ``NAME.drive`` / ``NAME.back`` pair -- a ``mesh`` or ``gear_mesh`` with a
clearance, a clutch or spline clearance -- :mod:`gearsym.symbolic.elements.base`), fixed over
the cycle: ``"drive"`` (drive-side contact), ``"back"`` (back-side contact) or
``"separated"``.  Other switching surfaces take the side the state is on.  The state
must be *consistent* with the mean loads it produces, flank by flank:

* a mesh in contact on a flank carries a positive mean contact force on it;
* a separated mesh would carry no positive mean force on either flank if it touched;
* a separated mesh whose position no stiffness fixes (a clearance under no mean load,
  e.g. an idler or an unloaded spline) sits in the **centre** of its clearance (the mean
  of ``(g_drive + g_back)/2`` is zero); when no state is consistent in this strict sense
  (a zero clearance under no mean load) the meshes touch with zero mean force.

The mean contact force of a flank is measured as ``s = F/k``: the mean force over the
mean contact stiffness, in the unit of the deflection (for a constant stiffness and no
transmission error it is the mean deflection past the flank), computed from the
generated functions as ``s = sign * (G.da)(G.G)/(G.dJ.G)`` with ``da``, ``dJ`` the
change of the mean acceleration and of its Jacobian when the flank touches and ``G``
the gradient of its switching function; this makes the averaged contact law continuous
(the force vanishes where the state changes), so a consistent state exists whenever the
mean loads can be balanced.

**Solution.**  A guided search over the contact states: start from the flank the mean
loads at the starting guess press (drive side when undecided), solve, and move every
inconsistent mesh to the state its mean load asks for (a separated mesh that an
unbalanced mean load drives is tried on both flanks); small models fall back to every
state in order of distance from the start.  In each state a Newton iteration on the
averaged equations with equilibrated (row and column scaled) Jacobians, whose
least-squares step handles free directions: a free direction that a separated
clearance sees is fixed by centring it, any other is a rigid-body mode.  Contact
states are piecewise linear in the usual models, so Newton ends in one or two steps
whatever the contact stiffness (a 2e13 N/m contact is solved to the round-off of the
state).

**Averages.**  A Gauss-Legendre quadrature on the forcing period, split at every
scheduled breakpoint, so piecewise-constant mesh stiffness is averaged exactly
(:func:`period_nodes`), with the sub-intervals doubled until the mean of the equations
settles (a mesh harmonic many times the forcing frequency is resolved:
:class:`PeriodAverage`); ``gearsym modes --samples N`` passes N equally spaced samples.
Explicit models are evaluated by the engine's C functions at all nodes at once,
implicit ones (the mean of ``-r(t, x, 0)``) by the generated CasADi functions.

**Refusals.**  :class:`~gearsym.errors.SpecError` (naming the scene file and
``initial.static`` for a static start): a rigid-body mode (a free direction that no
clearance sees, unless the caller keeps it, as ``modes`` does), mean loads that do not
balance along one, or no consistent contact state (naming each mesh and what its mean
load does).  :class:`~gearsym.errors.ConvergenceError`: Newton did not converge.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .codegen.artifact import generated_map
from .errors import ConvergenceError, GearsymError, SpecError

_log = logging.getLogger(__name__)

if TYPE_CHECKING:  # pragma: no cover
    from .system import CompiledSystem as System

__all__ = ["PeriodAverage", "StaticEquilibrium", "equal_nodes", "period_nodes", "static_equilibrium",
           "static_state"]

#: Gauss-Legendre points per sub-interval and sub-intervals per forcing period (at least)
_GL_POINTS = 8
_MIN_PIECES = 8
_MAX_NODES = 20_000
#: the contact states of a backlash mesh
DRIVE, BACK, SEPARATED = "drive", "back", "separated"
_STATES = (DRIVE, BACK, SEPARATED)
#: the mean of the equations has settled when a doubling of the nodes moves it less than this
_AVERAGE_TOL = 1e-11
#: singular values below this (relative, equilibrated Jacobian) span a free direction
_RANK_TOL = 1e-11
#: Newton: iterations, and the step (relative to the coordinate's scale) that ends it
_MAX_NEWTON = 60
_STEP_TOL = 1e-13
#: the residual a solution may keep, relative to the size of the terms that balance
_RESIDUAL_TOL = 1e-10
#: a mean contact force below this (as a deflection, relative to the clearance, the deflection
#: and the terms of the equations) is no load
_LOAD_TOL = 1e-12
#: contact states tried at most (every state when 3**meshes is at most _ENUMERATE)
_ENUMERATE = 243
_MAX_STATES = 300


def period_nodes(system: System, p: np.ndarray, pieces: int = _MIN_PIECES) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes and weights for the average over one forcing period: Gauss-Legendre
    on at least ``pieces`` equal sub-intervals, split at every scheduled breakpoint.

    Parameters
    ----------
    system
        The compiled system.
    p
        Its parameter vector.
    pieces
        Sub-intervals at least (8: trigonometric terms of the forcing frequency are exact;
        :class:`PeriodAverage` doubles them until the mean of the equations settles).

    Returns
    -------
    t : ndarray
        Nodes in ``[0, T)`` (``[0.0]`` without a forcing period).
    w : ndarray
        Weights summing to 1.
    """
    T = system.period_of(p)
    if not T:
        return np.zeros(1), np.ones(1)
    cuts = {0.0, T}
    for P, fractions in system.schedule_table(p):
        if not (math.isfinite(P) and P > 0) or T / P * (len(fractions) + 1) > _MAX_NODES / _GL_POINTS:
            continue
        for k in range(int(math.ceil(T / P)) + 1):
            for f in (0.0, *fractions):
                c = (k + float(f)) * P
                if 0 < c < T:
                    cuts.add(c)
    edges = np.array(sorted(cuts))
    fine = np.unique(np.concatenate([edges, np.linspace(0, T, pieces + 1)]))
    x, wx = np.polynomial.legendre.leggauss(_GL_POINTS)
    a, b = fine[:-1, None], fine[1:, None]
    t = (a + (b - a) * (x + 1) / 2).ravel()
    w = ((b - a) / 2 * wx).ravel() / T
    return t, w


def equal_nodes(system: System, p: np.ndarray, samples: int, t0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``samples`` equally spaced nodes on ``[t0, t0 + T)`` with equal weights (exact for
    trigonometric polynomials of degree below ``samples``); ``[t0]`` without a forcing period.

    Parameters
    ----------
    system
        The compiled system.
    p
        Its parameter vector.
    samples
        Number of nodes.
    t0
        Start of the period.

    Returns
    -------
    t, w : ndarray
        Nodes and weights (summing to 1).
    """
    T = system.period_of(p)
    if not T:
        return np.array([float(t0)]), np.ones(1)
    return t0 + T * np.arange(samples) / samples, np.full(samples, 1.0 / samples)


@dataclass(frozen=True)
class _Mesh:
    """A backlash mesh: the indices and contact signs of its two switching surfaces."""

    name: str
    drive: int
    back: int
    sign_drive: float
    sign_back: float

    def sides(self, state: str) -> tuple[float, float]:
        """Sides ``sigma`` of (drive, back) surface in a contact state."""
        d = self.sign_drive if state == DRIVE else -self.sign_drive
        b = self.sign_back if state == BACK else -self.sign_back
        return d, b


class PeriodAverage:
    """Averages of a compiled model's generated functions over one forcing period, with the
    contact state of every backlash mesh fixed (CasADi maps of the generated functions).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units).
    nodes
        ``(t, w)``: nodes and weights of the average (default :func:`period_nodes`).

    Attributes
    ----------
    meshes : list
        The backlash meshes (each with its drive and back surface).
    t, w : ndarray
        The nodes and weights.
    """

    def __init__(self, system: System, params: Mapping[str, float] | None = None,
                 nodes: tuple[np.ndarray, np.ndarray] | None = None, probe: Sequence[float] | None = None):
        gen = system.generated
        self.system = system
        self.generated = gen
        self.p = system.param_vector(params)
        self.nx = gen.nx
        self.nsw = gen.nsw
        pairs: dict[str, dict[str, tuple[int, float]]] = {}
        for j, _, mesh, kind, sign in gen.contact_surfaces:
            pairs.setdefault(mesh, {})[str(kind)] = (j, float(sign))
        self.meshes = [_Mesh(m, s["drive"][0], s["back"][0], s["drive"][1], s["back"][1])
                       for m, s in pairs.items() if "drive" in s and "back" in s]
        contact = {k for m in self.meshes for k in (m.drive, m.back)}
        self._switch = np.array([j for j in range(self.nsw) if j not in contact], dtype=int)
        if nodes is not None:
            self._set_nodes(*nodes)
        else:
            self._refine(np.asarray(system.x0 if probe is None else probe, float))

    def _set_nodes(self, t: np.ndarray, w: np.ndarray) -> None:
        self.t, self.w = np.asarray(t, float), np.asarray(w, float)
        self.n = n = len(self.t)
        self._tt = self.t.reshape(1, n)
        zero = np.zeros((n, self.nx))
        self._sched = np.asarray(self.system.modes(self.t, zero, self.p))[:, self.nsw:].reshape(n, -1)

    def _at_nodes(self, x: np.ndarray) -> np.ndarray:
        return np.repeat(np.asarray(x, float)[None, :], self.n, axis=0)

    def _casadi(self, name: str, *args: Any) -> np.ndarray:
        """A generated function mapped over the nodes (CasADi), dense, as numpy; a sparse output
        is converted from its non-zeros (converting every element was most of the cost)."""
        out = generated_map(self.generated, name, self.n)(self._tt, *args)
        rows, cols = out.sparsity().get_triplet()
        dense = np.zeros(out.shape)
        dense[rows, cols] = out.nonzeros()
        return dense

    def _refine(self, x: np.ndarray) -> None:
        """:func:`period_nodes` with the sub-intervals doubled until the mean of the equations
        and of their Jacobian (every mesh in drive-side contact, at ``x``) settles to round-off:
        a mesh harmonic many times the forcing frequency is then resolved."""
        contact = {m.name: DRIVE for m in self.meshes}
        pieces, last = _MIN_PIECES, None
        nx = self.nx
        while True:
            self._set_nodes(*period_nodes(self.system, self.p, pieces))
            f, J, size = self.average_with_size(x, self.sides(x, contact), sizes=True)
            assert J is not None
            if not (np.all(np.isfinite(f)) and np.all(np.isfinite(J))):
                return
            # scales: a Jacobian entry against the largest of its row and column (entries that
            # are round-off of cancelling terms have no accuracy of their own), a mean against
            # the terms it balances
            SJ = size[nx:].reshape(nx, nx)
            scale_J = np.maximum(SJ.max(axis=1)[:, None], SJ.max(axis=0)[None, :])
            scale_f = size[:nx] + SJ @ np.abs(x)
            if last is not None and np.all(np.abs(J - last[1]) <= _AVERAGE_TOL * scale_J) \
                    and np.all(np.abs(f - last[0]) <= _AVERAGE_TOL * scale_f):
                return
            if self.n * 2 > _MAX_NODES:
                return
            last, pieces = (f, J), pieces * 2

    def switching(self, x: np.ndarray) -> np.ndarray:
        """``g(t_k, x)`` at every node, shape ``(n, nsw)``."""
        if not self.nsw:
            return np.zeros((self.n, 0))
        return self.system.engine.evaluate("sw", self.t, self._at_nodes(x), self.p)

    def switching_gradient(self, x: np.ndarray) -> np.ndarray:
        """The mean over the nodes of ``dg/dx``, shape ``(nsw, nx)``."""
        if not self.nsw:
            return np.zeros((0, self.nx))
        G = self._casadi("gs_swx", self._at_nodes(x).T, self.p).reshape(self.nsw, self.n, self.nx)
        return np.einsum("ikj,k->ij", G, self.w)

    def sides(self, x: np.ndarray, contact: Mapping[str, str]) -> np.ndarray:
        """The mode's surface sides at every node, shape ``(n, nsw)``: each backlash mesh in its
        contact state, every other surface on the side ``x`` is on (``g >= 0`` -> +1)."""
        sigma = np.ones((self.n, self.nsw))
        if self._switch.size:
            g = self.switching(x)
            sigma[:, self._switch] = np.where(g[:, self._switch] >= 0, 1.0, -1.0)
        for m in self.meshes:
            sigma[:, m.drive], sigma[:, m.back] = m.sides(contact[m.name])
        return sigma

    def average(self, x: np.ndarray, sigma: np.ndarray, jacobian: bool = True
                ) -> tuple[np.ndarray, np.ndarray | None]:
        """Mean over the nodes of the right-hand side and of its Jacobian ``d/dx`` at ``x``.

        For an implicit model, the mean of ``-r(t, x, 0)`` (generalised forces in the
        velocity rows) and of ``-dr/dx``.

        Parameters
        ----------
        x
            The state.
        sigma
            Surface sides at every node (:meth:`sides`).
        jacobian
            Also the Jacobian.

        Returns
        -------
        f : ndarray, shape (nx,)
        J : ndarray, shape (nx, nx), or None
        """
        f, J, _ = self.average_with_size(x, sigma, jacobian)
        return f, J

    def average_with_size(self, x: np.ndarray, sigma: np.ndarray, jacobian: bool = True, sizes: bool = False
                          ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`average`, and the mean of ``|f|`` over the nodes (the size of the terms
        whose mean is taken: a scale for the round-off of the mean); with ``sizes``, the
        means of ``|f|`` and ``|J|`` (flattened, as ``[f, J.ravel()]``)."""
        n, nx = self.n, self.nx
        X = self._at_nodes(x)
        J3: np.ndarray | None = None
        if self.generated.implicit:  # nodes along the last axis
            m = np.hstack([sigma, self._sched]).T if self._sched.size else np.asarray(sigma).T
            zero = np.zeros((nx, n))
            F = -self._casadi("gs_res", X.T, zero, self.p, m).reshape(nx, n).T
            if jacobian:
                J3 = -self._casadi("gs_resjac", X.T, zero, self.p, m, 0.0).reshape(nx, n, nx).transpose(1, 0, 2)
        else:  # the engine's C evaluation (the schedule segments from its own mode logic)
            F = self.system.engine.evaluate("rhs", self.t, X, self.p, sigma)
            J3 = self.system.engine.evaluate("jac", self.t, X, self.p, sigma) if jacobian else None
        w = self.w
        size = np.abs(F).T @ w
        Jm = np.einsum("kij,k->ij", J3, w) if J3 is not None else None
        if sizes and J3 is not None:
            size = np.concatenate([size, np.einsum("kij,k->ij", np.abs(J3), w).ravel()])
        return F.T @ w, Jm, size


@dataclass(frozen=True)
class StaticEquilibrium:
    """The static equilibrium of a compiled model (:func:`static_equilibrium`).

    Attributes
    ----------
    state : ndarray
        The full state: the coordinates at equilibrium, velocities zero.
    coordinates : list of str
        Names of the coordinates solved for.
    contact : dict
        Contact state of every backlash mesh: ``"drive"``, ``"back"`` or ``"separated"``.
    loads : dict
        Per mesh, the mean contact force over the mean contact stiffness on the flank in
        contact (``F/k``, in the deflection's unit), or for a separated mesh the smaller
        of its two flank gaps as a negative number.
    sigma : ndarray, shape (n_nodes, n_surfaces)
        The surface sides used at each node of the average.
    nodes : tuple of ndarray
        ``(t, w)``: the nodes and weights of the average.
    free : int
        Free (rigid-body) directions kept at the guess (``rigid="keep"``).
    info : dict
        ``iterations`` (Newton, all states), ``states_tried``, ``residual`` (largest mean
        acceleration left, relative to the terms that balance).
    """

    state: np.ndarray
    coordinates: list[str]
    contact: dict[str, str]
    loads: dict[str, float]
    sigma: np.ndarray = field(repr=False)
    nodes: tuple[np.ndarray, np.ndarray] = field(repr=False)
    free: int = 0
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def q(self) -> np.ndarray:
        """The coordinates at equilibrium (in the order of :attr:`coordinates`)."""
        return self.state[: len(self.coordinates)].copy()


@dataclass
class _Solve:
    """The outcome of Newton in one contact state."""

    q: np.ndarray
    ok: bool
    iterations: int = 0
    residual: float = math.inf
    #: separated meshes along whose free direction a mean load is left (they must touch)
    pushed: tuple[str, ...] = ()
    #: a mean load is left along a free direction that no clearance sees
    rigid_unbalanced: bool = False
    #: free directions that no clearance fixes (columns, coordinates)
    free: np.ndarray | None = None
    message: str = ""


class _Problem:
    """The averaged static equations in the coordinates ``qi`` of the state ``x``."""

    def __init__(self, avg: PeriodAverage, x: np.ndarray, qi: list[int], vi: list[int]):
        self.avg = avg
        self.x = x
        self.qi, self.vi = qi, vi

    def state(self, q: np.ndarray) -> np.ndarray:
        xs = self.x.copy()
        xs[self.qi] = q
        return xs

    def equations(self, q: np.ndarray, contact: Mapping[str, str], jacobian: bool = True
                  ) -> tuple[np.ndarray, np.ndarray | None]:
        """Mean accelerations of the coordinates and their Jacobian in the coordinates."""
        f, J, _ = self.equations_with_size(q, contact, jacobian)
        return f, J

    def equations_with_size(self, q: np.ndarray, contact: Mapping[str, str], jacobian: bool = True
                            ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """:meth:`equations` and the mean size of the accelerations averaged."""
        xs = self.state(q)
        f, J, size = self.avg.average_with_size(xs, self.avg.sides(xs, contact), jacobian)
        return f[self.vi], (J[np.ix_(self.vi, self.qi)] if J is not None else None), size[self.vi]

    def centres(self, q: np.ndarray, meshes: Sequence[_Mesh]) -> tuple[np.ndarray, np.ndarray]:
        """Mean position of each mesh in its clearance (``(g_drive + g_back)/2``: 0 in the
        centre) and its gradient in the coordinates."""
        xs = self.state(q)
        if not meshes:
            return np.zeros(0), np.zeros((0, len(self.qi)))
        g = self.avg.switching(xs).T @ self.avg.w
        G = self.avg.switching_gradient(xs)[:, self.qi]
        c = np.array([(g[m.drive] + g[m.back]) / 2 for m in meshes])
        C = np.array([(G[m.drive] + G[m.back]) / 2 for m in meshes])
        return c, C


def _equilibrate(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column scales ``R``, ``D`` making ``R J D`` of unit row and column maxima."""
    col = np.abs(J).max(axis=0) if J.size else np.zeros(0)
    D = np.where(col > 0, 1.0 / np.where(col > 0, col, 1.0), 1.0)
    row = np.abs(J * D).max(axis=1) if J.size else np.zeros(0)
    R = np.where(row > 0, 1.0 / np.where(row > 0, row, 1.0), 1.0)
    return R, D


def _step(prob: _Problem, q: np.ndarray, r: np.ndarray, J: np.ndarray, contact: Mapping[str, str],
          load_scale: float) -> tuple[np.ndarray, tuple[str, ...], bool, np.ndarray]:
    """One Newton step with the free directions handled (see the module docstring).

    Returns
    -------
    dq
        The step.
    pushed
        Separated meshes whose free direction carries an unbalanced mean load.
    rigid_unbalanced
        An unbalanced mean load along a free direction no clearance sees.
    free
        The free directions no clearance fixes (columns).
    """
    R, D = _equilibrate(J)
    U, s, Vt = np.linalg.svd(R[:, None] * J * D[None, :])
    rank = int(np.sum(s > _RANK_TOL * s[0])) if s.size and s[0] > 0 else 0
    rs = R * r
    dz = -Vt[:rank].T @ ((U[:, :rank].T @ rs) / s[:rank])
    dq = D * dz
    nq = len(q)
    if rank == nq:
        return dq, (), False, np.zeros((nq, 0))
    N = D[:, None] * Vt[rank:].T
    N /= np.linalg.norm(N, axis=0)
    unbalanced = float(np.abs(U[:, rank:].T @ rs).max()) > _RESIDUAL_TOL * load_scale
    open_meshes = [m for m in prob.avg.meshes if contact[m.name] == SEPARATED]
    c, C = prob.centres(q, open_meshes)
    CN = C @ N if open_meshes else np.zeros((0, N.shape[1]))
    seen = [i for i in range(len(open_meshes)) if np.abs(CN[i]).max() > 1e-8 * np.linalg.norm(C[i])]
    free = N
    if seen:
        A = CN[seen]
        z, *_ = np.linalg.lstsq(A, -(c[seen] + C[seen] @ dq), rcond=1e-10)
        dq = dq + N @ z
        _, sa, vta = np.linalg.svd(A)
        ra = int(np.sum(sa > 1e-10 * sa[0])) if sa.size else 0
        free = N @ vta[ra:].T
    pushed = tuple(open_meshes[i].name for i in seen) if unbalanced else ()
    return dq, pushed, unbalanced and not seen, free


def _newton(prob: _Problem, q0: np.ndarray, contact: Mapping[str, str]) -> _Solve:
    """Newton on the averaged equations in one contact state (backtracking on non-finite or
    growing residuals)."""
    q = np.array(q0, float)
    r, J, size = prob.equations_with_size(q, contact)
    assert J is not None
    R, _ = _equilibrate(J)
    # the size of the terms that balance: stiffness times coordinates, and the loads
    load_scale = float(np.max(R * (np.abs(J) @ np.abs(q) + np.abs(r) + size), initial=0.0))
    qs = np.abs(q).copy()
    it = 0
    free = np.zeros((len(q), 0))
    prev = math.inf
    stalled = 0
    for it in range(1, _MAX_NEWTON + 1):
        if not np.all(np.isfinite(r)) or not np.all(np.isfinite(J)):
            return _Solve(q, False, it, message="the mean equations are not finite at the iterate")
        dq, pushed, rigid, free = _step(prob, q, r, J, contact, load_scale)
        if pushed or rigid:
            return _Solve(q, False, it, pushed=pushed, rigid_unbalanced=rigid, free=free,
                          message="an unbalanced mean load along a free direction")
        qs = np.maximum(qs, np.abs(dq))
        step = float(np.max(np.abs(dq) / np.where(qs > 0, qs, 1.0), initial=0.0))
        merit = float(np.max(np.abs(R * r), initial=0.0))
        lam = 1.0
        for _ in range(30):
            qn = q + lam * dq
            rn, Jn = prob.equations(qn, contact)
            mn = float(np.max(np.abs(R * rn), initial=0.0))
            if np.all(np.isfinite(rn)) and (mn <= 2 * merit or mn <= _RESIDUAL_TOL * load_scale):
                break
            lam /= 2
        q, r, J = qn, rn, Jn
        assert J is not None
        if step <= _STEP_TOL:
            break
        stalled = stalled + 1 if step >= prev / 2 else 0
        if stalled >= 3:
            break
        prev = step
    load_scale = max(load_scale, float(np.max(R * (np.abs(J) @ np.abs(q)), initial=0.0)))
    res = float(np.max(np.abs(R * r), initial=0.0)) / load_scale if load_scale > 0 else 0.0
    ok = res <= _RESIDUAL_TOL and bool(np.all(np.isfinite(q)))
    return _Solve(q, ok, it, res, free=free, message="" if ok else f"Newton stopped with a relative residual "
                                                                  f"{res:.3g} in {it} iterations")


def _loads(prob: _Problem, q: np.ndarray, contact: Mapping[str, str]) -> dict[str, tuple[float, float, float]]:
    """Per mesh: the mean contact force over the mean contact stiffness ``s = F/k`` that its
    drive and its back flank would carry if they touched at ``q`` (the other meshes as in
    ``contact``), and the size of its clearance (a scale for the zero load)."""
    out: dict[str, tuple[float, float, float]] = {}
    if not prob.avg.meshes:
        return out
    xs = prob.state(q)
    g = prob.avg.switching(xs).T @ prob.avg.w
    G = prob.avg.switching_gradient(xs)[:, prob.qi]
    for m in prob.avg.meshes:
        a0, J0, size0 = prob.equations_with_size(q, {**contact, m.name: SEPARATED})
        assert J0 is not None
        s = []
        # the zero of a load: the clearance, the deflection, and the size of the terms of the
        # equations as a deflection (their round-off is no load)
        scale = max(abs(g[m.drive] - g[m.back]) / 2, float(np.abs(G[m.drive]) @ np.abs(q)))
        for flank, j, sign in ((DRIVE, m.drive, m.sign_drive), (BACK, m.back, m.sign_back)):
            a1, J1, size1 = prob.equations_with_size(q, {**contact, m.name: flank})
            assert J1 is not None
            grad = G[j]
            den = float(grad @ (J1 - J0) @ grad)
            if den < 0:
                s.append(sign * float(grad @ (a1 - a0)) * float(grad @ grad) / den)
                scale = max(scale, float(np.abs(grad) @ (size0 + size1)) * float(grad @ grad) / -den)
            else:  # no contact stiffness seen: the mean deflection past the flank
                s.append(sign * float(g[j]))
        out[m.name] = (s[0], s[1], scale)
    return out


def _zero_load_contacts(contact: Mapping[str, str], loads: Mapping[str, tuple[float, float, float]]) -> bool:
    """Whether every mesh in contact at least touches (a mean load of zero within round-off
    counts): the fallback when no state is consistent in the strict sense (e.g. a zero clearance
    under no mean load)."""
    for name, (sd, sb, scale) in loads.items():
        own = sd if contact[name] == DRIVE else sb if contact[name] == BACK else None
        if own is not None and own < -_LOAD_TOL * scale:
            return False
    return True


def _violations(contact: Mapping[str, str], loads: Mapping[str, tuple[float, float, float]]
                ) -> dict[str, tuple[str, str]]:
    """The meshes whose contact state their mean load contradicts: mesh -> (state it asks
    for, why).  A contact without mean load asks to be separated (and centred)."""
    bad: dict[str, tuple[str, str]] = {}
    for name, (sd, sb, scale) in loads.items():
        tol = _LOAD_TOL * scale
        state = contact[name]
        want = DRIVE if sd > tol else BACK if sb > tol else SEPARATED
        if want == state:
            continue
        if state == SEPARATED:
            why = (f"separated, its mean load would press the {want} flank (F/k = "
                   f"{sd if want == DRIVE else sb:.4g})")
        else:
            own = sd if state == DRIVE else sb
            why = (f"in {state}-side contact, the mean load {'pulls the flanks apart' if own < -tol else 'is zero'}"
                   f" (F/k = {own:.4g})")
        bad[name] = (want, why)
    return bad


def _margins(contact: Mapping[str, str], loads: Mapping[str, tuple[float, float, float]]) -> dict[str, float]:
    out = {}
    for name, (sd, sb, _) in loads.items():
        out[name] = sd if contact[name] == DRIVE else sb if contact[name] == BACK else max(sd, sb)
    return out


def _start(prob: _Problem, q0: np.ndarray) -> dict[str, str]:
    """The contact state the mean loads press at the guess (drive side when undecided)."""
    contact = {m.name: DRIVE for m in prob.avg.meshes}
    loads = _loads(prob, q0, {m.name: SEPARATED for m in prob.avg.meshes})
    for name, (sd, sb, scale) in loads.items():
        if sb > _LOAD_TOL * scale and not sd > sb:
            contact[name] = BACK
    return contact


class _Search:
    """The guided search over the contact states (module docstring)."""

    def __init__(self, prob: _Problem, q0: np.ndarray, rigid: str, where: tuple[str | None, str | None]):
        self.prob, self.q0, self.rigid, self.where = prob, q0, rigid, where
        self.names = [m.name for m in prob.avg.meshes]
        self.iterations = 0
        self.solves = 0
        self.tried: list[tuple[dict[str, str], _Solve, dict[str, tuple[str, str]]]] = []
        #: the first state whose contacts all touch, some without mean load (the fallback)
        self.touching: tuple[dict[str, str], _Solve, dict[str, tuple[float, float, float]]] | None = None

    def error(self, message: str) -> SpecError:
        file, fld = self.where
        return SpecError(message, file=file, field=fld)

    def run(self) -> tuple[dict[str, str], _Solve, dict[str, tuple[float, float, float]]]:
        start = _start(self.prob, self.q0)
        queue = [start]
        seen: set[tuple[str, ...]] = set()
        enumerated = False
        while len(seen) < _MAX_STATES:
            if not queue:
                if enumerated or len(_STATES) ** len(self.names) > _ENUMERATE:
                    break
                enumerated = True
                queue = self._all_states(start, seen)
                continue
            contact = queue.pop(0)
            key = tuple(contact[n] for n in self.names)
            if key in seen:
                continue
            seen.add(key)
            found = self._try(contact)
            if isinstance(found, tuple):
                return found
            queue = found + queue
        if self.touching is not None:
            return self.touching
        raise self._no_equilibrium()

    def _try(self, contact: dict[str, str]
             ) -> tuple[dict[str, str], _Solve, dict[str, tuple[float, float, float]]] | list[dict[str, str]]:
        sol = _newton(self.prob, self.q0, contact)
        self.iterations += sol.iterations
        self.solves += 1
        if sol.rigid_unbalanced:
            raise self.error("no static equilibrium: the mean loads do not balance along a rigid-body mode "
                             f"({_direction(self.prob, sol.free)}): the system accelerates as a whole "
                             f"(balance the mean loads, or reduce the model to relative coordinates with "
                             f"[reduction]){self._switch_hint()}")
        if sol.free is not None and sol.free.shape[1] and self.rigid == "refuse":
            raise self.error("the static equilibrium is not determined: the mean stiffness matrix is singular "
                             f"along {_direction(self.prob, sol.free)} (a rigid-body mode? reduce the model to "
                             f"relative coordinates with [reduction]){self._switch_hint()}")
        if sol.pushed:
            self.tried.append((contact, sol, {n: (DRIVE + "/" + BACK, "separated, an unbalanced mean load drives "
                                                  "it against a flank") for n in sol.pushed}))
            return [{**contact, n: f} for n in sol.pushed for f in (DRIVE, BACK)]
        if not sol.ok:
            self.tried.append((contact, sol, {}))
            return []
        loads = _loads(self.prob, sol.q, contact)
        bad = _violations(contact, loads)
        if not bad:
            return contact, sol, loads
        if self.touching is None and _zero_load_contacts(contact, loads):
            self.touching = (contact, sol, loads)
        self.tried.append((contact, sol, bad))
        together = {**contact, **{n: w for n, (w, _) in bad.items()}}
        return [together] + ([{**contact, n: w} for n, (w, _) in bad.items()] if len(bad) > 1 else [])

    def _switch_hint(self) -> str:
        """For models with switching surfaces other than mesh contacts (a contact law written in
        [equations]): their side is taken from the state, so a guess outside the contact sees no
        stiffness."""
        if not self.prob.avg._switch.size:
            return ""
        return ("; or a contact written as a switching condition (not a mesh) that the starting guess does not "
                "touch: give [initial] values in contact")

    def _all_states(self, start: Mapping[str, str], seen: set[tuple[str, ...]]) -> list[dict[str, str]]:
        keys = [k for k in itertools.product(_STATES, repeat=len(self.names)) if k not in seen]
        keys.sort(key=lambda k: sum(a != start[n] for a, n in zip(k, self.names)))
        return [dict(zip(self.names, k)) for k in keys]

    def _no_equilibrium(self) -> GearsymError:
        converged = [(c, s, b) for c, s, b in self.tried if s.ok or s.pushed]
        if not converged:
            msgs = sorted({s.message for _, s, _ in self.tried})
            return ConvergenceError("the static equilibrium did not converge in any contact state: "
                                    + "; ".join(msgs))
        contact, _, bad = min(converged, key=lambda t: len(t[2]))
        why = "; ".join(f"mesh '{n}' {w}" for n, (_, w) in bad.items())
        return self.error(f"no static equilibrium: no contact state of the meshes is consistent with its mean "
                          f"loads ({len(self.tried)} tried); closest: {why}")



def _direction(prob: _Problem, free: np.ndarray | None) -> str:
    """The coordinates a free direction moves (text)."""
    names = [prob.avg.generated.state_names[i] for i in prob.qi]
    if free is None or not free.size:
        return "a free direction"
    v = free[:, 0]
    big = np.abs(v) > 1e-6 * np.abs(v).max()
    return "the coordinates " + ", ".join(n for n, b in zip(names, big) if b)


def static_equilibrium(system: System, params: Mapping[str, float] | None = None, *,
                       guess: Sequence[float] | None = None,
                       states: tuple[Sequence[str], Sequence[str]] | None = None,
                       nodes: tuple[np.ndarray, np.ndarray] | None = None, rigid: str = "refuse",
                       where: tuple[str | None, str | None] = (None, "initial.static")) -> StaticEquilibrium:
    """The static equilibrium of every coordinate under the mean loads (module docstring).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units).
    guess
        Full state whose coordinates start the solve (default: the system's ``x0``).
    states
        ``(coordinates, velocities)``: names of the coordinate states solved for and of their
        velocities (zero); default: the first and the second half of the states without the
        algebraic variables (``[q, q']``, the layout of every compiled model).
    nodes
        ``(t, w)`` of the average over the forcing period (default :func:`period_nodes`).
    rigid
        ``"refuse"``: a free direction that no clearance fixes (a rigid-body mode) is an
        error; ``"keep"``: it keeps the guess's value.
    where
        ``(file, field)`` named by the errors.

    Returns
    -------
    StaticEquilibrium

    Raises
    ------
    SpecError
        A rigid-body mode (with ``rigid="refuse"``), mean loads that do not balance along
        one, or no contact state consistent with the mean loads (naming the meshes).
    ConvergenceError
        Newton did not converge.
    """
    if rigid not in ("refuse", "keep"):
        raise ValueError(f"rigid must be 'refuse' or 'keep', got {rigid!r}")
    gen = system.generated
    names = list(gen.state_names)
    if states is None:
        nq = (gen.nx - len(gen.algebraic or [])) // 2
        coords, vels = names[:nq], names[nq:2 * nq]
    else:
        coords, vels = list(states[0]), list(states[1])
        if len(coords) != len(vels):
            raise ValueError(f"{len(coords)} coordinates but {len(vels)} velocities")
    qi = [names.index(c) for c in coords]
    vi = [names.index(v) for v in vels]
    x = np.array(system.x0 if guess is None else guess, dtype=float)
    x[vi] = 0.0
    avg = PeriodAverage(system, params, nodes, probe=x)
    prob = _Problem(avg, x, qi, vi)
    search = _Search(prob, x[qi].copy(), rigid, where)
    contact, sol, loads = search.run()
    xs = prob.state(sol.q)
    free = sol.free.shape[1] if sol.free is not None else 0
    _log.info("static equilibrium of %s: contact state %s (Newton iterations %d, contact states tried %d, "
              "residual %.3g)", getattr(system, "name", "the system"),
              ", ".join(f"{m}: {s}" for m, s in contact.items()) or "(no backlash mesh)",
              search.iterations, search.solves, sol.residual)
    return StaticEquilibrium(
        state=xs, coordinates=coords, contact=dict(contact), loads=_margins(contact, loads),
        sigma=avg.sides(xs, contact), nodes=(avg.t, avg.w), free=int(free),
        info={"iterations": search.iterations, "states_tried": search.solves, "residual": sol.residual})


def static_state(system: System, coordinates: Sequence[str] | None = None, velocities: Sequence[str] | None = None,
                 guess: Sequence[float] | None = None, params: Mapping[str, float] | None = None,
                 where: tuple[str | None, str | None] = (None, "initial.static")) -> np.ndarray:
    """The full state at the static equilibrium (:func:`static_equilibrium`, rigid-body modes
    refused): what ``[initial] static = true`` starts from.

    Parameters
    ----------
    system
        The compiled system.
    coordinates, velocities
        Names of the coordinate states (solved for) and of their velocities (zero); default
        every coordinate of the model.
    guess
        Full state whose coordinates start the solve (default: the system's ``x0``).
    params
        Parameter overrides (declared units, as every ``params=``).
    where
        ``(file, field)`` named by the errors.

    Returns
    -------
    ndarray
        The full state: coordinates at the static equilibrium, velocities zero, any
        other state as in ``guess``.

    Raises
    ------
    SpecError, ConvergenceError
        As :func:`static_equilibrium`.
    """
    states = None if coordinates is None else (coordinates, velocities if velocities is not None else [])
    return static_equilibrium(system, params, guess=guess, states=states, where=where).state
