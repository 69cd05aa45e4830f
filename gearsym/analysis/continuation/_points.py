"""The points of a branch: :class:`BranchPoint`, :class:`Bifurcation` and the recipe
:class:`ContinuationSetup` (re-exported by :mod:`gearsym.analysis.continuation._branch`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...display import BifurcationDisplay, BranchPointDisplay

__all__ = ["BIFURCATION_TYPES", "Bifurcation", "BranchPoint", "ContinuationSetup"]

#: Types of located special points and what they mean.
BIFURCATION_TYPES: dict[str, str] = {
    "fold": "turning point of the branch: a real multiplier through +1 (saddle-node, jump in a sweep)",
    "period_doubling": "a real multiplier through -1 (flip): a period-2k orbit branches off",
    "neimark_sacker": "a complex pair of multipliers through the unit circle (torus, quasi-periodic motion)",
    "grazing": "the orbit starts or stops touching a switching (contact) surface: the rattle state changes",
    "branch_point": "a real multiplier through +1 without a turning point (symmetry-breaking pitchfork)",
}


@dataclass(frozen=True, eq=False, repr=False)
class BranchPoint(BranchPointDisplay):
    """One periodic orbit on a branch.

    Units: ``value`` in the parameter's declared unit, ``x0`` in SI, ``period`` in the model's
    time unit (seconds); ``max``, ``min``, ``rms`` in the observed state's SI unit.

    Attributes
    ----------
    value : float
        The continuation parameter's value (declared unit, as ``start`` / ``stop``).
    x0 : ndarray
        State at ``t0`` (the start of the forcing period).
    period : float
        Orbit period (``periods`` forcing periods at this parameter value).
    periods : float
        Forcing periods per orbit period.
    multipliers : ndarray (complex)
        Non-trivial Floquet multipliers by decreasing modulus (the multipliers of
        rigid-body modes are in ``trivial_multipliers``).
    stable : bool
        No multiplier outside the unit circle beyond its tolerance (the rule of
        :mod:`gearsym.analysis.periodic._stability`).
    n_unstable : int
        Number of multipliers outside the circle beyond their tolerances.
    max, min, rms : float
        Of the observed state (the first state unless chosen) over one period.
    rattle_state : int or None
        0 no contact loss, 1 contact loss only, 2 back-side contact (backlash models).
    n_events : int
        Surface crossings in one period.
    surface_extrema : dict
        ``{surface: (min g, max g)}`` of each switching function over the orbit
        (grazing: one of them crosses 0).
    tangent : ndarray
        Unit tangent of the branch in scaled variables (unknowns, parameter).
    bifurcation : str or None
        Type of the special point this is (located bifurcation), else ``None``.
    residual : float
        Scaled residual of the corrector.
    iterations : int
        Corrector (Newton) iterations.
    u : ndarray
        The unknowns of the continuation (shooting states or harmonic coefficients).
    stability : str
        ``"asymptotically_stable"``, ``"neutral"`` or ``"unstable"``.
    trivial_multipliers : ndarray (complex)
        Multipliers of the rigid-body modes (reported apart, not judged).
    multiplier_tolerances : ndarray
        The neutral band of each multiplier.
    meshes : dict
        Per mesh: ``rattle_state`` and ``min``, ``max``, ``peak_to_peak`` of its
        dynamic deflection over the orbit.
    monodromy : ndarray or None
        The monodromy of the orbit (what branch switching takes the critical eigenvector from).
    closure : float
        The point's verification: the mismatch after one period integrated once more, relative
        to what the integration's error allows (:mod:`gearsym.analysis.periodic._verification`; a point
        above 1 is not accepted on a branch).  NaN where not verified.
    """

    value: float
    x0: np.ndarray
    period: float
    periods: float
    multipliers: np.ndarray
    stable: bool
    n_unstable: int
    max: float
    min: float
    rms: float
    rattle_state: int | None
    n_events: int
    surface_extrema: dict[str, tuple[float, float]]
    tangent: np.ndarray | None = None
    bifurcation: str | None = None
    residual: float = math.nan
    iterations: int = 0
    u: np.ndarray | None = field(default=None, repr=False)
    monodromy: np.ndarray | None = field(default=None, repr=False)
    stability: str = ""
    trivial_multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, complex), repr=False)
    multiplier_tolerances: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    meshes: dict[str, dict[str, Any]] = field(default_factory=dict)
    closure: float = math.nan

    @property
    def peak_to_peak(self) -> float:
        """``max - min`` of the observed state."""
        return self.max - self.min

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the keys of ``gearsym continue --json``).

        Returns
        -------
        dict
        """
        return {
            "value": float(self.value),
            "stable": bool(self.stable),
            "max": float(self.max),
            "min": float(self.min),
            "rms": float(self.rms),
            "rattle_state": self.rattle_state,
            "x0": [float(v) for v in self.x0],
            "period": float(self.period),
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "n_unstable": int(self.n_unstable),
            "n_events": int(self.n_events),
            "bifurcation": self.bifurcation,
            "stability": self.stability,
            "trivial_multipliers": [[float(m.real), float(m.imag)] for m in self.trivial_multipliers],
            "meshes": {k: {kk: _jsonable(vv) for kk, vv in v.items()} for k, v in self.meshes.items()},
            "closure": float(self.closure),
        }


