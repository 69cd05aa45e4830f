"""What an attractor is and how one is recognised: the rules that basins, maps and brute-force diagrams share.

Basins (:mod:`gearsym.analysis.sweeps._basins`), the coexistence search of maps
(:mod:`gearsym.analysis.sweeps._map_attractors`) and brute-force bifurcation diagrams
(:mod:`gearsym.analysis.sweeps._bifurcation_diagram`) all look at the **Poincare points** of a
response: its states once per forcing period ``T`` (at the phase ``t0``).  The rules below are
written once, here:

**Units.**  Every distance between states is measured per state, in units of the state's
**scale** along the attractor (:func:`state_scale`): its range (peak-to-peak), at least
:data:`SIZE_FLOOR` (1e-3) of its magnitude (so a state that hardly moves along the attractor is
not compared at the level of the integration's round-off); a state identically zero gets
:data:`SIZE_FLOOR` of the largest magnitude.  The distance of two states is the largest of these
relative differences (:func:`relative_distances`), with the rigid-body directions of a free gear
train projected out where they are given.

**Period** (:func:`cycle_period`, :func:`settled_period`).  A sequence of Poincare points
``P_0 .. P_N`` has settled on a cycle of ``k`` forcing periods when
``max |P_n - P_(n-k)| / scale <= tol`` over the second half of the points (``n >= N / 2``; the scale
along the samples of that half), for the smallest such ``k <= max_k``; else it has no period
(``0``).  The tolerance is relative to each state's range: :data:`REPEAT_TOL` (1e-3) in basins
and the map's landings (``SearchOptions.settle_tol``), ``DiagramOptions.settle_tol`` (1e-4) in a
brute-force diagram, whose periods no orbit solve verifies.

**The kinds** (:data:`ATTRACTOR_KINDS`, codes; :data:`KINDS`, the names of the same kinds):

* ``0`` **periodic**: a stable periodic orbit, verified by the orbit solver: its stability
  verdict asymptotically stable or neutral (:data:`STABLE`; an unstable orbit is never an
  attractor).  Its period is the smallest ``d`` whose Poincare points repeat
  (:func:`repeat_period`, to :data:`SAME_ORBIT`): an orbit solved over ``k`` periods that
  repeats after ``d | k`` is the period-``d`` orbit when that one is stable too.
* Otherwise the response is **non-periodic**, classified by its largest Lyapunov exponent
  ``lambda`` with its error ``e`` (the 95 % half-width of
  :attr:`~gearsym.analysis.sweeps.LyapunovResult.errors`), its zero band
  ``z = max(e, zero_rate / T)`` (:data:`ZERO_RATE`, 0.01 per forcing period: a smaller exponent
  is not told from zero over the few hundred periods of a run), and its Poincare section
  (:func:`classify_exponent`):

  * ``2`` **chaotic**: ``lambda > z``, positive beyond its error;
  * ``1`` **quasi-periodic**: ``|lambda| <= z``, zero within its error, with an error within
    the zero band (``e <= zero_rate / T``: an exponent known only to a wider error is not known to
    be zero), **and** the Poincare points lie on one closed curve (:func:`closed_curve`);
  * ``3`` **unclassified** ("not classified"): neither -- a negative exponent (the response
    converges, to an orbit of more periods than were looked for or after a transient longer
    than the run), a zero exponent with a section that is not one curve or with an error
    above the zero band, or no exponent.

**Same attractor.**  Two periodic orbits of the same period are one when a state of one is
within :data:`SAME_ORBIT` (1e-4) of one of the ``k`` Poincare points of the other (any phase of a
period-``k`` orbit).  The **neighbourhood** of an attractor is the set of states within
``radius`` of one of its Poincare points (:class:`Table`; ``radius`` relative, 0.05 by default,
for a non-periodic attractor at least twice the median gap between its points:
:func:`cloud_radius`); neighbourhoods of different attractors never overlap (each radius is cut
to a quarter of the distance to the nearest point of another attractor).  A trajectory has
settled on an attractor after ``hits`` consecutive Poincare points in its neighbourhood
(:data:`CLOUD_HITS` times that for a non-periodic one, whose region a transient may cross); a
**landing** (the end of a transient) is on a known attractor when more than half of its last
``CLOUD_HITS * hits`` Poincare points lie in that attractor's neighbourhood
(:meth:`Table.landing`).

**Descriptions.**  A stable orbit is described by :func:`describe_orbit` (period, Poincare
points, refined extrema of every state and mesh deflection, rattle states, multipliers,
exponent ``log max|mu| / (k T)`` with its error from the multiplier's tolerance), a non-periodic
response by :func:`describe_response` (its section, extrema, rattle state, exponent and kind).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..periodic import PeriodicOrbit, rattle_state
from ._lyapunov import lyapunov_exponents
from ._scales import SIZE_FLOOR, project, relative_distances, sample_scale, state_scale

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ATTRACTOR_KINDS", "CHAOTIC", "CLOUD_HITS", "KIND_CODES", "KINDS", "PERIODIC", "QUASI_PERIODIC",
           "REPEAT_TOL", "SAME_ORBIT", "SIZE_FLOOR", "STABLE", "UNCLASSIFIED", "ZERO_RATE", "OrbitDescription",
           "ResponseDescription", "Table", "classify_exponent", "closed_curve", "cloud_radius", "cycle_period",
           "describe_orbit", "describe_response", "project", "relative_distances", "repeat_period",
           "sample_scale", "settled_period", "stable_attractor", "state_scale"]

PERIODIC, QUASI_PERIODIC, CHAOTIC, UNCLASSIFIED = 0, 1, 2, 3
#: The kinds of attractor by code (the ``attractor_kind`` / ``response_kind`` / ``kind`` variables).
ATTRACTOR_KINDS: dict[int, str] = {
    PERIODIC: "stable periodic orbit (asymptotically stable or neutral, verified)",
    QUASI_PERIODIC: "quasi-periodic (largest Lyapunov exponent zero within its error, Poincare points on one "
                    "curve)",
    CHAOTIC: "chaotic (largest Lyapunov exponent positive beyond its error)",
    UNCLASSIFIED: "non-periodic, not classified (no stable orbit of at most the longest period looked for; "
                  "neither chaotic nor quasi-periodic)",
}
#: The short name of each kind (a basin attractor's ``kind``), in code order.
_NAMES = ("periodic", "quasi-periodic", "chaotic", "unclassified")
#: The kinds by name (the same kinds as :data:`ATTRACTOR_KINDS`, in code order).
KINDS: dict[str, str] = {name: ATTRACTOR_KINDS[code] for code, name in enumerate(_NAMES)}
#: Code of each kind's name.
KIND_CODES: dict[str, int] = {name: code for code, name in enumerate(_NAMES)}
#: Stability verdicts of an orbit that is an attractor.
STABLE = ("asymptotically_stable", "neutral")
#: Poincare points repeat (period detection) when they agree to this fraction of each state's range.
REPEAT_TOL = 1e-3
#: Two periodic orbits (or two phases of one) are the same to this fraction of each state's range.
SAME_ORBIT = 1e-4
#: An exponent below this per forcing period is not told from zero.
ZERO_RATE = 0.01
#: A non-periodic attractor settles a trajectory after this many times ``hits`` points in its region.
CLOUD_HITS = 4
#: Output samples per forcing period of the integration of a non-periodic response.
DENSE = 32


# ------------------------------------------------------------------ period
def cycle_period(P: np.ndarray, scale: np.ndarray, max_k: int, tol: float, V: np.ndarray | None = None) -> int:
    """The period of a sequence of Poincare points (module docstring).

    Parameters
    ----------
    P
        Poincare points ``P_0 .. P_N``, shape (N + 1, nx).
    scale
        Each state's unit.
    max_k
        Longest period tried.
    tol
        The largest difference accepted, in those units.
    V
        Rigid-body directions projected out of the differences (or ``None``).

    Returns
    -------
    int
        The smallest ``k <= max_k`` with ``max |P_n - P_(n-k)| / scale <= tol`` for every ``n >= N / 2``
        (``k`` at most that half), and every such ``P_n`` within ``tol`` of the point of its phase in the
        cycle before that half (no drift); 0 if none.
    """
    P = np.asarray(P, float)
    m = len(P) // 2
    for k in range(1, min(max_k, m) + 1):
        d = project(P[m:] - P[m - k:len(P) - k], V) / scale
        if np.all(np.isfinite(d)) and float(np.max(np.abs(d))) <= tol:
            # and no drift: every point within tol of the one of its phase in the cycle before the half
            # (a transient converging slowly, e.g. near a period doubling, repeats from one cycle to the
            # next to within tol while its points still move by more over the half)
            drift = project(P[m:] - P[m - k + (np.arange(len(P) - m) % k)], V) / scale
            if float(np.max(np.abs(drift))) <= tol:
                return k
    return 0


def settled_period(Y: np.ndarray, per: int, max_k: int, tol: float, V: np.ndarray | None = None) -> int:
    """The period of dense samples of a response (:func:`cycle_period` of its Poincare points).

    Parameters
    ----------
    Y
        ``per`` samples per forcing period, ``Y[0]`` at the phase of the section, shape (per N + 1, nx).
    per
        Samples per forcing period.
    max_k, tol, V
        As :func:`cycle_period`.

    Returns
    -------
    int
        The period in forcing periods, 0 if none; the scale is that of the samples over the second
        half of the Poincare points (the ones compared).
    """
    Y = np.asarray(Y, float)
    P = Y[::per]
    return cycle_period(P, sample_scale(Y[(len(P) // 2) * per:]), max_k, tol, V)


def repeat_period(points: np.ndarray, scale: np.ndarray, tol: float = SAME_ORBIT, V: np.ndarray | None = None
                  ) -> int:
    """The smallest ``d`` dividing ``k`` after which the ``k`` Poincare points of an orbit repeat.

    Parameters
    ----------
    points
        The orbit's Poincare points, shape (k, nx), in order.
    scale
        Each state's unit.
    tol
        The largest difference accepted, in those units.
    V
        Rigid-body directions projected out of the differences (or ``None``).

    Returns
    -------
    int
        ``d`` (``k`` when they do not repeat sooner).
    """
    k = len(points)
    for d in range(1, k):
        if k % d == 0:
            diff = project(points[d:] - points[:-d], V) / scale
            if float(np.max(np.abs(diff))) <= tol:
                return d
    return k


# ------------------------------------------------------------------ non-periodic: the kind
def closed_curve(points: np.ndarray) -> bool:
    """Whether Poincare points lie on one curve (the section of a quasi-periodic response, an invariant
    closed curve) rather than a cloud or the layers of a chaotic attractor.

    The points are centred and each state divided by its standard deviation (constant states are
    dropped); every point is joined to its two nearest neighbours.  Points along one curve, sampled
    densely enough, make this graph connected; a cloud, or the separate layers of a chaotic
    attractor's section, fall apart into many pieces (uniform random points in a square: about one
    piece per fifteen points; the Henon attractor's 300 points: 37 pieces; an irrational rotation
    on a circle: one).

    Parameters
    ----------
    points
        Shape (n, nx), n at least 16 distinct points.

    Returns
    -------
    bool
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    X = np.asarray(points, float)
    X = X[np.all(np.isfinite(X), axis=1)]
    if len(X) < 16:
        return False
    sd = np.std(X, axis=0)
    keep = sd > 1e-12 * max(float(np.max(sd)), 1e-300)
    if not keep.any():
        return False
    X = (X[:, keep] - X[:, keep].mean(axis=0)) / sd[keep]
    X = np.unique(np.round(X, 9), axis=0)
    n = len(X)
    if n < 16:
        return False  # a finite set of points: an orbit of many periods, not a curve
    _, idx = cKDTree(X).query(X, k=3)
    A = coo_matrix((np.ones(2 * n), (np.repeat(np.arange(n), 2), idx[:, 1:].ravel())), shape=(n, n))
    n_comp, _ = connected_components(A, directed=False)
    return bool(n_comp == 1)


