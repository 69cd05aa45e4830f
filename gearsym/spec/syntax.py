"""The expression language of spec files: a whitelist tokenizer and parser.

An expression string from a spec file is untrusted data.  It is never handed to
Python's ``eval``, to ``sympy.sympify`` or ``parse_expr``: this module reads it with its
own small parser into an immutable tree of the few node types the language has, and
rejects everything else with a one-line :class:`ExpressionError`.  The symbolic layer
builds sympy objects from this tree (:mod:`gearsym.symbolic.parsing`).

The language (Python/sympy syntax, ``^`` means ``**``):

* numbers: decimal integers and decimal floats (``3``, ``0.5``, ``1e-3``);
* names: parameters, coordinates, velocities, derived quantities, ``t``, ``pi``, ``E``;
* ``+ - * / **`` and unary ``+ -`` (Python precedence: ``-x**2 == -(x**2)``,
  ``a**b**c == a**(b**c)``);
* calls of the functions in :data:`~gearsym.spec.expressions.FUNCTIONS` (with their
  number of arguments) and of the bound functions, positional arguments only;
* ``Piecewise((value, condition), ...)``;
* conditions (only as the second element of a ``Piecewise`` pair): one comparison
  ``< <= > >=`` between two values, ``True``, ``False``, and conditions combined with
  ``and`` / ``or`` (parentheses as in Python).

Not part of the language (each gets a clear message): strings, bytes, attributes,
subscripts, lists, sets, dicts, lambdas, comprehensions, conditional expressions,
keyword arguments, ``*args``, the walrus, ``not``, ``~``, ``&``, ``|``, ``//``, ``%``,
``@``, ``==``, ``!=``, chained comparisons, non-decimal or complex numbers, non-ASCII
characters, names starting with ``_``.

Limits (bad input, not a crash or a hang in sympy): :data:`MAX_LENGTH` characters,
:data:`MAX_NODES` nodes, nesting depth :data:`MAX_DEPTH` (a flat sum or product of
many terms is one level), :data:`MAX_LITERAL_DIGITS` digits per number, numbers of
magnitude up to 1e300, constant exponents up to :data:`MAX_EXPONENT` in magnitude
(also when nested powers multiply them), constant values that stay finite.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from functools import lru_cache

from .exprtree import (  # noqa: F401  (re-exported: the language in one place)
    ARITY,
    BOUND_FUNCTIONS,
    CONDITIONS,
    CONSTANT_VALUES,
    CONSTANTS,
    FUNCTIONS,
    MAX_ARGS,
    MAX_DEPTH,
    MAX_EXPONENT,
    MAX_LENGTH,
    MAX_LITERAL_DIGITS,
    MAX_MAGNITUDE,
    MAX_NODES,
    Boolean,
    Call,
    Chain,
    Compare,
    Expression,
    ExpressionError,
    Logic,
    Name,
    Node,
    Number,
    Piecewise,
    Power,
    Unary,
    _Tuple,
    children,
    quote,
    walk,
)

# --------------------------------------------------------------- tokenizer

_TOKEN = re.compile(r"""
    (?P<ws>[ \t\r\n]+)
  | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
  | (?P<op>\*\*|<=|>=|==|!=|//|:=|->|[-+*/(),<>=%@&|~.\[\]{}:;!'"`\\\#$?])
""", re.VERBOSE)

_FORBIDDEN_OPS = {
    "==": "'==' is not allowed: a condition compares with < <= > or >=",
    "!=": "'!=' is not allowed: a condition compares with < <= > or >=",
    "//": "'//' is not allowed (write floor(a/b))",
    "%": "'%' is not allowed",
    "@": "'@' is not allowed",
    "&": "'&' is not allowed: combine conditions with 'and'",
    "|": "'|' is not allowed: combine conditions with 'or'",
    "~": "'~' is not allowed: write the opposite comparison instead (x <= b for not x > b)",
    "!": "'!' is not allowed",
    ":=": "assignment expressions (':=') are not allowed",
    "=": "'=' is not allowed (no assignments or keyword arguments)",
    ".": "attribute access ('.') is not allowed",
    "[": "subscripts and lists ('[') are not allowed",
    "]": "subscripts and lists (']') are not allowed",
    "{": "sets and dicts ('{') are not allowed",
    "}": "sets and dicts ('}') are not allowed",
    ":": "':' is not allowed (no slices, lambdas or dicts)",
    ";": "';' is not allowed",
    "'": "strings are not allowed",
    '"': "strings are not allowed",
    "`": "'`' is not allowed",
    "\\": "'\\' is not allowed",
    "#": "comments ('#') are not allowed",
    "$": "'$' is not allowed",
    "?": "'?' is not allowed",
    "->": "'->' is not allowed",
}
_KEYWORD_MESSAGES = {
    "not": "'not' is not allowed: write the opposite comparison instead (x <= b for not x > b)",
    "lambda": "lambda is not allowed",
    "if": "conditional expressions ('if') are not allowed: use Piecewise((a, condition), (b, True))",
    "else": "conditional expressions ('else') are not allowed: use Piecewise((a, condition), (b, True))",
    "for": "comprehensions ('for') are not allowed",
    "in": "'in' is not allowed",
    "is": "'is' is not allowed",
    "None": "None is not a value",
}
_PY_KEYWORDS = {"await", "async", "yield", "from", "import", "global", "nonlocal", "del", "pass", "raise",
                "return", "try", "except", "finally", "while", "with", "as", "assert", "break", "class",
                "continue", "def", "elif"}


@dataclass(frozen=True, slots=True)
class _Tok:
    kind: str   # "num", "name", "op", "end"
    text: str
    pos: int


def _tokenize(text: str) -> list[_Tok]:
    toks: list[_Tok] = []
    pos = 0
    n = len(text)
    while pos < n:
        m = _TOKEN.match(text, pos)
        if m is None:
            ch = text[pos]
            raise ExpressionError(f"character {quote(repr(ch))} at column {pos + 1} is not allowed")
        kind = m.lastgroup or ""
        tok = m.group()
        if kind == "num":
            nxt = text[m.end():m.end() + 1]
            if nxt and (nxt.isalnum() or nxt in "_."):
                end = m.end()
                while end < n and (text[end].isalnum() or text[end] in "_."):
                    end += 1
                raise ExpressionError(f"malformed number '{quote(text[pos:end])}' at column {pos + 1} "
                                      f"(only decimal numbers such as 12, 0.5, 1e-3)")
            mant = re.split(r"[eE]", tok)[0]
            digits = len(mant.replace(".", "").lstrip("0"))
            if digits > MAX_LITERAL_DIGITS:
                raise ExpressionError(f"number '{quote(tok, 40)}' has more than {MAX_LITERAL_DIGITS} digits")
            if "." not in tok and "e" not in tok.lower() and len(tok) > 1 and tok[0] == "0" and tok.strip("0"):
                raise ExpressionError(f"number '{tok}' has leading zeros")
        if kind != "ws":
            toks.append(_Tok(kind, tok, pos))
        pos = m.end()
    toks.append(_Tok("end", "", n))
    return toks


# ------------------------------------------------------------------- parser


class _Parser:
    """Recursive descent over the token list; chains are loops, depth is bounded."""

    def __init__(self, text: str, toks: list[_Tok]):
        self.text = text
        self.toks = toks
        self.i = 0
        self.depth = 0
        self.nodes = 0

    # --- helpers
    @property
    def tok(self) -> _Tok:
        return self.toks[self.i]

    def advance(self) -> _Tok:
        t = self.toks[self.i]
        self.i += 1
        return t

    def at_op(self, *ops: str) -> bool:
        return self.tok.kind == "op" and self.tok.text in ops

    def at_name(self, *names: str) -> bool:
        return self.tok.kind == "name" and self.tok.text in names

    def expect_op(self, op: str, what: str) -> _Tok:
        if not self.at_op(op):
            self.unexpected(f"expected {what}")
        return self.advance()

    def unexpected(self, hint: str = "") -> None:
        t = self.tok
        if t.kind == "op" and t.text in _FORBIDDEN_OPS:
            if t.text == "=" and self.i > 0 and self.toks[self.i - 1].kind == "name":
                raise ExpressionError(f"keyword argument '{self.toks[self.i - 1].text}=' is not allowed "
                                      f"(column {self.toks[self.i - 1].pos + 1}): arguments are positional")
            raise ExpressionError(f"{_FORBIDDEN_OPS[t.text]} (column {t.pos + 1})")
        if t.kind == "name" and t.text in _KEYWORD_MESSAGES:
            raise ExpressionError(f"{_KEYWORD_MESSAGES[t.text]} (column {t.pos + 1})")
        if t.kind == "name" and t.text in _PY_KEYWORDS:
            raise ExpressionError(f"'{t.text}' is not allowed (column {t.pos + 1})")
        if t.kind == "end":
            raise ExpressionError(f"syntax error: unexpected end of expression{'; ' + hint if hint else ''}")
        raise ExpressionError(f"syntax error at column {t.pos + 1} near '{quote(t.text, 20)}'"
                              f"{'; ' + hint if hint else ''}")

    def node(self, cls, start: int, end: int, *args) -> Node:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise ExpressionError(f"expression too large (more than {MAX_NODES} terms and operators)")
        return cls(start, end, *args)

    def enter(self) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExpressionError(f"expression nested too deeply (more than {MAX_DEPTH} levels of "
                                  f"parentheses, calls, powers or signs)")

    def leave(self) -> None:
        self.depth -= 1

    # --- grammar
    def parse(self) -> Node:
        e = self.or_expr()
        if self.tok.kind != "end":
            if self.at_op(","):
                raise ExpressionError(f"unexpected ',' at column {self.tok.pos + 1} (a tuple is only "
                                      f"allowed as a (value, condition) pair of Piecewise)")
            self.unexpected()
        return e

    def or_expr(self) -> Node:
        first = self.and_expr()
        if not self.at_name("or"):
            return first
        items = [first]
        while self.at_name("or"):
            self.advance()
            items.append(self.and_expr())
        return self.node(Logic, first.start, items[-1].end, "or", tuple(items))

    def and_expr(self) -> Node:
        first = self.comparison()
        if not self.at_name("and"):
            return first
        items = [first]
        while self.at_name("and"):
            self.advance()
            items.append(self.comparison())
        return self.node(Logic, first.start, items[-1].end, "and", tuple(items))

    def comparison(self) -> Node:
        if self.at_name("not"):
            self.unexpected()
        left = self.arith()
        if self.at_op("<", "<=", ">", ">="):
            op = self.advance().text
            right = self.arith()
            if self.at_op("<", "<=", ">", ">=", "==", "!="):
                raise ExpressionError(f"chained comparison at column {self.tok.pos + 1}: write "
                                      f"(a < b) and (b < c)")
            return self.node(Compare, left.start, right.end, op, left, right)
        if self.at_name("in", "is", "if", "not"):
            self.unexpected()
        return left

    def chain(self, ops: tuple[str, ...], sub) -> Node:
        first = sub()
        if not self.at_op(*ops):
            return first
        rest = []
        while self.at_op(*ops):
            op = self.advance().text
            rest.append((op, sub()))
        return self.node(Chain, first.start, rest[-1][1].end, first, tuple(rest))

    def arith(self) -> Node:
        return self.chain(("+", "-"), self.term)

    def term(self) -> Node:
        return self.chain(("*", "/"), self.unary)

    def unary(self) -> Node:
        if self.at_op("+", "-"):
            t = self.advance()
            self.enter()
            operand = self.unary()
            self.leave()
            return self.node(Unary, t.pos, operand.end, t.text, operand)
        if self.at_op("*"):
            raise ExpressionError(f"'*' unpacking is not allowed (column {self.tok.pos + 1})")
        return self.power()

    def power(self) -> Node:
        base = self.atom()
        if self.at_op("**"):
            self.advance()
            self.enter()
            exponent = self.unary()
            self.leave()
            return self.node(Power, base.start, exponent.end, base, exponent)
        return base

    def atom(self) -> Node:
        t = self.tok
        if t.kind == "num":
            self.advance()
            is_int = not any(c in t.text for c in ".eE")
            return self.node(Number, t.pos, t.pos + len(t.text), t.text, is_int)
        if t.kind == "name":
            if t.text in ("True", "False"):
                self.advance()
                return self.node(Boolean, t.pos, t.pos + len(t.text), t.text == "True")
            if t.text in _KEYWORD_MESSAGES or t.text in _PY_KEYWORDS or t.text in ("and", "or"):
                self.unexpected()
            if t.text.startswith("_"):
                raise ExpressionError(f"names starting with '_' are not allowed: '{quote(t.text, 40)}' "
                                      f"(column {t.pos + 1})")
            self.advance()
            if self.at_op("("):
                return self.call(t)
            return self.node(Name, t.pos, t.pos + len(t.text), t.text)
        if self.at_op("("):
            self.advance()
            self.enter()
            if self.at_op(")"):
                raise ExpressionError(f"empty parentheses at column {t.pos + 1}")
            items = [self.or_expr()]
            while self.at_op(","):
                self.advance()
                if self.at_op(")"):
                    break
                items.append(self.or_expr())
            end = self.expect_op(")", "')'")
            self.leave()
            if len(items) == 1 and not self.toks[self.i - 2].text == ",":
                return replace(items[0], start=t.pos, end=end.pos + 1)  # span with the parentheses
            return self.node(_Tuple, t.pos, end.pos + 1, tuple(items))
        self.unexpected()
        raise AssertionError  # pragma: no cover

    def call(self, name: _Tok) -> Node:
        func = name.text
        if func not in FUNCTIONS and func not in BOUND_FUNCTIONS:
            # possibly a table of the model (gearsym/spec/tables.py): the spec layer and the
            # symbolic layer, which know the model's tables, refuse any other name; a call whose
            # arguments are not in the language is reported as an unknown function here
            try:
                return self._call(name)
            except ExpressionError:
                raise ExpressionError(unknown_function(func)) from None
        return self._call(name)

    def _call(self, name: _Tok) -> Node:
        func = name.text
        self.advance()  # '('
        self.enter()
        args: list[Node] = []
        while not self.at_op(")"):
            if self.tok.kind == "name" and self.toks[self.i + 1].kind == "op" \
                    and self.toks[self.i + 1].text in ("=", ":="):
                raise ExpressionError(f"keyword argument '{self.tok.text}=' in {func}() is not allowed "
                                      f"(column {self.tok.pos + 1}): arguments are positional")
            if self.at_op("*", "**"):
                raise ExpressionError(f"'*' unpacking is not allowed (column {self.tok.pos + 1})")
            args.append(self.or_expr())
            if len(args) > MAX_ARGS:
                raise ExpressionError(f"{func}() with more than {MAX_ARGS} arguments")
            if self.at_op(","):
                self.advance()
                continue
            if not self.at_op(")"):
                if self.at_name("for"):
                    self.unexpected()
                if self.at_op("="):
                    raise ExpressionError(f"keyword arguments in {func}() are not allowed (column "
                                          f"{self.tok.pos + 1}): arguments are positional")
                self.unexpected(f"expected ',' or ')' in the arguments of {func}()")
        end = self.advance()
        self.leave()
        span = (name.pos, end.pos + 1)
        if func == "Piecewise":
            pairs = []
            for a in args:
                if not isinstance(a, _Tuple) or len(a.items) != 2:
                    raise ExpressionError(f"Piecewise takes (value, condition) pairs: "
                                          f"'{quote(self.text[span[0]:span[1]])}'")
                pairs.append((a.items[0], a.items[1]))
            if not pairs:
                raise ExpressionError("Piecewise needs at least one (value, condition) pair")
            return self.node(Piecewise, span[0], span[1], tuple(pairs))
        if func not in ARITY:  # a table call: its number of arguments is checked with the model
            return self.node(Call, span[0], span[1], func, tuple(args))
        lo, hi = ARITY[func]
        if len(args) < lo or (hi is not None and len(args) > hi):
            want = (f"{lo}" if lo == hi else f"{lo} or {hi}" if hi is not None else f"at least {lo}")
            raise ExpressionError(f"{func}() takes {want} argument{'s' if want != '1' else ''}, got "
                                  f"{len(args)}: '{quote(self.text[span[0]:span[1]])}'")
        return self.node(Call, span[0], span[1], func, tuple(args))


def unknown_function(func: str, tables: object = ()) -> str:
    """The message for a call of a name that is neither a function nor a table."""
    known = f" (known: {', '.join(sorted(FUNCTIONS))}"
    tables = sorted(tables)  # type: ignore[call-overload]
    known += f"; tables: {', '.join(tables)})" if tables else ")"
    return f"unknown function '{quote(func, 40)}'{known}"


# -------------------------------------------------------------- semantics


class _Checker:
    """Bottom-up checks of a parsed tree: value/condition kinds, constants, exponents."""

    def __init__(self, expr: Expression):
        self.expr = expr
        self.const = expr.const
        self.degree: dict[int, float] = {}

    def err(self, node: Node, message: str) -> ExpressionError:
        return ExpressionError(f"{message} in '{self.expr.source(node)}'")

    def run(self) -> None:
        body = self.expr.body
        order = list(walk(body))
        for node in reversed(order):  # children before parents
            self.check(node)
        if isinstance(body, _Tuple):
            raise ExpressionError(f"unexpected tuple '{self.expr.source(body)}' (only Piecewise takes "
                                  f"(value, condition) pairs)")
        if isinstance(body, CONDITIONS):
            raise ExpressionError(f"'{self.expr.source(body)}' is a condition, not a value (conditions "
                                  f"belong in Piecewise((value, condition), ...))")

    def value(self, node: Node, parent: Node) -> float | None:
        if isinstance(node, _Tuple):
            raise self.err(node, "unexpected tuple (only Piecewise takes (value, condition) pairs)")
        if isinstance(node, CONDITIONS):
            raise self.err(parent, f"'{self.expr.source(node)}' is a condition, not a value")
        return self.const.get(id(node))

    def check(self, node: Node) -> None:
        key = id(node)
        deg = max((self.degree.get(id(c), 1.0) for c in children(node)), default=1.0)
        const: float | None = None
        try:
            const = self._check(node)
        except (OverflowError, ZeroDivisionError, ValueError) as exc:
            if isinstance(exc, ExpressionError):
                raise
            const = None
        if isinstance(node, Power):
            e = self.const.get(id(node.exponent))
            if e is not None:
                deg = self.degree.get(id(node.base), 1.0) * max(1.0, abs(e))
                if deg > MAX_EXPONENT:
                    raise self.err(node, f"powers with exponents above {MAX_EXPONENT} are not allowed")
        if const is not None and not (math.isfinite(const) and abs(const) <= MAX_MAGNITUDE):
            raise self.err(node, "constant value too large")
        if const is not None:
            self.const[key] = const
        self.degree[key] = deg

    def _check(self, node: Node) -> float | None:
        if isinstance(node, Number):
            v = float(node.text)
            if not math.isfinite(v) or abs(v) > MAX_MAGNITUDE or (v != 0 and abs(v) < 1 / MAX_MAGNITUDE):
                raise self.err(node, "number out of range (magnitude 1e-300 .. 1e300)")
            return v
        if isinstance(node, Name):
            return CONSTANT_VALUES.get(node.id)
        if isinstance(node, Boolean):
            return None
        if isinstance(node, _Tuple):
            return None  # checked by the parent (Piecewise) or rejected by value()
        if isinstance(node, Unary):
            v = self.value(node.operand, node)
            return None if v is None else (-v if node.op == "-" else v)
        if isinstance(node, Chain):
            acc = self.value(node.first, node)
            for op, x in node.rest:
                v = self.value(x, node)
                if op == "/" and v == 0:
                    raise self.err(node, "division by zero")
                if acc is None or v is None:
                    acc = None
                    continue
                acc = acc + v if op == "+" else acc - v if op == "-" else acc * v if op == "*" else acc / v
            return acc
        if isinstance(node, Power):
            b = self.value(node.base, node)
            e = self.value(node.exponent, node)
            if e is not None and abs(e) > MAX_EXPONENT:
                raise self.err(node, f"exponent {e:g} is too large (limit {MAX_EXPONENT} in magnitude)")
            if b is None or e is None:
                return None
            if b == 0 and e < 0:
                raise self.err(node, "zero to a negative power")
            if b < 0 and e != int(e):
                raise self.err(node, "a negative number to a fractional power is complex")
            if b != 0 and e * math.log10(abs(b)) > 300:
                raise self.err(node, "constant value too large")
            return b ** e
        if isinstance(node, Call):
            vals = [self.value(a, node) for a in node.args]
            if any(v is None for v in vals):
                return None
            fn = _MATH.get(node.func)
            if fn is None:
                return None
            if node.func == "atan2" and vals[0] == vals[1] == 0:
                raise self.err(node, "atan2(0, 0) is undefined")
            try:
                return float(fn(*vals))
            except OverflowError:
                raise self.err(node, "constant value too large") from None
            except ValueError:  # sqrt(-1), log(0), asin(2): complex or infinite in sympy
                raise self.err(node, f"constant argument outside the domain of {node.func}()") from None
        if isinstance(node, Piecewise):
            for val, cond in node.pairs:
                self.value(val, node)
                if not isinstance(cond, CONDITIONS):
                    raise self.err(node, f"'{self.expr.source(cond)}' is not a condition (a comparison "
                                         f"such as x > b, True, or conditions joined by and / or)")
            return None
        if isinstance(node, Compare):
            self.value(node.left, node)
            self.value(node.right, node)
            return None
        if isinstance(node, Logic):
            for c in node.operands:
                if not isinstance(c, CONDITIONS):
                    raise self.err(node, f"'{self.expr.source(c)}' is not a condition ('{node.op}' joins "
                                         f"comparisons)")
            return None
        raise self.err(node, "unsupported syntax")  # pragma: no cover


def _heaviside(x: float, h0: float = 0.5) -> float:
    return 1.0 if x > 0 else 0.0 if x < 0 else h0


_MATH = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "exp": math.exp, "log": math.log,
         "sqrt": math.sqrt, "abs": abs, "Abs": abs, "sinh": math.sinh, "cosh": math.cosh, "tanh": math.tanh,
         "atan": math.atan, "asin": math.asin, "acos": math.acos, "atan2": math.atan2, "Max": max,
         "Min": min, "max": max, "min": min, "floor": math.floor,
         "sign": lambda x: float((x > 0) - (x < 0)), "Heaviside": _heaviside}


@lru_cache(maxsize=8192)
def _parse_cached(text: str) -> Expression:
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression too long ({len(text)} characters, limit {MAX_LENGTH})")
    if not text.isascii():
        bad = next(c for c in text if not c.isascii())
        raise ExpressionError(f"non-ASCII character '{quote(bad)}' at column {text.index(bad) + 1}: "
                              f"names and operators are ASCII")
    src = text.replace("^", "**")
    toks = _tokenize(src)
    if len(toks) == 1:
        raise ExpressionError("empty expression")
    body = _Parser(src, toks).parse()
    expr = Expression(src, body)
    _Checker(expr).run()
    return expr


def parse_checked(text: object) -> Expression:
    """Parse and check an expression (cached by text).

    Parameters
    ----------
    text
        The expression; an int or float is read as its ``repr``.

    Raises
    ------
    ExpressionError
        If the expression is not in the language or breaks a limit.
    """
    if isinstance(text, bool):
        raise ExpressionError(f"expected an expression, got the boolean {text}")
    if isinstance(text, (int, float)):
        if not math.isfinite(text):
            raise ExpressionError(f"non-finite value {text}")
        text = repr(float(text))
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {type(text).__name__}")
    return _parse_cached(text.strip())
