"""One point of a stability / response map: the response there, never an unstable orbit.

:func:`map_point` computes the periodic orbit at one grid point of
:func:`gearsym.analysis.sweeps.stability_map`.  Newton (shooting, harmonic balance) converges
to unstable orbits as readily as to stable ones, and an unstable orbit is not what the
system does there: a map showed rattle state 1 for an orbit with ``|mu| = 1.47`` where the
attractor was a stable orbit without contact loss.  So where the orbit found is unstable:

1. it is recorded apart (``unstable_max_multiplier``, ``unstable_rattle_state``);
2. the stable response is searched for: one integration of :data:`SEARCH_PERIODS` forcing
   periods from the solve's start (the previous point's response: the attractor a sweep
   follows), then from the unstable orbit perturbed along its unstable direction (both ways
   for a real multiplier above +1, the larger component positive first), each followed by the
   orbit solve from where the integration ended if the integration settled (its samples once
   per orbit period approach a fixed point);
3. if no stable orbit of the map's number of periods is found, the point has **no stable
   periodic response** (``response = 0``): its response quantities (rattle state,
   peak-to-peak) are left empty, the map's figure hatches it.

A linear system (no switching surfaces, a Jacobian that does not depend on the state) has one
periodic orbit: unstable, there is no periodic response, and nothing is searched.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError
from ...quantities import orbit_quantities, periodic_quantities
from ..periodic import (
    NotPiecewiseConstantError,
    PeriodicOrbit,
    PiecewiseLTV,
    floquet,
    periodic_orbit,
    rigid_state_basis,
)
from ._attractor_id import sample_scale

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["EXACT_RTOL", "RESPONSE", "SEARCH", "SEARCH_PERIODS", "is_linear", "map_point"]

#: Smallest relative error assigned to an exact (matrix-exponential) monodromy in the stability
#: rule; the estimate is :meth:`~gearsym.analysis.periodic.PiecewiseLTV.rounding_error`.
EXACT_RTOL = 1e-14
#: Forcing periods integrated from each start of the search for a stable response (the solve
#: that follows relaxes further where the samples are still approaching an orbit).
SEARCH_PERIODS = 20
#: The search solves for an orbit from where the integration ended only if its samples once per
#: orbit period changed by at most this fraction of the state's range over the last period (or
#: were still shrinking): else no orbit of that period attracts from there.
SETTLED = 1e-2
#: The ``response`` codes of a map point.
RESPONSE = {1: "a stable periodic orbit: the response (the values shown are its)",
            0: "no stable periodic response found (an unstable orbit only, in the unstable_* variables)",
            -1: "no orbit (the solve failed)"}
#: How the response was found (``response_search``).
SEARCH = {0: "the orbit solve itself",
          1: "integration from the solve's start (the previous point's response, or x0), then the solve",
          2: "integration from the unstable orbit perturbed along its unstable direction, then the solve",
          3: "the longer landing of the coexistence search (or of the lyapunov quantity) from the solve's start, "
             "then the solve (gearsym.analysis.sweeps._coexist)",
          -1: "not found"}


def empty_point(method: str) -> dict[str, Any]:
    """The record of a point before anything is known (a failed point)."""
    return {"max_multiplier": math.nan, "peak_to_peak": math.nan, "rattle_state": -1, "stability": "unknown",
            "converged": False, "iterations": 0, "method": method, "x0": None, "error": "", "response": -1,
            "response_search": -1, "unstable_max_multiplier": math.nan, "unstable_rattle_state": -1}


def map_point(system: CompiledSystem, params: dict[str, float], method: str, periods: float, guess: np.ndarray | None,
              want_ptp: bool, options: Mapping[str, Any], gear: str | None = None, keep_orbit: bool = False
              ) -> dict[str, Any]:
    """The response at one grid point (module docstring).

    Parameters
    ----------
    system
        The compiled system.
    params
        The point's parameter values (declared units).
    method
        ``"auto"``, ``"exact"``, ``"shooting"`` or ``"hbm"``.
    periods
        Forcing periods of the orbit.
    guess
        The previous point's response state (``None``: the scene's initial state after a transient).
    want_ptp
        Compute the peak-to-peak of the first state.
    options
        Options of the orbit solver.
    gear
        A gear quantity of the response to compute (:func:`gearsym.quantities.orbit_quantities`: the
        worst mesh), stored under its name (NaN without a stable response).
    keep_orbit
        Also return the stable response's :class:`~gearsym.analysis.periodic.PeriodicOrbit` as
        ``orbit`` (the coexistence search describes it; it is not picklable cheaply: take it out).

    Returns
    -------
    dict
        ``max_multiplier``, ``stability`` (of the response, else of the unstable orbit found),
        ``rattle_state``, ``peak_to_peak``, ``x0`` (of the response only), ``response``
        (:data:`RESPONSE`), ``response_search`` (:data:`SEARCH`), ``unstable_max_multiplier``,
        ``unstable_rattle_state``, ``converged`` (an orbit was found), ``iterations``, ``method``,
        ``error``.
    """
    out = empty_point(method)
    if method in ("auto", "exact"):
        try:
            return _gear_of_exact(system, params, periods, _exact_point(system, params, periods, want_ptp, out),
                                  gear)
        except NotPiecewiseConstantError as exc:
            if method == "exact":
                out["error"] = str(exc)
                return out
        method = out["method"] = "shooting"
    orbit, err = _solve(system, params, method, periods, guess, options)
    if orbit is None:
        out["error"] = err
        return out
    out.update(converged=True, iterations=orbit.iterations)
    if orbit.stability == "unstable":
        out.update(unstable_max_multiplier=orbit.max_multiplier,
                   unstable_rattle_state=-1 if orbit.rattle_state is None else int(orbit.rattle_state))
        found, how, notes = _stable_response(system, params, method, periods, guess, orbit, options)
        if found is None:
            out.update(max_multiplier=orbit.max_multiplier, stability=orbit.stability, response=0,
                       error="; ".join(notes))
            return out
        orbit = found
        out["response_search"] = how
    else:
        out["response_search"] = 0
    out.update(max_multiplier=orbit.max_multiplier, stability=orbit.stability, response=1, x0=orbit.x0.tolist(),
               rattle_state=-1 if orbit.rattle_state is None else int(orbit.rattle_state))
    if keep_orbit:
        out["orbit"] = orbit  # (the caller takes it out before the record leaves the process)
    if want_ptp:
        try:
            out["peak_to_peak"] = orbit.peak_to_peak(0) if method == "hbm" else float(
                np.ptp(orbit.trajectory(n_out=513).y[:, 0]))
        except GearsymError as exc:
            out["error"] = f"the peak-to-peak integration failed: {exc}"
    if gear:
        try:
            out[gear] = orbit_quantities(system, orbit, [gear])[gear]
        except GearsymError as exc:
            out["error"] = f"the gear quantity {gear} failed: {exc}"
    return out


def _gear_of_exact(system: CompiledSystem, params: dict[str, float], periods: float, out: dict[str, Any],
                   gear: str | None) -> dict[str, Any]:
    """The gear quantity of an exact (matrix-exponential) point's response, from its periodic state."""
    if gear and out["response"] == 1:
        ltv = PiecewiseLTV.from_system(system, params, periods=periods)
        try:
            out[gear] = periodic_quantities(system, ltv.periodic_state(), float(ltv.times[-1] - ltv.times[0]),
                                            t0=float(ltv.times[0]), params=params).value(gear)
        except GearsymError as exc:
            out["error"] = f"the gear quantity {gear} failed: {exc}"
    return out