def classify_exponent(lam: float, err: float, T: float, section: np.ndarray, zero_rate: float = ZERO_RATE
                      ) -> tuple[int, str]:
    """The kind of a non-periodic response (module docstring).

    Parameters
    ----------
    lam, err
        Its largest Lyapunov exponent (per unit of the system's time) and the exponent's error
        (95 % half-width); NaN when not computed.
    T
        The forcing period.
    section
        Its Poincare points, shape (n, nx).
    zero_rate
        The exponent's zero band per forcing period, at least.

    Returns
    -------
    tuple
        ``(code, reason)``: a key of :data:`ATTRACTOR_KINDS` other than :data:`PERIODIC`, and a
        sentence saying why.
    """
    if not (math.isfinite(lam) and math.isfinite(err) and math.isfinite(T) and T > 0):
        return UNCLASSIFIED, "no Lyapunov exponent (or no error of it)"
    band = max(err, zero_rate / T)
    rate = f"largest exponent {lam:.4g} +- {err:.2g} ({lam * T:.3g} per forcing period)"
    if lam > band:
        return CHAOTIC, rate + ": positive beyond its error"
    curve = closed_curve(section)
    where = f"Poincare section: {'one curve' if curve else 'not one curve'} ({len(section)} points)"
    if abs(lam) <= band and err > zero_rate / T:
        # an error wider than the zero band: "zero within its error" says nothing (a transient still
        # converging, measured over too few periods, has an exponent of any sign within its error)
        return UNCLASSIFIED, (f"{rate}: not known to be zero, its error is above {zero_rate:g} per forcing period "
                              f"(more Lyapunov periods would tell); {where}")
    if abs(lam) <= band:
        return (QUASI_PERIODIC if curve else UNCLASSIFIED), f"{rate}: zero within its error; {where}"
    return UNCLASSIFIED, (f"{rate}: negative (converging, to an orbit of more periods than looked for or after a "
                          f"longer transient); {where}")


