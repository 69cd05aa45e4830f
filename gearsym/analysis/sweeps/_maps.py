"""Two-parameter stability / response maps (Vaishya & Singh Figs. 5 and 10).

:func:`stability_map` evaluates, on a grid over two run-time parameters, the
maximum Floquet multiplier modulus ``max |mu|`` of the periodic orbit (the
stability parameter lambda of V&S section 6), the peak-to-peak of the first
state over the orbit, and the rattle state, and returns an ``xarray.Dataset``;
:func:`save_map` writes it to netCDF with a heat-map PNG.

Per grid point the method is

* ``"exact"``: the monodromy as a product of matrix exponentials
  (:class:`~gearsym.analysis.periodic.PiecewiseLTV`), for linear systems with
  piecewise-constant coefficients (V&S formulation A, Meissner);
* ``"shooting"``: the periodic orbit by Newton shooting and its monodromy from the
  engine's variational equations (any explicit model; for a linear system the
  orbit solve is one Newton step);
* ``"hbm"``: harmonic balance;
* ``"auto"`` (default): ``"exact"`` where the system is piecewise-constant LTV, else
  ``"shooting"``.

The grid is cut into rows (tasks, each a sweep in ``x`` that starts every Newton
solve from the previous point's orbit) and run on all local cores by default
(worker processes that die with their parent, :mod:`gearsym.analysis.sweeps._workers`) or on a
Dask cluster when a scheduler address (or a ``distributed.Client``) is passed: both run
the same task function, and the workers get the compiled system itself (a
:class:`~gearsym.system.System` pickles: it reloads its build from the build cache by key,
never recompiles; the build must be in that cache on the worker's machine).  A local
worker that crashes (a segmentation fault in compiled code) fails the points of its task,
with the signal as their error; the other tasks go on.  Scripts that build maps in parallel
need an ``if __name__ == "__main__"`` guard, as with any ``multiprocessing`` code (workers
start a fresh interpreter).

A map tells the truth at every point: where the orbit found is unstable, the stable response
is searched for (:mod:`gearsym.analysis.sweeps._map_points`); a point without one is marked
(``response = 0``) and hatched in the figure, never shown with the unstable orbit's rattle
state or amplitude.

Grid values, ``params`` and the coordinates of the result are in the model's declared
units (as ``--set``; :class:`~gearsym.spec.units.ParameterUnits`), with the SI values as
``<name>_si`` coordinates.
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import LIMITS, check_count, check_counts, check_orbit_options
from ...display import netcdf_engine
from ...errors import ParameterError
from ...files import atomic_path, save_figure
from ...progress import progress_bar
from ...quantities import map_quantities
from ...spec.settings import resolve_settings
from .._inputs import SceneLike, is_scene
from .._options import resolve_options
from ..periodic import (
    ORBIT_METHODS,
    NotPiecewiseConstantError,
    exact_multipliers,
    floquet,
    rigid_state_basis,
    whole_periods,
)
from . import _coexist, _workers
from ._coexist_figure import attractor_panels, draw_panels, outline_coexistence
from ._map_points import EXACT_RTOL, RESPONSE, SEARCH, empty_point, map_point

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from ...system import CompiledSystem

__all__ = ["MAP_METHODS", "QUANTITIES", "MapOptions", "save_map", "stability_map"]

_log = logging.getLogger(__name__)

#: The gear quantities a map can show (gearsym.quantities), with their meanings.
GEAR_QUANTITIES = map_quantities()
#: Quantities a map can show (all are stored; ``quantity`` picks the plotted one).
QUANTITIES: dict[str, str] = {
    "max_multiplier": "maximum Floquet multiplier modulus max|mu| (unstable > 1)",
    "peak_to_peak": "peak-to-peak of the first state over the periodic orbit",
    "rattle_state": "0 no contact loss, 1 contact loss only, 2 back-side contact",
    "lyapunov": "largest Lyapunov exponent of the response (log max|mu| / T of a periodic one; computed for the "
                "attractor reached where there is none)",
    **{k: f"{v[1]} (the worst mesh)" for k, v in GEAR_QUANTITIES.items()},
}

#: Largest map (grid points): every point keeps its orbit summary, about 1 kB.
MAX_POINTS = LIMITS["map_points"].high

_STABILITY_CODE = {"asymptotically_stable": 0, "neutral": 1, "unstable": 2}
#: Methods of a map: the exact matrix-exponential path (``auto`` picks it where it applies) and
#: the periodic-orbit solvers (:data:`gearsym.analysis.periodic.ORBIT_METHODS`).
MAP_METHODS = ("auto", "exact", *ORBIT_METHODS)


# ----------------------------------------------------------------- one point
def _run_chunk(system: CompiledSystem, task: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Task function (module level, picklable): one run of grid points in x."""
    base = dict(task["params"])
    guess = None if task.get("x0") is None else np.asarray(task["x0"], float)
    res = []
    for (xv, yv) in task["points"]:
        params = dict(base)
        params[task["xname"]] = float(xv)
        params[task["yname"]] = float(yv)
        r = map_point(system, params, task["method"], task["periods"], guess, task["want_ptp"], task["options"],
                      gear=task.get("gear"))
        if r["response"] == 1 and r["x0"] is not None and np.all(np.isfinite(r["x0"])):
            # the next point starts from this point's response (never from an unstable orbit)
            guess = np.asarray(r["x0"], float)
        res.append(r)
    return res


