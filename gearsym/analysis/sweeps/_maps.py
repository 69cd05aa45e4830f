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
from ...errors import ParameterError
from ...files import atomic_path, save_figure
from ...quantities import map_quantities
from ...spec.settings import resolve_settings
from .._inputs import SceneLike, is_scene
from ..periodic import (
    ORBIT_METHODS,
    NotPiecewiseConstantError,
    exact_multipliers,
    floquet,
    rigid_state_basis,
    whole_periods,
)
from . import _workers
from ._map_points import EXACT_RTOL, RESPONSE, SEARCH, empty_point, map_point

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from ...system import CompiledSystem

__all__ = ["QUANTITIES", "save_map", "stability_map"]

_log = logging.getLogger(__name__)

#: The gear quantities a map can show (gearsym.quantities), with their meanings.
GEAR_QUANTITIES = map_quantities()
#: Quantities a map can show (all are stored; ``quantity`` picks the plotted one).
QUANTITIES: dict[str, str] = {
    "max_multiplier": "maximum Floquet multiplier modulus max|mu| (unstable > 1)",
    "peak_to_peak": "peak-to-peak of the first state over the periodic orbit",
    "rattle_state": "0 no contact loss, 1 contact loss only, 2 back-side contact",
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
               n_workers: int) -> tuple[list[dict[str, Any]], str]:
    """Run the row tasks serially, on local worker processes or on Dask
    (:func:`gearsym.analysis.sweeps.run_tasks`); the points of a task whose worker died fail."""
    chunks, runner = _workers.run_tasks(_run_chunk, system, tasks, workers=n_workers, dask=dask)
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


def stability_map(target: SceneLike | CompiledSystem, x: Sequence[Any], y: Sequence[Any],
                  quantity: str | None = None, *, method: str | None = None, periods: float | None = None,
                  params: Mapping[str, float] | None = None, dask: Any = None, workers: int | None = None,
                  rows_per_task: int | None = None, orbit_options: Mapping[str, Any] | None = None,
                  x0: Sequence[float] | None = None) -> xr.Dataset:
    """Evaluate a stability / response map over two parameters.

    Parameters
    ----------
    target
        A scene or its compiled system.
    x, y
        ``(NAME, LO, HI, N)``: parameter and grid of each axis (declared units, as ``--set``).
    quantity
        One of :data:`QUANTITIES` (the one plotted; ``max_multiplier`` and
        ``rattle_state`` are always stored, ``peak_to_peak`` when asked for).
    method
        ``"auto"``, ``"exact"``, ``"shooting"`` or ``"hbm"`` (see module docstring).
    periods
        Orbit period in forcing periods (a positive whole number).

        ``quantity``, ``method``, ``periods`` and the ``harmonics`` and ``rtol`` of
        ``orbit_options`` not given take the values of the scene's ``[map]`` table, else
        ``"max_multiplier"``, ``"auto"``, 1 (one resolution with ``gearsym map``:
        :func:`gearsym.spec.settings.resolve_settings`).
    params
        Further parameter overrides (declared units) for every point.
    dask
        Scheduler address (``"tcp://host:8786"``) or a ``distributed.Client``: run
        the tasks on that cluster.  Default: a process pool on all local cores.
    workers
        Local processes (default ``os.cpu_count()``; 1: run in this process).
    rows_per_task
        Grid rows per task (default: enough tasks for 4 per worker).
    orbit_options
        Passed to the orbit solver (e.g. ``{"rtol": 1e-9}``, ``{"harmonics": 32}``).
    x0
        Initial guess of the orbit at the first point of every row (default: the scene's
        initial state after a transient); every other point starts from the previous
        point's response.

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
        the unstable orbit found at a point.  Attributes ``n_failed``,
        ``n_no_stable_response``.
    """
    check_counts(workers=workers, rows_per_task=rows_per_task)  # bounded work (gearsym.budget)
    wall = time.perf_counter()
    grid = _Grid.of(x, y)
    scene: Any = target if is_scene(target) else None
    # the scene's [map] table under the caller's values: one resolution with `gearsym map`
    table = (scene.spec.extra if scene is not None else getattr(target, "settings", {})).get("map")
    quantity, method, periods, orbit_options = _settings(table, quantity, method, periods, orbit_options)
    system = scene.compile() if scene is not None else target
    base = _check_parameters(system, scene, grid, params)
    if x0 is not None and np.shape(x0) != (system.generated.nx,):
        raise ParameterError(f"x0 must have {system.generated.nx} entries ({', '.join(system.state_names)}), got "
                             f"shape {np.shape(x0)}")
    want_ptp = quantity == "peak_to_peak"
    gear = quantity if quantity in GEAR_QUANTITIES else None  # a gear quantity (gearsym.quantities)
    if gear and not system.generated.meshes:
        raise ParameterError(f"quantity '{gear}': model '{system.name}' has no mesh elements")
    n_workers = int(workers or os.cpu_count() or 1)
    flat: list[dict[str, Any]] | None = None
    runner = ""
    if method in ("auto", "exact") and not want_ptp and not gear:
        flat = _exact_points(system, [dict(base, **{grid.xname: float(xv), grid.yname: float(yv)})
                                      for yv in grid.ys for xv in grid.xs], periods, required=method == "exact")
        runner = "vectorised (exact)"
    if flat is None:
        tasks = _row_tasks(grid, rows_per_task, n_workers, {
            "xname": grid.xname, "yname": grid.yname, "method": method, "periods": periods, "want_ptp": want_ptp,
            "options": dict(orbit_options or {}), "params": base, "x0": None if x0 is None else [float(v) for v in x0],
            "gear": gear})
        flat, runner = _run_tasks(system, tasks, dask, n_workers)
    _log.info("stability map of %s: %d x %d points (%s x %s), %s, %d failed", system.name, len(grid.xs),
              len(grid.ys), grid.xname, grid.yname, runner, sum(1 for r in flat if r.get("error")))
    ds = _dataset(system, flat, grid.xname, grid.xs, grid.yname, grid.ys, want_ptp, gear)
    ds.attrs.update({
        "title": f"{QUANTITIES[quantity]} over {grid.xname} x {grid.yname}",
        "quantity": quantity,
        "scene": system.name,
        "method": method,
        "periods": float(periods),
        "params_json": json.dumps(base, sort_keys=True),
        "runner": runner,
        "wall_s": time.perf_counter() - wall,
        "source": "gearsym.analysis.sweeps.stability_map",
        "stability_rule": "gearsym.analysis.periodic.floquet (neutral band from the monodromy error)",
    })
    return ds


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
        tasks.append({"points": pts, **common, "options": dict(common["options"])})
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


