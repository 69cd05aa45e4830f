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

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SpecError
from . import expressions as ex
from .constraints import Algebraic, Constraint, parse_algebraic, parse_constraints
from .elements import ELEMENT_TYPES, ElementType
from .fields import (
    Ctx,
    Term,
    as_table,
    did_you_mean,
    expr_str,
    number,
    only_keys,
    read_terms,
    string,
    string_list,
    table,
    unit_of,
    unknown_key,
)
from .files import read_toml
from .initial import read_initial
from .names import check_label, check_symbol_name
from .reduction import Reduction, parse_reduction
from .tables import Table, parse_tables
from .units import Unit
from .validate import validate_model

__all__ = ["Coordinate", "Derived", "Dimensionless", "Effect", "Element", "Equation", "Group",
           "ModelSpec", "Parameter", "Reduction", "Schedule", "Table", "Term", "load_model", "parse_model"]

# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Parameter:
    """A run-time parameter: ``value`` in ``unit``, ``si_scale`` the SI value of one ``unit``
    (:class:`~gearsym.spec.units.ParameterUnits` converts).  ``minimum``, ``maximum`` (declared
    unit) and ``positive`` are the range its entry declares (:mod:`gearsym.spec.rules`)."""

    name: str
    value: float
    unit: str
    meaning: str
    si_scale: float
    dims: Unit
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False


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
    """A lumped element of a model: its ``type`` names an element type of
    :data:`gearsym.spec.elements.ELEMENT_TYPES`, which says what its fields mean."""

    name: str
    type: str
    fields: dict[str, tuple[Term, ...]]
    coordinate: str | None = None
    drive_side: str = "positive"
    effect: str | None = None
    variant: str | None = None
    meaning: str = ""
    #: the coordinate fields of its type (:attr:`~gearsym.spec.elements.ElementType.coordinates`):
    #: field -> coordinate names
    coordinates: dict[str, tuple[str, ...]] = field(default_factory=dict)


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
    """Reference scales for the dimensionless form, and the named groups.

    Every scale is optional (``None``: the default of :mod:`gearsym.symbolic.scales`).
    """

    time: str | None
    coordinates: dict[str, str]
    groups: tuple[Group, ...]
    length: str | None = None
    mass: str | None = None


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
    initial: dict[str, float | str]
    dimensionless: Dimensionless | None
    notes: str = ""
    units: dict[str, Unit] = field(default_factory=dict, repr=False)
    outputs: dict[str, Derived] = field(default_factory=dict)
    #: ``[initial] static``: start from the static equilibrium (``None``: not given)
    static: bool | None = None
    #: ``[algebraic]`` variables and ``[constraints]`` (gearsym/spec/constraints.py)
    algebraic: dict[str, Algebraic] = field(default_factory=dict)
    constraints: dict[str, Constraint] = field(default_factory=dict)
    #: ``[tables]``: data with a unit and a domain (gearsym/spec/tables.py)
    tables: dict[str, Table] = field(default_factory=dict)

    def data_digest(self) -> str:
        """SHA-256 of the data the model reads besides its own file (its tables' numbers): part
        of the build key, so that a changed table file is a new build."""
        import hashlib

        parts = [f"{n}:{t.digest}" for n, t in sorted(self.tables.items())]
        return hashlib.sha256("\n".join(parts).encode()).hexdigest() if parts else ""

    def state_names(self) -> list[str]:
        """Names of the states: coordinates, velocities, then algebraic variables.

        A coordinate that a constraint ties to the others is not a state (nor its velocity).
        """
        if self.reduction is not None:
            kept = [(self.coordinates[k].name, self.coordinates[k].velocity) for k in self.reduction.keep]
            return self.reduction.state_names(kept=kept)
        tied = {c.coordinate for c in self.constraints.values()}
        coords = [c for c in self.coordinates.values() if c.name not in tied]
        return [c.name for c in coords] + [c.velocity for c in coords] + list(self.algebraic)


# ------------------------------------------------------------------------ parsing

_TOP = {"model", "coordinates", "parameters", "derived", "effects", "schedules", "elements",
        "equations", "reduction", "forcing", "initial", "dimensionless", "outputs", "algebraic", "constraints",
        "tables"}
_MODEL_KEYS = {"name", "description", "reference", "time_unit", "form", "notes"}
#: keys every element takes besides the fields of its type (gearsym/spec/elements/)
_ELEMENT_META = {"type", "coordinate", "effect", "variant", "meaning", "drive_side"}


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
    data = read_toml(path, "model file")
    if "scene" in data and "model" not in data:
        raise SpecError("this is a scene file, not a model file", file=str(path))
    return parse_model(data, str(path))


