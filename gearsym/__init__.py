"""gearsym: a symbolic model compiler for gear-transmission dynamics.

Describe a gear model declaratively (``models/*.toml``), pick a scene
(``scenes/*.toml``), and get the equations of motion, generated C, and fast,
event-exact simulation through SUNDIALS.

>>> import gearsym                                             # doctest: +SKIP
>>> scene = gearsym.load_scene("scenes/kahraman_singh.toml")   # doctest: +SKIP
>>> traj = scene.compile().simulate(periods=200)               # doctest: +SKIP
"""

from .analysis.branch import Bifurcation, Branch, BranchPoint
from .analysis.continuation import continuation
from .errors import CompileError, ConvergenceError, GearsymError, ParameterError, SimulationError, SpecError
from .facade import Scene, load_scene
from .results import Event, Trajectory

__version__ = "0.1.0"

__all__ = ["Bifurcation", "Branch", "BranchPoint", "CompileError", "ConvergenceError", "Event", "GearsymError",
           "ParameterError", "Scene", "SimulationError", "SpecError", "Trajectory", "__version__", "continuation",
           "load_scene"]
