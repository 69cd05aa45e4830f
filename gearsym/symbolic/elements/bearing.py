"""``bearing``: springs and dampers on the transverse coordinates of a shaft centre.

``Q_x -= stiffness_x*x + damping_x*x'`` and the same in ``y`` (``stiffness_y`` defaults to
``stiffness_x``, a missing damping to none).  A coordinate of a switched-off effect
(e.g. ``bearing_flexibility``) contributes nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy as sp

if TYPE_CHECKING:
    from ...spec.model import Element
    from .base import Assembly


def assemble(a: Assembly, el: Element) -> None:
    """Add the bearing forces to ``a.Q``."""
    for axis in ("x", "y"):
        names = el.coordinates.get(axis)
        if not names:
            continue
        c = a.coordinate(names[0])
        if c == 0:
            continue
        k = a.field(el, f"stiffness_{axis}")
        if k == 0 and axis == "y" and "stiffness_y" not in el.fields:
            k = a.field(el, "stiffness_x")
        damping = a.field(el, f"damping_{axis}")
        a.add_force(c, -k * c - damping * a.ddt(c) if damping != 0 else -k * c)
    _ = sp
