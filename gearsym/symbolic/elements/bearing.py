"""``bearing``: springs and dampers on the transverse coordinates of a shaft centre.

``Q_x -= stiffness_x*x + damping_x*x'`` and the same in ``y`` (``stiffness_y`` defaults to
``stiffness_x``, a missing damping to none).  A coordinate of a switched-off effect
(e.g. ``bearing_flexibility``) contributes nothing.
"""

from __future__ import annotations

import sympy as sp

from .base import SymbolicElement


class Bearing(SymbolicElement):
    """Symbolic side of ``bearing`` (see the module docstring)."""

    type_name = "bearing"

    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        out = []
        for axis in ("x", "y"):
            c = self.coordinate(axis)
            if c == 0:
                continue
            k = self.field(f"stiffness_{axis}")
            if k == 0 and axis == "y" and "stiffness_y" not in self.el.fields:
                k = self.field("stiffness_x")
            damping = self.field(f"damping_{axis}")
            out.append((c, -k * c - damping * self.a.ddt(c) if damping != 0 else -k * c))
        return out