# ------------------------------------------------------------------ descriptions
@dataclass(frozen=True, eq=False)
class OrbitDescription:
    """A stable periodic orbit as an attractor (module docstring).

    Attributes
    ----------
    orbit : PeriodicOrbit
        The verified orbit.
    period : int
        Its period in forcing periods (after :func:`repeat_period`).
    points : ndarray, shape (period, nx)
        Its Poincare points at ``orbit.t0 + j T``, in order.
    minimum, maximum : ndarray, shape (nx,)
        Each state's extrema along it (:meth:`PeriodicOrbit.extrema`: refined by parabolic
        interpolation from 1024 samples per forcing period, or from the harmonic series).
    scale : ndarray
        :func:`state_scale` of the extrema.
    rattle_state : int or None
        The worst mesh's rattle state (``None`` without contact surfaces).
    mesh_rattle, mesh_peak_to_peak : dict
        Per mesh: the rattle state and the peak-to-peak of the dynamic deflection
        (:meth:`PeriodicOrbit.meshes`).
    max_multiplier : float
        ``max |mu|``.
    lyapunov, lyapunov_error : float
        ``log max|mu| / (period T)`` and its error from the multiplier's tolerance.
    """

    orbit: PeriodicOrbit
    period: int
    points: np.ndarray
    minimum: np.ndarray
    maximum: np.ndarray
    scale: np.ndarray
    rattle_state: int | None
    mesh_rattle: dict[str, int]
    mesh_peak_to_peak: dict[str, float]
    max_multiplier: float
    lyapunov: float
    lyapunov_error: float

    @property
    def stability(self) -> str:
        """The orbit's stability verdict (one of :data:`STABLE`)."""
        return str(self.orbit.stability)

    @property
    def amplitude(self) -> np.ndarray:
        """Peak-to-peak of each state."""
        return self.maximum - self.minimum


