"""The spec side of an element type: its schema, unit rules, physical ranges and reduction role.

Every element type is one :class:`ElementType` subclass in a module of this package
(``inertia.py``, ``mesh.py``, ...), registered in :data:`gearsym.spec.elements.ELEMENT_TYPES`
under its ``name``; the symbolic side (the equations it contributes) is the class of the same
name in :mod:`gearsym.symbolic.elements`.  Nothing outside the two element packages asks
which type an element is: the parser, the unit checks (:mod:`gearsym.spec.validate`), the
physical ranges (:mod:`gearsym.spec.rules`), the ``[reduction] mode = "deflections"``
coordinates (:mod:`gearsym.spec.reduction`) and the scene's effect bookkeeping
(:mod:`gearsym.spec.scene`) call the hooks below.  This layer knows no sympy.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

from .. import expressions as ex
from ..units import Unit

if TYPE_CHECKING:  # pragma: no cover
    from ...errors import SpecError
    from ..fields import Ctx, Term
    from ..model import Element, ModelSpec

__all__ = ["Deflection", "DeflectionType", "ElementType", "UnitCheck"]


@dataclass(frozen=True)
class UnitCheck:
    """What the unit rules of an element work with (:meth:`ElementType.check_units`).

    Attributes
    ----------
    ctx
        The parser's context (``ctx.error(field, message)`` builds the SpecError).
    spec
        The model being validated (its coordinates and time unit).
    unit_of_terms
        The unit of a field's terms (``None`` when no term is active).
    energy_of
        ``energy_of(field, unit)``: the unit of the work a term does; every energy of a model
        must have one unit (the first one seen defines it).
    """

    ctx: Ctx
    spec: ModelSpec
    unit_of_terms: Callable[[tuple[Term, ...]], Unit | None]
    energy_of: Callable[[str, Unit], None]

    @property
    def time(self) -> Unit:
        """The model's time unit."""
        return self.spec.time_dims

    def coordinate(self, name: str) -> Unit:
        """The unit of a coordinate."""
        return self.spec.coordinates[name].dims

    def field(self, el: Element, key: str) -> Unit | None:
        """The unit of an expression field of ``el`` (``None``: absent or no active term)."""
        return self.unit_of_terms(el.fields[key]) if key in el.fields else None

    def error(self, field: str, message: str) -> SpecError:
        """A SpecError naming ``field`` of the model file."""
        return self.ctx.error(field, message)


@dataclass(frozen=True)
class Deflection:
    """The coordinate an element gets in ``[reduction] mode = "deflections"``.

    Attributes
    ----------
    definition
        Terms of the reduced coordinate's definition (linear in the coordinates).
    geometric
        The terms whose unit is the coordinate's unit.
    field
        The field named when ``geometric`` has no active term (``"deflection"``).
    meaning
        What the coordinate is (``"dynamic deflection (deflection - error)"``).
    """

    definition: tuple[Term, ...]
    geometric: tuple[Term, ...]
    field: str
    meaning: str


