"""``bearing``: a radial bearing of a shaft centre.

Springs and dampers on one or two transverse coordinates (``x``, ``y``):
``Q_x -= stiffness_x*x + damping_x*x'`` (the same in ``y``; ``stiffness_y`` defaults to
``stiffness_x``).  Stiffnesses and dampings are >= 0; each does work in the model's energy
unit on its coordinate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import ElementType, UnitCheck

if TYPE_CHECKING:  # pragma: no cover
    from ..model import Element


class Bearing(ElementType):
    """Spec side of ``bearing`` (see the module docstring)."""

    name = "bearing"
    meaning = "radial bearing: springs/dampers on the transverse coordinates x, y of a centre"
    required = frozenset({"stiffness_x"})
    optional = frozenset({"stiffness_y", "damping_x", "damping_y"})
    coordinates = {"x": 1, "y": 1}
    required_coordinates = frozenset({"x"})
    ranges = {"stiffness_x": (">=0", "stiffness"), "stiffness_y": (">=0", "stiffness"),
              "damping_x": (">=0", "damping"), "damping_y": (">=0", "damping")}

    def check_units(self, el: Element, u: UnitCheck) -> None:
        w = f"elements.{el.name}"
        for axis in ("x", "y"):
            if axis not in el.coordinates:
                continue
            c = u.coordinate(el.coordinates[axis][0])
            for key, per_time in ((f"stiffness_{axis}", False), (f"damping_{axis}", True)):
                v = u.field(el, key)
                if v is not None:
                    u.energy_of(f"{w}.{key}", v * c * c / u.time if per_time else v * c * c)
