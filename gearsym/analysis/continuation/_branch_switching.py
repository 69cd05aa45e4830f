"""Branch switching at a period doubling: the branch of the doubled orbit.

At a located period doubling the ``2k``-period map has the multiplier
``(-1)^2 = 1`` with the eigenvector ``v`` of ``-1``; the new branch leaves the old
one along ``(v, 0)``, so the first corrector runs on the hyperplane orthogonal to
that direction a small distance away, and the continuation proceeds from there
(until the parameter range is left or the doubled orbit merges back into the
period-``k`` branch).  What the parent was computed with comes from its
:class:`~gearsym.analysis.continuation.ContinuationSetup` (``Branch.setup``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ...errors import ConvergenceError, GearsymError, ParameterError
from .._options import resolve_options
from ..periodic import ShootingResidual
from ._arclength import Leg, formatter, period_defect, run
from ._branch import Bifurcation, Branch
from ._detection import detect_types
from ._options import ContinuationOptions

__all__ = ["switch_all", "switch_period_doubling"]


def switch_period_doubling(branch: Branch, bifurcation: Bifurcation | int | None = None, *,
                           stop: float | None = None, amplitude: float = 2e-3,
                           options: ContinuationOptions | None = None, **keywords: Any) -> Branch:
    """Continue the period-doubled branch born at a located period doubling.

    Parameters
    ----------
    branch
        A branch from :func:`continuation` (shooting).
    bifurcation
        The period-doubling point (or its index in ``branch.bifurcations``;
        default: the first period doubling).
    stop
        End of the parameter range of the new branch (default: the parent's
        ``stop``); its other end is the parent's ``start``.
    amplitude
        Distance (scaled arclength) from the period-doubling point along the
        critical eigenvector at which the first doubled orbit is sought.
    options
        The step settings of the new branch (:class:`~gearsym.analysis.continuation.ContinuationOptions`:
        ``ds``, ``ds_min``, ``ds_max``, ``max_angle``, ``max_points``, ``tol``, ``max_newton``,
        ``detect``, ``locate``, ``n_dense``, ``progress``, ``stall_points``, ``stall_tol``,
        ``f_lambda``); the problem (periods, segments, tolerances of the integrator, state
        weight) is the parent's.  ``tol`` and ``n_dense`` default to the parent's.
    **keywords
        Any of those settings one by one; a keyword wins over ``options``.

    Returns
    -------
    Branch
        With ``periods`` twice the parent's; appended to ``branch.children``.
    """
    o = resolve_options(options, ContinuationOptions, keywords, "switch_period_doubling")
    return _switch(branch, bifurcation, stop, amplitude, o, detect_types(o.detect), formatter(o.display))


def _switch(branch: Branch, bifurcation: Bifurcation | int | None, stop: float | None, amplitude: float,
            o: ContinuationOptions, types: tuple[str, ...], fmt: Callable[[float], str]) -> Branch:
    """:func:`switch_period_doubling` with the options resolved."""
    if bifurcation is None:
        pds = branch.of_type("period_doubling")
        if not pds:
            raise ParameterError("the branch has no located period doubling")
        bifurcation = pds[0]
    elif isinstance(bifurcation, int):
        bifurcation = branch.bifurcations[bifurcation]
    if bifurcation.type != "period_doubling":
        raise ParameterError(f"branch switching needs a period doubling, got a {bifurcation.type}")
    setup = branch.setup
    system = branch.system
    if setup is None or system is None or branch.method != "shooting" or setup.segments is None:
        raise ParameterError("branch switching needs a shooting branch from gearsym.continuation")
    start = float(branch.info.get("start", branch.points[0].value))
    stop = float(branch.info.get("stop", branch.points[-1].value)) if stop is None else float(stop)
    pt = bifurcation.point
    lam = float(bifurcation.value)
    M = pt.monodromy
    if M is None:
        raise ParameterError("the period-doubling point has no monodromy")
    w, V = np.linalg.eig(M)
    k = int(np.argmin(np.abs(w + 1.0)))
    v = np.real(V[:, k])
    v = v / np.linalg.norm(v)
    # (a DAE's monodromy is that of its differential states: the algebraic variables, the last
    # states, follow them and are not moved)
    v = np.concatenate([v, np.zeros(len(pt.x0) - len(v))])
    res = ShootingResidual(system, setup.param, 2 * setup.periods, setup.params, setup.segments * (
        2 if setup.segments > 1 else 1), setup.t0, setup.rtol, setup.atol, setup.fd_step, setup.integrator,
        f_lambda=o.f_lambda)
    # state scale of the parent (at this point), the tangent (v, 0) in scaled variables
    nx = res.nx
    state_scale = np.array(setup.state_scale, float)
    x_star = pt.x0
    vs = v / state_scale
    vs = vs / np.linalg.norm(vs)
    x_guess = x_star + amplitude * vs * state_scale * math.sqrt(nx)
    u_guess = res.u_from_orbit(x_guess, lam)
    u_star = res.u_from_orbit(x_star, lam)
    S = np.concatenate([res.unknown_scale(state_scale) / setup.state_weight, [abs(stop - start)]])
    t_dir = np.concatenate([(u_guess - u_star), [0.0]]) / S
    t_dir = t_dir / np.linalg.norm(t_dir)
    z_first = np.concatenate([u_guess, [lam]])
    tol = o.tol if o.tol is not None else float(branch.info.get("tol", 1e-9))
    # the parent's problem, the caller's steps (ds_max and max_points at their own defaults)
    o = replace(o, tol=tol, ds_max=0.02 if o.ds_max is None else o.ds_max,
                max_points=5000 if o.max_points is None else o.max_points, state_weight=setup.state_weight)
    # direction: towards the side where the doubled orbit exists is found by the corrector; the
    # continuation range keeps the parent's orientation
    lo, hi = min(start, stop), max(start, stop)
    child = run(res, u_guess, Leg(
        lo if stop >= start else hi, hi if stop >= start else lo, o, types, setup.state,
        o.n_dense if o.n_dense is not None else setup.n_dense, "shooting", state_scale, fmt,
        first=(z_first, t_dir), parent=bifurcation, stop_on_merge=True,
        info={"start": lo, "stop": hi, "rtol": res.rtol, "atol": res.atol, "tol": tol,
              "params": dict(branch.info.get("params", {})), "t0": res.t0, "switched_at": lam}))
    # the corrector on the hyperplane orthogonal to (v, 0) lands on the doubled branch; check it
    p0 = child.points[0]
    if abs(p0.value - lam) > 0.5 * abs(hi - lo) or period_defect(res, p0.value, p0.x0) < 1e2 * tol:
        raise ConvergenceError(f"branch switching at the period doubling at {setup.param} = {lam:.8g} fell back "
                               f"onto the period-{setup.periods:g} orbit; try a larger amplitude=")
    branch.children.append(child)
    return child


def switch_all(branch: Branch, depth: int, options: ContinuationOptions, types: tuple[str, ...],
               fmt: Callable[[float], str], stop: float | None = None) -> list[dict[str, Any]]:
    """Switch at every period doubling of ``branch``, recursively to ``depth`` levels.

    Parameters
    ----------
    branch
        The branch.
    depth
        Levels of switching.
    options
        The continuation's resolved options (the steps of every new branch).
    types
        The special points to detect.
    fmt
        Formats a parameter value for messages.
    stop
        End of the range of the new branches (default: the parent's).

    Returns
    -------
    list of dict
        The failures (``value``, ``periods`` of the parent branch, ``error``).
    """
    failures: list[dict[str, Any]] = []
    for b in list(branch.of_type("period_doubling")):
        if b.info.get("located") is False:
            failures.append({"value": b.value, "periods": branch.periods,
                             "error": f"the period doubling was detected between {branch.param} = "
                                      f"{b.info['bracket'][0]:.8g} and {b.info['bracket'][1]:.8g} but not located "
                                      f"({b.info.get('reason', '')}): no branch switching from it"})
            continue
        try:
            child = _switch(branch, b, stop, 2e-3, options, types, fmt)
        except GearsymError as exc:
            failures.append({"value": b.value, "periods": branch.periods, "error": str(exc)})
            continue
        if depth > 1:
            failures += switch_all(child, depth - 1, options, types, fmt, stop)
    return failures