class ElementType(ABC):
    """The spec side of one element type (PyBaMM-submodel style: fixed hooks, one class).

    Class attributes
    ----------------
    name
        The ``type`` of the element in a model file.
    meaning
        One line for docs and messages.
    required, optional
        Its expression fields.
    takes_coordinate
        Whether it names the one coordinate it acts on in ``coordinate = "q"`` (required).
    coordinates
        Coordinate fields: name -> how many coordinate names it takes (1: a string, 2: an
        array of two).  An element with coordinate fields may not use ``coordinate``.
    required_coordinates
        The coordinate fields that must be given.
    ranges
        Physical range of fields: field -> (``">0"`` or ``">=0"``, what it is), checked for
        the parameter values a scene uses (:mod:`gearsym.spec.rules`).
    has_deflection
        Whether its elements have a coordinate in ``[reduction] mode = "deflections"``
        (:meth:`deflection`); only those may be named in ``[reduction] elements``.
    deflection_default
        Whether they get it without ``elements`` naming them.

    Hooks (methods) are below; :meth:`check_units` is the one every type must write.
    """

    name: ClassVar[str]
    meaning: ClassVar[str] = ""
    required: ClassVar[frozenset[str]] = frozenset()
    optional: ClassVar[frozenset[str]] = frozenset()
    takes_coordinate: ClassVar[bool] = False
    coordinates: ClassVar[Mapping[str, int]] = {}
    required_coordinates: ClassVar[frozenset[str]] = frozenset()
    ranges: ClassVar[Mapping[str, tuple[str, str]]] = {}
    has_deflection: ClassVar[bool] = False
    deflection_default: ClassVar[bool] = False

    def __repr__(self) -> str:
        return f"<element type '{self.name}'>"

    @abstractmethod
    def check_units(self, el: Element, u: UnitCheck) -> None:
        """Check the units of ``el``'s fields and declare the work its terms do (``u.energy_of``);
        raise ``u.error(field, message)`` naming the field that is wrong."""

    def mass_coordinates(self, el: Element) -> tuple[str, ...]:
        """The coordinates ``el`` gives a mass (a diagonal entry of the mass matrix); every
        coordinate needs one, from an element or from ``[equations]``."""
        return ()

    def range_label(self, el: Element, what: str) -> str:
        """How a range message names a field of ``el`` (``"half backlash of mesh 'mesh'"``)."""
        return f"{what} of {self.name} '{el.name}'"

    def acts_on(self, el: Element) -> set[str]:
        """Names of the coordinates ``el`` acts on (an element whose coordinates all belong to
        one effect belongs to that effect: :mod:`gearsym.spec.scene`).  May contain other
        names; the caller keeps the coordinates."""
        if el.coordinate is not None:
            return {el.coordinate}
        return {n for names in el.coordinates.values() for n in names}

    def deflection(self, el: Element) -> Deflection | None:
        """The coordinate ``el`` gets in ``[reduction] mode = "deflections"`` (``None`` for a type
        without :attr:`has_deflection`)."""
        return None


# ------------------------------------------------------------- elements acting on a deflection


class DeflectionType(ElementType):
    """An element type acting on a ``deflection`` field (an expression of the coordinates and
    time), whose generalised force is ``-W*d(deflection)/d(q_i)``: the unit rules, coordinates
    and deflection coordinate of ``spring``, ``damper`` and ``mesh``.

    ``error`` and ``backlash`` are in the unit ``d`` of the deflection, ``stiffness`` does work
    ``k*d^2`` and ``coefficient`` / ``damping`` ``c*d^2/time``.  Its coordinate in
    ``[reduction] mode = "deflections"`` is the deflection minus the ``error`` terms (if any).
    """

    has_deflection = True
    #: what its deflection coordinate is (``inspect`` shows it)
    deflection_meaning: ClassVar[str] = "deflection"

    def check_units(self, el: Element, u: UnitCheck) -> None:
        w = f"elements.{el.name}"
        f = el.fields
        d = u.unit_of_terms(f["deflection"])
        if d is None:
            raise u.error(f"{w}.deflection", "no active term")
        for key in ("error", "backlash"):
            if key in f:
                v = u.unit_of_terms(f[key])
                if v is not None and not v.same_dimension(d):
                    raise u.error(f"{w}.{key}", f"unit mismatch: [{v.si_string()}] but the "
                                                f"deflection is [{d.si_string()}]")
        if "stiffness" in f:
            v = u.unit_of_terms(f["stiffness"])
            if v is not None:
                u.energy_of(f"{w}.stiffness", v * d * d)
        for key in ("coefficient", "damping"):
            if key in f:
                v = u.unit_of_terms(f[key])
                if v is not None:
                    u.energy_of(f"{w}.{key}", v * d * d / u.time)

    def acts_on(self, el: Element) -> set[str]:
        return set().union(*(ex.names_in(t.expr) for t in el.fields.get("deflection", ())))

    def deflection(self, el: Element) -> Deflection:
        definition = tuple(el.fields["deflection"])
        if "error" in el.fields:  # the dynamic deflection: deflection - error
            definition += tuple(dataclasses.replace(t, expr=f"-({t.expr})") for t in el.fields["error"])
        return Deflection(definition, tuple(el.fields["deflection"]), "deflection", self.deflection_meaning)
