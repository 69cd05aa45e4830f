"""Translate sympy expressions into CasADi SX by walking the expression tree.

``lambdify`` cannot emit CasADi's ``if_else`` for ``Piecewise``; walking the tree
can, and it maps every sympy construct the spec language allows.  Identical
sympy sub-expressions map to the same SX node (a cache keyed by the sub-tree), so
shared terms are computed once in the generated C.
"""

from __future__ import annotations

from collections.abc import Mapping

import casadi as ca
import sympy as sp
from sympy.logic.boolalg import BooleanFalse, BooleanTrue

from ..errors import CompileError
from ..symbolic.budget import Budget

_UNARY = {
    sp.sin: ca.sin, sp.cos: ca.cos, sp.tan: ca.tan, sp.exp: ca.exp, sp.log: ca.log,
    sp.sinh: ca.sinh, sp.cosh: ca.cosh, sp.tanh: ca.tanh, sp.atan: ca.atan, sp.asin: ca.asin,
    sp.acos: ca.acos, sp.Abs: ca.fabs, sp.sign: ca.sign, sp.floor: ca.floor, sp.ceiling: ca.ceil,
}


class SXTranslator:
    """Translate sympy expressions to CasADi SX given a symbol map.

    Parameters
    ----------
    symbols
        Maps every free sympy symbol to an SX scalar.
    budget
        The deadline of the code generation, checked once per distinct sub-expression
        (:class:`gearsym.symbolic.budget.Budget`).
    """

    def __init__(self, symbols: Mapping[sp.Symbol, ca.SX], budget: Budget | None = None):
        self.symbols = dict(symbols)
        self.cache: dict[sp.Basic, ca.SX] = {}
        self.budget = budget

    def __call__(self, expr: sp.Basic) -> ca.SX:
        """Translate one expression (scalar)."""
        if expr in self.cache:
            return self.cache[expr]
        if self.budget is not None:
            self.budget.check()
        out = self._walk(expr)
        self.cache[expr] = out
        return out

    def matrix(self, mat: sp.Matrix) -> ca.SX:
        """Translate a sympy Matrix into a dense SX matrix of the same shape."""
        rows, cols = mat.shape
        out = ca.SX.zeros(rows, cols)
        for i in range(rows):
            for j in range(cols):
                out[i, j] = self(mat[i, j])
        return out

    def _walk(self, e: sp.Basic) -> ca.SX:  # noqa: C901 - a flat dispatch is clearest here
        if isinstance(e, sp.Symbol):
            if e not in self.symbols:
                raise CompileError(f"symbol '{e}' has no value in the generated function")
            return self.symbols[e]
        if isinstance(e, (sp.Integer, sp.Rational, sp.Float)) or e.is_Number:
            return ca.SX(float(e))
        if e is sp.pi:
            return ca.SX(float(sp.pi))
        if e is sp.E:
            return ca.SX(float(sp.E))
        if isinstance(e, BooleanTrue):
            return ca.SX(1.0)
        if isinstance(e, BooleanFalse):
            return ca.SX(0.0)
        if isinstance(e, sp.Add):
            args = [self(a) for a in e.args]
            out = args[0]
            for a in args[1:]:
                out = out + a
            return out
        if isinstance(e, sp.Mul):
            args = [self(a) for a in e.args]
            out = args[0]
            for a in args[1:]:
                out = out * a
            return out
        if isinstance(e, sp.Pow):
            base, ex = e.args
            b = self(base)
            if ex.is_Integer:
                n = int(ex)
                if n == 2:
                    return (b * b)
                if n == -1:
                    return 1 / b
                if n == -2:
                    return 1 / (b * b)
                if 0 < n <= 4:
                    out = b
                    for _ in range(n - 1):
                        out = out * b
                    return out
                return ca.constpow(b, float(n))
            if ex == sp.Rational(1, 2):
                return ca.sqrt(b)
            if ex == sp.Rational(-1, 2):
                return 1 / ca.sqrt(b)
            if ex.is_Number:
                return ca.constpow(b, float(ex))
            return ca.power(b, self(ex))
        if isinstance(e, sp.Piecewise):
            out = None
            for val, cond in reversed(e.args):
                v = self(val)
                if cond is sp.true or isinstance(cond, BooleanTrue):
                    out = v
                else:
                    c = self(cond)
                    out = ca.if_else(c, v, out if out is not None else ca.SX(float("nan")))
            return out
        if isinstance(e, sp.StrictLessThan):
            return self(e.lhs) < self(e.rhs)
        if isinstance(e, sp.LessThan):
            return self(e.lhs) <= self(e.rhs)
        if isinstance(e, sp.StrictGreaterThan):
            return self(e.lhs) > self(e.rhs)
        if isinstance(e, sp.GreaterThan):
            return self(e.lhs) >= self(e.rhs)
        if isinstance(e, sp.Eq):
            return self(e.lhs) == self(e.rhs)
        if isinstance(e, sp.Ne):
            return self(e.lhs) != self(e.rhs)
        if isinstance(e, sp.And):
            args = [self(a) for a in e.args]
            out = args[0]
            for a in args[1:]:
                out = ca.logic_and(out, a)
            return out
        if isinstance(e, sp.Or):
            args = [self(a) for a in e.args]
            out = args[0]
            for a in args[1:]:
                out = ca.logic_or(out, a)
            return out
        if isinstance(e, sp.Not):
            return ca.logic_not(self(e.args[0]))
        if isinstance(e, (sp.Max, sp.Min)):
            fn = ca.fmax if isinstance(e, sp.Max) else ca.fmin
            args = [self(a) for a in e.args]
            out = args[0]
            for a in args[1:]:
                out = fn(out, a)
            return out
        if isinstance(e, sp.Heaviside):
            x = self(e.args[0])
            return ca.if_else(x > 0, 1.0, ca.if_else(x < 0, 0.0, 0.5))
        if isinstance(e, sp.atan2):
            return ca.atan2(self(e.args[0]), self(e.args[1]))
        if isinstance(e, sp.Mod):
            return ca.fmod(self(e.args[0]), self(e.args[1]))
        fn = _UNARY.get(e.func)
        if fn is not None:
            return fn(self(e.args[0]))
        raise CompileError(f"cannot generate code for '{e.func.__name__}' in '{e}'")
