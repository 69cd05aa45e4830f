"""``mesh``: a gear mesh on a deflection along its line of action, with backlash.

``delta = deflection - error`` (the dynamic deflection), force
``W = stiffness*f(delta) + damping*delta'`` with ``f`` the dead zone of the half
``backlash`` (``delta - b`` / ``0`` / ``delta + b``); ``Q_i -= W*d(deflection)/d(q_i)``.
With a backlash it has the contact surfaces ``NAME.drive`` / ``NAME.back`` (its flanks).
``backlash``, ``stiffness`` and ``damping`` are >= 0.  In ``[reduction] mode =
"deflections"`` it gets the coordinate ``x_NAME = delta`` by default.
"""

from __future__ import annotations

from .base import DeflectionType


class Mesh(DeflectionType):
    """Spec side of ``mesh`` (see the module docstring)."""

    name = "mesh"
    meaning = "gear mesh on a deflection along its line of action, with backlash (dead zone)"
    required = frozenset({"deflection", "stiffness"})
    optional = frozenset({"error", "damping", "backlash"})
    ranges = {"backlash": (">=0", "half backlash"), "stiffness": (">=0", "stiffness"),
              "damping": (">=0", "damping")}
    deflection_default = True
    deflection_meaning = "dynamic deflection (deflection - error)"
