"""Element types derived by one module each (see :mod:`gearsym.spec.elements` for their fields).

Each module defines one :class:`~gearsym.symbolic.elements.base.SymbolicElement` subclass:
its mass matrix entries, generalised forces, contact surfaces, per-mesh results, the terms
the rigid-body-mode test sees and its candidate length scale (the hooks are listed in
:mod:`gearsym.symbolic.elements.base`).  :class:`~gearsym.symbolic.model.SymbolicModel`
assembles whatever :data:`ASSEMBLERS` holds and asks no element its type.  A new element
type is one module here and one in :mod:`gearsym.spec.elements`, one line in each registry,
and its documentation (``docs/contributing.md``, "Adding an element type").
"""

from __future__ import annotations

from .base import Assembly, MeshResult, SymbolicElement
from .bearing import Bearing
from .damper import Damper
from .force import Force
from .gear_mesh import GearMesh
from .inertia import Inertia
from .mesh import Mesh
from .spring import Spring

#: element type -> the class of its symbolic side (the keys are those of
#: :data:`gearsym.spec.elements.ELEMENT_TYPES`)
ASSEMBLERS: dict[str, type[SymbolicElement]] = {cls.type_name: cls for cls in (
    Inertia, Spring, Damper, Mesh, Force, Bearing, GearMesh,
)}

__all__ = ["ASSEMBLERS", "Assembly", "MeshResult", "SymbolicElement"]
