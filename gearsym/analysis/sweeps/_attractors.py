"""Attractors of a forced system found from landing states, and the neighbourhood test of a basin.

Used by :mod:`gearsym.analysis.sweeps._basins`.  An attractor is described by its **Poincare points**:
the states at the basin's phase ``t0 + i T`` of the forcing period (the ``k`` points of a
period-``k`` orbit, in order; a cloud of points for a non-periodic attractor).

:func:`identify` turns a *landing* (a state reached after a long transient) into an
:class:`Attractor`:

1. the landing is integrated ``2 max_period + 8`` more periods and the smallest ``k`` whose
   Poincare points repeat (to ``1e-3`` of their range) is its period guess;
2. with a guess, the periodic orbit is shot (:func:`gearsym.analysis.periodic.periodic_orbit`,
   ``periods = k``, from the landing, at the phase ``t0``); it is the attractor when Newton
   converges to an **asymptotically stable** orbit that passes through the landing (its
   Poincare points within the neighbourhood radius of the last samples) -- an orbit that is
   unstable, neutral or elsewhere is not what the trajectory approaches.  A period that
   divides ``k`` is found from the orbit's own Poincare points;
3. otherwise the attractor is **non-periodic**: its Poincare section is ``cloud`` points of
   a further integration, and its largest Lyapunov exponent
   (:func:`gearsym.analysis.sweeps.lyapunov_exponents`) decides the kind: ``"chaotic"``
   (positive beyond its error), ``"quasi-periodic"`` (zero within its error) or
   ``"long-period"`` (negative: the trajectory converges, but to no orbit of period at most
   ``max_period`` that the shooting found).

The **neighbourhood** of an attractor (:class:`Table`): a state ``x`` is in it when
``max_i |x_i - P_i| / s_i <= r`` for one of its Poincare points ``P``, with ``s_i`` the
attractor's size in state ``i`` (its peak-to-peak over the continuous trajectory, at least
1e-3 of the state's magnitude) and ``r`` the relative radius (``radius``, 0.05 by default;
for a non-periodic attractor at least twice the typical gap between its cloud points).
Neighbourhoods of different attractors never overlap: a radius is cut to a quarter of the
distance (in the attractor's units) to the nearest Poincare point of another attractor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError
from ..periodic import periodic_orbit

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem as System

__all__ = ["KINDS", "Attractor", "Table", "detect_period", "identify"]

#: Kinds of attractors.
KINDS: dict[str, str] = {
    "periodic": "stable periodic orbit (shooting converged, asymptotically stable)",
    "quasi-periodic": "non-periodic, largest Lyapunov exponent zero within its error",
    "chaotic": "non-periodic, largest Lyapunov exponent positive beyond its error",
    "long-period": "converging (largest Lyapunov exponent negative) but no orbit of period <= max_period found",
}
#: Smallest size of an attractor in a state, relative to the state's magnitude on it.
SIZE_FLOOR = 1e-3
#: Poincare points repeat (period detection) when they agree to this fraction of their range.
REPEAT_TOL = 1e-3
#: Output samples per forcing period of the dense integrations (amplitudes).
DENSE = 32
#: A non-periodic attractor settles a trajectory after this many times ``hits`` points in its region.
CLOUD_HITS = 4


@dataclass(frozen=True, eq=False)
class Attractor:
    """One attractor of a basin map.

    Attributes
    ----------
    index : int
        Its label in the basin map.
    kind : str
        One of :data:`KINDS`.
    period : int or None
        Forcing periods of a periodic orbit (``None`` for the other kinds).
    points : ndarray, shape (k, nx)
        Poincare points at the basin's phase: the ``k`` states of a period-``k`` orbit in the
        order the orbit visits them, or the cloud of a non-periodic attractor.
    minimum, maximum : ndarray, shape (nx,)
        Range of each state along the attractor: of a periodic orbit from 1024 samples per forcing
        period refined by parabolic interpolation (:meth:`PeriodicOrbit.extrema`), of a non-periodic
        attractor from :data:`DENSE` samples per period along its cloud's integration.
    scale : ndarray, shape (nx,)
        Its size per state (the unit of the neighbourhood test, module docstring).
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
        Largest Lyapunov exponent and its error (non-periodic; for a periodic orbit
        ``log(max_multiplier) / (period T)`` and 0).
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


