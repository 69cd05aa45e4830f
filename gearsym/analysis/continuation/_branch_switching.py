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
from typing import Any

import numpy as np

from ...budget import check_counts
from ...errors import ConvergenceError, GearsymError, ParameterError
from ..periodic import ShootingResidual
from ._arclength import period_defect, run
from ._branch import Bifurcation, Branch
from ._detection import detect_types

__all__ = ["switch_all", "switch_period_doubling"]


def switch_period_doubling(branch: Branch, bifurcation: Bifurcation | int | None = None, *,
                           stop: float | None = None, amplitude: float = 2e-3, **options: Any) -> Branch:
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
    **options
        ``ds``, ``ds_max``, ``tol``, ... as for :func:`continuation`.

    Returns
    -------
    Branch
        With ``periods`` twice the parent's; appended to ``branch.children``.
    """
    check_counts(**{k: v for k, v in options.items() if k in ("max_points", "max_newton", "n_dense", "stall_points")})
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
    res = ShootingResidual(system, setup.param, 2 * setup.periods, setup.params, setup.segments * (
        2 if setup.segments > 1 else 1), setup.t0, setup.rtol, setup.atol, setup.fd_step, setup.integrator)
    # state scale of the parent (at this point), the tangent (v, 0) in scaled variables
    nx = res.nx
    state_scale = np.array(setup.state_scale, float)
    x_star = pt.x0
    vs = v / state_scale
    vs = vs / np.linalg.norm(vs)
    step = amplitude
    x_guess = x_star + step * vs * state_scale * math.sqrt(nx)
    u_guess = res.u_from_orbit(x_guess, lam)
    u_star = res.u_from_orbit(x_star, lam)
    S = np.concatenate([res.unknown_scale(state_scale) / setup.state_weight, [abs(stop - start)]])
    t_dir = np.concatenate([(u_guess - u_star), [0.0]]) / S
    t_dir = t_dir / np.linalg.norm(t_dir)
    z_first = np.concatenate([u_guess, [lam]])
    opts = {k: options[k] for k in ("ds", "ds_min", "ds_max", "max_angle", "max_points", "tol", "max_newton",
                                    "locate", "n_dense", "progress", "stall_points", "stall_tol", "fmt")
            if k in options}
    types = detect_types(options.get("detect", True))
    kw = dict(ds=opts.get("ds", 0.005), ds_min=opts.get("ds_min", 1e-7), ds_max=opts.get("ds_max", 0.02),
              max_angle=opts.get("max_angle", 0.3), max_points=opts.get("max_points", 5000),
              tol=opts.get("tol", float(branch.info.get("tol", 1e-9))), max_newton=opts.get("max_newton", 7),
              types=types, locate=opts.get("locate", True), state=setup.state,
              n_dense=opts.get("n_dense", setup.n_dense), progress=opts.get("progress"),
              stall_points=opts.get("stall_points", 50), stall_tol=opts.get("stall_tol", 1e-5), fmt=opts.get("fmt"))
    # direction: towards the side where the doubled orbit exists is found by the corrector; the
    # continuation range keeps the parent's orientation
    lo, hi = min(start, stop), max(start, stop)
    child = run(res, u_guess, lo if stop >= start else hi, hi if stop >= start else lo, state_scale=state_scale,
                method="shooting", first=(z_first, t_dir), parent=bifurcation, stop_on_merge=True,
                state_weight=setup.state_weight, **kw,
                info={"start": lo, "stop": hi, "rtol": res.rtol, "atol": res.atol, "tol": kw["tol"],
                      "params": dict(branch.info.get("params", {})), "t0": res.t0, "switched_at": lam})
    # the corrector on the hyperplane orthogonal to (v, 0) lands on the doubled branch; check it
    p0 = child.points[0]
    if abs(p0.value - lam) > 0.5 * abs(hi - lo) or period_defect(res, p0.value, p0.x0) < 1e2 * kw["tol"]:
        raise ConvergenceError(f"branch switching at the period doubling at {setup.param} = {lam:.8g} fell back "
                               f"onto the period-{setup.periods:g} orbit; try a larger amplitude=")
    branch.children.append(child)
    return child


def switch_all(branch: Branch, depth: int, **kw: Any) -> list[dict[str, Any]]:
    """Switch at every period doubling of ``branch``, recursively to ``depth`` levels.

    Returns the failures (``value``, ``periods`` of the parent branch, ``error``).
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
            child = switch_period_doubling(branch, b, stop=kw.get("stop"),
                                           **{k: v for k, v in kw.items() if k not in ("stop", "start", "types")},
                                           detect=kw.get("types", True))
        except GearsymError as exc:
            failures.append({"value": b.value, "periods": branch.periods, "error": str(exc)})
            continue
        if depth > 1:
            failures += switch_all(child, depth - 1, **kw)
    return failures