def _orbit_points(orbit: PeriodicOrbit, k: int, T: float, tr: Any) -> np.ndarray:
    """The states at ``t0 + j T``, ``j < k``, from the orbit's dense trajectory (or a run that hits them)."""
    x0 = np.asarray(orbit.x0, float)
    if k == 1:
        return x0[None, :]
    t = np.asarray(tr.t, float)
    want = orbit.t0 + T * np.arange(k)
    idx = np.clip(np.searchsorted(t, want - 1e-9 * T), 0, len(t) - 1)
    if np.all(np.abs(t[idx] - want) <= 1e-9 * T):
        pts = np.asarray(tr.y, float)[idx]
    else:  # (a trajectory not sampled at whole forcing periods)
        run = orbit.system.simulate(t_end=orbit.t0 + (k - 1) * T, t0=orbit.t0, x0=x0, t_out=want,
                                    rtol=orbit.info.get("rtol", 1e-10), atol=orbit.info.get("atol", 1e-12),
                                    params=orbit.params)
        pts = np.asarray(run.y, float)
    pts[0] = x0
    return pts


def describe_orbit(orbit: PeriodicOrbit, T: float) -> OrbitDescription:
    """The description of a verified orbit over its own period (no check of stability or of a shorter
    period: :func:`stable_attractor` does both).

    Parameters
    ----------
    orbit
        The orbit (attached to its system).
    T
        The forcing period.

    Returns
    -------
    OrbitDescription

    Raises
    ------
    GearsymError
        The orbit's trajectory failed.
    """
    k = max(1, int(round(orbit.periods)))
    tr = orbit.trajectory()  # (cached: extrema and meshes use the same samples)
    points = _orbit_points(orbit, k, T, tr)
    nx = points.shape[1]
    ext = np.array([orbit.extrema(i) for i in range(nx)], float).reshape(nx, 2)
    lo, hi = ext[:, 0], ext[:, 1]
    meshes = orbit.meshes()
    mu = float(orbit.max_multiplier)
    tol = np.asarray(orbit.multiplier_tolerances, float)
    period = float(orbit.period)
    lam = math.log(mu) / period if mu > 0 else -math.inf
    lam_err = float(tol[0]) / (mu * period) if tol.size and mu > 0 else math.nan
    return OrbitDescription(
        orbit=orbit, period=k, points=points, minimum=lo, maximum=hi, scale=state_scale(lo, hi),
        rattle_state=None if orbit.rattle_state is None else int(orbit.rattle_state),
        mesh_rattle={str(m): int(v) for m, v in orbit.rattle_states.items() if v is not None},
        mesh_peak_to_peak={str(m): float(v["deflection_peak_to_peak"]) for m, v in meshes.items()},
        max_multiplier=mu, lyapunov=lam, lyapunov_error=lam_err)