# ------------------------------------------------------------------ neighbourhoods
@dataclass(frozen=True)
class Table:
    """The Poincare points of the known attractors, for the neighbourhood test (module docstring).

    Attributes
    ----------
    points : ndarray, shape (K, nx)
        Every attractor's Poincare points, stacked.
    owner : ndarray of int, shape (K,)
        The attractor of each point.
    inv_scale : ndarray, shape (K, nx)
        ``1 / scale`` of the point's attractor.
    radius : ndarray, shape (K,)
        The neighbourhood radius of the point's attractor (after the cut against the others).
    hits : ndarray of int, shape (A,)
        Consecutive Poincare points in each attractor's neighbourhood that settle a trajectory on
        it: ``hits`` for a periodic orbit, :data:`CLOUD_HITS` times that for a non-periodic one
        (a transient may cross the region of a cloud for a few periods).
    """

    points: np.ndarray
    owner: np.ndarray
    inv_scale: np.ndarray
    radius: np.ndarray
    hits: np.ndarray

    @classmethod
    def of(cls, attractors: Sequence[Attractor], nx: int, hits: int = 3) -> Table:
        """The table of ``attractors`` (radii cut so that no two neighbourhoods overlap; ``hits``
        consecutive points settle a trajectory on a periodic orbit)."""
        need = np.array([hits if a.kind == "periodic" else CLOUD_HITS * hits for a in attractors], dtype=int)
        if not attractors:
            z = np.zeros((0, nx))
            return cls(z, np.zeros(0, int), z.copy(), np.zeros(0), need)
        radii = effective_radii(attractors)
        pts = np.vstack([a.points for a in attractors])
        owner = np.concatenate([np.full(len(a.points), a.index) for a in attractors])
        inv = np.vstack([np.broadcast_to(1.0 / a.scale, a.points.shape) for a in attractors])
        rad = np.concatenate([np.full(len(a.points), r) for a, r in zip(attractors, radii, strict=True)])
        return cls(pts, owner, inv, rad, need)

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays (what a worker process gets)."""
        return {"points": self.points, "owner": self.owner, "inv_scale": self.inv_scale, "radius": self.radius,
                "hits": self.hits}

    def match(self, X: np.ndarray, values: int = 4_000_000) -> np.ndarray:
        """The attractor whose neighbourhood holds each state, or -1.

        Parameters
        ----------
        X
            States, shape (m, nx).
        values
            Differences computed at once (memory: 8 bytes each): states are compared in blocks
            of ``values / (K nx)``.

        Returns
        -------
        ndarray of int, shape (m,)
            The attractor's index (the nearest in units of its radius when several), or -1.
        """
        m = X.shape[0]
        out = np.full(m, -1, dtype=int)
        if m == 0 or self.points.shape[0] == 0:
            return out
        block = max(1, values // max(self.points.size, 1))
        for s in range(0, m, block):
            D = np.max(np.abs(X[s:s + block, None, :] - self.points[None, :, :]) * self.inv_scale[None, :, :],
                       axis=2) / self.radius[None, :]
            j = np.argmin(D, axis=1)
            inside = D[np.arange(D.shape[0]), j] <= 1.0
            out[s:s + block][inside] = self.owner[j[inside]]
        return out


def effective_radii(attractors: Sequence[Attractor]) -> list[float]:
    """Each attractor's radius, cut to a quarter of its distance to the nearest point of another."""
    radii = []
    for a in attractors:
        r = a.radius
        for b in attractors:
            if b is a:
                continue
            d = np.max(np.abs(a.points[:, None, :] - b.points[None, :, :]) / a.scale, axis=2)
            r = min(r, 0.25 * float(np.min(d)))
        radii.append(r)
    return radii


def table_from_arrays(arrays: Mapping[str, np.ndarray]) -> Table:
    """The inverse of :meth:`Table.as_arrays`."""
    return Table(np.asarray(arrays["points"], float), np.asarray(arrays["owner"], int),
                 np.asarray(arrays["inv_scale"], float), np.asarray(arrays["radius"], float),
                 np.asarray(arrays["hits"], int))


# ------------------------------------------------------------------ identification
def detect_period(Q: np.ndarray, max_period: int, scale: np.ndarray, tol: float = REPEAT_TOL) -> int | None:
    """The smallest ``k <= max_period`` with ``Q[j] == Q[j - k]`` (to ``tol`` times ``scale``, the size
    of the motion in each state) over the second half of the Poincare points ``Q`` (shape (L, nx)),
    or None."""
    L = Q.shape[0]
    h = L // 2
    for k in range(1, min(max_period, h) + 1):
        if np.max(np.abs(Q[h:] - Q[h - k:L - k]) / scale) <= tol:
            return k
    return None


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


