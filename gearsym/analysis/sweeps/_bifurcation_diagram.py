"""Brute-force bifurcation diagrams: Poincare points after a transient over a sweep of one parameter.

:func:`bifurcation_diagram` sweeps one parameter over ``n`` values, forward (from ``start`` to
``stop``) and backward, each value starting from the state where the previous one ended (the way a
slow run-up and run-down of a test rig goes: the response follows an attractor until it disappears,
then jumps): at each value the state is integrated ``transient`` forcing periods, then ``samples``
forcing periods sampled once per period (the Poincare section at forcing phase 0), and the largest
Lyapunov exponent of where it is (:func:`gearsym.analysis.sweeps.lyapunov_exponents`, one exponent over
``lyapunov_periods``; optional).  The section points repeat after ``k`` periods for a period-``k``
response (``period``: the smallest ``k <= max_k`` whose section points repeat after ``k`` periods to
``settle_tol`` of each state's range over the second half of the samples, 0 for none), and a
non-periodic response is classified as every sweep classifies it
(:func:`~gearsym.analysis.sweeps._attractor_id.classify_exponent`: chaotic for a positive exponent
beyond its error, quasi-periodic for a zero one with the section on one curve, else not classified;
without the exponent, not classified).  Both rules are those of the basins and the maps
(:mod:`gearsym.analysis.sweeps._attractor_id`); a diagram's period is not verified by an orbit solve,
so its tolerance is stricter by default (1e-4 against 1e-3).

The two directions are two tasks of :func:`gearsym.analysis.sweeps.run_tasks` (two local processes,
or a Dask cluster); each value of a direction is one unit of the progress bar.

:func:`save_bifurcation_diagram` writes ``<stem>.nc`` (netCDF), ``<stem>.json`` (the summary per
value) and ``<stem>.png`` (the Poincare points of one state against the parameter, forward and
backward, over the largest Lyapunov exponent).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_count
from ...display import netcdf_engine
from ...errors import GearsymError, ParameterError
from ...files import atomic_path, save_figure, write_json
from ...progress import progress_bar
from .._inputs import SceneLike, is_scene
from .._options import resolve_options
from . import _workers
from ._attractor_id import ATTRACTOR_KINDS, PERIODIC, UNCLASSIFIED, classify_exponent, settled_period
from ._lyapunov import lyapunov_exponents

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from ...system import CompiledSystem

__all__ = ["DIRECTIONS", "DiagramOptions", "bifurcation_diagram", "diagram_summary", "save_bifurcation_diagram"]

#: The directions of a sweep.
DIRECTIONS = ("forward", "backward")
#: The kinds of a value (:data:`~gearsym.analysis.sweeps.ATTRACTOR_KINDS`; a diagram's period is not verified by an
#: orbit solve) and the failed code.
_KIND_LEGEND = "; ".join(f"{k} {v}" for k, v in {**ATTRACTOR_KINDS, PERIODIC: "periodic (the section repeats after "
                                                  "period forcing periods; no orbit solve verifies it)"}.items()
                         ) + "; -1 failed"


@dataclass(frozen=True)
class DiagramOptions:
    """Settings of :func:`bifurcation_diagram` (each also accepted as a keyword).

    Attributes
    ----------
    directions : tuple of str
        ``("forward", "backward")`` (default), or one of them.
    transient : int
        Forcing periods integrated at each value before the section is sampled.
    samples : int
        Poincare points kept at each value.
    lyapunov : bool
        Compute the largest Lyapunov exponent at each value.
    lyapunov_periods : int
        Forcing periods of that exponent (at least 32).
    max_k : int
        Longest period (forcing periods) recognised in the section.
    settle_tol : float
        The section repeats when its points agree to this fraction of each state's range (a response
        still approaching its orbit more slowly than that counts as on it).
    params : mapping or None
        Further parameter overrides (declared units).
    x0 : sequence of float or None
        The state at the first value of each direction (default: the scene's initial state).
    rtol, atol : float or None
        Integrator tolerances (default: the scene's ``[simulate]``).
    workers : int or None
        Local processes (default: one per direction, at most the cores; 1: this process).
    dask : str or distributed.Client or None
        Run the directions on that Dask cluster.
    progress : bool or None
        A progress bar on stderr (``None``: when stderr is a terminal).
    """

    directions: tuple[str, ...] = DIRECTIONS
    transient: int = 200
    samples: int = 64
    lyapunov: bool = True
    lyapunov_periods: int = 400
    max_k: int = 8
    settle_tol: float = 1e-4
    params: Mapping[str, float] | None = None
    x0: Sequence[float] | None = None
    rtol: float | None = None
    atol: float | None = None
    workers: int | None = None
    dask: Any = None
    progress: bool | None = None

    def __post_init__(self) -> None:
        dirs = (self.directions,) if isinstance(self.directions, str) else tuple(self.directions)
        if not dirs or any(d not in DIRECTIONS for d in dirs) or len(set(dirs)) != len(dirs):
            raise ParameterError(f"directions must be forward, backward or both, got {self.directions!r}")
        object.__setattr__(self, "directions", dirs)
        for name, lo in (("transient", 0), ("samples", 2), ("lyapunov_periods", 32), ("max_k", 1)):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < lo:
                raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
        check_count("transient", self.transient)
        check_count("samples", self.samples, rule="sweep_samples")
        check_count("lyapunov_periods", self.lyapunov_periods, rule="transient")
        if self.samples < 2 * self.max_k + 1:
            raise ParameterError(f"samples={self.samples}: at least 2 max_k + 1 = {2 * self.max_k + 1} section "
                                 "points are needed to recognise a cycle of max_k periods")
        if not (isinstance(self.settle_tol, (int, float)) and 0 < self.settle_tol < 1):
            raise ParameterError(f"settle_tol must be a number in (0, 1), got {self.settle_tol!r}")
        if self.workers is not None:
            check_count("workers", self.workers)


# ------------------------------------------------------------------ one direction (a task)
def _classify(Y: np.ndarray, per: int, lam: float, err: float, T: float, opts: DiagramOptions) -> tuple[int, int]:
    """``(period, kind)`` of one value from its dense samples ``Y`` (``per`` per forcing period, ``Y[0]`` at a
    whole period) and its largest exponent (module docstring)."""
    k = settled_period(Y, per, opts.max_k, opts.settle_tol)
    if k:
        return k, PERIODIC
    if not math.isfinite(lam):
        return 0, UNCLASSIFIED
    return 0, classify_exponent(lam, err, T, Y[per::per])[0]


def _value(system: CompiledSystem, params: dict[str, float], x: np.ndarray, opts: DiagramOptions,
           tol: dict[str, float]) -> dict[str, Any]:
    """One value of a sweep: transient, section, exponent, classification."""
    T = float(system.require_period(params, "a bifurcation diagram"))
    if opts.transient:
        x = np.asarray(system.simulate(t_end=opts.transient * T, x0=x, n_out=2, params=params, **tol).x_final, float)
    per = 8
    tr = system.simulate(t_end=opts.samples * T, x0=x, n_out=per * opts.samples + 1, params=params, **tol)
    Y = np.asarray(tr.y, float)
    P = Y[per::per]
    lam = err = math.nan
    if opts.lyapunov:
        ly = lyapunov_exponents(system, params, x0=Y[-1], periods=opts.lyapunov_periods, transient=0, exponents=1,
                                progress=False, **({"rtol": tol["rtol"]} if "rtol" in tol else {}))
        lam, err = float(ly.exponents[0]), float(ly.errors[0])
    k, kind = _classify(Y, per, lam, err, T, opts)
    return {"section": P, "lyapunov": lam, "lyapunov_error": err, "period": k, "kind": kind, "x": Y[-1].copy(),
            "error": ""}


def _sweep_task(system: CompiledSystem, task: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Task function (module level, picklable): one direction of the sweep."""
    opts: DiagramOptions = task["options"]
    base = dict(task["params"])
    x = np.asarray(task["x0"], float)
    start = x.copy()
    out = []
    for v in task["values"]:
        params = {**base, task["param"]: float(v)}
        try:
            r = _value(system, params, x, opts, task["tol"])
            x = r["x"]
        except GearsymError as exc:
            nx = len(x)
            r = {"section": np.full((opts.samples, nx), np.nan), "lyapunov": math.nan, "lyapunov_error": math.nan,
                 "period": 0, "kind": -1, "x": None, "error": str(exc)[:300]}
            x = start.copy()  # the next value starts afresh (the state here is lost)
        out.append(r)
        _workers.report(1)
    return out


# ------------------------------------------------------------------ the diagram
def bifurcation_diagram(target: SceneLike | CompiledSystem, param: str, start: float, stop: float, n: int,
                        options: DiagramOptions | None = None, **keywords: Any) -> xr.Dataset:
    """A brute-force bifurcation diagram of one parameter (module docstring).

    Parameters
    ----------
    target
        A scene or its compiled system.
    param
        The parameter swept (a run-time parameter; values in its declared unit).
    start, stop
        The range (the forward sweep goes from ``start`` to ``stop``).
    n
        Number of values (at least 1).
    options
        The other settings (:class:`DiagramOptions`).
    **keywords
        Fields of :class:`DiagramOptions` given one by one (``transient=``, ``samples=``, ...); they
        override ``options``.

    Returns
    -------
    xarray.Dataset
        ``poincare`` (direction, ``param``, sample, state): the section points; ``lyapunov`` and
        ``lyapunov_error`` (direction, ``param``): the largest exponent (per unit of the system's time);
        ``period`` (0: none of at most ``max_k``); ``kind`` (:data:`~gearsym.analysis.sweeps.ATTRACTOR_KINDS`,
        -1 failed).  Coordinates: ``direction``, ``param`` (declared units) and ``<param>_si``,
        ``state``.  Attributes: the settings, ``wall_s``, ``values_per_second``, ``runner``,
        ``n_failed``, ``errors``.
    """
    opts = resolve_options(options, DiagramOptions, keywords, "bifurcation_diagram")
    wall = time.perf_counter()
    check_count("n", n, rule="sweep_values")
    lo, hi = float(start), float(stop)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ParameterError(f"the range of {param} must be finite, got {start!r} .. {stop!r}")
    scene: Any = target if is_scene(target) else None
    system = scene.compile() if scene is not None else target
    if param not in system.param_names:
        raise ParameterError(f"'{param}' is not a run-time parameter of this system (have: "
                             f"{', '.join(system.param_names)})")
    base = {**system.params, **{k: float(v) for k, v in (opts.params or {}).items()}}
    values = np.linspace(lo, hi, int(n))
    for v in (values[0], values[-1]):
        system.param_vector({**base, param: float(v)})  # the physical ranges at the ends (exit 2)
        system.require_period({**base, param: float(v)}, "a bifurcation diagram")  # and a forcing period there
    x0 = np.asarray(system.x0 if opts.x0 is None else opts.x0, float)
    if x0.shape != (system.generated.nx,):
        raise ParameterError(f"x0 must have {system.generated.nx} entries ({', '.join(system.state_names)})")
    tol = {k: float(v) for k, v in (("rtol", opts.rtol), ("atol", opts.atol)) if v is not None}
    tasks = [{"param": param, "values": values if d == "forward" else values[::-1], "params": base,
              "x0": x0.tolist(), "options": opts, "tol": tol} for d in opts.directions]
    workers = opts.workers if opts.workers is not None else min(len(tasks), os.cpu_count() or 1)
    bar = progress_bar(opts.progress, len(tasks) * len(values), f"sweep {param}", unit="value")
    try:
        results, runner = _workers.run_tasks(_sweep_task, system, tasks, workers=workers, dask=opts.dask,
                                             progress=bar, weights=[len(values)] * len(tasks))
    finally:
        bar.close()
    for d, res in zip(opts.directions, results, strict=True):
        if isinstance(res, _workers.TaskFailure):
            raise GearsymError(f"the {d} sweep failed: {res.message}")
    ds = _dataset(system, param, values, opts, results)
    wall_s = time.perf_counter() - wall
    ds.attrs.update({"scene": system.name, "param": param, "runner": runner, "wall_s": wall_s,
                     "values_per_second": len(tasks) * len(values) / max(wall_s, 1e-300),
                     "transient": opts.transient, "samples": opts.samples, "lyapunov_periods": opts.lyapunov_periods
                     if opts.lyapunov else 0, "max_k": opts.max_k, "settle_tol": opts.settle_tol,
                     "kinds": _KIND_LEGEND,
                     "source": "gearsym.analysis.sweeps.bifurcation_diagram"})
    return ds


def _dataset(system: CompiledSystem, param: str, values: np.ndarray, opts: DiagramOptions,
             results: list[list[dict[str, Any]]]) -> xr.Dataset:
    """The diagram's variables (each direction in increasing parameter order)."""
    import xarray as xr

    nd, nv, nx = len(results), len(values), system.generated.nx
    P = np.full((nd, nv, opts.samples, nx), np.nan)
    lam, err = np.full((nd, nv), np.nan), np.full((nd, nv), np.nan)
    per, kind = np.zeros((nd, nv), np.int16), np.full((nd, nv), -1, np.int8)
    errors = []
    for a, (d, res) in enumerate(zip(opts.directions, results, strict=True)):
        order = range(nv) if d == "forward" else range(nv - 1, -1, -1)
        for i, r in zip(order, res, strict=True):
            P[a, i], lam[a, i], err[a, i] = r["section"], r["lyapunov"], r["lyapunov_error"]
            per[a, i], kind[a, i] = r["period"], r["kind"]
            if r["error"] and len(errors) < 5:
                errors.append(f"({d}, {param}={values[i]:g}): {r['error']}")
    si = system.units.to_si({param: values})[param]
    dims = ("direction", param)
    ds = xr.Dataset(
        {"poincare": ((*dims, "sample", "state"), P, {"long_name": "state at whole forcing periods after the "
                                                                  "transient (Poincare section at phase 0)"}),
         "lyapunov": (dims, lam, {"long_name": "largest Lyapunov exponent (per unit of the system's time)"}),
         "lyapunov_error": (dims, err, {"long_name": "its 95 % error"}),
         "period": (dims, per, {"long_name": "period of the section in forcing periods (0: none of at most max_k)"}),
         "kind": (dims, kind, {"long_name": _KIND_LEGEND})},
        coords={"direction": list(opts.directions), param: (param, values, {"units": system.units.unit(param) or "SI"}),
                f"{param}_si": (param, si), "state": list(system.state_names)})
    ds.attrs.update({"n_failed": int(np.sum(kind < 0)), "errors": "\n".join(errors)})
    return ds


def diagram_summary(ds: xr.Dataset) -> dict[str, Any]:
    """A JSON-ready summary: per direction and value the period, kind and largest exponent.

    Parameters
    ----------
    ds
        A :func:`bifurcation_diagram` result.

    Returns
    -------
    dict
    """
    param = str(ds.attrs["param"])
    out: dict[str, Any] = {k: (v.item() if hasattr(v, "item") else v) for k, v in ds.attrs.items()}
    out["values"] = ds[param].values.tolist()
    out["unit"] = ds[param].attrs.get("units", "")
    for d in ds["direction"].values.tolist():
        sel = ds.sel(direction=d)
        lam = sel["lyapunov"].values
        out[d] = {"period": sel["period"].values.tolist(), "kind": sel["kind"].values.tolist(),
                  "lyapunov": [None if not math.isfinite(v) else float(v) for v in lam],
                  "lyapunov_error": [None if not math.isfinite(v) else float(v) for v in sel["lyapunov_error"].values]}
    return out


def save_bifurcation_diagram(ds: xr.Dataset, out_dir: str | Path, state: str | None = None,
                             stem: str = "sweep") -> list[Path]:
    """Write ``<stem>.nc``, ``<stem>.json`` and ``<stem>.png`` into ``out_dir`` (module docstring).

    Parameters
    ----------
    ds
        A :func:`bifurcation_diagram` result.
    out_dir
        The folder (made if missing).
    state
        The state drawn (default: the first).
    stem
        The files' name.

    Returns
    -------
    list of Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ds["state"].values.tolist()
    s = names[0] if state is None else state
    if s not in names:
        raise ParameterError(f"state '{s}' is not a state of the diagram (have: {', '.join(names)})")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    nc, js, png = out / f"{stem}.nc", out / f"{stem}.json", out / f"{stem}.png"
    with atomic_path(nc) as tmp:
        ds.to_netcdf(tmp, engine=netcdf_engine())
    write_json(js, diagram_summary(ds))
    param = str(ds.attrs["param"])
    v = ds[param].values
    fig, (ax, axl) = plt.subplots(2, 1, figsize=(7.5, 6.6), sharex=True, gridspec_kw={"height_ratios": [2.3, 1]})
    marks = {"forward": (">", "C0"), "backward": ("<", "C3")}
    for d in ds["direction"].values.tolist():
        sel = ds.sel(direction=d)
        m, c = marks[d]
        pts = sel["poincare"].sel(state=s).values
        ax.plot(np.repeat(v, pts.shape[1]), pts.ravel(), ".", ms=1.5, color=c, alpha=0.6)
        ax.plot([], [], m, color=c, label=f"sweep {d}")
        if np.isfinite(sel["lyapunov"].values).any():
            axl.plot(v, sel["lyapunov"].values, m + "-", ms=3, lw=0.8, color=c, label=f"sweep {d}")
    axl.axhline(0.0, color="0.4", lw=0.6)
    unit = ds[param].attrs.get("units", "")
    axl.set_xlabel(f"{param} [{unit}]" if unit and unit not in ("1", "SI") else param)
    ax.set_ylabel(f"{s} at whole forcing periods")
    axl.set_ylabel("largest Lyapunov exponent")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"{ds.attrs.get('scene', '')}: brute-force bifurcation diagram")
    fig.tight_layout()
    save_figure(fig, png, dpi=120)
    plt.close(fig)
    return [nc, js, png]