def _failed_chunk(task: Mapping[str, Any], message: str) -> list[dict[str, Any]]:
    """The points of a task whose worker process died (a crash in compiled code): failed,
    with the reason as their error."""
    return [{**empty_point(task["method"]), "error": message} for _ in task["points"]]


def _run_tasks(system: CompiledSystem, tasks: list[dict[str, Any]], dask: Any,
               n_workers: int, progress: Any = None) -> tuple[list[dict[str, Any]], str]:
    """Run the row tasks serially, on local worker processes or on Dask
    (:func:`gearsym.analysis.sweeps.run_tasks`); the points of a task whose worker died fail.
    Tasks with the coexistence search or the Lyapunov exponent run :func:`._coexist.run_rows`."""
    fn = _coexist.run_rows if tasks and (tasks[0].get("coexist") or tasks[0].get("lyapunov")) else _run_chunk
    chunks, runner = _workers.run_tasks(fn, system, tasks, workers=n_workers, dask=dask, progress=progress,
                                        weights=[len(t["points"]) for t in tasks])
    flat: list[dict[str, Any]] = []
    for task, chunk in zip(tasks, chunks, strict=True):
        flat += _failed_chunk(task, chunk.message) if isinstance(chunk, _workers.TaskFailure) else chunk
    return flat, runner


# ----------------------------------------------------------------- the map
def _axis(spec: Sequence[Any], what: str) -> tuple[str, np.ndarray]:
    if len(spec) != 4:
        raise ParameterError(f"{what} must be (NAME, LO, HI, N), got {spec!r}")
    name, lo, hi, n = spec
    check_count(f"{what} N", n, rule="map_axis")  # before np.linspace allocates
    n = int(n)
    lo, hi = float(lo), float(hi)
    if n < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"{what}: need finite LO, HI and N >= 1 (got {lo}, {hi}, {n})")
    return str(name), np.linspace(lo, hi, n)


