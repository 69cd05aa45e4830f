"""``mesh``: a gear mesh on a deflection, with transmission error, damping and backlash.

``delta = deflection - error``; ``W = stiffness*f(delta) + damping*delta'`` with ``f`` the
dead zone of the half ``backlash`` (``delta`` itself without one);
``Q_i -= W*d(deflection)/d(q_i)``.  With a backlash: the contact surfaces ``NAME.drive`` /
``NAME.back`` (``delta -/+ b``, :func:`gearsym.symbolic.switching.dead_zone`), and the half
backlash is a candidate length scale.  Per-mesh results: ``delta`` and ``W``.
"""

from __future__ import annotations

from functools import cached_property

import sympy as sp

from .base import MeshResult, dead_zone
from .deflection import DeflectionElement


class Mesh(DeflectionElement):
    """Symbolic side of ``mesh`` (see the module docstring)."""

    type_name = "mesh"

    @cached_property
    def delta(self) -> sp.Expr:
        return self.geometry - self.field("error")

    @cached_property
    def _contact(self) -> tuple[sp.Expr, sp.Expr, sp.Expr, list]:
        """``(stiffness, damping, f(delta), surfaces)``."""
        k = self.field("stiffness")
        c = self.field("damping")
        f, surfaces = dead_zone(self.el, self.delta, self.field("backlash"))
        return k, c, f, surfaces

    def force_law(self) -> sp.Expr:
        k, c, f, _ = self._contact
        return k * f + c * self.a.ddt(self.delta)

    def surfaces(self) -> list:
        return list(self._contact[3])

    def mesh(self) -> MeshResult:
        return MeshResult(self.delta, self.W, f"elements.{self.el.name}.deflection")

    def length_scale(self) -> sp.Expr | None:
        return self.field("backlash") if "backlash" in self.el.fields else None
