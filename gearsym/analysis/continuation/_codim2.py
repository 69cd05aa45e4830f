"""Two-parameter continuation of bifurcation curves of periodic orbits of the hybrid system.

:func:`continue_bifurcation` follows a fold, branch point, period-doubling, Neimark-Sacker or
grazing curve in the plane of two run-time parameters, from a special point located on a
one-parameter branch (:class:`~gearsym.analysis.continuation.CurveStart`) or from a guess:

* the curve is the solution set of a minimally augmented system built on the monodromy with
  saltation (:mod:`._augmented`, :mod:`._augmented_more`: the shooting residual plus one or two
  test functions from bordered systems, or the tangency of the grazing orbit);
* it is continued by pseudo-arclength in ``(x0, lambda_1, lambda_2, extras)`` (:mod:`._curve_tracer`)
  in both directions from the start until it leaves the box of the two parameter ranges;
* the codimension-2 points on it (:data:`~gearsym.analysis.continuation.CODIM2_TYPES`: cusp,
  fold-flip, 1:1 and 1:2 resonances, intersections with grazing curves, ...) are detected by
  their test functions changing sign and located on the curve.

The shooting rows are exact (the engine's variational monodromy with saltation and its parameter
sensitivities); the test functions' derivatives are central differences of the monodromy (their
accuracy and cost in :mod:`._augmented`): ``info["derivatives"]`` of the result says so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import ConvergenceError, GearsymError, ParameterError
from .._inputs import SceneLike, as_system
from .._options import check_tolerances, resolve_options
from ..periodic import floquet
from ._api import _default_atol, _state_scale
from ._augmented import Augmented, BorderedSystem, BranchPointSystem, null_vectors
from ._augmented_more import GrazingSystem, NeimarkSackerSystem
from ._codim2_start import CurveOptions, CurveStart
from ._corrector import _periodic_extremum
from ._curve import CURVE_TYPES, BifurcationCurve, Codim2Point, CurvePoint
from ._curve_tracer import Leg, Node, Tracer, TracerSettings
from ._orbit_map import OrbitMap, check_params, fd_step

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["continue_bifurcation"]

#: the one-parameter special points each curve type may start from
_STARTS = {"fold": ("fold", "branch_point"), "branch_point": ("fold", "branch_point"),
           "period_doubling": ("period_doubling",), "neimark_sacker": ("neimark_sacker",), "grazing": ("grazing",)}


def continue_bifurcation(system: CompiledSystem | SceneLike, follow: str | None, param: str, param2: str,
                         start: float, stop: float, *, start_from: CurveStart | tuple[Any, int],
                         params: Mapping[str, float] | None = None, bounds2: tuple[float, float] | None = None,
                         options: CurveOptions | None = None, **keywords: Any) -> BifurcationCurve:
    """Continue a bifurcation curve of periodic orbits in two parameters.

    Parameters
    ----------
    system
        Compiled system (or a scene, compiled here).
    follow
        The curve: a key of :data:`~gearsym.analysis.continuation.CURVE_TYPES` (``"fold"``,
        ``"branch_point"``, ``"period_doubling"``, ``"neimark_sacker"``, ``"grazing"``); ``None``:
        the type of the special point started from.  A fold asked for at a branch point (a
        multiplier +1 on an orbit that persists through it, e.g. the trivial orbit ``x = 0``) is
        continued as a branch point (``info["formulation"]`` says so).
    param, param2
        The two run-time parameters (declared units), the horizontal and vertical axes of the plane.
    start, stop
        The range of ``param``: the curve ends where it leaves it.
    start_from
        A :class:`~gearsym.analysis.continuation.CurveStart` (:meth:`CurveStart.guess`,
        :meth:`CurveStart.from_branch`), or ``(branch, index)``: the special point ``index`` of a
        branch (a :class:`~gearsym.analysis.continuation.Branch` or its JSON object).
    params
        Other parameter overrides (declared units); they win over the branch's.
    bounds2
        The range of ``param2`` (default: unbounded).
    options
        The settings (:class:`~gearsym.analysis.continuation.CurveOptions`).
    **keywords
        Any of those settings one by one; a keyword wins over ``options``.

    Returns
    -------
    BifurcationCurve
        A curve that stops early is returned, not raised: check ``curve.complete`` and
        ``curve.stop_reasons``.

    Raises
    ------
    ParameterError
        Unknown parameters or curve type, a start outside the ranges, a start of another type,
        bad options.
    ConvergenceError
        No point of the curve near the start.
    """
    system = as_system(system, "continue_bifurcation")
    wall = time.perf_counter()
    o = resolve_options(options, CurveOptions, keywords, "continue_bifurcation")
    check_tolerances(tol=o.tol, rtol=o.rtol, **({"atol": o.atol} if o.atol is not None else {}))
    check_params(system, param, param2)
    if getattr(system.generated, "rigid_modes", None):
        raise ParameterError("bifurcation curves of models with rigid-body modes are not supported (their trivial "
                             "multipliers +1 make every fold test singular)")
    st = start_from if isinstance(start_from, CurveStart) else CurveStart.from_branch(*start_from)
    kind = _kind(follow, st)
    setup = _Setup.make(system, param, param2, start, stop, st, params, bounds2, o)
    aug, tracer, first, formulation = _first_point(setup, kind, st, o)
    legs = _trace(tracer, aug, first, o)
    curve = _assemble(setup, aug, legs, formulation)
    return replace(curve, info={**curve.info, "start": dict(st.info), "wall_s": time.perf_counter() - wall})


def _kind(follow: str | None, st: CurveStart) -> str:
    """The curve type: ``follow``, checked against the special point started from."""
    kind = follow if follow is not None else st.type
    if kind is None:
        raise ParameterError(f"follow: the type of the curve is needed with a guess (one of {', '.join(CURVE_TYPES)})")
    if kind not in CURVE_TYPES:
        raise ParameterError(f"follow: unknown curve type '{kind}' (have: {', '.join(CURVE_TYPES)})")
    if st.type is not None and st.type not in _STARTS[kind]:
        raise ParameterError(f"follow {kind}: the special point started from is a {st.type} (a {kind} curve starts "
                             f"from {' or '.join(_STARTS[kind])})")
    return kind


class _Setup:
    """The resolved task: the system, the parameters, their box and scales, the period map."""

    def __init__(self, **kw: Any):
        self.__dict__.update(kw)

    @classmethod
    def make(cls, system: CompiledSystem, param: str, param2: str, start: float, stop: float, st: CurveStart,
             params: Mapping[str, float] | None, bounds2: tuple[float, float] | None, o: CurveOptions) -> _Setup:
        values = {**st.values, **{k: float(v) for k, v in (params or {}).items()}}
        for name in values:
            if name not in system.params:
                raise ParameterError(f"parameter '{name}' of the start is not a run-time parameter of this system")
        lam0 = np.array([values.get(param, system.params[param]), values.get(param2, system.params[param2])], float)
        box = _box(start, stop, bounds2)
        for k, (name, v) in enumerate(zip((param, param2), lam0, strict=True)):
            lo, hi = box[k]
            if not lo <= v <= hi:
                raise ParameterError(f"the start's {name} = {v:g} lies outside its range {lo:g} .. {hi:g}")
        periods = o.periods or st.periods or 1.0
        if abs(periods - round(periods)) > 1e-9:
            raise ParameterError(f"periods must be a whole number of forcing periods, got {periods:g}")
        t0 = o.t0 if o.t0 is not None else (st.t0 or 0.0)
        base = {k: v for k, v in values.items() if k not in (param, param2)}
        scale2 = o.scale2 or (box[1][1] - box[1][0] if math.isfinite(box[1][1] - box[1][0])
                              else max(abs(float(lam0[1])), 1.0))
        lam_scale = np.array([abs(stop - start), scale2], float)
        x0 = _start_state(system, st, {**base, param: lam0[0], param2: lam0[1]}, t0, periods, o)
        P = float(round(periods)) * float(system.require_period({**base, param: lam0[0], param2: lam0[1]},
                                                                "bifurcation curves"))
        x_scale = _state_scale(system, x0, t0, P, {**base, param: lam0[0], param2: lam0[1]}, max(o.rtol, 1e-9),
                               o.atol or 1e-12)
        atol = o.atol if o.atol is not None else _default_atol(o.rtol, x_scale, system)
        omap = OrbitMap(system, param, param2, base, round(periods), t0, o.rtol, atol, method=o.method)
        return cls(system=system, param=param, param2=param2, box=box, lam0=lam0, x0=x0, lam_scale=lam_scale,
                   x_scale=x_scale, omap=omap, base=base, periods=float(round(periods)), t0=t0, atol=atol)

    def fmt(self, lam: np.ndarray) -> str:
        return f"({self.param}, {self.param2}) = ({lam[0]:.10g}, {lam[1]:.10g})"


def _box(start: float, stop: float, bounds2: tuple[float, float] | None) -> tuple[tuple[float, float], ...]:
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise ParameterError(f"the range of the first parameter must be two different finite values, got "
                             f"{start} .. {stop}")
    lo2, hi2 = (-math.inf, math.inf) if bounds2 is None else (float(bounds2[0]), float(bounds2[1]))
    if math.isnan(lo2) or math.isnan(hi2) or not lo2 < hi2:
        raise ParameterError(f"the range of the second parameter must be lo < hi, got {lo2} .. {hi2}")
    return ((min(start, stop), max(start, stop)), (lo2, hi2))


def _start_state(system: CompiledSystem, st: CurveStart, params: dict[str, float], t0: float, periods: float,
                 o: CurveOptions) -> np.ndarray:
    """The orbit's state at the start: the special point's, the guess's, or after a transient."""
    nx = system.generated.nx
    if st.x0 is not None:
        x0 = np.asarray(st.x0, float)
        if x0.shape != (nx,) or not np.all(np.isfinite(x0)):
            raise ParameterError(f"x0 of the start must have {nx} finite entries ({', '.join(system.state_names)}), "
                                 f"got {x0.tolist()}")
        return x0
    n = o.transient if o.transient is not None else float(system.defaults.get("transient_periods", 50))
    T = float(system.require_period(params, "bifurcation curves"))
    k = max(1, int(math.ceil(n / periods))) * int(round(periods))
    return system.simulate(t_end=t0, t0=t0 - k * T, x0=system.x0, rtol=max(o.rtol, 1e-9), atol=1e-12, n_out=2,
                           params=params).x_final


