"""One work-precision run of a scene (error against wall time of every method, in one run)
and ``gearsym bench``'s whole report for a scene."""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..options import merge_options
from .events import RunTimeout
from .measures import _grid_crossings, _normalised_error, _stat_deviation, _statistics, pareto_report
from .model import PythonModel
from .orbits import analysis_costs
from .peers import METHOD_NAMES, _Context, make_methods
from .reference import Reference, make_reference
from .timing import _time_round_robin, compile_times, environment

__all__ = ["DEFAULT_RTOLS", "DIVERGENCE_LEVEL", "EXTRA_RTOLS", "WorkPrecisionOptions", "bench_scene", "parse_rtols",
           "run_work_precision", "scene_atol_ratio"]

#: Relative tolerances of a work-precision run (1e-3 ... 1e-10; 1e-11, 1e-12 where the
#: reference is exact or good enough).
DEFAULT_RTOLS: tuple[float, ...] = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
EXTRA_RTOLS: tuple[float, ...] = (1e-11, 1e-12)
#: Normalised difference of the two references beyond which the regime counts as
#: diverging (chaotic) and errors are no longer measured.
DIVERGENCE_LEVEL = 1e-8


@dataclass(frozen=True)
class WorkPrecisionOptions:
    """The settings of one :func:`run_work_precision` (each with its default).

    Parameters
    ----------
    label
        Name of the case in tables (default: the scene name).
    rtols
        Relative tolerances (default :data:`DEFAULT_RTOLS`, plus 1e-11 and 1e-12 when
        ``extra_rtols``).
    periods, t_end
        Horizon (default: the scene's ``[simulate] periods``, else 100 periods).
    points_per_period
        Output grid density (the error is the largest over the grid; default 32).
    methods
        Subset of :data:`~gearsym.bench.peers.METHOD_NAMES` (default: all).
    extra_rtols
        Also run rtol 1e-11 and 1e-12 (default: when the reference's floor is below
        1e-13, e.g. an exact reference).
    rounds, slot, single_run_s
        Timing: warm-up, then ``rounds`` interleaved rounds (default 3) of about ``slot``
        seconds (default 0.1) per method (a method slower than ``single_run_s``, default 2 s,
        is timed once).
    max_seconds
        A method slower than this at one tolerance is skipped at the tighter ones (default 20 s).
    stats_skip_periods
        Transient left out of the statistics (default: a tenth of the horizon).
    """

    label: str | None = None
    rtols: Sequence[float] | None = None
    periods: float | None = None
    t_end: float | None = None
    points_per_period: int = 32
    methods: Sequence[str] | None = None
    extra_rtols: bool | None = None
    rounds: int = 3
    slot: float = 0.1
    single_run_s: float = 2.0
    max_seconds: float = 20.0
    stats_skip_periods: float | None = None


@dataclass(frozen=True)
class _Case:
    """The horizon, grid and reference of one work-precision run."""

    T: float | None
    t_end: float
    grid: np.ndarray
    x0: np.ndarray
    reference: Reference
    scale: np.ndarray
    floor: float
    i_h: int
    skip: int
    pm: Any
    lambdify_s: float