def stable_attractor(orbit: PeriodicOrbit | None, T: float, solve: Callable[[np.ndarray, int], PeriodicOrbit | None],
                     V: np.ndarray | None = None) -> OrbitDescription | None:
    """A verified orbit as an attractor: ``None`` unless stable; the period-``d`` orbit when its Poincare
    points repeat after ``d | k`` and that orbit is stable too (module docstring).

    Parameters
    ----------
    orbit
        The orbit found (``None``: none).
    T
        The forcing period.
    solve
        ``solve(x, d)``: the orbit of ``d`` forcing periods by Newton from ``x`` (``None`` when it fails).
    V
        Rigid-body directions (or ``None``).

    Returns
    -------
    OrbitDescription or None
    """
    if orbit is None or orbit.stability not in STABLE:
        return None
    desc = describe_orbit(orbit, T)
    d = repeat_period(desc.points, desc.scale, SAME_ORBIT, V)
    if d < desc.period:
        shorter = solve(np.asarray(orbit.x0, float), d)
        if shorter is not None and shorter.stability in STABLE:
            return stable_attractor(shorter, T, solve, V)
    return desc


@dataclass(frozen=True, eq=False)
class ResponseDescription:
    """A non-periodic response (module docstring).

    Attributes
    ----------
    kind : int
        :data:`CHAOTIC`, :data:`QUASI_PERIODIC` or :data:`UNCLASSIFIED`.
    points : ndarray, shape (n, nx)
        Its Poincare points (the states after each of ``n`` forcing periods).
    minimum, maximum : ndarray, shape (nx,)
        Each state's extrema along the integration (:data:`DENSE` samples per forcing period).
    scale : ndarray
        :func:`state_scale` of them.
    rattle_state : int or None
        The rattle state along the integration (``None`` without contact surfaces).
    lyapunov, lyapunov_error : float
        The largest Lyapunov exponent and its error.
    note : str
        Why the kind (:func:`classify_exponent`).
    info : dict
        ``lyapunov_periods``, ``lyapunov_converged``, ``points``.
    """

    kind: int
    points: np.ndarray
    minimum: np.ndarray
    maximum: np.ndarray
    scale: np.ndarray
    rattle_state: int | None
    lyapunov: float
    lyapunov_error: float
    note: str
    info: dict[str, Any] = field(default_factory=dict)


