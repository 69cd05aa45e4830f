"""Elements acting on a ``deflection`` field: ``spring``, ``damper`` and ``mesh`` share this.

The element's force ``W`` acts along its deflection (an expression of the coordinates and
time): virtual work ``-W*d(deflection)`` gives ``Q_i -= W*d(deflection)/d(q_i)`` for every
coordinate the deflection contains (only the ``deflection`` is differentiated, not the
``error``).  A deflection that depends on no coordinate of the scene is an error, unless it
uses only coordinates of switched-off effects (then the element is not present).
"""

from __future__ import annotations

from abc import abstractmethod
from functools import cached_property

import sympy as sp

from ...errors import SpecError
from .base import SymbolicElement

__all__ = ["DeflectionElement"]


class DeflectionElement(SymbolicElement):
    """Base of the element types with a ``deflection`` field (see the module docstring)."""

    #: the fields whose expressions the rigid-body-mode test sees (with the deflection)
    RIGID_FIELDS = ("error", "stiffness", "damping", "backlash", "coefficient")

    @cached_property
    def geometry(self) -> sp.Expr:
        """The geometric deflection (the ``deflection`` field)."""
        return self.field("deflection")

    @cached_property
    def delta(self) -> sp.Expr:
        """The deflection the force law acts on (default: the geometric deflection)."""
        return self.geometry

    @abstractmethod
    def force_law(self) -> sp.Expr:
        """The force ``W`` along the deflection."""

    @cached_property
    def W(self) -> sp.Expr:
        """The force along the deflection (:meth:`force_law`, computed once)."""
        return self.force_law()

    def present(self) -> bool:
        from ...spec.expressions import names_in

        geom, _ = self.geometry, self.delta
        if not any(geom.has(qi) for qi in self.a.q):
            spec = self.a.ns.rs.model
            gated = {c for c in spec.coordinates if c not in self.a.index}
            if any(names_in(t.expr) & gated for t in self.el.fields.get("deflection", ())):
                return False  # acts only on coordinates of switched-off effects
            raise SpecError("the deflection does not depend on any coordinate",
                            file=spec.path, field=f"elements.{self.el.name}.deflection")
        # the fields in the order the rigid-body test lists them (their surfaces, if any, in this order)
        self._rigid = [self.field(k) for k in self.RIGID_FIELDS if k in self.el.fields]
        return True

    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        geom, W = self.geometry, self.W
        gfree = geom.free_symbols
        out = []
        for qi in self.a.q:
            if qi not in gfree:
                continue  # d(geom)/d(qi) = 0: skip the (costly) symbolic derivative
            dd = sp.diff(geom, qi)
            if dd != 0:
                out.append((qi, -(W * dd)))
        return out

    def rigid_terms(self, applied: list[sp.Expr]) -> tuple[list[sp.Expr], list[sp.Expr]]:
        return [self.geometry], list(self._rigid)