def _netcdf_engine() -> str:
    for eng, mod in (("netcdf4", "netCDF4"), ("h5netcdf", "h5netcdf")):
        try:
            __import__(mod)
            return eng
        except ImportError:
            continue
    return "scipy"


def save_map(ds: xr.Dataset, out_dir: str | Path, quantity: str | None = None, stem: str = "map"
             ) -> list[Path]:
    """Write ``<stem>.nc`` (netCDF) and ``<stem>.png`` (heat map) into ``out_dir``.

    The heat map shows ``quantity`` (default: the dataset's) over the two axes;
    for ``max_multiplier`` the colour scale is centred on 1 and the boundary of the
    unstable region (the ``stable`` variable of the stability rule) is drawn as a contour.
    Points without a stable periodic response (``response`` 0) are hatched ``//`` and have
    no response colour (rattle state, peak-to-peak); failed points are hatched ``xx``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    nc = out / f"{stem}.nc"
    with atomic_path(nc) as tmp:
        ds.to_netcdf(tmp, engine=_netcdf_engine())
    q = quantity or str(ds.attrs.get("quantity", "max_multiplier"))
    if q not in ds:
        raise ParameterError(f"the map has no variable '{q}' (have: {', '.join(ds.data_vars)})")
    yname, xname = ds[q].dims
    X, Y = ds[xname].values, ds[yname].values
    Z = ds[q].values.astype(float)
    resp = ds["response"].values if "response" in ds else None
    if resp is not None and (q in ("rattle_state", "peak_to_peak") or q in GEAR_QUANTITIES):
        Z[resp != 1] = np.nan  # the response's quantity: none where there is no stable response
    fig, ax = plt.subplots(figsize=(7, 5.2))
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
    fig.tight_layout()
    png = out / f"{stem}.png"
    save_figure(fig, png, dpi=120)
    plt.close(fig)
    return [nc, png]
