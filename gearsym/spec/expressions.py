"""Checking expression strings of a spec without any computer algebra.

Expressions in model files are Python/sympy syntax (``k_m*(1 + eps*cos(Omega*t))``,
``Piecewise((x - b, x > b), (0, True))``).  This module parses them with :mod:`ast`
to find the names they use and to infer their physical dimension, so that the spec
layer can report unknown symbols and unit mismatches with the field they are in,
before anything is handed to sympy.
"""

from __future__ import annotations

import ast
import keyword
from collections.abc import Callable, Mapping
from fractions import Fraction

from .units import ONE, Unit

#: Functions allowed in expressions, and the names sympy knows them by.
FUNCTIONS: dict[str, str] = {
    "sin": "sin", "cos": "cos", "tan": "tan", "exp": "exp", "log": "log",
    "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "atan": "atan", "asin": "asin",
    "acos": "acos", "atan2": "atan2", "sqrt": "sqrt", "abs": "Abs", "Abs": "Abs",
    "sign": "sign", "Max": "Max", "Min": "Min", "max": "Max", "min": "Min",
    "floor": "floor", "Heaviside": "Heaviside", "Piecewise": "Piecewise",
}
#: Constants always available.
CONSTANTS = {"pi", "E"}
#: Numeric functions of parameters, evaluated when the parameters are bound (not
#: symbolically, never inside the integrator): name -> (dimension of each argument,
#: dimension of the result), dimensions as (kg, m, s) exponents.  Their arguments
#: must be parameter names.  Implementations: :mod:`gearsym.bound_functions`.
BOUND_FUNCTIONS: dict[str, tuple[tuple[tuple[int, int, int], ...], tuple[int, int, int]]] = {
    # Weierstrass-Mandelbrot mean asperity height (D, G, lam, L, l_a) -> length
    "wm_mean_height": (((0, 0, 0), (0, 1, 0), (0, 0, 0), (0, 1, 0), (0, 1, 0)), (0, 1, 0)),
}

_DIMLESS_ARG = {"sin", "cos", "tan", "exp", "log", "sinh", "cosh", "tanh", "atan", "asin",
                "acos", "floor"}


class ExpressionError(ValueError):
    """An expression is malformed, uses an unknown name or mixes dimensions."""


def parse(text: object) -> ast.Expression:
    """Parse an expression string into an :mod:`ast` tree.

    Raises
    ------
    ExpressionError
        If ``text`` is not a string, or not a valid expression.
    """
    if isinstance(text, bool):
        raise ExpressionError(f"expected an expression, got the boolean {text}")
    if isinstance(text, (int, float)):
        text = repr(float(text))
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {type(text).__name__}")
    if not text.strip():
        raise ExpressionError("empty expression")
    try:
        return ast.parse(text.strip().replace("^", "**"), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"syntax error in '{text}': {exc.msg}") from None


def names_in(text: object) -> set[str]:
    """The variable names an expression uses (functions and constants excluded)."""
    tree = parse(text)
    out: set[str] = set()
    for node in ast.walk(tree):
        if (isinstance(node, ast.Name) and node.id not in FUNCTIONS and node.id not in CONSTANTS
                and node.id not in BOUND_FUNCTIONS):
            out.add(node.id)
        if isinstance(node, ast.Call) and not (
            isinstance(node.func, ast.Name) and (node.func.id in FUNCTIONS or node.func.id in BOUND_FUNCTIONS)
        ):
            fname = ast.unparse(node.func)
            raise ExpressionError(f"unknown function '{fname}' (known: {', '.join(sorted(FUNCTIONS))})")
        if isinstance(node, (ast.Attribute, ast.Subscript, ast.Lambda, ast.Dict, ast.Set,
                             ast.ListComp, ast.GeneratorExp, ast.Starred)):
            raise ExpressionError(f"unsupported syntax '{ast.unparse(node)}'")
    return out


def check_identifier(name: str) -> str | None:
    """Return a problem with ``name`` as a symbol name, or ``None`` if it is fine."""
    if not isinstance(name, str) or not name.isidentifier():
        return f"'{name}' is not a valid symbol name (letters, digits, underscores)"
    if keyword.iskeyword(name):
        return f"'{name}' is a Python keyword and cannot be a symbol name"
    if (name in FUNCTIONS or name in CONSTANTS or name in BOUND_FUNCTIONS
            or name in ("t", "I", "S", "N", "O", "Q")):
        return f"'{name}' is reserved (function, constant, time or sympy name)"
    return None


def infer_unit(text: object, units: Mapping[str, Unit]) -> Unit:
    """Infer the physical unit of an expression.

    Parameters
    ----------
    text
        The expression.
    units
        Unit of every name the expression may use.

    Raises
    ------
    ExpressionError
        On unknown names or dimensionally inconsistent operations; the message
        quotes the offending sub-expression.
    """
    tree = parse(text)
    names_in(text)  # raises on unknown functions / syntax
    return _Dim(units).visit(tree.body)


