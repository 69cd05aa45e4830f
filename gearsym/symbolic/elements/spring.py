"""``spring``: ``W = stiffness*deflection``, ``Q_i -= W*d(deflection)/d(q_i)``."""

from __future__ import annotations

import sympy as sp

from .deflection import DeflectionElement


class Spring(DeflectionElement):
    """Symbolic side of ``spring`` (see the module docstring)."""

    type_name = "spring"

    def force_law(self) -> sp.Expr:
        return self.field("stiffness") * self.delta
