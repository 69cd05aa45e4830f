"""The pseudo-arclength predictor-corrector loop of the continuation.

Predictor along the unit tangent (or a step in the parameter itself where the
branch is a graph over it), corrector (:class:`~gearsym.analysis.continuation._corrector.Continuer`),
step control, detection and location of special points between accepted points
(:mod:`gearsym.analysis.continuation._detection`), and the conditions under which a branch ends.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ...errors import ConvergenceError, GearsymError
from ..periodic import PeriodicOrbitProblem, neutral_step_limit
from ._branch import Bifurcation, Branch, ContinuationSetup
from ._corrector import Continuer, Node, distance_to_one, graph_like, rescale
from ._detection import boundary_node, detect_between
from ._stall import QUICK_STALL, stalled_branch

__all__ = ["Progress", "formatter", "period_defect", "run"]


def formatter(display: tuple[float, str] | None) -> Callable[[float], str]:
    """Format a parameter value (declared unit) for messages: in the display unit, unit ``1`` omitted."""
    if display is None:
        return lambda v: f"{v:.10g}"
    scale, unit = float(display[0]), str(display[1] or "")
    suffix = "" if unit in ("", "1") else f" {unit}"
    return lambda v: f"{v / scale:.10g}{suffix}"


class Progress:
    """A progress bar (tqdm) of a continuation over its parameter range; silent when disabled."""
    def __init__(self, enabled: bool | None, start: float, stop: float, param: str):
        self.bar = None
        if enabled is None:
            enabled = bool(getattr(sys.stderr, "isatty", lambda: False)())
        if enabled:
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=1000, desc=f"continuation in {param}", file=sys.stderr, leave=False,
                                bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} [{elapsed}]")
            except ImportError:  # pragma: no cover
                self.bar = None
        self.start, self.stop = start, stop
        self.done = 0

    def update(self, lam: float, n_points: int, n_bif: int) -> None:
        if self.bar is None:
            return
        span = self.stop - self.start
        frac = 0.0 if span == 0 else min(max((lam - self.start) / span, 0.0), 1.0)
        k = int(1000 * frac)
        if k > self.done:
            self.bar.update(k - self.done)
            self.done = k
        self.bar.set_postfix_str(f"value={lam:.6g} points={n_points} bifurcations={n_bif}", refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run(res: PeriodicOrbitProblem, u0: np.ndarray, start: float, stop: float, *, state_scale: np.ndarray, ds: float,
         ds_min: float, ds_max: float, max_angle: float, max_points: int, tol: float, max_newton: int,
         types: tuple[str, ...], locate: bool, state: int, n_dense: int, progress: bool | None,
         method: str, first: tuple[np.ndarray, np.ndarray] | None = None, parent: Bifurcation | None = None,
         stop_on_merge: bool = False, state_weight: float = 1.0, stall_points: int = 50, stall_tol: float = 1e-5,
         fmt: Callable[[float], str] | None = None, info: dict[str, Any] | None = None) -> Branch:
    """The predictor-corrector loop (shared by :func:`~gearsym.analysis.continuation.continuation`
    and branch switching): a :class:`Branch` from ``start`` until the range is left, the branch
    merges back (``stop_on_merge``) or it cannot advance.  ``info`` is added to the branch's."""
    fmt = fmt or formatter(None)
    extra_info = dict(info or {})
    lo, hi = min(start, stop), max(start, stop)
    lam_scale = abs(stop - start)
    C = Continuer(res, lam_scale=lam_scale, tol=tol, max_newton=max_newton, state=state, n_dense=n_dense,
                   detect=types, state_weight=state_weight)
    C.set_state_scale(state_scale)
    n = res.n
    if first is None:
        # correct at fixed lambda = start, tangent oriented towards stop
        row = np.zeros(n + 1)
        row[-1] = 1.0
        z0 = np.concatenate([u0, [start]])
        t_ref = np.zeros(n + 1)
        t_ref[-1] = 1.0 if stop > start else -1.0
        z, ev, it = C.correct(z0, row, start / C.S[-1], t_ref=t_ref)
        node = C.make_node(z, ev, t_ref, it)
    else:
        z_first, t_first = first
        z, ev, it = C.correct(z_first, t_first, float(t_first @ (z_first / C.S)), t_ref=t_first)
        node = C.make_node(z, ev, t_first, it)
    # scale from the first orbit, then re-express the tangent
    C, node = rescale(C, node, force=True)
    nodes: list[Node] = [node]
    specials: list[tuple[int, str, dict[str, Any]]] = []  # (node index, type, info)
    prog = Progress(progress, start, stop, res.param)
    stop_reason = ""
    complete = False
    h = h_arc = h_nat = float(ds)
    force_arc = False
    n_rejected = 0
    merge_ref = None
    try:
        while True:
            A = nodes[-1]
            if len(nodes) >= max_points:
                stop_reason = (f"max_points={max_points} reached at {res.param} = {fmt(float(A.z[-1]))} before the "
                               f"end of the range ({fmt(stop)}): raise max_points or ds_max")
                break
            wA = A.z / C.S
            # where no turning point is possible (no multiplier near +1) and the state moves fast
            # with the parameter, step in the parameter itself (natural parameter): Newton on a
            # contracting map at fixed parameter is robust even when the branch is kinked by
            # many grazing impacts
            natural = (res.natural_steps and A.graph and abs(A.t[-1]) < 0.7 and not force_arc
                       and distance_to_one(A.point.multipliers) > 0.2)
            h = h_nat if natural else h_arc
            try:
                if natural:
                    row = np.zeros(n + 1)
                    row[-1] = 1.0
                    dl = math.copysign(h, A.t[-1])
                    w_pred = wA.copy()
                    w_pred[-1] += dl
                    z, ev, it = C.correct(w_pred * C.S, row, float(wA[-1]) + dl, t_ref=A.t)
                else:
                    row = A.t
                    z, ev, it = C.correct((wA + h * A.t) * C.S, A.t, float(A.t @ wA) + h, t_ref=A.t)
                B = C.make_node(z, ev, A.t, it, ref=A)
                B.graph = res.natural_steps and graph_like(B.point.multipliers, A.point.multipliers,
                                                           tau_b=B.tau.get("branch_point", math.nan),
                                                           tau_a=A.tau.get("branch_point", math.nan))
                if natural and (B.tau.get("branch_point", math.nan) > 0) != (A.tau.get("branch_point", math.nan) > 0):
                    force_arc = True  # a real multiplier crossed +1: a fold may be near, use the arclength
                    raise ConvergenceError("a multiplier crossed +1 in a parameter step")
                cosang = float(B.t @ A.t)
                if B.graph:
                    cosang = abs(cosang)
                if not natural and cosang < math.cos(max_angle) and h > 4 * ds_min:
                    raise ConvergenceError(f"tangent turned by {math.degrees(math.acos(max(-1, cosang))):.1f} deg")
            except GearsymError as exc:
                n_rejected += 1
                h *= 0.5
                if natural:
                    h_nat = h
                else:
                    h_arc = h
                if h < ds_min:
                    stop_reason = (f"the branch cannot advance: step size below ds_min={ds_min:g} at {res.param} = "
                                   f"{fmt(float(A.z[-1]))} before the end of the range ({fmt(stop)}); last "
                                   f"rejection: {exc}")
                    break
                continue
            lamB = float(B.z[-1])
            leaving = lamB > hi or lamB < lo
            if leaving:
                bound = hi if lamB > hi else lo
                try:
                    B = boundary_node(C, A, B, bound)
                    stop_reason = (f"reached {res.param} = {fmt(bound)}" if bound == (hi if stop > start else lo)
                                   else f"left the range at {res.param} = {fmt(bound)}")
                    complete = True
                except GearsymError as exc:
                    # the branch left the range, but its point at the boundary is not known: the
                    # last point stays the one outside, and the branch does not claim to reach it
                    stop_reason = (f"the branch left the range between {res.param} = {fmt(float(A.z[-1]))} and "
                                   f"{fmt(lamB)}, but its point at {fmt(bound)} could not be corrected "
                                   f"(the last point is outside the range): {exc}")
            new_specials = detect_between(C, A, B, types, locate, row) if types else []
            _append_specials(nodes, specials, new_specials, A, B)
            prog.update(float(B.z[-1]), len(nodes), len(specials))
            if leaving:
                break
            if stop_on_merge:
                d = period_defect(res, float(B.z[-1]), B.point.x0)
                if merge_ref is None:
                    merge_ref = d
                elif d < 1e-4 * max(merge_ref, 1e-300) or d < 1e3 * tol:
                    stop_reason = "merged back into the branch of the base period (period doubling)"
                    complete = True
                    break
                merge_ref = max(merge_ref, d)
            stalled = stalled_branch([(nd.point.value, nd.size, nd.point.multipliers) for nd in
                                      nodes[-max(stall_points, QUICK_STALL[0]) - 1:]], stall_points,
                                     stall_tol * lam_scale, lam_scale, getattr(res, "rtol", 1e-10))
            if stalled:
                k_st, lo_st, hi_st, s0_st, s1_st = stalled
                stop_reason = (f"the branch does not advance: {res.param} stayed within {fmt(lo_st)} .. "
                               f"{fmt(hi_st)} over the last {k_st} points while the orbit's magnitude went "
                               f"from {s0_st:.3g} to {s1_st:.3g} (a resonance of an undamped system: no "
                               f"periodic orbit beyond it; or a multiplier at +1 along the branch)")
                break
            # step control
            force_arc = False
            h_used = h
            if it <= 1:
                h = min(2.0 * h, ds_max)
            elif it <= 3:
                h = min(1.5 * h, ds_max)
            elif it >= 5:
                h = max(0.6 * h, ds_min)
            cosang = abs(float(B.t @ A.t)) if B.graph else float(B.t @ A.t)
            if not natural and cosang < math.cos(0.5 * max_angle):
                h = max(0.7 * h, ds_min)
            h = neutral_step_limit(A.point, B.point, h, h_used, ds_min)
            if natural:
                h_nat = h
            else:
                h_arc = h
            C, nodes[-1] = rescale(C, nodes[-1])
    finally:
        prog.close()
    kinds = {idx: kind for idx, kind, _ in specials}
    points = [replace(nd.point, bifurcation=kinds[i]) if i in kinds else nd.point for i, nd in enumerate(nodes)]
    bifs = [Bifurcation(type=kind, value=float(nodes[idx].z[-1]), point=points[idx], index=idx, info=binfo)
            for idx, kind, binfo in specials]
    setup = ContinuationSetup(
        param=res.param, periods=res.periods, params=dict(res.base_params), segments=getattr(res, "segments", None),
        harmonics=getattr(res, "H", None), t0=res.t0, rtol=res.rtol, atol=res.atol, fd_step=res.fd_step,
        integrator=getattr(res, "method", None), state_scale=tuple(float(v) for v in C.state_scale),
        state_weight=C.state_weight, state=state, n_dense=n_dense, tol=tol, start=start, stop=stop)
    return Branch(param=res.param, points=points, bifurcations=bifs, periods=res.periods, method=method,
                  state=res.system.state_names[state], state_names=res.system.state_names,
                  stop_reason=stop_reason, complete=complete, stop_value=float(nodes[-1].z[-1]), parent=parent,
                  system=res.system, setup=setup,
                  info={"n_rejected_steps": n_rejected, "n_residual_evaluations": res.n_evals,
                        "n_integrations": res.n_integrations, **extra_info})