@dataclass(frozen=True)
class MapOptions:
    """Settings of :func:`stability_map` (each also accepted as a keyword).

    Attributes
    ----------
    method : str or None
        ``"auto"``, ``"exact"``, ``"shooting"`` or ``"hbm"`` (module docstring).
    periods : float or None
        Orbit period in forcing periods (a positive whole number).

        ``method``, ``periods`` (with the quantity and the ``harmonics`` and ``rtol`` of
        ``orbit_options``) not given take the values of the scene's ``[map]`` table, else ``"auto"``,
        1 (one resolution with ``gearsym map``: :func:`gearsym.spec.settings.resolve_settings`).
    params : mapping or None
        Further parameter overrides (declared units) for every point.
    dask : str or distributed.Client or None
        Scheduler address (``"tcp://host:8786"``) or a ``distributed.Client``: run the tasks on that
        cluster.  Default: a process pool on all local cores.
    workers : int or None
        Local processes (default ``os.cpu_count()``; 1: run in this process).
    rows_per_task : int or None
        Grid rows per task (default: enough tasks for 4 per worker).
    orbit_options : mapping or None
        Passed to the orbit solver (e.g. ``{"rtol": 1e-9}``, ``{"harmonics": 32}``).
    x0 : sequence of float or None
        Initial guess of the orbit at the first point of every row (default: the scene's initial state
        after a transient); every other point starts from the previous point's response.
    search : str, sequence, bool, SearchOptions or None
        The coexistence search (:mod:`gearsym.analysis.sweeps._coexist`): ``"auto"`` (default: every
        search on maps of at most :data:`~gearsym.analysis.sweeps._coexist.COEXIST_DEFAULT_POINTS` points
        of a nonlinear model), ``"none"``, ``"all"``, a subset of ``rows``, ``columns``, ``starts``, or
        a :class:`~gearsym.analysis.sweeps.SearchOptions`.
    progress : bool or None
        A progress bar (:func:`gearsym.progress.progress_bar`: ``tqdm.auto``); ``None``: where someone
        watches (stderr a terminal, or a notebook).
    """

    method: str | None = None
    periods: float | None = None
    params: Mapping[str, float] | None = None
    dask: Any = None
    workers: int | None = None
    rows_per_task: int | None = None
    orbit_options: Mapping[str, Any] | None = None
    x0: Sequence[float] | None = None
    search: Any = "auto"
    progress: bool | None = None


