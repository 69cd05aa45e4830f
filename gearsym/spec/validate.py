"""Cross-field checks of a parsed model: symbols, effects, units, circular definitions."""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import expressions as ex
from .constraints import validate_constraints
from .elements import UnitCheck, element_type
from .fields import Ctx, Term, did_you_mean, unit_of
from .reduction import reduction_units
from .units import ONE, Unit

if TYPE_CHECKING:
    from .model import ModelSpec


def validate_model(ctx: Ctx, spec: ModelSpec) -> None:
    """Cross-field checks: symbols, effects, units, circular definitions."""
    units = _base_units(spec)
    tables = ex.TableContext(spec.tables, frozenset(f"{s}_phase" for s in spec.schedules))
    _check_terms(ctx, spec)
    _check_tables(ctx, spec, units, tables)
    _derived_units(ctx, spec, units, tables)
    _check_schedules(ctx, spec, units)
    energy = _Energy(ctx)
    check = UnitCheck(ctx, spec, lambda terms: _terms_unit(ctx, terms, units, tables), energy.of)
    for el in spec.elements.values():  # each element type's unit rules (gearsym/spec/elements/)
        element_type(el.type).check_units(el, check)
    tt = spec.time_dims
    for eq in spec.equations.values():
        c = spec.coordinates[eq.coordinate]
        if eq.force:
            u = _terms_unit(ctx, eq.force, units, tables)
            if u is not None:
                energy.of(f"equations.{eq.coordinate}.force", u * c.dims)
        if eq.mass:
            u = _terms_unit(ctx, eq.mass, units, tables)
            if u is not None:
                energy.of(f"equations.{eq.coordinate}.mass", u * (c.dims / tt) ** 2)
    if spec.reduction is not None:
        red_units = reduction_units(ctx, spec.reduction, spec.elements,
                                    lambda terms: _terms_unit(ctx, terms, units, tables))
        for rc in spec.reduction.coordinates:
            units[rc.name] = Unit(1.0, red_units[rc.name].dims)
            units[rc.velocity] = units[rc.name] / spec.time_dims
    has_mass = {q for el in spec.elements.values() for q in element_type(el.type).mass_coordinates(el)}
    has_mass |= {q for q, eq in spec.equations.items() if eq.mass}
    for q in spec.coordinates:
        if q not in has_mass:
            raise ctx.error(f"coordinates.{q}", f"coordinate '{q}' has no inertia element and no "
                                                f"equations.{q}.mass")
    if spec.dimensionless is not None:
        _check_dimensionless(ctx, spec, units)
    for k in spec.initial:
        if k not in spec.state_names():
            raise ctx.error(f"initial.{k}", f"'{k}' is not a state{did_you_mean(k, spec.state_names())} "
                                            f"(states: {', '.join(spec.state_names())})")
    for o in spec.outputs.values():
        u = _terms_unit(ctx, o.terms, units, tables)
        if o.unit is not None and u is not None:
            declared = unit_of(ctx, f"outputs.{o.name}.unit", o.unit)
            if not u.same_dimension(declared):
                raise ctx.error(f"outputs.{o.name}.value", f"unit mismatch: value is [{u.si_string()}] "
                                                           f"but unit says [{declared.si_string()}]")
    validate_constraints(ctx, spec, units, energy.unit, [(t.field, t.expr) for _, t in _all_terms(spec)])
    spec.units.update(units)


class _Energy:
    """The common energy unit of a model's terms: the first one seen defines it."""

    def __init__(self, ctx: Ctx):
        self.ctx = ctx
        self.unit: Unit | None = None

    def of(self, where: str, u: Unit) -> None:
        """Declare that the term at ``where`` does work in the unit ``u``."""
        if self.unit is None:
            self.unit = Unit(1.0, u.dims)
        elif not u.same_dimension(self.unit):
            raise self.ctx.error(where, f"unit mismatch: this term does work in [{u.si_string()}] but "
                                        f"other terms in [{self.unit.si_string()}]")


def _base_units(spec: ModelSpec) -> dict[str, Unit]:
    """Units of time, the coordinates, velocities, parameters, algebraic variables, schedule
    symbols and declared reduced coordinates."""
    units: dict[str, Unit] = {"t": spec.time_dims}
    for c in spec.coordinates.values():
        units[c.name] = c.dims
        units[c.velocity] = c.dims / spec.time_dims
    for p in spec.parameters.values():
        units[p.name] = Unit(1.0, p.dims.dims)
    for a in spec.algebraic.values():
        units[a.name] = Unit(1.0, a.dims.dims)
    for s in spec.schedules.values():
        units[f"{s.name}_phase"] = ONE
        units[f"{s.name}_segment"] = ONE
    if spec.reduction is not None:
        for rc in spec.reduction.coordinates:
            if rc.dims is not None:
                units[rc.name] = rc.dims
                units[rc.velocity] = rc.dims / spec.time_dims
    return units