def parse_model(data: dict[str, Any], path: str = "<model>") -> ModelSpec:
    """Validate an already-parsed model document (see :func:`load_model`)."""
    ctx = Ctx(path)
    for key in data:
        if key not in _TOP:
            raise ctx.error(key, unknown_key(key, _TOP, "section"))
    meta = table(ctx, data, "model", required=True)
    name, form, time_unit, time_dims = _model_meta(ctx, meta)
    names = _Names(ctx)
    declare = names.declare
    coordinates = _coordinates(ctx, data, declare)
    parameters: dict[str, Parameter] = {}
    for pname, p in table(ctx, data, "parameters").items():
        where = f"parameters.{pname}"
        if isinstance(p, (int, float)) and not isinstance(p, bool):
            p = {"value": p}
        p = as_table(ctx, where, p)
        only_keys(ctx, where, p, {"value", "unit", "meaning", "min", "max", "positive"})
        declare(pname, where)
        parameters[pname] = _parameter(ctx, where, pname, p)
    effects = _effects(ctx, data)
    schedules = _schedules(ctx, data, declare)
    tables = parse_tables(ctx, data, declare)
    derived = _quantities(ctx, data, "derived", declare, schedules)
    elements = {lname: _element(ctx, lname, el, coordinates, schedules)
                for lname, el in table(ctx, data, "elements").items()}
    equations = _equations(ctx, data, coordinates, schedules)
    # algebraic variables and constraints (gearsym/spec/constraints.py)
    algebraic = parse_algebraic(ctx, data, declare)
    constraints = parse_constraints(ctx, data)
    reduction = _reduction(ctx, data, declare, elements, coordinates, schedules)
    forcing = table(ctx, data, "forcing")
    only_keys(ctx, "forcing", forcing, {"period"})
    period = expr_str(ctx, "forcing.period", forcing["period"]) if "period" in forcing else None
    initial, static = read_initial(table(ctx, data, "initial"), ctx.error)
    dimless = _dimensionless(ctx, data, declare) if "dimensionless" in data else None
    # outputs: quantities evaluated along trajectories (e.g. the dynamic backlash B(t))
    outputs = _quantities(ctx, data, "outputs", declare, schedules)
    if dimless is not None and "tau" in names.where:
        raise ctx.error(names.where["tau"], "'tau' is the time of the [dimensionless] form; choose another name")
    spec = ModelSpec(
        path=path, name=name, description=string(ctx, meta, "model.description") or "",
        reference=string(ctx, meta, "model.reference") or "", form=form, time_unit=time_unit,
        time_dims=time_dims, coordinates=coordinates, parameters=parameters, derived=derived,
        effects=effects, schedules=schedules, elements=elements, equations=equations,
        reduction=reduction, forcing_period=period, initial=initial, dimensionless=dimless,
        notes=string(ctx, meta, "model.notes") or "", outputs=outputs, static=static,
        algebraic=algebraic, constraints=constraints, tables=tables,
    )
    validate_model(ctx, spec)
    return spec


class _Names:
    """The names a model declares (one namespace): ``declare`` refuses a bad or duplicate one."""

    def __init__(self, ctx: Ctx):
        self.ctx = ctx
        #: name -> where declared
        self.where: dict[str, str] = {}

    def declare(self, n: str, where: str) -> None:
        """Declare ``n`` at the field ``where``."""
        problem = ex.check_identifier(n)
        if problem:
            raise self.ctx.error(where, problem)
        if n in self.where:
            raise self.ctx.error(where, f"duplicate name '{n}' (already declared at {self.where[n]})")
        self.where[n] = where


def _model_meta(ctx: Ctx, meta: dict[str, Any]) -> tuple[str, str, str, Unit]:
    """The ``[model]`` table: name, form, time unit and its dimensions."""
    only_keys(ctx, "model", meta, _MODEL_KEYS)
    name = string(ctx, meta, "model.name", required=True)
    problem = check_label(name, "model name")
    if problem:
        raise ctx.error("model.name", problem)
    form = string(ctx, meta, "model.form") or "explicit"
    if form not in ("explicit", "implicit"):
        raise ctx.error("model.form", f"must be 'explicit' or 'implicit', got '{form}'")
    time_unit = string(ctx, meta, "model.time_unit") or "s"
    time_dims = unit_of(ctx, "model.time_unit", time_unit)
    if not (time_dims.dims == (0, 0, 1) or time_dims.dimensionless):
        raise ctx.error("model.time_unit", f"'{time_unit}' is not a unit of time")
    if time_dims.scale != 1.0:
        raise ctx.error("model.time_unit", "time must be in seconds ('s') or dimensionless ('1')")
    return name, form, time_unit, time_dims  # type: ignore[return-value]


