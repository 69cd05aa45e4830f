"""``damper``: ``W = coefficient*d(deflection)/dt`` (total derivative along the motion),
``Q_i -= W*d(deflection)/d(q_i)``."""

from __future__ import annotations

import sympy as sp

from .deflection import DeflectionElement


class Damper(DeflectionElement):
    """Symbolic side of ``damper`` (see the module docstring)."""

    type_name = "damper"

    def force_law(self) -> sp.Expr:
        return self.field("coefficient") * self.a.ddt(self.delta)
