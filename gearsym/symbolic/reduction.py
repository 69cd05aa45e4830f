"""Reduction of a (semi-definite) model to relative coordinates.

The ``[reduction]`` section (:mod:`gearsym.spec.reduction`) defines ``m`` relative
coordinates ``x = A q + s(t)`` (``A`` constant, ``m x n``, of rank ``m``).  The
reduction eliminates ``m`` coordinates ``q_E`` (the first columns of ``A`` that form
an invertible block ``A_E``)::

    q_E = A_E^-1 (x - s(t) - A_K q_K),     v_E = A_E^-1 (x' - s'(t) - A_K v_K)

and writes ``x'' = A M^-1 Q(t, q, v) + s''(t)``.  The reduced system is *closed* when
these equations no longer depend on the kept coordinates ``q_K`` and their velocities
(they are rigid-body coordinates then): anything left over is a
:class:`~gearsym.errors.SpecError` naming it.  The displayed mass of ``x_i`` is
``1 / (sum_j A_ij^2 / M_jj)`` (for one mesh the equivalent mass ``m_e``), and the
generalised force is that mass times the acceleration, so the first-order form is
``x_i'' = acc_i`` exactly.
"""

from __future__ import annotations

import random
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import SpecError

if TYPE_CHECKING:  # pragma: no cover
    from .model import SymbolicModel
    from .parsing import Namespace

__all__ = ["ReductionResult", "reduce_model"]


class ReductionResult:
    """What :func:`reduce_model` returns (attributes only)."""

    def __init__(self, coordinates: list[sp.Symbol], velocities: list[sp.Symbol], mass: sp.Matrix,
                 forces: sp.Matrix, sub: dict[sp.Symbol, sp.Expr], A: sp.Matrix, kept: list[sp.Symbol],
                 masses: list[sp.Expr], shifts: list[sp.Expr]):
        self.coordinates = coordinates
        self.velocities = velocities
        self.mass = mass
        self.forces = forces
        #: substitution of the eliminated coordinates and velocities
        self.sub = sub
        #: coefficients of the coordinates in the reduced coordinates (m x n)
        self.A = A
        #: coordinates that were not eliminated (rigid-body coordinates of a closed reduction)
        self.kept = kept
        #: displayed (equivalent) mass of each reduced coordinate
        self.masses = masses
        #: time function s_i(t) of each reduced coordinate (x = A q + s)
        self.shifts = shifts


def _numeric_rank(A: sp.Matrix) -> int:
    """Generic rank of a matrix of parameter expressions (random parameter values)."""
    import numpy as np

    syms = sorted(A.free_symbols, key=str)
    rng = random.Random(20240611)
    ranks = []
    for _ in range(2):
        vals = {s: sp.Float(rng.uniform(0.6, 1.7)) for s in syms}
        try:
            num = np.array(A.xreplace(vals).evalf(), dtype=float)
        except (TypeError, ValueError):
            return int(A.rank())
        ranks.append(int(np.linalg.matrix_rank(num)) if num.size else 0)
    return max(ranks)


