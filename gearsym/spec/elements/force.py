"""``force``: a generalised force on one coordinate (a torque on an angle).

``Q_coordinate += value``; ``value`` may use time, the states and the velocities.  Its unit
is energy / coordinate.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import ElementType, UnitCheck

if TYPE_CHECKING:  # pragma: no cover
    from ..model import Element


class Force(ElementType):
    """Spec side of ``force`` (see the module docstring)."""

    name = "force"
    meaning = "generalised force on one coordinate (Q_coordinate += value)"
    required = frozenset({"value"})
    takes_coordinate = True

    def check_units(self, el: Element, u: UnitCheck) -> None:
        c = u.coordinate(el.coordinate)  # type: ignore[arg-type]
        v = u.unit_of_terms(el.fields["value"])
        if v is not None:
            u.energy_of(f"elements.{el.name}.value", v * c)
