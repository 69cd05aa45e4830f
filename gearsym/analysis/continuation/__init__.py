"""Continuation of periodic orbits in one parameter: predictor, corrector, detection, branches.

The public face (the modules behind it are private):

* :func:`continuation` continues a periodic orbit from ``start`` to ``stop`` of a run-time
  parameter (pseudo-arclength, or steps in the parameter where the branch is a graph over
  it) and returns a :class:`Branch` of :class:`BranchPoint` objects with the located
  special points (:class:`Bifurcation`, the types of :data:`BIFURCATION_TYPES`); its
  settings are :class:`ContinuationOptions`, and :class:`ContinuationSetup` records what
  a branch was computed with;
* :func:`switch_period_doubling` starts the branch of the doubled orbit at a period doubling;
* :func:`add_legend` labels the special points of a branch figure.

Continuation drives the periodic-orbit problems of :mod:`gearsym.analysis.periodic` (the
only other kind of analysis it imports).
"""

from __future__ import annotations

from ._api import continuation
from ._branch import BIFURCATION_TYPES, Bifurcation, Branch, BranchPoint, ContinuationSetup, add_legend
from ._branch_switching import switch_period_doubling
from ._options import ContinuationOptions

__all__ = ["BIFURCATION_TYPES", "Bifurcation", "Branch", "BranchPoint", "ContinuationOptions", "ContinuationSetup",
           "add_legend", "continuation", "switch_period_doubling"]
