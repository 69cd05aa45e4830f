"""``spring``: a linear spring on a deflection (an expression of the coordinates and time).

Force ``W = stiffness*deflection``; virtual work ``-W*d(deflection)`` gives
``Q_i -= W*d(deflection)/d(q_i)``.  A spring may have a negative stiffness (a softening
support): no range.  In ``[reduction] mode = "deflections"`` it gets the coordinate
``x_NAME = deflection`` by default.
"""

from __future__ import annotations

from .base import DeflectionType


class Spring(DeflectionType):
    """Spec side of ``spring`` (see the module docstring)."""

    name = "spring"
    meaning = "linear spring on a deflection (W = stiffness*deflection)"
    required = frozenset({"deflection", "stiffness"})
    deflection_default = True
