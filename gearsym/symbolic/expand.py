"""Expansion and folding of the symbolic equations (shared by the model and its reductions)."""

from __future__ import annotations

import sympy as sp

__all__ = ["_expand_in_states", "_fold_segments"]


def _expand_in_states(expr: sp.Expr, states: tuple[sp.Symbol, ...], t: sp.Symbol,
                      blocks: bool = False) -> sp.Expr:
    """``sp.expand(expr)``, except when ``expr`` has time-dependent denominators.

    With a rational function of time (e.g. a time-varying base radius ``rb2(t)`` in
    a reduction ``q = q2 + e(t)/rb2(t)``) a full expansion multiplies every product of
    sums out over the expanded denominators (a 555-operation right-hand side became
    24 000 operations and lost the cancellation ``rb2*(e/rb2) = e``).  In that case the
    expression is expanded in the states only: every state-free subexpression is kept
    as one block (so identical blocks still cancel when the products are rebuilt).
    Models without such denominators keep the full expansion, unless ``blocks`` is
    true (used for time-varying right-hand sides, e.g. with schedule-segment
    ``Piecewise`` or Fourier excitations, whose full expansion multiplies every
    inlined derived quantity out: models/vaishya_singh.toml took 15 s for 1 766
    generated operations (formulation A) and 16 s for 10 093 (STE only), against 2 s
    for 1 645 and 3 s for 627 with the blocks kept).
    """
    rational_in_t = any(p.exp.is_negative and p.base.has(t) for p in expr.atoms(sp.Pow))
    if not rational_in_t and not blocks:
        return sp.expand(expr)
    wanted = set(states)
    blocks: dict[sp.Expr, sp.Dummy] = {}

    def atomize(e: sp.Basic) -> sp.Basic:
        if e.is_Atom:
            return e
        if isinstance(e, sp.Expr) and not isinstance(e, sp.Piecewise) and not (e.free_symbols & wanted):
            if e not in blocks:
                blocks[e] = sp.Dummy(f"c{len(blocks)}")
            return blocks[e]
        return e.func(*[atomize(a) for a in e.args])

    out = sp.expand(atomize(expr))
    return out.xreplace({d: e for e, d in blocks.items()})


def _fold_segments(expr: sp.Expr, segments: dict[sp.Symbol, int]) -> sp.Expr:
    """``sp.piecewise_fold(expr)``, one schedule segment at a time.

    Folding a sum of many schedule ``Piecewise`` (piecewise-constant stiffness,
    damping, load sharing, friction sign, ...) with ``piecewise_fold`` multiplies out
    every combination of their branches (exponential in time and memory).  The
    segment index of a schedule takes only the values ``0 .. n-1``, so the exact fold
    is one branch per segment: ``Piecewise((expr|seg=0, seg < 0.5), (expr|seg=1,
    seg < 1.5), ..., (expr|seg=n-1, True))``, each branch folded in the remaining
    (state-dependent) conditions only.

    Parameters
    ----------
    expr
        The expression to fold.
    segments
        Segment-index symbol of each schedule -> number of segments.
    """
    present = [(sym, n) for sym, n in segments.items() if expr.has(sym)]
    if not present:
        return sp.piecewise_fold(expr)
    sym, n = present[0]
    rest = {k: v for k, v in segments.items() if k != sym}
    pieces = [(_fold_segments(expr.subs(sym, i), rest), sym < sp.Float(i + 0.5)) for i in range(n - 1)]
    pieces.append((_fold_segments(expr.subs(sym, n - 1), rest), sp.true))
    return sp.Piecewise(*pieces)
