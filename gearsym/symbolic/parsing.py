"""Turn checked expressions of a resolved scene into sympy expressions.

No user string ever reaches ``sympify``, ``parse_expr`` or ``eval``: the spec layer reads
each expression into a checked tree (:mod:`gearsym.spec.syntax`), and :class:`Builder`
turns that tree into sympy objects node by node, applying the same Python operators
to sympy objects as evaluating the expression would (so ``1/2`` is ``Rational(1, 2)``,
``0.5`` is ``Float('0.5')``, ``^`` is a power).  Flat sums and products are folded in
a loop (a 500-term Fourier series is no deeper than one term); everything else is
bounded by the spec layer's nesting-depth limit.

Internal symbols (surface sides ``sigma_j(t)``, schedule cycle ``n_<s>(t)`` and segment
``seg_<s>(t)`` indices) are made by :func:`internal_symbol`; their names contain
parentheses, which no user name can (see :mod:`gearsym.spec.names`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import sympy as sp

from ..errors import SpecError
from ..spec import syntax as sx
from ..spec.expressions import BOUND_FUNCTIONS, FUNCTIONS, ExpressionError, names_in, parse
from ..spec.model import ModelSpec, Term
from ..spec.scene import ResolvedScene
from ..spec.syntax import quote, unknown_function
from .budget import check_expression, checkpoint
from .surfaces import RECORDED_CALLS, Recorder, SurfaceFinder
from .tables import TableLowering

_SYMPY_FUNCTIONS: dict[str, Callable[..., sp.Basic]] = {
    name: getattr(sp, fn) for name, fn in FUNCTIONS.items() if name != "Piecewise"}
#: Values no expression of a model may contain.
_NOT_REAL = (sp.zoo, sp.nan, sp.oo, -sp.oo, sp.I)
#: Products with at least this many factors are built as one ``Mul`` (see :meth:`Builder.chain`).
LONG_PRODUCT = 64
_COMPARE = {"<": lambda a, b: a < b, "<=": lambda a, b: a <= b,
            ">": lambda a, b: a > b, ">=": lambda a, b: a >= b}


def internal_symbol(name: str) -> sp.Symbol:
    """A symbol of the symbolic layer that no user name can collide with.

    ``name`` is the readable stem (``sigma_0``, ``n_mesh``, ``seg_mesh``); the symbol is
    ``name + "(t)"``: user names are ``[A-Za-z][A-Za-z0-9_]*``, so none can equal it,
    and it sorts next to ``name`` (sympy orders terms by name, so the generated code
    of models without such a twin does not change).
    """
    return sp.Symbol(f"{name}(t)", real=True)


class Builder:
    """Build sympy objects from checked expression trees.

    Parameters
    ----------
    names
        What each name means (symbols, or sympy expressions of derived quantities).
    bound
        Called as ``bound(function name, argument names)`` for a call of a bound
        function; returns the symbol standing for its value.
    record
        Sees every comparison, ``Piecewise`` and call of
        :data:`~gearsym.symbolic.surfaces.RECORDED_CALLS`: ``record.before(node, argument
        values)`` before sympy builds it (a check that may raise: sympy's ``Max`` of n
        arguments costs n**2 comparisons), ``record(node, value, argument values)`` after
        (:class:`~gearsym.symbolic.surfaces.Recorder`).
    """

    def __init__(self, names: Mapping[str, sp.Basic],
                 bound: Callable[[str, list[str]], sp.Basic] | None = None,
                 record: Recorder | None = None,
                 table: Callable[[sx.Node, Callable[[sx.Node], sp.Basic]], sp.Basic | None] | None = None):
        self.names = names
        self.bound = bound
        self.record = record
        self.table = table

    def build(self, expr: sx.Expression) -> sp.Basic:
        """The sympy object of a checked expression."""
        return self.visit(expr.body)

    def visit(self, node: sx.Node) -> sp.Basic:
        if isinstance(node, sx.Number):
            return sp.Integer(node.text) if node.is_int else sp.Float(node.text)
        if isinstance(node, sx.Name):
            if node.id == "pi":
                return sp.pi
            if node.id == "E":
                return sp.E
            if node.id not in self.names:
                value = self.table(node, self.visit) if self.table is not None else None
                if value is None:
                    raise ExpressionError(f"unknown symbol '{node.id}'")
                return value
            return self.names[node.id]
        if isinstance(node, sx.Boolean):
            return sp.true if node.value else sp.false
        if isinstance(node, sx.Unary):
            v = self.visit(node.operand)
            return -v if node.op == "-" else +v
        if isinstance(node, sx.Chain):
            return self.chain(node)
        if isinstance(node, sx.Power):
            return self.visit(node.base) ** self.visit(node.exponent)
        if isinstance(node, sx.Compare):
            sides = (self.visit(node.left), self.visit(node.right))
            if self.record is not None:
                self.record.before(node, sides)
            return self._recorded(node, _COMPARE[node.op](*sides), sides)
        if isinstance(node, sx.Logic):
            ops = [self.visit(c) for c in node.operands]
            return sp.And(*ops) if node.op == "and" else sp.Or(*ops)
        if isinstance(node, sx.Piecewise):
            pairs = [(self.visit(v), self.visit(c)) for v, c in node.pairs]
            if self.record is not None:
                self.record.before(node, tuple(c for _, c in pairs))
            return self._recorded(node, sp.Piecewise(*pairs), ())
        if isinstance(node, sx.Call):
            if node.func not in FUNCTIONS and node.func not in BOUND_FUNCTIONS:
                value = self.table(node, self.visit) if self.table is not None else None
                if value is None:
                    raise ExpressionError(unknown_function(node.func))
                return value
            if node.func in BOUND_FUNCTIONS:
                names = [a.id if isinstance(a, sx.Name) else None for a in node.args]
                if self.bound is None or any(a is None for a in names):
                    raise ExpressionError(f"arguments of {node.func}() must be parameter names")
                return self.bound(node.func, names)  # type: ignore[arg-type]
            args = tuple(self.visit(a) for a in node.args)
            if node.func not in RECORDED_CALLS:
                return _SYMPY_FUNCTIONS[node.func](*args)
            if self.record is not None:
                self.record.before(node, args)
            return self._recorded(node, _SYMPY_FUNCTIONS[node.func](*args), args)
        raise ExpressionError(f"unsupported expression node {type(node).__name__}")  # pragma: no cover

    def _recorded(self, node: sx.Node, value: sp.Basic, args: tuple) -> sp.Basic:
        if self.record is not None:
            self.record(node, value, args)
        return value

    def chain(self, node: sx.Chain) -> sp.Basic:
        """A flat chain of ``+ -`` or ``* /``, without recursion and without quadratic cost.

        A sum is one ``Add(a, -b, c, ...)``: the same object as Python's left-to-right
        ``a - b + c ...`` (``x - y`` is ``Add(x, -y)``; ``Add`` flattens nested sums and
        accumulates the coefficients of like terms in the order of its arguments either
        way), built in one pass instead of one pass per term.  A product is folded left
        to right with Python's operators (a division of numbers is exact then); only a
        long product (more than :data:`LONG_PRODUCT` factors) is built as one ``Mul``.
        """
        first = self.visit(node.first)
        if node.rest[0][0] in "+-":
            return sp.Add(first, *[self.visit(x) if op == "+" else -self.visit(x) for op, x in node.rest])
        if len(node.rest) >= LONG_PRODUCT:
            return sp.Mul(first, *[self.visit(x) if op == "*" else sp.Pow(self.visit(x), -1)
                                   for op, x in node.rest])
        acc = first
        for op, x in node.rest:  # left to right, as Python evaluates a chain
            acc = acc * self.visit(x) if op == "*" else acc / self.visit(x)
        return acc


def _derived_order(m: ModelSpec) -> list[str]:
    """The derived quantities of model ``m`` in dependency order.

    The order of passes over the table, each taking (in file order) every quantity whose
    dependencies are done: a quantity's pass is the largest of its dependencies' passes,
    plus one for a dependency written after it.  Computed in one walk (repeated passes cost
    a pass per level of a chain written backwards: hours for 20 000 quantities).
    """
    index = {name: i for i, name in enumerate(m.derived)}
    deps = {name: sorted(set().union(*[names_in(t.expr) for t in d.terms]) & index.keys()) if d.terms else []
            for name, d in m.derived.items()}
    rank: dict[str, int] = {}
    waiting: set[str] = set()  # on the stack, under their dependencies
    for root in m.derived:  # depth first with an explicit stack (a chain may be long)
        todo = [root]
        while todo:
            name = todo[-1]
            if name in rank:
                todo.pop()
                continue
            missing = [d for d in deps[name] if d not in rank]
            if missing:
                if name in waiting or waiting.intersection(missing):  # pragma: no cover - rejected by the spec layer
                    raise SpecError("circular derived quantities", file=m.path, field="derived")
                waiting.add(name)
                todo += missing
                continue
            waiting.discard(name)
            rank[name] = max([rank[d] + (index[d] > index[name]) for d in deps[name]], default=0)
            todo.pop()
    return sorted(m.derived, key=lambda name: (rank[name], index[name]))


class Namespace:
    """Sympy symbols and derived expressions of one resolved scene.

    Attributes
    ----------
    t
        The time symbol.
    params
        Parameter symbols by name (all model parameters).
    coords, vels
        Coordinate and velocity symbols by name (before any reduction); coordinates
        whose ``effect`` is off are left out and read as 0 in every expression.
    bound
        One symbol per distinct call of a bound (numeric) function of parameters,
        e.g. ``wm_mean_height(D, G, lam, L_c, l_a)``, mapped to ``(function name,
        argument parameter names)``; the compiled system evaluates it when the
        parameters are bound and passes it as a parameter.
    sched_n, sched_seg
        Cycle-index and segment-index symbols of each schedule.
    derived
        With ``structured=True``: the symbol of every derived quantity that depends on
        parameters only (no time, state or schedule), mapped to its definition (in
        parameters and the symbols of earlier such quantities).  Expressions then keep
        these names (``m_e``, ``omega_n``) instead of their inlined definitions; see
        :meth:`inline`.  Empty otherwise.

    Parameters
    ----------
    rs
        The resolved scene.
    structured
        Keep parameter-only derived quantities as symbols (see ``derived``); ``"all"``:
        every derived quantity, also those of time and states (for differentiating by
        the chain rule through named intermediate quantities).
    """

    def __init__(self, rs: ResolvedScene, structured: bool | str = False):
        self.rs = rs
        self.derived: dict[sp.Symbol, sp.Expr] = {}
        m = rs.model
        self.t = sp.Symbol("t", real=True)
        self.params = {p: sp.Symbol(p, real=True) for p in m.parameters}
        on = [c for c in m.coordinates.values() if rs.effect_active(c.effect)]
        self.coords = {c.name: sp.Symbol(c.name, real=True) for c in on}
        self.vels = {c.velocity: sp.Symbol(c.velocity, real=True) for c in on}
        #: algebraic variables (constraint multipliers) by name
        self.alg = {a: sp.Symbol(a, real=True) for a in getattr(m, "algebraic", {})}
        self.bound: dict[sp.Symbol, tuple[str, tuple[str, ...]]] = {}
        self.sched_n = {s: internal_symbol(f"n_{s}") for s in m.schedules}
        self.sched_seg = {s: internal_symbol(f"seg_{s}") for s in m.schedules}
        self._local: dict[str, sp.Basic] = {"t": self.t}
        self._local.update(self.params)
        self._local.update(self.coords)
        self._local.update(self.vels)
        if m.reduction is not None:  # the reduced states, for [outputs] (never before the reduction)
            self._local[m.reduction.coordinate] = sp.Symbol(m.reduction.coordinate, real=True)
            self._local[m.reduction.velocity] = sp.Symbol(m.reduction.velocity, real=True)
        self._local.update(self.alg)
        #: the switching surfaces written in the fields parsed so far, with their names
        self.surfaces = SurfaceFinder(frozenset({*self.coords.values(), *self.vels.values(), *self.alg.values()}),
                                      self.t, m.path)
        for c in m.coordinates.values():
            if c.name not in self.coords:  # gated coordinate of a switched-off effect
                self._local[c.name] = sp.Integer(0)
                self._local[c.velocity] = sp.Integer(0)
        self.schedule_period: dict[str, sp.Expr] = {}
        self.schedule_breaks: dict[str, list[sp.Expr]] = {}
        # Schedule periods/breaks may use derived quantities, and derived quantities may
        # use a schedule's phase: the phase is first written with a placeholder period,
        # the periods and breaks are parsed after the derived quantities, and the
        # placeholders are then replaced (see the end of __init__).
        placeholder = {s: sp.Dummy(f"period_{s}", positive=True) for s in m.schedules}
        self._placeholder = placeholder
        #: the model's tables written into the equations (gearsym/symbolic/tables.py)
        self.tables = TableLowering(self, internal_symbol)
        for s in m.schedules.values():
            self._local[f"{s.name}_phase"] = self.t / placeholder[s.name] - self.sched_n[s.name]
            self._local[f"{s.name}_segment"] = self.sched_seg[s.name]
        # derived quantities, in dependency order (validated acyclic by the spec layer)
        for name in _derived_order(m):
            value = self.sum_terms(m.derived[name].terms)
            if structured and not value.is_Atom and (structured == "all" or self._parameter_only(value)):
                sym = sp.Symbol(name, real=True)
                self.derived[sym] = value
                value = sym
            self._local[name] = value
        for s in m.schedules.values():
            self.schedule_period[s.name] = self.parse(s.period, f"schedules.{s.name}.period")
            self.schedule_breaks[s.name] = [self.parse(b, f"schedules.{s.name}.breaks[{i}]")
                                            for i, b in enumerate(s.breaks)]
        fill = {placeholder[s]: self.schedule_period[s] for s in m.schedules}
        if fill:
            for s in m.schedules:
                self.schedule_period[s] = self.schedule_period[s].xreplace(fill)
                self.schedule_breaks[s] = [b.xreplace(fill) for b in self.schedule_breaks[s]]
                self._local[f"{s}_phase"] = self.t / self.schedule_period[s] - self.sched_n[s]
            for name in m.derived:
                self._local[name] = self._local[name].xreplace(fill)
            for s in self.tables.hidden:  # hidden schedules of tables called by derived quantities
                self.schedule_period[s] = self.schedule_period[s].xreplace(fill)
            self.tables.display = {k.xreplace(fill): v for k, v in self.tables.display.items()}

    def period_of(self, schedule: str) -> sp.Expr:
        """The period of a schedule (a placeholder while the derived quantities are read)."""
        return self.schedule_period.get(schedule, self._placeholder.get(schedule))

    def _table(self, node: sx.Node, visit: Callable[[sx.Node], sp.Basic], where: str,
               record: Recorder | None) -> sp.Basic | None:
        """A call of a table, or a table's bare name (its declared arguments); ``None``: not a table."""
        tables = self.rs.model.tables
        name = node.func if isinstance(node, sx.Call) else node.id  # type: ignore[union-attr]
        if name not in tables:
            return None
        table = tables[name]
        if isinstance(node, sx.Call):
            args = node.args
        else:
            if not table.arguments:
                raise ExpressionError(f"table '{name}' is used by its name but declares no arguments")
            args = tuple(parse(a).body for a in table.arguments)
        return self.tables.call(table, args, visit, where, record)

    def _parameter_only(self, expr: sp.Basic) -> bool:
        """Whether ``expr`` depends on parameters (and parameter-only derived quantities) only."""
        allowed = set(self.params.values()) | set(self.bound) | set(self.derived)
        return expr.free_symbols <= allowed

    def inline(self, expr: sp.Basic) -> sp.Basic:
        """``expr`` with every derived symbol replaced by its (fully inlined) definition."""
        if not self.derived or not (expr.free_symbols & self.derived.keys()):
            return expr
        return expr.xreplace(self.inlined_definitions())

    def inlined_definitions(self) -> dict[sp.Symbol, sp.Expr]:
        """Every derived symbol mapped to its definition in parameters alone."""
        cached = self.__dict__.get("_inlined")
        if cached is None:
            cached = {}
            for sym, value in self.derived.items():  # dependency order: earlier ones are done
                cached[sym] = value.xreplace(cached) if value.free_symbols & cached.keys() else value
            self.__dict__["_inlined"] = cached
        return cached

    def _bound_call(self, fname: str, names: list[str]) -> sp.Symbol:
        """The parameter-like symbol standing for ``fname(p1, p2, ...)``."""
        for a in names:
            if a not in self.params:
                raise SpecError(f"arguments of {fname}() must be parameter names, got '{a}'",
                                file=self.rs.model.path)
        sym = sp.Symbol(f"{fname}({', '.join(names)})", real=True)
        self.bound[sym] = (fname, tuple(names))
        return sym

    def parse(self, text: str, where: str = "", surfaces: tuple[str, ...] = ()) -> sp.Expr:
        """Build the sympy expression of an expression string (checked by the spec layer).

        The result is measured before anything else walks it (:mod:`gearsym.symbolic.budget`:
        a chain of derived quantities can make it grow without bound), and its switching
        surfaces are recorded (:attr:`surfaces`), named by ``surfaces`` if given.
        """
        checkpoint(where or None)
        try:
            tree = parse(text)
            record = self.surfaces.recorder(tree, where)
            out = Builder(self._local, self._bound_call, record,
                          lambda node, visit: self._table(node, visit, where, record)).build(tree)
            check_expression(out, self.rs.model.path, where or None, dynamic=self.surfaces.dynamic)
            if out.has(*_NOT_REAL):
                raise ExpressionError(f"'{quote(text)}' evaluates to an infinite, undefined or complex "
                                      f"value ({sp.sstr(out)[:60]})")
            self.surfaces.collect(record, surfaces)
            return out
        except ExpressionError as exc:
            raise SpecError(str(exc), file=self.rs.model.path, field=where or None) from None
        except RecursionError:
            raise SpecError("expression too deeply nested for the symbolic layer", file=self.rs.model.path,
                            field=where or None) from None

    def sum_terms(self, terms: tuple[Term, ...], el_effect: str | None = None,
                  el_variant: str | None = None) -> sp.Expr:
        """Sum of the active terms of an expression field (one ``Add``: the same object as
        adding them one by one, in one pass however many terms there are)."""
        return sp.Add(*[self.parse(term.expr, term.field, term.surface) for term in terms
                        if self.rs.is_active(term, el_effect, el_variant)])

    def param_value(self, name: str) -> float:
        """SI value of a parameter in the resolved scene."""
        return self.rs.values[name]