def reduce_model(model: SymbolicModel, ns: Namespace, q: list[sp.Symbol], v: list[sp.Symbol], M: sp.Matrix,
                 Q: sp.Matrix) -> ReductionResult:
    """Reduce the assembled equations ``M q'' = Q`` to the model's reduced coordinates.

    Raises
    ------
    SpecError
        Nonlinear or time-dependent coefficients, dependent definitions, a non-diagonal
        mass matrix, or a reduced system that is not closed.
    """
    from .expand import _expand_in_states, _fold_segments

    spec = model.spec
    red = spec.reduction
    assert red is not None
    rcs = [c for c in red.coordinates if model.resolved.effect_active(c.effect, c.variant)]
    if not rcs:
        raise SpecError("no reduced coordinate is active in this scene (their elements are switched off)",
                        file=spec.path, field="reduction")

    def where(c) -> str:
        if c.element is not None:
            return f"elements.{c.element}.deflection"
        if red.mode == "explicit" and len(red.coordinates) == 1:
            return "reduction.definition"
        return f"reduction.coordinates.{c.name}.definition"

    n, m = len(q), len(rcs)
    rows, shifts = [], []
    for c in rcs:
        d = ns.sum_terms(c.definition, c.effect, c.variant)
        a = [sp.diff(d, qi) for qi in q]
        if any(ai.has(*q, *v) for ai in a):
            raise SpecError("the reduced coordinate must be linear in the coordinates", file=spec.path,
                            field=where(c))
        if any(ai.has(ns.t) for ai in a):
            raise SpecError("the coefficients of the coordinates in the reduced coordinate must not "
                            "depend on time (write the equations in [equations] instead)", file=spec.path,
                            field=where(c))
        s = d - sum(ai * qi for ai, qi in zip(a, q))
        if s.has(*q, *v):  # keep the structure of s when it is already state-free
            s = sp.simplify(s)
        if s.has(*q, *v):
            raise SpecError("cannot separate the definition into coordinates and time", file=spec.path,
                            field=where(c))
        if all(ai == 0 for ai in a):
            raise SpecError("the reduced coordinate does not depend on any coordinate", file=spec.path,
                            field=where(c))
        rows.append(a)
        shifts.append(s)
    A = sp.Matrix(rows)
    if m > n:
        raise SpecError(f"{m} reduced coordinates for {n} coordinates: at most one per coordinate",
                        file=spec.path, field="reduction")
    if not M.is_diagonal():
        raise SpecError("reduction needs a diagonal mass matrix", file=spec.path, field=where(rcs[0]))
    # pivot columns: the first ones that keep the block invertible (one coordinate: its first)
    piv: list[int] = []
    for j in range(n):
        if _numeric_rank(A[:, piv + [j]]) > len(piv):
            piv.append(j)
        if len(piv) == m:
            break
    if len(piv) < m:
        r = 0
        for i, c in enumerate(rcs):
            if _numeric_rank(A[: i + 1, :]) == r:
                raise SpecError(f"the reduced coordinate '{c.name}' is a combination of the ones before it "
                                f"(the definitions must be independent)", file=spec.path, field=where(c))
            r += 1
    kept = [j for j in range(n) if j not in piv]
    xs = [sp.Symbol(c.name, real=True) for c in rcs]
    xds = [sp.Symbol(c.velocity, real=True) for c in rcs]
    AE, AK = A[:, piv], A[:, kept]
    AEinv = AE.inv() if m > 1 else sp.Matrix([[1 / AE[0, 0]]])
    S = sp.Matrix(shifts)
    Sdot = S.diff(ns.t)
    qK = sp.Matrix([q[j] for j in kept]) if kept else sp.zeros(0, 1)
    vK = sp.Matrix([v[j] for j in kept]) if kept else sp.zeros(0, 1)
    rest_q = sp.Matrix(xs) - S - (AK * qK if kept else sp.zeros(m, 1))
    rest_v = sp.Matrix(xds) - Sdot - (AK * vK if kept else sp.zeros(m, 1))
    qE = AEinv * rest_q
    vE = AEinv * rest_v
    sub: dict[sp.Symbol, sp.Expr] = {}
    for i, j in enumerate(piv):
        sub[q[j]] = qE[i]
        sub[v[j]] = vE[i]
    states = tuple(xs + xds)
    seg_count = {ns.sched_seg[sn]: len(b) + 1 for sn, b in ns.schedule_breaks.items()}
    others = [q[j] for j in kept] + [v[j] for j in kept]
    hide, show = ns.tables.hider()  # tables of time or parameters stay whole (gearsym/symbolic/tables.py)
    accs, masses = [], []
    for i, c in enumerate(rcs):
        acc = sum(A[i, j] * Q[j, 0] / M[j, j] for j in range(n) if A[i, j] != 0) + sp.diff(S[i], ns.t, 2)
        # expanded in the states only, state-free blocks kept whole: a full expansion multiplies
        # every inlined derived quantity out (a switched-off effect then made the code bigger:
        # vaishya_singh with every effect off had 787 operations against 122 with the stiffness
        # variation on, whose schedule already kept the blocks)
        sched = True
        acc = _expand_in_states(hide(acc.subs(sub)), states, ns.t, blocks=sched)
        acc = _fold_segments(acc, seg_count)
        if acc.has(*others):
            leftover = sorted(str(o) for o in others if acc.has(o))
            legacy = where(c) == "reduction.definition"
            what = (f"cannot reduce to '{c.name}'" if legacy else
                    f"the reduced equations are not closed: the equation of '{c.name}'")
            raise SpecError(f"{what}: the forces still depend on {', '.join(leftover)} (the system is not "
                            f"semi-definite in these coordinates: some deflection, spring or force sees a "
                            f"combination of the coordinates that no reduced coordinate describes; add a "
                            f"reduced coordinate for it or keep the coordinates)", file=spec.path,
                            field=where(c) if legacy else "reduction")
        m_eq = 1 / sum(A[i, j] ** 2 / M[j, j] for j in range(n) if A[i, j] != 0)
        if not model.structured:  # structured: keep the form of a derived m_e = 1/(sum ...)
            m_eq = sp.simplify(m_eq)
        accs.append((acc, sched))
        masses.append(m_eq)
    forces = sp.Matrix([show(_expand_in_states(me * acc, states, ns.t, blocks=sched))
                        for me, (acc, sched) in zip(masses, accs)])
    return ReductionResult(xs, xds, sp.diag(*masses), forces, sub, A, [q[j] for j in kept], masses, shifts)