def _check_terms(ctx: Ctx, spec: ModelSpec) -> None:
    """Every term: its effect exists and its variant is one of it; bound functions take
    parameter names; every coordinate's effect exists."""
    for where, term in _all_terms(spec):
        if term.effect is not None:
            if term.effect not in spec.effects:
                raise ctx.error(where, f"effect '{term.effect}' is not in the model "
                                       f"(effects: {', '.join(spec.effects) or 'none'})")
            eff = spec.effects[term.effect]
            if term.variant is not None and term.variant not in eff.variants:
                raise ctx.error(where, f"'{term.variant}' is not a variant of effect "
                                       f"'{term.effect}' (variants: {', '.join(eff.variants) or 'none'})")
        elif term.variant is not None:
            raise ctx.error(where, "a variant needs an effect")
        for fname, args in _bound_calls(ctx, where, term.expr):
            for i, a in enumerate(args):
                if a not in spec.parameters:
                    raise ctx.error(where, f"argument {i + 1} of {fname}() must be the name of a "
                                           f"parameter (it is evaluated when parameters are bound), "
                                           f"got {a or 'an expression'}")
    for c in spec.coordinates.values():
        if c.effect is not None and c.effect not in spec.effects:
            raise ctx.error(f"coordinates.{c.name}.effect", f"effect '{c.effect}' is not in the model "
                                                             f"(effects: {', '.join(spec.effects) or 'none'})")


def _check_tables(ctx: Ctx, spec: ModelSpec, units: dict[str, Unit], tables: ex.TableContext) -> None:
    """A table's ``scale`` is a dimensionless expression of the parameters; its ``arguments`` (what
    its bare name means) fit its domain and use no derived quantity and no bare table name."""
    for t in spec.tables.values():
        where = f"tables.{t.name}"
        if t.scale is not None:
            bad = sorted(_names(ctx, f"{where}.scale", t.scale) - set(spec.parameters))
            if bad:
                raise ctx.error(f"{where}.scale", f"must be an expression of the parameters, not of "
                                                  f"{', '.join(bad)}")
            _expect(ctx, f"{where}.scale", t.scale, units, ONE, "dimensionless")
        if not t.arguments:
            continue
        for i, a in enumerate(t.arguments):
            bad = sorted(n for n in _names(ctx, f"{where}.arguments", a) if n in spec.derived or
                         (n in spec.tables and n not in {f for f, _ in ex.table_calls(a)}))
            if bad:
                raise ctx.error(f"{where}.arguments", f"argument {i + 1} may not use {', '.join(bad)} (derived "
                                                      f"quantities and bare table names: write the expression)")
        try:
            ex.infer_unit(f"{t.name}({', '.join(t.arguments)})", units, tables)
        except ex.ExpressionError as exc:
            raise ctx.error(f"{where}.arguments", str(exc)) from None


def _derived_units(ctx: Ctx, spec: ModelSpec, units: dict[str, Unit], tables: ex.TableContext) -> None:
    """Units of the derived quantities, in dependency order (a cycle is an error)."""
    for dname in _derived_order(ctx, spec):
        d = spec.derived[dname]
        u = _terms_unit(ctx, d.terms, units, tables)
        if d.unit is not None:
            declared = unit_of(ctx, f"derived.{dname}.unit", d.unit)
            if u is not None and not u.same_dimension(declared):
                raise ctx.error(f"derived.{dname}.value",
                                f"unit mismatch: value is [{u.si_string()}] but unit says "
                                f"[{declared.si_string()}]")
            u = declared
        units[dname] = u if u is not None else ONE


def _check_schedules(ctx: Ctx, spec: ModelSpec, units: dict[str, Unit]) -> None:
    """Schedule periods and the forcing period are times, breaks dimensionless, all functions of
    the parameters only."""
    for s in spec.schedules.values():
        _expect(ctx, f"schedules.{s.name}.period", s.period, units, spec.time_dims, "a time")
        for i, b in enumerate(s.breaks):
            _expect(ctx, f"schedules.{s.name}.breaks[{i}]", b, units, ONE, "dimensionless")
    if spec.forcing_period is not None:
        _expect(ctx, "forcing.period", spec.forcing_period, units, spec.time_dims, "a time")
    dynamic = {"t"} | set(spec.coordinates) | {c.velocity for c in spec.coordinates.values()}
    if spec.reduction is not None:
        dynamic |= set(spec.reduction.state_names())
    checks = [("forcing.period", spec.forcing_period)] if spec.forcing_period else []
    for s in spec.schedules.values():
        checks.append((f"schedules.{s.name}.period", s.period))
        checks += [(f"schedules.{s.name}.breaks[{i}]", b) for i, b in enumerate(s.breaks)]
    for where, text in checks:
        bad = sorted(_names(ctx, where, text) & dynamic)
        if bad:
            raise ctx.error(where, f"must depend on parameters only, not on {', '.join(bad)}")