def _coordinates(ctx: Ctx, data: dict[str, Any], declare: Callable[[str, str], None]) -> dict[str, Coordinate]:
    """The ``[coordinates]`` tables."""
    coordinates: dict[str, Coordinate] = {}
    for cname, c in table(ctx, data, "coordinates", required=True).items():
        where = f"coordinates.{cname}"
        c = as_table(ctx, where, c)
        only_keys(ctx, where, c, {"unit", "meaning", "velocity", "effect"})
        unit = string(ctx, c, f"{where}.unit") or "1"
        dims = unit_of(ctx, f"{where}.unit", unit)
        if dims.scale != 1.0:
            raise ctx.error(f"{where}.unit", f"coordinates must be in coherent SI units, not '{unit}'")
        vel = string(ctx, c, f"{where}.velocity") or f"{cname}_dot"
        declare(cname, where)
        declare(vel, f"{where}.velocity")
        coordinates[cname] = Coordinate(cname, unit, string(ctx, c, f"{where}.meaning") or "", vel, dims,
                                        string(ctx, c, f"{where}.effect"))
    if not coordinates:
        raise ctx.error("coordinates", "a model needs at least one coordinate")
    return coordinates


def _effects(ctx: Ctx, data: dict[str, Any]) -> dict[str, Effect]:
    """The ``[effects]`` tables (variants, defaults, requirements)."""
    effects: dict[str, Effect] = {}
    for ename, e in table(ctx, data, "effects").items():
        where = f"effects.{ename}"
        e = as_table(ctx, where, e)
        only_keys(ctx, where, e, {"meaning", "default", "variants", "requires"})
        problem = check_symbol_name(ename)
        if problem:
            raise ctx.error(where, problem)
        variants = tuple(string_list(ctx, e, f"{where}.variants"))
        for i, vname in enumerate(variants):
            problem = check_symbol_name(vname)
            if problem:
                raise ctx.error(f"{where}.variants[{i}]", problem)
        if len(set(variants)) != len(variants):
            raise ctx.error(f"{where}.variants", "duplicate variant name")
        default = e.get("default", True)
        if not isinstance(default, (bool, str)):
            raise ctx.error(f"{where}.default", "must be true, false or a variant name")
        if isinstance(default, str) and default not in variants:
            raise ctx.error(f"{where}.default", f"'{default}' is not a variant of '{ename}' "
                                                f"(variants: {', '.join(variants) or 'none'})")
        if default is True and variants:
            default = variants[0]
        effects[ename] = Effect(ename, string(ctx, e, f"{where}.meaning") or "", default, variants,
                                tuple(string_list(ctx, e, f"{where}.requires")))
    for e in effects.values():
        for r in e.requires:
            if r not in effects:
                raise ctx.error(f"effects.{e.name}.requires", f"effect '{r}' is not in the model")
            if r == e.name:
                raise ctx.error(f"effects.{e.name}.requires", "an effect cannot require itself")
    return effects


def _schedules(ctx: Ctx, data: dict[str, Any], declare: Callable[[str, str], None]) -> dict[str, Schedule]:
    """The ``[schedules]`` tables (each declares ``NAME_phase`` and ``NAME_segment``)."""
    schedules: dict[str, Schedule] = {}
    for sname, s in table(ctx, data, "schedules").items():
        where = f"schedules.{sname}"
        s = as_table(ctx, where, s)
        only_keys(ctx, where, s, {"period", "breaks", "meaning"})
        problem = check_symbol_name(sname)
        if problem:
            raise ctx.error(where, problem)
        declare(f"{sname}_phase", where)
        declare(f"{sname}_segment", where)
        if "period" not in s:
            raise ctx.error(f"{where}.period", "missing period")
        breaks = s.get("breaks", [])
        if not isinstance(breaks, list):
            raise ctx.error(f"{where}.breaks", "must be an array of expressions (fractions of the cycle)")
        schedules[sname] = Schedule(sname, expr_str(ctx, f"{where}.period", s["period"]),
                                    tuple(expr_str(ctx, f"{where}.breaks[{i}]", b)
                                          for i, b in enumerate(breaks)),
                                    string(ctx, s, f"{where}.meaning") or "")
    return schedules


