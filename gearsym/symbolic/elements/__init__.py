"""Element types derived by one module each (see :mod:`gearsym.spec.elements` for their fields).

Each module defines ``assemble(a, el)``: it adds the element's kinetic energy to the mass
matrix and its generalised forces to ``Q`` through the :class:`Assembly` ``a`` (and
registers its contact surfaces).  A new element type is one module here, registered in
:data:`ASSEMBLERS`, plus its schema in :mod:`gearsym.spec.elements`.
"""

from __future__ import annotations

from collections.abc import Callable

from . import bearing, gear_mesh
from .base import Assembly

#: element type -> assemble(assembly, element)
ASSEMBLERS: dict[str, Callable[[Assembly, object], None]] = {
    "bearing": bearing.assemble,
    "gear_mesh": gear_mesh.assemble,
}

__all__ = ["ASSEMBLERS", "Assembly"]
