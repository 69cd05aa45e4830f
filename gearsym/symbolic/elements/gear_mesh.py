"""``gear_mesh``: a spur mesh whose line of action couples rotations and centre translations.

Deflection along the line of action (x of the pinion centre pointing to the gear, y across
the centre line, rotations positive in the drive direction)::

    delta = rb_p*th_p - rb_g*th_g + (xp - xg)*sin(alpha) + (yp - yg)*cos(alpha) - error

with ``alpha`` the ``pressure_angle`` field (it may depend on the centre coordinates, e.g.
``acos((rb_p + rb_g)/a)`` with the actual centre distance ``a``).  The mesh force
``W = stiffness*f(delta) + damping*delta'`` (``f`` the dead zone of the half ``backlash``;
``delta'`` the total derivative, through ``alpha`` too) acts along the line of action::

    Q_th_p -= rb_p*W,   Q_th_g += rb_g*W,
    Q_xp -= W*sin(alpha),   Q_yp -= W*cos(alpha),   Q_xg += W*sin(alpha),   Q_yg += W*cos(alpha)

i.e. the virtual work ``-W*d(delta)`` with the direction of the line of action frozen: the
turning of the line of action with the centres does no work (Yu et al. 2021, eq. 12).  A
centre that is not given (or whose coordinates are switched off) is fixed.  With a backlash:
the contact surfaces ``NAME.drive`` / ``NAME.back`` as for ``mesh``, and the half backlash is
a candidate length scale.  Per-mesh results: ``delta`` and ``W``.
"""

from __future__ import annotations

from functools import cached_property

import sympy as sp

from .base import MeshResult, SymbolicElement, dead_zone


class GearMesh(SymbolicElement):
    """Symbolic side of ``gear_mesh`` (see the module docstring)."""

    type_name = "gear_mesh"

    @cached_property
    def _law(self) -> dict[str, object]:
        """Coordinates, arms, ``delta``, the dead zone's surfaces and ``W``, computed once."""
        th_p, th_g = self.coordinate("pinion"), self.coordinate("gear")
        xp, yp = self.coordinate("pinion_centre", 0), self.coordinate("pinion_centre", 1)
        xg, yg = self.coordinate("gear_centre", 0), self.coordinate("gear_centre", 1)
        rb_p = self.field("pinion_base_radius")
        rb_g = self.field("gear_base_radius")
        alpha = self.field("pressure_angle")
        s, c = sp.sin(alpha), sp.cos(alpha)
        delta = rb_p * th_p - rb_g * th_g + (xp - xg) * s + (yp - yg) * c - self.field("error")
        f, surfaces = dead_zone(self.el, delta, self.field("backlash"))
        damping = self.field("damping")
        W = self.field("stiffness") * f + (damping * self.a.ddt(delta) if damping != 0 else 0)
        arms = ((th_p, -rb_p), (th_g, rb_g), (xp, -s), (yp, -c), (xg, s), (yg, c))
        return {"delta": delta, "W": W, "surfaces": surfaces, "arms": arms}

    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        W = self._law["W"]
        return [(coord, arm * W) for coord, arm in self._law["arms"]]  # type: ignore[attr-defined]

    def surfaces(self) -> list:
        return list(self._law["surfaces"])  # type: ignore[call-overload]

    def mesh(self) -> MeshResult:
        return MeshResult(self._law["delta"], self._law["W"], f"elements.{self.el.name}")  # type: ignore[arg-type]

    def length_scale(self) -> sp.Expr | None:
        return self.field("backlash") if "backlash" in self.el.fields else None