def _element(ctx: Ctx, lname: str, el: Any, coordinates: dict[str, Coordinate],
             schedules: dict[str, Schedule]) -> Element:
    """One ``[elements.NAME]`` table, read with the schema of its type (gearsym/spec/elements/)."""
    where = f"elements.{lname}"
    problem = check_symbol_name(lname)
    if problem:
        raise ctx.error(where, problem)
    el = as_table(ctx, where, el)
    etype = string(ctx, el, f"{where}.type", required=True)
    if etype not in ELEMENT_TYPES:
        raise ctx.error(f"{where}.type", f"unknown element type '{etype}'{did_you_mean(etype, ELEMENT_TYPES)} "
                                         f"(known: {', '.join(ELEMENT_TYPES)})")
    kind = ELEMENT_TYPES[etype]
    fields_ = set(kind.required) | set(kind.optional)
    only_keys(ctx, where, el, fields_ | _ELEMENT_META | set(kind.coordinates))
    if kind.coordinates and "coordinate" in el:
        raise ctx.error(f"{where}.coordinate", f"a {etype} element names its coordinates in "
                                               f"{', '.join(sorted(kind.coordinates))}")
    coord_refs = _coordinate_fields(ctx, where, el, kind, coordinates) if kind.coordinates else {}
    for r in sorted(kind.required):
        if r not in el:
            raise ctx.error(f"{where}.{r}", f"missing field '{r}' of {etype} element")
    coord = None
    if kind.takes_coordinate:
        coord = string(ctx, el, f"{where}.coordinate", required=True)
        if coord not in coordinates:
            raise ctx.error(f"{where}.coordinate", f"unknown coordinate '{coord}'{did_you_mean(coord, coordinates)}")
    drive = string(ctx, el, f"{where}.drive_side") or "positive"
    if drive not in ("positive", "negative"):
        raise ctx.error(f"{where}.drive_side", "must be 'positive' or 'negative'")
    fields = {k: read_terms(ctx, f"{where}.{k}", el[k], schedules) for k in sorted(fields_) if k in el}
    return Element(lname, etype, fields, coord, drive, string(ctx, el, f"{where}.effect"),
                   string(ctx, el, f"{where}.variant"), string(ctx, el, f"{where}.meaning") or "", coord_refs)


def _equations(ctx: Ctx, data: dict[str, Any], coordinates: dict[str, Coordinate],
               schedules: dict[str, Schedule]) -> dict[str, Equation]:
    """The ``[equations.COORD]`` tables (explicit additions to ``M q'' = Q``)."""
    equations: dict[str, Equation] = {}
    for qname, eq in table(ctx, data, "equations").items():
        where = f"equations.{qname}"
        if qname not in coordinates:
            raise ctx.error(where, f"unknown coordinate '{qname}'{did_you_mean(qname, coordinates)}")
        eq = as_table(ctx, where, eq)
        only_keys(ctx, where, eq, {"mass", "force"})
        equations[qname] = Equation(
            qname,
            read_terms(ctx, f"{where}.mass", eq["mass"], schedules) if "mass" in eq else (),
            read_terms(ctx, f"{where}.force", eq["force"], schedules) if "force" in eq else (),
        )
    return equations


def _reduction(ctx: Ctx, data: dict[str, Any], declare: Callable[[str, str], None], elements: dict[str, Element],
               coordinates: dict[str, Coordinate], schedules: dict[str, Schedule]) -> Reduction | None:
    """The ``[reduction]`` section (gearsym/spec/reduction.py), or ``None``."""
    if "reduction" not in data:
        return None
    reduction = parse_reduction(
        ctx, table(ctx, data, "reduction"), declare, elements,
        lambda where, value: read_terms(ctx, where, value, schedules),
        lambda tbl, where: string(ctx, tbl, where), lambda where, text: unit_of(ctx, where, text))
    for i, k in enumerate(reduction.keep):
        if k not in coordinates:
            raise ctx.error(f"reduction.keep[{i}]", f"unknown coordinate '{k}'")
    return reduction