@dataclass(frozen=True, eq=False, repr=False)
class Bifurcation(BifurcationDisplay):
    """A located special point of a branch.

    Attributes
    ----------
    type : str
        ``"fold"``, ``"period_doubling"``, ``"neimark_sacker"``, ``"grazing"`` or
        ``"branch_point"`` (see :data:`BIFURCATION_TYPES`).
    value : float
        Parameter value at the point.
    point : BranchPoint
        The orbit there.
    index : int
        Index of the point in ``Branch.points``.
    info : dict
        Details: ``surface`` and ``side`` ("min"/"max" of g) for grazing, the crossing
        multiplier, ``n_unstable`` before/after, whether the test function jumped
        (``nonsmooth``), the test-function residual at the located point.
    """

    type: str
    value: float
    point: BranchPoint
    index: int = -1
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def multipliers(self) -> np.ndarray:
        """Floquet multipliers at the point."""
        return self.point.multipliers

    @property
    def x0(self) -> np.ndarray:
        """The state of the orbit at the point at ``t0`` (SI units; the ``x0`` of :meth:`to_dict`)."""
        return self.point.x0

    @property
    def period(self) -> float:
        """The orbit's period at the point (the model's time unit)."""
        return self.point.period

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary.

        Returns
        -------
        dict
        """
        d = {"type": self.type, "value": float(self.value),
             "multipliers": [[float(m.real), float(m.imag)] for m in self.point.multipliers],
             "x0": [float(v) for v in self.point.x0], "period": float(self.point.period),
             "max": float(self.point.max), "min": float(self.point.min),
             "rattle_state": self.point.rattle_state, "index": int(self.index)}
        for k, v in self.info.items():
            d[k] = _jsonable(v)
        return d


def _jsonable(v: Any) -> Any:
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, complex):
        return [v.real, v.imag]
    if isinstance(v, np.ndarray):
        if np.iscomplexobj(v):
            return [[float(z.real), float(z.imag)] for z in v.ravel()]
        return v.tolist()
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v


@dataclass(frozen=True)
class ContinuationSetup:
    """How a branch was computed: the recipe branch switching continues from.

    Plain settings, no solver state: :func:`gearsym.analysis.continuation.switch_period_doubling`
    builds a new periodic-orbit problem from them.

    Attributes
    ----------
    param : str
        The continuation parameter.
    periods : float
        Forcing periods per orbit.
    params : dict
        The other parameter overrides (declared units).
    segments : int
        Shooting segments (``None`` for harmonic balance).
    harmonics : int or None
        Harmonics (harmonic balance).
    t0 : float
        Phase of the orbits' reference state.
    rtol, atol : float
        Integrator tolerances.
    fd_step : float
        Step of the finite-difference parameter derivative.
    integrator : str or None
        Integrator of the engine (``None``: its default).
    state_scale : tuple of float
        The state magnitudes of the scaled variables at the end of the branch.
    state_weight : float
        Weight of the states against the parameter in the arclength.
    state : int
        Index of the observed state.
    n_dense : int
        Samples per forcing period for extrema and grazing tests.
    tol : float
        Corrector tolerance.
    start, stop : float
        The parameter range.
    """

    param: str
    periods: float
    params: dict[str, float]
    segments: int | None
    harmonics: int | None
    t0: float
    rtol: float
    atol: float
    fd_step: float
    integrator: str | None
    state_scale: tuple[float, ...]
    state_weight: float
    state: int
    n_dense: int
    tol: float
    start: float
    stop: float
