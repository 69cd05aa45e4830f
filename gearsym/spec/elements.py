"""Element types of the model spec: their fields and unit rules (no sympy).

The classical elements (``inertia``, ``force``, ``spring``, ``damper``, ``mesh``) are read
by :mod:`gearsym.spec.model` itself; the types below are described by an
:class:`ElementSchema` each -- expression fields, coordinate fields, unit checks -- and
derived by one module each in :mod:`gearsym.symbolic.elements`.  A new element type is
a schema here and a module there.

``bearing``
    A radial bearing of a shaft centre: springs and dampers on one or two transverse
    coordinates (``x``, ``y``).  ``Q_x -= stiffness_x*x + damping_x*x'`` (the same in y).
``gear_mesh``
    A spur mesh whose line of action couples the rotations with the transverse motion
    of both centres: ``delta = rb_p*th_p - rb_g*th_g + (xp - xg)*sin(alpha) +
    (yp - yg)*cos(alpha) - error`` (x of the pinion towards the gear, y across the
    centre line, rotations positive in the drive direction), ``alpha`` the pressure
    angle (may depend on the centre coordinates, e.g. through the centre distance).  The
    mesh force ``W = k*f(delta) + c*delta'`` (``f`` the dead zone of the half backlash)
    acts along the line of action: ``-rb_p*W`` on the pinion rotation, ``+rb_g*W`` on
    the gear's, ``-W*(sin alpha, cos alpha)`` on the pinion centre and ``+W*(...)`` on
    the gear centre (the direction is frozen in the virtual work: the rotation of the
    line of action with the centres does no work).  Switching surfaces ``NAME.drive`` /
    ``NAME.back`` as for ``mesh``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from .units import ONE, Unit

if TYPE_CHECKING:
    from .fields import Ctx, Term
    from .model import Element, ModelSpec

__all__ = ["ELEMENT_SCHEMAS", "FIELD_RANGES", "ElementSchema", "validate_element"]

LENGTH = Unit(1.0, (0, 1, 0))


@dataclass(frozen=True)
class ElementSchema:
    """Fields of an element type.

    Attributes
    ----------
    required, optional
        Expression fields.
    coordinates
        Coordinate fields: name -> number of coordinate names it takes (1: a string,
        2: an array of two).
    required_coordinates
        The coordinate fields that must be given.
    meaning
        One line for error messages and docs.
    ranges
        Physical range of fields: field -> (``">0"`` or ``">=0"``, what it is), checked for
        the parameter values a scene uses (:mod:`gearsym.spec.rules`).
    """

    required: frozenset[str]
    optional: frozenset[str] = frozenset()
    coordinates: dict[str, int] = field(default_factory=dict)
    required_coordinates: frozenset[str] = frozenset()
    meaning: str = ""
    ranges: dict[str, tuple[str, str]] = field(default_factory=dict)


ELEMENT_SCHEMAS: dict[str, ElementSchema] = {
    "bearing": ElementSchema(
        required=frozenset({"stiffness_x"}),
        optional=frozenset({"stiffness_y", "damping_x", "damping_y"}),
        coordinates={"x": 1, "y": 1},
        required_coordinates=frozenset({"x"}),
        meaning="radial bearing: springs/dampers on the transverse coordinates x, y of a centre",
        ranges={"stiffness_x": (">=0", "stiffness"), "stiffness_y": (">=0", "stiffness"),
                "damping_x": (">=0", "damping"), "damping_y": (">=0", "damping")},
    ),
    "gear_mesh": ElementSchema(
        required=frozenset({"pinion_base_radius", "gear_base_radius", "pressure_angle", "stiffness"}),
        optional=frozenset({"error", "damping", "backlash"}),
        coordinates={"pinion": 1, "gear": 1, "pinion_centre": 2, "gear_centre": 2},
        required_coordinates=frozenset({"pinion", "gear"}),
        meaning="spur mesh along the line of action, coupling rotations and centre translations",
        ranges={"backlash": (">=0", "half backlash"), "stiffness": (">=0", "stiffness"),
                "damping": (">=0", "damping")},
    ),
}

#: Physical range of the fields of every element type (see :attr:`ElementSchema.ranges`): a
#: value that is a function of the parameters only is checked against it.  A spring may have a
#: negative stiffness (a softening support); a contact (mesh) may not.
FIELD_RANGES: dict[str, dict[str, tuple[str, str]]] = {
    "inertia": {"value": (">0", "inertia")},
    "mesh": {"backlash": (">=0", "half backlash"), "stiffness": (">=0", "stiffness"), "damping": (">=0", "damping")},
    "damper": {"coefficient": (">=0", "damping coefficient")},
    **{k: v.ranges for k, v in ELEMENT_SCHEMAS.items()},
}


def validate_element(ctx: Ctx, spec: ModelSpec, el: Element,
                     unit_of_terms: Callable[[tuple[Term, ...]], Unit | None],
                     energy_of: Callable[[str, Unit], None]) -> None:
    """Unit checks of an element of a schema type (see the module docstring)."""
    w = f"elements.{el.name}"
    tt = spec.time_dims
    f = el.fields

    def coord(name: str) -> Unit:
        return spec.coordinates[name].dims

    if el.type == "bearing":
        for axis in ("x", "y"):
            if axis not in el.coordinates:
                continue
            c = coord(el.coordinates[axis][0])
            for key, per_time in ((f"stiffness_{axis}", False), (f"damping_{axis}", True)):
                if key in f:
                    u = unit_of_terms(f[key])
                    if u is not None:
                        energy_of(f"{w}.{key}", u * c * c / tt if per_time else u * c * c)
        return
    if el.type == "gear_mesh":
        rot = coord(el.coordinates["pinion"][0])
        if not coord(el.coordinates["gear"][0]).same_dimension(rot):
            raise ctx.error(f"{w}.gear", "the pinion and gear coordinates must have the same unit")
        rb = unit_of_terms(f["pinion_base_radius"])
        rg = unit_of_terms(f["gear_base_radius"])
        if rb is not None and rg is not None and not rb.same_dimension(rg):
            raise ctx.error(f"{w}.gear_base_radius", f"unit mismatch: [{rg.si_string()}] but the pinion "
                                                     f"base radius is [{rb.si_string()}]")
        d = (rb or rg or LENGTH) * rot
        for key in ("pinion_centre", "gear_centre"):
            for i, c in enumerate(el.coordinates.get(key, ())):
                if not coord(c).same_dimension(d):
                    raise ctx.error(f"{w}.{key}[{i}]", f"unit mismatch: '{c}' is [{coord(c).si_string()}] but "
                                                       f"the deflection along the line of action is "
                                                       f"[{d.si_string()}]")
        a = unit_of_terms(f["pressure_angle"])
        if a is not None and not a.same_dimension(ONE):
            raise ctx.error(f"{w}.pressure_angle", f"must be dimensionless (an angle), got [{a.si_string()}]")
        for key in ("error", "backlash"):
            if key in f:
                u = unit_of_terms(f[key])
                if u is not None and not u.same_dimension(d):
                    raise ctx.error(f"{w}.{key}", f"unit mismatch: [{u.si_string()}] but the deflection is "
                                                  f"[{d.si_string()}]")
        u = unit_of_terms(f["stiffness"])
        if u is not None:
            energy_of(f"{w}.stiffness", u * d * d)
        if "damping" in f:
            u = unit_of_terms(f["damping"])
            if u is not None:
                energy_of(f"{w}.damping", u * d * d / tt)
        return
    raise AssertionError(f"no unit rules for element type {el.type}")  # pragma: no cover
