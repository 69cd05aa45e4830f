"""Maps that show every coexisting stable response: the searches over the grid and their layers.

:func:`gearsym.analysis.sweeps.stability_map` keeps, besides the response its row sweep follows
(the 2-D layers ``max_multiplier``, ``rattle_state``, ``response``, ...: unchanged), every
attractor found at each grid point (:mod:`gearsym.analysis.sweeps._map_attractors`) when the
coexistence search is on (``search``):

1. **rows** (tasks in parallel, as the map's row tasks): along each row, forward then backward,
   every point starts from the attractors of its neighbour (Newton from its orbits; where there is
   no stable orbit there any more, the landing from its state: where a slow sweep jumps).  The
   forward pass also runs the map's own row sweep (its 2-D layers).  Attractors that Newton
   continued onto each other are one branch: an attractor is not continued to a point that
   already has one of its branch (there Newton would find that one again); a landing (a jump)
   joins no branches, so the other side of a fold is still searched.
2. **starts** (in the same tasks): at every point, the landings from the scene's initial state
   (or ``x0``), the static equilibrium at the point's parameters, the rest state (every state
   zero), before the passes carry what they find along the row; after the passes, ``spread``
   states on the diagonal of the box of the states along the orbits found at the point, from half
   its size below to half its size above it.
3. **columns** (tasks in parallel, after the rows): along each column, up then down, every point
   starts from the attractors of its neighbour (found by the rows or by this pass).

The cost grows with rows x columns x directions x attractors per point (each continuation is a
Newton solve, each start a landing of at most ``land_periods`` forcing periods, a non-periodic
attractor a Lyapunov run).  ``search="auto"`` (the default) runs every search on maps of at most
:data:`COEXIST_DEFAULT_POINTS` points of a nonlinear model, none on larger maps or linear models
(one periodic orbit).

The layers, along the dimension ``attractor`` (attractors sorted at each point: the stable
periodic orbits first by rattle state, period and peak-to-peak, then the non-periodic ones;
the map's 2-D ``response`` variable keeps its name, so the dimension is not called so):
``attractor_kind`` (:data:`ATTRACTOR_KINDS`), ``attractor_periods``, ``attractor_max_multiplier``,
``attractor_stability`` (0 asymptotically stable, 1 neutral), ``attractor_rattle_state``,
``attractor_peak_to_peak``, ``attractor_lyapunov`` (+ ``_error``), ``attractor_found_by``
(:data:`FOUND_BY`), ``attractor_x0`` (with ``state``), and per mesh ``attractor_mesh_rattle_state``,
``attractor_mesh_peak_to_peak`` (with ``mesh``); in 2-D ``n_stable`` (stable periodic orbits) and
``n_attractors`` (all).  With the quantity ``lyapunov`` (or the search on), the 2-D ``lyapunov``,
``lyapunov_error`` and ``response_kind`` are those of the attractor of the row sweep: its periodic
response, else the attractor its integration lands on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError, ParameterError
from . import _workers
from ._attractor_id import ATTRACTOR_KINDS, CHAOTIC, PERIODIC, QUASI_PERIODIC
from ._map_attractors import FOUND_BY, SEARCHES, MapAttractor, PointSearch, SearchOptions
from ._map_points import is_linear, map_point

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

    from ...system import CompiledSystem

__all__ = ["COEXIST_DEFAULT_POINTS", "add_layers", "column_phase", "is_linear", "resolve_search", "run_rows"]

#: ``search="auto"`` searches every coexisting response on maps of at most this many points.
COEXIST_DEFAULT_POINTS = 100


def resolve_search(search: Any, n_points: int, linear: bool) -> SearchOptions | None:
    """The coexistence search of a map: ``None`` (off) or its :class:`SearchOptions`.

    Parameters
    ----------
    search
        ``"auto"`` / ``None`` (on for at most :data:`COEXIST_DEFAULT_POINTS` points of a nonlinear
        model), ``"none"`` / ``"off"`` / ``False``, ``"all"`` / ``"on"`` / ``True``, a comma-separated
        subset of :data:`SEARCHES` (or a sequence of them), or a :class:`SearchOptions`.
    n_points
        The map's points.
    linear
        The model is linear (one periodic orbit: nothing coexists).

    Returns
    -------
    SearchOptions or None
    """
    if isinstance(search, SearchOptions):
        return None if not search.search else search
    if search is None or search == "auto":
        return SearchOptions() if n_points <= COEXIST_DEFAULT_POINTS and not linear else None
    if search is False or search in ("none", "off", ""):
        return None
    if search is True or search in ("all", "on"):
        return SearchOptions()
    items = [s.strip() for s in search.split(",")] if isinstance(search, str) else list(search)
    if not all(isinstance(s, str) for s in items):
        raise ParameterError(f"search must be 'auto', 'none', 'all' or a list of {', '.join(SEARCHES)}; got {search!r}")
    return SearchOptions(search=tuple(s for s in items if s)) if any(items) else None


# ------------------------------------------------------------------ the row tasks
def _start_states(system: CompiledSystem, params: Mapping[str, float], x0: Sequence[float] | None
                  ) -> list[tuple[int, np.ndarray]]:
    """The fixed starts of a point: initial state, static equilibrium (where one is found), rest."""
    from ...static import static_state

    starts: list[tuple[int, np.ndarray]] = [(5, np.asarray(system.x0 if x0 is None else x0, float))]
    try:
        starts.append((6, np.asarray(static_state(system, params=params), float)))
    except (GearsymError, ValueError, np.linalg.LinAlgError):
        pass  # no static equilibrium (a rigid-body mode, no consistent contact state): no such start
    starts.append((7, np.zeros(system.generated.nx)))
    out: list[tuple[int, np.ndarray]] = []
    for how, x in starts:
        if np.all(np.isfinite(x)) and not any(np.array_equal(x, y) for _, y in out):
            out.append((how, x))
    return out


def _spread_states(attractors: Sequence[MapAttractor], n: int) -> list[np.ndarray]:
    """``n`` states on the diagonal of the box of the periodic attractors' states, from half its size
    below it to half its size above it."""
    per = [a for a in attractors if a.kind == PERIODIC]
    if not per or n < 1:
        return []
    lo = np.min([a.lo for a in per], axis=0)
    hi = np.max([a.hi for a in per], axis=0)
    w = hi - lo
    return [lo - 0.5 * w + f * 2.0 * w for f in (np.linspace(0.0, 1.0, n) if n > 1 else [0.5])]


def _sweep_attractor(search: PointSearch, r: dict[str, Any], orbit: Any, guess: np.ndarray | None,
                     x0: Sequence[float] | None, describe: bool) -> MapAttractor | None:
    """The attractor of the map's row sweep at a point: its stable response ``orbit`` (described when
    ``describe``), else where the integration from the sweep's state lands."""
    if r["response"] == 1:
        return search.take(orbit, 0) if describe and orbit is not None else None
    start = guess if guess is not None else np.asarray(search.system.x0 if x0 is None else x0, float)
    return search.start(start, 0)


