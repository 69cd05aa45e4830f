"""Independent references for the benchmark backlash oscillator (no gearsym code).

The Kahraman & Singh (1990) dimensionless backlash oscillator::

    x'' + 2*zeta*x' + (1 + eps*cos(Omega*t)) * f(x) = Fm + Fa*Omega**2*cos(Omega*t)
    f(x) = x - b (x > b),  0 (|x| <= b),  x + b (x < -b)

with states ``(x, v)`` and switching surfaces ``"mesh.drive"`` (``g = x - b``) and
``"mesh.back"`` (``g = x + b``).  An event's direction is the sign of ``dg/dt``
(``+1``: ``g`` went from - to +).

Two references are provided, written by hand from the equation above:

* :func:`reference_solution` -- scipy ``solve_ivp`` DOP853 (``rtol=1e-13``,
  ``atol=1e-15``) on the smooth right-hand side of one contact mode at a time, with
  terminal events at ``x = +-b``, restarted in the new mode at every crossing.
* :func:`closed_form_linear` -- for ``eps = 0`` the system is linear with constant
  coefficients between contacts, so each segment has a closed form (complex
  exponentials plus a particular solution); contact times are roots of the closed
  form found by ``brentq`` after bracketing on a fine sampling grid (with a check of
  the extrema of ``g`` between samples, so grazing double crossings are not lost).

Both return ``(y, event_times, event_surfaces, event_directions)``.

This module is a helper, not a test.  Load it under a unique module name
(``importlib``) from tests: ``tests/engine/reference.py`` is imported as
``reference`` by the engine tests.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = ["DEFAULTS", "SURFACES", "closed_form_linear", "forcing_period", "mode_of",
           "reference_rhs", "reference_solution"]

#: Default parameters of models/kahraman_singh.toml.
DEFAULTS: dict[str, float] = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}

#: Names of the switching surfaces: index 0 is g = x - b, index 1 is g = x + b.
SURFACES: tuple[str, str] = ("mesh.drive", "mesh.back")

_MAX_EVENTS = 200_000


def _params(params: Mapping[str, float] | None) -> dict[str, float]:
    p = dict(DEFAULTS)
    for k, v in (params or {}).items():
        if k not in DEFAULTS:
            raise KeyError(f"unknown parameter '{k}' (have: {', '.join(DEFAULTS)})")
        p[k] = float(v)
    return p


def forcing_period(params: Mapping[str, float] | None = None) -> float:
    """Forcing period ``2*pi/Omega``."""
    return 2.0 * math.pi / _params(params)["Omega"]


def mode_of(x: float, v: float, b: float) -> int:
    """Contact mode of a state: +1 drive side (x > b), 0 free flight, -1 back side (x < -b).

    On a surface the velocity decides (the side the flow is heading to).
    """
    if x > b or (x == b and v > 0):
        return 1
    if x < -b or (x == -b and v < 0):
        return -1
    return 0


def reference_rhs(t: float, y: Sequence[float], mode: int,
                  params: Mapping[str, float] | None = None) -> np.ndarray:
    """Right-hand side ``(x', v')`` of contact mode ``mode`` (+1, 0, -1)."""
    p = _params(params)
    return _mode_rhs(p, mode)(t, y)


def _mode_rhs(p: dict[str, float], mode: int):
    zeta, Fm, Fa, eps, b, Om = (p[k] for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega"))
    A = Fa * Om * Om
    two_zeta = 2.0 * zeta
    cos = math.cos
    if mode == 0:
        def rhs(t, y):
            return np.array([y[1], Fm + A * cos(Om * t) - two_zeta * y[1]])
    else:
        shift = b if mode > 0 else -b

        def rhs(t, y):
            c = cos(Om * t)
            return np.array([y[1], Fm + A * c - two_zeta * y[1] - (1.0 + eps * c) * (y[0] - shift)])
    return rhs


def _armed(mode: int) -> list[tuple[int, int]]:
    """Surfaces (index, direction of the crossing) that can end a segment in ``mode``.

    Only the crossing *away* from the current mode is armed, so a restart exactly on
    the surface just crossed cannot re-trigger it.
    """
    if mode > 0:
        return [(0, -1)]          # leave drive contact: x - b goes + -> -
    if mode < 0:
        return [(1, +1)]          # leave back contact: x + b goes - -> +
    return [(0, +1), (1, -1)]     # free flight: hit the drive side or the back side


def _next_mode(surface: int, direction: int) -> int:
    if surface == 0:
        return 1 if direction > 0 else 0
    return 0 if direction > 0 else -1


def _make_event(surface: int, direction: int, b: float):
    shift = b if surface == 0 else -b

    def ev(t, y):
        return y[0] - shift

    ev.terminal = True
    ev.direction = direction
    return ev


def _evaluate_segments(starts: np.ndarray, evaluators: list, t_eval: np.ndarray) -> np.ndarray:
    out = np.empty((t_eval.size, 2))
    idx = np.clip(np.searchsorted(starts, t_eval, side="right") - 1, 0, len(evaluators) - 1)
    for k in np.unique(idx):
        sel = idx == k
        out[sel] = np.asarray(evaluators[k](t_eval[sel])).T.reshape(-1, 2)
    return out


def reference_solution(params: Mapping[str, float] | None, x0: Sequence[float], t_eval: Sequence[float],
                       *, t0: float = 0.0, rtol: float = 1e-13, atol: float = 1e-15,
                       max_step: float | None = None
                       ) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
    """Event-located DOP853 reference solution of the benchmark oscillator.

    Parameters
    ----------
    params
        Parameter values (missing ones take :data:`DEFAULTS`).
    x0
        Initial state ``(x, v)`` at ``t0``.
    t_eval
        Output times in ``[t0, max(t_eval)]``; the integration ends at ``max(t_eval)``.
    t0
        Start time.
    rtol, atol
        DOP853 tolerances.
    max_step
        Largest DOP853 step (default: a sixteenth of the forcing period, so that no
        pair of crossings can hide inside one step).

    Returns
    -------
    y : ndarray, shape (len(t_eval), 2)
        States at ``t_eval`` (from the dense output of the segment holding each time).
    event_times : ndarray
    event_surfaces : list of str
        ``"mesh.drive"`` or ``"mesh.back"``.
    event_directions : ndarray of int
        Sign of ``dg/dt`` at the crossing.
    """
    p = _params(params)
    b = p["b"]
    t_eval = np.asarray(t_eval, dtype=float)
    t_end = float(np.max(t_eval))
    if t_end <= t0 or np.min(t_eval) < t0:
        raise ValueError("t_eval must lie in [t0, t_end] with t_end > t0")
    if max_step is None:
        max_step = forcing_period(p) / 16
    t = float(t0)
    y = np.array(x0, dtype=float)
    mode = mode_of(y[0], y[1], b)
    rhs = {m: _mode_rhs(p, m) for m in (-1, 0, 1)}
    events = {m: [(_make_event(j, d, b), j, d) for j, d in _armed(m)] for m in (-1, 0, 1)}
    starts: list[float] = []
    evaluators: list = []
    ev_t: list[float] = []
    ev_s: list[str] = []
    ev_d: list[int] = []
    while True:
        evs = events[mode]
        sol = solve_ivp(rhs[mode], (t, t_end), y, method="DOP853", rtol=rtol, atol=atol,
                        events=[e[0] for e in evs], dense_output=True, max_step=max_step)
        if sol.status == -1:
            raise RuntimeError(f"reference DOP853 failed at t={sol.t[-1]}: {sol.message}")
        starts.append(t)
        evaluators.append(sol.sol)
        if sol.status != 1:
            break
        hits = [(te[0], k) for k, te in enumerate(sol.t_events) if te.size]
        te, k = min(hits)
        _, j, d = evs[k]
        ye = np.array(sol.y_events[k][0], dtype=float)
        ye[0] = b if j == 0 else -b   # exactly on the surface
        ev_t.append(float(te))
        ev_s.append(SURFACES[j])
        ev_d.append(d)
        if len(ev_t) > _MAX_EVENTS:
            raise RuntimeError(f"more than {_MAX_EVENTS} events before t={te}")
        t, y, mode = float(te), ye, _next_mode(j, d)
        if t >= t_end:
            break
    yv = _evaluate_segments(np.array(starts), evaluators, t_eval)
    return yv, np.array(ev_t), ev_s, np.array(ev_d, dtype=int)


# ---------------------------------------------------------------------------
# closed form for eps = 0
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Segment:
    """x'' + 2 zeta x' + k x = c0 + A cos(Omega t) from (t_s, x_s, v_s)."""

    t_s: float
    k: float
    c0: float
    zeta: float
    Om: float
    X: complex            # particular amplitude of the cos forcing: Re(X e^{i Om t})
    lam1: complex
    lam2: complex
    C1: complex
    C2: complex
    double: bool          # double root: x_h = (C1 + C2 tau) e^{lam1 tau}

    @classmethod
    def start(cls, t_s: float, x_s: float, v_s: float, mode: int, p: dict[str, float]) -> _Segment:
        zeta, Fm, Fa, b, Om = (p[k] for k in ("zeta", "Fm", "Fa", "b", "Omega"))
        k = 0.0 if mode == 0 else 1.0
        c0 = Fm + mode * b  # f = x - b, x + b moved to the right-hand side
        den = complex(k - Om * Om, 2.0 * zeta * Om)
        if den == 0:
            raise ValueError("undamped resonance (zeta = 0, Omega = 1): no periodic particular solution")
        X = Fa * Om * Om / den
        root = cmath.sqrt(zeta * zeta - k)
        lam1, lam2 = -zeta + root, -zeta - root
        double = abs(lam1 - lam2) < 1e-7
        seg = cls(t_s, k, c0, zeta, Om, X, lam1, lam2, 0j, 0j, double)
        xp, vp = seg._particular(np.array([t_s]))
        dx, dv = x_s - xp[0], v_s - vp[0]
        if double:
            C1, C2 = complex(dx), dv - lam1 * dx
        else:
            C2 = (dv - lam1 * dx) / (lam2 - lam1)
            C1 = dx - C2
        return cls(t_s, k, c0, zeta, Om, X, lam1, lam2, C1, C2, double)

    def _particular(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        tau = t - self.t_s
        e = self.X * np.exp(1j * self.Om * t)
        xp, vp = e.real.copy(), (1j * self.Om * e).real
        if self.k != 0.0:
            xp += self.c0 / self.k
        elif self.zeta != 0.0:       # simple root 0 of the characteristic polynomial
            xp += self.c0 / (2.0 * self.zeta) * tau
            vp += self.c0 / (2.0 * self.zeta)
        else:                        # double root 0
            xp += 0.5 * self.c0 * tau * tau
            vp += self.c0 * tau
        return xp, vp

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """States ``(x, v)``, shape (2, n)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        tau = t - self.t_s
        xp, vp = self._particular(t)
        e1 = np.exp(self.lam1 * tau)
        if self.double:
            xh = (self.C1 + self.C2 * tau) * e1
            vh = self.C2 * e1 + self.lam1 * xh
        else:
            e2 = np.exp(self.lam2 * tau)
            xh = self.C1 * e1 + self.C2 * e2
            vh = self.lam1 * self.C1 * e1 + self.lam2 * self.C2 * e2
        return np.vstack([xp + xh.real, vp + vh.real])


def _first_crossing(seg: _Segment, armed: list[tuple[int, int]], b: float, t_end: float,
                    dt: float) -> tuple[float, int, int] | None:
    """Earliest armed crossing of a segment after its start, or None before t_end."""
    chunk = 512
    a = seg.t_s
    while a < t_end:
        grid = a + dt * np.arange(chunk + 1)
        grid = grid[grid < t_end]
        grid = np.append(grid, t_end) if grid[-1] < t_end else grid
        if grid[0] == seg.t_s:
            grid[0] = seg.t_s + min(dt, grid[1] - grid[0]) * 1e-6  # step off the surface
        xv = seg(grid)
        best: tuple[float, int, int] | None = None
        for j, d in armed:
            shift = b if j == 0 else -b
            dg = d * (xv[0] - shift)   # > 0: on the far side of the armed crossing
            dv = d * xv[1]             # d/dt of dg
            if dg[0] > 0:
                raise RuntimeError(f"closed form: crossing of {SURFACES[j]} right at the restart "
                                   f"t={seg.t_s} (chattering or grazing restart)")
            cand = None
            out = np.nonzero(dg > 0)[0]
            i_out = int(out[0]) if out.size else grid.size
            # a maximum of dg between samples that pokes through zero (grazing double crossing)
            for i in np.nonzero((dv[:-1] > 0) & (dv[1:] < 0))[0]:
                if i + 1 >= i_out:
                    break
                tm = brentq(lambda s, d=d: d * seg(s)[1, 0], grid[i], grid[i + 1], xtol=1e-15, rtol=8.9e-16)
                if d * (seg(tm)[0, 0] - shift) > 0:
                    cand = (grid[i], tm)
                    break
            if cand is None and out.size:
                cand = (grid[i_out - 1], grid[i_out])
            if cand is not None:
                tc = brentq(lambda s, c=shift: seg(s)[0, 0] - c, cand[0], cand[1], xtol=1e-15, rtol=8.9e-16)
                if best is None or tc < best[0]:
                    best = (tc, j, d)
        if best is not None:
            return best
        a = grid[-1]
        if a >= t_end:
            return None
    return None


def closed_form_linear(params: Mapping[str, float] | None, x0: Sequence[float], t_eval: Sequence[float],
                       *, t0: float = 0.0, samples_per_period: int = 256
                       ) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
    """Exact piecewise closed-form solution for ``eps = 0``.

    Between contacts the oscillator is ``x'' + 2 zeta x' + k x = Fm + mode*b +
    Fa Omega^2 cos(Omega t)`` with ``k = 1`` in contact and ``k = 0`` in free flight,
    solved exactly (homogeneous part from the characteristic roots, particular part
    ``Re(X e^{i Omega t})`` plus the constant-load response).  The contact times are
    roots of the closed form (``brentq`` to ~1e-15), bracketed on a grid of
    ``samples_per_period`` points per shortest period (forcing or natural), with the
    extrema of ``g`` between samples checked so that a grazing double crossing
    inside one sample interval is not missed.

    Parameters
    ----------
    params
        Parameter values (missing ones take :data:`DEFAULTS`); ``eps`` must be 0.
    x0
        Initial state at ``t0``.
    t_eval
        Output times; the solution is computed up to ``max(t_eval)``.
    t0
        Start time.
    samples_per_period
        Bracketing resolution.

    Returns
    -------
    y, event_times, event_surfaces, event_directions
        As :func:`reference_solution`.
    """
    p = _params(params)
    if p["eps"] != 0.0:
        raise ValueError(f"closed_form_linear needs eps = 0 (got eps = {p['eps']})")
    b = p["b"]
    t_eval = np.asarray(t_eval, dtype=float)
    t_end = float(np.max(t_eval))
    if t_end <= t0 or np.min(t_eval) < t0:
        raise ValueError("t_eval must lie in [t0, t_end] with t_end > t0")
    dt = min(forcing_period(p), 2.0 * math.pi) / samples_per_period
    x_s, v_s = float(x0[0]), float(x0[1])
    mode = mode_of(x_s, v_s, b)
    t = float(t0)
    segs: list[_Segment] = []
    ev_t: list[float] = []
    ev_s: list[str] = []
    ev_d: list[int] = []
    while True:
        seg = _Segment.start(t, x_s, v_s, mode, p)
        segs.append(seg)
        hit = _first_crossing(seg, _armed(mode), b, t_end, dt)
        if hit is None:
            break
        tc, j, d = hit
        ev_t.append(tc)
        ev_s.append(SURFACES[j])
        ev_d.append(d)
        if len(ev_t) > _MAX_EVENTS:
            raise RuntimeError(f"more than {_MAX_EVENTS} events before t={tc}")
        x_s, v_s = (b if j == 0 else -b), float(seg(tc)[1, 0])
        t, mode = tc, _next_mode(j, d)
    y = _evaluate_segments(np.array([s.t_s for s in segs]), segs, t_eval)
    return y, np.array(ev_t), ev_s, np.array(ev_d, dtype=int)
