"""The pseudo-arclength predictor-corrector loop of the continuation.

Predictor along the unit tangent (or a step in the parameter itself where the
branch is a graph over it), corrector (:class:`~gearsym.analysis.continuation._corrector.Continuer`),
step control, detection and location of special points between accepted points
(:mod:`gearsym.analysis.continuation._detection`), and the conditions under which a branch ends.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import ConvergenceError, GearsymError
from ...progress import progress_bar
from ..periodic import PeriodicOrbitProblem, neutral_step_limit
from ._branch import Bifurcation, Branch, ContinuationSetup
from ._corrector import Continuer, Node, distance_to_one, graph_like, rescale
from ._detection import boundary_node, detect_between
from ._stall import QUICK_STALL, stalled_branch

_log = logging.getLogger(__name__)

if TYPE_CHECKING:  # pragma: no cover
    from ._options import ContinuationOptions

__all__ = ["Leg", "Progress", "formatter", "period_defect", "run"]


def formatter(display: tuple[float, str] | None) -> Callable[[float], str]:
    """Format a parameter value (declared unit) for messages: in the display unit, unit ``1`` omitted."""
    if display is None:
        return lambda v: f"{v:.10g}"
    scale, unit = float(display[0]), str(display[1] or "")
    suffix = "" if unit in ("", "1") else f" {unit}"
    return lambda v: f"{v / scale:.10g}{suffix}"


class Progress:
    """The progress bar of a continuation over its parameter range (:mod:`gearsym.progress`:
    ``tqdm.auto`` in terminals and notebooks; silent when not wanted)."""

    def __init__(self, enabled: bool | None, start: float, stop: float, param: str):
        self.bar = progress_bar(enabled, 1000, f"continuation in {param}",
                                bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} [{elapsed}]")
        self.start, self.stop = start, stop
        self.done = 0

    def update(self, lam: float, n_points: int, n_bif: int) -> None:
        """Show the fraction of the range covered, the value and the counts."""
        span = self.stop - self.start
        frac = 0.0 if span == 0 else min(max((lam - self.start) / span, 0.0), 1.0)
        k = int(1000 * frac)
        if k > self.done:
            self.bar(k - self.done)
            self.done = k
        self.bar.postfix(f"value={lam:.6g} points={n_points} bifurcations={n_bif}")

    def close(self) -> None:
        self.bar.close()


@dataclass(frozen=True)
class Leg:
    """One run of the predictor-corrector loop (:func:`run`): the range and the settings.

    Attributes
    ----------
    start, stop : float
        The parameter range: the branch starts at ``start`` and ends when it leaves the range.
    options : ContinuationOptions
        The resolved settings (``ds``, ``ds_min``, ``ds_max``, ``max_angle``, ``max_points``,
        ``tol``, ``max_newton``, ``locate``, ``progress``, ``state_weight``, ``stall_points``,
        ``stall_tol`` are read; none of them ``None``).
    types : tuple of str
        The special points to detect.
    state : int
        The observed state.
    n_dense : int
        Samples per forcing period of the dense output.
    method : str
        The periodic-orbit method of the problem (``"shooting"``, ``"hbm"``).
    state_scale : ndarray
        The state magnitudes of the first orbit.
    fmt : callable
        Formats a parameter value for messages.
    first : tuple or None
        ``(z, tangent)``: the first corrector on the hyperplane through ``z`` orthogonal to the
        tangent (branch switching); default: at fixed ``lambda = start``.
    parent : Bifurcation or None
        The bifurcation the branch was switched at.
    stop_on_merge : bool
        End when the orbit merges back into the branch of half its period.
    info : mapping
        Added to the branch's ``info``.
    """

    start: float
    stop: float
    options: ContinuationOptions
    types: tuple[str, ...]
    state: int
    n_dense: int
    method: str
    state_scale: np.ndarray
    fmt: Callable[[float], str] = field(default_factory=lambda: formatter(None))
    first: tuple[np.ndarray, np.ndarray] | None = None
    parent: Bifurcation | None = None
    stop_on_merge: bool = False
    info: Mapping[str, Any] = field(default_factory=dict)


def run(res: PeriodicOrbitProblem, u0: np.ndarray, leg: Leg) -> Branch:
    """The predictor-corrector loop (shared by :func:`~gearsym.analysis.continuation.continuation`
    and branch switching): a :class:`Branch` from ``leg.start`` until the range is left, the branch
    merges back (``leg.stop_on_merge``) or it cannot advance.

    Parameters
    ----------
    res
        The periodic-orbit problem.
    u0
        Its unknowns at (or near) the first orbit.
    leg
        The range and the settings.

    Returns
    -------
    Branch
    """
    return _Tracer(res, leg).trace(u0)


class _Tracer:
    """The state of one run of the loop: the corrector, the accepted nodes, the special points,
    the step sizes (arclength and natural-parameter) and why the branch ended."""

    def __init__(self, res: PeriodicOrbitProblem, leg: Leg):
        o = leg.options
        self.res, self.leg, self.o = res, leg, o
        self.lo, self.hi = min(leg.start, leg.stop), max(leg.start, leg.stop)
        self.lam_scale = abs(leg.stop - leg.start)
        self.C = Continuer(res, lam_scale=self.lam_scale, tol=o.tol, max_newton=o.max_newton, state=leg.state,
                           n_dense=leg.n_dense, detect=leg.types, state_weight=o.state_weight)
        self.C.set_state_scale(leg.state_scale)
        self.nodes: list[Node] = []
        self.specials: list[tuple[int, str, dict[str, Any]]] = []  # (node index, type, info)
        self.stop_reason = ""
        self.complete = False
        self.h_arc = self.h_nat = float(o.ds)
        self.force_arc = False
        self.n_rejected = 0
        self.merge_ref: float | None = None

    def trace(self, u0: np.ndarray) -> Branch:
        """Run the loop from ``u0`` and assemble the branch."""
        self._first_node(u0)
        prog = Progress(self.o.progress, self.leg.start, self.leg.stop, self.res.param)
        try:
            while self._advance(prog):
                pass
        finally:
            prog.close()
        return self._branch()

    def _first_node(self, u0: np.ndarray) -> None:
        C, leg, n = self.C, self.leg, self.res.n
        if leg.first is None:
            # correct at fixed lambda = start, tangent oriented towards stop
            row = np.zeros(n + 1)
            row[-1] = 1.0
            z0 = np.concatenate([u0, [leg.start]])
            t_ref = np.zeros(n + 1)
            t_ref[-1] = 1.0 if leg.stop > leg.start else -1.0
            z, ev, it = C.correct(z0, row, leg.start / C.S[-1], t_ref=t_ref)
            node = C.make_node(z, ev, t_ref, it)
        else:
            z_first, t_first = leg.first
            z, ev, it = C.correct(z_first, t_first, float(t_first @ (z_first / C.S)), t_ref=t_first)
            node = C.make_node(z, ev, t_first, it)
        # scale from the first orbit, then re-express the tangent
        self.C, node = rescale(C, node, force=True)
        self.nodes.append(node)

    def _advance(self, prog: Progress) -> bool:
        """One predictor-corrector step (and the detection between the two points); ``False``
        when the branch ends."""
        o, res, fmt, A = self.o, self.res, self.leg.fmt, self.nodes[-1]
        if len(self.nodes) >= o.max_points:
            self.stop_reason = (f"max_points={o.max_points} reached at {res.param} = {fmt(float(A.z[-1]))} before "
                                f"the end of the range ({fmt(self.leg.stop)}): raise max_points or ds_max")
            return False
        # where no turning point is possible (no multiplier near +1) and the state moves fast
        # with the parameter, step in the parameter itself (natural parameter): Newton on a
        # contracting map at fixed parameter is robust even when the branch is kinked by
        # many grazing impacts
        natural = (res.natural_steps and A.graph and abs(A.t[-1]) < 0.7 and not self.force_arc
                   and distance_to_one(A.point.multipliers) > 0.2)
        h = self.h_nat if natural else self.h_arc
        try:
            B, row, it = self._step(A, natural, h)
        except GearsymError as exc:
            return self._reject(A, natural, h, exc)
        lamB = float(B.z[-1])
        leaving = lamB > self.hi or lamB < self.lo
        if leaving:
            B = self._at_boundary(A, B, lamB)
        new_specials = detect_between(self.C, A, B, self.leg.types, o.locate, row) if self.leg.types else []
        _append_specials(self.nodes, self.specials, new_specials, A, B)
        prog.update(float(B.z[-1]), len(self.nodes), len(self.specials))
        if leaving or self._merged(B) or self._stalled():
            return False
        self._control_step(A, B, it, natural, h)
        return True

    def _step(self, A: Node, natural: bool, h: float) -> tuple[Node, np.ndarray, int]:
        """Predict from ``A`` by ``h`` and correct: the new node, the corrector's row and its
        iterations; raises where the step is refused."""
        C, res, n, o = self.C, self.res, self.res.n, self.o
        wA = A.z / C.S
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
            self.force_arc = True  # a real multiplier crossed +1: a fold may be near, use the arclength
            raise ConvergenceError("a multiplier crossed +1 in a parameter step")
        cosang = float(B.t @ A.t)
        if B.graph:
            cosang = abs(cosang)
        if not natural and cosang < math.cos(o.max_angle) and h > 4 * o.ds_min:
            raise ConvergenceError(f"tangent turned by {math.degrees(math.acos(max(-1, cosang))):.1f} deg")
        return B, row, it

    def _reject(self, A: Node, natural: bool, h: float, exc: GearsymError) -> bool:
        """A refused step: halve it; ``False`` (the branch ends) below ``ds_min``."""
        o, fmt = self.o, self.leg.fmt
        self.n_rejected += 1
        h *= 0.5
        if natural:
            self.h_nat = h
        else:
            self.h_arc = h
        if h < o.ds_min:
            self.stop_reason = (f"the branch cannot advance: step size below ds_min={o.ds_min:g} at {self.res.param} = "
                                f"{fmt(float(A.z[-1]))} before the end of the range ({fmt(self.leg.stop)}); last "
                                f"rejection: {exc}")
            return False
        return True

    def _at_boundary(self, A: Node, B: Node, lamB: float) -> Node:
        """The point where the branch leaves the range (``B`` itself if it cannot be corrected)."""
        leg, fmt, param = self.leg, self.leg.fmt, self.res.param
        bound = self.hi if lamB > self.hi else self.lo
        try:
            B = boundary_node(self.C, A, B, bound)
            self.stop_reason = (f"reached {param} = {fmt(bound)}" if bound == (self.hi if leg.stop > leg.start
                                                                                 else self.lo)
                                else f"left the range at {param} = {fmt(bound)}")
            self.complete = True
        except GearsymError as exc:
            # the branch left the range, but its point at the boundary is not known: the
            # last point stays the one outside, and the branch does not claim to reach it
            self.stop_reason = (f"the branch left the range between {param} = {fmt(float(A.z[-1]))} and "
                                f"{fmt(lamB)}, but its point at {fmt(bound)} could not be corrected "
                                f"(the last point is outside the range): {exc}")
        return B

    def _merged(self, B: Node) -> bool:
        """Branch switching: the doubled orbit merged back into the branch of the base period."""
        if not self.leg.stop_on_merge:
            return False
        d = period_defect(self.res, float(B.z[-1]), B.point.x0)
        if self.merge_ref is None:
            self.merge_ref = d
        elif d < 1e-4 * max(self.merge_ref, 1e-300) or d < 1e3 * self.o.tol:
            self.stop_reason = "merged back into the branch of the base period (period doubling)"
            self.complete = True
            return True
        self.merge_ref = max(self.merge_ref, d)
        return False

    def _stalled(self) -> bool:
        """The parameter stays put while the orbit grows (:mod:`gearsym.analysis.continuation._stall`)."""
        o, fmt = self.o, self.leg.fmt
        stalled = stalled_branch([(nd.point.value, nd.size, nd.point.multipliers) for nd in
                                  self.nodes[-max(o.stall_points, QUICK_STALL[0]) - 1:]], o.stall_points,
                                 o.stall_tol * self.lam_scale, self.lam_scale, getattr(self.res, "rtol", 1e-10))
        if not stalled:
            return False
        k_st, lo_st, hi_st, s0_st, s1_st = stalled
        self.stop_reason = (f"the branch does not advance: {self.res.param} stayed within {fmt(lo_st)} .. "
                            f"{fmt(hi_st)} over the last {k_st} points while the orbit's magnitude went "
                            f"from {s0_st:.3g} to {s1_st:.3g} (a resonance of an undamped system: no "
                            f"periodic orbit beyond it; or a multiplier at +1 along the branch)")
        return True

    def _control_step(self, A: Node, B: Node, it: int, natural: bool, h: float) -> None:
        """The next step size from the corrector's effort, the tangent's turn and the multipliers."""
        o = self.o
        self.force_arc = False
        h_used = h
        if it <= 1:
            h = min(2.0 * h, o.ds_max)
        elif it <= 3:
            h = min(1.5 * h, o.ds_max)
        elif it >= 5:
            h = max(0.6 * h, o.ds_min)
        cosang = abs(float(B.t @ A.t)) if B.graph else float(B.t @ A.t)
        if not natural and cosang < math.cos(0.5 * o.max_angle):
            h = max(0.7 * h, o.ds_min)
        h = neutral_step_limit(A.point, B.point, h, h_used, o.ds_min)
        if natural:
            self.h_nat = h
        else:
            self.h_arc = h
        self.C, self.nodes[-1] = rescale(self.C, self.nodes[-1])

    def _branch(self) -> Branch:
        """The branch of the accepted nodes and the special points found."""
        res, leg, nodes, C = self.res, self.leg, self.nodes, self.C
        kinds = {idx: kind for idx, kind, _ in self.specials}
        points = [replace(nd.point, bifurcation=kinds[i]) if i in kinds else nd.point for i, nd in enumerate(nodes)]
        bifs = [Bifurcation(type=kind, value=float(nodes[idx].z[-1]), point=points[idx], index=idx, info=binfo)
                for idx, kind, binfo in self.specials]
        setup = ContinuationSetup(
            param=res.param, periods=res.periods, params=dict(res.base_params), segments=getattr(res, "segments", None),
            harmonics=getattr(res, "H", None), t0=res.t0, rtol=res.rtol, atol=res.atol, fd_step=res.fd_step,
            integrator=getattr(res, "method", None), state_scale=tuple(float(v) for v in C.state_scale),
            state_weight=C.state_weight, state=leg.state, n_dense=leg.n_dense, tol=self.o.tol, start=leg.start,
            stop=leg.stop)
        _log.info("continuation in %s: %d points, %s; %s", res.param, len(points),
                  ", ".join(f"{b.type} at {b.value:.6g}" for b in bifs) or "no special point",
                  f"stopped: {self.stop_reason}" if self.stop_reason else "complete")
        return Branch(param=res.param, points=points, bifurcations=bifs, periods=res.periods, method=leg.method,
                      state=res.system.state_names[leg.state], state_names=res.system.state_names,
                      stop_reason=self.stop_reason, complete=self.complete, stop_value=float(nodes[-1].z[-1]),
                      parent=leg.parent, system=res.system, setup=setup,
                      info={"n_rejected_steps": self.n_rejected, "n_residual_evaluations": res.n_evals,
                            "n_integrations": res.n_integrations, "corrector": C.engine_report(),
                            **dict(leg.info)})


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
