"""``force``: a generalised force on one coordinate, ``Q[q] += value``.

``value`` may use time, the states and the velocities; the rigid-body-mode test sees it.
"""

from __future__ import annotations

import sympy as sp

from .base import SymbolicElement


class Force(SymbolicElement):
    """Symbolic side of ``force`` (see the module docstring)."""

    type_name = "force"

    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        return [(self.a.coordinate(self.el.coordinate), self.field("value"))]  # type: ignore[arg-type]
