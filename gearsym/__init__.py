"""gearsym: a symbolic model compiler for gear-transmission dynamics.

Describe a gear model declaratively (``models/*.toml``), pick a scene
(``scenes/*.toml``), and get the equations of motion, generated C, and fast,
event-exact simulation through SUNDIALS.

>>> import gearsym                                             # doctest: +SKIP
>>> scene = gearsym.load_scene("scenes/kahraman_singh.toml")   # doctest: +SKIP
>>> traj = scene.compile().simulate(periods=200)               # doctest: +SKIP

The public names are imported on first use (PEP 562), so ``import gearsym`` and
``gearsym --version`` do not pay for sympy, CasADi or the analysis layer.

Diagnostics go to the standard :mod:`logging` hierarchy under the ``gearsym`` logger (one
logger per module, ``logging.getLogger(__name__)``): build cache hits, misses and rebuilds
with their reason, compile times, the shared driver object, the static equilibrium's
contact state, why a continuation stopped.  The library installs no handler (only a
:class:`logging.NullHandler` on ``gearsym``); an application shows them with, e.g.,
``logging.basicConfig(level=logging.INFO)``, the CLI with ``-v`` / ``-vv``.
"""

from __future__ import annotations

import importlib
import logging

from ._version import __version__

logging.getLogger(__name__).addHandler(logging.NullHandler())

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (type checkers read it as True)


#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "Bifurcation": ".analysis.continuation",
    "Branch": ".analysis.continuation",
    "BranchPoint": ".analysis.continuation",
    "continuation": ".analysis.continuation",
    "switch_period_doubling": ".analysis.continuation",
    "ContinuationOptions": ".analysis.continuation",
    "continue_bifurcation": ".analysis.continuation",
    "BifurcationCurve": ".analysis.continuation",
    "CurveOptions": ".analysis.continuation",
    "CurveStart": ".analysis.continuation",
    "ShootingOptions": ".analysis.periodic",
    "PeriodicOrbit": ".analysis.periodic",
    "HarmonicBalanceOptions": ".analysis.periodic",
    "harmonic_balance": ".analysis.periodic",
    "mesh_deflections": ".analysis.periodic",
    "ModalAnalysis": ".analysis.linear",
    "modal_analysis": ".analysis.linear",
    "stability_map": ".analysis.sweeps",
    "LyapunovOptions": ".analysis.sweeps",
    "LyapunovResult": ".analysis.sweeps",
    "lyapunov_exponents": ".analysis.sweeps",
    "BasinOptions": ".analysis.sweeps",
    "BasinResult": ".analysis.sweeps",
    "basins": ".analysis.sweeps",
    "RunupOptions": ".analysis.sweeps",
    "RunupResult": ".analysis.sweeps",
    "runup": ".analysis.sweeps",
    "DiagramOptions": ".analysis.sweeps",
    "bifurcation_diagram": ".analysis.sweeps",
    "CompileError": ".errors",
    "ConvergenceError": ".errors",
    "GearsymError": ".errors",
    "ParameterError": ".errors",
    "SimulationError": ".errors",
    "SpecError": ".errors",
    "Scene": ".facade",
    "load_scene": ".facade",
    "Event": ".results",
    "GearQuantities": ".quantities",
    "gear_quantities": ".quantities",
    "Trajectory": ".results",
    "System": ".facade",
    "SimulateOptions": ".simulation_options",
}

__all__ = [
    "BasinOptions", "BasinResult", "Bifurcation", "BifurcationCurve", "Branch", "BranchPoint", "CompileError",
    "ContinuationOptions", "ConvergenceError", "CurveOptions", "CurveStart", "DiagramOptions", "Event",
    "GearQuantities", "GearsymError", "HarmonicBalanceOptions", "LyapunovOptions", "LyapunovResult",
    "ModalAnalysis", "ParameterError", "PeriodicOrbit", "RunupOptions", "RunupResult", "Scene", "ShootingOptions",
    "SimulateOptions", "SimulationError", "SpecError", "System", "Trajectory", "__version__", "basins",
    "bifurcation_diagram", "continuation", "continue_bifurcation", "gear_quantities", "harmonic_balance",
    "load_scene", "lyapunov_exponents", "mesh_deflections", "modal_analysis", "runup", "stability_map",
    "switch_period_doubling",
]

if TYPE_CHECKING:  # pragma: no cover
    from .analysis.continuation import (
        Bifurcation,
        BifurcationCurve,
        Branch,
        BranchPoint,
        ContinuationOptions,
        CurveOptions,
        CurveStart,
        continuation,
        continue_bifurcation,
        switch_period_doubling,
    )
    from .analysis.linear import ModalAnalysis, modal_analysis
    from .analysis.periodic import (
        HarmonicBalanceOptions,
        PeriodicOrbit,
        ShootingOptions,
        harmonic_balance,
        mesh_deflections,
    )
    from .analysis.sweeps import (
        BasinOptions,
        BasinResult,
        DiagramOptions,
        LyapunovOptions,
        LyapunovResult,
        RunupOptions,
        RunupResult,
        basins,
        bifurcation_diagram,
        lyapunov_exponents,
        runup,
        stability_map,
    )
    from .errors import (
        CompileError,
        ConvergenceError,
        GearsymError,
        ParameterError,
        SimulationError,
        SpecError,
    )
    from .facade import Scene, System, load_scene
    from .quantities import GearQuantities, gear_quantities
    from .results import Event, Trajectory
    from .simulation_options import SimulateOptions


def __getattr__(name: str) -> object:
    """Import a public name on first access."""
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'gearsym' has no attribute '{name}'") from None
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
