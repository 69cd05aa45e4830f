"""A compiled scene's equations as Python callables, for references built in the tests.

:func:`lambdified_solve` takes the scene's *symbolic* model (the derivation it shares with
the generated C), turns its modal right-hand side and switching functions into Python
functions with ``sympy.lambdify``, and integrates them with the hand-written event-located
DOP853 of :func:`tests.hard._ref.hybrid_solve`: nothing of the code generation, the C
engine or the benchmark harness is involved.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ._ref import hybrid_solve


@dataclass
class LambdifiedSolution:
    """States on the grid and the events (time, surface index, direction)."""

    y: np.ndarray
    event_t: np.ndarray
    event_surface: np.ndarray
    event_direction: np.ndarray


def lambdified_solve(model, p: Sequence[float], x0: Sequence[float], t_eval: Sequence[float], *,
                     rtol: float = 1e-12, atol: float | np.ndarray = 1e-14) -> LambdifiedSolution:
    """Event-located integration of an explicit model without schedules.

    Parameters
    ----------
    model
        The scene's symbolic model (``scene.model``).
    p
        Parameter vector in the order of ``model.parameters`` (SI, as the engine takes it).
    x0, t_eval
        Initial state and output times (from ``t_eval[0]``).
    rtol, atol
        DOP853 tolerances.
    """
    assert model.form == "explicit" and not model.schedules, "explicit models without schedules only"
    args = [model.t, *model.states, *model.parameters]
    sigma = list(model.modal.sigma)
    modal = sp.lambdify(args + sigma, list(model.modal.rhs), modules="math", cse=True)
    g = sp.lambdify(args, [s.expr for s in model.switching], modules="math", cse=True)
    pv = [float(v) for v in p]

    def rhs(t, y, sig):
        return np.array(modal(t, *y, *pv, *sig))

    def gfun(t, y):
        return np.array(g(t, *y, *pv), dtype=float)

    t_eval = np.asarray(t_eval, float)
    y, events = hybrid_solve(rhs, gfun, x0, t_eval, t0=float(t_eval[0]), rtol=rtol, atol=atol)
    ev = np.array(events, dtype=float).reshape(-1, 3)
    return LambdifiedSolution(y, ev[:, 0], ev[:, 1].astype(int), ev[:, 2].astype(int))