def _promote(r: dict[str, Any], a: MapAttractor | None, periods: int, search: PointSearch, gear: str | None) -> None:
    """Where the map's own search found no stable response but the longer landing from the same start
    reached a stable orbit of the map's period, that orbit is the response (``response_search`` 3)."""
    if r["response"] == 1 or a is None or a.kind != PERIODIC or a.periods != periods:
        return
    r.update(response=1, response_search=3, max_multiplier=a.max_multiplier, x0=a.x0.tolist(),
             stability="asymptotically_stable" if a.stability == 0 else "neutral", rattle_state=a.rattle_state,
             converged=True, peak_to_peak=a.peak_to_peak)
    if gear:  # the map's gear quantity of that response (gearsym.quantities)
        from ...quantities import orbit_quantities

        orbit = search.solve(a.x0, periods)
        try:
            r[gear] = math.nan if orbit is None else orbit_quantities(search.system, orbit, [gear])[gear]
        except GearsymError as exc:
            r["error"] = f"the gear quantity {gear} failed: {exc}"


def _lyapunov_fields(r: dict[str, Any], a: MapAttractor | None, T: float, periods: int) -> dict[str, Any]:
    """The 2-D ``lyapunov``, ``lyapunov_error``, ``response_kind`` of a point."""
    if r["response"] == 1:
        mu = float(r["max_multiplier"])
        lam = math.log(mu) / (periods * T) if mu > 0 else -math.inf
        err = a.lyapunov_error if a is not None and a.kind == PERIODIC else math.nan
        return {"lyapunov": lam, "lyapunov_error": err, "response_kind": PERIODIC}
    if a is None:
        return {"lyapunov": math.nan, "lyapunov_error": math.nan, "response_kind": -1}
    return {"lyapunov": a.lyapunov, "lyapunov_error": a.lyapunov_error, "response_kind": a.kind}


