"""Basins of attraction: which start leads to which response.

:func:`basins` integrates a grid of initial states -- two states varied over a grid, the others
fixed, all taken at the phase ``phase`` of the forcing period (``t0 = phase T``) -- until each
lands on a known attractor, and returns a :class:`BasinResult`: a label per grid cell and the
table of attractors (period, rattle state, largest multiplier, Poincare points, amplitudes).

The run:

1. **Discovery.**  ``seeds`` cells spread over the grid are integrated ``transient`` forcing
   periods (one C call for all of them: :func:`gearsym.engine.batch.run_batch`); each landing
   that is not on a known attractor is identified (:func:`~gearsym.analysis.sweeps._attractors.identify`):
   a periodic orbit is shot from it and kept when it is stable and passes through the landing;
   else the attractor is non-periodic (chaotic, quasi-periodic or unclassified, by its largest
   Lyapunov exponent and its Poincare section: the rules every sweep shares,
   :mod:`gearsym.analysis.sweeps._attractor_id`) and its Poincare section is kept.
2. **Settling.**  Every cell is integrated ``chunk`` forcing periods per C call, its Poincare
   point (the state at ``t0 + i T``) checked after every period against the neighbourhoods of
   the known attractors (:class:`~gearsym.analysis.sweeps._attractor_id.Table`: a distance relative to
   each attractor's size, any of its ``k`` phases); a cell is settled, with that attractor's
   label, after ``hits`` consecutive Poincare points in one neighbourhood (four times that for
   a non-periodic attractor, whose region a transient may cross), so most cells cost a few
   periods (16 on average on the benchmark oscillator's two coexisting orbits, whose
   multipliers have modulus 0.7).  Blocks of cells run in one C call per chunk (no
   per-trajectory Python), on local worker processes or a Dask cluster
   (:func:`gearsym.analysis.sweeps.run_tasks`), with a progress bar.

   The early termination is safe when a neighbourhood lies inside its attractor's basin: the
   radius (5 % of the attractor's size by default) must be small against the distance to the
   nearest basin boundary (on the benchmark oscillator at ``Omega = 0.87`` the Poincare point of
   the saddle orbit between the two attractors is about 11 radii from the nearer one's).  A smaller ``radius`` or more ``hits``
   trade periods for margin.
3. **Rounds.**  The cells still unsettled get a budget that doubles from
   :data:`FIRST_BUDGET` periods up to ``periods_max``; before each later round, up to ``seeds``
   of them are integrated ``transient`` more periods and identified (attractors the first seeds
   missed), and the round continues them from where they stopped.

Labels: ``0, 1, ...`` the attractors (:attr:`BasinResult.attractors`), :data:`UNRESOLVED` (-1:
bounded but not settled on a known attractor within ``periods_max``), :data:`UNBOUNDED` (-2: a
state beyond ``bound`` times its magnitude on the grid and the attractors), :data:`FAILED` (-3:
the integration failed; :attr:`BasinResult.stats` has the first message).

The result's :attr:`~BasinResult.dataset` is an ``xarray.Dataset``; :meth:`BasinResult.save`
writes it as netCDF with a PNG of the map (one colour per attractor, a legend naming each
attractor's period and rattle state, its Poincare points drawn on the plane).

Scripts that run basins on local worker processes need an ``if __name__ == "__main__":``
guard (workers start a fresh interpreter).
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import LIMITS, check_count
from ...display import BasinDisplay, netcdf_engine
from ...errors import GearsymError, ParameterError
from ...integrators import check_method, default_method, get_method
from ...progress import progress_bar
from .._inputs import SceneLike, as_system
from ._attractor_id import KINDS, Table
from ._attractors import Attractor, Context, identify, table_of

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from ...system import CompiledSystem as System

__all__ = ["FAILED", "UNBOUNDED", "UNRESOLVED", "BasinOptions", "BasinResult", "basins"]

_log = logging.getLogger(__name__)

#: Label of a cell that did not settle on a known attractor within ``periods_max``.
UNRESOLVED = -1
#: Label of a cell whose state left ``bound`` times its magnitude.
UNBOUNDED = -2
#: Label of a cell whose integration failed.
FAILED = -3
#: Names of the special labels.
SPECIAL_LABELS: dict[int, str] = {UNRESOLVED: "unresolved", UNBOUNDED: "unbounded", FAILED: "failed"}
#: Forcing periods of the first settling round (the budget doubles each round up to periods_max).
FIRST_BUDGET = 64
#: Cells per task of the settling rounds, at most (at least 4 tasks per worker otherwise).
MAX_BLOCK = 2048
#: Fewer pending cells than this settle in this process (starting workers costs about a second).
MIN_PARALLEL = 256


@dataclass(frozen=True)
class BasinOptions:
    """Settings of :func:`basins`.

    Attributes
    ----------
    phase : float
        Phase of the forcing period at which the grid's states are taken and the Poincare
        points sampled, in ``[0, 1)`` (``t0 = phase T``).
    periods_max : int
        Forcing periods a cell is integrated at most before it is called unresolved.
    chunk : int
        Forcing periods per C call between the neighbourhood checks.
    hits : int
        Consecutive Poincare points in one attractor's neighbourhood that settle a cell.
    radius : float
        Radius of an attractor's neighbourhood relative to its size (module
        :mod:`gearsym.analysis.sweeps._attractors`).
    seeds : int
        Cells integrated ``transient`` periods and identified before the first round (spread
        over the grid), and unsettled cells identified before each later round, at most.
    transient : int
        Forcing periods integrated from a seed before its attractor is identified.
    max_period : int
        Longest periodic orbit looked for, in forcing periods.
    cloud : int
        Poincare points kept of a non-periodic attractor.
    lyapunov_periods : float
        Forcing periods of the largest Lyapunov exponent of a non-periodic attractor.
    rtol : float
        Integrator relative tolerance.
    atol : float or None
        Absolute tolerance; ``None``: ``1e-2 * rtol`` times each state's magnitude (on the grid,
        the base state and the attractors).
    method : str or None
        Integrator (default: the scene's).
    bound : float
        A state beyond ``bound`` times its magnitude is unbounded.
    """

    phase: float = 0.0
    periods_max: int = 500
    chunk: int = 2
    hits: int = 3
    radius: float = 0.05
    seeds: int = 16
    transient: int = 300
    max_period: int = 12
    cloud: int = 400
    lyapunov_periods: float = 400.0
    rtol: float = 1e-8
    atol: float | None = None
    method: str | None = None
    bound: float = 1e3

    def __post_init__(self) -> None:
        if not (isinstance(self.phase, (int, float)) and math.isfinite(self.phase) and 0 <= self.phase < 1):
            raise ParameterError(f"phase must be in [0, 1) (a fraction of the forcing period), got {self.phase!r}")
        for name, lo, hi in (("periods_max", 1, 10_000_000), ("chunk", 1, 10_000), ("hits", 1, 10_000),
                             ("seeds", 1, 100_000), ("transient", 0, 10_000_000), ("max_period", 1, 1000),
                             ("cloud", 8, 100_000)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ParameterError(f"{name} must be an integer in [{lo:,}, {hi:,}], got {v!r}")
        for name in ("radius", "lyapunov_periods", "bound", "rtol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be positive and finite, got {v!r}")
        if self.radius >= 1:
            raise ParameterError(f"radius must be below 1 (a fraction of the attractor's size), got {self.radius:g}")
        if not 1e-15 <= self.rtol < 1:
            raise ParameterError(f"rtol must be in [1e-15, 1), got {self.rtol:g}")
        if self.atol is not None and not (isinstance(self.atol, (int, float)) and math.isfinite(self.atol)
                                          and self.atol > 0):
            raise ParameterError(f"atol must be positive and finite, got {self.atol!r}")
        if self.method is not None:
            get_method(self.method)  # a known integration method (its model form is checked with the system)
        if self.lyapunov_periods < 32:
            raise ParameterError(f"lyapunov_periods must be at least 32 (the exponent's error estimate needs "
                                 f"32 blocks), got {self.lyapunov_periods:g}")


@dataclass(frozen=True, eq=False)
class BasinResult(BasinDisplay):
    """A basin map: a label per grid cell and the attractors (module docstring).

    In Jupyter a table of the attractors and their basins; ``to_xarray()`` the map
    (:attr:`dataset`), ``to_dataframe()`` one row per attractor (:mod:`gearsym.display`).

    States (the grid, :attr:`base`, the attractors' points) are in the system's own variables, as
    :attr:`gearsym.System.x0`.

    Attributes
    ----------
    labels : ndarray of int, shape (ny, nx)
        The attractor of each cell (index into :attr:`attractors`), or :data:`UNRESOLVED`,
        :data:`UNBOUNDED`, :data:`FAILED`.  Row ``i`` is ``y_values[i]``.
    periods : ndarray of int, shape (ny, nx)
        Forcing periods each cell was integrated until it settled (or gave up).
    attractors : tuple of Attractor
        The attractors found.
    x_state, y_state : str
        The states varied along the axes.
    x_values, y_values : ndarray
        The grid.
    base : ndarray
        The initial state of every cell before the two grid states are set.
    state_names : list of str
    phase, t0, period : float
        The phase, ``t0 = phase T`` and the forcing period ``T``.
    params : dict
        Run-time parameter values (declared units).
    scene : str
    options : BasinOptions
    stats : dict
        Counts and times: ``n_cells``, ``periods_integrated`` (settling rounds and discovery),
        ``events``, ``steps``, ``c_seconds`` / ``c_cpu_seconds`` (wall / CPU time inside the C
        batches of the settling rounds, summed over the workers), ``cpu_seconds`` (CPU time of the
        settling tasks, summed over the workers), ``wall_s``, ``discovery_s``, ``settle_s``,
        ``runner``, ``rounds``, ``n_seeds``, ``first_error``.
    """

    labels: np.ndarray
    periods: np.ndarray
    attractors: tuple[Attractor, ...]
    x_state: str
    y_state: str
    x_values: np.ndarray
    y_values: np.ndarray
    base: np.ndarray
    state_names: list[str]
    phase: float
    t0: float
    period: float
    params: dict[str, float]
    scene: str
    options: BasinOptions
    stats: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------ queries
    def count(self, label: int) -> int:
        """The number of cells with a label.

        Parameters
        ----------
        label
            An attractor's index or a special label (:data:`UNRESOLVED`, ...).

        Returns
        -------
        int
        """
        return int(np.count_nonzero(self.labels == label))

    @property
    def fractions(self) -> dict[int, float]:
        """Fraction of the cells per label (attractors and special labels present)."""
        labs, n = np.unique(self.labels, return_counts=True)
        return {int(k): float(c) / self.labels.size for k, c in zip(labs, n, strict=True)}

    def label_at(self, x: float, y: float) -> int:
        """The label of the grid cell nearest to a point of the plane.

        Parameters
        ----------
        x, y
            Values of :attr:`x_state` and :attr:`y_state`.

        Returns
        -------
        int
        """
        i = int(np.argmin(np.abs(self.y_values - y)))
        j = int(np.argmin(np.abs(self.x_values - x)))
        return int(self.labels[i, j])

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no per-cell arrays).

        Returns
        -------
        dict
            The grid, the attractors (:meth:`Attractor.as_dict`), the fraction of the cells per
            label, the options and :attr:`stats`.
        """
        return {"scene": self.scene, "x": {"state": self.x_state, "lo": float(self.x_values[0]),
                                           "hi": float(self.x_values[-1]), "n": int(self.x_values.size)},
                "y": {"state": self.y_state, "lo": float(self.y_values[0]), "hi": float(self.y_values[-1]),
                      "n": int(self.y_values.size)},
                "phase": self.phase, "t0": self.t0, "period": self.period, "params": dict(self.params),
                "base": dict(zip(self.state_names, self.base.tolist(), strict=True)),
                "attractors": [a.as_dict(self.state_names) for a in self.attractors],
                "fractions": {self.label_name(k): v for k, v in self.fractions.items()},
                "n_unresolved": self.count(UNRESOLVED), "n_unbounded": self.count(UNBOUNDED),
                "n_failed": self.count(FAILED), "options": asdict(self.options), "stats": dict(self.stats)}

    def label_name(self, label: int) -> str:
        """The name of a label.

        Parameters
        ----------
        label
            An attractor's index or a special label.

        Returns
        -------
        str
            ``"A0: period 1, rattle 0"``, or ``"unresolved"``, ``"unbounded"``, ``"failed"``.
        """
        if label in SPECIAL_LABELS:
            return SPECIAL_LABELS[label]
        return f"A{label}: {self.attractors[label].name}"

    def __repr__(self) -> str:
        parts = ", ".join(f"{self.label_name(k)} {v:.1%}" for k, v in self.fractions.items())
        return (f"BasinResult({self.scene}: {self.y_values.size} x {self.x_values.size} cells in "
                f"({self.x_state}, {self.y_state}); {parts})")

    # ------------------------------------------------------------ output
    @cached_property
    def dataset(self) -> xr.Dataset:
        """The map and the attractor table as an ``xarray.Dataset`` (netCDF-3 compatible types)."""
        return _dataset(self)

    def plot(self, ax: Any = None) -> Any:
        """Draw the basin map: one colour per label, the attractors' Poincare points, a legend.

        Parameters
        ----------
        ax
            A matplotlib axes (default: a new figure's).

        Returns
        -------
        matplotlib.axes.Axes
        """
        return _plot(self, ax)

    def save(self, out_dir: str | Path, stem: str = "basins") -> list[Path]:
        """Write ``<stem>.nc`` (the :attr:`dataset`), ``<stem>.json`` (:meth:`as_dict`) and ``<stem>.png``.

        Parameters
        ----------
        out_dir
            Folder (created if missing).
        stem
            File names.

        Returns
        -------
        list of Path
            The files written (each atomically).
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ...files import atomic_path, save_figure, write_json

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        files = [out / f"{stem}.nc", out / f"{stem}.json", out / f"{stem}.png"]
        with atomic_path(files[0]) as tmp:
            self.dataset.to_netcdf(tmp, engine=netcdf_engine())
        write_json(files[1], self.as_dict())
        fig, ax = plt.subplots(figsize=(7.5, 5.6))
        self.plot(ax)
        fig.tight_layout()
        save_figure(fig, files[2], dpi=120)
        plt.close(fig)
        return files


# ------------------------------------------------------------------ the run
def basins(target: SceneLike | System, x: Sequence[Any], y: Sequence[Any], *, params: Mapping[str, float] | None = None,
           options: BasinOptions | None = None, base: Sequence[float] | None = None, workers: int = 1,
           dask: Any = None, progress: bool | None = False, **overrides: Any) -> BasinResult:
    """The basins of attraction of a forced system over a grid of two states (module docstring).

    Parameters
    ----------
    target
        A compiled system (or a scene, compiled here).
    x, y
        The axes: ``(STATE, LO, HI, N)`` each, two different states, ``N >= 2``.
    params
        Parameter overrides (declared units).
    options
        Settings (:class:`BasinOptions`).
    base
        The state of every cell before the two grid states are set (default: the scene's
        initial state).
    workers
        Local worker processes (1: this process).
    dask
        A Dask scheduler address or ``distributed.Client``: the settling rounds run there.
    progress
        A progress bar of the settled cells (:func:`gearsym.progress.progress_bar`: ``tqdm.auto``;
        ``None``: in a terminal or a notebook).
    **overrides
        Fields of :class:`BasinOptions` overriding ``options`` (``periods_max=200``).

    Returns
    -------
    BasinResult

    Raises
    ------
    ParameterError
        An unknown state, equal states, a bad axis, a bad option, a model without a forcing
        period, a bad ``base``.
    """
    wall = time.perf_counter()
    opts = _options(options, overrides)
    system = as_system(target, "a basin of attraction")
    if system.generated.implicit:
        raise ParameterError("basins of attraction need an explicit model (CVODE); this one is implicit")
    check_count("workers", workers)
    xi, xs = _axis(system, x, "x")
    yi, ys = _axis(system, y, "y")
    if xi == yi:
        raise ParameterError(f"x and y must be different states, both are '{system.state_names[xi]}'")
    if xs.size * ys.size > LIMITS["map_points"].high:
        raise ParameterError(f"a basin of {xs.size} x {ys.size} cells is above the limit of "
                             f"{LIMITS['map_points'].high:,} cells")
    T = system.require_period(params, "a basin of attraction")
    b0 = _base(system, base)
    cells = np.repeat(b0[None, :], xs.size * ys.size, axis=0)
    cells[:, xi] = np.tile(xs, ys.size)
    cells[:, yi] = np.repeat(ys, xs.size)
    run = _Run(system, params, opts, T, cells, (ys.size, xs.size), workers, dask)
    run.discover(_spread(ys.size, xs.size, opts.seeds))
    run.settle_all(progress)
    run.stats["wall_s"] = time.perf_counter() - wall
    _log.info("basins of %s: %d x %d cells in (%s, %s), %d attractor(s) [%s], %d unresolved, %d unbounded, %d failed, "
              "%.3g s", system.name, xs.size, ys.size, system.state_names[xi], system.state_names[yi],
              len(run.attractors), "; ".join(a.name for a in run.attractors), int(np.sum(run.labels == UNRESOLVED)),
              int(np.sum(run.labels == UNBOUNDED)), int(np.sum(run.labels == FAILED)), run.stats["wall_s"])
    return BasinResult(labels=run.labels.reshape(ys.size, xs.size), periods=run.periods.reshape(ys.size, xs.size),
                       attractors=tuple(run.attractors), x_state=system.state_names[xi],
                       y_state=system.state_names[yi], x_values=xs, y_values=ys, base=b0,
                       state_names=system.state_names, phase=float(opts.phase), t0=run.ctx.t0, period=T,
                       params=system.run_params(params), scene=system.name, options=opts, stats=run.stats)


def _options(options: BasinOptions | None, overrides: Mapping[str, Any]) -> BasinOptions:
    opts = options or BasinOptions()
    if overrides:
        known = {f.name for f in fields(BasinOptions)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ParameterError(f"unknown option(s) {', '.join(unknown)} of a basin (have: {', '.join(sorted(known))})")
        opts = replace(opts, **overrides)
    return opts


def _axis(system: System, spec: Sequence[Any], what: str) -> tuple[int, np.ndarray]:
    """The state index and the values of an axis ``(STATE, LO, HI, N)``."""
    if isinstance(spec, str) or len(spec) != 4:
        raise ParameterError(f"{what} must be (STATE, LO, HI, N), got {spec!r}")
    name, lo, hi, n = spec
    names = system.state_names
    if name not in names:
        raise ParameterError(f"{what}: '{name}' is not a state (states: {', '.join(names)})")
    check_count(f"{what} N", n, rule="map_axis", low=2)
    try:
        lo_f, hi_f = float(lo), float(hi)
    except (TypeError, ValueError):
        raise ParameterError(f"{what}: LO and HI must be numbers, got {lo!r}, {hi!r}") from None
    if not (math.isfinite(lo_f) and math.isfinite(hi_f) and lo_f < hi_f):
        raise ParameterError(f"{what}: need finite LO < HI, got {lo_f:g}, {hi_f:g}")
    return names.index(name), np.linspace(lo_f, hi_f, int(n))


def _base(system: System, base: Sequence[float] | None) -> np.ndarray:
    nx = system.generated.nx
    b = np.array(system.x0 if base is None else base, dtype=float).reshape(-1)
    if b.shape != (nx,) or not np.all(np.isfinite(b)):
        raise ParameterError(f"base must be {nx} finite numbers ({', '.join(system.state_names)}), got {base!r}")
    return b


def _spread(ny: int, nx: int, n: int) -> np.ndarray:
    """About ``n`` cell indices spread evenly over an ``ny x nx`` grid (a sub-grid of cell centres)."""
    ky = max(1, min(ny, int(round(math.sqrt(n * ny / nx)))))
    kx = max(1, min(nx, n // ky))
    iy = np.unique(((np.arange(ky) + 0.5) * ny / ky).astype(int))
    ix = np.unique(((np.arange(kx) + 0.5) * nx / kx).astype(int))
    return (iy[:, None] * nx + ix[None, :]).ravel()


class _Run:
    """The state of one :func:`basins` run: the cells, the attractors, the counters."""

    def __init__(self, system: System, params: Mapping[str, float] | None, opts: BasinOptions, T: float,
                 cells: np.ndarray, shape: tuple[int, int], workers: int, dask: Any) -> None:
        self.system, self.params, self.opts, self.shape = system, params, opts, shape
        self.workers, self.dask = workers, dask
        n, nx = cells.shape
        self.x = cells.copy()
        self.sigma = np.zeros((n, system.engine.nsw))
        self.started = np.zeros(n, dtype=bool)  # sigma holds the cell's surface sides
        self.labels = np.full(n, UNRESOLVED, dtype=int)
        self.periods = np.zeros(n, dtype=int)
        self.attractors: list[Attractor] = []
        self.grid_magnitude = np.max(np.abs(cells), axis=0)
        method = opts.method or default_method(system.generated.implicit, system.defaults.get("method"))
        check_method(method, system.generated.implicit)
        self.ctx = Context(system=system, params=params, p=system.param_vector(params), t0=opts.phase * T, T=T,
                           rtol=float(opts.rtol), atol=self._atol(), method=method, max_period=opts.max_period,
                           radius=opts.radius, cloud=opts.cloud, lyapunov_periods=float(opts.lyapunov_periods))
        self.stats: dict[str, Any] = {"n_cells": n, "periods_integrated": 0, "events": 0, "steps": 0,
                                      "c_seconds": 0.0, "c_cpu_seconds": 0.0, "cpu_seconds": 0.0, "discovery_s": 0.0, "settle_s": 0.0, "rounds": 0,
                                      "runner": "serial", "first_error": "", "n_seeds": 0}

    def _magnitude(self) -> np.ndarray:
        """Each state's magnitude on the grid, the base state and the attractors."""
        mag = self.grid_magnitude.copy()
        for a in self.attractors:
            mag = np.maximum(mag, np.maximum(np.abs(a.minimum), np.abs(a.maximum)))
        return mag

    def _atol(self) -> np.ndarray:
        mag = self._magnitude()
        top = float(np.max(mag)) if mag.size else 1.0
        if self.opts.atol is not None:
            return np.full(mag.shape, float(self.opts.atol))
        floor = max(1e-6 * top, 1e-300) if top > 0 else 1.0
        return 1e-2 * self.opts.rtol * np.maximum(mag, floor)

    def _bound(self) -> np.ndarray:
        mag = self._magnitude()
        return np.where(mag > 0, self.opts.bound * mag, np.inf)

    # ------------------------------------------------------------ discovery
    def discover(self, idx: np.ndarray) -> int:
        """Integrate the cells ``idx`` ``transient`` periods from where they are and identify their
        landings; returns the number of new attractors."""
        from ...engine.batch import run_batch

        t = time.perf_counter()
        ctx, opts = self.ctx, self.opts
        new = 0
        if opts.transient > 0:
            res = run_batch(self.system.engine, self.x[idx], ctx.p, ctx.t0, ctx.t0 + opts.transient * ctx.T,
                            sigma0s=self._sigma0(idx), method=ctx.method, rtol=ctx.rtol,
                            atol=float(np.min(ctx.atol)), atol_vec=ctx.atol, max_step=ctx.T / 8)
            self._count(res, opts.transient * len(idx))
            ok = res.status == 0
            landings, sides = res.x_final[ok], res.sigma_final[ok]
            if not np.all(ok) and not self.stats["first_error"]:
                self.stats["first_error"] = res.message
            idx = idx[ok]
        else:
            landings, sides = self.x[idx], self._sigma0(idx)
        bound = self._bound()
        for cell, xl, sl in zip(idx, landings, sides if sides is not None else [None] * len(idx), strict=True):
            if np.any(np.abs(xl) > bound):
                continue
            try:
                att = identify(ctx, xl, sl, len(self.attractors), int(cell), self.attractors, opts.hits)
            except GearsymError as exc:  # the landing's own integration failed: the cell tells later
                self.stats["first_error"] = self.stats["first_error"] or f"seed cell {int(cell)}: {exc}"
                continue
            if att is not None:
                self.attractors.append(att)
                new += 1
        self.stats["n_seeds"] += len(idx)
        self.stats["discovery_s"] += time.perf_counter() - t
        if new:  # tolerances and bounds from the attractors' magnitudes too
            self.ctx = replace(self.ctx, atol=self._atol())
        return new

    def _sigma0(self, idx: np.ndarray) -> np.ndarray | None:
        if not np.all(self.started[idx]) or self.sigma.shape[1] == 0:
            return None
        return self.sigma[idx]

    def _count(self, res: Any, periods: int) -> None:
        self.stats["periods_integrated"] += int(periods)
        self.stats["events"] += int(np.sum(res.n_events))
        self.stats["steps"] += int(np.sum(res.n_steps))

    # ------------------------------------------------------------ settling
    def settle_all(self, progress: bool | None) -> None:
        """The settling rounds (module docstring, steps 2 and 3)."""
        t = time.perf_counter()
        bar = progress_bar(progress, self.labels.size, "basin cells settled", unit="cell")
        try:
            done, budget = 0, min(FIRST_BUDGET, self.opts.periods_max)
            while True:
                pending = np.flatnonzero(self.labels == UNRESOLVED)
                if pending.size == 0 or done >= self.opts.periods_max:
                    break
                if self.stats["rounds"] > 0:  # attractors the first seeds missed
                    pick = pending[np.unique(np.linspace(0, pending.size - 1, min(self.opts.seeds, pending.size))
                                             .astype(int))]
                    self.discover(pick)
                self._round(pending, budget - done, bar)
                self.stats["rounds"] += 1
                done, budget = budget, min(2 * budget, self.opts.periods_max)
        finally:
            bar.close()
        self.stats["settle_s"] = time.perf_counter() - t

    def _round(self, pending: np.ndarray, periods: int, bar: Any) -> None:
        """Continue the ``pending`` cells up to ``periods`` more periods (tasks on the workers)."""
        from ._workers import TaskFailure, run_tasks

        table = table_of(self.attractors, self.x.shape[1], self.opts.hits).as_arrays()
        parallel = (self.workers > 1 or self.dask is not None) and pending.size >= MIN_PARALLEL
        n_tasks = max(math.ceil(pending.size / MAX_BLOCK), (16 if self.dask is not None else 4 * self.workers)
                      if parallel else 1)
        blocks = [b for b in np.array_split(pending, n_tasks) if b.size]
        common = {"p": self.ctx.p, "t0": self.ctx.t0, "T": self.ctx.T, "periods": int(periods),
                  "chunk": self.opts.chunk, "table": table, "rtol": self.ctx.rtol,
                  "atol": self.ctx.atol, "method": self.ctx.method, "bound": self._bound()}
        tasks = [{**common, "x": self.x[b], "sigma": self._sigma0(b)} for b in blocks]

        def finished(i: int, out: Any) -> None:
            if not isinstance(out, TaskFailure):
                bar(int(np.count_nonzero(out["label"] != UNRESOLVED)))

        results, runner = run_tasks(settle_block, self.system, tasks, workers=self.workers if parallel else 1,
                                    dask=self.dask if parallel else None, on_result=finished)
        self.stats["runner"] = runner
        for b, out in zip(blocks, results, strict=True):
            if isinstance(out, TaskFailure):
                self.labels[b] = FAILED
                self.stats["first_error"] = self.stats["first_error"] or out.message
                continue
            self.labels[b] = out["label"]
            self.periods[b] += out["periods"]
            self.x[b] = out["x"]
            self.sigma[b] = out["sigma"]
            self.started[b] = True
            for k in ("periods_integrated", "events", "steps", "c_seconds", "c_cpu_seconds", "cpu_seconds"):
                self.stats[k] += out[k]
            if out["message"] and not self.stats["first_error"]:
                self.stats["first_error"] = out["message"]


def settle_block(system: System, task: Mapping[str, Any]) -> dict[str, Any]:
    """Task function (module level, picklable): integrate a block of cells ``chunk`` periods per C
    call until each settles, leaves the bound or fails, for at most ``periods`` periods.

    Returns ``label``, ``periods`` (integrated until settled), ``x`` and ``sigma`` (where each
    stopped), ``periods_integrated``, ``events``, ``steps``, ``c_seconds`` and ``message`` (the
    first failure).
    """
    from ...engine.batch import run_batch

    table = Table.from_arrays(task["table"])
    X = np.array(task["x"], dtype=float)
    m, nx = X.shape
    sig = None if task["sigma"] is None else np.array(task["sigma"], dtype=float)
    t0, T, budget, chunk = task["t0"], task["T"], int(task["periods"]), int(task["chunk"])
    bound = np.asarray(task["bound"], float)
    atol = np.broadcast_to(np.asarray(task["atol"], float), (nx,))
    label = np.full(m, UNRESOLVED, dtype=int)
    used = np.zeros(m, dtype=int)
    last = np.full(m, -1, dtype=int)
    streak = np.zeros(m, dtype=int)
    out = {"periods_integrated": 0, "events": 0, "steps": 0, "c_seconds": 0.0, "c_cpu_seconds": 0.0,
           "message": ""}
    cpu0 = time.process_time()
    active = np.arange(m)
    done = 0
    while active.size and done < budget:
        c = min(chunk, budget - done)
        tc, cc = time.perf_counter(), time.process_time()
        res = run_batch(system.engine, X[active], task["p"], t0, t0 + c * T, t0 + T * np.arange(1, c + 1),
                        sigma0s=None if sig is None else sig[active], method=task["method"], rtol=task["rtol"],
                        atol=float(np.min(atol)), atol_vec=atol, max_step=T / 8)
        out["c_seconds"] += time.perf_counter() - tc
        out["c_cpu_seconds"] += time.process_time() - cc
        out["periods_integrated"] += c * active.size
        out["events"] += int(np.sum(res.n_events))
        out["steps"] += int(np.sum(res.n_steps))
        ok = res.status == 0
        if not np.all(ok):
            label[active[~ok]] = FAILED
            used[active[~ok]] = done + c
            out["message"] = out["message"] or res.message
        if sig is None:
            sig = np.zeros((m, res.sigma_final.shape[1]))
        for j in range(c):
            live = ok & (label[active] == UNRESOLVED)
            cells, P = active[live], res.y[live, j, :]
            far = np.any(np.abs(P) > bound, axis=1) | ~np.all(np.isfinite(P), axis=1)
            label[cells[far]] = UNBOUNDED
            used[cells[far]] = done + j + 1
            cells, P = cells[~far], P[~far]
            lab = table.match(P)
            same = (lab >= 0) & (lab == last[cells])
            streak[cells] = np.where(same, streak[cells] + 1, (lab >= 0).astype(int))
            last[cells] = lab
            if not table.hits.size:  # no attractor known: nothing settles
                continue
            settled = (lab >= 0) & (streak[cells] >= table.hits[np.maximum(lab, 0)])
            label[cells[settled]] = lab[settled]
            used[cells[settled]] = done + j + 1
        X[active[ok]] = res.x_final[ok]
        sig[active[ok]] = res.sigma_final[ok]
        done += c
        still = label[active] == UNRESOLVED
        used[active[still]] = done
        active = active[still]
    out["cpu_seconds"] = time.process_time() - cpu0
    return {**out, "label": label, "periods": used, "x": X,
            "sigma": sig if sig is not None else np.zeros((m, system.engine.nsw))}


# ------------------------------------------------------------------ dataset and figure
def _dataset(r: BasinResult) -> xr.Dataset:
    import xarray as xr

    A = len(r.attractors)
    n_st = len(r.state_names)
    kmax = max([len(a.points) for a in r.attractors] + [1])
    pts = np.full((A, kmax, n_st), np.nan)
    for i, a in enumerate(r.attractors):
        pts[i, : len(a.points)] = a.points

    def per(fn: Any, dtype: Any = float) -> np.ndarray:
        return np.array([fn(a) for a in r.attractors], dtype=dtype).reshape(A)

    legend = "; ".join(f"{k}={v}" for k, v in SPECIAL_LABELS.items())
    ds = xr.Dataset(
        {"label": ((r.y_state, r.x_state), r.labels.astype(np.int32),
                   {"long_name": "attractor of each initial state",
                    "description": f"index into the attractor dimension; {legend}"}),
         "periods": ((r.y_state, r.x_state), r.periods.astype(np.int32),
                     {"long_name": "forcing periods integrated until the cell settled"}),
         "attractor_kind": (("attractor",), per(lambda a: a.code, np.int32),
                            {"flag_values": list(range(len(KINDS))), "flag_meanings": " ".join(KINDS)}),
         "attractor_period": (("attractor",), per(lambda a: a.period or 0, np.int32),
                              {"long_name": "forcing periods of a periodic orbit (0: not periodic)"}),
         "rattle_state": (("attractor",), per(lambda a: -1 if a.rattle_state is None else a.rattle_state, np.int32),
                          {"long_name": "0 no contact loss, 1 contact loss only, 2 back-side contact, -1 none"}),
         "max_multiplier": (("attractor",), per(lambda a: a.max_multiplier),
                            {"long_name": "largest Floquet multiplier modulus (periodic)"}),
         "lyapunov": (("attractor",), per(lambda a: a.lyapunov), {"long_name": "largest Lyapunov exponent"}),
         "lyapunov_error": (("attractor",), per(lambda a: a.lyapunov_error)),
         "fraction": (("attractor",), per(lambda a: r.count(a.index) / r.labels.size),
                      {"long_name": "fraction of the cells in the basin"}),
         "n_points": (("attractor",), per(lambda a: len(a.points), np.int32)),
         "poincare": (("attractor", "point", "state"), pts,
                      {"long_name": "Poincare points at the phase (NaN padded)"}),
         "minimum": (("attractor", "state"), np.array([a.minimum for a in r.attractors]).reshape(A, n_st)),
         "maximum": (("attractor", "state"), np.array([a.maximum for a in r.attractors]).reshape(A, n_st)),
         "amplitude": (("attractor", "state"), np.array([a.amplitude for a in r.attractors]).reshape(A, n_st),
                       {"long_name": "peak-to-peak along the attractor"})},
        coords={r.x_state: r.x_values, r.y_state: r.y_values, "attractor": np.arange(A, dtype=np.int32),
                "state": np.arange(n_st, dtype=np.int32)},
        attrs={"scene": r.scene, "x_state": r.x_state, "y_state": r.y_state, "phase": r.phase, "t0": r.t0,
               "period": r.period, "state_names": ",".join(r.state_names), "base": r.base.tolist(),
               "params": json.dumps(r.params), "attractor_names": "; ".join(a.name for a in r.attractors),
               "options": json.dumps(asdict(r.options)),
               "stats": json.dumps({k: v for k, v in r.stats.items()}, default=str)})
    return ds


_SPECIAL_COLOURS = {UNRESOLVED: "#d9d9d9", UNBOUNDED: "#000000", FAILED: "#ff00ff"}


def _plot(r: BasinResult, ax: Any = None) -> Any:
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    if ax is None:
        _, ax = plt.subplots(figsize=(7.5, 5.6))
    palette = plt.get_cmap("tab10" if len(r.attractors) <= 10 else "tab20")
    colours = [_SPECIAL_COLOURS[FAILED], _SPECIAL_COLOURS[UNBOUNDED], _SPECIAL_COLOURS[UNRESOLVED]]
    colours += [palette(i % palette.N) for i in range(len(r.attractors))]
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(-3.5, len(r.attractors) + 0.5), cmap.N)
    ax.pcolormesh(r.x_values, r.y_values, r.labels, cmap=cmap, norm=norm, shading="nearest")
    xi, yi = r.state_names.index(r.x_state), r.state_names.index(r.y_state)
    handles = []
    for a in r.attractors:
        c = colours[a.index + 3]
        periodic = a.kind == "periodic"
        ax.plot(a.points[:, xi], a.points[:, yi], "o" if periodic else ".", ms=7 if periodic else 1.5,
                mfc=c, mec="k", mew=0.8 if periodic else 0, ls="none")
        handles.append(Patch(facecolor=c, edgecolor="k", label=f"{r.label_name(a.index)} "
                                                               f"({r.count(a.index) / r.labels.size:.0%})"))
    for lab, name in SPECIAL_LABELS.items():
        if r.count(lab):
            handles.append(Patch(facecolor=_SPECIAL_COLOURS[lab], edgecolor="k",
                                 label=f"{name} ({r.count(lab) / r.labels.size:.1%})"))
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.85)
    ax.set_xlim(r.x_values[0], r.x_values[-1])
    ax.set_ylim(r.y_values[0], r.y_values[-1])
    ax.set_xlabel(r.x_state)
    ax.set_ylabel(r.y_state)
    ax.set_title(f"{r.scene}: basins of attraction at phase {r.phase:g} (circles: Poincare points)", fontsize=10)
    return ax