def describe_response(system: CompiledSystem, params: Mapping[str, float] | None, x: np.ndarray, T: float, *,
                      t0: float = 0.0, points: int = 200, lyapunov_periods: float = 400.0,
                      tolerances: Mapping[str, Any] | None = None, method: str | None = None,
                      zero_rate: float = ZERO_RATE) -> ResponseDescription:
    """Integrate a non-periodic response ``points`` forcing periods from ``x`` (at ``t0``), run its largest
    Lyapunov exponent from where that ends, and classify it (:func:`classify_exponent`).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter values (declared units).
    x
        A state on the response at ``t0``.
    T
        The forcing period.
    t0
        The phase of the section.
    points
        Poincare points kept.
    lyapunov_periods
        Forcing periods of the exponent.
    tolerances
        ``rtol`` / ``atol`` of the integrations (absent: the scene's).
    method
        Integration method (``None``: the scene's).
    zero_rate
        :func:`classify_exponent`'s.

    Returns
    -------
    ResponseDescription

    Raises
    ------
    GearsymError
        An integration failed.
    """
    tol = dict(tolerances or {})
    extra = {} if method is None else {"method": method}
    n = int(points)
    tr = system.simulate(x0=x, t0=t0, t_end=t0 + n * T, n_out=n * DENSE + 1, params=params, **tol, **extra)
    Y = np.asarray(tr.y, float)
    section = Y[DENSE::DENSE]
    rattle = (rattle_state(tr, system=system, steady_fraction=1.0)
              if system.generated.contact_surfaces else None)
    x_start = Y[-1]
    left = (math.ceil(t0 / T) * T - t0) if t0 % T else 0.0  # the exponent's run starts at a whole period
    if left > 0:
        x_start = np.asarray(system.simulate(x0=x_start, t0=t0 + n * T, t_end=t0 + n * T + left, n_out=2,
                                             params=params, **tol, **extra).x_final, float)
    lyap_opts = {k: v for k, v in (("rtol", tol.get("rtol")), ("method", method)) if v is not None}
    res = lyapunov_exponents(system, params, x0=x_start, periods=lyapunov_periods, transient=0, exponents=1,
                             progress=False, **lyap_opts)
    lam, err = float(res.exponents[0]), float(res.errors[0])
    kind, note = classify_exponent(lam, err, T, section, zero_rate)
    lo, hi = Y.min(axis=0), Y.max(axis=0)
    return ResponseDescription(kind=kind, points=section, minimum=lo, maximum=hi, scale=state_scale(lo, hi),
                               rattle_state=None if rattle is None else int(rattle), lyapunov=lam,
                               lyapunov_error=err, note=note,
                               info={"lyapunov_periods": lyapunov_periods, "lyapunov_converged": bool(res.converged),
                                     "points": n})


def cloud_radius(points: np.ndarray, scale: np.ndarray, radius: float) -> float:
    """The neighbourhood radius of a non-periodic attractor: ``radius``, at least twice the median gap
    between its Poincare points (in units of ``scale``), so that the neighbourhood bridges them.

    Parameters
    ----------
    points
        Its Poincare points, shape (n, nx).
    scale
        Each state's unit.
    radius
        The relative radius of a periodic attractor's neighbourhood.

    Returns
    -------
    float
    """
    from scipy.spatial import cKDTree

    X = np.asarray(points, float) / scale
    if len(X) < 2:
        return float(radius)
    gaps, _ = cKDTree(X).query(X, k=2, p=np.inf)  # each point's nearest other point
    return max(float(radius), 2.0 * float(np.median(gaps[:, 1])))