def _make_system(kind: str, setup: _Setup, st: CurveStart, o: CurveOptions) -> tuple[Augmented, str]:
    """The augmented system of the curve and a description of its formulation."""
    fd = o.fd_step or fd_step(o.rtol)
    omap = setup.omap
    if kind == "branch_point" or (kind == "fold" and (st.type == "branch_point" or (st.type is None
                                                                                      and _persists(setup)))):
        k = None if st.varied is None else (0 if st.varied == setup.param else 1)
        aug = BranchPointSystem(omap, fd, k)
        return aug, ("branch_point: the orbit persists through its multiplier +1 (dF/dlambda in the range of "
                     "M - I), continued as the singularity of [M - I, dF/dlambda_k] with the unfolding F + mu b")
    if kind in ("fold", "period_doubling"):
        return BorderedSystem(omap, fd, kind), f"bordered {'M - I' if kind == 'fold' else 'M + I'}"
    if kind == "neimark_sacker":
        return NeimarkSackerSystem(omap, fd), "bordered M - exp(i omega) I (complex), omega an unknown"
    surface, side = o.surface or st.surface, o.side or st.side
    if surface is None or side is None:
        surface, side = _nearest_touch(setup, surface, side)
    return GrazingSystem(omap, fd, surface, side), (f"g = 0 and dg/dt = 0 of surface '{surface}' ({side} of g) at "
                                                    f"the touching phase theta, an unknown")


