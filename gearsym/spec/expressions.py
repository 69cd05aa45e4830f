"""Checking expression strings of a spec without any computer algebra.

Expressions in model files are Python/sympy syntax (``k_m*(1 + eps*cos(Omega*t))``,
``Piecewise((x - b, x > b), (0, True))``).  :mod:`gearsym.spec.syntax` reads them with a
whitelist parser into a checked tree; this module finds the names they use and infers
their physical dimension, so that the spec layer can report unknown symbols and unit
mismatches with the field they are in, before anything is handed to sympy.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from . import syntax as sx
from .names import check_symbol_name
from .syntax import BOUND_FUNCTIONS, CONSTANTS, FUNCTIONS, Expression, ExpressionError
from .units import ONE, Unit

__all__ = ["BOUND_FUNCTIONS", "CONSTANTS", "FUNCTIONS", "ExpressionError", "Expression", "TableContext",
           "bound_calls", "check_identifier", "constant_value", "infer_unit", "names_in", "parse", "rename",
           "table_calls"]

_DIMLESS_ARG = {"sin", "cos", "tan", "exp", "log", "sinh", "cosh", "tanh", "atan", "asin",
                "acos", "floor"}


def parse(text: object) -> Expression:
    """Parse and check an expression (see :mod:`gearsym.spec.syntax` for the language).

    Raises
    ------
    ExpressionError
        If ``text`` is not a string or number, or not a valid expression.
    """
    return sx.parse_checked(text)


def names_in(text: object) -> set[str]:
    """The names an expression uses: variables and the tables it calls (the functions of the
    language and constants excluded)."""
    out = set()
    for n in sx.walk(parse(text).body):
        if isinstance(n, sx.Name) and n.id not in CONSTANTS:
            out.add(n.id)
        elif isinstance(n, sx.Call) and n.func not in FUNCTIONS and n.func not in BOUND_FUNCTIONS:
            out.add(n.func)
    return out


def table_calls(text: object) -> list[tuple[str, tuple[sx.Node, ...]]]:
    """The calls of names that are not functions of the language (tables of the model):
    ``(name, argument nodes)``, in the order written."""
    return [(n.func, n.args) for n in sx.walk(parse(text).body)
            if isinstance(n, sx.Call) and n.func not in FUNCTIONS and n.func not in BOUND_FUNCTIONS]


@dataclass(frozen=True)
class TableContext:
    """What unit inference needs to know of a model's tables.

    Attributes
    ----------
    tables
        Name -> :class:`~gearsym.spec.tables.Table`.
    phases
        The phase names of the model's schedules (``NAME_phase``): the arguments a table
        over the mesh phase takes.
    """

    tables: Mapping[str, Any]
    phases: frozenset[str] = frozenset()


def check_identifier(name: str) -> str | None:
    """Return a problem with ``name`` as a symbol name, or ``None`` if it is fine
    (see :func:`gearsym.spec.names.check_symbol_name`)."""
    return check_symbol_name(name)


def bound_calls(text: object) -> list[tuple[str, list[str | None]]]:
    """Calls of :data:`BOUND_FUNCTIONS` in an expression: ``(name, argument names)``.

    An argument that is not a plain name is reported as ``None``.
    """
    return [(n.func, [a.id if isinstance(a, sx.Name) else None for a in n.args])
            for n in sx.walk(parse(text).body) if isinstance(n, sx.Call) and n.func in BOUND_FUNCTIONS]


def rename(text: str, mapping: Mapping[str, str]) -> str:
    """``text`` with the names in ``mapping`` replaced (the text must parse)."""
    parse(text)  # only names, numbers and operators: a word-boundary replacement is exact
    pattern = re.compile(r"(?<![A-Za-z0-9_.])(" + "|".join(map(re.escape, mapping)) + r")(?![A-Za-z0-9_])")
    return pattern.sub(lambda m: mapping[m.group(1)], text)


def constant_value(text: str, env: Mapping[str, float]) -> float | None:
    """Numeric value of an expression of constants and the names in ``env`` only.

    ``None`` if it uses anything else (time, states, schedules, conditions, unknown
    names) or if the value is not a finite number.
    """
    try:
        expr = parse(text)
    except ExpressionError:
        return None
    try:
        v = _Eval(env).visit(expr.body)
    except (KeyError, ArithmeticError, ValueError, TypeError):
        return None
    return v if math.isfinite(v) else None


class _Eval:
    def __init__(self, env: Mapping[str, float]):
        self.env = env

    def visit(self, n: sx.Node) -> float:
        if isinstance(n, sx.Number):
            return float(n.text)
        if isinstance(n, sx.Name):
            return sx.CONSTANT_VALUES[n.id] if n.id in CONSTANTS else float(self.env[n.id])
        if isinstance(n, sx.Unary):
            v = self.visit(n.operand)
            return -v if n.op == "-" else v
        if isinstance(n, sx.Chain):
            acc = self.visit(n.first)
            for op, x in n.rest:
                v = self.visit(x)
                acc = acc + v if op == "+" else acc - v if op == "-" else acc * v if op == "*" else acc / v
            return acc
        if isinstance(n, sx.Power):
            return float(self.visit(n.base) ** self.visit(n.exponent))
        if isinstance(n, sx.Call) and n.func in sx._MATH:
            return float(sx._MATH[n.func](*[self.visit(a) for a in n.args]))
        raise KeyError("not constant")


def infer_unit(text: object, units: Mapping[str, Unit], tables: TableContext | None = None) -> Unit:
    """Infer the physical unit of an expression.

    Parameters
    ----------
    text
        The expression.
    units
        Unit of every name the expression may use.
    tables
        The model's tables (calls ``k(mesh_phase)`` and bare names ``k`` of tables that
        declare their arguments); ``None``: no tables.

    Raises
    ------
    ExpressionError
        On unknown names or dimensionally inconsistent operations; the message
        quotes the offending sub-expression.
    """
    expr = parse(text)
    return _Dim(units, expr, tables).visit(expr.body)


class _Dim:
    """Units of a checked tree (recursion is bounded by the nesting-depth limit)."""

    def __init__(self, units: Mapping[str, Unit], expr: Expression, tables: TableContext | None = None):
        self.units = units
        self.expr = expr
        self.tables = tables if tables is not None else TableContext({})

    def src(self, node: sx.Node) -> str:
        return self.expr.source(node)

    def visit(self, node: sx.Node) -> Unit:
        if isinstance(node, (sx.Number, sx.Boolean)):
            return ONE
        if isinstance(node, sx.Name):
            if node.id in CONSTANTS:
                return ONE
            if node.id not in self.units and node.id in self.tables.tables:
                return self.bare_table(node)
            if node.id not in self.units:
                close = difflib.get_close_matches(node.id, sorted(self.units), n=1, cutoff=0.6)
                raise ExpressionError(f"unknown symbol '{node.id}'" + (f"; did you mean '{close[0]}'?" if close else ""))
            return self.units[node.id]
        if isinstance(node, sx.Unary):
            return self.visit(node.operand)
        if isinstance(node, sx.Chain):
            return self.chain(node)
        if isinstance(node, sx.Power):
            return self.power(node)
        if isinstance(node, sx.Compare):
            self._same(self.visit(node.left), self.visit(node.right), node, "compared sides")
            return ONE
        if isinstance(node, sx.Logic):
            for v in node.operands:
                self.visit(v)
            return ONE
        if isinstance(node, sx.Piecewise):
            unit: Unit | None = None
            for val, cond in node.pairs:
                u = self.visit(val)
                self.visit(cond)
                unit = u if unit is None else self._same(unit, u, node, "branches")
            assert unit is not None
            return unit
        if isinstance(node, sx.Call):
            return self.call(node)
        raise ExpressionError(f"unsupported syntax '{self.src(node)}'")  # pragma: no cover

    def _same(self, a: Unit, b: Unit, node: sx.Node, what: str) -> Unit:
        if not a.same_dimension(b):
            raise ExpressionError(f"unit mismatch in '{self.src(node)}': {what} [{a.si_string()}] "
                                  f"and [{b.si_string()}]")
        return a

    def chain(self, node: sx.Chain) -> Unit:
        acc = self.visit(node.first)
        for op, x in node.rest:
            u = self.visit(x)
            if op in "+-":
                self._same(acc, u, node, "terms")
            else:
                acc = acc * u if op == "*" else acc / u
        return acc

    def power(self, node: sx.Power) -> Unit:
        a = self.visit(node.base)
        exp = self.expr.const.get(id(node.exponent))
        if exp is None:
            b = self.visit(node.exponent)
            if not b.dimensionless:
                raise ExpressionError(f"exponent of '{self.src(node)}' must be dimensionless")
            if not a.dimensionless:
                raise ExpressionError(f"'{self.src(node)}': a dimensional base needs a numeric exponent")
            return ONE
        return a ** Fraction(exp).limit_denominator(1000)

    def bare_table(self, node: sx.Name) -> Unit:
        """The unit of a table used by its name: its arguments are declared (checked with the table)."""
        table = self.tables.tables[node.id]
        if not table.arguments:
            raise ExpressionError(f"table '{node.id}' is used by its name but declares no arguments: call it "
                                  f"({node.id}(...)) or declare its arguments (tables.{node.id}.arguments)")
        return Unit(1.0, table.dims.dims)

    def table_call(self, node: sx.Call) -> Unit:
        """The unit of a table call, after checking its arguments against the table's domain."""
        from .syntax import unknown_function

        table = self.tables.tables.get(node.func)
        if table is None:
            raise ExpressionError(unknown_function(node.func, self.tables.tables))
        src = self.src(node)
        if len(node.args) != len(table.axes):
            raise ExpressionError(f"table '{node.func}' takes {len(table.axes)} argument"
                                  f"{'s' if len(table.axes) != 1 else ''} (its domain), got {len(node.args)}: "
                                  f"'{src}'")
        for i, (arg, axis) in enumerate(zip(node.args, table.axes)):
            what = f"argument {i + 1} of table '{node.func}' in '{src}'"
            if axis.kind == "phase":
                if not (isinstance(arg, sx.Name) and arg.id in self.tables.phases):
                    raise ExpressionError(f"{what} must be the phase of a schedule "
                                          f"({', '.join(sorted(self.tables.phases)) or 'no schedules'}): the table "
                                          f"is over the mesh phase, got '{self.src(arg)}'")
                continue
            if i == 0 and table.period is not None and not (isinstance(arg, sx.Name) and arg.id == "t"):
                raise ExpressionError(f"{what} must be the time t: the table is periodic in time")
            u = self.visit(arg)
            if not u.same_dimension(axis.dims):
                raise ExpressionError(f"unit mismatch: {what} is [{u.si_string()}], the table's domain is "
                                      f"{axis.unit} [{axis.dims.si_string()}]")
        return Unit(1.0, table.dims.dims)

    def call(self, node: sx.Call) -> Unit:
        name = node.func
        if name not in FUNCTIONS and name not in BOUND_FUNCTIONS:
            return self.table_call(node)
        units = [self.visit(a) for a in node.args]
        if name in BOUND_FUNCTIONS:
            want, result = BOUND_FUNCTIONS[name]
            for i, (u, w) in enumerate(zip(units, want)):
                wu = Unit(1.0, tuple(Fraction(d) for d in w))
                if not u.same_dimension(wu):
                    raise ExpressionError(
                        f"argument {i + 1} of {name}() must be [{wu.si_string()}] in "
                        f"'{self.src(node)}', got [{u.si_string()}]")
            return Unit(1.0, tuple(Fraction(d) for d in result))
        if name in _DIMLESS_ARG:
            if not units[0].dimensionless:
                raise ExpressionError(
                    f"argument of {name}() must be dimensionless in '{self.src(node)}', "
                    f"got [{units[0].si_string()}]")
            return ONE
        if name == "sqrt":
            return units[0] ** Fraction(1, 2)
        if name in ("abs", "Abs"):
            return units[0]
        if name in ("sign", "Heaviside"):
            if name == "Heaviside" and len(units) == 2 and not units[1].dimensionless:
                raise ExpressionError(f"the value at 0 of Heaviside() must be dimensionless in "
                                      f"'{self.src(node)}'")
            return ONE
        # Max, Min, max, min, atan2
        u = units[0]
        for other in units[1:]:
            self._same(u, other, node, "arguments")
        return ONE if name == "atan2" else u