# ------------------------------------------------------------------ neighbourhoods
@dataclass(frozen=True)
class Table:
    """The Poincare points of known attractors, for the neighbourhood test (module docstring).

    Attributes
    ----------
    points : ndarray, shape (K, nx)
        Every attractor's Poincare points, stacked.
    owner : ndarray of int, shape (K,)
        The attractor (its label) of each point.
    inv_scale : ndarray, shape (K, nx)
        ``1 / scale`` of the point's attractor.
    radius : ndarray, shape (K,)
        The neighbourhood radius of the point's attractor (after the cut against the others).
    hits : ndarray of int, shape (A,)
        Consecutive Poincare points in each attractor's neighbourhood that settle a trajectory on
        it (by label): ``hits`` for a periodic orbit, :data:`CLOUD_HITS` times that for a
        non-periodic one.
    """

    points: np.ndarray
    owner: np.ndarray
    inv_scale: np.ndarray
    radius: np.ndarray
    hits: np.ndarray

    @classmethod
    def build(cls, entries: Sequence[tuple[np.ndarray, np.ndarray, float, bool]], nx: int, hits: int = 3) -> Table:
        """The table of attractors labelled ``0, 1, ...`` in the order given.

        Parameters
        ----------
        entries
            Per attractor: ``(points, scale, radius, periodic)``.
        nx
            Number of states.
        hits
            Consecutive points that settle a trajectory on a periodic attractor.

        Returns
        -------
        Table
            Radii cut so that no two neighbourhoods overlap.
        """
        need = np.array([hits if per else CLOUD_HITS * hits for _, _, _, per in entries], dtype=int)
        if not entries:
            z = np.zeros((0, nx))
            return cls(z, np.zeros(0, int), z.copy(), np.zeros(0), need)
        pts = [np.atleast_2d(np.asarray(p, float)) for p, _, _, _ in entries]
        inv = [1.0 / np.asarray(s, float) for _, s, _, _ in entries]
        radii = []
        for a, (pa, ia) in enumerate(zip(pts, inv, strict=True)):
            r = float(entries[a][2])
            for b, pb in enumerate(pts):
                if b != a:
                    r = min(r, 0.25 * float(np.min(relative_distances(pa, pb, ia))))
            radii.append(r)
        return cls(np.vstack(pts), np.concatenate([np.full(len(p), a) for a, p in enumerate(pts)]),
                   np.vstack([np.broadcast_to(i, p.shape) for p, i in zip(pts, inv, strict=True)]),
                   np.concatenate([np.full(len(p), r) for p, r in zip(pts, radii, strict=True)]), need)

    def as_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays (what a worker process gets)."""
        return {"points": self.points, "owner": self.owner, "inv_scale": self.inv_scale, "radius": self.radius,
                "hits": self.hits}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> Table:
        """The inverse of :meth:`as_arrays`."""
        return cls(np.asarray(arrays["points"], float), np.asarray(arrays["owner"], int),
                   np.asarray(arrays["inv_scale"], float), np.asarray(arrays["radius"], float),
                   np.asarray(arrays["hits"], int))

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
            The attractor's label (the nearest in units of its radius when several), or -1.
        """
        m = X.shape[0]
        out = np.full(m, -1, dtype=int)
        if m == 0 or self.points.shape[0] == 0:
            return out
        block = max(1, values // max(self.points.size, 1))
        for s in range(0, m, block):
            D = relative_distances(X[s:s + block], self.points, self.inv_scale) / self.radius[None, :]
            j = np.argmin(D, axis=1)
            inside = D[np.arange(D.shape[0]), j] <= 1.0
            out[s:s + block][inside] = self.owner[j[inside]]
        return out

    def landing(self, P: np.ndarray, hits: int = 3) -> int:
        """The known attractor a landing is on: the one whose neighbourhood holds more than half of its
        last ``CLOUD_HITS * hits`` Poincare points, or -1.

        Parameters
        ----------
        P
            The landing's Poincare points, shape (n, nx), the last ones last.
        hits
            As :meth:`build`.

        Returns
        -------
        int
        """
        last = np.asarray(P, float)[-CLOUD_HITS * hits:]
        lab = self.match(last)
        if lab.size == 0 or not np.any(lab >= 0):
            return -1
        best = np.bincount(lab[lab >= 0])
        a = int(np.argmax(best))
        return a if 2 * int(best[a]) > len(last) else -1