def _persists(setup: _Setup) -> bool:
    """Whether the orbit at a guessed start persists through its multiplier +1: ``dF/dlambda``
    orthogonal to the left null vector of ``M - I`` for both parameters (a branch point, not a fold)."""
    run = setup.omap.run(setup.x0, setup.lam0)
    w = null_vectors(run.M - np.eye(len(setup.x0)))[1][:, 0]
    S = run.S * setup.lam_scale[None, :]
    size = np.linalg.norm(S, axis=0)
    tiny = 1e-9 * float(np.max(setup.x_scale))
    return bool(np.all((size <= tiny) | (np.abs(w @ S) <= 1e-5 * size)))


def _nearest_touch(setup: _Setup, surface: str | None, side: str | None) -> tuple[str, str]:
    """The surface and side whose extremum over the start orbit is nearest zero."""
    run = setup.omap.run(setup.x0, setup.lam0, monodromy=False, sens=False, n_samples=1025)
    P = setup.omap.period(setup.lam0)
    t = setup.t0 + P * np.arange(1025) / 1024
    G = setup.system.switching(t, run.samples, p=setup.omap.setup(setup.lam0)[0]).reshape(1025, -1)
    names = list(setup.system.surface_names)
    if not names:
        raise ParameterError("a grazing curve needs a switching surface; this system has none")
    best = None
    for j, name in enumerate(names):
        for sd, v in (("min", float(np.min(G[:, j]))), ("max", float(np.max(G[:, j])))):
            if (surface in (None, name)) and (side in (None, sd)) and (best is None or abs(v) < best[0]):
                best = (abs(v), name, sd)
    if best is None:
        raise ParameterError(f"surface '{surface}' is not a switching surface of this system (have: {', '.join(names)})")
    return best[1], best[2]