def stability_map(target: SceneLike | CompiledSystem, x: Sequence[Any], y: Sequence[Any],
                  quantity: str | None = None, options: MapOptions | None = None, **keywords: Any) -> xr.Dataset:
    """Evaluate a stability / response map over two parameters.

    Parameters
    ----------
    target
        A scene or its compiled system.
    x, y
        ``(NAME, LO, HI, N)``: parameter and grid of each axis (declared units, as ``--set``).
    quantity
        One of :data:`QUANTITIES` (the one plotted; ``max_multiplier`` and ``rattle_state`` are
        always stored, ``peak_to_peak`` when asked for, ``lyapunov`` when asked for or with the
        coexistence search); default: the scene's ``[map]`` table, else ``"max_multiplier"``.
    options
        The other settings (:class:`MapOptions`).
    **keywords
        Fields of :class:`MapOptions` given one by one (``method=``, ``periods=``, ``params=``,
        ``dask=``, ``workers=``, ``rows_per_task=``, ``orbit_options=``, ``x0=``, ``search=``,
        ``progress=``); they override ``options``.

    Returns
    -------
    xarray.Dataset
        Variables ``max_multiplier``, ``stable`` (0/1), ``stability`` (0 asymptotically
        stable, 1 neutral, 2 unstable: the rule of :mod:`gearsym.analysis.periodic._stability`,
        which treats multipliers on the unit circle within the monodromy's error as
        neutral, e.g. undamped systems), ``rattle_state``,
        ``converged``, ``iterations`` (and ``peak_to_peak``) on dims ``(y, x)`` named by
        the parameters, with the grid (declared units) as coordinates and the SI values as
        ``<name>_si`` coordinates.  The response is never an unstable orbit
        (:mod:`gearsym.analysis.sweeps._map_points`): ``response`` is 1 where a stable periodic
        orbit is the response (``rattle_state``, ``peak_to_peak`` are its), 0 where none
        was found (those are left empty; ``max_multiplier`` and ``stability`` are the
        unstable orbit's), -1 where the solve failed; ``response_search`` says how the
        response was found, ``unstable_max_multiplier`` / ``unstable_rattle_state`` record
        the unstable orbit found at a point.  With the coexistence search, every attractor
        found at each point along the dimension ``attractor`` and ``n_stable``
        (:mod:`gearsym.analysis.sweeps._coexist`); with the quantity ``lyapunov`` (or the search),
        ``lyapunov``, ``lyapunov_error``, ``response_kind``.  Attributes ``n_failed``,
        ``n_no_stable_response``, ``wall_s``, ``points_per_second``, ``orbit_solves``,
        ``periods_integrated`` (by the searches), ``coexist_search``.
    """
    opts = resolve_options(options, MapOptions, keywords, "stability_map")
    check_counts(workers=opts.workers, rows_per_task=opts.rows_per_task)  # bounded work (gearsym.budget)
    wall = time.perf_counter()
    grid = _Grid.of(x, y)
    scene: Any = target if is_scene(target) else None
    # the scene's [map] table under the caller's values: one resolution with `gearsym map`
    table = (scene.spec.extra if scene is not None else getattr(target, "settings", {})).get("map")
    quantity, method, periods, orbit_options = _settings(table, quantity, opts.method, opts.periods,
                                                         opts.orbit_options)
    system = scene.compile() if scene is not None else target
    base = _check_parameters(system, scene, grid, opts.params)
    x0 = opts.x0
    if x0 is not None and np.shape(x0) != (system.generated.nx,):
        raise ParameterError(f"x0 must have {system.generated.nx} entries ({', '.join(system.state_names)}), got "
                             f"shape {np.shape(x0)}")
    want_ptp = quantity == "peak_to_peak"
    gear = quantity if quantity in GEAR_QUANTITIES else None  # a gear quantity (gearsym.quantities)
    if gear and not system.generated.meshes:
        raise ParameterError(f"quantity '{gear}': model '{system.name}' has no mesh elements")
    n_workers = int(opts.workers or os.cpu_count() or 1)
    flat: list[dict[str, Any]] | None = None
    runner = ""
    coexist = None
    bar = progress_bar(opts.progress, grid.size, f"map {grid.xname} x {grid.yname}", unit="pt")
    try:
        if method in ("auto", "exact") and not want_ptp and not gear:
            flat = _exact_points(system, [dict(base, **{grid.xname: float(xv), grid.yname: float(yv)})
                                          for yv in grid.ys for xv in grid.xs], periods, required=method == "exact")
            runner = "vectorised (exact)"
            if flat is not None:
                _exact_lyapunov(system, flat, grid, base, periods, quantity == "lyapunov")
                bar(grid.size)
        if flat is None:
            forced = system.period(base) is not None
            if quantity == "lyapunov" and not forced:
                raise ParameterError("the quantity lyapunov needs a forcing period (the exponents of an autonomous "
                                     "model: gearsym lyapunov --block-time)")
            coexist = _coexist.resolve_search(opts.search, grid.size, _coexist.is_linear(system, base)) \
                if forced else None  # (the search lands on attractors at whole forcing periods)
            flat, runner = _shooting_points(system, grid, base, quantity, method, periods, orbit_options, x0,
                                            opts, n_workers, coexist, bar, gear)
    finally:
        bar.close()
    _log.info("stability map of %s: %d x %d points (%s x %s), %s, %d failed, coexistence search %s", system.name,
              len(grid.xs), len(grid.ys), grid.xname, grid.yname, runner, sum(1 for r in flat if r.get("error")),
              ",".join(coexist.search) if coexist is not None else "off")
    ds = _dataset(system, flat, grid.xname, grid.xs, grid.yname, grid.ys, want_ptp, gear)
    ds = _coexist.add_layers(ds, flat, system.state_names, _mesh_names(system), coexist)
    wall_s = time.perf_counter() - wall
    ds.attrs.update({
        "title": f"{QUANTITIES[quantity]} over {grid.xname} x {grid.yname}",
        "quantity": quantity,
        "scene": system.name,
        "method": method,
        "periods": float(periods),
        "params_json": json.dumps(base, sort_keys=True),
        "runner": runner,
        "wall_s": wall_s,
        "points_per_second": grid.size / max(wall_s, 1e-300),
        "orbit_solves": int(sum(r.get("search_stats", {}).get("solves", 0) for r in flat)),
        "periods_integrated": int(sum(r.get("search_stats", {}).get("periods", 0) for r in flat)),
        "coexist_search": ",".join(coexist.search) if coexist is not None else "none",
        "source": "gearsym.analysis.sweeps.stability_map",
        "stability_rule": "gearsym.analysis.periodic.floquet (neutral band from the monodromy error)",
    })
    return ds


