"""``damper``: a linear damper on the rate of a deflection.

Force ``W = coefficient*d(deflection)/dt`` (chain rule over the coordinates plus ``d/dt``
of explicit time); ``Q_i -= W*d(deflection)/d(q_i)``.  ``coefficient >= 0``.  In
``[reduction] mode = "deflections"`` a damper gets a coordinate only when named in
``elements`` (it usually acts on the deflection of a spring or mesh that has one).
"""

from __future__ import annotations

from .base import DeflectionType


class Damper(DeflectionType):
    """Spec side of ``damper`` (see the module docstring)."""

    name = "damper"
    meaning = "linear damper on the rate of a deflection (W = coefficient*d(deflection)/dt)"
    required = frozenset({"deflection", "coefficient"})
    ranges = {"coefficient": (">=0", "damping coefficient")}