def run_work_precision(scene, options: WorkPrecisionOptions | None = None, *, reference: Reference | None = None,
                       x0: Sequence[float] | None = None, params: Mapping[str, float] | None = None,
                       progress: Callable[[str], None] | None = None, system=None, **keywords: Any) -> dict[str, Any]:
    """Work-precision data of one scene (see the module docstring).

    Parameters
    ----------
    scene
        A :class:`gearsym.Scene`.
    options
        The settings (:class:`WorkPrecisionOptions`: tolerances, horizon, grid, methods, timing).
    reference
        A reference on the grid; default :func:`make_reference`.
    x0, params
        Initial state (default: the scene's) and parameter overrides (declared units).
    progress
        Called with one-line progress messages.
    system
        An already compiled system of ``scene`` (default: ``scene.compile()``).
    **keywords
        The fields of :class:`WorkPrecisionOptions` as keywords, overriding those of ``options``.

    Returns
    -------
    dict
        JSON-ready: case, grid, reference, divergence, results (one row per method and
        rtol: best_s, median_s, error, error_final, stats, ...), statistics.

    Raises
    ------
    ParameterError
        An unknown keyword (named, with the closest one).
    """
    o = merge_options(WorkPrecisionOptions, options, keywords, "run_work_precision")
    say = progress or (lambda s: None)
    system = system if system is not None else scene.compile()
    names = list(o.methods or METHOD_NAMES)
    case = _case(scene, system, o, names, reference, x0, params, say)
    extra = case.floor < 1e-13 if o.extra_rtols is None else o.extra_rtols
    rtols = list(o.rtols) if o.rtols is not None else list(DEFAULT_RTOLS) + (list(EXTRA_RTOLS) if extra else [])
    ctx = _Context(system, case.pm, case.x0, case.grid, dict(params) if params else None, case.T)
    mlist = make_methods(ctx, names)
    for m in mlist:
        m.max_run_s = max(3 * o.max_seconds, 30.0)
    ref_stats = _statistics(case.reference.y, system.state_names, case.skip)
    ref_cross = _grid_crossings(case.pm, case.grid, case.reference.y, case.skip)
    results: list[dict[str, Any]] = []
    too_slow: dict[str, float] = {}
    atol_ratio = scene_atol_ratio(scene)
    for rtol in rtols:
        ready, rows = _set_up(mlist, rtol, rtol * atol_ratio, too_slow, o.max_seconds)
        say(f"rtol {rtol:g}: {', '.join(m.name for _, m in ready)}")
        firsts, times = _time_round_robin([m.run for _, m in ready], o.rounds, o.slot, o.single_run_s)
        for (row, m), first, ts in zip(ready, firsts, times):
            _measure_row(row, m, first, ts, case, system, (ref_stats, ref_cross), too_slow, o.max_seconds)
        results += rows
    g = {r["rtol"]: r for r in results if r["method"] == "gearsym" and "best_s" in r}
    for r in results:
        if "best_s" in r and r["rtol"] in g:
            r["ratio_to_gearsym"] = r["best_s"] / g[r["rtol"]]["best_s"]
    data = _report(scene, system, o, case, params, atol_ratio, (ref_stats, ref_cross), rtols, results)
    data["pareto"] = pareto_report(data)
    return data


