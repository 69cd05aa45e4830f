"""Hand-written references for the hard cases (no gearsym code).

* :func:`hybrid_solve` -- event-located scipy DOP853 for a piecewise-smooth system
  given by a right-hand side per mode (``rhs(t, y, sigma)``, ``sigma_j = +-1`` the side
  of switching function ``g_j``) and the switching functions ``g(t, y)``; the mode is
  held fixed between events (terminal, direction-aware events on every ``g_j``) and
  the integration restarts at every event and at given breakpoints.
* :func:`ks` -- ``tests/reference.py`` (the benchmark oscillator's references), from
  ``tests/_ks_loader.py``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from _ks_loader import ks  # noqa: F401  (tests/ is on sys.path: pytest's rootdir-based import)
from scipy.integrate import solve_ivp


def hybrid_solve(rhs: Callable[[float, np.ndarray, np.ndarray], np.ndarray],
                 g: Callable[[float, np.ndarray], np.ndarray], x0: Sequence[float], t_eval: Sequence[float], *,
                 t0: float = 0.0, breaks: Sequence[float] = (), rtol: float = 1e-12, atol: float = 1e-14,
                 max_step: float = np.inf, sigma0: Sequence[float] | None = None, max_events: int = 100_000):
    """Event-located, mode-switched DOP853 solution.

    Returns
    -------
    y : ndarray (len(t_eval), n)
    events : list of (t, j, direction)
    """
    t_eval = np.asarray(t_eval, float)
    t_end = float(t_eval[-1])
    y = np.asarray(x0, float).copy()
    t = float(t0)
    gv = np.asarray(g(t, y), float)
    sigma = np.where(gv >= 0, 1.0, -1.0) if sigma0 is None else np.asarray(sigma0, float).copy()
    stops = sorted(b for b in breaks if t < b < t_end) + [t_end]
    starts, sols, events = [], [], []
    for tb in stops:
        while t < tb:
            sig = sigma.copy()
            evs = []
            for j in range(sigma.size):
                def ev(tt, yy, j=j):
                    return g(tt, yy)[j]
                ev.terminal = True
                ev.direction = -sig[j]
                evs.append(ev)
            sol = solve_ivp(lambda tt, yy, sig=sig: rhs(tt, yy, sig), (t, tb), y, method="DOP853", rtol=rtol, atol=atol,
                            events=evs or None, dense_output=True, max_step=max_step)
            assert sol.status != -1, sol.message
            starts.append(t)
            sols.append(sol.sol)
            if sol.status == 1:
                hits = [(float(te[0]), j) for j, te in enumerate(sol.t_events) if te.size]
                te = min(h[0] for h in hits)
                for tj, j in hits:
                    if tj <= te + 1e-15 * max(1.0, abs(te)):
                        events.append((te, j, int(-sigma[j])))
                        sigma[j] = -sigma[j]
                        y = np.asarray(sol.y_events[j][0], float).copy()
                t = te
                assert len(events) < max_events, "too many events in the reference"
            else:
                t, y = tb, sol.y[:, -1].copy()
    out = np.empty((t_eval.size, y.size))
    idx = np.clip(np.searchsorted(np.array(starts), t_eval, side="right") - 1, 0, len(sols) - 1)
    for k in np.unique(idx):
        sel = idx == k
        out[sel] = np.asarray(sols[k](t_eval[sel])).T.reshape(-1, y.size)
    return out, events
