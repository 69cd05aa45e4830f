"""The checked expression tree of the spec language, its limits and function tables.

Produced by :mod:`gearsym.spec.syntax` (the parser), read by the spec layer (names,
units, constants) and by the symbolic layer (sympy objects are built from it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: Longest expression (characters).
MAX_LENGTH = 200_000
#: Most nodes in one expression.
MAX_NODES = 50_000
#: Deepest nesting of parentheses, calls, powers and unary operators.
MAX_DEPTH = 40
#: Most digits of one number.
MAX_LITERAL_DIGITS = 30
#: Largest constant exponent (in magnitude; nested powers multiply their exponents).
MAX_EXPONENT = 64
#: Largest magnitude of a number or of a constant sub-expression.
MAX_MAGNITUDE = 1e300
#: Most arguments of one call (``Max``/``Min`` arguments, ``Piecewise`` pairs).
MAX_ARGS = 256

#: Functions allowed in expressions, and the names sympy knows them by.
FUNCTIONS: dict[str, str] = {
    "sin": "sin", "cos": "cos", "tan": "tan", "exp": "exp", "log": "log",
    "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "atan": "atan", "asin": "asin",
    "acos": "acos", "atan2": "atan2", "sqrt": "sqrt", "abs": "Abs", "Abs": "Abs",
    "sign": "sign", "Max": "Max", "Min": "Min", "max": "Max", "min": "Min",
    "floor": "floor", "Heaviside": "Heaviside", "Piecewise": "Piecewise",
}
#: Constants always available, with their values.
CONSTANT_VALUES = {"pi": math.pi, "E": math.e}
CONSTANTS = set(CONSTANT_VALUES)
#: Numeric functions of parameters, evaluated when the parameters are bound (not
#: symbolically, never inside the integrator): name -> (dimension of each argument,
#: dimension of the result), dimensions as (kg, m, s) exponents.  Their arguments
#: must be parameter names.  Implementations: :mod:`gearsym.bound_functions`.
BOUND_FUNCTIONS: dict[str, tuple[tuple[tuple[int, int, int], ...], tuple[int, int, int]]] = {
    # Weierstrass-Mandelbrot mean asperity height (D, G, lam, L, l_a) -> length
    "wm_mean_height": (((0, 0, 0), (0, 1, 0), (0, 0, 0), (0, 1, 0), (0, 1, 0)), (0, 1, 0)),
}
#: Number of arguments of each callable (min, max; ``None``: no upper bound).
ARITY: dict[str, tuple[int, int | None]] = {
    **{f: (1, 1) for f in ("sin", "cos", "tan", "exp", "log", "sinh", "cosh", "tanh", "atan", "asin",
                           "acos", "sqrt", "abs", "Abs", "sign", "floor")},
    "atan2": (2, 2), "Heaviside": (1, 2),
    **{f: (2, None) for f in ("Max", "Min", "max", "min")},
    **{f: (len(args), len(args)) for f, (args, _) in BOUND_FUNCTIONS.items()},
}


class ExpressionError(ValueError):
    """An expression is malformed, uses an unknown name or mixes dimensions."""


# ------------------------------------------------------------------ the tree


@dataclass(frozen=True, slots=True)
class Node:
    """Base of the checked expression tree; ``start:end`` is the source span."""

    start: int
    end: int


@dataclass(frozen=True, slots=True)
class Number(Node):
    """A decimal literal; ``text`` as written (sympy reads it with full precision)."""

    text: str
    is_int: bool


@dataclass(frozen=True, slots=True)
class Name(Node):
    """A symbol, ``pi`` or ``E``."""

    id: str


@dataclass(frozen=True, slots=True)
class Boolean(Node):
    """``True`` or ``False`` (a condition)."""

    value: bool


@dataclass(frozen=True, slots=True)
class Unary(Node):
    """``+x`` or ``-x``."""

    op: str
    operand: Node


@dataclass(frozen=True, slots=True)
class Chain(Node):
    """A flat left-associative chain ``first op1 x1 op2 x2 ...`` of ``+ -`` or ``* /``.

    Evaluated left to right, exactly as Python would: ``((first op1 x1) op2 x2) ...``.
    """

    first: Node
    rest: tuple[tuple[str, Node], ...]


@dataclass(frozen=True, slots=True)
class Power(Node):
    """``base ** exponent``."""

    base: Node
    exponent: Node


@dataclass(frozen=True, slots=True)
class Call(Node):
    """A call of a whitelisted function (positional arguments)."""

    func: str
    args: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class Piecewise(Node):
    """``Piecewise((value, condition), ...)``."""

    pairs: tuple[tuple[Node, Node], ...]


@dataclass(frozen=True, slots=True)
class Compare(Node):
    """One comparison ``left op right`` (``op`` in ``< <= > >=``)."""

    op: str
    left: Node
    right: Node


@dataclass(frozen=True, slots=True)
class Logic(Node):
    """``c1 and c2 and ...`` or ``c1 or c2 or ...`` of conditions."""

    op: str
    operands: tuple[Node, ...]


@dataclass(frozen=True, slots=True)
class _Tuple(Node):
    """A parenthesised pair: only valid as an argument of ``Piecewise``."""

    items: tuple[Node, ...]


CONDITIONS = (Compare, Logic, Boolean)


def children(node: Node) -> tuple[Node, ...]:
    """The direct sub-expressions of a node."""
    if isinstance(node, Unary):
        return (node.operand,)
    if isinstance(node, Chain):
        return (node.first, *(x for _, x in node.rest))
    if isinstance(node, Power):
        return (node.base, node.exponent)
    if isinstance(node, Call):
        return node.args
    if isinstance(node, Piecewise):
        return tuple(x for pair in node.pairs for x in pair)
    if isinstance(node, Compare):
        return (node.left, node.right)
    if isinstance(node, Logic):
        return node.operands
    return ()


def walk(node: Node):
    """Every node of a tree (iteratively, parents before children)."""
    todo = [node]
    while todo:
        n = todo.pop()
        yield n
        todo.extend(reversed(children(n)))


@dataclass(frozen=True)
class Expression:
    """A checked expression.

    Attributes
    ----------
    text
        The source text (``^`` already read as ``**``).
    body
        The root of the tree.
    const
        Value of every constant sub-expression (no names but ``pi`` and ``E``), keyed
        by ``id(node)`` of the nodes of ``body``.
    """

    text: str
    body: Node
    const: dict[int, float] = field(default_factory=dict, repr=False, compare=False)

    def source(self, node: Node) -> str:
        """The source text of a sub-expression (for messages)."""
        return quote(self.text[node.start:node.end])


def quote(text: str, limit: int = 60) -> str:
    """``text`` on one line, printable ASCII, at most ``limit`` characters."""
    text = " ".join(text.split())
    text = text.encode("ascii", "backslashreplace").decode()
    return text if len(text) <= limit else text[: limit - 3] + "..."
