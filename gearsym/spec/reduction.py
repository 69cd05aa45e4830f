"""The ``[reduction]`` section of a model: which relative coordinates replace the coordinates.

A semi-definite model (a gear train that nothing ties to the ground) has rigid-body
modes; its vibration lives in relative coordinates (mesh and shaft deflections).
Three forms are accepted:

* **one coordinate** (the original form)::

      [reduction]
      coordinate = "x"
      velocity = "v"
      definition = "rb1*th1 - rb2*th2 - e_s"
      unit = "m"

* **several named coordinates**, each with its definition::

      [reduction.coordinates.x1]
      definition = "rb1*th1 - rb2*th2"
      unit = "m"
      velocity = "v1"            # default x1_dot
      [reduction.coordinates.x2]
      definition = "th2 - th3"
      unit = "rad"

* **automatic, one coordinate per deflection**::

      [reduction]
      mode = "deflections"
      elements = ["mesh1", "shaft", "mesh2"]   # optional; default every spring and mesh

  Element ``NAME`` gives the coordinate ``x_NAME`` (velocity ``v_NAME``): the mesh's
  dynamic deflection ``deflection - error`` (the dynamic transmission error along its
  line of action, so its contact surfaces are ``x_NAME -/+ backlash``) or the spring's
  ``deflection``, in the unit of that deflection.  Dampers are assumed to act on the
  deflection of a spring or mesh (else name them in ``elements``).  An element switched
  off by an effect takes its coordinate with it.  Which types get a coordinate, and
  what it is, each element type says (:meth:`~gearsym.spec.elements.ElementType.deflection`,
  ``deflection_default``).

Every definition must be linear in the coordinates with constant coefficients (plus a
function of time).  The symbolic layer eliminates as many coordinates as there are
reduced coordinates and checks that the reduced equations are closed (they must not
depend on the coordinates left over, which are then rigid-body coordinates).

This module knows nothing of sympy; the parsing helpers of :mod:`gearsym.spec.model`
are passed in (no import cycle).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .elements import ELEMENT_TYPES, element_type
from .fields import only_keys

if TYPE_CHECKING:  # pragma: no cover
    from .model import Element, Term
    from .units import Unit

__all__ = ["ReducedCoordinate", "Reduction", "deflection_coordinate_names", "deflection_types", "parse_reduction",
           "reduction_units"]


def deflection_types(default_only: bool = False) -> list[str]:
    """The element types that have a coordinate in ``mode = "deflections"`` (those that may be
    named in ``[reduction] elements``), or with ``default_only`` those that get one by default."""
    return [n for n, t in ELEMENT_TYPES.items()
            if t.deflection_default or (t.has_deflection and not default_only)]


@dataclass(frozen=True)
class ReducedCoordinate:
    """One relative coordinate of a reduction.

    Attributes
    ----------
    name, velocity
        Names of the coordinate and of its velocity state.
    definition
        Terms of its definition (linear in the coordinates plus a time function).
    unit
        Declared unit; ``None`` in ``mode = "deflections"`` (the deflection's unit).
    meaning
        Text for ``inspect``.
    dims
        Dimensions of ``unit`` (``None`` until inferred, deflections mode).
    element, effect, variant
        The element a deflection coordinate belongs to, and its gating effect: the
        coordinate exists only while the element does.
    """

    name: str
    velocity: str
    definition: tuple[Term, ...]
    unit: str | None
    meaning: str
    dims: Unit | None
    element: str | None = None
    effect: str | None = None
    variant: str | None = None


@dataclass(frozen=True)
class Reduction:
    """The reduced coordinates of a model (see the module docstring).

    ``coordinate``, ``velocity``, ``definition``, ``unit``, ``meaning`` and ``dims``
    are those of the first reduced coordinate (the single-coordinate form).
    """

    coordinates: tuple[ReducedCoordinate, ...]
    mode: str = "explicit"
    #: coordinates kept as states beside the (single) reduced one: its definition may depend
    #: on them in any smooth way, e.g. through a pressure angle that varies with the centre
    #: distance (``[reduction] keep``, :mod:`gearsym.symbolic.reduction_keep`)
    keep: tuple[str, ...] = ()

    @property
    def coordinate(self) -> str:
        """Name of the (first) reduced coordinate."""
        return self.coordinates[0].name

    @property
    def velocity(self) -> str:
        """Name of the (first) reduced velocity."""
        return self.coordinates[0].velocity

    @property
    def definition(self) -> tuple[Term, ...]:
        """Definition terms of the (first) reduced coordinate."""
        return self.coordinates[0].definition

    @property
    def unit(self) -> str | None:
        """Unit of the (first) reduced coordinate."""
        return self.coordinates[0].unit

    @property
    def meaning(self) -> str:
        """Meaning of the (first) reduced coordinate."""
        return self.coordinates[0].meaning

    @property
    def dims(self) -> Unit | None:
        """Dimensions of the (first) reduced coordinate."""
        return self.coordinates[0].dims

    def state_names(self, active: Callable[[ReducedCoordinate], bool] | None = None,
                    kept: Sequence[tuple[str, str]] = ()) -> list[str]:
        """Reduced coordinates (those ``active`` accepts), then the ``kept`` coordinates
        (``(name, velocity)`` pairs), then the velocities in the same order."""
        cs = [c for c in self.coordinates if active is None or active(c)]
        return [c.name for c in cs] + [k for k, _ in kept] + [c.velocity for c in cs] + [v for _, v in kept]


def deflection_coordinate_names(element: str) -> tuple[str, str]:
    """``(x_NAME, v_NAME)``: the coordinate and velocity of an element's deflection."""
    return f"x_{element}", f"v_{element}"


def parse_reduction(ctx: Any, r: dict[str, Any], declare: Callable[[str, str], None],
                    elements: dict[str, Element], terms: Callable[[str, Any], tuple[Term, ...]],
                    text: Callable[[dict[str, Any], str], str | None],
                    unit: Callable[[str, str], Unit]) -> Reduction:
    """Parse a ``[reduction]`` table.

    Parameters
    ----------
    ctx
        The model parser's context (``ctx.error(field, message)`` builds a SpecError).
    r
        The table.
    declare
        Declares a new name (rejects duplicates and bad identifiers).
    elements
        The model's parsed elements.
    terms
        ``terms(where, value)`` parses an expression field.
    text
        ``text(table, where)`` reads an optional string field.
    unit
        ``unit(where, text)`` parses a unit.
    """
    mode = text(r, "reduction.mode") or ("explicit" if ("coordinate" in r or "coordinates" in r) else None)
    if mode not in ("explicit", "deflections"):
        if mode is None:
            raise ctx.error("reduction", "needs 'coordinate' (one reduced coordinate), a "
                                         "[reduction.coordinates.NAME] table per coordinate, or "
                                         "mode = \"deflections\"")
        raise ctx.error("reduction.mode", f"must be 'explicit' or 'deflections', got '{mode}'")
    if mode == "deflections":
        return _parse_deflections(ctx, r, declare, elements, text)
    if "coordinates" in r:
        _only(ctx, "reduction", r, {"mode", "coordinates"})
        table = r["coordinates"]
        if not isinstance(table, dict) or not table:
            raise ctx.error("reduction.coordinates", "expected one table per reduced coordinate, e.g. "
                                                     "[reduction.coordinates.x1]")
        out = []
        for name, c in table.items():
            where = f"reduction.coordinates.{name}"
            if not isinstance(c, dict):
                raise ctx.error(where, f"wrong type: expected a table, got {type(c).__name__}")
            _only(ctx, where, c, {"definition", "unit", "velocity", "meaning"})
            out.append(_one(ctx, c, where, name, declare, terms, text, unit))
        return Reduction(tuple(out), "explicit")
    _only(ctx, "reduction", r, {"mode", "coordinate", "velocity", "definition", "unit", "meaning", "keep"})
    name = text(r, "reduction.coordinate")
    if name is None:
        raise ctx.error("reduction.coordinate", "missing field 'coordinate'")
    keep = r.get("keep", [])
    if not isinstance(keep, list) or not all(isinstance(k, str) for k in keep):
        raise ctx.error("reduction.keep", "expected an array of coordinate names")
    if len(set(keep)) != len(keep):
        raise ctx.error("reduction.keep", "a coordinate is listed twice")
    return Reduction((_one(ctx, r, "reduction", name, declare, terms, text, unit, single=True),), "explicit",
                     tuple(keep))


def _one(ctx: Any, c: dict[str, Any], where: str, name: str, declare: Callable[[str, str], None],
         terms: Callable[[str, Any], tuple[Term, ...]], text: Callable[[dict[str, Any], str], str | None],
         unit: Callable[[str, str], Unit], single: bool = False) -> ReducedCoordinate:
    vel = text(c, f"{where}.velocity") or f"{name}_dot"
    declare(name, f"{where}.coordinate" if single else where)
    declare(vel, f"{where}.velocity")
    if "definition" not in c:
        raise ctx.error(f"{where}.definition", "missing definition of the reduced coordinate")
    u = text(c, f"{where}.unit") or "1"
    dims = unit(f"{where}.unit", u)
    if dims.scale != 1.0:
        raise ctx.error(f"{where}.unit", f"reduced coordinates must be in coherent SI units, not '{u}'")
    return ReducedCoordinate(name, vel, terms(f"{where}.definition", c["definition"]), u,
                             text(c, f"{where}.meaning") or "", dims)


def _parse_deflections(ctx: Any, r: dict[str, Any], declare: Callable[[str, str], None],
                       elements: dict[str, Element],
                       text: Callable[[dict[str, Any], str], str | None]) -> Reduction:
    _only(ctx, "reduction", r, {"mode", "elements", "meaning"})
    if "elements" in r:
        names = r["elements"]
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise ctx.error("reduction.elements", "expected a non-empty array of element names")
        if len(set(names)) != len(names):
            raise ctx.error("reduction.elements", "an element is named twice")
        for i, n in enumerate(names):
            if n not in elements:
                raise ctx.error(f"reduction.elements[{i}]", f"unknown element '{n}'")
            if not element_type(elements[n].type).has_deflection:
                raise ctx.error(f"reduction.elements[{i}]", f"element '{n}' is a {elements[n].type}: only "
                                                            f"{', '.join(deflection_types())} elements have a "
                                                            f"deflection")
    else:
        names = [n for n, el in elements.items() if element_type(el.type).deflection_default]
        if not names:
            raise ctx.error("reduction.mode", f"mode = \"deflections\" needs "
                                              f"{' or '.join(deflection_types(default_only=True))} elements")
    out = []
    for n in names:
        el = elements[n]
        xn, vn = deflection_coordinate_names(n)
        declare(xn, f"elements.{n} (reduced coordinate of mode = \"deflections\")")
        declare(vn, f"elements.{n} (reduced velocity of mode = \"deflections\")")
        d = element_type(el.type).deflection(el)
        assert d is not None
        out.append(ReducedCoordinate(xn, vn, d.definition, None, f"{d.meaning} of {n}" + (
            f": {el.meaning}" if el.meaning else ""), None, n, el.effect, el.variant))
    return Reduction(tuple(out), "deflections")


def reduction_units(ctx: Any, reduction: Reduction, elements: dict[str, Element],
                    terms_unit: Callable[[tuple[Term, ...]], Unit | None]) -> dict[str, Unit]:
    """Units of the reduced coordinates (checked against the definitions).

    Parameters
    ----------
    terms_unit
        Infers the unit of a field's terms (``None`` when no term is active).

    Returns
    -------
    dict
        Coordinate name -> unit (velocities are added by the caller).
    """
    out: dict[str, Unit] = {}
    for c in reduction.coordinates:
        if c.element is not None:
            el = elements[c.element]
            d = element_type(el.type).deflection(el)
            assert d is not None
            u = terms_unit(d.geometric)
            if u is None:
                raise ctx.error(f"elements.{c.element}.{d.field}", "no active term")
            out[c.name] = u
            continue
        where = "reduction.definition" if len(reduction.coordinates) == 1 and reduction.mode == "explicit" \
            and c.definition and c.definition[0].field == "reduction.definition" \
            else f"reduction.coordinates.{c.name}.definition"
        u = terms_unit(c.definition)
        assert c.dims is not None
        if u is not None and not u.same_dimension(c.dims):
            unit_field = "reduction.unit" if where == "reduction.definition" else \
                f"reduction.coordinates.{c.name}.unit"
            raise ctx.error(where, f"unit mismatch: [{u.si_string()}] but {unit_field} is "
                                   f"[{c.dims.si_string()}]")
        out[c.name] = c.dims
    return out


def _only(ctx: Any, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    only_keys(ctx, where, table, allowed)
