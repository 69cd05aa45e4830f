"""``gear_mesh``: a spur mesh whose line of action couples rotations and centre translations.

Deflection along the line of action (x of the pinion towards the gear, y across the centre
line, rotations positive in the drive direction)::

    delta = rb_p*th_p - rb_g*th_g + (xp - xg)*sin(alpha) + (yp - yg)*cos(alpha) - error

``alpha`` the ``pressure_angle`` (it may depend on the centre coordinates, e.g. through the
centre distance).  The mesh force ``W = k*f(delta) + c*delta'`` (``f`` the dead zone of the
half backlash) acts along the line of action: ``-rb_p*W`` on the pinion rotation, ``+rb_g*W``
on the gear's, ``-W*(sin alpha, cos alpha)`` on the pinion centre and ``+W*(...)`` on the gear
centre (the direction is frozen in the virtual work: the rotation of the line of action with
the centres does no work).  Contact surfaces ``NAME.drive`` / ``NAME.back`` as for ``mesh``.

Unit rules: the pinion and gear rotations in one unit, the base radii in one unit, each
centre coordinate in the unit of the deflection ``rb*th``, the pressure angle dimensionless,
``error`` and ``backlash`` in the deflection's unit.  No coordinate in ``[reduction] mode =
"deflections"``: ``delta`` is in general not linear in the centre coordinates (write the
reduced coordinate with ``[reduction] coordinate`` and ``keep``, as ``models/yu_6dof.toml``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..units import ONE, Unit
from .base import ElementType, UnitCheck

if TYPE_CHECKING:  # pragma: no cover
    from ..model import Element

LENGTH = Unit(1.0, (0, 1, 0))


class GearMesh(ElementType):
    """Spec side of ``gear_mesh`` (see the module docstring)."""

    name = "gear_mesh"
    meaning = "spur mesh along the line of action, coupling rotations and centre translations"
    required = frozenset({"pinion_base_radius", "gear_base_radius", "pressure_angle", "stiffness"})
    optional = frozenset({"error", "damping", "backlash"})
    coordinates = {"pinion": 1, "gear": 1, "pinion_centre": 2, "gear_centre": 2}
    required_coordinates = frozenset({"pinion", "gear"})
    ranges = {"backlash": (">=0", "half backlash"), "stiffness": (">=0", "stiffness"),
              "damping": (">=0", "damping")}

    def check_units(self, el: Element, u: UnitCheck) -> None:
        w = f"elements.{el.name}"
        rot = u.coordinate(el.coordinates["pinion"][0])
        if not u.coordinate(el.coordinates["gear"][0]).same_dimension(rot):
            raise u.error(f"{w}.gear", "the pinion and gear coordinates must have the same unit")
        rb = u.field(el, "pinion_base_radius")
        rg = u.field(el, "gear_base_radius")
        if rb is not None and rg is not None and not rb.same_dimension(rg):
            raise u.error(f"{w}.gear_base_radius", f"unit mismatch: [{rg.si_string()}] but the pinion "
                                                   f"base radius is [{rb.si_string()}]")
        d = (rb or rg or LENGTH) * rot
        for key in ("pinion_centre", "gear_centre"):
            for i, c in enumerate(el.coordinates.get(key, ())):
                if not u.coordinate(c).same_dimension(d):
                    raise u.error(f"{w}.{key}[{i}]", f"unit mismatch: '{c}' is [{u.coordinate(c).si_string()}] "
                                                     f"but the deflection along the line of action is "
                                                     f"[{d.si_string()}]")
        a = u.field(el, "pressure_angle")
        if a is not None and not a.same_dimension(ONE):
            raise u.error(f"{w}.pressure_angle", f"must be dimensionless (an angle), got [{a.si_string()}]")
        for key in ("error", "backlash"):
            v = u.field(el, key)
            if v is not None and not v.same_dimension(d):
                raise u.error(f"{w}.{key}", f"unit mismatch: [{v.si_string()}] but the deflection is "
                                            f"[{d.si_string()}]")
        v = u.field(el, "stiffness")
        if v is not None:
            u.energy_of(f"{w}.stiffness", v * d * d)
        v = u.field(el, "damping")
        if v is not None:
            u.energy_of(f"{w}.damping", v * d * d / u.time)
