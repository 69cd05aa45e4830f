"""The attractors at one parameter point: stable periodic orbits and classified non-periodic responses.

A map point can have several stable responses (the jump phenomenon of a softening mesh: a
response in permanent contact and an impacting one at the same speed and load).
:class:`PointSearch` collects them at one parameter point from two kinds of start:

* **continuation** from a neighbouring grid point's attractor (:meth:`PointSearch.follow`):
  Newton from the neighbour's orbit; where that fails or gives an unstable orbit (the
  neighbour's orbit has gone through a fold or a period doubling), the integration from the
  neighbour's state *lands* where a slow sweep would jump to;
* **a starting state** (:meth:`PointSearch.start`): the integration from it lands.

**Landing** (:func:`land`): the state is integrated in blocks of :attr:`SearchOptions.block`
forcing periods, at most :attr:`SearchOptions.land_periods`, and sampled once per forcing
period (the Poincare section at the forcing phase 0).  It has *settled on a period-k cycle*
when its Poincare points repeat after ``k`` periods to :attr:`SearchOptions.settle_tol` of each
state's range over the second half of the block (rigid-body directions projected out), for the
smallest such ``k <= max_k`` (:func:`~gearsym.analysis.sweeps._attractor_id.settled_period`, the
rule every sweep shares).  The orbit of ``k`` forcing periods is then solved by Newton from
the landing state.

**Periodic attractors.**  Every orbit is verified by the orbit solver (one independent
integration over its period) and kept only if stable: ``asymptotically_stable`` (every
non-trivial Floquet multiplier inside the unit circle beyond its tolerance) or ``neutral``
(one on the circle within the monodromy's error; :mod:`gearsym.analysis.periodic._stability`).
An unstable orbit is never an attractor.  An orbit solved over ``k`` periods whose section
points repeat after ``d | k`` periods is the period-``d`` orbit (solved again over ``d``) when
that one is stable.  Its largest Lyapunov exponent is ``log max|mu| / (k T)`` (exact: the
Floquet multipliers).  The description (section points, extrema, peak-to-peaks, rattle states)
is :func:`~gearsym.analysis.sweeps._attractor_id.describe_orbit`.

**Two orbits are the same** when they have the same period ``k`` and the state of one is within
:data:`SAME_ORBIT` of one of the ``k`` section points of the other (the phase shift of a
period-``k`` orbit), each state measured over its range along the known orbit.

**Non-periodic attractors** (the landing did not settle): classified by the rules every sweep
shares (:func:`~gearsym.analysis.sweeps._attractor_id.classify_exponent`) from the largest
Lyapunov exponent ``lambda`` (:func:`gearsym.analysis.sweeps.lyapunov_exponents`, one exponent
over :attr:`SearchOptions.lyapunov_periods` forcing periods, with its 95 % error ``e``) and the
Poincare section (:attr:`SearchOptions.section_points` points), with the zero band
``z = max(e, zero_rate / T)`` (:attr:`SearchOptions.zero_rate` per forcing period):

* **chaotic**: ``lambda > z`` (positive beyond its error);
* **quasi-periodic**: ``|lambda| <= z`` (zero within its error) and the section points lie on
  one curve (:func:`closed_curve`: the graph joining every section point to its two nearest
  neighbours is connected; a cloud or a chaotic attractor's layered section falls apart into
  many pieces);
* otherwise **not classified** (e.g. a negative exponent: an orbit of more than ``max_k``
  periods, or a transient longer than the landing).

None of them is ever reported as a periodic orbit.  A non-periodic landing is a known
non-periodic attractor when more than half of its last Poincare points lie in that attractor's
neighbourhood (:meth:`~gearsym.analysis.sweeps._attractor_id.Table.landing`; not classified again).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError, ParameterError
from ..periodic import PeriodicOrbit, periodic_orbit, rigid_state_basis
from ._attractor_id import (
    ATTRACTOR_KINDS,
    CHAOTIC,
    PERIODIC,
    QUASI_PERIODIC,
    REPEAT_TOL,
    SAME_ORBIT,
    STABLE,
    UNCLASSIFIED,
    ZERO_RATE,
    Table,
    closed_curve,
    cloud_radius,
    cycle_period,
    describe_response,
    relative_distances,
    settled_period,
    stable_attractor,
    state_scale,
)

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ATTRACTOR_KINDS", "CHAOTIC", "FOUND_BY", "PERIODIC", "QUASI_PERIODIC", "SAME_ORBIT", "SEARCHES",
           "UNCLASSIFIED", "Landing", "MapAttractor", "PointSearch", "SearchOptions", "closed_curve", "cycle_period",
           "land"]

#: The relative neighbourhood radius of a non-periodic attractor at least (a landing on it).
RADIUS = 0.05
#: How an attractor was found (the map's ``attractor_found_by``).
FOUND_BY: dict[int, str] = {
    0: "the row sweep of the map (its response)",
    1: "continuation along the row, forward (from the left neighbour)",
    2: "continuation along the row, backward (from the right neighbour)",
    3: "continuation along the column, up (from the neighbour below)",
    4: "continuation along the column, down (from the neighbour above)",
    5: "start: the scene's initial state (or x0)",
    6: "start: the static equilibrium",
    7: "start: the rest state (every state zero)",
    8: "start: a state spread over the range of the orbits found",
}
#: The searches of a coexistence map: continuation along the rows (both ways), along the columns
#: (both ways), and the starting states.
SEARCHES = ("rows", "columns", "starts")


@dataclass(frozen=True)
class SearchOptions:
    """Settings of the coexistence search (:mod:`gearsym.analysis.sweeps._map_attractors`).

    Attributes
    ----------
    search : tuple of str
        Which searches run (a subset of :data:`SEARCHES`).
    spread : int
        Starting states spread over the range of the orbits found at a point.
    land_periods : int
        Most forcing periods integrated from a start before it is non-periodic.
    block : int
        Forcing periods per integration of a landing.
    max_k : int
        Longest period (forcing periods) of a cycle recognised by a landing.
    settle_tol : float
        A landing has settled when its section points repeat to this fraction of each state's range.
    section_points : int
        Poincare points of a non-periodic attractor (the closed-curve test).
    lyapunov_periods : int
        Forcing periods of the Lyapunov exponent of a non-periodic attractor.
    zero_rate : float
        An exponent is zero when ``|lambda| T`` is below this (per forcing period) or within its error.
    """

    search: tuple[str, ...] = SEARCHES
    spread: int = 3
    land_periods: int = 400
    block: int = 50
    max_k: int = 8
    settle_tol: float = REPEAT_TOL
    section_points: int = 200
    lyapunov_periods: int = 400
    zero_rate: float = ZERO_RATE

    def __post_init__(self) -> None:
        bad = [s for s in self.search if s not in SEARCHES]
        if bad:
            raise ParameterError(f"search: unknown {', '.join(map(repr, bad))}; choose among {', '.join(SEARCHES)}")
        object.__setattr__(self, "search", tuple(s for s in SEARCHES if s in self.search))
        for name, lo, hi in (("spread", 0, 100), ("land_periods", 1, 1_000_000), ("block", 1, 100_000),
                             ("max_k", 1, 64), ("section_points", 16, 1_000_000),
                             ("lyapunov_periods", 32, 1_000_000)):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not lo <= v <= hi:
                raise ParameterError(f"{name} must be an integer in [{lo}, {hi:,}], got {v!r}")
        if self.block < 2 * self.max_k + 1:
            raise ParameterError(f"block={self.block}: a landing needs at least 2 max_k + 1 = {2 * self.max_k + 1} "
                                 "periods per block to see a cycle of max_k periods")
        for name in ("settle_tol", "zero_rate"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0 < v < 1):
                raise ParameterError(f"{name} must be a number in (0, 1), got {v!r}")


@dataclass
class MapAttractor:
    """One attractor at a parameter point.

    Attributes
    ----------
    kind : int
        A key of :data:`ATTRACTOR_KINDS`.
    periods : int
        Period in forcing periods (0: non-periodic).
    x0 : ndarray
        A state on it at a whole number of forcing periods (periodic: the orbit's state at ``t0``).
    section : ndarray
        Its Poincare points, shape (k, nx) (non-periodic: the sampled section).
    lo, hi : ndarray
        Each state's least and largest value along it.
    max_multiplier : float
        ``max |mu|`` (periodic; NaN otherwise).
    stability : int
        0 asymptotically stable, 1 neutral (periodic); -1 otherwise.
    rattle_state : int
        The worst mesh's rattle state (periodic; -1 without meshes or otherwise).
    mesh_rattle : dict
        Rattle state of each mesh.
    peak_to_peak : float
        Peak-to-peak of the first state.
    mesh_peak_to_peak : dict
        Peak-to-peak of each mesh's dynamic deflection.
    lyapunov, lyapunov_error : float
        Largest Lyapunov exponent (per unit of the system's time) and its error.
    found_by : int
        A key of :data:`FOUND_BY`.
    source : int or None
        The flat grid index of the neighbour it was continued from.
    continued : bool
        Found by Newton from the neighbour's orbit (not by a landing).
    branches : set of tuple
        Identities of the branch it is on: its own (grid index, serial number) and those of every
        attractor of a neighbour that Newton continued onto it (or it onto).  An attractor is not
        continued to a point that already has one of its branch (:meth:`PointSearch.connected`).
    note : str
        The closed-curve verdict of a non-periodic attractor, or other remarks.
    """

    kind: int
    periods: int
    x0: np.ndarray
    section: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    max_multiplier: float = math.nan
    stability: int = -1
    rattle_state: int = -1
    mesh_rattle: dict[str, int] = field(default_factory=dict)
    peak_to_peak: float = math.nan
    mesh_peak_to_peak: dict[str, float] = field(default_factory=dict)
    lyapunov: float = math.nan
    lyapunov_error: float = math.nan
    found_by: int = -1
    source: int | None = None
    continued: bool = False
    note: str = ""
    branches: set[tuple[int, int]] = field(default_factory=set)

    def scale(self) -> np.ndarray:
        """Each state's unit for distances: its range along the attractor, at least 1e-3 of its magnitude
        (:func:`~gearsym.analysis.sweeps._attractor_id.state_scale`)."""
        return state_scale(self.lo, self.hi)

    def order_key(self) -> tuple[Any, ...]:
        """The order of the attractors at a point: periodic ones first by rattle state, period and
        peak-to-peak, then the non-periodic ones by kind."""
        ptp = self.peak_to_peak if math.isfinite(self.peak_to_peak) else math.inf
        return (self.kind != PERIODIC, self.kind, self.rattle_state, self.periods, ptp)


@dataclass
class Landing:
    """Where an integration from a state went (:func:`land`).

    Attributes
    ----------
    k : int
        Period of the cycle it settled on (forcing periods), 0: none within the landing.
    x : ndarray
        The state at the end (a whole number of forcing periods from the start).
    section : ndarray
        The Poincare points of the last block.
    periods : int
        Forcing periods integrated.
    note : str
        Why it did not settle.
    """

    k: int
    x: np.ndarray
    section: np.ndarray
    periods: int
    note: str = ""


def land(system: CompiledSystem, params: Mapping[str, float], x: np.ndarray, opts: SearchOptions,
         tolerances: Mapping[str, Any], V: np.ndarray | None = None) -> Landing:
    """Integrate from ``x`` (at forcing phase 0) until the section points settle on a cycle
    (module docstring).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter values (declared units).
    x
        The starting state.
    opts
        :attr:`SearchOptions.block`, :attr:`~SearchOptions.land_periods`, :attr:`~SearchOptions.max_k`,
        :attr:`~SearchOptions.settle_tol`.
    tolerances
        ``rtol``/``atol`` of the integration (``None``: the scene's).
    V
        The rigid-body directions (projected out), or ``None``.

    Returns
    -------
    Landing

    Raises
    ------
    GearsymError
        The integration failed.
    """
    T = system.require_period(params, "a landing on an attractor")
    per = 8  # samples per forcing period (the range of each state)
    x = np.asarray(x, float)
    done = 0
    P = np.zeros((0, len(x)))
    while done < opts.land_periods:
        m = min(opts.block, opts.land_periods - done)
        m = max(m, 2 * opts.max_k + 1)
        tr = system.simulate(t_end=m * T, x0=x, n_out=per * m + 1, params=params, **tolerances)
        Y = np.asarray(tr.y, float)
        if not np.all(np.isfinite(Y)):
            return Landing(0, x, P, done, "the integration did not stay finite")
        P = Y[::per]
        x = Y[-1].copy()
        done += m
        k = settled_period(Y, per, opts.max_k, opts.settle_tol, V)
        if k:
            return Landing(k, x, P, done)
    return Landing(0, x, P, done, f"no cycle of at most {opts.max_k} forcing periods settled in {done} periods")


class PointSearch:
    """The attractors found at one parameter point (module docstring).

    Parameters
    ----------
    system
        The compiled system.
    params
        The point's parameter values (declared units).
    method
        ``"shooting"`` or ``"hbm"``.
    orbit_options
        Options of the orbit solver.
    opts
        The search's settings.
    index
        The point's flat grid index (the ``source`` of what is continued from it).
    known
        Attractors already known here.
    """

    def __init__(self, system: CompiledSystem, params: Mapping[str, float], method: str,
                 orbit_options: Mapping[str, Any], opts: SearchOptions, index: int = 0,
                 known: list[MapAttractor] | None = None) -> None:
        self.system = system
        self.params = dict(params)
        self.method = "shooting" if method in ("auto", "exact") else method
        self.orbit_options = dict(orbit_options)
        self.opts = opts
        self.index = index
        self.attractors: list[MapAttractor] = list(known or [])
        self.new: list[MapAttractor] = []
        self.notes: list[str] = []
        self.stats = {"solves": 0, "periods": 0}
        self.T = float(system.require_period(params, "the coexistence search"))
        V = rigid_state_basis(system, params)
        self.V = None if V is None or not np.shape(V)[1] else np.asarray(V, float)
        rtol = self.orbit_options.get("rtol")
        self.tolerances: dict[str, Any] = {} if rtol is None else {"rtol": max(float(rtol), 1e-12)}

    # ------------------------------------------------------------ orbits
    def solve(self, x: np.ndarray, k: int) -> PeriodicOrbit | None:
        """The verified orbit of ``k`` forcing periods by Newton from ``x`` (no transient), or ``None``."""
        opts = dict(self.orbit_options)
        if self.method == "shooting":
            opts["transient"] = 0
        self.stats["solves"] += 1
        try:
            return periodic_orbit(self.system, periods=k, x0=np.asarray(x, float), method=self.method,
                                  params=self.params, **opts)
        except GearsymError as exc:
            self.notes.append(f"orbit of {k} period(s): {str(exc)[:200]}")
            return None

    def known_orbit(self, x: np.ndarray, k: int, tol: float = SAME_ORBIT) -> MapAttractor | None:
        """The known periodic attractor of period ``k`` through ``x`` (a section point within ``tol``)."""
        for a in self.attractors:
            if a.kind != PERIODIC or a.periods != k:
                continue
            if float(np.min(relative_distances(x, a.section, 1.0 / a.scale(), self.V))) <= tol:
                return a
        return None

    def _nonperiodic_known(self, section: np.ndarray) -> MapAttractor | None:
        """The known non-periodic attractor a landing's Poincare points are on (:meth:`Table.landing`), or ``None``."""
        clouds = [a for a in self.attractors if a.kind != PERIODIC]
        if not clouds:
            return None
        table = Table.build([(a.section, a.scale(), cloud_radius(a.section, a.scale(), RADIUS), False)
                             for a in clouds], section.shape[1])
        i = table.landing(section)
        return clouds[i] if i >= 0 else None

    def connected(self, a: MapAttractor) -> bool:
        """Whether an attractor here is on ``a``'s branch (Newton joined them): continuing ``a`` here
        would find it again."""
        return any(a.branches & b.branches for b in self.attractors)

    def _add(self, a: MapAttractor) -> bool:
        if a.kind == PERIODIC and self.known_orbit(a.x0, a.periods) is not None:
            return False
        a.branches.add((self.index, len(self.attractors)))  # (unique: the list only grows, across phases too)
        self.attractors.append(a)
        self.new.append(a)
        return True

    def take(self, orbit: PeriodicOrbit, found_by: int, source: int | None = None, continued: bool = False
             ) -> MapAttractor | None:
        """Record a verified orbit if it is stable and new; the attractor it is (new or known), or ``None``."""
        if orbit.stability not in STABLE:
            return None
        k = int(round(orbit.periods))
        known = self.known_orbit(orbit.x0, k)
        if known is not None:
            return known
        a = describe_orbit(self, orbit, found_by, source, continued)
        if a is None:
            return None
        known = self.known_orbit(a.x0, a.periods)  # (a period-k solve that was the period-d orbit)
        if known is not None:
            return known
        self._add(a)
        return a

    # ------------------------------------------------------------ searches
    def follow(self, a: MapAttractor, found_by: int, source: int) -> MapAttractor | None:
        """Continue a neighbour's attractor here: Newton from its orbit; where that gives no stable
        orbit, the landing from its state (where a slow sweep jumps).  Returns the attractor reached
        (new or known), or ``None``."""
        if a.kind == PERIODIC:
            orbit = self.solve(a.x0, a.periods)
            if orbit is not None:
                got = self.take(orbit, found_by, source, continued=True)
                if got is not None:
                    got.branches |= a.branches  # one branch: Newton joined them
                    return got
        return self.start(a.x0, found_by, source)

    def start(self, x: np.ndarray, found_by: int, source: int | None = None) -> MapAttractor | None:
        """The attractor the integration from ``x`` lands on (recorded if new), or ``None``."""
        try:
            landing = land(self.system, self.params, x, self.opts, self.tolerances, self.V)
        except GearsymError as exc:
            self.notes.append(f"{FOUND_BY[found_by]}: the integration failed ({str(exc)[:200]})")
            return None
        self.stats["periods"] += landing.periods
        if landing.k:
            known = self.known_orbit(landing.x, landing.k, tol=10 * self.opts.settle_tol)
            if known is not None:
                return known
            orbit = self.solve(landing.x, landing.k)
            got = None if orbit is None else self.take(orbit, found_by, source)
            if got is None:
                self.notes.append(f"{FOUND_BY[found_by]}: settled on a cycle of {landing.k} period(s) but no "
                                  "stable orbit was solved from it")
            return got
        if not np.all(np.isfinite(landing.x)):
            self.notes.append(f"{FOUND_BY[found_by]}: {landing.note}")
            return None
        known = self._nonperiodic_known(landing.section)
        if known is not None:
            return known
        a = classify(self, landing, found_by, source)
        if a is not None:
            self._add(a)
        return a


def describe_orbit(search: PointSearch, orbit: PeriodicOrbit, found_by: int, source: int | None,
                   continued: bool) -> MapAttractor | None:
    """A stable orbit as a :class:`MapAttractor` (:func:`~gearsym.analysis.sweeps._attractor_id.stable_attractor`:
    section points, extrema, peak-to-peaks of the first state and of each mesh's deflection, rattle
    states; the period-``d`` orbit if its section repeats after ``d | k`` and that one is stable)."""
    try:
        d = stable_attractor(orbit, search.T, search.solve, search.V)
    except GearsymError as exc:
        search.notes.append(f"the orbit's trajectory failed: {str(exc)[:200]}")
        return None
    if d is None:
        return None
    return MapAttractor(PERIODIC, d.period, np.asarray(d.orbit.x0, float), d.points, d.minimum, d.maximum,
                        max_multiplier=d.max_multiplier, stability=0 if d.stability == "asymptotically_stable" else 1,
                        rattle_state=-1 if d.rattle_state is None else d.rattle_state, mesh_rattle=dict(d.mesh_rattle),
                        peak_to_peak=float(d.amplitude[0]), mesh_peak_to_peak=dict(d.mesh_peak_to_peak),
                        lyapunov=d.lyapunov, lyapunov_error=d.lyapunov_error, found_by=found_by, source=source,
                        continued=continued)


def classify(search: PointSearch, landing: Landing, found_by: int, source: int | None) -> MapAttractor | None:
    """A non-periodic landing as a quasi-periodic, chaotic or unclassified :class:`MapAttractor` (module
    docstring; :func:`~gearsym.analysis.sweeps._attractor_id.describe_response`): its Poincare section and its
    largest Lyapunov exponent."""
    opts = search.opts
    try:
        d = describe_response(search.system, search.params, landing.x, search.T, points=opts.section_points,
                              lyapunov_periods=opts.lyapunov_periods, tolerances=search.tolerances,
                              zero_rate=opts.zero_rate)
    except GearsymError as exc:
        search.notes.append(f"{FOUND_BY[found_by]}: the non-periodic response could not be classified "
                            f"({str(exc)[:200]})")
        return None
    search.stats["periods"] += opts.section_points + opts.lyapunov_periods
    return MapAttractor(d.kind, 0, d.points[-1].copy(), d.points, d.minimum, d.maximum, lyapunov=d.lyapunov,
                        lyapunov_error=d.lyapunov_error, found_by=found_by, source=source, note=d.note,
                        peak_to_peak=float(d.maximum[0] - d.minimum[0]))