def _case(scene, system, o: WorkPrecisionOptions, names: list[str], reference: Reference | None,
          x0: Sequence[float] | None, params: Mapping[str, float] | None, say: Callable[[str], None]) -> _Case:
    """The horizon and output grid, the reference on it, its floor and divergence horizon."""
    sim = scene.spec.simulate
    T = system.period(params)
    t_end, periods = o.t_end, o.periods
    if t_end is None:
        if periods is None:
            periods = float(sim.get("periods", 100)) if T else None
        t_end = float(periods) * T if T else float(sim.get("t_end", 100.0))
    n_out = int(round(t_end / T * o.points_per_period)) + 1 if T else 1001
    grid = np.linspace(0.0, t_end, n_out)
    grid[-1] = t_end
    x0v = np.asarray(system.x0 if x0 is None else x0, dtype=float)
    need_py = any(not n.startswith("gearsym") and n != "CasADi cvodes" for n in names) or reference is None
    t = time.perf_counter()
    pm = PythonModel(scene.model, system, params) if need_py else None
    lambdify_s = time.perf_counter() - t
    # state scales from a gearsym run at the scene's tolerance
    probe = system.simulate(t_end=t_end, x0=x0v, t_out=grid, params=params,
                            rtol=float(sim.get("rtol", 1e-8)), atol=float(sim.get("atol", 1e-10)))
    scale = np.max(np.abs(probe.y), axis=0)
    if reference is None:
        say("reference ...")
        reference = make_reference(system, pm, x0v, grid, params, atol_scale=np.where(scale > 0, scale, 1.0))
    y_ref = reference.y
    scale = np.max(np.abs(y_ref), axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    # reference floor and divergence horizon
    if reference.y_check is not None:
        u = _normalised_error(reference.y_check, y_ref, scale)
        beyond = np.nonzero(u > DIVERGENCE_LEVEL)[0]
        i_h = int(beyond[0]) if beyond.size else grid.size
        floor = float(np.max(u[:i_h])) if i_h > 0 else float("nan")
    else:
        i_h = grid.size
        floor = 1e-14
    skip = int(round((o.stats_skip_periods if o.stats_skip_periods is not None else 0.1 * t_end / (T or 1))
                     * (o.points_per_period if T else n_out / t_end)))
    skip = min(max(skip, 0), grid.size - 2)
    return _Case(T, t_end, grid, x0v, reference, scale, max(floor, 1e-15), i_h, skip, pm, lambdify_s)


def _set_up(mlist: list[Any], rtol: float, atol: float, too_slow: dict[str, float], max_seconds: float
            ) -> tuple[list[tuple[dict[str, Any], Any]], list[dict[str, Any]]]:
    """The rows of one tolerance, and the methods set up for it (those not skipped or failed)."""
    rows, ready = [], []
    for m in mlist:
        row: dict[str, Any] = {"method": m.name, "description": m.description, "events": m.events,
                               "gearsym": m.gearsym, "rtol": rtol, "atol": atol}
        if m.name in too_slow:
            row["skipped"] = f"slower than {max_seconds:g} s at rtol {too_slow[m.name]:g}"
            rows.append(row)
            continue
        try:
            t = time.perf_counter()
            m.setup(rtol, atol)
            row["setup_s"] = time.perf_counter() - t
            ready.append((row, m))
        except Exception as exc:
            row["failed"] = f"setup: {type(exc).__name__}: {exc}"
        rows.append(row)
    return ready, rows


def _measure_row(row: dict[str, Any], m: Any, first: Any, ts: list[float], case: _Case, system,
                 ref: tuple[Any, Any], too_slow: dict[str, float], max_seconds: float) -> None:
    """Fill ``row`` with the error, timing and statistics of one method's run at one tolerance."""
    rtol, i_h, y_ref = row["rtol"], case.i_h, case.reference.y
    if isinstance(first, Exception):
        row["failed"] = f"{type(first).__name__}: {first}"[:500]
        if isinstance(first, RunTimeout):
            too_slow[m.name] = rtol
        return
    y = np.asarray(first.y, dtype=float)
    if y.shape != y_ref.shape or not np.all(np.isfinite(y)):
        row["failed"] = "non-finite or mis-shaped output"
        return
    err = _normalised_error(y, y_ref, case.scale)
    best = min(ts)
    row.update(best_s=best, median_s=statistics.median(ts), repeats=len(ts),
               error=float(np.max(err[:i_h])) if i_h > 0 else float("nan"),
               error_final=float(err[i_h - 1]) if i_h > 0 else float("nan"),
               error_full_horizon=float(np.max(err)),
               below_floor=bool(np.max(err[:i_h]) <= 10 * case.floor) if i_h > 0 else False,
               **{k: v for k, v in first.stats.items()})
    for k in ("n_steps", "n_rhs", "n_events"):
        row.setdefault(k, None)
    row["statistics"] = _statistics(y, system.state_names, case.skip)
    row["grid_crossings"] = _grid_crossings(case.pm, case.grid, y, case.skip)
    row["statistics_deviation"] = _stat_deviation(row, ref[0], ref[1], case.scale, system.state_names)
    if best > max_seconds:
        too_slow[m.name] = rtol


def _report(scene, system, o: WorkPrecisionOptions, case: _Case, params: Mapping[str, float] | None,
            atol_ratio: float, ref: tuple[Any, Any], rtols: list[float], results: list[dict[str, Any]]
            ) -> dict[str, Any]:
    """The JSON-ready data of one run (without its Pareto report)."""
    T, grid, i_h, reference = case.T, case.grid, case.i_h, case.reference
    chaotic = i_h < grid.size
    return {
        "case": o.label or scene.name,
        "scene": str(scene.path),
        "params": {k: float(v) for k, v in system.params.items()} | (dict(params) if params else {}),
        "x0": case.x0.tolist(),
        "state_names": system.state_names,
        "forcing_period": T,
        "t_end": case.t_end,
        "periods": (case.t_end / T) if T else None,
        "points_per_period": o.points_per_period if T else None,
        "n_grid": int(grid.size),
        "atol_rule": f"atol = rtol * {atol_ratio:g} (the scene's atol/rtol)",
        "error_definition": ("max over the output grid (up to the divergence horizon) of max_i |y_i - y_ref_i| "
                             "/ max_t |y_ref_i| (each state scaled by its largest magnitude)"),
        "state_scale": case.scale.tolist(),
        "reference": {"kind": reference.kind, "description": reference.description,
                      "wall_s": reference.wall_s, "events": reference.events, "floor": case.floor},
        "lambdify_s": case.lambdify_s,
        "divergence": {"chaotic": chaotic, "level": DIVERGENCE_LEVEL,
                       "horizon_t": float(grid[i_h - 1]) if i_h > 0 else 0.0,
                       "horizon_periods": (grid[i_h - 1] / T) if (T and i_h > 0) else None,
                       "note": ("the two references drift apart beyond the horizon (sensitive/chaotic "
                                "regime): errors are measured up to it, statistics over the whole run")
                       if chaotic else "the two references agree over the whole horizon"},
        "statistics_reference": {"states": ref[0], "grid_crossings": ref[1], "skip_points": case.skip},
        "statistics_deviation_definition": ("largest of |mean - mean_ref| / scale and |rms - rms_ref| / scale over "
                                            "the states (after the first tenth of the run), and the relative "
                                            "difference of the number of surface crossings seen on the grid"),
        "rtols": list(rtols),
        "results": results,
    }


def parse_rtols(text: str) -> list[float]:
    """``"1e-4,1e-6"`` -> ``[1e-4, 1e-6]``, each in ``[1e-15, 1)``."""
    out = []
    for item in text.split(","):
        try:
            v = float(item)
        except ValueError:
            raise ParameterError(f"--rtols: '{item}' is not a number") from None
        if not (math.isfinite(v) and 1e-15 <= v < 1):
            raise ParameterError(f"--rtols: {item} is not a usable relative tolerance (need 1e-15 <= rtol < 1)")
        out.append(v)
    return sorted(set(out), reverse=True)



def bench_scene(scene, *, rtols: Sequence[float] | None = None, methods: Sequence[str] | None = None,
                periods: float | None = None, points_per_period: int = 32, rounds: int = 3,
                compile_timing: bool = True, reference: Reference | None = None, label: str | None = None,
                progress: Callable[[str], None] | None = None, analyses: bool = True,
                **kw: Any) -> dict[str, Any]:
    """Everything ``gearsym bench`` reports for one scene: environment, compile times,
    the work-precision data and the cost of the periodic-orbit analyses.

    Returns
    -------
    dict
        ``{"benchmark", "environment", "compile", "case", "analysis"}``.
    """
    say = progress or (lambda s: None)
    comp = None
    if compile_timing:
        say("compile times (cold in a fresh folder, then cached) ...")
        comp = compile_times(scene.path, scene.resolved.effects)  # parameters never change the build
    system = scene.compile()
    data = run_work_precision(scene, label=label, rtols=rtols, periods=periods,
                              points_per_period=points_per_period, methods=methods, rounds=rounds,
                              reference=reference, progress=say, system=system, **kw)
    analysis = None
    if analyses:
        say("periodic-orbit analyses ...")
        analysis = analysis_costs(system, data["rtols"], kw.get("params"), scene_atol_ratio(scene), say)
    return {"benchmark": "work_precision", "environment": environment(), "compile": comp, "case": data,
            "analysis": analysis}


def scene_atol_ratio(scene) -> float:
    """The scene's ``atol / rtol`` (``[simulate]``): every tolerance of a sweep keeps it."""
    sim = scene.spec.simulate
    return float(sim.get("atol", 1e-10)) / float(sim.get("rtol", 1e-8))

