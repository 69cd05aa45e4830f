"""The one damped Newton iteration of the periodic-orbit solvers.

Shooting (:func:`gearsym.analysis.periodic.shoot`, the first orbit of a continuation
included) and the continuation's corrector (:class:`gearsym.analysis.continuation._corrector.Continuer`)
run this loop; they differ only in what they pass in:

* ``evaluate(x)``: the residual record at ``x`` (raises :class:`~gearsym.errors.GearsymError`
  when the integration fails);
* ``norm(ev)``: the residual norm the damping must decrease;
* ``direction(x, ev)``: the full Newton step, its size relative to the tolerance's scale,
  and notes for the history;
* ``converged(ev, size, damping)``: a note (``""`` for a plain convergence) when ``ev`` is
  converged after a step of relative ``size`` taken with ``damping`` -- also asked
  *before* a step is taken (``damping = 0``), so that a point whose Newton step is
  already below the tolerance is accepted without one more integration (with
  ``policy.apply_final_step`` the step is added to it);
* ``stalled(x, ev, dx, error)``: what to do when no damped step decreases the residual
  (accept at the noise floor, restart from a relaxed point, or fail).

The step is halved from 1 down to ``policy.min_damping`` until the residual falls by
the factor ``1 - policy.decrease * damping`` (or below ``policy.accept_below``); with
``policy.accept_last`` the smallest step is taken even when it does not decrease (the
corrector, whose rejection is the continuation's step control).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import GearsymError

__all__ = ["NewtonOutcome", "NewtonPolicy", "damped_newton"]


@dataclass(frozen=True)
class NewtonPolicy:
    """How a damped Newton iteration proceeds.

    Attributes
    ----------
    max_iter : int
        Newton steps allowed.
    min_damping : float
        Smallest damping factor tried (halving from 1).
    decrease : float
        Sufficient decrease: a damped step ``a`` is accepted when the norm falls below
        ``(1 - decrease * a)`` times the current one.
    accept_below : float
        A damped step whose norm is below this is accepted whatever the decrease.
    accept_last : bool
        Take the smallest damped step even if it does not decrease the norm (an
        evaluation failure there is raised).
    diverge : tuple of float or None
        ``(ratio, floor)``: after two steps, stop when the norm falls by less than
        ``ratio`` while above ``floor``.
    apply_final_step : bool
        When ``converged`` accepts a point before its step is taken, return ``x + dx``
        (the step's effect on the residual is quadratic in its size, far below the
        tolerance) without evaluating it.
    """

    max_iter: int
    min_damping: float = 2.0 ** -12
    decrease: float = 1e-4
    accept_below: float = 0.0
    accept_last: bool = False
    diverge: tuple[float, float] | None = None
    apply_final_step: bool = False


@dataclass(frozen=True)
class NewtonOutcome:
    """The result of :func:`damped_newton`.

    Attributes
    ----------
    x : ndarray
        The last iterate.
    ev : object
        Its residual record (from ``evaluate``).
    iterations : int
        Newton steps taken.
    converged : bool
        Whether ``converged`` accepted ``x``.
    failure : str
        Why not (empty when converged); ``"max_iter"`` when the budget ran out.
    note : str
        The convergence note.
    """

    x: np.ndarray
    ev: Any
    iterations: int
    converged: bool
    failure: str = ""
    note: str = ""


def damped_newton(x: np.ndarray, ev: Any, *, evaluate: Callable[[np.ndarray], Any],
                  norm: Callable[[Any], float],
                  direction: Callable[[np.ndarray, Any], tuple[np.ndarray, float, dict[str, Any]]],
                  converged: Callable[[Any, float, float], str | None], policy: NewtonPolicy,
                  stalled: Callable[[np.ndarray, Any, np.ndarray, str], tuple[str, Any]] | None = None,
                  on_step: Callable[[int, Any, float, dict[str, Any]], None] | None = None) -> NewtonOutcome:
    """Damped Newton from ``x`` (with its record ``ev``); see the module docstring.

    Parameters
    ----------
    x, ev
        Start point and its residual record.
    evaluate, norm, direction, converged
        The problem (see the module docstring).
    policy
        Iteration budget and damping rules.
    stalled
        Called when no damped step is accepted; returns ``("converged", note)``,
        ``("restart", (x, ev))`` or ``("fail", message)``.  Default: fail.
    on_step
        Called after every accepted step with ``(iteration, ev, damping, notes)``.

    Returns
    -------
    NewtonOutcome
    """
    it = 0
    size, damping = math.inf, 1.0
    r_prev = math.inf
    while True:
        note = converged(ev, size, damping)
        if note is not None:
            return NewtonOutcome(x, ev, it, True, note=note)
        if it >= policy.max_iter:
            return NewtonOutcome(x, ev, it, False, "max_iter")
        r = norm(ev)
        if not math.isfinite(r):
            return NewtonOutcome(x, ev, it, False, "non-finite residual")
        if policy.diverge is not None and it >= 2 and r > policy.diverge[0] * r_prev and r > policy.diverge[1]:
            return NewtonOutcome(x, ev, it, False, f"Newton diverges (residual {r_prev:.3g} -> {r:.3g})")
        dx, size, notes = direction(x, ev)
        if not np.all(np.isfinite(dx)):
            return NewtonOutcome(x, ev, it, False, "the Newton matrix is not finite")
        note = converged(ev, size, 0.0)
        if note is not None:  # the step is below the tolerance: no need to integrate at its end
            return NewtonOutcome(x + dx if policy.apply_final_step else x, ev, it, True,
                                 note=note or "Newton step below tolerance")
        it += 1
        r_prev = r
        damping, last_err, evn = 1.0, "", None
        accepted = False
        while damping >= policy.min_damping:
            last = damping * 0.5 < policy.min_damping
            xn = x + damping * dx
            try:
                evn = evaluate(xn)
                rn = norm(evn)
            except GearsymError as exc:
                if policy.accept_last and last:
                    raise
                last_err, rn = str(exc), math.nan
            else:
                if math.isfinite(rn) and (rn < (1.0 - policy.decrease * damping) * r or rn <= policy.accept_below
                                          or (policy.accept_last and last)):
                    accepted = True
                    break
            damping *= 0.5
        if accepted:
            x, ev = xn, evn
            if on_step is not None:
                on_step(it, ev, damping, notes)
            continue
        action, payload = stalled(x, ev, dx, last_err) if stalled is not None else (
            "fail", last_err or "no damped step reduces the residual")
        if action == "converged":
            return NewtonOutcome(x, ev, it, True, note=payload)
        if action == "restart":
            x, ev = payload
            size, damping = math.inf, 1.0
            continue
        return NewtonOutcome(x, ev, it, False, payload)
