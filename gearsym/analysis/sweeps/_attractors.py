"""Attractors of a forced system found from landing states (basins of attraction).

Used by :mod:`gearsym.analysis.sweeps._basins`.  An attractor is described by its **Poincare points**:
the states at the basin's phase ``t0 + i T`` of the forcing period (the ``k`` points of a
period-``k`` orbit, in order; a cloud of points for a non-periodic attractor).  The rules --
units, period detection, kinds, neighbourhoods, descriptions -- are those every sweep shares
(:mod:`gearsym.analysis.sweeps._attractor_id`); this module applies them to a landing.

:func:`identify` turns a *landing* (a state reached after a long transient) into an
:class:`Attractor`:

1. the landing is integrated ``2 max_period + 8`` more periods; when more than half of its last
   Poincare points lie in the neighbourhood of a known attractor it is that one
   (:meth:`~gearsym.analysis.sweeps._attractor_id.Table.landing`); else its period guess is the
   smallest ``k`` whose Poincare points repeat
   (:func:`~gearsym.analysis.sweeps._attractor_id.settled_period`, to
   :data:`~gearsym.analysis.sweeps._attractor_id.REPEAT_TOL` of each state's range);
2. with a guess, the periodic orbit is shot (:func:`gearsym.analysis.periodic.periodic_orbit`,
   ``periods = k``, from the landing, at the phase ``t0``); it is the attractor when Newton
   converges to a **stable** orbit (asymptotically stable or neutral) that passes through the
   landing (its Poincare points within the neighbourhood radius of the last sample) -- an
   orbit that is unstable or elsewhere is not what the trajectory approaches.  A shorter period
   ``d | k`` of its Poincare points is the period-``d`` orbit
   (:func:`~gearsym.analysis.sweeps._attractor_id.stable_attractor`);
3. otherwise the attractor is **non-periodic**: its Poincare section is ``cloud`` points of a
   further integration, and its largest Lyapunov exponent
   (:func:`gearsym.analysis.sweeps.lyapunov_exponents`) and section decide the kind
   (:func:`~gearsym.analysis.sweeps._attractor_id.classify_exponent`): ``"chaotic"``,
   ``"quasi-periodic"`` or ``"unclassified"``.

The **neighbourhood** of an attractor (:class:`~gearsym.analysis.sweeps._attractor_id.Table`): a state
``x`` is in it when ``max_i |x_i - P_i| / s_i <= r`` for one of its Poincare points ``P``, with
``s_i`` the attractor's scale in state ``i`` (its peak-to-peak, at least 1e-3 of the state's
magnitude) and ``r`` the relative radius (``radius``, 0.05 by default; for a non-periodic
attractor at least twice the median gap between its cloud points).  Neighbourhoods of
different attractors never overlap: a radius is cut to a quarter of the distance (in the
attractor's units) to the nearest Poincare point of another attractor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError
from ..periodic import PeriodicOrbit, periodic_orbit
from ._attractor_id import (
    KIND_CODES,
    KINDS,
    REPEAT_TOL,
    Table,
    cloud_radius,
    describe_response,
    relative_distances,
    settled_period,
    stable_attractor,
)

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem as System

__all__ = ["KINDS", "Attractor", "Context", "Table", "identify", "table_of"]

#: Output samples per forcing period of the landing's integration (its period and scale).
DENSE = 32


@dataclass(frozen=True, eq=False)
class Attractor:
    """One attractor of a basin map.

    Attributes
    ----------
    index : int
        Its label in the basin map.
    kind : str
        One of :data:`KINDS`: ``"periodic"``, ``"quasi-periodic"``, ``"chaotic"``, ``"unclassified"``
        (the names of the codes 0-3 of :data:`~gearsym.analysis.sweeps.ATTRACTOR_KINDS`; criteria in
        :mod:`gearsym.analysis.sweeps._attractor_id`).
    period : int or None
        Forcing periods of a periodic orbit (``None`` for the other kinds).
    points : ndarray, shape (k, nx)
        Poincare points at the basin's phase: the ``k`` states of a period-``k`` orbit in the
        order the orbit visits them, or the cloud of a non-periodic attractor.
    minimum, maximum : ndarray, shape (nx,)
        Range of each state along the attractor: of a periodic orbit from 1024 samples per forcing
        period refined by parabolic interpolation (:meth:`PeriodicOrbit.extrema`), of a non-periodic
        attractor from 32 samples per period along its cloud's integration.
    scale : ndarray, shape (nx,)
        Its size per state (the unit of the neighbourhood test, module docstring;
        :func:`~gearsym.analysis.sweeps._attractor_id.state_scale`).
    radius : float
        Relative radius of its neighbourhood (before the cut against other attractors).
    rattle_state : int or None
        0 no contact loss, 1 contact loss only, 2 back-side contact
        (:data:`gearsym.analysis.periodic.RATTLE_STATES`); ``None`` without contact surfaces.
    max_multiplier : float
        Largest Floquet multiplier modulus (periodic; NaN otherwise).
    stability : str
        The orbit's stability verdict (periodic; ``""`` otherwise).
    lyapunov, lyapunov_error : float
        Largest Lyapunov exponent and its error (for a periodic orbit ``log(max_multiplier) / (period T)``
        and its error from the multiplier's tolerance).
    seed : int
        The grid cell whose trajectory found it.
    x0 : ndarray, shape (nx,)
        A state on it at the basin's phase (the first Poincare point).
    info : dict
        How it was found (shooting iterations and residual, Lyapunov periods, ...).
    """

    index: int
    kind: str
    period: int | None
    points: np.ndarray
    minimum: np.ndarray
    maximum: np.ndarray
    scale: np.ndarray
    radius: float
    rattle_state: int | None
    max_multiplier: float = math.nan
    stability: str = ""
    lyapunov: float = math.nan
    lyapunov_error: float = math.nan
    seed: int = -1
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def x0(self) -> np.ndarray:
        """The first Poincare point."""
        return self.points[0]

    @property
    def code(self) -> int:
        """The kind's code (a key of :data:`~gearsym.analysis.sweeps.ATTRACTOR_KINDS`)."""
        return KIND_CODES[self.kind]

    @property
    def amplitude(self) -> np.ndarray:
        """Peak-to-peak of each state along the attractor."""
        return self.maximum - self.minimum

    @property
    def name(self) -> str:
        """A short description: ``"period 1, rattle 1"``, ``"chaotic, rattle 2"``."""
        what = f"period {self.period}" if self.kind == "periodic" else self.kind
        return what + ("" if self.rattle_state is None else f", rattle {self.rattle_state}")

    def as_dict(self, state_names: Sequence[str] | None = None) -> dict[str, Any]:
        """A JSON-ready summary (Poincare points of a cloud: the first 16)."""
        names = list(state_names) if state_names is not None else [str(i) for i in range(len(self.minimum))]
        return {"index": self.index, "name": self.name, "kind": self.kind, "period": self.period,
                "rattle_state": self.rattle_state, "max_multiplier": _finite(self.max_multiplier),
                "stability": self.stability, "lyapunov": _finite(self.lyapunov),
                "lyapunov_error": _finite(self.lyapunov_error), "seed": self.seed,
                "n_points": int(len(self.points)), "points": self.points[:16].tolist(),
                "minimum": dict(zip(names, self.minimum.tolist(), strict=True)),
                "maximum": dict(zip(names, self.maximum.tolist(), strict=True)),
                "radius": self.radius}

    def __repr__(self) -> str:
        return f"Attractor({self.index}: {self.name}, x0={np.array2string(self.x0, precision=6)})"


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def table_of(attractors: Sequence[Attractor], nx: int, hits: int = 3) -> Table:
    """The neighbourhood table of a basin's attractors (labels: their indices, in order).

    Parameters
    ----------
    attractors
        The attractors, ``attractors[i].index == i``.
    nx
        Number of states.
    hits
        Consecutive Poincare points that settle a trajectory on a periodic attractor.

    Returns
    -------
    Table
    """
    return Table.build([(a.points, a.scale, a.radius, a.kind == "periodic") for a in attractors], nx, hits)


# ------------------------------------------------------------------ identification
@dataclass(frozen=True)
class Context:
    """What :func:`identify` needs besides the landing: the system and the basin's settings."""

    system: System
    params: Mapping[str, float] | None
    p: np.ndarray
    t0: float
    T: float
    rtol: float
    atol: Any
    method: str
    max_period: int
    radius: float
    cloud: int
    lyapunov_periods: float


def _integrate(ctx: Context, x: np.ndarray, periods: int, sigma: np.ndarray | None = None,
               per_period: int = 1) -> tuple[np.ndarray, Any]:
    """States every ``1/per_period`` forcing period over ``periods`` periods from ``x`` at ``t0``
    (the first row is ``x``), and the engine's result."""
    n = periods * per_period
    grid = ctx.t0 + ctx.T * np.arange(n + 1) / per_period
    grid[-1] = ctx.t0 + periods * ctx.T
    av = np.broadcast_to(np.asarray(ctx.atol, float), x.shape)
    res = ctx.system.engine.run(x, ctx.p, ctx.t0, grid[-1], grid, method=ctx.method, rtol=ctx.rtol,
                                atol=float(np.min(av)), atol_vec=np.array(av), sigma0=sigma, max_step=ctx.T / 8)
    return res.y, res


def identify(ctx: Context, x: np.ndarray, sigma: np.ndarray | None, index: int, seed: int,
             known: Sequence[Attractor], hits: int) -> Attractor | None:
    """The attractor a landing state lies on (module docstring), or None when it is one of ``known``.

    Parameters
    ----------
    ctx
        The system and the settings.
    x, sigma
        The landing state at the phase ``ctx.t0`` and its surface sides (or None).
    index
        The label a new attractor gets.
    seed
        The grid cell the landing came from.
    known
        Attractors found before.
    hits
        Consecutive Poincare points in a known periodic attractor's neighbourhood that settle a
        trajectory on it (:class:`~gearsym.analysis.sweeps._attractor_id.Table`).

    Returns
    -------
    Attractor or None

    Raises
    ------
    SimulationError
        The integration of the landing failed (the caller labels the cell failed).
    """
    L = 2 * ctx.max_period + 8
    Y, _ = _integrate(ctx, x, L, sigma, per_period=DENSE)
    if table_of(known, x.shape[0], hits).landing(Y[DENSE::DENSE], hits) >= 0:
        return None
    k = settled_period(Y, DENSE, ctx.max_period, REPEAT_TOL)
    if k:
        att = _periodic(ctx, Y[-1], k, index, seed)
        if att is not None:
            return att
    return _non_periodic(ctx, Y[-1], index, seed, k)


def _shoot(ctx: Context, x: np.ndarray, k: int) -> PeriodicOrbit | None:
    """The periodic orbit of ``k`` forcing periods from ``x`` at ``t0``, or None (no convergence)."""
    try:
        return periodic_orbit(ctx.system, periods=k, x0=x, params=ctx.params, method="shooting", t0=ctx.t0,
                              transient=0)
    except GearsymError:
        return None


def _periodic(ctx: Context, x: np.ndarray, k: int, index: int, seed: int) -> Attractor | None:
    """The stable period-``k`` orbit through the landing's last Poincare point ``x``, or None."""
    desc = stable_attractor(_shoot(ctx, x, k), ctx.T, lambda y, d: _shoot(ctx, y, d))
    if desc is None:
        return None
    # the orbit must be what the trajectory approaches: the landing near one of its points
    if float(np.min(relative_distances(x, desc.points, 1.0 / desc.scale))) > ctx.radius:
        return None
    orbit = desc.orbit
    return Attractor(index=index, kind="periodic", period=desc.period, points=desc.points, minimum=desc.minimum,
                     maximum=desc.maximum, scale=desc.scale, radius=ctx.radius, rattle_state=desc.rattle_state,
                     max_multiplier=desc.max_multiplier, stability=desc.stability, lyapunov=desc.lyapunov,
                     lyapunov_error=desc.lyapunov_error, seed=seed,
                     info={"iterations": int(orbit.iterations), "residual": float(orbit.residual),
                           "multipliers": [[float(m.real), float(m.imag)] for m in orbit.multipliers]})


def _non_periodic(ctx: Context, x: np.ndarray, index: int, seed: int, k_guess: int) -> Attractor:
    """A non-periodic attractor from a landing: its cloud, rattle state, largest Lyapunov exponent and kind."""
    tol = {"rtol": ctx.rtol, "atol": float(np.min(ctx.atol))}
    d = describe_response(ctx.system, ctx.params, x, ctx.T, t0=ctx.t0, points=max(int(ctx.cloud), 8),
                          lyapunov_periods=ctx.lyapunov_periods, tolerances=tol, method=ctx.method)
    kind = next(name for name, code in KIND_CODES.items() if code == d.kind)
    return Attractor(index=index, kind=kind, period=None, points=d.points, minimum=d.minimum, maximum=d.maximum,
                     scale=d.scale, radius=cloud_radius(d.points, d.scale, ctx.radius), rattle_state=d.rattle_state,
                     seed=seed, lyapunov=d.lyapunov, lyapunov_error=d.lyapunov_error,
                     info={**d.info, "period_guess": k_guess or None, "cloud": len(d.points), "note": d.note})
