"""References of a work-precision run: the exact solution of a piecewise-constant linear
time-varying system (matrix exponentials), else the event-located DOP853 at a tight tolerance."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .events import solve_with_events
from .model import PythonModel

__all__ = ["Reference", "make_reference"]


@dataclass
class Reference:
    """A reference solution on the grid.

    Attributes
    ----------
    y
        States on the grid.
    kind
        ``"exact"`` (closed form / matrix exponentials) or ``"tight"`` (event-located
        DOP853 at a far tighter tolerance), or a caller's label.
    description
        How it was computed.
    y_check
        A second, less accurate solution (10x looser), whose difference from ``y``
        bounds the reference's error; ``None`` for exact references (then ``floor``
        is the rounding level).
    wall_s
        Seconds to compute ``y`` (and ``y_check``).
    events
        Number of switching events, if known.
    """

    y: np.ndarray
    kind: str
    description: str
    y_check: np.ndarray | None = None
    wall_s: float = 0.0
    events: int | None = None


def make_reference(system, pm: PythonModel | None, x0: np.ndarray, grid: np.ndarray,
                   params: Mapping[str, float] | None = None, rtol: float = 1e-13,
                   atol_scale: np.ndarray | None = None) -> Reference:
    """The best available reference for a compiled scene (see the module docstring)."""
    from ..analysis.periodic import NotPiecewiseConstantError, PiecewiseLTV

    t = time.perf_counter()
    T = system.period(params)
    if T and not system.generated.nsw and not system.generated.implicit:
        try:
            ltv = PiecewiseLTV.from_system(system, params, t0=0.0)
        except NotPiecewiseConstantError:
            ltv = None
        if ltv is not None:
            S = np.ones(len(x0)) if atol_scale is None else np.asarray(atol_scale, float)
            y = _propagate_ltv(ltv, x0, grid, T, S)
            # cross-check the first two periods against the tight event-located integration
            # (matrix exponentials of badly scaled SI systems can lose digits)
            n_chk = int(np.searchsorted(grid, grid[0] + 2 * T, side="right"))
            diff = None
            if pm is not None and n_chk >= 2:
                chk = solve_with_events(pm, x0, grid[:n_chk], t0=float(grid[0]), rtol=rtol, atol=rtol * 1e-2 * S)
                diff = float(np.max(np.abs(chk.y - y[:n_chk]) / np.maximum(np.max(np.abs(y), axis=0), 1e-300)))
            if diff is None or diff < 1e-10:
                return Reference(y, "exact", "matrix exponentials of the piecewise-constant LTV system, states "
                                 "scaled by their magnitudes (PiecewiseLTV, segment by segment)"
                                 + (f"; agrees with DOP853 at rtol {rtol:g} to {diff:.1e} over 2 periods"
                                    if diff is not None else ""), None, time.perf_counter() - t, 0)
            say_fallback = (f"; the matrix-exponential solution was not used (it differs by {diff:.1e} from "
                            f"this over the first 2 periods)")
        else:
            say_fallback = ""
    else:
        say_fallback = ""
    if pm is None:
        raise ValueError("no Python model for the event-located reference")
    scale = np.ones(pm.nx) if atol_scale is None else np.asarray(atol_scale, float)
    sol = solve_with_events(pm, x0, grid, t0=float(grid[0]), rtol=rtol, atol=rtol * 1e-2 * scale)
    chk = solve_with_events(pm, x0, grid, t0=float(grid[0]), rtol=10 * rtol, atol=10 * rtol * 1e-2 * scale)
    return Reference(sol.y, "tight", f"event-located, mode-switched scipy DOP853 (rtol {rtol:g}, atol "
                     f"{rtol * 1e-2:g} x state scale), restarted at every event and breakpoint; floor from "
                     f"a second run at rtol {10 * rtol:g}{say_fallback}", chk.y, time.perf_counter() - t,
                     int(sol.event_t.size))


def _propagate_ltv(ltv, x0: np.ndarray, grid: np.ndarray, T: float, scale: np.ndarray | None = None) -> np.ndarray:
    """Propagate period by period in the scaled states ``x / scale`` (well-conditioned exponentials)."""
    from ..analysis.periodic import PiecewiseLTV

    S = np.ones(len(x0)) if scale is None else np.asarray(scale, float)
    ltv = PiecewiseLTV(times=ltv.times, A=[(A * S[None, :]) / S[:, None] for A in ltv.A],
                       B=None if ltv.B is None else [B / S[:, None] for B in ltv.B], omega=ltv.omega, K=ltv.K)
    t0 = float(grid[0])
    k0 = math.floor(t0 / T + 1e-12)
    x = np.asarray(x0, float) / S
    y = np.full((grid.size, x.size), np.nan)
    k = k0
    tcur = t0
    while True:
        ts, te = k * T, (k + 1) * T
        piece = PiecewiseLTV(times=ltv.times - ltv.times[0] + ts, A=ltv.A, B=ltv.B, omega=ltv.omega, K=ltv.K)
        if tcur > ts:  # start inside the first period: shift the segments
            raise ValueError("exact LTV reference needs the grid to start at a whole period")
        sel = np.nonzero((grid >= ts) & (grid <= te))[0]
        x_end, ys = piece.propagate(x, grid[sel])
        y[sel] = ys
        x = x_end
        k += 1
        tcur = te
        if te >= grid[-1] - 1e-12 * max(1.0, abs(grid[-1])):
            break
    return y * S[None, :]