def _shooting_points(system: CompiledSystem, grid: _Grid, base: dict[str, float], quantity: str, method: str,
                     periods: int, orbit_options: dict[str, Any], x0: Sequence[float] | None, opts: MapOptions,
                     n_workers: int, coexist: Any, bar: Any, gear: str | None = None
                     ) -> tuple[list[dict[str, Any]], str]:
    """The points of an orbit-solver map: the row tasks (with the coexistence search's rows and starts
    when on), then the column tasks of the search."""
    common = {"xname": grid.xname, "yname": grid.yname, "method": method, "periods": periods,
              "want_ptp": quantity == "peak_to_peak", "options": dict(orbit_options), "params": base,
              "x0": None if x0 is None else [float(v) for v in x0], "row_length": len(grid.xs),
              "coexist": coexist, "lyapunov": quantity == "lyapunov", "gear": gear}
    if coexist is not None and "columns" in coexist.search and len(grid.ys) > 1:
        bar.set_total(2 * grid.size)  # one bar over both phases
    tasks = _row_tasks(grid, opts.rows_per_task, n_workers, common)
    flat, runner = _run_tasks(system, tasks, opts.dask, n_workers, bar)
    if coexist is not None and "columns" in coexist.search:
        bar.describe(f"map {grid.xname} x {grid.yname} (columns)")
        params = [dict(base, **{grid.xname: float(xv), grid.yname: float(yv)}) for yv in grid.ys for xv in grid.xs]
        _coexist.column_phase(system, flat, (len(grid.ys), len(grid.xs)), params,
                              {"method": method, "options": dict(orbit_options), "coexist": coexist},
                              n_workers, opts.dask, bar)
    return flat, runner


def _exact_lyapunov(system: CompiledSystem, flat: list[dict[str, Any]], grid: _Grid, base: dict[str, float],
                    periods: int, wanted: bool) -> None:
    """The largest Lyapunov exponent of a linear system's points (exact path): ``log max|mu| / (k T)``,
    that of every solution (unbounded where it is positive)."""
    if not wanted:
        return
    for r, (yv, xv) in zip(flat, ((yv, xv) for yv in grid.ys for xv in grid.xs), strict=True):
        T = system.period({**base, grid.xname: float(xv), grid.yname: float(yv)}) or math.nan
        mu = float(r["max_multiplier"])
        r.update(lyapunov=math.log(mu) / (periods * T) if mu > 0 else -math.inf, lyapunov_error=math.nan,
                 response_kind=0 if r["response"] == 1 else -1)


def _mesh_names(system: CompiledSystem) -> list[str]:
    return list(getattr(system.generated, "meshes", []) or [])


@dataclass(frozen=True)
class _Grid:
    """The two axes of a map: parameter names and grid values (declared units)."""

    xname: str
    xs: np.ndarray
    yname: str
    ys: np.ndarray

    @classmethod
    def of(cls, x: Sequence[Any], y: Sequence[Any]) -> _Grid:
        xname, xs = _axis(x, "x")
        yname, ys = _axis(y, "y")
        if len(xs) * len(ys) > MAX_POINTS:
            raise ParameterError(f"a map of {len(xs)} x {len(ys)} = {len(xs) * len(ys):.3g} points is above the "
                                 f"limit of {MAX_POINTS:,} points (about 1 kB of memory each); use coarser axes or "
                                 f"several maps")
        if xname == yname:
            raise ParameterError("the two axes must be different parameters")
        return cls(xname, xs, yname, ys)

    @property
    def size(self) -> int:
        """Number of points."""
        return len(self.xs) * len(self.ys)


def _settings(table: Mapping[str, Any] | None, quantity: str | None, method: str | None, periods: float | None,
              orbit_options: Mapping[str, Any] | None) -> tuple[str, str, int, dict[str, Any]]:
    """The map's quantity, method, periods and orbit options: the caller's, else the scene's
    ``[map]`` table, else the defaults; checked once (not as a failure at every point)."""
    given = dict(orbit_options or {})
    st = resolve_settings("map", table, quantity=quantity, method=method, periods=periods,
                          harmonics=given.pop("harmonics", None), rtol=given.pop("rtol", None))
    quantity, method, periods = st["quantity"], st["method"], st["periods"]
    options = {**given, **{k: st[k] for k in ("harmonics", "rtol") if st[k] is not None}}
    check_orbit_options(options)  # once here, not as a failure at every point
    if quantity not in QUANTITIES:
        raise ParameterError(f"quantity must be one of {', '.join(QUANTITIES)}, got '{quantity}'")
    if method not in MAP_METHODS:
        raise ParameterError(f"method must be {', '.join(MAP_METHODS)}, got '{method}'")
    return quantity, method, whole_periods(periods), options  # a whole number of forcing periods