def _append_specials(nodes: list[Node], specials: list[tuple[int, str, dict[str, Any]]],
                     found: list[tuple[Node, str, dict[str, Any]]], A: Node, B: Node) -> None:
    """Append the special points found between A (the last node) and B, then B: a special point
    that is A or B itself (detected but not located, reported at a branch point) marks that
    point instead of adding it twice."""
    at_b = []
    for nd, kind, binfo in found:
        if nd is A:
            specials.append((len(nodes) - 1, kind, binfo))
        elif nd is B:
            at_b.append((kind, binfo))
        else:
            nodes.append(nd)
            specials.append((len(nodes) - 1, kind, binfo))
    nodes.append(B)
    specials.extend((len(nodes) - 1, kind, binfo) for kind, binfo in at_b)


def period_defect(res: PeriodicOrbitProblem, lam: float, x0: np.ndarray) -> float:
    """``max |x(t0 + P/2) - x(t0)|`` (scaled): zero when a period-2k orbit is a period-k orbit."""
    if res.periods < 2 or int(round(res.periods)) % 2:
        return math.inf
    half = res.period(lam) / 2
    tr = res.system.simulate(t_end=res.t0 + half, t0=res.t0, x0=x0, rtol=res.rtol, atol=res.atol, n_out=2,
                             params=res.params(lam))
    scale = np.maximum(np.abs(x0), 1e-300)
    return float(np.max(np.abs(tr.x_final - x0) / np.maximum(scale, np.max(scale) * 1e-6)))
