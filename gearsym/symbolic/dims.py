"""Physical dimensions of sympy expressions (mass, length, time exponents).

The spec layer infers the unit of every name a model declares (``ModelSpec.units``);
:class:`Dimensions` extends that to the sympy expressions of the symbolic layer, so
that the dimensionless form can divide every sub-expression by the scale of its own
dimension.  Angles are dimensionless (as in SI).
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction

import sympy as sp
from sympy.core.relational import Relational

Dim = tuple[Fraction, Fraction, Fraction]
ZERO: Dim = (Fraction(0), Fraction(0), Fraction(0))
MASS: Dim = (Fraction(1), Fraction(0), Fraction(0))
LENGTH: Dim = (Fraction(0), Fraction(1), Fraction(0))
TIME: Dim = (Fraction(0), Fraction(0), Fraction(1))

_SAME_AS_ARGS = (sp.Abs, sp.Max, sp.Min)


def add(a: Dim, b: Dim) -> Dim:
    """Dimension of a product."""
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def scale(a: Dim, k: Fraction) -> Dim:
    """Dimension of a power."""
    return (a[0] * k, a[1] * k, a[2] * k)


def neg(a: Dim) -> Dim:
    """Dimension of a reciprocal."""
    return (-a[0], -a[1], -a[2])


class DimensionError(ValueError):
    """An expression mixes dimensions (e.g. a sum of a length and a time)."""


class Dimensions:
    """Dimensions of expressions over a table of symbols.

    Parameters
    ----------
    table
        Dimension of every symbol that may appear (others are dimensionless, e.g.
        surface sides ``sigma_j`` and schedule indices).
    """

    def __init__(self, table: Mapping[sp.Symbol, Dim]):
        self.table = dict(table)
        self._cache: dict[sp.Basic, Dim | None] = {}

    def __call__(self, e: sp.Basic) -> Dim:
        """The dimension of ``e`` (numbers and unknown symbols are dimensionless)."""
        d = self._dims(e)
        return ZERO if d is None else d

    def _dims(self, e: sp.Basic) -> Dim | None:
        """``None`` for a pure number (it takes the dimension of whatever it is added to)."""
        if e in self._cache:
            return self._cache[e]
        out = self._compute(e)
        self._cache[e] = out
        return out

    def _compute(self, e: sp.Basic) -> Dim | None:  # noqa: C901 - a flat dispatch
        if e.is_Number or e in (sp.pi, sp.E) or isinstance(e, sp.logic.boolalg.BooleanAtom):
            return None
        if isinstance(e, sp.Symbol):
            return self.table.get(e, ZERO)
        if isinstance(e, sp.Add):
            found = None
            for a in e.args:
                d = self._dims(a)
                if d is None:
                    continue
                if found is None:
                    found = d
                elif d != found:
                    raise DimensionError(f"terms of different dimensions in '{sp.sstr(e)[:120]}'")
            return found
        if isinstance(e, sp.Mul):
            out = None
            for a in e.args:
                d = self._dims(a)
                if d is not None:
                    out = d if out is None else add(out, d)
            return out
        if isinstance(e, sp.Pow):
            d = self._dims(e.base)
            if d is None or d == ZERO:
                return d
            if not e.exp.is_Number:
                raise DimensionError(f"a dimensional base with a symbolic exponent in '{sp.sstr(e)[:120]}'")
            return scale(d, Fraction(str(e.exp)) if e.exp.is_Float else Fraction(int(e.exp.p), int(e.exp.q)))
        if isinstance(e, sp.Piecewise):
            found = None
            for v, _ in e.args:
                d = self._dims(v)
                if d is not None:
                    found = d
                    break
            return found
        if isinstance(e, _SAME_AS_ARGS):
            for a in e.args:
                d = self._dims(a)
                if d is not None:
                    return d
            return None
        if isinstance(e, sp.atan2):
            return ZERO
        if isinstance(e, (Relational, sp.And, sp.Or, sp.Not)):
            return ZERO
        return ZERO  # sin, cos, exp, sign, Heaviside, floor, ...: dimensionless


def monomial(d: Dim, symbols: tuple[sp.Expr, sp.Expr, sp.Expr]) -> sp.Expr:
    """``M**d[0] * L**d[1] * T**d[2]`` for scale expressions ``(M, L, T)``."""
    out = sp.Integer(1)
    for k, s in zip(d, symbols):
        if k:
            out *= s ** sp.Rational(k.numerator, k.denominator)
    return out