def _dimensionless(ctx: Ctx, data: dict[str, Any], declare: Callable[[str, str], None]) -> Dimensionless:
    """The ``[dimensionless]`` section: reference scales and named groups."""
    dl = table(ctx, data, "dimensionless")
    only_keys(ctx, "dimensionless", dl, {"time", "length", "mass", "coordinates", "groups"})
    groups = []
    for gname, g in as_table(ctx, "dimensionless.groups", dl.get("groups", {})).items():
        gw = f"dimensionless.groups.{gname}"
        g = as_table(ctx, gw, g)
        only_keys(ctx, gw, g, {"definition", "eliminates", "meaning"})
        declare(gname, gw)
        groups.append(Group(gname, expr_str(ctx, f"{gw}.definition", g.get("definition")),
                            string(ctx, g, f"{gw}.eliminates", required=True),
                            string(ctx, g, f"{gw}.meaning") or ""))
    return Dimensionless(
        expr_str(ctx, "dimensionless.time", dl["time"]) if "time" in dl else None,
        {k: expr_str(ctx, f"dimensionless.coordinates.{k}", v)
         for k, v in as_table(ctx, "dimensionless.coordinates", dl.get("coordinates", {})).items()},
        tuple(groups),
        expr_str(ctx, "dimensionless.length", dl["length"]) if "length" in dl else None,
        expr_str(ctx, "dimensionless.mass", dl["mass"]) if "mass" in dl else None,
    )


def _parameter(ctx: Ctx, where: str, name: str, p: dict[str, Any]) -> Parameter:
    """One ``[parameters]`` entry: value, unit, meaning and its declared range (checked on its value)."""
    if "value" not in p:
        raise ctx.error(f"{where}.value", f"missing value for parameter '{name}'")
    value = number(ctx, f"{where}.value", p["value"])
    unit = string(ctx, p, f"{where}.unit") or "1"
    dims = unit_of(ctx, f"{where}.unit", unit)
    lo = number(ctx, f"{where}.min", p["min"]) if "min" in p else None
    hi = number(ctx, f"{where}.max", p["max"]) if "max" in p else None
    positive = p.get("positive", False)
    if not isinstance(positive, bool):
        raise ctx.error(f"{where}.positive", f"must be true or false, got {positive!r}")
    if lo is not None and hi is not None and lo > hi:
        raise ctx.error(f"{where}.max", f"max ({hi:g}) is below min ({lo:g})")
    problem = (f">= {lo:g} (its min)" if lo is not None and value < lo else
               f"<= {hi:g} (its max)" if hi is not None and value > hi else
               "positive" if positive and not value > 0 else None)
    if problem:
        raise ctx.error(f"{where}.value", f"the value {value:g} of '{name}' must be {problem}")
    return Parameter(name, value, unit, string(ctx, p, f"{where}.meaning") or "", dims.scale, dims, lo, hi, positive)


def _coordinate_fields(ctx: Ctx, where: str, el: dict[str, Any], schema: ElementType,
                       coordinates: dict[str, Coordinate]) -> dict[str, tuple[str, ...]]:
    """The coordinate fields of an element (names checked against the coordinates)."""
    out: dict[str, tuple[str, ...]] = {}
    for key, count in schema.coordinates.items():
        fw = f"{where}.{key}"
        if key not in el:
            if key in schema.required_coordinates:
                raise ctx.error(fw, f"missing field '{key}' of {el.get('type')} element")
            continue
        value = el[key]
        names = [value] if count == 1 and isinstance(value, str) else value
        if not isinstance(names, list) or len(names) != count or not all(isinstance(n, str) for n in names):
            what = "a coordinate name" if count == 1 else f"an array of {count} coordinate names"
            raise ctx.error(fw, f"wrong type: expected {what}")
        for i, n in enumerate(names):
            if n not in coordinates:
                raise ctx.error(fw if count == 1 else f"{fw}[{i}]",
                                f"unknown coordinate '{n}'{did_you_mean(n, coordinates)}")
        out[key] = tuple(names)
    return out


def _quantities(ctx: Ctx, data: dict[str, Any], section: str, declare: Any,
                schedules: dict[str, Schedule]) -> dict[str, Derived]:
    """Parse a table of named quantities ([derived] or [outputs]): value, unit, meaning."""
    out: dict[str, Derived] = {}
    for name, d in table(ctx, data, section).items():
        where = f"{section}.{name}"
        if isinstance(d, (str, list)) or (isinstance(d, dict) and "value" not in d):
            d = {"value": d}
        d = as_table(ctx, where, d)
        only_keys(ctx, where, d, {"value", "unit", "meaning"})
        declare(name, where)
        out[name] = Derived(name, read_terms(ctx, f"{where}.value", d["value"], schedules),
                            string(ctx, d, f"{where}.unit"), string(ctx, d, f"{where}.meaning") or "")
    return out