def size_of(samples: np.ndarray) -> np.ndarray:
    """The size of an attractor per state from samples along it (module docstring)."""
    mag = np.max(np.abs(samples), axis=0)
    top = float(np.max(mag)) if mag.size else 1.0
    floor = SIZE_FLOOR * np.maximum(mag, 1e-12 * max(top, np.finfo(float).tiny))
    return np.maximum(np.ptp(samples, axis=0), np.maximum(floor, np.finfo(float).tiny))


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
        Consecutive Poincare points in a known attractor's neighbourhood that make the landing
        one of ``known``.

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
    Q = Y[DENSE::DENSE]
    table = Table.of(known, x.shape[0], hits)
    lab = table.match(Q[-hits:])
    if lab.size and lab[0] >= 0 and np.all(lab == lab[0]):
        return None
    k = detect_period(Q, ctx.max_period, size_of(Y[(L // 2) * DENSE:]))
    if k is not None:
        att = _periodic(ctx, Q, k, index, seed)
        if att is not None:
            return att
    return _non_periodic(ctx, Q[-1], index, seed, k)


def _shoot(ctx: Context, x: np.ndarray, k: int) -> Any:
    """The periodic orbit of ``k`` forcing periods from ``x`` at ``t0``, or None (no convergence)."""
    try:
        return periodic_orbit(ctx.system, periods=k, x0=x, params=ctx.params, method="shooting", t0=ctx.t0,
                              transient=0)
    except GearsymError:
        return None


def _periodic(ctx: Context, Q: np.ndarray, k: int, index: int, seed: int) -> Attractor | None:
    """The stable period-``k`` orbit through the landing's Poincare points ``Q``, or None."""
    orbit = _shoot(ctx, Q[-1], k)
    if orbit is None or orbit.stability != "asymptotically_stable":
        return None
    Y, _ = _integrate(ctx, np.asarray(orbit.x0, float), k, per_period=DENSE)
    points = Y[:-1:DENSE][:k]
    scale = size_of(Y)
    for j in range(1, k):  # a shorter period (k a multiple of it): shoot that one
        if k % j == 0 and np.max(np.abs(points[j] - points[0]) / scale) <= REPEAT_TOL:
            return _periodic(ctx, Q, j, index, seed)
    # the orbit must be what the trajectory approaches: the landing near one of its points
    d = np.min(np.max(np.abs(Q[-1][None, :] - points) / scale, axis=1))
    if d > ctx.radius:
        return None
    mm = float(np.max(np.abs(orbit.multipliers))) if len(orbit.multipliers) else 0.0
    lyap = math.log(mm) / (k * ctx.T) if mm > 0 else -math.inf
    ext = np.array([orbit.extrema(i) for i in range(points.shape[1])])  # refined from 1024 samples per period
    return Attractor(index=index, kind="periodic", period=int(k), points=points, minimum=ext[:, 0],
                     maximum=ext[:, 1], scale=scale, radius=ctx.radius, rattle_state=orbit.rattle_state,
                     max_multiplier=mm, stability=orbit.stability, lyapunov=lyap, lyapunov_error=0.0, seed=seed,
                     info={"iterations": int(orbit.iterations), "residual": float(orbit.residual),
                           "multipliers": [[float(m.real), float(m.imag)] for m in orbit.multipliers]})


def _non_periodic(ctx: Context, x: np.ndarray, index: int, seed: int, k_guess: int | None) -> Attractor:
    """A non-periodic attractor from a landing: its cloud, rattle state and largest Lyapunov exponent."""
    from ..periodic import rattle_state
    from ._lyapunov import LyapunovOptions, lyapunov_exponents

    system = ctx.system
    n = max(int(ctx.cloud), 8)
    traj = system.simulate(x0=x, t0=ctx.t0, t_end=ctx.t0 + n * ctx.T, n_out=n * DENSE + 1, params=ctx.params,
                           rtol=ctx.rtol, atol=float(np.min(ctx.atol)), method=ctx.method)
    Y = traj.y
    cloud = Y[:-1:DENSE][:n]
    scale = size_of(Y)
    rattle = rattle_state(traj, system=system, steady_fraction=1.0) if system.generated.contact_surfaces else None
    # the gap between neighbouring cloud points: the neighbourhood must bridge it
    from scipy.spatial import cKDTree

    gaps, _ = cKDTree(cloud / scale).query(cloud / scale, k=2, p=np.inf)  # each point's nearest other point
    radius = max(ctx.radius, 2.0 * float(np.median(gaps[:, 1])))
    # the state at a multiple of the forcing period (the exponents' runs start at t = 0)
    phase_left = (math.ceil(ctx.t0 / ctx.T) * ctx.T - ctx.t0) if ctx.t0 % ctx.T else 0.0
    x_start = Y[-1]
    if phase_left > 0:
        x_start = system.flow(Y[-1], ctx.t0 + n * ctx.T, ctx.t0 + n * ctx.T + phase_left, ctx.p,
                              rtol=ctx.rtol, atol=ctx.atol, monodromy=False, method=ctx.method).x_final
    lyo = LyapunovOptions(periods=ctx.lyapunov_periods, transient=0, exponents=1, rtol=ctx.rtol,
                          method=ctx.method)
    res = lyapunov_exponents(system, ctx.params, lyo, x0=x_start)
    lam, err = float(res.exponents[0]), float(res.errors[0])
    tol = max(err, 1e-4 / ctx.T)
    kind = "chaotic" if lam > tol else ("long-period" if lam < -tol else "quasi-periodic")
    return Attractor(index=index, kind=kind, period=None, points=cloud, minimum=np.min(Y, axis=0),
                     maximum=np.max(Y, axis=0), scale=scale, radius=radius, rattle_state=rattle, seed=seed,
                     lyapunov=lam, lyapunov_error=err,
                     info={"lyapunov_periods": ctx.lyapunov_periods, "lyapunov_converged": bool(res.converged),
                           "period_guess": k_guess, "cloud": n})
