"""What an element module works with while the equations are assembled."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import sympy as sp

if TYPE_CHECKING:
    from ...spec.model import Element
    from ..parsing import Namespace


@dataclass
class Assembly:
    """The equations ``M q'' = Q`` being assembled, and helpers for element modules.

    Attributes
    ----------
    ns
        The namespace (symbols and expression parsing).
    q, v
        Coordinates and velocities of this scene (gated coordinates left out).
    M, Q
        Mass matrix and generalised forces (sympy matrices, changed in place).
    hints
        Switching functions the elements declare (contact surfaces), in order.
    forces
        Every generalised force added (read by the rigid-body-mode test).
    is_active
        ``is_active(effect, variant)``: whether an effect is on.
    """

    ns: Namespace
    q: list[sp.Symbol]
    v: list[sp.Symbol]
    M: sp.Matrix
    Q: sp.Matrix
    hints: list[Any] = field(default_factory=list)
    is_active: Any = None
    #: every generalised force added (for the rigid-body-mode test of :mod:`..rigid`)
    forces: list[sp.Expr] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.index = {s.name: i for i, s in enumerate(self.q)}

    def field(self, el: Element, key: str) -> sp.Expr:
        """Sum of the active terms of an expression field of ``el`` (0 if absent)."""
        return self.ns.sum_terms(el.fields.get(key, ()), el.effect, el.variant)

    def coordinate(self, name: str) -> sp.Expr:
        """The symbol of a coordinate, or 0 if its effect is off."""
        return self.q[self.index[name]] if name in self.index else sp.Integer(0)

    def ddt(self, expr: sp.Expr) -> sp.Expr:
        """Total time derivative along the motion (``d/dt + sum_i v_i d/dq_i``)."""
        free = expr.free_symbols
        return sp.diff(expr, self.ns.t) + sum(sp.diff(expr, qi) * vi for qi, vi in zip(self.q, self.v)
                                              if qi in free)

    def add_force(self, coordinate: sp.Expr, value: sp.Expr) -> None:
        """``Q[coordinate] += value`` (nothing for a coordinate of a switched-off effect)."""
        if isinstance(coordinate, sp.Symbol) and coordinate.name in self.index:
            self.Q[self.index[coordinate.name], 0] += value
            self.forces.append(value)


def dead_zone(a: Assembly, el: Element, delta: sp.Expr, b: sp.Expr) -> sp.Expr:
    """``f(delta)``: the backlash dead zone of half width ``b`` (``delta`` itself if ``b`` is 0),
    registering the contact surfaces ``NAME.drive`` / ``NAME.back`` (as the ``mesh`` element)."""
    from ..switching import dead_zone as _dead_zone

    f, surfaces = _dead_zone(el.name, el.drive_side, delta, b)
    a.hints += surfaces
    return f
