"""``inertia``: the mass (or moment of inertia) of one coordinate.

Kinetic energy ``1/2 value qdot^2``: ``M[q, q] += value``.  No force, no surface.
"""

from __future__ import annotations

import sympy as sp

from .base import SymbolicElement


class Inertia(SymbolicElement):
    """Symbolic side of ``inertia`` (see the module docstring)."""

    type_name = "inertia"

    def mass(self) -> list[tuple[sp.Expr, sp.Expr]]:
        return [(self.a.coordinate(self.el.coordinate), self.field("value"))]  # type: ignore[arg-type]

    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        return []
