"""Linear analysis: modes about the static equilibrium and the structure of planetary modes.

The public face (the modules behind it are private): :func:`modal_analysis` (natural
frequencies and mode shapes of the linearisation about the static equilibrium, or of its
average over a mesh period: :class:`ModalAnalysis`), :func:`static_equilibrium` and the
helpers :func:`averaged_linearization`, :func:`diagonal_mass`; :func:`classify_planetary`
sorts the modes of a planetary set into the types of Lin & Parker (:data:`MODE_TYPES`,
:func:`planetary_layout`, :class:`PlanetaryLayout`).

The static equilibrium itself (:mod:`gearsym.static`) stays in the system layer, because
:meth:`gearsym.Scene.compile` starts from it.  This package imports no other kind of analysis.
"""

from __future__ import annotations

from ._modes import ModalAnalysis, averaged_linearization, diagonal_mass, modal_analysis, static_equilibrium
from ._planetary import MODE_TYPES, PlanetaryLayout, classify_planetary, planetary_layout

__all__ = ["MODE_TYPES", "ModalAnalysis", "PlanetaryLayout", "averaged_linearization", "classify_planetary",
           "diagonal_mass", "modal_analysis", "planetary_layout", "static_equilibrium"]
