"""The symbolic side of an element type: the hooks the model assembles, and what they work with.

Every element type is one :class:`SymbolicElement` subclass in a module of this package,
registered in :data:`gearsym.symbolic.elements.ASSEMBLERS` under the ``type`` name of its spec
side (:mod:`gearsym.spec.elements`).  :class:`~gearsym.symbolic.model.SymbolicModel` makes one
instance per element of the scene (effect on) and calls its hooks, in this order:

``present()``
    whether it acts in this scene at all (an element on coordinates of switched-off effects
    does not);
``mass()``, ``forces()``
    its contributions to ``M q'' = Q``: diagonal mass entries and generalised forces, as
    ``(coordinate, value)`` pairs (a coordinate of a switched-off effect reads as 0 and is
    skipped);
``surfaces()``
    its contact surfaces: switching functions of kind ``"drive"`` / ``"back"`` are the two
    flanks of a clearance (named ``NAME.drive`` / ``NAME.back``), which the static equilibrium
    (:mod:`gearsym.static`) gives one contact state per element, the analyses a rattle state
    and :attr:`~gearsym.symbolic.model.SymbolicModel.modes` its named modes;
``mesh()``
    its per-mesh results (:class:`MeshResult`: the dynamic deflection and the force along
    the line of action), reported for every mesh of a train (``gs_mesh``, ``gs_mesh_force``,
    :mod:`gearsym.analysis.meshes`, the FMU's outputs);
``rigid_terms(applied)``
    the expressions the rigid-body-mode test (:mod:`gearsym.symbolic.rigid`) must see;
``length_scale()``
    a candidate for the length scale of the dimensionless form (:mod:`gearsym.symbolic.scales`:
    the first positive half backlash of a length unit).

Every hook but :meth:`SymbolicElement.forces` has a default (nothing).  Values are computed
lazily and once (``functools.cached_property``), so hooks may share them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import sympy as sp

if TYPE_CHECKING:
    from ...spec.model import Element
    from ..parsing import Namespace
    from ..switching import SwitchingFunction

__all__ = ["Assembly", "MeshResult", "SymbolicElement", "dead_zone"]


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
    """

    ns: Namespace
    q: list[sp.Symbol]
    v: list[sp.Symbol]
    M: sp.Matrix
    Q: sp.Matrix

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

    def _row(self, coordinate: sp.Expr) -> int | None:
        if isinstance(coordinate, sp.Symbol) and coordinate.name in self.index:
            return self.index[coordinate.name]
        return None

    def add_mass(self, coordinate: sp.Expr, value: sp.Expr) -> bool:
        """``M[coordinate, coordinate] += value``; False (nothing added) for a coordinate of a
        switched-off effect."""
        i = self._row(coordinate)
        if i is None:
            return False
        self.M[i, i] += value
        return True

    def add_force(self, coordinate: sp.Expr, value: sp.Expr) -> bool:
        """``Q[coordinate] += value``; False (nothing added) for a coordinate of a switched-off
        effect."""
        i = self._row(coordinate)
        if i is None:
            return False
        self.Q[i, 0] += value
        return True


@dataclass(frozen=True)
class MeshResult:
    """Per-mesh results of an element (:meth:`SymbolicElement.mesh`).

    Attributes
    ----------
    deflection
        The dynamic deflection along the line of action (``deflection - error``).
    force
        The force along the line of action, ``k*f(delta) + c*delta'``.
    field
        The spec field an error about the deflection names (``elements.NAME.deflection``).
    """

    deflection: sp.Expr
    force: sp.Expr
    field: str


class SymbolicElement(ABC):
    """The symbolic side of one element type (see the module docstring for the hooks).

    Parameters
    ----------
    a
        The assembly (namespace, coordinates, helpers).
    el
        The element of the spec.
    """

    #: the element type (the ``type`` of the spec), as its spec side names it
    type_name: ClassVar[str]

    def __init__(self, a: Assembly, el: Element):
        self.a = a
        self.el = el

    def __repr__(self) -> str:
        return f"<{self.type_name} element '{self.el.name}'>"

    # ------------------------------------------------------------------ helpers

    def field(self, key: str) -> sp.Expr:
        """Sum of the active terms of an expression field (0 if absent)."""
        return self.a.field(self.el, key)

    def coordinate(self, key: str, i: int = 0) -> sp.Expr:
        """The symbol of the ``i``-th name of the coordinate field ``key`` (0 if the field is
        absent or the coordinate's effect is off)."""
        names = self.el.coordinates.get(key, ())
        return self.a.coordinate(names[i]) if i < len(names) else sp.Integer(0)

    # -------------------------------------------------------------------- hooks

    def present(self) -> bool:
        """Whether the element acts in this scene (default: its ``coordinate``, if it names one,
        is a coordinate of this scene)."""
        return self.el.coordinate is None or self.el.coordinate in self.a.index

    def mass(self) -> list[tuple[sp.Expr, sp.Expr]]:
        """Diagonal entries of the mass matrix, ``(coordinate, inertia)`` pairs."""
        return []

    @abstractmethod
    def forces(self) -> list[tuple[sp.Expr, sp.Expr]]:
        """Generalised forces, ``(coordinate, Q contribution)`` pairs."""

    def surfaces(self) -> list[SwitchingFunction]:
        """Contact surfaces (kinds ``"drive"`` / ``"back"``: the flanks of a clearance), in order."""
        return []

    def mesh(self) -> MeshResult | None:
        """Per-mesh results (``None``: not a mesh)."""
        return None

    def rigid_terms(self, applied: list[sp.Expr]) -> tuple[list[sp.Expr], list[sp.Expr]]:
        """``(deflections, force expressions)`` for the rigid-body-mode test: a motion that
        changes none of them is a rigid-body mode.  ``applied``: the generalised forces that
        reached ``Q`` (the default force expressions)."""
        return [], list(applied)

    def length_scale(self) -> sp.Expr | None:
        """A candidate length scale of the dimensionless form (a half backlash), or ``None``."""
        return None


def dead_zone(el: Element, delta: sp.Expr, b: sp.Expr) -> tuple[sp.Expr, list[Any]]:
    """``f(delta)``: the backlash dead zone of half width ``b`` (``delta`` itself if ``b`` is 0),
    and the contact surfaces ``NAME.drive`` / ``NAME.back`` it switches on
    (:func:`gearsym.symbolic.switching.dead_zone`)."""
    from ..switching import dead_zone as _dead_zone

    return _dead_zone(el.name, el.drive_side, delta, b)