def _check_parameters(system: CompiledSystem, scene: Any, grid: _Grid, params: Mapping[str, float] | None
                      ) -> dict[str, float]:
    """The parameters of every point (the system's, with ``params`` over them), after the axes
    are checked to be run-time parameters and the corners of the grid to be in range."""
    for nm in (grid.xname, grid.yname):
        if scene is not None and nm not in scene.model_spec.parameters:
            raise ParameterError(f"'{nm}' is not a parameter of model {scene.model_spec.name} "
                                 f"(have: {', '.join(scene.model_spec.parameters)})")
        if nm not in system.param_names:
            raise ParameterError(f"'{nm}' is not a run-time parameter of this system (have: "
                                 f"{', '.join(system.param_names)}); parameters of switched-off effects "
                                 f"are not inputs")
    base = dict(system.params)
    base.update({k: float(v) for k, v in (params or {}).items()})
    system.param_vector(base)  # validates
    for xv in (grid.xs[0], grid.xs[-1]):  # the physical ranges of the values (gearsym.spec.rules) at the corners: exit 2
        for yv in (grid.ys[0], grid.ys[-1]):
            system.param_vector({**base, grid.xname: float(xv), grid.yname: float(yv)})
    return base


def _row_tasks(grid: _Grid, rows_per_task: int | None, n_workers: int, common: dict[str, Any]) -> list[dict[str, Any]]:
    """The grid cut into tasks of whole rows (each a sweep in ``x``), enough for 4 per worker."""
    ny = len(grid.ys)
    if rows_per_task is None:
        rows_per_task = max(1, int(math.ceil(ny / max(1, 4 * n_workers))))
    tasks = []
    for j0 in range(0, ny, rows_per_task):
        pts = [(float(xv), float(grid.ys[j])) for j in range(j0, min(ny, j0 + rows_per_task)) for xv in grid.xs]
        tasks.append({"points": pts, **common, "options": dict(common["options"]), "first_index": j0 * len(grid.xs)})
    return tasks


def _exact_points(system: CompiledSystem, pts: list[dict[str, float]], periods: int,
                  required: bool) -> list[dict[str, Any]] | None:
    """The fast path of a linear system with piecewise-constant coefficients: every point at once
    (one mapped Jacobian call, batched expm); ``None`` where it does not apply (raised when
    ``required``)."""
    try:
        _, monos, errs = exact_multipliers(system, pts, periods=periods, monodromies=True)
    except NotPiecewiseConstantError:
        if required:
            raise
        return None
    return [_exact_record(floquet(M, max(float(e), EXACT_RTOL), rigid_state_basis(system, pt)))
            for M, e, pt in zip(monos, errs, pts, strict=True)]


def _exact_record(fq: Any) -> dict[str, Any]:
    """The record of a point of the vectorised exact path (a linear system: one orbit; unstable,
    no periodic response)."""
    out = empty_point("exact")
    unstable = fq.stability == "unstable"
    ok = bool(np.isfinite(fq.max_multiplier))
    out.update(max_multiplier=fq.max_multiplier, stability=fq.stability, converged=ok,
               response=(0 if unstable else 1) if ok else -1, response_search=0 if ok and not unstable else -1,
               unstable_max_multiplier=fq.max_multiplier if unstable else math.nan)
    return out


