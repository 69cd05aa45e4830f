"""Physical ranges of parameter values: what the model demands of the values it uses.

A value is checked where the physics demands it, derived from the element or section that
uses it rather than from parameter names:

* **elements** (the ``ranges`` of each type in :mod:`gearsym.spec.elements`): an inertia's ``value`` > 0; a
  mesh's ``backlash`` (half backlash), ``stiffness`` and ``damping`` >= 0; a damper's
  ``coefficient`` >= 0; a bearing's stiffnesses and dampings >= 0; ``equations.Q.mass`` > 0
  for a coordinate without an inertia element;
* **schedules**: ``period`` > 0, every break in (0, 1) and greater than the one before (the
  C driver's rule, now checked for every schedule, also one the scene does not use);
* **declarations** in ``[parameters]``: ``min``, ``max`` (in the declared unit) and
  ``positive = true``, for parameters no element constrains.

A field is checked when the sum of its active terms is a function of the parameters only
(through derived quantities); a field that depends on time or the state (a time-varying mesh
stiffness, a dynamic backlash) is not.  :func:`parameter_rules` collects the rules of a
resolved scene; :meth:`ParameterRules.violation` checks a set of SI values.  The scene's own
values are checked when the scene is resolved (:func:`gearsym.spec.scene.resolve_scene`,
``--set`` included), every other value where a parameter vector is built
(:meth:`gearsym.system.System.param_vector`: ``params=`` of every method, map points,
continuation steps).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from . import expressions as ex
from .elements import element_type

if TYPE_CHECKING:  # pragma: no cover
    from .model import ModelSpec
    from .scene import ResolvedScene
    from .units import ParameterUnits

__all__ = ["ParameterRules", "Rule", "parameter_rules"]


@dataclass(frozen=True)
class Rule:
    """One physical range: ``lower (<|<=) sum(c * term) (<|<=) upper``.

    Attributes
    ----------
    terms
        ``(coefficient, expression)`` pairs whose sum is the checked value (SI).
    lower, upper
        Bounds (SI), ``None`` for none.
    strict
        Whether the bounds are strict (``>`` / ``<``).
    condition
        The rule in words for messages (``"positive"``, ``">= 0"``, ``"in (0, 1)"``).
    what
        What the value is (``"half backlash"``, ``"inertia"``).
    field
        The spec field the rule comes from (``elements.mesh.backlash``).
    names
        The parameters the value depends on (through derived quantities).
    """

    terms: tuple[tuple[float, str], ...]
    lower: float | None
    upper: float | None
    strict: bool
    condition: str
    what: str
    field: str
    names: frozenset[str]

    def holds(self, value: float) -> bool:
        """Whether ``value`` lies in the range."""
        if self.lower is not None and not (value > self.lower if self.strict else value >= self.lower):
            return False
        return self.upper is None or (value < self.upper if self.strict else value <= self.upper)

    @property
    def parameter(self) -> str | None:
        """The parameter the rule is about when its value is that parameter itself, else ``None``."""
        if len(self.terms) == 1 and self.terms[0][0] == 1.0 and self.terms[0][1].strip() in self.names:
            return self.terms[0][1].strip()
        return None

    @property
    def source(self) -> str:
        """The checked expression as text."""
        out = ""
        for c, t in self.terms:
            out += ("" if not out else " - " if c < 0 else " + ") + (f"({t})" if len(self.terms) > 1 else t)
        return out


class ParameterRules:
    """The physical ranges of a scene's parameter values (see the module docstring).

    Parameters
    ----------
    rules
        The rules.
    derived
        Active terms of the derived quantities the rules use (functions of the parameters).
    """

    __slots__ = ("by_name", "derived", "rules")

    def __init__(self, rules: Iterable[Rule] = (), derived: Mapping[str, tuple[str, ...]] | None = None):
        self.rules: tuple[Rule, ...] = tuple(rules)
        self.derived: dict[str, tuple[str, ...]] = dict(derived or {})
        self.by_name: dict[str, tuple[Rule, ...]] = {}
        for r in self.rules:
            for n in r.names:
                self.by_name[n] = (*self.by_name.get(n, ()), r)

    def __getstate__(self) -> tuple[tuple[Rule, ...], dict[str, tuple[str, ...]]]:
        return self.rules, self.derived

    def __setstate__(self, state: tuple[tuple[Rule, ...], dict[str, tuple[str, ...]]]) -> None:
        self.__init__(*state)  # type: ignore[misc]

    def __repr__(self) -> str:
        return f"ParameterRules({len(self.rules)} rules)"

    def value(self, rule: Rule, si: Mapping[str, float]) -> float | None:
        """The value a rule checks, at SI parameter values (``None``: not computable there)."""
        env = dict(si)
        total = 0.0
        for c, t in rule.terms:
            v = self._eval(t, env, 0)
            if v is None:
                return None
            total += c * v
        return total

    def _eval(self, text: str, env: dict[str, float], depth: int) -> float | None:
        if depth > 50:
            return None
        for n in ex.names_in(text):
            if n not in env and n in self.derived:
                parts = [self._eval(t, env, depth + 1) for t in self.derived[n]]
                if any(p is None for p in parts):
                    return None
                env[n] = float(sum(parts))  # type: ignore[arg-type]
        return ex.constant_value(text, env)

    def violation(self, si: Mapping[str, float], changed: Iterable[str] | None = None
                  ) -> tuple[Rule, float] | None:
        """The first rule the SI values ``si`` break, with the value it checks.

        Parameters
        ----------
        si
            Parameter values (SI).  A rule that uses a parameter without a value here is
            skipped (e.g. one of a switched-off effect, in a compiled system).
        changed
            Check only the rules that use one of these parameters (default: all).
        """
        if changed is None:
            todo: Iterable[Rule] = self.rules
        else:
            seen: dict[int, Rule] = {}
            for n in changed:
                for r in self.by_name.get(n, ()):
                    seen.setdefault(id(r), r)
            todo = seen.values()
        for r in todo:
            if not r.names <= si.keys():
                continue
            v = self.value(r, si)
            if v is not None and not r.holds(v):
                return r, v
        return None

    def message(self, rule: Rule, value: float, si: Mapping[str, float], units: ParameterUnits,
                with_field: bool = True, file: str | None = None) -> str:
        """The sentence for a broken rule: what, the range, the values in their declared units
        (and the rule's field, in ``file`` if given)."""
        declared = units.to_declared({n: si[n] for n in sorted(rule.names) if n in si})

        def show(n: str) -> str:
            unit = units.unit(n)
            return f"{n} = {declared[n]:g}" + ("" if unit in ("", "1") else f" {unit}")

        where = (f" ({file}: {rule.field})" if file else f" ({rule.field})") if with_field else ""
        p = rule.parameter
        if p is not None and p in declared:
            got = show(p)
        else:
            got = f"{value:g} from '{rule.source}'"
            if declared:
                got += " with " + ", ".join(show(n) for n in declared)
        return f"{rule.what}{where} must be {rule.condition}, got {got}"


# ---------------------------------------------------------------- collecting the rules

_CONDITIONS = {">0": (0.0, None, True, "positive"), ">=0": (0.0, None, False, ">= 0")}


def parameter_rules(rs: ResolvedScene) -> ParameterRules:
    """The physical ranges of a resolved scene's parameters (see the module docstring).

    Only rules whose value is a function of the parameters are kept (a field that uses
    time, a state, a schedule or a bound function is not checked here).
    """
    model = rs.model
    derived = {n: tuple(t.expr for t in d.terms if rs.is_active(t)) for n, d in model.derived.items()}
    params = set(model.parameters)
    reach = _parameter_reach(derived, params)
    rules: list[Rule] = []

    def add(terms: tuple[tuple[float, str], ...], kind: str | tuple, what: str, fld: str) -> None:
        if not terms:
            return
        names: set[str] = set()
        for _, t in terms:
            for n in ex.names_in(t):
                if n in params:
                    names.add(n)
                elif n in reach:
                    names |= reach[n]
                else:
                    return  # time, a state, a schedule or a derived quantity of those: not checked
            if ex.bound_calls(t):
                return
        lower, upper, strict, cond = _CONDITIONS[kind] if isinstance(kind, str) else kind
        rules.append(Rule(terms, lower, upper, strict, cond, what, fld, frozenset(names)))

    _element_rules(rs, add)
    _schedule_rules(model, add)
    for p in model.parameters.values():
        _declared_rules(p, add)
    return ParameterRules(rules, {n: derived[n] for n in reach})


def _parameter_reach(derived: Mapping[str, tuple[str, ...]], params: set[str]) -> dict[str, frozenset[str]]:
    """Derived quantities that are functions of the parameters only -> the parameters they use."""
    reach: dict[str, frozenset[str] | None] = {}

    def visit(name: str, depth: int) -> frozenset[str] | None:
        if name in reach:
            return reach[name]
        reach[name] = None  # a cycle (rejected by the model's validation) reads as "not a parameter function"
        if depth > 50:
            return None
        out: set[str] = set()
        for t in derived[name]:
            if ex.bound_calls(t):
                return None
            for n in ex.names_in(t):
                if n in params:
                    out.add(n)
                elif n in derived:
                    sub = visit(n, depth + 1)
                    if sub is None:
                        return None
                    out |= sub
                else:
                    return None
        reach[name] = frozenset(out)
        return reach[name]

    for n in derived:
        visit(n, 0)
    return {n: r for n, r in reach.items() if r is not None}


def _element_rules(rs: ResolvedScene, add) -> None:
    """The field ranges of the active elements, and ``equations.Q.mass`` > 0 without an inertia."""
    model = rs.model
    with_inertia: set[str] = set()
    for el in model.elements.values():
        if not rs.effect_active(el.effect, el.variant):
            continue
        if el.coordinate is not None and not rs.coordinate_active(el.coordinate):
            continue
        etype = element_type(el.type)
        with_inertia.update(etype.mass_coordinates(el))
        for key, (kind, what) in etype.ranges.items():
            terms = tuple((1.0, t.expr) for t in el.fields.get(key, ()) if rs.is_active(t, el.effect, el.variant))
            add(terms, kind, etype.range_label(el, what), f"elements.{el.name}.{key}")
    for q, eq in model.equations.items():
        if q in with_inertia or not rs.coordinate_active(q):
            continue
        terms = tuple((1.0, t.expr) for t in eq.mass if rs.is_active(t))
        add(terms, ">0", f"mass of coordinate '{q}'", f"equations.{q}.mass")


def _schedule_rules(model: ModelSpec, add) -> None:
    """Every schedule (used by the scene or not): period > 0, breaks 0 < c_1 < c_2 < ... < 1."""
    for s in model.schedules.values():
        w = f"schedules.{s.name}"
        add(((1.0, s.period),), ">0", f"period of schedule '{s.name}'", f"{w}.period")
        for i, b in enumerate(s.breaks):
            add(((1.0, b),), (0.0, 1.0, True, "in (0, 1) (a fraction of the cycle)"),
                f"break {i} of schedule '{s.name}'", f"{w}.breaks[{i}]")
            if i:
                add(((1.0, b), (-1.0, s.breaks[i - 1])), (0.0, None, True, f"greater than break {i - 1}"),
                    f"break {i} of schedule '{s.name}'", f"{w}.breaks[{i}]")


def _declared_rules(p, add) -> None:
    """``min``, ``max`` and ``positive`` of a ``[parameters]`` entry (declared unit -> SI bounds)."""
    unit = "" if p.unit in ("", "1") else f" {p.unit}"
    w = f"parameters.{p.name}"
    if p.positive:
        add(((1.0, p.name),), ">0", f"parameter '{p.name}'", w)
    if p.minimum is not None:
        add(((1.0, p.name),), (p.minimum * p.si_scale, None, False, f">= {p.minimum:g}{unit} (its min)"),
            f"parameter '{p.name}'", w)
    if p.maximum is not None:
        add(((1.0, p.name),), (None, p.maximum * p.si_scale, False, f"<= {p.maximum:g}{unit} (its max)"),
            f"parameter '{p.name}'", w)