def _check_dimensionless(ctx: Ctx, spec: ModelSpec, units: dict[str, Unit]) -> None:
    """The ``[dimensionless]`` section: coordinates of the (reduced) model, groups that
    eliminate a parameter they contain, scales in the right units."""
    dl = spec.dimensionless
    assert dl is not None
    for q in dl.coordinates:
        if q not in spec.state_names()[: (len(spec.state_names()) - len(spec.algebraic)) // 2]:
            raise ctx.error(f"dimensionless.coordinates.{q}", f"'{q}' is not a coordinate of the "
                                                              f"(reduced) model{did_you_mean(q, spec.state_names())}")
    for g in dl.groups:
        gw = f"dimensionless.groups.{g.name}"
        if g.eliminates not in spec.parameters:
            raise ctx.error(f"{gw}.eliminates", f"unknown parameter '{g.eliminates}'")
        _expect(ctx, f"{gw}.definition", g.definition, units, ONE, "dimensionless")
        if g.eliminates not in ex.names_in(g.definition):
            raise ctx.error(f"{gw}.eliminates", f"'{g.eliminates}' does not appear in the definition")
    if dl.time is not None:
        _expect(ctx, "dimensionless.time", dl.time, units, spec.time_dims, "a time")
    if dl.length is not None:
        _expect(ctx, "dimensionless.length", dl.length, units, Unit(1.0, (0, 1, 0)), "a length")
    if dl.mass is not None:
        _expect(ctx, "dimensionless.mass", dl.mass, units, Unit(1.0, (1, 0, 0)), "a mass")
    for q, text in dl.coordinates.items():
        _expect(ctx, f"dimensionless.coordinates.{q}", text, units, units[q], "the coordinate's unit")


def _all_terms(spec: ModelSpec):
    for d in spec.derived.values():
        for t in d.terms:
            yield t.field, t
    for el in spec.elements.values():
        for terms in el.fields.values():
            for t in terms:
                yield t.field, t
        if el.effect is not None or el.variant is not None:
            yield f"elements.{el.name}.effect", Term("0", f"elements.{el.name}", el.effect, el.variant)
    for eq in spec.equations.values():
        for t in (*eq.mass, *eq.force):
            yield t.field, t
    if spec.reduction is not None:
        for rc in spec.reduction.coordinates:
            if rc.element is None:
                for t in rc.definition:
                    yield t.field, t


def _derived_order(ctx: Ctx, spec: ModelSpec) -> list[str]:
    """The derived quantities in dependency order; a cycle is an error.  A depth-first walk
    with its own stack: a chain of 20 000 derived quantities is no deeper for Python."""
    known = set(spec.derived)
    deps = {n: sorted(set().union(*[_names(ctx, t.field, t.expr) for t in d.terms]) & known)
            for n, d in spec.derived.items()}
    order: list[str] = []
    state: dict[str, int] = {}
    for root in spec.derived:
        if state.get(root) == 2:
            continue
        path, todo = [root], [iter(deps[root])]
        state[root] = 1
        while todo:
            m = next(todo[-1], None)
            if m is None:
                n = path.pop()
                todo.pop()
                state[n] = 2
                order.append(n)
            elif state.get(m) == 1:
                cycle = " -> ".join(path[path.index(m):] + [m])
                raise ctx.error(f"derived.{m}", f"circular definition: {cycle}")
            elif state.get(m) != 2:
                state[m] = 1
                path.append(m)
                todo.append(iter(deps[m]))
    return order


def _bound_calls(ctx: Ctx, where: str, text: str) -> list[tuple[str, list[str | None]]]:
    try:
        return ex.bound_calls(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None


def _names(ctx: Ctx, where: str, text: str) -> set[str]:
    try:
        return ex.names_in(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None


def _terms_unit(ctx: Ctx, terms: tuple[Term, ...], units: dict[str, Unit],
                tables: ex.TableContext | None = None) -> Unit | None:
    out: Unit | None = None
    for t in terms:
        try:
            u = ex.infer_unit(t.expr, units, tables)
        except ex.ExpressionError as exc:
            raise ctx.error(t.field, str(exc)) from None
        if out is not None and not out.same_dimension(u):
            raise ctx.error(t.field, f"unit mismatch: this term is [{u.si_string()}] but earlier "
                                     f"terms of the field are [{out.si_string()}]")
        out = u
    return out


def _expect(ctx: Ctx, where: str, text: str, units: dict[str, Unit], want: Unit, what: str) -> None:
    try:
        u = ex.infer_unit(text, units)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None
    if not u.same_dimension(want):
        raise ctx.error(where, f"unit mismatch: must be {what} [{want.si_string()}], "
                               f"got [{u.si_string()}]")