def _dataset(system: CompiledSystem, flat: list[dict[str, Any]], xname: str, xs: np.ndarray, yname: str, ys: np.ndarray,
             want_ptp: bool, gear: str | None = None) -> xr.Dataset:
    """The map's variables and coordinates from the point records (row-major in ``y``, ``x``)."""
    import xarray as xr

    ny, nx = len(ys), len(xs)
    floats = {k: np.full((ny, nx), np.nan) for k in ("max_multiplier", "peak_to_peak", "unstable_max_multiplier",
                                                      *((gear,) if gear else ()))}
    ints = {k: np.full((ny, nx), -1, dtype=np.int8) for k in ("rattle_state", "stability", "response",
                                                             "response_search", "unstable_rattle_state")}
    conv = np.zeros((ny, nx), dtype=np.int8)
    iters = np.zeros((ny, nx), dtype=np.int32)
    methods: set[str] = set()
    errors: list[str] = []
    for idx, r in enumerate(flat):
        j, i = divmod(idx, nx)
        for k, a in floats.items():
            a[j, i] = r.get(k, np.nan)
        for k, a in ints.items():
            a[j, i] = _STABILITY_CODE.get(r.get("stability", "unknown"), -1) if k == "stability" else r[k]
        conv[j, i] = 1 if r["converged"] else 0
        iters[j, i] = r["iterations"]
        methods.add(r["method"])
        if r["error"] and len(errors) < 5:
            errors.append(f"({xname}={xs[i]:g}, {yname}={ys[j]:g}): {r['error'][:300]}")
    stab, resp = ints["stability"], ints["response"]
    dims = (yname, xname)
    data = {
        "max_multiplier": (dims, floats["max_multiplier"], {"long_name": QUANTITIES["max_multiplier"] + " of the "
                           "response; where there is none (response 0), of the unstable orbit found"}),
        "stable": (dims, np.where(stab >= 0, (stab < 2).astype(np.int8), -1).astype(np.int8),
                   {"long_name": "1 stable (no multiplier outside the unit circle beyond its tolerance, "
                                 "gearsym.analysis.periodic._stability), 0 unstable, -1 unknown"}),
        "stability": (dims, stab, {"long_name": "0 asymptotically stable, 1 neutral (on the unit circle "
                                                "within the monodromy's error), 2 unstable, -1 unknown"}),
        "response": (dims, resp, {"long_name": "; ".join(f"{k} {v}" for k, v in RESPONSE.items())}),
        "response_search": (dims, ints["response_search"],
                            {"long_name": "how the response was found: " +
                                          "; ".join(f"{k} {v}" for k, v in SEARCH.items())}),
        "rattle_state": (dims, ints["rattle_state"], {"long_name": QUANTITIES["rattle_state"] + " of the response "
                                                      "(-1: no stable response, none or unknown)"}),
        "unstable_max_multiplier": (dims, floats["unstable_max_multiplier"],
                                    {"long_name": "max|mu| of an unstable orbit found at the point (never the "
                                                  "response; NaN: none found)"}),
        "unstable_rattle_state": (dims, ints["unstable_rattle_state"],
                                  {"long_name": "rattle state of that unstable orbit (-1: none)"}),
        "converged": (dims, conv, {"long_name": "an orbit was found (1) or the solve failed (0)"}),
        "iterations": (dims, iters, {"long_name": "Newton / quasi-Newton iterations"}),
    }
    if want_ptp:
        data["peak_to_peak"] = (dims, floats["peak_to_peak"], {"long_name": QUANTITIES["peak_to_peak"] + " (the "
                                                               "response's; NaN: no stable response)"})
    if gear:
        data[gear] = (dims, floats[gear], {"long_name": f"{QUANTITIES[gear]} of the response (NaN: no stable "
                                                        "response)"})
    units = system.units
    si = units.to_si({xname: xs, yname: ys})
    coords = {
        xname: (xname, xs, {"units": units.unit(xname) or "SI"}),
        yname: (yname, ys, {"units": units.unit(yname) or "SI"}),
        f"{xname}_si": (xname, si[xname]),
        f"{yname}_si": (yname, si[yname]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({"methods_used": ",".join(sorted(methods)), "n_points": int(nx * ny),
                     "n_failed": int(np.sum(conv == 0)), "n_no_stable_response": int(np.sum(resp == 0)),
                     "errors": "\n".join(errors)})
    return ds


# ------------------------------------------------------------------- output
def _hatch(ax: Any, X: np.ndarray, Y: np.ndarray, response: np.ndarray) -> None:
    """Hatch the cells without a stable periodic response (``//``) and the failed ones (``xx``),
    with a legend entry for each kind present."""
    from matplotlib.patches import Patch

    handles = []
    for code, hatch, label in ((0, "//", "no stable periodic response"), (-1, "xx", "no orbit (failed)")):
        mask = response == code
        if not mask.any():
            continue
        ax.pcolor(X, Y, np.ma.masked_where(~mask, np.ones(mask.shape)), shading="nearest", hatch=hatch,
                  facecolor="none" if code == 0 else "0.85", edgecolor="0.25", linewidth=0.0)
        handles.append(Patch(facecolor="none" if code == 0 else "0.85", edgecolor="0.25", hatch=hatch, label=label))
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.85)


def save_map(ds: xr.Dataset, out_dir: str | Path, quantity: str | None = None, stem: str = "map"
             ) -> list[Path]:
    """Write ``<stem>.nc`` (netCDF) and ``<stem>.png`` (heat map) into ``out_dir``.

    The heat map shows ``quantity`` (default: the dataset's) over the two axes;
    for ``max_multiplier`` the colour scale is centred on 1 and the boundary of the
    unstable region (the ``stable`` variable of the stability rule) is drawn as a contour.
    Points without a stable periodic response (``response`` 0) are hatched ``//`` and have
    no response colour (rattle state, peak-to-peak, Lyapunov exponent); failed points are hatched
    ``xx``.  A map with the coexistence layers gets more panels in the same figure
    (:mod:`gearsym.analysis.sweeps._coexist_figure`): the cells with coexisting stable responses are
    outlined on the heat map, a panel shows how many coexist (non-periodic attractors hatched), and one
    panel per response index shows each one's ``quantity``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    nc = out / f"{stem}.nc"
    with atomic_path(nc) as tmp:
        ds.to_netcdf(tmp, engine=netcdf_engine())
    q = quantity or str(ds.attrs.get("quantity", "max_multiplier"))
    if q not in ds:
        raise ParameterError(f"the map has no variable '{q}' (have: {', '.join(ds.data_vars)})")
    yname, xname = ds[q].dims
    X, Y = ds[xname].values, ds[yname].values
    Z = ds[q].values.astype(float)
    resp = ds["response"].values if "response" in ds else None
    if resp is not None and (q in ("rattle_state", "peak_to_peak") or q in GEAR_QUANTITIES):
        Z[resp != 1] = np.nan  # the response's quantity: none where there is no stable response
    extra = attractor_panels(ds)
    ncols = min(3, 1 + extra)
    nrows = -(-(1 + extra) // ncols)
    fig = plt.figure(figsize=(7 + 6 * (ncols - 1), 5.2 * nrows))
    ax = fig.add_subplot(nrows, ncols, 1)
    if q == "max_multiplier":
        zmin, zmax = np.nanmin(Z), np.nanmax(Z)
        lo = min(zmin, 0.999) if np.isfinite(zmin) else 0.5
        hi = max(zmax, 1.001) if np.isfinite(zmax) else 1.5
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="RdBu_r", norm=TwoSlopeNorm(1.0, lo, hi))
        if "stable" in ds and min(Z.shape) > 1:
            st = ds["stable"].values.astype(float)
            st[st < 0] = np.nan
            if np.nanmin(st) < 0.5 < np.nanmax(st):
                ax.contour(X, Y, st, levels=[0.5], colors="k", linewidths=0.8)
    elif q == "rattle_state":
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="viridis", vmin=-1, vmax=2)
    elif q == "lyapunov" and np.isfinite(Z).any():
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="RdBu_r", norm=TwoSlopeNorm(
            0.0, min(float(np.nanmin(Z)), -1e-12), max(float(np.nanmax(Z)), 1e-12)))
    else:
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="viridis")
    cb = fig.colorbar(pc, ax=ax)
    cb.set_label(q.replace("_", " "))
    if resp is not None:
        _hatch(ax, X, Y, resp)
    xu = ds[xname].attrs.get("units", "")
    yu = ds[yname].attrs.get("units", "")
    ax.set_xlabel(f"{xname} [{xu}]" if xu and xu != "1" else xname)
    ax.set_ylabel(f"{yname} [{yu}]" if yu and yu != "1" else yname)
    ax.set_title(f"{ds.attrs.get('scene', '')}: {q.replace('_', ' ')}")
    if extra:
        outline_coexistence(ax, X, Y, ds["n_stable"].values)
        draw_panels(fig, [fig.add_subplot(nrows, ncols, 2 + k) for k in range(extra)], ds, q)
    fig.tight_layout()
    png = out / f"{stem}.png"
    save_figure(fig, png, dpi=120)
    plt.close(fig)
    return [nc, png]