def _exact_point(system: CompiledSystem, params: dict[str, float], periods: float, want_ptp: bool,
                 out: dict[str, Any]) -> dict[str, Any]:
    """The exact (matrix-exponential) path: one orbit, unique; unstable means no periodic response."""
    ltv = PiecewiseLTV.from_system(system, params, periods=periods)
    fq = floquet(ltv.monodromy(), max(ltv.rounding_error(), EXACT_RTOL), rigid_state_basis(system, params))
    unstable = fq.stability == "unstable"
    out.update(max_multiplier=fq.max_multiplier, converged=True, method="exact", stability=fq.stability,
               response=0 if unstable else 1, response_search=-1 if unstable else 0)
    if unstable:
        out["unstable_max_multiplier"] = fq.max_multiplier
    elif want_ptp:
        if ltv.B is None:
            out["peak_to_peak"] = 0.0
        else:
            x0 = ltv.periodic_state()
            t = np.linspace(ltv.times[0], ltv.times[-1], 257)
            _, y = ltv.propagate(x0, t)
            out["peak_to_peak"] = float(np.ptp(y[:, 0]))
    return out


def _solve(system: CompiledSystem, params: dict[str, float], method: str, periods: float, guess: np.ndarray | None,
           options: Mapping[str, Any]) -> tuple[PeriodicOrbit | None, str]:
    """The orbit from ``guess`` (then, if that fails, from the scene's initial state after a
    transient): ``(orbit, "")`` or ``(None, error)``."""
    opts = dict(options)
    if method == "shooting":
        opts.setdefault("transient", 0 if guess is not None else None)
    err = ""
    for attempt in range(2):
        try:
            return periodic_orbit(system, periods=periods, x0=guess, method=method, params=params, **opts), ""
        except GearsymError as exc:
            err = str(exc)
            if attempt == 0 and guess is not None:
                guess = None  # retry from the scene's initial state (with a transient)
                opts.pop("transient", None)
                continue
            break
    return None, err


