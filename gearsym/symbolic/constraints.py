"""Constraints and algebraic variables: the index-1 DAE of a constrained model.

A constraint ``q_d = h(t, q)`` (``[constraints.NAME]``, see :mod:`gearsym.spec.constraints`)
is enforced by its multiplier ``lambda`` (an ``[algebraic]`` variable), the generalised
force it applies to ``q_d``.  Written as ``C = q_d - h = 0``, the reaction adds
``lambda * dC/dq_i`` to every generalised force (virtual work): ``+lambda`` on ``q_d`` and
``-lambda * dh/dq_i`` on the coordinates ``h`` depends on.

``q_d`` is then no longer a state: every expression reads ``h`` for it and
``dh/dt = h_t + sum_i h_{q_i} v_i`` for its velocity (coordinate partitioning), and its own
equation of motion, with ``q_d'' = d(dh/dt)/dt`` (which contains the accelerations
``v_i'``), becomes the algebraic equation of ``lambda``:

    M_i  v_i' = Q_i - lambda * dh/dq_i            (kept coordinates, differential)
    M_d  h''  = Q_d + lambda                      (the constraint row, algebraic in lambda)

The iteration matrix of this system in ``(v', lambda)`` is
``[[M, dh/dq], [M_d dh/dq^T, -1]]``, nonsingular whenever ``M`` is (its Schur complement
is ``-(1 + M_d dh/dq^T M^-1 dh/dq) < 0``): the DAE has index 1, IDA integrates it with
the algebraic variables in its error test, and the position- and velocity-level
constraints hold exactly (``q_d`` is computed from ``h``), so nothing drifts.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .parsing import Namespace, internal_symbol


@dataclass
class ConstrainedSystem:
    """Result of :func:`apply_constraints`.

    Attributes
    ----------
    coordinates, velocities
        The kept (independent) coordinates and velocities.
    algebraic
        The algebraic variables (multipliers), in ``[algebraic]`` order.
    mass, forces
        ``M`` and ``Q`` of the kept coordinates, reactions included, with the tied
        coordinates replaced.
    rows
        One algebraic equation per constraint (in the order of ``algebraic``), ``= 0``,
        in terms of the placeholder accelerations ``accelerations``.
    accelerations
        One placeholder symbol per kept velocity (its time derivative).
    sub
        ``q_d -> h``, ``v_d -> dh/dt`` for every tied coordinate.
    """

    coordinates: list[sp.Symbol]
    velocities: list[sp.Symbol]
    algebraic: list[sp.Symbol]
    mass: sp.Matrix
    forces: sp.Matrix
    rows: sp.Matrix
    accelerations: list[sp.Symbol]
    sub: dict[sp.Symbol, sp.Expr]


def apply_constraints(spec, ns: Namespace, q: list[sp.Symbol], v: list[sp.Symbol], M: sp.Matrix,
                      Q: sp.Matrix) -> ConstrainedSystem:
    """Eliminate the constrained coordinates and form the constraint rows (module docstring).

    Parameters
    ----------
    spec
        The :class:`~gearsym.spec.model.ModelSpec` (its ``constraints`` and ``algebraic``).
    ns
        The scene's namespace (symbols).
    q, v
        All coordinates and velocities.
    M, Q
        Diagonal mass matrix and generalised forces of all coordinates.

    Returns
    -------
    ConstrainedSystem
    """
    t = ns.t
    index = {s.name: i for i, s in enumerate(q)}
    lam = {a: ns.alg[a] for a in spec.algebraic}
    tied = {c.coordinate for c in spec.constraints.values()}
    keep = [i for i, s in enumerate(q) if s.name not in tied]
    qk = [q[i] for i in keep]
    vk = [v[i] for i in keep]
    acc = [internal_symbol(f"acc_{s}") for s in vk]
    Q = sp.Matrix(Q)
    sub: dict[sp.Symbol, sp.Expr] = {}
    hdd: dict[str, sp.Expr] = {}
    for c in spec.constraints.values():
        d = index[c.coordinate]
        h = ns.parse(c.equals, f"constraints.{c.name}.equals")
        L = lam[c.multiplier]
        Q[d, 0] += L
        for i in keep:
            dh = sp.diff(h, q[i])
            if dh != 0:
                Q[i, 0] -= L * dh
        hdot = sp.diff(h, t) + sum((sp.diff(h, qi) * vi for qi, vi in zip(qk, vk)), sp.Integer(0))
        hdd[c.name] = (sp.diff(hdot, t) + sum((sp.diff(hdot, qi) * vi for qi, vi in zip(qk, vk)), sp.Integer(0))
                       + sum((sp.diff(hdot, vi) * ai for vi, ai in zip(vk, acc)), sp.Integer(0)))
        sub[q[d]] = h
        sub[v[d]] = hdot
    mass = sp.diag(*[M[i, i].xreplace(sub) for i in keep]) if keep else sp.zeros(0, 0)
    forces = sp.Matrix([Q[i, 0].xreplace(sub) for i in keep])
    by_mult = {c.multiplier: c for c in spec.constraints.values()}
    rows = []
    for a in spec.algebraic:
        c = by_mult[a]
        d = index[c.coordinate]
        rows.append(M[d, d].xreplace(sub) * hdd[c.name] - Q[d, 0].xreplace(sub))
    return ConstrainedSystem(qk, vk, [lam[a] for a in spec.algebraic], mass, forces, sp.Matrix(rows), acc, sub)
