"""Budgets for symbolic work: bounded expressions and a deadline.

The spec layer bounds every expression *as written* (length, nodes, nesting, exponents;
:mod:`gearsym.spec.syntax`).  Substituting ``[derived]`` quantities can still make an
expression grow without bound from a short file: a chain ``d_k = (d_(k-1) + b)*(d_(k-1) + 2*b)``
doubles the tree at every step (24 steps: 2**24 nodes that sympy walks one by one), a
tower ``c_k = c_(k-1)**64`` multiplies the exponents (``x**(64**6)``, or an integer of
2**36 bits), a deep chain ``d_k = sin(d_(k-1))`` exceeds Python's recursion limit.  So every
expression the symbolic layer builds from a spec field is measured before sympy works on
it (:func:`check_expression`), with counts that are themselves cheap on a shared tree (one
visit per distinct sub-expression, however often it is shared):

* ``nodes``: the number of nodes of the tree as sympy walks it (:data:`MAX_TREE_NODES`);
* ``depth``: the nesting depth (:data:`MAX_TREE_DEPTH`);
* ``degree``: the polynomial degree (products add, integer powers multiply;
  :data:`MAX_DEGREE`);
* ``terms``: an upper bound of the number of terms of its full expansion, the cost of the
  ``expand`` the derivation applies to conditions, deflections and reductions
  (:data:`MAX_EXPANDED_TERMS`);
* every number finite and at most :data:`MAX_MAGNITUDE` in magnitude.

Nonsmooth functions of the states become switching surfaces, each pair of ``Max``/``Min``
arguments one: their number per call and per model is bounded too
(:data:`MAX_STATE_ARGS`, :data:`MAX_PIECEWISE_CONDITIONS`, :data:`MAX_SURFACES`).

What the checks cannot bound (the cost of a derivation that is large but within every
limit) a :class:`Budget` bounds in time: a deadline that the derivation and the code
generator check between their steps (:func:`checkpoint`).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass

import sympy as sp

from ..errors import SpecError

#: Most nodes of one expression after ``[derived]`` substitution (the shipped models: < 1 000).
MAX_TREE_NODES = 200_000
#: Deepest nesting of one expression after substitution (Python's recursion limit is 1 000
#: frames; sympy's tree walks take a few frames per level).
MAX_TREE_DEPTH = 150
#: Highest polynomial degree of one expression (products add degrees, powers multiply them).
MAX_DEGREE = 256
#: Most terms of the full expansion of one expression (an upper bound; the shipped models: < 2 000).
MAX_EXPANDED_TERMS = 100_000
#: Largest magnitude of a number in an expression (as the spec layer's constants).
MAX_MAGNITUDE = 1e300
#: Most arguments of a ``Max``/``Min`` of the states (each pair of arguments is a surface).
MAX_STATE_ARGS = 16
#: Most state-dependent conditions of one ``Piecewise`` (each one is a surface).
MAX_PIECEWISE_CONDITIONS = 64
#: Most switching surfaces of one model.
MAX_SURFACES = 256
#: Default time budget of one derivation or one code generation (seconds); the environment
#: variable ``GEARSYM_SYMBOLIC_SECONDS`` sets another.
DEFAULT_SECONDS = 900.0

_MAX_INT_BITS = int(math.log2(MAX_MAGNITUDE)) + 1


class ExpressionTooLarge(ValueError):
    """An expression breaks one of the limits of this module (the message says which)."""


@dataclass(frozen=True)
class Measure:
    """The sizes of an expression (see the module docstring)."""

    nodes: int
    depth: int
    degree: int
    terms: int


def _number_problem(e: sp.Basic) -> str | None:
    if e.is_Integer:
        big = abs(int(e)).bit_length() > _MAX_INT_BITS
    elif e.is_Rational:
        big = max(abs(e.p).bit_length(), abs(e.q).bit_length()) > _MAX_INT_BITS
    elif e.is_Float:
        v = float(e)
        big = not math.isfinite(v) or abs(v) > MAX_MAGNITUDE
    else:
        return None
    return f"a number out of range (magnitude above {MAX_MAGNITUDE:g})" if big else None


def _binomial_capped(n: int, k: int, cap: int) -> int:
    """``C(n, k)``, or ``cap + 1`` if it exceeds ``cap`` (without computing huge numbers)."""
    k = min(k, n - k)
    if k < 0:
        return 0
    out = 1
    for i in range(1, k + 1):
        out = out * (n - k + i) // i
        if out > cap:
            return cap + 1
    return out


#: generator sets larger than this are not tracked (the product bound is used alone)
_GENERATORS_TRACKED = 64


@dataclass(frozen=True, slots=True)
class _Poly:
    """Degree, number of terms (bound) and generators of the expansion of one node."""

    degree: int
    terms: int
    gens: frozenset | None  # None: too many to track


@dataclass(frozen=True, slots=True)
class _Node:
    nodes: int
    depth: int
    static: bool    # no dynamic symbol below
    full: _Poly     # sp.expand: every symbol and function is a generator
    blocked: _Poly  # expanded in the dynamic symbols, each static sub-expression one generator


_NUMBER = _Poly(0, 1, frozenset())


def measure(expr: sp.Basic, dynamic: frozenset = frozenset()) -> Measure:
    """The sizes of ``expr``, one visit per distinct sub-expression.

    Parameters
    ----------
    expr
        The expression.
    dynamic
        The states: the expansions of the derivation in the states hold every
        sub-expression free of them as one symbol (a "block"); their size is bounded too.

    Raises
    ------
    ExpressionTooLarge
        As soon as one size is above its limit, or a number is out of range.
    """
    memo: dict[int, _Node] = {}
    stack: list[tuple[sp.Basic, bool]] = [(expr, False)]
    while stack:
        e, ready = stack.pop()
        key = id(e)
        if key in memo:
            continue
        if not ready:
            stack.append((e, True))
            stack.extend((a, False) for a in e.args if id(a) not in memo)
            continue
        memo[key] = _measure_node(e, [memo[id(a)] for a in e.args], dynamic)
    top = memo[id(expr)]
    return Measure(top.nodes, top.depth, top.full.degree, max(top.full.terms, top.blocked.terms))


def _measure_node(e: sp.Basic, kids: list[_Node], dynamic: frozenset) -> _Node:
    nodes = 1 + sum(k.nodes for k in kids)
    if nodes > MAX_TREE_NODES:
        raise ExpressionTooLarge(f"more than {MAX_TREE_NODES} nodes")
    depth = 1 + max((k.depth for k in kids), default=0)
    if depth > MAX_TREE_DEPTH:
        raise ExpressionTooLarge(f"nested more than {MAX_TREE_DEPTH} levels deep")
    if not kids:
        problem = _number_problem(e)
        if problem:
            raise ExpressionTooLarge(problem)
        if isinstance(e, sp.Symbol):
            own = _Poly(1, 1, frozenset((e,)))
            return _Node(nodes, depth, e not in dynamic, own, own)
        return _Node(nodes, depth, True, _NUMBER, _NUMBER)
    static = all(k.static for k in kids)
    full = _combine(e, [k.full for k in kids])
    if full.degree > MAX_DEGREE:
        raise ExpressionTooLarge(f"a polynomial degree of {full.degree} (limit {MAX_DEGREE}; products add the "
                                 f"degrees, powers multiply them)")
    if static and dynamic:  # one block
        blocked = _Poly(1, 1, frozenset((e,))) if full.degree else _NUMBER
    elif dynamic and isinstance(e, (sp.Add, sp.Mul)) and any(k.static and k.full.degree for k in kids):
        # the static terms (factors) of a sum (product) are held together as one block, as
        # switching.make_modal's canonical form does: one generator per distinct block (up to
        # a numeric factor), so (x + t + 1)*(x + t + 2)*... has as many as it has factors
        block = tuple(a if a.is_Number else a.as_coeff_Mul()[1]
                      for a, k in zip(e.args, kids) if k.static and (k.full.degree or isinstance(e, sp.Add)))
        group = _Poly(1, 1, frozenset((("block", block),)))
        blocked = _combine(e, [k.blocked for k in kids if not k.static] + [group])
    else:
        blocked = _combine(e, [k.blocked for k in kids])
    return _Node(nodes, depth, static, full, blocked)


def _combine(e: sp.Basic, kids: list[_Poly]) -> _Poly:
    """The expansion of node ``e`` from those of its arguments."""
    gens = _generators(kids)
    if isinstance(e, sp.Add):
        degree = max(k.degree for k in kids)
        terms = sum(k.terms for k in kids)
    elif isinstance(e, sp.Mul):
        degree = sum(k.degree for k in kids)
        terms = 1
        for k in kids:
            terms = min(terms * k.terms, MAX_EXPANDED_TERMS + 1)
    elif isinstance(e, sp.Pow) and e.exp.is_Rational:
        n = abs(e.exp)
        degree = math.ceil(n * kids[0].degree)
        power = _binomial_capped(kids[0].terms + int(n) - 1, int(n), MAX_EXPANDED_TERMS) if n.is_Integer else 1
        if e.exp.is_negative or not n.is_Integer:  # a denominator or a root: expanded inside, one term outside
            _check_terms(power)
            terms = 1
        else:
            terms = power
    else:  # functions, symbolic powers, Piecewise, conditions: one generator of their own
        degree = 1 if any(k.degree for k in kids) else 0
        terms = 1
        for k in kids:  # their arguments are expanded inside
            _check_terms(k.terms)
        gens = frozenset((e,)) if degree else frozenset()
    if gens is not None and terms > 1:  # at most the number of monomials of that degree in its generators
        terms = min(terms, _binomial_capped(len(gens) + degree, degree, MAX_EXPANDED_TERMS))
    _check_terms(terms)
    return _Poly(degree, terms, gens)


def _generators(kids: list[_Poly]) -> frozenset | None:
    if any(k.gens is None for k in kids):
        return None
    sets = [k.gens for k in kids if k.gens]
    if not sets:
        return frozenset()
    out = sets[0]
    for s in sets[1:]:
        if not s <= out:
            out = out | s
            if len(out) > _GENERATORS_TRACKED:
                return None
    return out


def _check_terms(terms: int) -> None:
    if terms > MAX_EXPANDED_TERMS:
        raise ExpressionTooLarge(f"an expansion of more than {MAX_EXPANDED_TERMS} terms")


def check_expression(expr: sp.Basic, file: str | None, field: str | None, what: str = "expression",
                     dynamic: frozenset = frozenset()) -> Measure:
    """Measure ``expr`` (:func:`measure`) and turn a limit it breaks into a :class:`SpecError`
    naming ``field``."""
    try:
        return measure(expr, dynamic)
    except ExpressionTooLarge as exc:
        raise SpecError(f"the {what} is too large for the symbolic layer once the derived quantities are "
                        f"substituted: {exc}", file=file, field=field) from None


# ------------------------------------------------------------------ the deadline


class Budget:
    """A deadline for one derivation or one code generation.

    Parameters
    ----------
    seconds
        Time allowed from now (default: ``$GEARSYM_SYMBOLIC_SECONDS`` or
        :data:`DEFAULT_SECONDS`).
    what
        What is being done (for the message).
    file
        The model file (for the message).
    """

    def __init__(self, seconds: float | None = None, what: str = "the symbolic derivation",
                 file: str | None = None):
        if seconds is None:
            seconds = default_seconds()
        self.seconds = float(seconds)
        self.what = what
        self.file = file
        self.deadline = time.monotonic() + self.seconds

    def check(self, where: str | None = None) -> None:
        """Raise :class:`SpecError` if the deadline has passed.

        Parameters
        ----------
        where
            The spec field or step being worked on (named in the message).
        """
        if time.monotonic() > self.deadline:
            raise SpecError(f"{self.what} took longer than its budget of {self.seconds:g} s (the model is too "
                            f"large or its expressions grow too much; GEARSYM_SYMBOLIC_SECONDS sets the budget)",
                            file=self.file, field=where)

    @contextlib.contextmanager
    def active(self) -> Iterator[Budget]:
        """Make this the budget that :func:`checkpoint` checks (within the ``with`` block).

        Inside another active budget, the earlier deadline of the two holds.
        """
        outer = _CURRENT.get()
        if outer is not None and outer.deadline < self.deadline:
            self.deadline, self.seconds, self.what = outer.deadline, outer.seconds, outer.what
        token = _CURRENT.set(self)
        try:
            yield self
        finally:
            _CURRENT.reset(token)


_CURRENT: contextvars.ContextVar[Budget | None] = contextvars.ContextVar("gearsym_budget", default=None)


def checkpoint(where: str | None = None) -> None:
    """Check the active :class:`Budget`, if any (see :meth:`Budget.active`)."""
    budget = _CURRENT.get()
    if budget is not None:
        budget.check(where)


def default_seconds() -> float:
    """The time budget from ``$GEARSYM_SYMBOLIC_SECONDS`` (a positive number) or :data:`DEFAULT_SECONDS`."""
    text = os.environ.get("GEARSYM_SYMBOLIC_SECONDS")
    if not text:
        return DEFAULT_SECONDS
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise SpecError(f"GEARSYM_SYMBOLIC_SECONDS must be a number of seconds >= 0, got '{text[:40]}'")
    return value