class _Dim:
    def __init__(self, units: Mapping[str, Unit]):
        self.units = units

    def visit(self, node: ast.AST) -> Unit:
        meth: Callable[[ast.AST], Unit] = getattr(self, "v_" + type(node).__name__, self.generic)
        return meth(node)

    def generic(self, node: ast.AST) -> Unit:
        raise ExpressionError(f"unsupported syntax '{ast.unparse(node)}'")

    def v_Constant(self, node: ast.Constant) -> Unit:
        if isinstance(node.value, bool):
            return ONE
        if not isinstance(node.value, (int, float)):
            raise ExpressionError(f"unsupported constant {node.value!r}")
        return ONE

    def v_Name(self, node: ast.Name) -> Unit:
        if node.id in CONSTANTS or node.id in ("True", "False"):
            return ONE
        if node.id not in self.units:
            raise ExpressionError(f"unknown symbol '{node.id}'")
        return self.units[node.id]

    def v_UnaryOp(self, node: ast.UnaryOp) -> Unit:
        return self.visit(node.operand)

    def _same(self, a: Unit, b: Unit, node: ast.AST, what: str) -> Unit:
        if not a.same_dimension(b):
            raise ExpressionError(
                f"unit mismatch in '{ast.unparse(node)}': {what} [{a.si_string()}] "
                f"and [{b.si_string()}]"
            )
        return a

    def v_BinOp(self, node: ast.BinOp) -> Unit:
        a = self.visit(node.left)
        if isinstance(node.op, ast.Pow):
            exp = _const(node.right)
            if exp is None:
                b = self.visit(node.right)
                if not b.dimensionless:
                    raise ExpressionError(f"exponent of '{ast.unparse(node)}' must be dimensionless")
                if not a.dimensionless:
                    raise ExpressionError(
                        f"'{ast.unparse(node)}': a dimensional base needs a numeric exponent"
                    )
                return ONE
            return a ** exp
        b = self.visit(node.right)
        if isinstance(node.op, (ast.Add, ast.Sub)):
            return self._same(a, b, node, "terms")
        if isinstance(node.op, ast.Mult):
            return a * b
        if isinstance(node.op, ast.Div):
            return a / b
        if isinstance(node.op, (ast.BitAnd, ast.BitOr)):
            return ONE
        raise ExpressionError(f"unsupported operator in '{ast.unparse(node)}'")

    def v_Compare(self, node: ast.Compare) -> Unit:
        a = self.visit(node.left)
        for comp in node.comparators:
            self._same(a, self.visit(comp), node, "compared sides")
        return ONE

    def v_BoolOp(self, node: ast.BoolOp) -> Unit:
        for v in node.values:
            self.visit(v)
        return ONE

    def v_Tuple(self, node: ast.Tuple) -> Unit:
        raise ExpressionError(f"unexpected tuple '{ast.unparse(node)}'")

    def v_Call(self, node: ast.Call) -> Unit:
        name = node.func.id  # type: ignore[attr-defined]
        args = node.args
        if name == "Piecewise":
            unit: Unit | None = None
            for arg in args:
                if not isinstance(arg, ast.Tuple) or len(arg.elts) != 2:
                    raise ExpressionError(
                        f"Piecewise takes (value, condition) pairs: '{ast.unparse(node)}'"
                    )
                u = self.visit(arg.elts[0])
                self.visit(arg.elts[1])
                unit = u if unit is None else self._same(unit, u, node, "branches")
            if unit is None:
                raise ExpressionError("Piecewise needs at least one (value, condition) pair")
            return unit
        units = [self.visit(a) for a in args]
        if name in BOUND_FUNCTIONS:
            want, result = BOUND_FUNCTIONS[name]
            if len(units) != len(want):
                raise ExpressionError(f"{name}() takes {len(want)} arguments: '{ast.unparse(node)}'")
            for i, (u, w) in enumerate(zip(units, want)):
                wu = Unit(1.0, tuple(Fraction(d) for d in w))
                if not u.same_dimension(wu):
                    raise ExpressionError(
                        f"argument {i + 1} of {name}() must be [{wu.si_string()}] in "
                        f"'{ast.unparse(node)}', got [{u.si_string()}]")
            return Unit(1.0, tuple(Fraction(d) for d in result))
        if name in _DIMLESS_ARG:
            if len(units) != 1:
                raise ExpressionError(f"{name}() takes one argument: '{ast.unparse(node)}'")
            if not units[0].dimensionless:
                raise ExpressionError(
                    f"argument of {name}() must be dimensionless in '{ast.unparse(node)}', "
                    f"got [{units[0].si_string()}]"
                )
            return ONE
        if name == "sqrt":
            return units[0] ** Fraction(1, 2)
        if name in ("abs", "Abs"):
            return units[0]
        if name in ("sign", "Heaviside"):
            return ONE
        if name in ("Max", "Min", "max", "min", "atan2"):
            u = units[0]
            for other in units[1:]:
                self._same(u, other, node, "arguments")
            return ONE if name == "atan2" else u
        raise ExpressionError(f"unknown function '{name}'")


def _const(node: ast.AST) -> Fraction | None:
    try:
        value = ast.literal_eval(node)
    except (ValueError, SyntaxError, TypeError):
        return None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return Fraction(value).limit_denominator(1000)
    return None


def bound_calls(text: object) -> list[tuple[str, list[str | None]]]:
    """Calls of :data:`BOUND_FUNCTIONS` in an expression: ``(name, argument names)``.

    An argument that is not a plain name is reported as ``None``.
    """
    out: list[tuple[str, list[str | None]]] = []
    for node in ast.walk(parse(text)):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in BOUND_FUNCTIONS):
            out.append((node.func.id, [a.id if isinstance(a, ast.Name) else None for a in node.args]))
    return out
