"""Turn checked expression strings of a resolved scene into sympy expressions."""

from __future__ import annotations

import sympy as sp
from sympy.parsing.sympy_parser import parse_expr

from ..errors import SpecError
from ..spec.expressions import BOUND_FUNCTIONS, FUNCTIONS
from ..spec.model import Term
from ..spec.scene import ResolvedScene


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
    """

    def __init__(self, rs: ResolvedScene):
        self.rs = rs
        m = rs.model
        self.t = sp.Symbol("t", real=True)
        self.params = {p: sp.Symbol(p, real=True) for p in m.parameters}
        on = [c for c in m.coordinates.values() if rs.effect_active(c.effect)]
        self.coords = {c.name: sp.Symbol(c.name, real=True) for c in on}
        self.vels = {c.velocity: sp.Symbol(c.velocity, real=True) for c in on}
        self.bound: dict[sp.Symbol, tuple[str, tuple[str, ...]]] = {}
        self.sched_n = {s: sp.Symbol(f"n_{s}", real=True) for s in m.schedules}
        self.sched_seg = {s: sp.Symbol(f"seg_{s}", real=True) for s in m.schedules}
        self._local: dict[str, object] = {name: getattr(sp, fn) for name, fn in FUNCTIONS.items()}
        self._local.update({"pi": sp.pi, "E": sp.E, "t": self.t, "True": sp.true, "False": sp.false})
        self._local.update(self.params)
        self._local.update(self.coords)
        self._local.update(self.vels)
        for c in m.coordinates.values():
            if c.name not in self.coords:  # gated coordinate of a switched-off effect
                self._local[c.name] = sp.Integer(0)
                self._local[c.velocity] = sp.Integer(0)
        for fname in BOUND_FUNCTIONS:
            self._local[fname] = self._bound_function(fname)
        self.schedule_period: dict[str, sp.Expr] = {}
        self.schedule_breaks: dict[str, list[sp.Expr]] = {}
        # Schedule periods/breaks may use derived quantities, and derived quantities may
        # use a schedule's phase: the phase is first written with a placeholder period,
        # the periods and breaks are parsed after the derived quantities, and the
        # placeholders are then replaced (see the end of __init__).
        placeholder = {s: sp.Dummy(f"period_{s}", positive=True) for s in m.schedules}
        for s in m.schedules.values():
            self._local[f"{s.name}_phase"] = self.t / placeholder[s.name] - self.sched_n[s.name]
            self._local[f"{s.name}_segment"] = self.sched_seg[s.name]
        # derived quantities, in dependency order (validated acyclic by the spec layer)
        pending = dict(m.derived)
        while pending:
            progressed = False
            for name, d in list(pending.items()):
                from ..spec.expressions import names_in

                deps = set().union(*[names_in(t.expr) for t in d.terms]) if d.terms else set()
                if deps & set(pending):
                    continue
                self._local[name] = self.sum_terms(d.terms)
                del pending[name]
                progressed = True
            if not progressed:  # pragma: no cover - the spec layer rejects cycles
                raise SpecError("circular derived quantities", file=m.path, field="derived")
        for s in m.schedules.values():
            self.schedule_period[s.name] = self.parse(s.period, f"schedules.{s.name}.period")
            self.schedule_breaks[s.name] = [self.parse(b, f"schedules.{s.name}.breaks[{i}]")
                                            for i, b in enumerate(s.breaks)]
        fill = {placeholder[s]: self.schedule_period[s] for s in m.schedules}
        if fill:
            for s in m.schedules:
                self.schedule_period[s] = sp.sympify(self.schedule_period[s]).xreplace(fill)
                self.schedule_breaks[s] = [sp.sympify(b).xreplace(fill) for b in self.schedule_breaks[s]]
                self._local[f"{s}_phase"] = self.t / self.schedule_period[s] - self.sched_n[s]
            for name in m.derived:
                self._local[name] = sp.sympify(self._local[name]).xreplace(fill)

    def _bound_function(self, fname: str):
        """A callable that turns ``fname(p1, p2, ...)`` into a parameter-like symbol."""
        def call(*args: sp.Basic) -> sp.Symbol:
            names = []
            for a in args:
                if not (isinstance(a, sp.Symbol) and str(a) in self.params):
                    raise SpecError(f"arguments of {fname}() must be parameter names, got '{a}'",
                                    file=self.rs.model.path)
                names.append(str(a))
            sym = sp.Symbol(f"{fname}({', '.join(names)})", real=True)
            self.bound[sym] = (fname, tuple(names))
            return sym
        return call

    def parse(self, text: str, where: str = "") -> sp.Expr:
        """Parse an expression string (already checked by the spec layer)."""
        try:
            return parse_expr(text.replace("^", "**"), local_dict=dict(self._local), evaluate=True)
        except Exception as exc:  # sympy raises many types
            raise SpecError(f"cannot interpret expression '{text}': {exc}", file=self.rs.model.path,
                            field=where or None) from None

    def sum_terms(self, terms: tuple[Term, ...], el_effect: str | None = None,
                  el_variant: str | None = None) -> sp.Expr:
        """Sum of the active terms of an expression field."""
        total: sp.Expr = sp.Integer(0)
        for term in terms:
            if self.rs.is_active(term, el_effect, el_variant):
                total = total + self.parse(term.expr, term.field)
        return total

    def param_value(self, name: str) -> float:
        """SI value of a parameter in the resolved scene."""
        return self.rs.values[name]
