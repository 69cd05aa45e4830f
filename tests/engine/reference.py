"""Independent references for the engine tests (scipy only, no gearsym code)."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def backlash_f(x: float, b: float, region: int) -> float:
    """Restoring force for region +1 (x > b), 0 (|x| <= b), -1 (x < -b)."""
    return x - b if region > 0 else (x + b if region < 0 else 0.0)


def backlash_reference(
    p, x0, t_end, t_out, *, jump_damping=False, rtol=1e-13, atol=1e-13, variational=False, saltation=True
):
    """DOP853 with terminal events at x = +-b, restarted at each event.

    Returns (y at t_out, event times, x_final, monodromy or None).  With
    ``variational`` the 2x2 variational equations are integrated along, with
    (or without) the saltation matrix at each event.
    """
    zeta, eps, Om, Fm, Fa, b = p

    def region_of(x, v):
        if x > b or (x == b and v > 0):
            return 1
        if x < -b or (x == -b and v < 0):
            return -1
        return 0

    def rhs_state(t, x, v, region):
        c = 1.0 if (not jump_damping or region != 0) else 0.0
        F = (
            -2 * zeta * c * v
            - (1 + eps * np.cos(Om * t)) * backlash_f(x, b, region)
            + Fm
            + Fa * Om**2 * np.cos(Om * t)
        )
        return np.array([v, F])

    def jac(t, x, v, region):
        c = 1.0 if (not jump_damping or region != 0) else 0.0
        k = (1 + eps * np.cos(Om * t)) if region != 0 else 0.0
        return np.array([[0.0, 1.0], [-k, -2 * zeta * c]])

    def rhs(t, y, region):
        d = rhs_state(t, y[0], y[1], region)
        if not variational:
            return d
        Phi = y[2:].reshape(2, 2)
        return np.concatenate([d, (jac(t, y[0], y[1], region) @ Phi).ravel()])

    t_out = np.asarray(t_out, dtype=float)
    y_out = np.full((len(t_out), 2), np.nan)
    t = 0.0
    y = np.array(x0, dtype=float)
    if variational:
        y = np.concatenate([y, np.eye(2).ravel()])
    region = region_of(y[0], y[1])
    ev_times = []
    while t < t_end:
        # crossing surfaces away from the current region
        evs = []
        if region >= 0:
            e1 = lambda tt, yy: yy[0] - b  # noqa: E731
            e1.terminal = True
            e1.direction = -1 if region == 1 else 1
            evs.append(e1)
        if region <= 0:
            e2 = lambda tt, yy: yy[0] + b  # noqa: E731
            e2.terminal = True
            e2.direction = 1 if region == -1 else -1
            evs.append(e2)
        sol = solve_ivp(
            lambda tt, yy, r=region: rhs(tt, yy, r),
            (t, t_end),
            y,
            method="DOP853",
            rtol=rtol,
            atol=atol,
            events=evs,
            dense_output=True,
        )
        t1 = sol.t[-1]
        mask = (t_out >= t) & (t_out <= t1)
        if mask.any():
            y_out[mask] = sol.sol(t_out[mask])[:2].T
        y = sol.y[:, -1].copy()
        if sol.status == 1:  # event
            ev_times.append(t1)
            old = region
            v = y[1]
            xe = y[0]
            if abs(xe - b) < abs(xe + b):
                new = 1 if v > 0 else 0
            else:
                new = -1 if v < 0 else 0
            if variational and saltation:
                f_old = rhs_state(t1, y[0], y[1], old)
                f_new = rhs_state(t1, y[0], y[1], new)
                G = np.array([1.0, 0.0])
                S = np.eye(2) + np.outer(f_new - f_old, G) / (G @ f_old)
                y[2:] = (S @ y[2:].reshape(2, 2)).ravel()
            region = new
        t = t1
        if sol.status == 0:
            break
    mono = y[2:].reshape(2, 2) if variational else None
    return y_out, np.array(ev_times), y[:2], mono
