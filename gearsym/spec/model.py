"""Model spec language v1: parse and validate ``models/*.toml``.

A model file describes a gear model declaratively (see ``docs/spec.md`` and the
shipped models).  This module turns it into immutable dataclasses and validates it:
every problem is a :class:`~gearsym.errors.SpecError` naming the file, the dotted
field path and the problem (unknown symbol, unit mismatch, missing parameter,
effect not in the model, duplicate name, wrong type).

Expression fields (stiffness, damping, deflection, forces, ...) take either

* a string expression, e.g. ``"k_m + k_a*cos(omega*t)"``;
* a table with a ``type``: ``sinusoid`` (``amplitude``, ``frequency``, ``phase``),
  ``fourier`` (``frequency``, ``mean``, ``cos = [...]``, ``sin = [...]``) or
  ``piecewise_cycle`` (``schedule``, ``values = [...]``, one per segment; values may
  use ``phase``, the position in the cycle in [0, 1)), optionally with ``effect`` /
  ``variant``;
* a table ``{ expr = "...", effect = "...", variant = "..." }``; or
* an array of the above, whose active terms are summed.

A coordinate may carry ``effect = "NAME"``: it (and its velocity state) exists only
while that effect is on; switched off, it reads as 0 everywhere and its equations,
inertia/force elements and the parameters only they use disappear.

Expressions may call the bound (numeric) functions of
:data:`~gearsym.spec.expressions.BOUND_FUNCTIONS` with parameter names as arguments,
e.g. ``wm_mean_height(D, G, lam, L_c, l_a)``; the compiled system evaluates them
whenever the parameters are bound (:mod:`gearsym.bound_functions`).

The spec layer knows nothing of sympy: expressions are checked with :mod:`ast`.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SpecError
from . import expressions as ex
from .reduction import Reduction, parse_reduction, reduction_units
from .units import ONE, Unit, UnitSyntaxError, parse_unit

# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Term:
    """One term of an expression field, possibly tagged with an effect (variant)."""

    expr: str
    field: str
    effect: str | None = None
    variant: str | None = None


@dataclass(frozen=True)
class Parameter:
    """A run-time parameter: ``value`` in ``unit`` (converted to SI as ``si_value``)."""

    name: str
    value: float
    unit: str
    meaning: str
    si_scale: float
    dims: Unit

    @property
    def si_value(self) -> float:
        """The value in SI units."""
        return self.value * self.si_scale


@dataclass(frozen=True)
class Coordinate:
    """A generalised coordinate and the name of its velocity state.

    ``effect``: if set, the coordinate (and its velocity) exists only while that
    effect is on; when it is off the coordinate is identically zero, its state is
    removed and its ``[equations]`` / inertia / force elements contribute nothing.
    """

    name: str
    unit: str
    meaning: str
    velocity: str
    dims: Unit
    effect: str | None = None


@dataclass(frozen=True)
class Derived:
    """A named derived quantity: the sum of its active terms."""

    name: str
    terms: tuple[Term, ...]
    unit: str | None
    meaning: str


@dataclass(frozen=True)
class Effect:
    """A physical effect that scenes switch on or off (compile-time)."""

    name: str
    meaning: str
    default: bool | str
    variants: tuple[str, ...] = ()
    requires: tuple[str, ...] = ()


@dataclass(frozen=True)
class Schedule:
    """A periodic schedule of breakpoints (piecewise-in-time coefficients)."""

    name: str
    period: str
    breaks: tuple[str, ...]  # interior break fractions in (0, 1); 0 is implicit
    meaning: str


@dataclass(frozen=True)
class Element:
    """A lumped element: ``inertia``, ``spring``, ``damper``, ``mesh`` or ``force``."""

    name: str
    type: str
    fields: dict[str, tuple[Term, ...]]
    coordinate: str | None = None
    drive_side: str = "positive"
    effect: str | None = None
    variant: str | None = None
    meaning: str = ""


@dataclass(frozen=True)
class Equation:
    """Explicit additions to the equation of one coordinate: ``mass`` and ``force``."""

    coordinate: str
    mass: tuple[Term, ...]
    force: tuple[Term, ...]


@dataclass(frozen=True)
class Group:
    """A dimensionless group: its definition and the parameter it eliminates."""

    name: str
    definition: str
    eliminates: str
    meaning: str


@dataclass(frozen=True)
class Dimensionless:
    """Reference scales for the dimensionless form, and the named groups."""

    time: str
    coordinates: dict[str, str]
    groups: tuple[Group, ...]


@dataclass(frozen=True)
class ModelSpec:
    """A validated model file."""

    path: str
    name: str
    description: str
    reference: str
    form: str
    time_unit: str
    time_dims: Unit
    coordinates: dict[str, Coordinate]
    parameters: dict[str, Parameter]
    derived: dict[str, Derived]
    effects: dict[str, Effect]
    schedules: dict[str, Schedule]
    elements: dict[str, Element]
    equations: dict[str, Equation]
    reduction: Reduction | None
    forcing_period: str | None
    initial: dict[str, float]
    dimensionless: Dimensionless | None
    notes: str = ""
    units: dict[str, Unit] = field(default_factory=dict, repr=False)
    outputs: dict[str, Derived] = field(default_factory=dict)

    def state_names(self) -> list[str]:
        """Names of the first-order states: coordinates then velocities."""
        if self.reduction is not None:
            return self.reduction.state_names()
        coords = list(self.coordinates.values())
        return [c.name for c in coords] + [c.velocity for c in coords]


# ------------------------------------------------------------------------ parsing

_TOP = {"model", "coordinates", "parameters", "derived", "effects", "schedules", "elements",
        "equations", "reduction", "forcing", "initial", "dimensionless", "outputs"}
_ELEMENT_FIELDS = {
    "inertia": ({"value"}, set()),
    "spring": ({"deflection", "stiffness"}, set()),
    "damper": ({"deflection", "coefficient"}, set()),
    "mesh": ({"deflection", "stiffness"}, {"error", "damping", "backlash"}),
    "force": ({"value"}, set()),
}
_ELEMENT_META = {"type", "coordinate", "effect", "variant", "meaning", "drive_side"}


class _Ctx:
    """Parsing context: the file name for errors."""

    def __init__(self, path: str):
        self.path = path

    def error(self, field_path: str | None, message: str) -> SpecError:
        return SpecError(message, file=self.path, field=field_path)


def load_model(path: str | Path) -> ModelSpec:
    """Read and validate a model file.

    Parameters
    ----------
    path
        Path of a ``models/*.toml`` file.

    Returns
    -------
    ModelSpec

    Raises
    ------
    SpecError
        If the file is missing, is not valid TOML, or fails validation; the
        message names the file and the field.
    """
    path = Path(path)
    ctx = _Ctx(str(path))
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ctx.error(None, "model file not found") from None
    except OSError as exc:
        raise ctx.error(None, f"cannot read model file: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise ctx.error(None, "not a text (UTF-8) file") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error(None, f"TOML syntax error: {exc}") from None
    return parse_model(data, ctx.path)


def parse_model(data: dict[str, Any], path: str = "<model>") -> ModelSpec:
    """Validate an already-parsed model document (see :func:`load_model`)."""
    ctx = _Ctx(path)
    for key in data:
        if key not in _TOP:
            raise ctx.error(key, f"unknown section '{key}' (known: {', '.join(sorted(_TOP))})")
    meta = _table(ctx, data, "model", required=True)
    name = _str(ctx, meta, "model.name", required=True)
    form = _str(ctx, meta, "model.form") or "explicit"
    if form not in ("explicit", "implicit"):
        raise ctx.error("model.form", f"must be 'explicit' or 'implicit', got '{form}'")
    time_unit = _str(ctx, meta, "model.time_unit") or "s"
    time_dims = _unit(ctx, "model.time_unit", time_unit)
    if not (time_dims.dims == (0, 0, 1) or time_dims.dimensionless):
        raise ctx.error("model.time_unit", f"'{time_unit}' is not a unit of time")
    if time_dims.scale != 1.0:
        raise ctx.error("model.time_unit", "time must be in seconds ('s') or dimensionless ('1')")

    names: dict[str, str] = {}  # name -> where declared

    def declare(n: str, where: str) -> None:
        problem = ex.check_identifier(n)
        if problem:
            raise ctx.error(where, problem)
        if n in names:
            raise ctx.error(where, f"duplicate name '{n}' (already declared at {names[n]})")
        names[n] = where

    # coordinates
    coordinates: dict[str, Coordinate] = {}
    for cname, c in _table(ctx, data, "coordinates", required=True).items():
        where = f"coordinates.{cname}"
        c = _as_table(ctx, where, c)
        _only(ctx, where, c, {"unit", "meaning", "velocity", "effect"})
        unit = _str(ctx, c, f"{where}.unit") or "1"
        dims = _unit(ctx, f"{where}.unit", unit)
        if dims.scale != 1.0:
            raise ctx.error(f"{where}.unit", f"coordinates must be in coherent SI units, not '{unit}'")
        vel = _str(ctx, c, f"{where}.velocity") or f"{cname}_dot"
        declare(cname, where)
        declare(vel, f"{where}.velocity")
        coordinates[cname] = Coordinate(cname, unit, _str(ctx, c, f"{where}.meaning") or "", vel, dims,
                                        _str(ctx, c, f"{where}.effect"))
    if not coordinates:
        raise ctx.error("coordinates", "a model needs at least one coordinate")

    # parameters
    parameters: dict[str, Parameter] = {}
    for pname, p in _table(ctx, data, "parameters").items():
        where = f"parameters.{pname}"
        if isinstance(p, (int, float)) and not isinstance(p, bool):
            p = {"value": p}
        p = _as_table(ctx, where, p)
        _only(ctx, where, p, {"value", "unit", "meaning"})
        declare(pname, where)
        if "value" not in p:
            raise ctx.error(f"{where}.value", f"missing value for parameter '{pname}'")
        value = _number(ctx, f"{where}.value", p["value"])
        unit = _str(ctx, p, f"{where}.unit") or "1"
        dims = _unit(ctx, f"{where}.unit", unit)
        parameters[pname] = Parameter(pname, value, unit, _str(ctx, p, f"{where}.meaning") or "",
                                      dims.scale, dims)

    # effects
    effects: dict[str, Effect] = {}
    for ename, e in _table(ctx, data, "effects").items():
        where = f"effects.{ename}"
        e = _as_table(ctx, where, e)
        _only(ctx, where, e, {"meaning", "default", "variants", "requires"})
        problem = ex.check_identifier(ename)
        if problem:
            raise ctx.error(where, problem)
        variants = tuple(_str_list(ctx, e, f"{where}.variants"))
        default = e.get("default", True)
        if not isinstance(default, (bool, str)):
            raise ctx.error(f"{where}.default", "must be true, false or a variant name")
        if isinstance(default, str) and default not in variants:
            raise ctx.error(f"{where}.default", f"'{default}' is not a variant of '{ename}' "
                                                f"(variants: {', '.join(variants) or 'none'})")
        if default is True and variants:
            default = variants[0]
        effects[ename] = Effect(ename, _str(ctx, e, f"{where}.meaning") or "", default, variants,
                                tuple(_str_list(ctx, e, f"{where}.requires")))
    for e in effects.values():
        for r in e.requires:
            if r not in effects:
                raise ctx.error(f"effects.{e.name}.requires", f"effect '{r}' is not in the model")
            if r == e.name:
                raise ctx.error(f"effects.{e.name}.requires", "an effect cannot require itself")

    # schedules
    schedules: dict[str, Schedule] = {}
    for sname, s in _table(ctx, data, "schedules").items():
        where = f"schedules.{sname}"
        s = _as_table(ctx, where, s)
        _only(ctx, where, s, {"period", "breaks", "meaning"})
        declare(f"{sname}_phase", where)
        declare(f"{sname}_segment", where)
        if "period" not in s:
            raise ctx.error(f"{where}.period", "missing period")
        breaks = s.get("breaks", [])
        if not isinstance(breaks, list):
            raise ctx.error(f"{where}.breaks", "must be an array of expressions (fractions of the cycle)")
        schedules[sname] = Schedule(sname, _expr_str(ctx, f"{where}.period", s["period"]),
                                    tuple(_expr_str(ctx, f"{where}.breaks[{i}]", b)
                                          for i, b in enumerate(breaks)),
                                    _str(ctx, s, f"{where}.meaning") or "")

    # derived
    derived = _quantities(ctx, data, "derived", declare, schedules)

    # elements
    elements: dict[str, Element] = {}
    for lname, el in _table(ctx, data, "elements").items():
        where = f"elements.{lname}"
        el = _as_table(ctx, where, el)
        etype = _str(ctx, el, f"{where}.type", required=True)
        if etype not in _ELEMENT_FIELDS:
            raise ctx.error(f"{where}.type", f"unknown element type '{etype}' "
                                             f"(known: {', '.join(_ELEMENT_FIELDS)})")
        required, optional = _ELEMENT_FIELDS[etype]
        _only(ctx, where, el, required | optional | _ELEMENT_META)
        for r in sorted(required):
            if r not in el:
                raise ctx.error(f"{where}.{r}", f"missing field '{r}' of {etype} element")
        coord = None
        if etype in ("inertia", "force"):
            coord = _str(ctx, el, f"{where}.coordinate", required=True)
            if coord not in coordinates:
                raise ctx.error(f"{where}.coordinate", f"unknown coordinate '{coord}'")
        drive = _str(ctx, el, f"{where}.drive_side") or "positive"
        if drive not in ("positive", "negative"):
            raise ctx.error(f"{where}.drive_side", "must be 'positive' or 'negative'")
        fields = {k: _terms(ctx, f"{where}.{k}", el[k], schedules) for k in sorted(required | optional)
                  if k in el}
        elements[lname] = Element(lname, etype, fields, coord, drive,
                                  _str(ctx, el, f"{where}.effect"), _str(ctx, el, f"{where}.variant"),
                                  _str(ctx, el, f"{where}.meaning") or "")

    # explicit equations
    equations: dict[str, Equation] = {}
    for qname, eq in _table(ctx, data, "equations").items():
        where = f"equations.{qname}"
        if qname not in coordinates:
            raise ctx.error(where, f"unknown coordinate '{qname}'")
        eq = _as_table(ctx, where, eq)
        _only(ctx, where, eq, {"mass", "force"})
        equations[qname] = Equation(
            qname,
            _terms(ctx, f"{where}.mass", eq["mass"], schedules) if "mass" in eq else (),
            _terms(ctx, f"{where}.force", eq["force"], schedules) if "force" in eq else (),
        )

    # reduction (gearsym/spec/reduction.py)
    reduction = None
    if "reduction" in data:
        reduction = parse_reduction(
            ctx, _table(ctx, data, "reduction"), declare, elements,
            lambda where, value: _terms(ctx, where, value, schedules),
            lambda table, where: _str(ctx, table, where), lambda where, text: _unit(ctx, where, text))

    forcing = _table(ctx, data, "forcing")
    _only(ctx, "forcing", forcing, {"period"})
    period = _expr_str(ctx, "forcing.period", forcing["period"]) if "period" in forcing else None

    initial: dict[str, float] = {}
    for k, v in _table(ctx, data, "initial").items():
        initial[k] = _number(ctx, f"initial.{k}", v)

    dimless = None
    if "dimensionless" in data:
        dl = _table(ctx, data, "dimensionless")
        _only(ctx, "dimensionless", dl, {"time", "coordinates", "groups"})
        groups = []
        for gname, g in _as_table(ctx, "dimensionless.groups", dl.get("groups", {})).items():
            gw = f"dimensionless.groups.{gname}"
            g = _as_table(ctx, gw, g)
            _only(ctx, gw, g, {"definition", "eliminates", "meaning"})
            groups.append(Group(gname, _expr_str(ctx, f"{gw}.definition", g.get("definition")),
                                _str(ctx, g, f"{gw}.eliminates", required=True),
                                _str(ctx, g, f"{gw}.meaning") or ""))
        dimless = Dimensionless(
            _expr_str(ctx, "dimensionless.time", dl.get("time", "1")),
            {k: _expr_str(ctx, f"dimensionless.coordinates.{k}", v)
             for k, v in _as_table(ctx, "dimensionless.coordinates", dl.get("coordinates", {})).items()},
            tuple(groups),
        )

    # outputs: quantities evaluated along trajectories (e.g. the dynamic backlash B(t))
    outputs = _quantities(ctx, data, "outputs", declare, schedules)

    spec = ModelSpec(
        path=path, name=name, description=_str(ctx, meta, "model.description") or "",
        reference=_str(ctx, meta, "model.reference") or "", form=form, time_unit=time_unit,
        time_dims=time_dims, coordinates=coordinates, parameters=parameters, derived=derived,
        effects=effects, schedules=schedules, elements=elements, equations=equations,
        reduction=reduction, forcing_period=period, initial=initial, dimensionless=dimless,
        notes=_str(ctx, meta, "model.notes") or "", outputs=outputs,
    )
    _validate(ctx, spec)
    return spec


# ------------------------------------------------------------------ validation


def _validate(ctx: _Ctx, spec: ModelSpec) -> None:
    """Cross-field checks: symbols, effects, units, circular definitions."""
    units: dict[str, Unit] = {"t": spec.time_dims}
    for c in spec.coordinates.values():
        units[c.name] = c.dims
        units[c.velocity] = c.dims / spec.time_dims
    for p in spec.parameters.values():
        units[p.name] = Unit(1.0, p.dims.dims)
    for s in spec.schedules.values():
        units[f"{s.name}_phase"] = ONE
        units[f"{s.name}_segment"] = ONE
    if spec.reduction is not None:
        for rc in spec.reduction.coordinates:
            if rc.dims is not None:
                units[rc.name] = rc.dims
                units[rc.velocity] = rc.dims / spec.time_dims

    # every term: effects exist, variants valid
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

    # derived: order by dependency (detect cycles), infer units
    order = _derived_order(ctx, spec)
    for dname in order:
        d = spec.derived[dname]
        u = _terms_unit(ctx, d.terms, units)
        if d.unit is not None:
            declared = _unit(ctx, f"derived.{dname}.unit", d.unit)
            if u is not None and not u.same_dimension(declared):
                raise ctx.error(f"derived.{dname}.value",
                                f"unit mismatch: value is [{u.si_string()}] but unit says "
                                f"[{declared.si_string()}]")
            u = declared
        units[dname] = u if u is not None else ONE

    # schedules
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

    # elements: a common energy unit
    energy: list[Unit | None] = [None]  # first one seen defines it

    def energy_of(where: str, u: Unit) -> None:
        if energy[0] is None:
            energy[0] = Unit(1.0, u.dims)
        elif not u.same_dimension(energy[0]):
            raise ctx.error(where, f"unit mismatch: this term does work in [{u.si_string()}] but "
                                   f"other terms in [{energy[0].si_string()}]")

    tt = spec.time_dims
    for el in spec.elements.values():
        w = f"elements.{el.name}"
        f = el.fields
        if el.type == "inertia":
            c = spec.coordinates[el.coordinate]  # type: ignore[index]
            u = _terms_unit(ctx, f["value"], units)
            if u is not None:
                energy_of(f"{w}.value", u * (c.dims / tt) ** 2)
        elif el.type == "force":
            c = spec.coordinates[el.coordinate]  # type: ignore[index]
            u = _terms_unit(ctx, f["value"], units)
            if u is not None:
                energy_of(f"{w}.value", u * c.dims)
        else:
            d = _terms_unit(ctx, f["deflection"], units)
            if d is None:
                raise ctx.error(f"{w}.deflection", "no active term")
            for key in ("error", "backlash"):
                if key in f:
                    u = _terms_unit(ctx, f[key], units)
                    if u is not None and not u.same_dimension(d):
                        raise ctx.error(f"{w}.{key}", f"unit mismatch: [{u.si_string()}] but the "
                                                      f"deflection is [{d.si_string()}]")
            if "stiffness" in f:
                u = _terms_unit(ctx, f["stiffness"], units)
                if u is not None:
                    energy_of(f"{w}.stiffness", u * d * d)
            for key in ("coefficient", "damping"):
                if key in f:
                    u = _terms_unit(ctx, f[key], units)
                    if u is not None:
                        energy_of(f"{w}.{key}", u * d * d / tt)
    for eq in spec.equations.values():
        c = spec.coordinates[eq.coordinate]
        if eq.force:
            u = _terms_unit(ctx, eq.force, units)
            if u is not None:
                energy_of(f"equations.{eq.coordinate}.force", u * c.dims)
        if eq.mass:
            u = _terms_unit(ctx, eq.mass, units)
            if u is not None:
                energy_of(f"equations.{eq.coordinate}.mass", u * (c.dims / tt) ** 2)
    if spec.reduction is not None:
        red_units = reduction_units(ctx, spec.reduction, spec.elements, lambda terms: _terms_unit(ctx, terms, units))
        for rc in spec.reduction.coordinates:
            units[rc.name] = Unit(1.0, red_units[rc.name].dims)
            units[rc.velocity] = units[rc.name] / spec.time_dims
    has_mass = {el.coordinate for el in spec.elements.values() if el.type == "inertia"}
    has_mass |= {q for q, eq in spec.equations.items() if eq.mass}
    for q in spec.coordinates:
        if q not in has_mass:
            raise ctx.error(f"coordinates.{q}", f"coordinate '{q}' has no inertia element and no "
                                                f"equations.{q}.mass")
    if spec.dimensionless is not None:
        for q in spec.dimensionless.coordinates:
            if q not in spec.state_names()[: len(spec.state_names()) // 2]:
                raise ctx.error(f"dimensionless.coordinates.{q}", f"'{q}' is not a coordinate of the "
                                                                  f"(reduced) model")
        for g in spec.dimensionless.groups:
            gw = f"dimensionless.groups.{g.name}"
            if g.eliminates not in spec.parameters:
                raise ctx.error(f"{gw}.eliminates", f"unknown parameter '{g.eliminates}'")
            _expect(ctx, f"{gw}.definition", g.definition, units, ONE, "dimensionless")
            if g.eliminates not in ex.names_in(g.definition):
                raise ctx.error(f"{gw}.eliminates", f"'{g.eliminates}' does not appear in the definition")
        _expect(ctx, "dimensionless.time", spec.dimensionless.time, units, spec.time_dims, "a time")
    for k in spec.initial:
        if k not in spec.state_names():
            raise ctx.error(f"initial.{k}", f"'{k}' is not a state (states: {', '.join(spec.state_names())})")
    for o in spec.outputs.values():
        u = _terms_unit(ctx, o.terms, units)
        if o.unit is not None and u is not None:
            declared = _unit(ctx, f"outputs.{o.name}.unit", o.unit)
            if not u.same_dimension(declared):
                raise ctx.error(f"outputs.{o.name}.value", f"unit mismatch: value is [{u.si_string()}] "
                                                           f"but unit says [{declared.si_string()}]")
    spec.units.update(units)


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


def _derived_order(ctx: _Ctx, spec: ModelSpec) -> list[str]:
    deps = {n: set().union(*[_names(ctx, t.field, t.expr) for t in d.terms]) & set(spec.derived)
            for n, d in spec.derived.items()}
    order: list[str] = []
    state: dict[str, int] = {}

    def visit(n: str, stack: list[str]) -> None:
        if state.get(n) == 2:
            return
        if state.get(n) == 1:
            cycle = " -> ".join(stack[stack.index(n):] + [n])
            raise ctx.error(f"derived.{n}", f"circular definition: {cycle}")
        state[n] = 1
        for m in sorted(deps[n]):
            visit(m, stack + [n])
        state[n] = 2
        order.append(n)

    for n in spec.derived:
        visit(n, [])
    return order


def _bound_calls(ctx: _Ctx, where: str, text: str) -> list[tuple[str, list[str | None]]]:
    try:
        return ex.bound_calls(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None


def _names(ctx: _Ctx, where: str, text: str) -> set[str]:
    try:
        return ex.names_in(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None


def _terms_unit(ctx: _Ctx, terms: tuple[Term, ...], units: dict[str, Unit]) -> Unit | None:
    out: Unit | None = None
    for t in terms:
        try:
            u = ex.infer_unit(t.expr, units)
        except ex.ExpressionError as exc:
            raise ctx.error(t.field, str(exc)) from None
        if out is not None and not out.same_dimension(u):
            raise ctx.error(t.field, f"unit mismatch: this term is [{u.si_string()}] but earlier "
                                     f"terms of the field are [{out.si_string()}]")
        out = u
    return out


def _expect(ctx: _Ctx, where: str, text: str, units: dict[str, Unit], want: Unit, what: str) -> None:
    try:
        u = ex.infer_unit(text, units)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None
    if not u.same_dimension(want):
        raise ctx.error(where, f"unit mismatch: must be {what} [{want.si_string()}], "
                               f"got [{u.si_string()}]")


# --------------------------------------------------------------------- helpers


def _quantities(ctx: _Ctx, data: dict[str, Any], section: str, declare: Any,
                schedules: dict[str, Schedule]) -> dict[str, Derived]:
    """Parse a table of named quantities ([derived] or [outputs]): value, unit, meaning."""
    out: dict[str, Derived] = {}
    for name, d in _table(ctx, data, section).items():
        where = f"{section}.{name}"
        if isinstance(d, (str, list)) or (isinstance(d, dict) and "value" not in d):
            d = {"value": d}
        d = _as_table(ctx, where, d)
        _only(ctx, where, d, {"value", "unit", "meaning"})
        declare(name, where)
        out[name] = Derived(name, _terms(ctx, f"{where}.value", d["value"], schedules),
                            _str(ctx, d, f"{where}.unit"), _str(ctx, d, f"{where}.meaning") or "")
    return out


def _terms(ctx: _Ctx, where: str, value: Any, schedules: dict[str, Schedule],
           effect: str | None = None, variant: str | None = None) -> tuple[Term, ...]:
    """Normalise an expression field into a tuple of terms."""
    if isinstance(value, list):
        out: list[Term] = []
        for i, v in enumerate(value):
            out.extend(_terms(ctx, f"{where}[{i}]", v, schedules, effect, variant))
        return tuple(out)
    if isinstance(value, dict):
        allowed = {"expr", "effect", "variant", "type", "amplitude", "frequency", "phase", "mean",
                   "cos", "sin", "schedule", "values"}
        _only(ctx, where, value, allowed)
        eff = value.get("effect", effect)
        var = value.get("variant", variant)
        for k, v in (("effect", eff), ("variant", var)):
            if v is not None and not isinstance(v, str):
                raise ctx.error(f"{where}.{k}", "must be a string")
        kind = value.get("type")
        if kind is None:
            if "expr" not in value:
                raise ctx.error(where, "a term table needs 'expr' or 'type'")
            return (Term(_expr_str(ctx, f"{where}.expr", value["expr"]), where, eff, var),)
        return (Term(_typed(ctx, where, kind, value, schedules), where, eff, var),)
    return (Term(_expr_str(ctx, where, value), where, effect, variant),)


def _typed(ctx: _Ctx, where: str, kind: str, v: dict[str, Any], schedules: dict[str, Schedule]) -> str:
    """Expand a typed excitation table into an expression string."""
    if kind == "sinusoid":
        amp = _expr_str(ctx, f"{where}.amplitude", v.get("amplitude"))
        freq = _expr_str(ctx, f"{where}.frequency", v.get("frequency"))
        phase = _expr_str(ctx, f"{where}.phase", v.get("phase", 0))
        mean = _expr_str(ctx, f"{where}.mean", v.get("mean", 0))
        wave = f"({amp})*cos(({freq})*t + ({phase}))"
        # an absent mean adds nothing (a literal 0 would be dimensionless and clash
        # with a dimensional amplitude in the unit check)
        return f"({mean}) + {wave}" if "mean" in v else wave
    if kind == "fourier":
        freq = _expr_str(ctx, f"{where}.frequency", v.get("frequency"))
        mean = _expr_str(ctx, f"{where}.mean", v.get("mean", 0))
        parts = [f"({mean})"] if "mean" in v else []  # see sinusoid: no dimensionless 0
        for key, fn in (("cos", "cos"), ("sin", "sin")):
            coefs = v.get(key, [])
            if not isinstance(coefs, list):
                raise ctx.error(f"{where}.{key}", "must be an array of coefficients")
            for n, c in enumerate(coefs, start=1):
                c = _expr_str(ctx, f"{where}.{key}[{n - 1}]", c)
                parts.append(f"({c})*{fn}({n}*({freq})*t)")
        return " + ".join(parts) if parts else "0"
    if kind == "piecewise_cycle":
        sname = v.get("schedule")
        if sname not in schedules:
            raise ctx.error(f"{where}.schedule", f"unknown schedule '{sname}' "
                                                 f"(schedules: {', '.join(schedules) or 'none'})")
        values = v.get("values")
        nseg = len(schedules[sname].breaks) + 1
        if not isinstance(values, list) or len(values) != nseg:
            raise ctx.error(f"{where}.values", f"needs one value per segment of schedule '{sname}' "
                                               f"({nseg})")
        vals = []
        for i, val in enumerate(values):
            s = _expr_str(ctx, f"{where}.values[{i}]", val)
            tree = ex.parse(s)
            # 'phase' inside a value means this schedule's phase
            s = _rename(tree, {"phase": f"{sname}_phase"})
            vals.append(s)
        seg = f"{sname}_segment"
        pieces = [f"({val}, {seg} < {i + 0.5})" for i, val in enumerate(vals[:-1])]
        pieces.append(f"({vals[-1]}, True)")
        return f"Piecewise({', '.join(pieces)})"
    raise ctx.error(f"{where}.type", f"unknown excitation type '{kind}' "
                                     f"(known: sinusoid, fourier, piecewise_cycle)")


def _rename(tree: Any, mapping: dict[str, str]) -> str:
    import ast

    class R(ast.NodeTransformer):
        def visit_Name(self, node: ast.Name) -> ast.Name:
            if node.id in mapping:
                return ast.copy_location(ast.Name(id=mapping[node.id], ctx=node.ctx), node)
            return node

    return ast.unparse(R().visit(tree))


def _expr_str(ctx: _Ctx, where: str, value: Any) -> str:
    if value is None:
        raise ctx.error(where, "missing expression")
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ctx.error(where, f"wrong type: expected an expression (string or number), "
                               f"got {type(value).__name__}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ctx.error(where, f"non-finite value {value}")
    text = value if isinstance(value, str) else repr(value)
    try:
        ex.names_in(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None
    return text


def _table(ctx: _Ctx, data: dict[str, Any], key: str, required: bool = False) -> dict[str, Any]:
    if key not in data:
        if required:
            raise ctx.error(key, f"missing section [{key}]")
        return {}
    return _as_table(ctx, key, data[key])


def _as_table(ctx: _Ctx, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ctx.error(where, f"wrong type: expected a table, got {type(value).__name__}")
    return value


def _only(ctx: _Ctx, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    for k in table:
        if k not in allowed:
            raise ctx.error(f"{where}.{k}", f"unknown field '{k}' (allowed: {', '.join(sorted(allowed))})")


def _str(ctx: _Ctx, table: dict[str, Any], where: str, required: bool = False) -> str | None:
    key = where.rsplit(".", 1)[-1]
    if key not in table:
        if required:
            raise ctx.error(where, f"missing field '{key}'")
        return None
    v = table[key]
    if not isinstance(v, str):
        raise ctx.error(where, f"wrong type: expected a string, got {type(v).__name__}")
    return v


def _str_list(ctx: _Ctx, table: dict[str, Any], where: str) -> list[str]:
    key = where.rsplit(".", 1)[-1]
    v = table.get(key, [])
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise ctx.error(where, "wrong type: expected an array of strings")
    return v


def _number(ctx: _Ctx, where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ctx.error(where, f"wrong type: expected a number, got {type(v).__name__} {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ctx.error(where, f"non-finite value {v}")
    return v


def _unit(ctx: _Ctx, where: str, text: str) -> Unit:
    try:
        return parse_unit(text)
    except UnitSyntaxError as exc:
        raise ctx.error(where, str(exc)) from None