def run_rows(system: CompiledSystem, task: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Task function (module level, picklable): whole rows of a map, with the map's own row sweep
    (its records, as :func:`gearsym.analysis.sweeps._maps` makes them), the 2-D Lyapunov fields and,
    with ``task["coexist"]``, the coexistence search (module docstring); each record then gets
    ``attractors``, ``notes`` and ``search_stats``.  (Maps without either run the plain row task.)"""
    opts: SearchOptions | None = task.get("coexist")
    base = dict(task["params"])
    x0 = task.get("x0")
    guess = None if x0 is None else np.asarray(x0, float)
    n_row, first = int(task["row_length"]), int(task["first_index"])
    records: list[dict[str, Any]] = []
    searches: list[PointSearch] = []
    prev_sweep: MapAttractor | None = None
    for i, (xv, yv) in enumerate(task["points"]):
        params = {**base, task["xname"]: float(xv), task["yname"]: float(yv)}
        r = map_point(system, params, task["method"], task["periods"], guess, task["want_ptp"], task["options"],
                      gear=task.get("gear"), keep_orbit=True)
        orbit = r.pop("orbit", None)
        search = PointSearch(system, params, r["method"], task["options"], opts or SearchOptions(), first + i)
        a = _sweep_attractor(search, r, orbit, guess, x0, opts is not None)
        if a is not None and i % n_row and r.get("response_search") == 0 and prev_sweep is not None:
            a.branches |= prev_sweep.branches  # Newton continued the previous point's response onto it
        prev_sweep = a
        _promote(r, a, int(task["periods"]), search, task.get("gear"))
        r.update(_lyapunov_fields(r, a, search.T, int(task["periods"])))
        if r["response"] == 1 and r["x0"] is not None and np.all(np.isfinite(r["x0"])):
            guess = np.asarray(r["x0"], float)  # (the map's own rule: never from an unstable orbit)
        if opts is not None:
            if "starts" in opts.search:
                for how, x in _start_states(system, params, x0):
                    search.start(x, how)
            if "rows" in opts.search and i % n_row:
                for b in list(searches[-1].attractors):
                    if not search.connected(b):
                        search.follow(b, 1, search.index - 1)
        records.append(r)
        searches.append(search)
        _workers.report(1)
    if opts is not None:
        _backward_and_spread(searches, n_row, opts)
        for r, s in zip(records, searches, strict=True):
            r.update(attractors=list(s.attractors), notes=list(s.notes), search_stats=dict(s.stats))
    return records


def _backward_and_spread(searches: list[PointSearch], n_row: int, opts: SearchOptions) -> None:
    """The backward pass of each row and the spread starts."""
    for r0 in range(0, len(searches), n_row):
        row = searches[r0: r0 + n_row]
        if "rows" in opts.search:
            for i in range(len(row) - 2, -1, -1):
                for b in list(row[i + 1].attractors):
                    if not row[i].connected(b):
                        row[i].follow(b, 2, row[i + 1].index)
        if "starts" in opts.search:
            for s in row:
                for x in _spread_states(s.attractors, opts.spread):
                    s.start(x, 8)


# ------------------------------------------------------------------ the column tasks
def run_columns(system: CompiledSystem, task: Mapping[str, Any]) -> list[list[dict[str, Any]]]:
    """Task function: whole columns, up then down (module docstring); per column and point, the new
    attractors, notes and counts."""
    opts: SearchOptions = task["coexist"]
    out = []
    for col in task["columns"]:
        searches = [PointSearch(system, p, task["method"], task["options"], opts, idx, known)
                    for p, idx, known in zip(col["params"], col["indices"], col["known"], strict=True)]
        n = len(searches)
        for how, order, step in ((3, range(1, n), -1), (4, range(n - 2, -1, -1), +1)):
            for j in order:
                for b in list(searches[j + step].attractors):
                    if not searches[j].connected(b):
                        searches[j].follow(b, how, searches[j + step].index)
        out.append([{"new": s.new, "notes": s.notes, "stats": s.stats} for s in searches])
        _workers.report(n)
    return out


def column_phase(system: CompiledSystem, records: list[dict[str, Any]], shape: tuple[int, int],
                 point_params: list[dict[str, float]], common: Mapping[str, Any], n_workers: int, dask: Any,
                 progress: Any) -> None:
    """Run the column tasks (columns in parallel) and add what they find to ``records`` (in place)."""
    ny, nx = shape
    if ny < 2:
        return
    per_task = max(1, int(math.ceil(nx / max(1, 4 * n_workers))))
    tasks = []
    for i0 in range(0, nx, per_task):
        cols = []
        for i in range(i0, min(nx, i0 + per_task)):
            idx = [j * nx + i for j in range(ny)]
            cols.append({"indices": idx, "params": [point_params[k] for k in idx],
                         "known": [records[k].get("attractors", []) for k in idx]})
        tasks.append({**common, "columns": cols})
    weights = [ny * len(t["columns"]) for t in tasks]
    results, _ = _workers.run_tasks(run_columns, system, tasks, workers=n_workers, dask=dask, progress=progress,
                                    weights=weights)
    for task, res in zip(tasks, results, strict=True):
        if isinstance(res, _workers.TaskFailure):
            for col in task["columns"]:
                for k in col["indices"]:
                    records[k].setdefault("notes", []).append(f"the column search failed: {res.message}")
            continue
        for col, per_point in zip(task["columns"], res, strict=True):
            for k, found in zip(col["indices"], per_point, strict=True):
                rec = records[k]
                rec["attractors"] = list(rec.get("attractors", [])) + list(found["new"])
                rec.setdefault("notes", []).extend(found["notes"])
                st = rec.setdefault("search_stats", {"solves": 0, "periods": 0})
                for key in ("solves", "periods"):
                    st[key] = st.get(key, 0) + found["stats"].get(key, 0)


# ------------------------------------------------------------------ the layers
def add_layers(ds: xr.Dataset, records: list[dict[str, Any]], state_names: Sequence[str],
               mesh_names: Sequence[str], coexist: SearchOptions | None) -> xr.Dataset:
    """The 2-D Lyapunov layers (where computed) and the attractor layers (module docstring)."""
    yname, xname = ds["rattle_state"].dims
    ny, nx = ds.sizes[yname], ds.sizes[xname]
    dims = (yname, xname)
    if any("lyapunov" in r for r in records):
        lam = np.array([r.get("lyapunov", math.nan) for r in records], float).reshape(ny, nx)
        err = np.array([r.get("lyapunov_error", math.nan) for r in records], float).reshape(ny, nx)
        kind = np.array([r.get("response_kind", -1) for r in records], np.int8).reshape(ny, nx)
        ds["lyapunov"] = (dims, lam, {"long_name": "largest Lyapunov exponent of the row sweep's attractor (per "
                                      "unit of the system's time): log max|mu| / T of its periodic response, else of "
                                      "the attractor its integration lands on"})
        ds["lyapunov_error"] = (dims, err, {"long_name": "error of lyapunov (95 % half-width; for a periodic "
                                            "response the multiplier's tolerance)"})
        ds["response_kind"] = (dims, kind, {"long_name": "kind of the row sweep's attractor: " + "; ".join(
            f"{k} {v}" for k, v in ATTRACTOR_KINDS.items()) + "; -1 not known"})
    if coexist is None:
        return ds
    atts = [sorted(r.get("attractors", []), key=lambda a: a.order_key()) for r in records]
    m = max(1, max(len(a) for a in atts))
    nxs = len(state_names)
    shape = (ny, nx, m)
    f = {k: np.full(shape, np.nan) for k in ("max_multiplier", "peak_to_peak", "lyapunov", "lyapunov_error")}
    i8 = {k: np.full(shape, -1, np.int8) for k in ("kind", "stability", "rattle_state", "found_by")}
    per = np.zeros(shape, np.int16)
    x0 = np.full((*shape, nxs), np.nan)
    mr = np.full((*shape, len(mesh_names)), -1, np.int8)
    mp = np.full((*shape, len(mesh_names)), np.nan)
    for idx, lst in enumerate(atts):
        j, i = divmod(idx, nx)
        for q, a in enumerate(lst):
            for k in f:
                f[k][j, i, q] = getattr(a, k)
            i8["kind"][j, i, q], i8["stability"][j, i, q] = a.kind, a.stability
            i8["rattle_state"][j, i, q], i8["found_by"][j, i, q] = a.rattle_state, a.found_by
            per[j, i, q] = a.periods
            x0[j, i, q] = a.x0
            for w, name in enumerate(mesh_names):
                mr[j, i, q, w] = a.mesh_rattle.get(name, -1)
                mp[j, i, q, w] = a.mesh_peak_to_peak.get(name, math.nan)
    kinds = i8["kind"]
    d3 = (*dims, "attractor")
    ds = ds.assign_coords(attractor=np.arange(m), state=list(state_names))
    ds["n_stable"] = (dims, np.sum(kinds == PERIODIC, axis=2).astype(np.int8),
                      {"long_name": "number of coexisting stable periodic orbits found"})
    ds["n_attractors"] = (dims, np.sum(kinds >= 0, axis=2).astype(np.int8),
                          {"long_name": "number of attractors found (stable periodic orbits and non-periodic "
                                        "responses)"})
    ds["attractor_kind"] = (d3, kinds, {"long_name": "; ".join(f"{k} {v}" for k, v in ATTRACTOR_KINDS.items()) + "; -1 none"})
    ds["attractor_periods"] = (d3, per, {"long_name": "period of the orbit in forcing periods (0: non-periodic "
                                                      "or none)"})
    ds["attractor_max_multiplier"] = (d3, f["max_multiplier"], {"long_name": "max|mu| of the stable orbit"})
    ds["attractor_stability"] = (d3, i8["stability"], {"long_name": "0 asymptotically stable, 1 neutral (a "
                                                       "multiplier on the unit circle within the monodromy's error)"})
    ds["attractor_rattle_state"] = (d3, i8["rattle_state"], {"long_name": "rattle state of the orbit (worst mesh): "
                                    "0 no contact loss, 1 contact loss only, 2 back-side contact; -1 none"})
    ds["attractor_peak_to_peak"] = (d3, f["peak_to_peak"], {"long_name": "peak-to-peak of the first state"})
    ds["attractor_lyapunov"] = (d3, f["lyapunov"], {"long_name": "largest Lyapunov exponent (per unit of the "
                                "system's time): log max|mu| / (k T) of an orbit, computed for the others"})
    ds["attractor_lyapunov_error"] = (d3, f["lyapunov_error"], {"long_name": "its error"})
    ds["attractor_found_by"] = (d3, i8["found_by"], {"long_name": "; ".join(f"{k} {v}"
                                                                            for k, v in FOUND_BY.items())})
    ds["attractor_x0"] = ((*d3, "state"), x0, {"long_name": "a state on the attractor at a whole number of "
                                               "forcing periods (an orbit's: its state at t0)"})
    if len(mesh_names):
        ds = ds.assign_coords(mesh=list(mesh_names))
        ds["attractor_mesh_rattle_state"] = ((*d3, "mesh"), mr, {"long_name": "rattle state of each mesh"})
        ds["attractor_mesh_peak_to_peak"] = ((*d3, "mesh"), mp, {"long_name": "peak-to-peak of each mesh's "
                                                                              "dynamic deflection"})
    n_st = ds["n_stable"].values
    ds.attrs.update({"coexist_search": ",".join(coexist.search), "n_coexisting": int(np.sum(n_st >= 2)),
                     "max_stable": int(np.max(n_st)) if n_st.size else 0,
                     "n_chaotic": int(np.sum(np.any(kinds == CHAOTIC, axis=2))),
                     "n_quasi_periodic": int(np.sum(np.any(kinds == QUASI_PERIODIC, axis=2)))})
    return ds
