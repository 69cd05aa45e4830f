"""Rattle state and peak-to-peak value of the steady response of a backlash mesh.

A backlash mesh has two contact surfaces (see :class:`gearsym.symbolic.model.SwitchingFunction`):
the *drive* flank (``kind = "drive"``, e.g. ``mesh.drive``) and the *back* flank
(``kind = "back"``, e.g. ``mesh.back``); between them the teeth are separated.  Over
the **steady part** of a response, the time window ``W = [t_start, t_end]``, the
rattle state (the ``rsv`` of Liu et al., Mech. Sci. 2021, Sect. 3.2; the impact
regimes of Kahraman & Singh, JSV 1990) is

* ``0`` (:data:`NO_RATTLE`): the response never leaves drive-side contact in ``W``
  (in drive contact at ``t_start`` and no crossing of the drive surface in ``W``);
* ``1`` (:data:`UNILATERAL`): it loses drive-side contact at some time in ``W``
  (separation at ``t_start`` or a crossing of the drive surface) but is never in
  back-side contact in ``W`` (single-sided impacts);
* ``2`` (:data:`BILATERAL`): it is in back-side contact at some time in ``W``
  (back contact at ``t_start`` or any crossing of the back surface): double-sided
  impacts.

Two ways to call :func:`rattle_state`:

* with a :class:`~gearsym.results.Trajectory` and its compiled ``system``: the
  crossings are the engine's located events (``Trajectory.events``; exact, nothing
  is missed between output samples), and the contact mode at ``t_start`` is
  obtained by evaluating the switching functions there;
* with sampled arrays ``(t, x)`` and the flank positions ``lower``/``upper``
  (scalars, arrays like ``x`` or callables of ``t``): contact is read from the
  samples, so a contact loss shorter than the sampling interval can be missed.

``drive_side`` says which flank drives: ``"positive"`` (drive contact ``x > upper``,
back contact ``x < lower``; Kahraman & Singh) or ``"negative"`` (drive contact
``x < lower``, back contact ``x > upper``; Liu et al.).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...codegen.artifact import generated_map
from ...results import Trajectory

NO_RATTLE = 0
UNILATERAL = 1
BILATERAL = 2
#: Meaning of the rattle-state codes (:data:`NO_RATTLE`, :data:`UNILATERAL`, :data:`BILATERAL`).
RATTLE_STATES: dict[int, str] = {
    0: "no contact loss (permanent drive-side contact)",
    1: "contact loss only (single-sided impacts / free flight)",
    2: "back-side contact (double-sided impacts)",
}

Bound = float | np.ndarray | Callable[[np.ndarray], np.ndarray] | None


@dataclass(frozen=True)
class RattleSummary:
    """What :func:`rattle_summary` found over the steady window.

    Attributes
    ----------
    state
        0 (no rattle), 1 (unilateral) or 2 (bilateral); see the module docstring.
    t_start, t_end
        The steady window.
    start_mode
        Contact mode at ``t_start``: ``"drive"``, ``"separation"`` or ``"back"``.
    n_drive
        Crossings of the drive surface in the window (events), or the number of
        samples out of drive contact (arrays).
    n_back
        Crossings of the back surface in the window (events), or the number of
        samples in back contact (arrays).
    method
        ``"events"`` or ``"samples"``.
    """

    state: int
    t_start: float
    t_end: float
    start_mode: str
    n_drive: int
    n_back: int
    method: str


def steady_window(t: np.ndarray, steady_fraction: float = 0.5, t_start: float | None = None,
                  period: float | None = None) -> tuple[float, float]:
    """The steady part ``[t_start, t_end]`` of a time span.

    Parameters
    ----------
    t
        Output times (increasing).
    steady_fraction
        Fraction of the span, at its end, taken as steady (0 < fraction <= 1).
    t_start
        Explicit start of the window (overrides ``steady_fraction``).
    period
        Forcing period: when given, the window is shortened to a whole number of
        periods ending at ``t_end`` (if at least one period fits), so that a
        peak-to-peak value or a count is not biased by a partial cycle.
    """
    t = np.asarray(t, dtype=float)
    t0, t1 = float(t[0]), float(t[-1])
    if t_start is not None:
        if not (t0 <= t_start < t1):
            raise ValueError(f"t_start={t_start} is outside the time span [{t0}, {t1})")
        return float(t_start), t1
    if not (0.0 < steady_fraction <= 1.0):
        raise ValueError(f"steady_fraction must be in (0, 1], got {steady_fraction}")
    span = steady_fraction * (t1 - t0)
    if period and period > 0 and span >= period * (1 - 1e-9):
        n = math.floor(span / period + 1e-9)
        span = n * period
    return max(t0, t1 - span), t1


def rattle_state(data: Trajectory | tuple[np.ndarray, np.ndarray], lower: Bound = None,
                 upper: Bound = None, *, system: Any = None, element: str | None = None,
                 drive_side: str = "positive", state: int | str = 0, steady_fraction: float = 0.5,
                 t_start: float | None = None) -> int:
    """Rattle state of the steady response: 0 none, 1 unilateral, 2 bilateral.

    Parameters
    ----------
    data
        A :class:`~gearsym.results.Trajectory` (with ``system``), or a pair of
        arrays ``(t, x)`` of a relative displacement (with ``lower``/``upper``).
    lower, upper
        Flank positions for sampled data (scalars, arrays like ``x``, or callables
        of ``t``): separation is ``lower <= x <= upper``.
    system
        The compiled :class:`~gearsym.system.System` the trajectory came from: gives
        the contact surfaces (kinds ``drive``/``back``) and evaluates them at
        ``t_start``.
    element
        Name of the backlash element (``"mesh"``) when the model has several.
    drive_side
        For sampled data: ``"positive"`` (drive contact ``x > upper``) or
        ``"negative"`` (drive contact ``x < lower``).
    state
        For a Trajectory with ``lower``/``upper`` but no ``system``: the state
        (index or name) compared with them.
    steady_fraction, t_start
        The steady window (see :func:`steady_window`; whole forcing periods when the
        trajectory has one).

    Returns
    -------
    int
        :data:`NO_RATTLE`, :data:`UNILATERAL` or :data:`BILATERAL` (definitions in
        the module docstring).
    """
    return rattle_summary(data, lower, upper, system=system, element=element,
                          drive_side=drive_side, state=state, steady_fraction=steady_fraction,
                          t_start=t_start).state


def rattle_summary(data: Trajectory | tuple[np.ndarray, np.ndarray], lower: Bound = None,
                   upper: Bound = None, *, system: Any = None, element: str | None = None,
                   drive_side: str = "positive", state: int | str = 0,
                   steady_fraction: float = 0.5, t_start: float | None = None) -> RattleSummary:
    """Like :func:`rattle_state`, with the details (:class:`RattleSummary`)."""
    if drive_side not in ("positive", "negative"):
        raise ValueError(f"drive_side must be 'positive' or 'negative', got '{drive_side}'")
    if isinstance(data, Trajectory):
        if system is not None:
            return _from_events(data, system, element, steady_fraction, t_start)
        if lower is None or upper is None:
            raise ValueError("a Trajectory needs system= (event-based classification) or "
                             "lower=/upper= (sample-based)")
        x = data[state] if isinstance(state, str) else data.y[:, int(state)]
        return _from_samples(data.t, x, lower, upper, drive_side, steady_fraction, t_start,
                             data.period)
    try:
        t, x = data
    except (TypeError, ValueError):
        raise TypeError("data must be a Trajectory or a pair of arrays (t, x)") from None
    if lower is None or upper is None:
        raise ValueError("sampled data needs lower= and upper= (the flank positions)")
    return _from_samples(np.asarray(t, float), np.asarray(x, float), lower, upper, drive_side,
                         steady_fraction, t_start, None)


def peak_to_peak(data: Trajectory | tuple[np.ndarray, np.ndarray] | np.ndarray, state: int | str = 0,
                 steady_fraction: float = 0.5, t_start: float | None = None) -> float:
    """Peak-to-peak value ``max(x) - min(x)`` of the steady response (the ``ppv`` of Liu et al.).

    Parameters
    ----------
    data
        A :class:`~gearsym.results.Trajectory`, a pair ``(t, x)``, or an array ``x``
        (then ``steady_fraction`` counts samples).
    state
        State of the trajectory (index or name).
    steady_fraction, t_start
        The steady window (see :func:`steady_window`; whole forcing periods when the
        trajectory has one).

    Returns
    -------
    float
    """
    if isinstance(data, Trajectory):
        t, x, period = data.t, (data[state] if isinstance(state, str) else data.y[:, int(state)]), data.period
    elif isinstance(data, tuple):
        t, x = (np.asarray(a, float) for a in data)
        period = None
    else:
        x = np.asarray(data, float)
        t = np.arange(x.size, dtype=float)
        period = None
    ts, te = steady_window(t, steady_fraction, t_start, period)
    on = (t >= ts - 1e-12 * max(1.0, abs(ts))) & (t <= te)
    w = np.asarray(x)[on]
    if w.size == 0:
        raise ValueError("no samples in the steady window")
    return float(np.max(w) - np.min(w))


# ------------------------------------------------------------------- internals


def _bound(b: Bound, t: np.ndarray, on: np.ndarray) -> np.ndarray:
    """Flank positions at the window samples ``t[on]`` (scalar, array like t, or callable)."""
    if callable(b):
        return np.broadcast_to(np.asarray(b(t[on]), float), t[on].shape)
    arr = np.asarray(b, float)
    if arr.ndim == 0:
        return np.broadcast_to(arr, t[on].shape)
    if arr.shape != t.shape:
        raise ValueError(f"a flank given as an array must have the shape of t {t.shape}, got {arr.shape}")
    return arr[on]


def _from_samples(t: np.ndarray, x: np.ndarray, lower: Bound, upper: Bound, drive_side: str,
                  steady_fraction: float, t_start: float | None,
                  period: float | None) -> RattleSummary:
    if t.shape != x.shape or t.ndim != 1:
        raise ValueError(f"t and x must be 1-D arrays of the same length, got {t.shape} and {x.shape}")
    ts, te = steady_window(t, steady_fraction, t_start, period)
    on = t >= ts - 1e-12 * max(1.0, abs(ts))
    xw = x[on]
    lo, up = _bound(lower, t, on), _bound(upper, t, on)
    if np.any(lo > up):
        raise ValueError("lower must not exceed upper")
    if drive_side == "positive":
        drive, back = xw > up, xw < lo
    else:
        drive, back = xw < lo, xw > up
    start = "drive" if drive[0] else ("back" if back[0] else "separation")
    n_out = int(np.count_nonzero(~drive))
    n_back = int(np.count_nonzero(back))
    st = BILATERAL if n_back else (UNILATERAL if n_out else NO_RATTLE)
    return RattleSummary(st, ts, te, start, n_out, n_back, "samples")


def _surfaces_of(system: Any) -> list[dict]:
    gen = getattr(system, "generated", system)
    surfaces = getattr(gen, "surfaces", None)
    if surfaces is None:
        raise TypeError("system must be a compiled System (or GeneratedModel) with contact surfaces")
    return [dict(s) for s in surfaces]


def _from_events(traj: Trajectory, system: Any, element: str | None, steady_fraction: float,
                 t_start: float | None) -> RattleSummary:
    surfaces = _surfaces_of(system)
    contact = [(j, s) for j, s in enumerate(surfaces) if s.get("kind") in ("drive", "back")]
    elements = list(dict.fromkeys(s["name"].rsplit(".", 1)[0] for _, s in contact))
    if not elements:
        raise ValueError("the system has no contact (drive/back) surfaces: no backlash element")
    if element is None:
        if len(elements) > 1:
            raise ValueError(f"several backlash elements ({', '.join(elements)}): choose one with element=")
        element = elements[0]
    elif element not in elements:
        raise ValueError(f"no backlash element '{element}' (have: {', '.join(elements)})")
    mine = {s["kind"]: (j, s) for j, s in contact if s["name"].rsplit(".", 1)[0] == element}

    ts, te = steady_window(traj.t, steady_fraction, t_start, traj.period)
    # contact mode at the first output sample of the window (snap the window to it)
    k = int(np.searchsorted(traj.t, ts - 1e-12 * max(1.0, abs(ts)), side="left"))
    k = min(k, traj.t.size - 1)
    ts = float(traj.t[k])
    g = _switching_values(system, traj, ts, traj.y[k])

    def in_contact(kind: str) -> bool:
        if kind not in mine:
            return False
        j, s = mine[kind]
        return float(s.get("contact_sign", 0)) * g[j] > 0

    start = "drive" if in_contact("drive") else ("back" if in_contact("back") else "separation")
    names = {kind: s["name"] for kind, (_, s) in mine.items()}
    window = [e for e in traj.events if ts <= e.t <= te]
    n_drive = sum(1 for e in window if e.surface == names.get("drive"))
    n_back = sum(1 for e in window if e.surface == names.get("back"))
    st = classify(start == "drive", start == "back", n_drive > 0, n_back > 0)
    return RattleSummary(st, ts, te, start, n_drive, n_back, "events")


def _switching_values(system: Any, traj: Trajectory, t: float, x: Sequence[float]) -> np.ndarray:
    gen = getattr(system, "generated", system)
    p = system.run_vector(traj.params) if hasattr(system, "run_vector") else \
        np.array([traj.params[n] for n in gen.param_names], dtype=float)
    if hasattr(system, "switching"):
        return np.asarray(system.switching(float(t), x, p=p), dtype=float).ravel()
    return np.asarray(generated_map(gen, "gs_sw", 1)(float(t), np.asarray(x, float), p), dtype=float).ravel()


def mesh_rattle_states(system: Any, x0: Sequence[float], t0: float, events: Sequence[Any],
                       params: Mapping[str, float] | None = None,
                       samples: tuple[np.ndarray, np.ndarray] | None = None,
                       g0: np.ndarray | None = None) -> dict[str, int]:
    """Rattle state of every backlash mesh along a periodic orbit.

    Uses the contact surfaces of the compiled model (``kind`` drive/back, as the
    symbolic layer names them, ``MESH.drive`` / ``MESH.back``) and is exact in the
    events: the side of every surface at ``t0`` plus every crossing along the period.

    With ``samples = (t, Y)`` (states ``Y[k]`` at times ``t[k]`` along the orbit, e.g.
    from a harmonic series) the sides are taken at the samples instead of from the
    events (approximate: a contact shorter than the sampling step can be missed).

    ``g0``, when given, is the switching functions at ``(t0, x0)`` (already evaluated).

    Returns
    -------
    dict
        Mesh name -> 0 (no contact loss), 1 (contact loss only) or 2 (back-side
        contact); empty if the model has no contact surfaces.
    """
    table = system.generated.contact_surfaces
    if not table:
        return {}
    p = system.param_vector(params) if g0 is None or samples is not None else None
    g = system.switching(float(t0), x0, p=p) if g0 is None else np.asarray(g0, float)
    G = None
    if samples is not None:
        ts, Y = np.asarray(samples[0], float), np.asarray(samples[1], float)
        G = system.switching(ts, Y, p=p).reshape(len(ts), -1).T
    g = g.tolist()
    hit = {e.surface for e in events}
    meshes: dict[str, dict[str, bool]] = {}
    for j, name, mesh, kind, sign in table:
        st = meshes.setdefault(mesh, {"drive_in": False, "drive_crossed": False, "back_in": False,
                                      "back_crossed": False})
        in_contact = (g[j] > 0) if sign > 0 else (g[j] < 0)
        crossed = name in hit
        if G is not None:
            side = (G[j] > 0) if sign > 0 else (G[j] < 0)
            in_contact = bool(np.all(side)) if kind == "drive" else bool(np.any(side))
            crossed = crossed or bool(np.any(side != side[0]))
        st[f"{kind}_in"] = bool(in_contact)
        st[f"{kind}_crossed"] = bool(crossed)
    return {mesh: classify(**st) for mesh, st in meshes.items()}


def classify(drive_in: bool, back_in: bool, drive_crossed: bool, back_crossed: bool) -> int:
    """The one rattle classifier: the state of a mesh from its contact at the start of a window
    and the crossings of its drive and back surfaces in it (module docstring).

    Parameters
    ----------
    drive_in, back_in
        Drive-side / back-side contact at the start of the window.
    drive_crossed, back_crossed
        Whether the drive / back surface is crossed in the window.

    Returns
    -------
    int
        :data:`BILATERAL` with any back-side contact, else :data:`NO_RATTLE` when the drive-side
        contact holds throughout, else :data:`UNILATERAL`.
    """
    if back_in or back_crossed:
        return BILATERAL
    return NO_RATTLE if drive_in and not drive_crossed else UNILATERAL
