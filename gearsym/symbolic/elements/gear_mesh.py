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
centre that is not given (or whose coordinates are switched off) is fixed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy as sp

from .base import dead_zone

if TYPE_CHECKING:
    from ...spec.model import Element
    from .base import Assembly


def assemble(a: Assembly, el: Element) -> None:
    """Add the mesh forces to ``a.Q`` and its contact surfaces to ``a.hints``."""
    th_p = a.coordinate(el.coordinates["pinion"][0])
    th_g = a.coordinate(el.coordinates["gear"][0])
    xp, yp = (a.coordinate(n) for n in el.coordinates.get("pinion_centre", ("", ""))) \
        if "pinion_centre" in el.coordinates else (sp.Integer(0), sp.Integer(0))
    xg, yg = (a.coordinate(n) for n in el.coordinates.get("gear_centre", ("", ""))) \
        if "gear_centre" in el.coordinates else (sp.Integer(0), sp.Integer(0))
    rb_p = a.field(el, "pinion_base_radius")
    rb_g = a.field(el, "gear_base_radius")
    alpha = a.field(el, "pressure_angle")
    s, c = sp.sin(alpha), sp.cos(alpha)
    delta = rb_p * th_p - rb_g * th_g + (xp - xg) * s + (yp - yg) * c - a.field(el, "error")
    f = dead_zone(a, el, delta, a.field(el, "backlash"))
    damping = a.field(el, "damping")
    W = a.field(el, "stiffness") * f + (damping * a.ddt(delta) if damping != 0 else 0)
    for coord, arm in ((th_p, -rb_p), (th_g, rb_g), (xp, -s), (yp, -c), (xg, s), (yg, c)):
        a.add_force(coord, arm * W)