def _stable_response(system: CompiledSystem, params: dict[str, float], method: str, periods: float,
                     guess: np.ndarray | None, unstable: PeriodicOrbit, options: Mapping[str, Any]
                     ) -> tuple[PeriodicOrbit | None, int, list[str]]:
    """Search the stable response where the orbit found is unstable: ``(orbit, how, notes)``
    (``how`` a key of :data:`SEARCH`; ``notes`` why each start gave none)."""
    if is_linear(system, params, unstable.x0, unstable.t0, unstable.period):
        return None, -1, ["a linear system has one periodic orbit, and it is unstable"]
    starts: list[tuple[int, np.ndarray]] = []
    kicks = _unstable_kicks(unstable)
    if guess is not None and (not kicks or np.max(np.abs(np.asarray(guess, float) - unstable.x0)) >
                              0.1 * np.max(np.abs(kicks[0] - unstable.x0))):
        # (a start on the unstable orbit itself would leave it by round-off, in no definite direction)
        starts.append((1, np.asarray(guess, float)))
    starts += [(2, k) for k in kicks]
    notes: list[str] = []
    for how, x in starts:
        x_end, why = _settled(system, params, unstable, x)
        if x_end is None:
            notes.append(f"{SEARCH[how]}: {why}")
            continue
        orbit, err = _solve(system, params, method, periods, x_end, {**options, "transient": 0} if
                            method == "shooting" else options)
        if orbit is None:
            notes.append(f"{SEARCH[how]}: {err}")
        elif orbit.stability == "unstable":
            notes.append(f"{SEARCH[how]}: unstable again (max |mu| = {orbit.max_multiplier:.4g})")
        else:
            return orbit, how, notes
    return None, -1, ["no stable periodic response: " + "; ".join(notes)]