def _first_point(setup: _Setup, kind: str, st: CurveStart, o: CurveOptions) -> tuple[Augmented, Tracer, Node, str]:
    """The augmented system, its tracer and the first point of the curve (corrected with the parameter
    the branch did not vary held, else the other)."""
    aug, formulation = _make_system(kind, setup, st, o)
    aug.set_scales(setup.x_scale, setup.lam_scale)
    y0 = aug.start(np.concatenate([setup.x0, setup.lam0]))
    tracer = _tracer(setup, aug, o)
    order = (1, 0) if st.varied == setup.param else (0, 1)
    errors = []
    for fixed in order:
        try:
            first = tracer.first(y0, fixed, float(setup.lam0[fixed]))
            return aug, tracer, tracer.reanchored(first), formulation  # (a section away from the events)
        except GearsymError as exc:
            errors.append(f"with {(setup.param, setup.param2)[fixed]} held: {exc}")
            y0 = aug.start(np.concatenate([setup.x0, setup.lam0]))
    raise ConvergenceError(f"no {aug.kind.replace('_', ' ')} point near the start {setup.fmt(setup.lam0)}: "
                           + "; ".join(errors))


def _tracer(setup: _Setup, aug: Augmented, o: CurveOptions) -> Tracer:
    settings = TracerSettings(ds=o.ds, ds_min=o.ds_min, ds_max=o.ds_max, max_angle=o.max_angle,
                              max_points=o.max_points, tol=o.tol, max_newton=o.max_newton, locate=o.locate,
                              detect=o.detect)
    return Tracer(aug, settings, setup.box, lambda y, ev: _tests(setup, aug, y, ev, o), setup.fmt, explain=_explain)


