"""``inertia``: the mass (or moment of inertia) of one coordinate.

``value`` is the diagonal entry of the mass matrix: kinetic energy ``1/2 value qdot^2``.
Its unit is energy / (coordinate/time)^2; it must be positive.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import ElementType, UnitCheck

if TYPE_CHECKING:  # pragma: no cover
    from ..model import Element


class Inertia(ElementType):
    """Spec side of ``inertia`` (see the module docstring)."""

    name = "inertia"
    meaning = "mass or moment of inertia of one coordinate (kinetic energy 1/2 value qdot^2)"
    required = frozenset({"value"})
    takes_coordinate = True
    ranges = {"value": (">0", "inertia")}

    def check_units(self, el: Element, u: UnitCheck) -> None:
        c = u.coordinate(el.coordinate)  # type: ignore[arg-type]
        v = u.unit_of_terms(el.fields["value"])
        if v is not None:
            u.energy_of(f"elements.{el.name}.value", v * (c / u.time) ** 2)

    def mass_coordinates(self, el: Element) -> tuple[str, ...]:
        return (el.coordinate,) if el.coordinate is not None else ()

    def range_label(self, el: Element, what: str) -> str:
        return what
