"""Reduction to one relative coordinate while other coordinates stay states (``[reduction] keep``).

For a transverse-torsional pair the dynamic transmission error
``x = a . q_E + s(q_K, t)`` is linear with constant coefficients ``a`` in the rotations
``q_E`` but depends on the kept centre translations ``q_K`` in any smooth way (through a
pressure angle that varies with the centre distance).  One rotation ``q_k`` (the first
with ``a_k != 0``) is eliminated::

    q_k = (x - s - sum_{i != k} a_i q_i)/a_k,    v_k = (x' - s' - sum_{i != k} a_i v_i)/a_k,
    s'  = ds/dt + sum_K ds/dq_j v_j,
    x'' = sum_E a_i Q_i/M_ii + s'',   s'' = d(s')/dt + sum_K (d(s')/dq_j v_j + d(s')/dv_j q_j''),

with the kept accelerations ``q_j'' = Q_j/M_jj`` substituted, so the system is explicit.
The reduced equations must not depend on the other eliminated coordinates (the pair must
be semi-definite in them); the kept rows are their own equations with the substitution.
The reduced coordinate's mass is ``m_eq = 1/sum_E a_i^2/M_ii`` (``m_e`` of a pair).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import SpecError

if TYPE_CHECKING:
    from .model import SymbolicModel
    from .parsing import Namespace


def reduce_keeping(model: SymbolicModel, ns: Namespace, q: list[sp.Symbol], v: list[sp.Symbol], M: sp.Matrix,
                   Q: sp.Matrix, surfaces: list[sp.Expr], meshes: Mapping[str, sp.Expr] | None = None,
                   surface_fields: Sequence[str] | None = None, forces: Mapping[str, sp.Expr] | None = None
                   ) -> tuple[list[sp.Symbol], list[sp.Symbol], sp.Matrix, sp.Matrix, dict[sp.Symbol, sp.Expr],
                              sp.Expr, list[sp.Expr | None]]:
    """Reduce ``M q'' = Q`` as described in the module docstring.

    Parameters
    ----------
    surfaces
        Switching functions of the elements (contact surfaces), rewritten in the new states.
    surface_fields
        The spec field each surface comes from, then (optionally) each mesh deflection's
        (named by the errors; default ``reduction.keep`` and ``elements.NAME.deflection``).
    meshes
        Dynamic deflection of every mesh element (by element name), rewritten in the
        new states like the surfaces.
    forces
        Force of every mesh element (by element name), rewritten likewise, the rate of the
        definition replaced by the new velocity.

    Returns
    -------
    coordinates, velocities, mass matrix, forces, substitution, reduced mass, rewritten
        ``[x, q_K...]``, ``[x', v_K...]``, ``diag(m_eq, M_KK)``, ``[m_eq x'', Q_K]``, the
        substitution of the eliminated coordinate and velocity, ``m_eq``, the surfaces
        followed by the mesh deflections and the mesh forces (in the order given; ``None`` for
        a force that still reads an eliminated coordinate).

    Raises
    ------
    SpecError
        The definition is not linear with constant coefficients in the eliminated
        coordinates, the mass matrix is not diagonal, or the reduced equations, a surface
        or a mesh deflection still depend on an eliminated coordinate (naming the
        element's field).
    """
    from .expand import _expand_in_states

    spec = model.spec
    red = spec.reduction
    assert red is not None
    where = "reduction.definition"
    t = ns.t
    kept_names = set(red.keep)
    K = [i for i, qi in enumerate(q) if qi.name in kept_names]
    E = [i for i in range(len(q)) if i not in K]
    if not M.is_diagonal():
        raise SpecError("reduction needs a diagonal mass matrix", file=spec.path, field=where)
    definition, a, s, k = _split_definition(spec, ns.sum_terms(red.definition), q, v, E, t)
    x = sp.Symbol(red.coordinate, real=True)
    xd = sp.Symbol(red.velocity, real=True)
    qK = [q[i] for i in K]
    vK = [v[i] for i in K]

    def ddt(e: sp.Expr) -> sp.Expr:
        return sp.diff(e, t) + sum(sp.diff(e, qj) * vj for qj, vj in zip(qK, vK) if qj in e.free_symbols)

    sdot = ddt(s)
    others_E = [i for i in E if i != k]
    sub = {q[k]: (x - s - sum(a[i] * q[i] for i in others_E)) / a[k],
           v[k]: (xd - sdot - sum(a[i] * v[i] for i in others_E)) / a[k]}
    states = tuple([x, *qK, xd, *vK])
    # nonsmooth functions of the kept states only (the dynamic backlash's Max) are held as
    # symbols while the equations are expanded: sympy re-evaluates a Max each time a tree
    # that contains it is rebuilt (a 6-DOF pair took 34 s instead of 2 s)
    hidden: dict[sp.Expr, sp.Symbol] = {}
    elim = {q[i] for i in E} | {v[i] for i in E}

    def hide(e: sp.Basic) -> sp.Basic:
        if isinstance(e, _NONSMOOTH) and not (e.free_symbols & elim):
            if e not in hidden:
                hidden[e] = sp.Dummy(f"h{len(hidden)}")
            return hidden[e]
        if not e.args or isinstance(e, sp.Symbol):
            return e
        new = [hide(arg) for arg in e.args]
        return e.func(*new) if any(a is not b for a, b in zip(new, e.args)) else e

    Q = Q.applyfunc(hide)
    # A mesh whose deflection is the definition (the usual case: the DTE of its gear_mesh)
    # sees the coordinates only through it and its rate: replace those sums by x and x'
    # directly, so the equations keep their structure (no expansion to cancel the rotations).
    everything = list(zip(q, v))
    d_rate = sp.diff(definition, t) + sum(sp.diff(definition, qi) * vi for qi, vi in everything
                                          if qi in definition.free_symbols)
    direct = Q.applyfunc(lambda e: e.subs(definition, x).subs(d_rate, xd))
    is_direct = not any(e.has(*[q[i] for i in E], *[v[i] for i in E]) for e in direct)
    if is_direct:
        accK = {q[i]: direct[i, 0] / M[i, i] for i in K}
        acc = sum(a[i] * direct[i, 0] / M[i, i] for i in E if a[i] != 0)
    else:
        accK = {q[i]: _expand_in_states(Q[i, 0].subs(sub), states, t, blocks=True) / M[i, i] for i in K}
        acc = _expand_in_states(sum(a[i] * Q[i, 0] / M[i, i] for i in E if a[i] != 0).subs(sub), states, t,
                                blocks=True)
    acc = acc + _second_derivative(model, ns, red, E, q, qK, vK, accK)
    left = [q[i] for i in others_E] + [v[i] for i in others_E]
    exprs = [acc, *accK.values()]
    bad = sorted({str(o) for o in left if any(e.has(o) for e in exprs)})
    if bad:
        raise SpecError(f"cannot reduce to '{red.coordinate}': the forces still depend on {', '.join(bad)} "
                        f"(the system is not semi-definite in these coordinates)", file=spec.path, field=where)
    m_eq = 1 / sum(a[i] ** 2 / M[i, i] for i in E if a[i] != 0)
    Mr = sp.diag(m_eq, *[M[i, i] for i in K])
    Qr = sp.Matrix([m_eq * acc] + [accK[q[i]] * M[i, i] for i in K])
    eliminated = [q[i] for i in E] + [v[i] for i in E]

    def in_new_states(g: sp.Expr, rate: bool = False) -> sp.Expr:
        """``g`` in the new states: the definition (and with ``rate`` its rate) replaced directly
        when the equations allow it, else the eliminated coordinates substituted and expanded."""
        if is_direct:
            g = hide(g).subs(definition, x)
            g = g.subs(d_rate, xd) if rate else g
        return g if not g.has(*eliminated) else _expand_in_states(hide(g).subs(sub), states, t, blocks=True)

    rewritten = _rewrite(spec, red, surfaces, dict(meshes or {}), dict(forces or {}), surface_fields, in_new_states,
                         eliminated)
    shown = {d: e for e, d in hidden.items()}
    return [x, *qK], [xd, *vK], Mr, Qr.xreplace(shown), sub, m_eq, [g if g is None else g.xreplace(shown)
                                                                     for g in rewritten]


def _split_definition(spec, definition: sp.Expr, q: list[sp.Symbol], v: list[sp.Symbol], E: list[int],
                      t: sp.Symbol) -> tuple[sp.Expr, dict[int, sp.Expr], sp.Expr, int]:
    """``(definition, a, s, k)``: ``definition = sum_E a_i q_i + s(q_K, t)`` with constant ``a_i``,
    and ``k`` the first eliminated coordinate with ``a_k != 0`` (see :func:`reduce_keeping`)."""
    where = "reduction.definition"
    a = {i: sp.diff(definition, q[i]) for i in E}
    if any(ai.has(*q, *v, t) for ai in a.values()):
        raise SpecError("the reduced coordinate must be linear, with constant coefficients, in the "
                        "coordinates it eliminates (those not in reduction.keep)", file=spec.path, field=where)
    s = definition - sum(a[i] * q[i] for i in E)
    if s.has(*[q[i] for i in E], *v):
        raise SpecError("cannot separate the definition into eliminated and kept coordinates",
                        file=spec.path, field=where)
    nz = [i for i in E if a[i] != 0]
    if not nz:
        raise SpecError("the reduced coordinate does not depend on any eliminated coordinate",
                        file=spec.path, field=where)
    return definition, a, s, nz[0]


def _rewrite(spec, red, surfaces: list[sp.Expr], meshes: dict[str, sp.Expr], forces: dict[str, sp.Expr],
             surface_fields: Sequence[str] | None, in_new_states, eliminated: list[sp.Symbol]) -> list:
    """The surfaces, mesh deflections and mesh forces in the new states (see :func:`reduce_keeping`).

    A surface or deflection that still reads an eliminated coordinate is an error naming its
    field; such a force is ``None`` (left out of the per-mesh results)."""
    owners = list(surface_fields or ["reduction.keep"] * len(surfaces))
    owners += [f"elements.{name}.deflection" for name in meshes][len(owners) - len(surfaces):]
    rewritten = [in_new_states(g) for g in [*surfaces, *meshes.values()]]
    for g, owner in zip(rewritten, owners):
        left = sorted(str(o) for o in eliminated if g.has(o))
        if left:
            raise SpecError(f"cannot reduce to '{red.coordinate}' keeping {', '.join(red.keep)}: after the "
                            f"reduction this still depends on {', '.join(left)} (it sees a combination of the "
                            f"eliminated coordinates that the reduced coordinate does not describe)",
                            file=spec.path, field=owner)
    out = [in_new_states(W, rate=True) for W in forces.values()]
    return rewritten + [None if W.has(*eliminated) else W for W in out]


def _second_derivative(model: SymbolicModel, ns: Namespace, red, E: list[int], q: list[sp.Symbol],
                       qK: list[sp.Symbol], vK: list[sp.Symbol], accK: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    """``s''`` by the chain rule through the model's named quantities (``a``, ``alpha``, ...).

    The definition is parsed with every derived quantity as a symbol; the time derivative
    of a symbol is a new symbol defined by the derivative of its definition (computed
    once), so ``s''`` is written like a hand derivation (``alpha'' = alpha_a a'^2 +
    alpha_a a''``...) and, once inlined, repeats identical sub-expressions -- which the
    code generator computes once -- instead of sympy's fully differentiated tree (three
    times the operations for the 6-DOF pair).
    """
    from .parsing import Namespace

    nsa = Namespace(model.resolved, structured="all")
    defs: dict[sp.Symbol, sp.Expr] = dict(nsa.derived)
    t = nsa.t
    d = nsa.sum_terms(red.definition)
    s_struct = d - sum(sp.diff(d, q[i]) * q[i] for i in E)
    states = set(qK) | set(vK)
    constant: dict[sp.Symbol, bool] = {}

    def is_constant(sym: sp.Symbol) -> bool:
        if sym not in constant:
            e = defs[sym]
            constant[sym] = not (e.has(t) or e.free_symbols & states) and all(
                is_constant(x) for x in e.free_symbols if x in defs)
        return constant[sym]

    rate: dict[sp.Symbol, sp.Expr] = dict(zip(qK, vK))
    rate.update({vj: accK[qj] for qj, vj in zip(qK, vK)})

    def D(e: sp.Expr) -> sp.Expr:
        out = sp.diff(e, t)
        for sym in e.free_symbols:
            if sym in rate:
                out += sp.diff(e, sym) * rate[sym]
            elif sym in defs and not is_constant(sym):
                if sym not in rate:
                    r = sp.Dummy(f"{sym}_t")
                    rate[sym] = r
                    defs[r] = D(defs[sym])
                out += sp.diff(e, sym) * rate[sym]
        return out

    # s has no velocities: D(s) needs only q -> v; D(D(s)) needs v -> accelerations
    sddot = D(D(s_struct))
    # back to the model's own symbols: derived quantities it keeps as symbols (structured model) stay
    inline = {sym: e for sym, e in defs.items() if sym not in ns.derived}
    for _ in range(64):
        new = sddot.xreplace(inline)
        if new == sddot:
            break
        sddot = new
    # the symbols of this namespace are the model's (same names and assumptions)
    return sddot


#: functions held as symbols during the reduction (see :func:`reduce_keeping`)
_NONSMOOTH = (sp.Max, sp.Min, sp.Abs, sp.sign, sp.Heaviside)