def _tests(setup: _Setup, aug: Augmented, y: np.ndarray, ev: Any, o: CurveOptions) -> dict[str, float]:
    """The codimension-2 test functions of a point (and its summary for the result, kept in ``ev``).

    Besides the system's own: the extremum of every switching function over the orbit (a sign
    change: the curve crosses a grazing curve) and the number of contact events in a period (a
    change: a local extremum of a switching function crossed zero, a grazing the global extrema
    do not show); the followed surface of a grazing curve is left out of both.
    """
    x, lam, _ = aug.split(y)
    fq = floquet(ev.M, setup.omap.rtol)
    n = max(8, int(o.n_dense * setup.periods))
    run = setup.omap.run(x, lam, monodromy=False, sens=False, n_samples=n + 1)
    samples = run.samples[:-1]
    t = setup.omap.t0 + setup.omap.period(lam) * np.arange(n) / n
    followed = aug.surface if isinstance(aug, GrazingSystem) else None
    ext: dict[str, tuple[float, float]] = {}
    near: tuple[str, str, float, float] | None = None  # (surface, side, local extremum, its range)
    names = list(setup.system.surface_names)
    if names:
        G = setup.system.switching(t, samples, p=setup.omap.setup(lam)[0]).reshape(n, -1)
        for j, name in enumerate(names):
            g = G[:, j]
            ext[name] = (_periodic_extremum(g, int(np.argmin(g)), 1.0), _periodic_extremum(g, int(np.argmax(g)), -1.0))
            if name == followed:
                continue
            for side, v in _local_extrema(g):
                if near is None or abs(v) < abs(near[2]):
                    near = (name, side, v, float(np.ptp(g)))
    y0 = samples[:, 0]
    ev.data["summary"] = {"fq": fq, "ext": ext, "max": float(np.max(y0)), "min": float(np.min(y0)), "near": near}
    tau = aug.tests(y, ev, fq.multipliers)
    for name, (gmin, gmax) in ext.items():
        for side, v in (("min", gmin), ("max", gmax)):
            if isinstance(aug, GrazingSystem) and (name, side) == (aug.surface, aug.side):
                continue
            tau[f"grazing|{name}|{side}"] = v
    skip = names.index(followed) if followed is not None else -1
    tau["count|events"] = float(sum(1 for k in np.asarray(ev.data.get("event_surface", []), int) if k != skip))
    return tau


def _local_extrema(g: np.ndarray) -> list[tuple[str, float]]:
    """The local minima and maxima of a periodic sequence (parabolic refinement)."""
    d_prev = g - np.roll(g, 1)
    d_next = np.roll(g, -1) - g
    out = []
    for i in np.nonzero(d_prev * d_next <= 0)[0].tolist():
        if d_prev[i] < 0 <= d_next[i] or d_prev[i] <= 0 < d_next[i]:
            out.append(("min", _periodic_extremum(g, i, 1.0)))
        elif d_prev[i] > 0 >= d_next[i] or d_prev[i] >= 0 > d_next[i]:
            out.append(("max", _periodic_extremum(g, i, -1.0)))
    return out


def _explain(node: Node) -> str:
    """Why a curve may not advance past a point: an orbit about to touch a switching surface."""
    near = (node.ev.data.get("summary") or {}).get("near")
    if near is None or not abs(near[2]) < 0.02 * max(near[3], 1e-300):
        return ""
    name, side, v, _ = near
    return (f"; there the orbit is within {abs(v):.2g} of touching '{name}' (a local {side} of g): a grazing, "
            f"where the period map is not smooth")


