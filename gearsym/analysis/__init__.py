"""The analysis layer, by kind: each kind is a subpackage with a small public face.

* :mod:`gearsym.analysis.periodic`: periodic-orbit problems and solvers (shooting, harmonic
  balance), Floquet multipliers and the stability rule, rattle states and mesh deflections of
  an orbit;
* ``gearsym.analysis.continuation``: continuation in one parameter (predictor, corrector,
  detection of special points, branch switching, branches);
* :mod:`gearsym.analysis.linear`: linear analysis (modes about the static equilibrium, the
  structure of planetary modes);
* :mod:`gearsym.analysis.sweeps`: sweeps and global dynamics (stability / response maps,
  Lyapunov exponents, basins of attraction, brute-force bifurcation diagrams, the process pool
  they run on).

The kinds import one another in one direction only (``tests/test_import_graph.py`` checks it):
continuation may import the periodic-orbit analysis; sweeps may import the periodic-orbit and
the linear analysis; the periodic-orbit and the linear analysis import neither.  Across kinds,
and from outside the analysis, only a kind's public face is imported, never its private
modules.  What every kind shares (``gearsym.analysis._options``: the resolution of the options
objects and the tolerance check; ``gearsym.analysis._inputs``: a scene or a compiled system as
input) sits beside them and imports none of them.

The main entry points are importable from here, on first use (so that importing one kind does
not import the others); :func:`gearsym.continuation` is the entry of continuation (here it
would hide the subpackage of the same name).
"""

from __future__ import annotations

import importlib

TYPE_CHECKING = False

#: public name -> the kind (subpackage) that defines it
_EXPORTS: dict[str, str] = {
    "periodic_orbit": "periodic", "shoot": "periodic", "harmonic_balance": "periodic", "mesh_deflections": "periodic",
    "PeriodicOrbit": "periodic", "ShootingOptions": "periodic", "HarmonicBalanceOptions": "periodic",
    "ContinuationOptions": "continuation", "Branch": "continuation", "BranchPoint": "continuation",
    "Bifurcation": "continuation", "switch_period_doubling": "continuation",
    "modal_analysis": "linear", "classify_planetary": "linear", "ModalAnalysis": "linear",
    "stability_map": "sweeps", "save_map": "sweeps", "lyapunov_exponents": "sweeps", "basins": "sweeps",
    "runup": "sweeps", "RunupOptions": "sweeps", "RunupResult": "sweeps", "bifurcation_diagram": "sweeps",
}
#: the kinds of analysis (subpackages)
KINDS = ("periodic", "continuation", "linear", "sweeps")

__all__ = [
    "KINDS", "Bifurcation", "Branch", "BranchPoint", "ContinuationOptions", "HarmonicBalanceOptions", "ModalAnalysis",
    "PeriodicOrbit", "RunupOptions", "RunupResult", "ShootingOptions",
    "basins", "bifurcation_diagram", "classify_planetary", "harmonic_balance", "lyapunov_exponents",
    "mesh_deflections", "modal_analysis", "periodic_orbit", "runup", "save_map", "shoot",
    "stability_map", "switch_period_doubling",
]

if TYPE_CHECKING:  # pragma: no cover
    from .continuation import Bifurcation, Branch, BranchPoint, ContinuationOptions, switch_period_doubling
    from .linear import ModalAnalysis, classify_planetary, modal_analysis
    from .periodic import (
        HarmonicBalanceOptions,
        PeriodicOrbit,
        ShootingOptions,
        harmonic_balance,
        mesh_deflections,
        periodic_orbit,
        shoot,
    )
    from .sweeps import (
        RunupOptions,
        RunupResult,
        basins,
        bifurcation_diagram,
        lyapunov_exponents,
        runup,
        save_map,
        stability_map,
    )


def __getattr__(name: str) -> object:
    """Import a kind, or a public name of one, on first access."""
    if name in KINDS:
        return importlib.import_module(f".{name}", __name__)
    try:
        kind = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'gearsym.analysis' has no attribute '{name}'") from None
    value = getattr(importlib.import_module(f".{kind}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS) | set(KINDS))
