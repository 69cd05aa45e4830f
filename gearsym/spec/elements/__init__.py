"""Element types of the model spec: one module each, registered here (no sympy).

Each module of this package defines one :class:`~gearsym.spec.elements.base.ElementType`:
its fields (required, optional, coordinate fields), unit rules, physical ranges and
reduction role.  The symbolic side of the same type -- mass matrix, generalised forces,
contact surfaces, per-mesh results, scales -- is the class registered under the same name
in :mod:`gearsym.symbolic.elements`.  A new element type is one module here and one there,
one line in each registry, and its documentation (``docs/contributing.md``, "Adding an
element type").

=============  ================================================================
``inertia``    mass or moment of inertia of one coordinate
``force``      generalised force on one coordinate
``spring``     linear spring on a deflection (an expression of the coordinates)
``damper``     linear damper on the rate of a deflection
``mesh``       gear mesh on a deflection, with error, damping and backlash
``bearing``    radial bearing: springs/dampers on the centre coordinates
``gear_mesh``  spur mesh along the line of action, coupling rotations and centres
=============  ================================================================
"""

from __future__ import annotations

from .base import Deflection, DeflectionType, ElementType, UnitCheck
from .bearing import Bearing
from .damper import Damper
from .force import Force
from .gear_mesh import GearMesh
from .inertia import Inertia
from .mesh import Mesh
from .spring import Spring

__all__ = ["ELEMENT_TYPES", "Deflection", "DeflectionType", "ElementType", "UnitCheck", "element_type"]

#: Every element type by its name (``type`` in a model file), in the order messages list them.
ELEMENT_TYPES: dict[str, ElementType] = {t.name: t for t in (
    Inertia(), Spring(), Damper(), Mesh(), Force(), Bearing(), GearMesh(),
)}


def element_type(name: str) -> ElementType:
    """The element type called ``name`` (a KeyError for a name no module registers; the
    parser has refused those with a message listing :data:`ELEMENT_TYPES`)."""
    return ELEMENT_TYPES[name]
