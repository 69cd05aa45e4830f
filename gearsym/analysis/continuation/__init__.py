"""Continuation of periodic orbits in one parameter: predictor, corrector, detection, branches.

The public face (the modules behind it are private):

* :func:`continuation` continues a periodic orbit from ``start`` to ``stop`` of a run-time
  parameter (pseudo-arclength, or steps in the parameter where the branch is a graph over
  it) and returns a :class:`Branch` of :class:`BranchPoint` objects with the located
  special points (:class:`Bifurcation`, the types of :data:`BIFURCATION_TYPES`); its
  settings are :class:`ContinuationOptions`, and :class:`ContinuationSetup` records what
  a branch was computed with;
* :func:`switch_period_doubling` starts the branch of the doubled orbit at a period doubling;
* :func:`add_legend` labels the special points of a branch figure;
* :func:`continue_bifurcation` continues a bifurcation curve (fold, branch point, period
  doubling, Neimark-Sacker, grazing: :data:`CURVE_TYPES`) in two parameters from a special point
  of a branch or a guess (:class:`CurveStart`), with the codimension-2 points on it
  (:data:`CODIM2_TYPES`), and returns a :class:`BifurcationCurve` of :class:`CurvePoint` and
  :class:`Codim2Point`; its settings are :class:`CurveOptions`; :func:`plot_curves` draws curves
  over a stability map of the same plane.

Continuation drives the periodic-orbit problems of :mod:`gearsym.analysis.periodic` (the
only other kind of analysis it imports).
"""

from __future__ import annotations

from ._api import continuation
from ._branch import BIFURCATION_TYPES, Bifurcation, Branch, BranchPoint, ContinuationSetup, add_legend
from ._branch_switching import switch_period_doubling
from ._codim2 import continue_bifurcation
from ._codim2_start import CurveOptions, CurveStart
from ._curve import CODIM2_TYPES, CURVE_TYPES, BifurcationCurve, Codim2Point, CurvePoint, plot_curves
from ._options import ContinuationOptions

__all__ = ["BIFURCATION_TYPES", "CODIM2_TYPES", "CURVE_TYPES", "Bifurcation", "BifurcationCurve", "Branch",
           "BranchPoint", "Codim2Point", "ContinuationOptions", "ContinuationSetup", "CurveOptions", "CurvePoint",
           "CurveStart", "add_legend", "continuation", "continue_bifurcation", "plot_curves",
           "switch_period_doubling"]
