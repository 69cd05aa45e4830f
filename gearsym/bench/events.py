"""Event-located, mode-switched integration in Python (scipy ``solve_ivp``): the algorithm of
gearsym's C driver written independently, and the wall-clock guard of the Python peers."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .model import PythonModel

__all__ = ["HybridSolution", "RunTimeout", "solve_with_events"]


@dataclass
class HybridSolution:
    """Result of :func:`solve_with_events`."""

    y: np.ndarray
    event_t: np.ndarray
    event_surface: np.ndarray
    event_direction: np.ndarray
    n_rhs: int
    n_segments: int


def solve_with_events(pm: PythonModel, x0: Sequence[float], t_eval: Sequence[float], *, t0: float = 0.0,
                      rtol: float = 1e-13, atol: float | np.ndarray = 1e-15, method: str = "DOP853",
                      max_step: float = np.inf, max_events: int = 1_000_000,
                      deadline: _Deadline | None = None) -> HybridSolution:
    """Event-located, mode-switched integration with scipy ``solve_ivp``.

    The modal right-hand side is integrated with the surface sides ``sigma`` fixed;
    a terminal event on ``g_j`` (armed only for the crossing away from the current
    side) flips ``sigma_j`` and restarts; the integration also restarts at every
    scheduled breakpoint, with the schedule mode of the next segment.  This is the
    algorithm of gearsym's C driver, written independently in Python.

    Returns
    -------
    HybridSolution
    """
    from scipy.integrate import solve_ivp

    t_eval = np.asarray(t_eval, dtype=float)
    t_end = float(t_eval[-1])
    y = np.array(x0, dtype=float)
    t = float(t0)
    g0 = pm.switching(t, y)
    sigma = np.where(g0 >= 0, 1.0, -1.0)
    breaks = list(pm.break_times(t, t_end)) + [t_end]
    starts: list[float] = []
    sols: list[Any] = []
    ev_t: list[float] = []
    ev_j: list[int] = []
    ev_d: list[int] = []
    n_rhs = 0
    gfun = [pm.switching_component(j) for j in range(pm.nsw)]
    for tb in breaks:
        sched = pm.sched_mode(0.5 * (t + tb))
        while t < tb:
            f = pm.modal_function(sigma, sched)
            if deadline is not None:
                f = _guarded(f, deadline)
            # each g_j starts on the side sigma_j says (a root located a hair early leaves g_j on
            # the old side at the restart, and scipy would then miss the next crossing)
            events = [_event(gfun[j], -sigma[j], t, sigma[j]) for j in range(pm.nsw)]
            sol = solve_ivp(f, (t, tb), y, method=method, rtol=rtol, atol=atol, events=events or None,
                            dense_output=True, max_step=max_step)
            if sol.status == -1:
                raise RuntimeError(f"event-located {method} failed at t={sol.t[-1]}: {sol.message}")
            n_rhs += int(sol.nfev)
            starts.append(t)
            sols.append(sol.sol)
            if sol.status == 1:
                hits = [(float(te[0]), j) for j, te in enumerate(sol.t_events) if te.size]
                te = min(h[0] for h in hits)
                ye = None
                for tj, j in hits:
                    if tj <= te + 4e-16 * max(1.0, abs(te)):
                        ev_t.append(te)
                        ev_j.append(j)
                        ev_d.append(int(-sigma[j]))
                        sigma[j] = -sigma[j]
                        ye = sol.y_events[j][0]
                if len(ev_t) > max_events:
                    raise RuntimeError(f"more than {max_events} events before t={te}")
                if len(ev_t) > 50 and ev_t[-1] - ev_t[-51] <= 1e-9 * max(1.0, abs(te)):
                    raise RuntimeError(f"event storm in the Python reference at t={te} (50 events within "
                                       f"1e-9): sliding or chattering on a switching surface")
                t, y = te, np.array(ye, dtype=float)
            else:
                t, y = tb, sol.y[:, -1].copy()
    out = np.empty((t_eval.size, pm.nx))
    idx = np.clip(np.searchsorted(np.array(starts), t_eval, side="right") - 1, 0, len(sols) - 1)
    for k in np.unique(idx):
        sel = idx == k
        out[sel] = np.asarray(sols[k](t_eval[sel])).T.reshape(-1, pm.nx)
    return HybridSolution(out, np.array(ev_t), np.array(ev_j, dtype=int), np.array(ev_d, dtype=int),
                          n_rhs, len(sols))


def _event(g: Callable[[float, np.ndarray], float], direction: float, t_start: float,
           side: float) -> Callable[[float, np.ndarray], float]:
    def ev(t, y):
        v = g(t, y)
        if t == t_start and v * side <= 0:
            return side * max(abs(v), 1e-300)
        return v

    ev.terminal = True  # type: ignore[attr-defined]
    ev.direction = direction  # type: ignore[attr-defined]
    return ev


class RunTimeout(RuntimeError):
    """A Python right-hand side ran past its method's time limit (the run is abandoned)."""


class _Deadline:
    """A wall-clock limit shared by a right-hand side and the run that uses it."""

    def __init__(self) -> None:
        self.t = math.inf
        self.limit = math.inf

    def start(self, limit: float) -> None:
        self.limit = limit
        self.t = time.perf_counter() + limit


def _guarded(f: Callable[[float, np.ndarray], np.ndarray], dl: _Deadline) -> Callable[[float, np.ndarray], np.ndarray]:
    """``f`` that raises :class:`RunTimeout` once the deadline has passed (some peers never
    finish on stiff jumps at tight tolerances, e.g. LSODA)."""
    clock = time.perf_counter

    def g(t, y):
        if clock() > dl.t:
            raise RunTimeout(f"abandoned after {dl.limit:g} s")
        return f(t, y)
    return g