def _trace(tracer: Tracer, aug: Augmented, first: Node, o: CurveOptions) -> list[tuple[Leg, str]]:
    """The legs of the curve from its first point: ``[(leg, "forward" | "backward")]`` (forward: the
    first parameter increasing at the start; the second where the first does not move)."""
    row_scales = tracer.Rs.copy()  # equilibrated at the first point
    t0_first = aug.omap.t0  # its section
    i = aug.nx
    sign = first.t[i] if abs(first.t[i]) > 1e-6 else first.t[i + 1]
    fwd = 1.0 if sign >= 0 else -1.0
    dirs = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[o.direction]
    legs: list[tuple[Leg, str]] = []
    for name in dirs:
        if legs:
            if legs[0][0].stop_reason == "the curve closed on itself":
                break
            aug.omap.t0 = t0_first  # the section and the borders of the first point again
            aug.accept(first.y, first.ev)
        tracer.Rs = row_scales.copy()
        legs.append((tracer.trace(first, fwd if name == "forward" else -fwd), name))
    return legs


def _assemble(setup: _Setup, aug: Augmented, legs: list[tuple[Leg, str]], formulation: str) -> BifurcationCurve:
    """The curve: the backward leg reversed, then the forward leg (their first points shared)."""
    nodes: list[Node] = []
    specials: list[tuple[int, str, dict[str, Any]]] = []
    by_name = {name: leg for leg, name in legs}
    if "backward" in by_name:
        leg = by_name["backward"]
        nodes = list(reversed(leg.nodes))
        specials = [(len(leg.nodes) - 1 - i, name, info) for i, name, info in leg.specials]
    start_index = max(len(nodes) - 1, 0)
    if "forward" in by_name:
        leg = by_name["forward"]
        nodes = nodes[:start_index] + leg.nodes
        specials += [(start_index + i, name, info) for i, name, info in leg.specials]
    points = [_point(setup, aug, nd) for nd in nodes]
    special_points = [Codim2Point(name, points[i].value, points[i].value2, points[i], i, info)
                      for i, name, info in sorted(specials, key=lambda s: s[0])]
    omap = setup.omap
    info = {"formulation": formulation, "params": dict(setup.base), "rtol": omap.rtol,
            "atol": omap.atol, "box": [list(b) for b in setup.box],
            "derivatives": _derivatives_note(aug, omap), "n_integrations": omap.n_integrations,
            "n_rejected_steps": sum(leg.n_rejected for leg, _ in legs)}
    return BifurcationCurve(type=aug.kind, param=setup.param, param2=setup.param2, points=points,
                            special_points=special_points, start_index=start_index,
                            stop_reasons=[f"{name}: {leg.stop_reason}" for leg, name in legs],
                            complete=all(leg.complete for leg, _ in legs), periods=setup.periods,
                            state_names=list(setup.system.state_names), info=info)


def _derivatives_note(aug: Augmented, omap: OrbitMap) -> str:
    sens = ("exact (the engine's parameter sensitivities)" if omap.exact_sensitivities
            else "central differences of the end state")
    return (f"shooting rows: M - I from the variational equations with saltation, dF/dlambda {sens}; test-function "
            f"rows: central differences of the monodromy with relative step {aug.fd:.3g} (error ~ step^2 + "
            f"rtol/step, relative); the curve is where the test functions vanish to tol")


def _point(setup: _Setup, aug: Augmented, nd: Node) -> CurvePoint:
    x, lam, _ = aug.split(nd.y)
    summ = nd.ev.data.get("summary")
    if summ is None:  # detection off: the multipliers only
        summ = {"fq": floquet(nd.ev.M, setup.omap.rtol), "ext": {}, "max": math.nan, "min": math.nan}
    fq = summ["fq"]
    return CurvePoint(value=float(lam[0]), value2=float(lam[1]), x0=np.asarray(x, float).copy(),
                      t0=float(nd.ev.data.get("t0", setup.t0)), period=setup.omap.period(lam),
                      multipliers=fq.multipliers, stability=fq.stability,
                      n_unstable=int(fq.n_unstable), extras=aug.describe(nd.y, nd.ev), max=summ["max"],
                      min=summ["min"], surface_extrema=summ["ext"], n_events=int(nd.ev.data.get("n_events", 0)),
                      residual=float(np.max(np.abs(nd.ev.R / aug.residual_scales()))), iterations=int(nd.iterations))