def _settled(system: CompiledSystem, params: dict[str, float], unstable: PeriodicOrbit, x: np.ndarray
             ) -> tuple[np.ndarray | None, str]:
    """Integrate :data:`SEARCH_PERIODS` forcing periods from ``x`` (sampled once per orbit period):
    ``(end state, "")`` when the samples settle (they approach a fixed point of the orbit-period
    map: the last step below :data:`SETTLED` of the orbit's size, or shrinking at least 2x over
    the last five), else ``(None, why)``: no orbit of this period attracts from there (a cycle
    of twice the period past a period doubling, a torus, chaos), and no solve is tried."""
    k = max(1, int(round(unstable.periods)))
    P = float(unstable.period)
    n = max(4, SEARCH_PERIODS // k)
    rtol = max(float(unstable.info.get("rtol", 1e-10)), 1e-9)
    atol = float(unstable.info.get("atol", 1e-12))
    try:
        tr = system.simulate(t_end=unstable.t0, t0=unstable.t0 - n * P, x0=x, rtol=rtol, atol=atol,
                             t_out=unstable.t0 - n * P + P * np.arange(n + 1), params=params)
    except GearsymError as exc:
        return None, f"the integration failed ({exc})"
    Y = np.asarray(tr.y, float)
    step = np.max(np.abs(np.diff(Y, axis=0)) / sample_scale(Y), axis=1)
    if not np.all(np.isfinite(step)):
        return None, "the integration diverged"
    if step[-1] <= SETTLED or step[-1] <= 0.5 * step[-6]:
        return Y[-1], ""
    return None, (f"the integration did not settle on an orbit of {k} forcing period(s) in {n * k} periods "
                  f"(last change {step[-1]:.3g} of the state's range)")


def _unstable_kicks(orbit: PeriodicOrbit, size: float = 1e-3) -> list[np.ndarray]:
    """The orbit's state moved by ``size`` of each state's magnitude along the eigenvector of its
    largest multiplier, both ways for a real multiplier above +1 (the two sides of the unstable
    orbit), one way otherwise."""
    M = orbit.monodromy
    x0 = np.asarray(orbit.x0, float)
    if M is None or not np.all(np.isfinite(M)):
        return []
    w, V = np.linalg.eig(np.asarray(M, float)[: len(x0), : len(x0)])
    target = orbit.multipliers[0] if len(orbit.multipliers) else w[np.argmax(np.abs(w))]
    v = V[:, int(np.argmin(np.abs(w - target)))]
    v = v.real if np.linalg.norm(v.real) >= np.linalg.norm(v.imag) else v.imag
    v = v if v[int(np.argmax(np.abs(v)))] > 0 else -v  # a definite sign (LAPACK's is arbitrary)
    scale = np.asarray(orbit.info.get("state_scales") or np.maximum(np.abs(x0), 1e-300), float)[: len(x0)]
    top = float(np.max(np.abs(v) / scale))
    if not (math.isfinite(top) and top > 0):
        return []
    d = size * v / top
    mu = complex(target)
    if abs(mu.imag) > 1e-9 * abs(mu) or mu.real < 0:
        # a multiplier below -1 (or a complex pair) turns the perturbation over every period: both
        # signs lead to the same place, one start is enough
        return [x0 + d]
    return [x0 + d, x0 - d]


def is_linear(system: CompiledSystem, params: Mapping[str, float], x: np.ndarray | None = None, t0: float = 0.0,
              span: float | None = None) -> bool:
    """A linear model: no switching surfaces and a Jacobian that does not depend on the state (at 8 times
    over ``span`` from ``t0``, the state ``x`` against twice it plus one).  It has one periodic orbit.

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter values (declared units).
    x
        The state compared (default: the system's initial state).
    t0, span
        The times (default: over one forcing period, or 1 without one).

    Returns
    -------
    bool
    """
    gen = system.generated
    if gen.nsw or gen.implicit:
        return False
    p = system.param_vector(params)
    h = span if span is not None else (system.period(params) or 1.0)
    t = t0 + h * np.arange(8) / 8
    X = np.tile(np.asarray(system.x0 if x is None else x, float), (8, 1))
    J1 = system.engine.evaluate("jac", t, X, p)
    J2 = system.engine.evaluate("jac", t, 2 * X + 1.0, p)
    return bool(np.all(np.abs(J1 - J2) <= 1e-12 * np.maximum(1.0, np.abs(J1))))
