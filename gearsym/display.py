"""How results show themselves: short reprs, HTML and LaTeX for notebooks, xarray and pandas.

Every result class of gearsym takes its display from one mixin here (kept apart from the
classes, which hold the numbers): a ``__repr__`` of one or a few lines (never the arrays),
``_repr_html_`` for Jupyter, and the conversions ``to_xarray()`` / ``to_dataframe()``.

**Units in the conversions.**  Time and states are in coherent SI units (the unit of each
state is its coordinate's: ``m``, ``rad``, ``m/s``, ...; ``1`` for a model in dimensionless
variables), parameter values in the units the model declares (``b_m`` in ``um`` when the model
says so), as everywhere in gearsym's API.  An xarray variable or coordinate carries its unit in
``attrs["units"]``; the parameters are attributes ``param_<name>`` with ``param_<name>_units``;
``attrs["units_convention"]`` says this once more.  A pandas frame carries the same in
``df.attrs["units"]`` (column -> unit) and ``df.attrs["params"]``.

Every dataset written by a ``to_xarray()`` method (:meth:`TrajectoryDisplay.to_xarray`, ...)
has only netCDF-safe attributes (numbers, strings, 1-D number arrays: ``True``/``False`` as
1/0, ``None`` as ``""``, mappings as JSON), so ``ds.to_netcdf(path)`` works with every engine, scipy's netCDF-3 included
(:func:`netcdf_engine`).

xarray and pandas come with ``gearsym[maps]`` (:mod:`gearsym.extras`); the reprs need neither.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .extras import require

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

__all__ = ["UNITS_CONVENTION", "BasinDisplay", "BifurcationDisplay", "BranchDisplay", "GearQuantitiesDisplay",
           "MeshQuantitiesDisplay", "BranchPointDisplay", "DimensionlessDisplay",
           "LyapunovDisplay", "ModalDisplay", "OrbitDisplay", "RunupDisplay", "SceneDisplay", "SymbolicDisplay",
           "SystemDisplay",
           "TrajectoryDisplay", "fmt", "html_card", "names_list", "netcdf_attrs", "netcdf_engine", "params_text"]

#: The sentence every dataset and frame carries (``attrs["units_convention"]``).
UNITS_CONVENTION = ("time and states in coherent SI units (each variable's 'units'; '1' for dimensionless "
                    "variables); parameter values in the model's declared units (param_<name>_units)")

_STABILITY_WORDS = {"asymptotically_stable": "stable", "neutral": "neutral", "unstable": "unstable", "": "unknown",
                    "unknown": "unknown"}


# ------------------------------------------------------------------ text helpers
def fmt(v: Any, digits: int = 6) -> str:
    """A number as ``%.{digits}g`` (complex as ``a+bj``), anything else as ``str``."""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (complex, np.complexfloating)):
        return f"{v.real:.{digits}g}{v.imag:+.{digits}g}j" if v.imag else f"{v.real:.{digits}g}"
    if isinstance(v, (float, np.floating, int, np.integer)):
        return f"{float(v):.{digits}g}" if isinstance(v, (float, np.floating)) else str(int(v))
    return "None" if v is None else str(v)


def names_list(names: Sequence[str], limit: int = 6) -> str:
    """``a, b, c, ... (+k)``: the first ``limit`` names and how many more."""
    names = list(names)
    head = ", ".join(names[:limit])
    return head + (f", ... (+{len(names) - limit})" if len(names) > limit else "")


def _with_unit(value: str, unit: str) -> str:
    return value if unit in ("", "1", None) else f"{value} {unit}"


def params_text(params: Mapping[str, float], units: Mapping[str, str] | None = None, limit: int = 4) -> str:
    """``name=value unit, ...``: the first ``limit`` parameters and how many more."""
    units = units or {}
    items = [f"{k}={_with_unit(fmt(v, 4), units.get(k, ''))}" for k, v in params.items()]
    return ", ".join(items[:limit]) + (f", ... (+{len(items) - limit})" if len(items) > limit else "")


def _stability(word: str) -> str:
    return _STABILITY_WORDS.get(word, word.replace("_", " "))


def _mu_text(mu: Sequence[complex], limit: int = 4) -> str:
    mu = list(mu)
    return ", ".join(fmt(m, 4) for m in mu[:limit]) + (f", ... (+{len(mu) - limit})" if len(mu) > limit else "")


# ------------------------------------------------------------------ HTML helpers
def _e(text: Any) -> str:
    return html.escape(str(text))


def html_table(header: Sequence[str] | None, rows: Iterable[Sequence[Any]]) -> str:
    """A compact HTML table (cells escaped)."""
    out = ['<table style="border-collapse:collapse;font-size:90%">']
    if header:
        out.append("<tr>" + "".join(f'<th style="text-align:left;padding:1px 8px">{_e(h)}</th>' for h in header)
                   + "</tr>")
    for r in rows:
        out.append("<tr>" + "".join(f'<td style="text-align:left;padding:1px 8px">{_e(c)}</td>' for c in r) + "</tr>")
    out.append("</table>")
    return "".join(out)


def html_card(title: str, summary: str, rows: Sequence[tuple[str, Any]] = (),
              sections: Sequence[tuple[str, str]] = ()) -> str:
    """The HTML of a result: a bold title, a one-line summary, a key-value table and folded sections.

    Parameters
    ----------
    title
        The class (``"Trajectory"``).
    summary
        One line (escaped).
    rows
        ``(key, value)`` pairs shown as a table (escaped).
    sections
        ``(label, html)``: folded ``<details>`` blocks (their HTML is taken as it is).

    Returns
    -------
    str
    """
    parts = [f'<div class="gearsym-repr"><b>{_e(title)}</b> {_e(summary)}']
    if rows:
        parts.append(html_table(None, [(k, v) for k, v in rows]))
    for label, body in sections:
        parts.append(f"<details><summary>{_e(label)}</summary>{body}</details>")
    parts.append("</div>")
    return "".join(parts)


def _params_table(params: Mapping[str, float], units: Mapping[str, str]) -> str:
    return html_table(("parameter", "value", "unit"), [(k, fmt(v), units.get(k, "") or "") for k, v in params.items()])


# ------------------------------------------------------------------ conversions
def netcdf_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """Attributes every netCDF engine stores: numbers, strings, 1-D number arrays.

    ``bool`` -> 0/1, ``None`` -> ``""``, mappings and other sequences -> JSON text, complex ->
    its text, numpy scalars -> Python numbers.

    Parameters
    ----------
    attrs
        Any attributes.

    Returns
    -------
    dict
    """
    out: dict[str, Any] = {}
    for k, v in attrs.items():
        if isinstance(v, (bool, np.bool_)):
            out[k] = int(v)
        elif v is None:
            out[k] = ""
        elif isinstance(v, (np.integer, int)):
            out[k] = int(v)
        elif isinstance(v, (np.floating, float)):
            out[k] = float(v)
        elif isinstance(v, str):
            out[k] = v
        elif isinstance(v, (complex, np.complexfloating)):
            out[k] = fmt(v, 17)
        elif isinstance(v, np.ndarray) and v.ndim == 1 and v.dtype.kind in "if":
            out[k] = v
        else:
            out[k] = json.dumps(v, default=_json_default)
    return out


def _json_default(v: Any) -> Any:
    if isinstance(v, (np.integer, np.floating)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, complex):
        return [v.real, v.imag]
    return str(v)


def netcdf_engine() -> str:
    """The netCDF engine installed: ``netcdf4``, else ``h5netcdf``, else scipy's netCDF-3 (``scipy``).

    Returns
    -------
    str
        For ``Dataset.to_netcdf(engine=...)`` and ``xarray.open_dataset(engine=...)``.
    """
    import importlib.util

    for eng, mod in (("netcdf4", "netCDF4"), ("h5netcdf", "h5netcdf")):
        if importlib.util.find_spec(mod) is not None:
            return eng
    return "scipy"


def _xarray(what: str) -> Any:
    require("maps", what)
    import xarray as xr

    return xr


def _pandas(what: str) -> Any:
    require("maps", what)
    import pandas as pd

    return pd


def _param_attrs(params: Mapping[str, float], units: Mapping[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in params.items():
        out[f"param_{k}"] = float(v)
        out[f"param_{k}_units"] = units.get(k, "") or ""
    return out


def _unit(units: Mapping[str, str], name: str) -> str:
    return units.get(name, "") or ""


def _series_dataset(t: np.ndarray, y: np.ndarray, names: Sequence[str], units: Mapping[str, str],
                    attrs: Mapping[str, Any], what: str) -> xr.Dataset:
    """A dataset of state series on the time coordinate ``t`` (one variable per state)."""
    xr = _xarray(what)
    data = {n: ("t", np.asarray(y[:, i], float), {"units": _unit(units, n), "long_name": f"state {n}"})
            for i, n in enumerate(names)}
    coords = {"t": ("t", np.asarray(t, float), {"units": _unit(units, "t") or "s", "long_name": "time"})}
    return xr.Dataset(data, coords=coords, attrs=netcdf_attrs({"units_convention": UNITS_CONVENTION, **attrs}))


def _series_frame(t: np.ndarray, y: np.ndarray, names: Sequence[str], units: Mapping[str, str],
                  params: Mapping[str, float], what: str) -> pd.DataFrame:
    pd = _pandas(what)
    df = pd.DataFrame(np.asarray(y, float), columns=list(names), index=pd.Index(np.asarray(t, float), name="t"))
    df.attrs["units"] = {"t": _unit(units, "t") or "s", **{n: _unit(units, n) for n in names}}
    df.attrs["params"] = dict(params)
    df.attrs["param_units"] = {k: _unit(units, k) for k in params}
    df.attrs["units_convention"] = UNITS_CONVENTION
    return df


# ================================================================== trajectories
class TrajectoryDisplay:
    """Display and conversions of :class:`gearsym.Trajectory`."""

    def __repr__(self) -> str:
        t, n = self.t, len(self.t)  # type: ignore[attr-defined]
        span = f"t {fmt(t[0], 4)} .. {fmt(t[-1], 4)}" if n else "no output"
        per = f", period {fmt(self.period, 6)}" if self.period else ""  # type: ignore[attr-defined]
        return (f"Trajectory({len(self.state_names)} states [{names_list(self.state_names)}], "  # type: ignore[attr-defined]
                f"{span} ({n} points), {len(self.events)} events{per}; "  # type: ignore[attr-defined]
                f"{params_text(self.params, getattr(self, 'units', {}))})")  # type: ignore[attr-defined]

    def _repr_html_(self) -> str:
        units = getattr(self, "units", {}) or {}
        t, y, names = self.t, self.y, self.state_names  # type: ignore[attr-defined]
        rows = [("time", f"{_with_unit(f'{fmt(t[0])} .. {fmt(t[-1])}', _unit(units, 't'))}, {len(t)} points"
                 if len(t) else "none"),
                ("events", f"{len(self.events)} surface crossings"),  # type: ignore[attr-defined]
                ("forcing period", fmt(self.period) if self.period else "none"),  # type: ignore[attr-defined]
                ("steps", self.stats.get("n_steps", "")), ("wall time", f"{fmt(self.stats.get('wall_s', math.nan), 3)} s")]  # type: ignore[attr-defined]
        states = html_table(("state", "unit", "min", "max", "final"),
                            [(n, _unit(units, n), fmt(np.min(y[:, i])), fmt(np.max(y[:, i])), fmt(y[-1, i]))
                             for i, n in enumerate(names)] if len(t) else [])
        return html_card("Trajectory", f"{len(names)} states, {len(t)} points", rows,
                         [("states", states), ("parameters", _params_table(self.params, units))])  # type: ignore[attr-defined]

    def to_xarray(self) -> xr.Dataset:
        """The trajectory as an :class:`xarray.Dataset`.

        Returns
        -------
        xarray.Dataset
            One variable per state on the coordinate ``t`` (``attrs["units"]``: the time
            unit, ``s`` or ``1``; each state its SI unit); the events as ``event_t``,
            ``event_surface``, ``event_direction`` on the dimension ``event``; the
            sensitivities (when computed) as ``sensitivity_<parameter>`` on ``(t, state)``;
            attributes ``period`` (NaN without one), ``param_<name>`` / ``param_<name>_units``
            (declared units), the run's settings and statistics (``setting_*``, ``stat_*``).
            Round-trips through netCDF (``to_netcdf``, any engine).
        """
        units = getattr(self, "units", {}) or {}
        attrs: dict[str, Any] = {"source": "gearsym.Trajectory",
                                 "period": math.nan if self.period is None else float(self.period),  # type: ignore[attr-defined]
                                 "period_units": _unit(units, "t") or "s",
                                 **_param_attrs(self.params, units)}  # type: ignore[attr-defined]
        attrs.update({f"setting_{k}": v for k, v in self.settings.items()})  # type: ignore[attr-defined]
        attrs.update({f"stat_{k}": v for k, v in self.stats.items() if isinstance(v, (int, float))})  # type: ignore[attr-defined]
        ds = _series_dataset(self.t, self.y, self.state_names, units, attrs, "Trajectory.to_xarray")  # type: ignore[attr-defined]
        ev = self.events  # type: ignore[attr-defined]
        ds["event_t"] = ("event", np.array([e.t for e in ev], float), {"units": _unit(units, "t") or "s",
                                                                      "long_name": "time of a surface crossing"})
        ds["event_surface"] = ("event", np.array([e.surface for e in ev], dtype=str),
                               {"long_name": "switching surface crossed"})
        ds["event_direction"] = ("event", np.array([e.direction for e in ev], np.int8),
                                 {"long_name": "+1: g from negative to positive, -1: the other way"})
        if self.sensitivities:  # type: ignore[attr-defined]
            ds = ds.assign_coords(state=("state", list(self.state_names)))  # type: ignore[attr-defined]
            for p, s in self.sensitivities.items():  # type: ignore[attr-defined]
                ds[f"sensitivity_{p}"] = (("t", "state"), np.asarray(s, float),
                                          {"long_name": f"d state / d {p} (state unit per {p} in SI)"})
        return ds

    def to_dataframe(self) -> pd.DataFrame:
        """The states as a :class:`pandas.DataFrame` indexed by time.

        Returns
        -------
        pandas.DataFrame
            One column per state, index ``t``; ``df.attrs``: ``units`` (column -> SI unit),
            ``params`` and ``param_units`` (declared units), ``units_convention``.
        """
        return _series_frame(self.t, self.y, self.state_names, getattr(self, "units", {}) or {},  # type: ignore[attr-defined]
                             self.params, "Trajectory.to_dataframe")  # type: ignore[attr-defined]


# ================================================================== periodic orbits
def _system_units(system: Any) -> dict[str, str]:
    """The unit of every value of a system's results (``{}`` without one)."""
    fn = getattr(system, "units_table", None)
    return dict(fn()) if callable(fn) else {}


class OrbitDisplay:
    """Display and conversions of :class:`gearsym.PeriodicOrbit`."""

    def _summary(self) -> str:
        o: Any = self
        rs = "" if o.rattle_state is None else f", rattle state {o.rattle_state}"
        return (f"{o.method}, period {fmt(o.period)} ({fmt(o.periods)} forcing period(s)), "
                f"{_stability(o.stability)}, max|mu| {fmt(o.max_multiplier, 4)}{rs}, "
                f"residual {fmt(o.residual, 2)} after {o.iterations} iterations")

    def __repr__(self) -> str:
        o: Any = self
        conv = "" if o.converged else " NOT CONVERGED"
        return f"PeriodicOrbit({self._summary()}{conv}; {params_text(o.params, _system_units(o.system))})"

    def _repr_html_(self) -> str:
        o: Any = self
        units = _system_units(o.system)
        mu = html_table(("multiplier", "|mu|", "tolerance"),
                        [(fmt(m, 6), fmt(abs(m), 6), fmt(o.multiplier_tolerances[i], 2)
                          if i < len(o.multiplier_tolerances) else "") for i, m in enumerate(o.multipliers)])
        x0 = html_table(("state", "x0", "unit"), [(n, fmt(v), _unit(units, n)) for n, v in zip(o.state_names, o.x0)])
        rows = [("method", o.method), ("period", _with_unit(fmt(o.period), _unit(units, "t"))),
                ("stability", f"{_stability(o.stability)} (max|mu| {fmt(o.max_multiplier)})"),
                ("converged", f"{o.converged}: residual {fmt(o.residual, 3)}, {o.iterations} iterations")]
        if o.rattle_states:
            rows.append(("rattle states", ", ".join(f"{k}: {v}" for k, v in o.rattle_states.items())))
        return html_card("PeriodicOrbit", _stability(o.stability), rows,
                         [("Floquet multipliers", mu), ("state at t0", x0),
                          ("parameters", _params_table(o.params, units))])

    def _samples(self, n_out: int | None) -> tuple[np.ndarray, np.ndarray]:
        """``(t, y)`` over one period: the engine's trajectory, else the harmonic series."""
        o: Any = self
        if o.system is not None:
            tr = o.trajectory(n_out=n_out)
            return tr.t, tr.y
        if o.coefficients is None:
            raise ValueError("this orbit has neither a system nor harmonic coefficients: no samples to convert")
        n = int(n_out or max(2048, int(1024 * o.periods) + 1))
        t = o.t0 + o.period * np.arange(n) / (n - 1)
        return t, _fourier_samples(np.asarray(o.coefficients, float), 2 * np.pi * (t - o.t0) / o.period)

    def _attrs(self, units: Mapping[str, str]) -> dict[str, Any]:
        o: Any = self
        return {"source": "gearsym.PeriodicOrbit", "method": o.method, "period": float(o.period),
                "period_units": _unit(units, "t") or "s", "periods": float(o.periods), "t0": float(o.t0),
                "stability": o.stability, "stable": bool(o.stable), "max_multiplier": float(o.max_multiplier),
                "converged": bool(o.converged), "iterations": int(o.iterations), "residual": float(o.residual),
                "rattle_state": -1 if o.rattle_state is None else int(o.rattle_state),
                "rattle_states": dict(o.rattle_states), **_param_attrs(o.params, units)}

    def to_xarray(self, n_out: int | None = None) -> xr.Dataset:
        """The sampled orbit (one period) and its multipliers as an :class:`xarray.Dataset`.

        Parameters
        ----------
        n_out
            Samples over the period (default: :meth:`~gearsym.PeriodicOrbit.trajectory`'s,
            1024 per forcing period).

        Returns
        -------
        xarray.Dataset
            One variable per state on ``t`` (SI units), ``x0`` (the state at ``t0``) on
            ``state``, ``multiplier_real`` / ``multiplier_imag`` / ``multiplier_tolerance``
            on ``multiplier``; attributes ``period`` (time unit), ``stability``, ``stable``,
            ``max_multiplier``, ``rattle_state`` (-1: none), ``param_<name>`` (declared units).
        """
        o: Any = self
        units = _system_units(o.system)
        t, y = self._samples(n_out)
        ds = _series_dataset(t, y, o.state_names, units, self._attrs(units), "PeriodicOrbit.to_xarray")
        ds = ds.assign_coords(state=("state", list(o.state_names)))
        ds["x0"] = ("state", np.asarray(o.x0, float), {"long_name": "state at t0 (units: those of each state)",
                                                        "units_of_states": json.dumps(
                                                            [_unit(units, n) for n in o.state_names])})
        mu = np.asarray(o.multipliers, complex)
        tol = np.asarray(o.multiplier_tolerances, float)
        ds["multiplier_real"] = ("multiplier", mu.real, {"units": "1", "long_name": "Floquet multiplier, real part"})
        ds["multiplier_imag"] = ("multiplier", mu.imag, {"units": "1", "long_name": "Floquet multiplier, imaginary part"})
        ds["multiplier_tolerance"] = ("multiplier", tol if len(tol) == len(mu) else np.full(len(mu), np.nan),
                                      {"units": "1", "long_name": "neutral band of each multiplier"})
        return ds

    def to_dataframe(self, n_out: int | None = None) -> pd.DataFrame:
        """The sampled orbit (one period) as a :class:`pandas.DataFrame` indexed by time.

        Parameters
        ----------
        n_out
            Samples over the period (default: :meth:`~gearsym.PeriodicOrbit.trajectory`'s).

        Returns
        -------
        pandas.DataFrame
            One column per state (SI units in ``df.attrs["units"]``); ``df.attrs`` also holds the
            orbit's period, stability, max|mu| and parameters (declared units).
        """
        o: Any = self
        units = _system_units(o.system)
        t, y = self._samples(n_out)
        df = _series_frame(t, y, o.state_names, units, o.params, "PeriodicOrbit.to_dataframe")
        df.attrs.update({k: v for k, v in self._attrs(units).items() if not k.startswith("param_")})
        return df


# ================================================================== branches
class BranchPointDisplay:
    """Display of :class:`gearsym.BranchPoint`."""

    def __repr__(self) -> str:
        p: Any = self
        rs = "" if p.rattle_state is None else f", rattle state {p.rattle_state}"
        bif = f", {p.bifurcation}" if p.bifurcation else ""
        mx = float(np.max(np.abs(p.multipliers))) if len(p.multipliers) else math.nan
        return (f"BranchPoint(value {fmt(p.value)}, {_stability(p.stability)}{bif}, max|mu| {fmt(mx, 4)}, "
                f"max {fmt(p.max, 4)}, min {fmt(p.min, 4)}, period {fmt(p.period)}{rs})")

    def _repr_html_(self) -> str:
        p: Any = self
        return html_card("BranchPoint", repr(self)[len("BranchPoint("):-1],
                         [("multipliers", _mu_text(p.multipliers, 8)), ("x0", ", ".join(fmt(v) for v in p.x0))])


class BifurcationDisplay:
    """Display of :class:`gearsym.Bifurcation`."""

    def __repr__(self) -> str:
        b: Any = self
        return (f"Bifurcation({b.type} at {fmt(b.value)}, multipliers {_mu_text(b.point.multipliers, 3)}, "
                f"max {fmt(b.point.max, 4)}, point {b.index})")

    def _repr_html_(self) -> str:
        b: Any = self
        info = [(k, v if isinstance(v, str) else fmt(v) if isinstance(v, (float, int, np.number))
                 else json.dumps(v, default=_json_default)[:120]) for k, v in b.info.items()]
        return html_card("Bifurcation", f"{b.type} at {fmt(b.value)}",
                         [("multipliers", _mu_text(b.point.multipliers, 8)),
                          ("x0", ", ".join(fmt(v) for v in b.point.x0)), ("period", fmt(b.point.period)), *info])


class BranchDisplay:
    """Display and conversions of :class:`gearsym.Branch`."""

    def _units(self) -> dict[str, str]:
        return _system_units(getattr(self, "system", None))

    def __repr__(self) -> str:
        b: Any = self
        n, vals = len(b.points), b.values
        rng = f"{fmt(np.min(vals), 6)} .. {fmt(np.max(vals), 6)}" if n else "no points"
        unit = self._units().get(b.param, "")
        bifs = ", ".join(f"{x.type} at {fmt(x.value, 5)}" for x in b.bifurcations[:4])
        more = f", ... (+{len(b.bifurcations) - 4})" if len(b.bifurcations) > 4 else ""
        kids = f", {len(b.children)} switched branches" if b.children else ""
        return (f"Branch({b.param} {_with_unit(rng, unit)}, {n} points ({int(np.sum(b.stable))} stable), "
                f"{len(b.bifurcations)} bifurcations{': ' + bifs + more if bifs else ''}; {b.method}, "
                f"{'complete' if b.complete else 'INCOMPLETE: ' + b.stop_reason[:80]}{kids})")

    def _repr_html_(self) -> str:
        b: Any = self
        units = self._units()
        bif = html_table(("type", b.param, "max", "multipliers"),
                         [(x.type, fmt(x.value), fmt(x.point.max), _mu_text(x.point.multipliers, 3))
                          for x in b.bifurcations])
        idx = list(range(len(b.points)))
        shown = idx if len(idx) <= 10 else idx[:5] + idx[-5:]
        pts = html_table(("#", b.param, "stability", "max|mu|", "max", "min", "rattle state"),
                         [(i, fmt(b.points[i].value), _stability(b.points[i].stability),
                           fmt(_max_abs(b.points[i].multipliers), 4), fmt(b.points[i].max, 5), fmt(b.points[i].min, 5),
                           b.points[i].rattle_state) for i in shown])
        unit = units.get(b.param, "")
        rows = [("parameter", f"{b.param} [{unit}]" if unit not in ("", "1") else b.param), ("points", len(b.points)),
                ("stable points", int(np.sum(b.stable))), ("method", f"{b.method}, {fmt(b.periods)} forcing period(s)"),
                ("end", f"{'complete' if b.complete else 'incomplete'}: {b.stop_reason}")]
        sections = [("bifurcations", bif)] if b.bifurcations else []
        return html_card("Branch", f"in {b.param}", rows,
                         sections + [(f"points ({'first and last 5' if len(idx) > 10 else 'all'})", pts)])

    def _columns(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """Column -> (values, unit, description), one value per point."""
        b: Any = self
        units = self._units()
        pts = b.points
        obs = b.state or (b.state_names[0] if b.state_names else "")
        cols: dict[str, tuple[np.ndarray, str, str]] = {
            b.param: (b.values, units.get(b.param, ""), "the continuation parameter (declared unit)"),
            "stable": (b.stable, "", "no multiplier outside the unit circle beyond its tolerance"),
            "stability": (np.array([p.stability for p in pts], dtype=str), "", "asymptotically_stable, neutral, unstable"),
            "n_unstable": (b.n_unstable, "", "multipliers outside the unit circle"),
            "max_multiplier": (np.array([_max_abs(p.multipliers) for p in pts]), "1", "max |mu|"),
            "period": (np.array([p.period for p in pts]), units.get("t", ""), "orbit period"),
        }
        for q in ("max", "min", "rms", "peak_to_peak"):
            cols[q] = (np.asarray(getattr(b, q), float), units.get(obs, ""), f"{q} of the observed state {obs}")
        cols["rattle_state"] = (np.array([-1 if r is None else r for r in b.rattle_states], int), "",
                                "0 no contact loss, 1 contact loss, 2 back-side contact, -1 none")
        cols["n_events"] = (np.array([p.n_events for p in pts], int), "", "surface crossings in one period")
        cols["bifurcation"] = (np.array([p.bifurcation or "" for p in pts], dtype=str), "", "type of a located point")
        cols["closure"] = (np.array([p.closure for p in pts], float), "1", "verification: mismatch / allowed")
        for i, n in enumerate(b.state_names):
            cols[f"x0_{n}"] = (np.array([p.x0[i] for p in pts], float), units.get(n, ""), f"state {n} at t0")
        for mesh in b.mesh_names:
            for q in ("min", "max", "peak_to_peak", "rattle_state"):
                unit = "" if q == "rattle_state" else "m"
                v = b.mesh_quantity(mesh, q)
                cols[f"{mesh}_{q}"] = (v.astype(np.int8) if q == "rattle_state" else v, unit,
                                       f"mesh {mesh}: {q} of its dynamic deflection" if unit else
                                       f"mesh {mesh}: 0 contact kept, 1 contact loss, 2 back-side contact, -1 unknown")
        return cols

    def _attrs(self) -> dict[str, Any]:
        b: Any = self
        units = self._units()
        params = b.info.get("params", {})
        return {"source": "gearsym.Branch", "param": b.param, "param_units": units.get(b.param, ""),
                "observed_state": b.state or (b.state_names[0] if b.state_names else ""), "method": b.method,
                "periods": float(b.periods), "complete": bool(b.complete), "stop_reason": b.stop_reason,
                "bifurcations": [x.to_dict() for x in b.bifurcations], **_param_attrs(params, units)}

    def to_dataframe(self) -> pd.DataFrame:
        """One row per point of the branch, in the order of the arclength.

        Returns
        -------
        pandas.DataFrame
            Columns: the parameter (declared unit), ``stable``, ``stability``, ``n_unstable``,
            ``max_multiplier``, ``period``, ``max`` / ``min`` / ``rms`` / ``peak_to_peak`` of the
            observed state, ``rattle_state``, ``n_events``, ``bifurcation`` (the type of a located
            point, else empty), ``closure``, ``x0_<state>``, and per mesh ``<mesh>_min`` /
            ``_max`` / ``_peak_to_peak`` (m) / ``_rattle_state``.  ``df.attrs["units"]`` gives
            each column's unit; ``df.attrs`` also the branch's settings.
        """
        pd = _pandas("Branch.to_dataframe")
        cols = self._columns()
        df = pd.DataFrame({k: v for k, (v, _, _) in cols.items()})
        df.index.name = "point"
        df.attrs.update(self._attrs())
        df.attrs["units"] = {k: u for k, (_, u, _) in cols.items()}
        df.attrs["units_convention"] = UNITS_CONVENTION
        return df

    def to_xarray(self) -> xr.Dataset:
        """The branch as an :class:`xarray.Dataset` on the dimension ``point``.

        Returns
        -------
        xarray.Dataset
            The columns of :meth:`to_dataframe` as variables on ``point`` (the parameter as a
            coordinate: it is not monotonic past a fold), each with ``units``; the multipliers as
            ``multiplier_real`` / ``multiplier_imag`` on ``(point, multiplier)`` (NaN-padded);
            attributes: the parameter and its unit, ``bifurcations`` (JSON), ``param_<name>``
            (the other parameters, declared units).  Round-trips through netCDF.
        """
        xr = _xarray("Branch.to_xarray")
        b: Any = self
        cols = self._columns()
        data = {}
        for k, (v, u, d) in cols.items():
            if k == b.param:
                continue
            arr = v.astype(np.int8) if v.dtype == bool else v
            data[k] = ("point", arr, {"units": u, "long_name": d})
        n = max((len(p.multipliers) for p in b.points), default=0)
        mu = np.full((len(b.points), n), np.nan + 0j)
        for i, p in enumerate(b.points):
            mu[i, :len(p.multipliers)] = p.multipliers
        data["multiplier_real"] = (("point", "multiplier"), mu.real, {"units": "1", "long_name": "Floquet multipliers"})
        data["multiplier_imag"] = (("point", "multiplier"), mu.imag, {"units": "1", "long_name": "Floquet multipliers"})
        v, u, d = cols[b.param]
        coords = {"point": ("point", np.arange(len(b.points))), b.param: ("point", v, {"units": u, "long_name": d})}
        attrs = netcdf_attrs({"units_convention": UNITS_CONVENTION, **self._attrs()})
        return xr.Dataset(data, coords=coords, attrs=attrs)


def _fourier_samples(c: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """``a0 + sum a_k cos(k phase) + b_k sin(k phase)`` of the rows ``[a0, a1, b1, a2, b2, ...]``."""
    y = np.tile(c[0], (len(phase), 1))
    for k in range(1, (c.shape[0] - 1) // 2 + 1):
        y += np.outer(np.cos(k * phase), c[2 * k - 1]) + np.outer(np.sin(k * phase), c[2 * k])
    return y


def _max_abs(mu: Sequence[complex]) -> float:
    return float(np.max(np.abs(mu))) if len(mu) else math.nan


# ================================================================== modes, Lyapunov exponents
class ModalDisplay:
    """Display and conversions of :class:`~gearsym.analysis.linear.ModalAnalysis`."""

    def _frequency_unit(self) -> str:
        return str(getattr(self, "info", {}).get("frequency_unit", "Hz"))

    def __repr__(self) -> str:
        m: Any = self
        f = ", ".join(fmt(v, 5) for v in m.frequencies_hz[:6]) + (", ..." if m.n_modes > 6 else "")
        contact = f"; contact {', '.join(f'{k}: {v}' for k, v in m.contact.items())}" if m.contact else ""
        return (f"ModalAnalysis({m.n_modes} mode{'s' if m.n_modes != 1 else ''} of [{names_list(m.coordinate_names)}]: {f} {self._frequency_unit()}"
                f"{'' if m.symmetric else ' (not symmetric)'}{contact})")

    def _repr_html_(self) -> str:
        m: Any = self
        rows = [(i, fmt(f, 6), fmt(z, 3), int(k), (m.classification or [""] * m.n_modes)[i],
                 ", ".join(f"{n}: {fmt(s, 3)}" for n, s in zip(m.coordinate_names, m.shapes[i])))
                for i, (f, z, k) in enumerate(zip(m.frequencies_hz, m.damping_ratios, m.multiplicities))]
        table = html_table(("mode", f"frequency [{self._frequency_unit()}]", "damping ratio", "multiplicity", "type",
                            "shape"), rows)
        return html_card("ModalAnalysis", f"{m.n_modes} natural modes about the static equilibrium",
                         [("contact at equilibrium", ", ".join(f"{k}: {v}" for k, v in m.contact.items()) or "-")],
                         [("modes", table)]).replace("<details>", "<details open>", 1)

    def to_dataframe(self) -> pd.DataFrame:
        """One row per mode: frequency, damping ratio, multiplicity, type, shape components.

        Returns
        -------
        pandas.DataFrame
            Columns ``frequency_hz`` (Hz; cycles per unit time for dimensionless time),
            ``damping_ratio``, ``multiplicity``, ``type`` (planetary sets), and
            ``shape_<coordinate>`` (largest component +1).
        """
        pd = _pandas("ModalAnalysis.to_dataframe")
        m: Any = self
        cols: dict[str, Any] = {"frequency_hz": m.frequencies_hz, "damping_ratio": m.damping_ratios,
                                "multiplicity": m.multiplicities}
        if m.classification is not None:
            cols["type"] = list(m.classification)
        for j, n in enumerate(m.coordinate_names):
            cols[f"shape_{n}"] = m.shapes[:, j]
        df = pd.DataFrame(cols)
        df.index.name = "mode"
        df.attrs["units"] = {"frequency_hz": self._frequency_unit(), "damping_ratio": "1"}
        df.attrs["params"] = dict(m.params)
        df.attrs["contact"] = dict(m.contact)
        return df

    def to_xarray(self) -> xr.Dataset:
        """The modes as an :class:`xarray.Dataset` on ``(mode, coordinate)``.

        Returns
        -------
        xarray.Dataset
            ``frequency_hz``, ``damping_ratio``, ``multiplicity`` (and ``type``) on ``mode``,
            ``shape`` on ``(mode, coordinate)``, ``equilibrium`` on ``coordinate`` (SI units);
            attributes ``contact`` (JSON), ``symmetric`` and the parameters (declared units).
        """
        xr = _xarray("ModalAnalysis.to_xarray")
        m: Any = self
        data: dict[str, Any] = {
            "frequency_hz": ("mode", m.frequencies_hz, {"units": self._frequency_unit(),
                                                         "long_name": "undamped natural frequency"}),
            "damping_ratio": ("mode", m.damping_ratios, {"units": "1", "long_name": "modal damping ratio"}),
            "multiplicity": ("mode", np.asarray(m.multiplicities, int), {"long_name": "modes of equal frequency"}),
            "shape": (("mode", "coordinate"), m.shapes, {"units": "1", "long_name": "mode shape, largest component +1"}),
            "equilibrium": ("coordinate", m.equilibrium, {"long_name": "static equilibrium (SI units of each coordinate)"}),
        }
        if m.classification is not None:
            data["type"] = ("mode", np.array(m.classification, dtype=str), {"long_name": "mode type"})
        coords = {"mode": np.arange(m.n_modes), "coordinate": list(m.coordinate_names)}
        attrs = {"source": "gearsym.analysis.linear.modal_analysis", "symmetric": bool(m.symmetric),
                 "contact": dict(m.contact), "units_convention": UNITS_CONVENTION,
                 **{f"param_{k}": float(v) for k, v in m.params.items()}}
        return xr.Dataset(data, coords=coords, attrs=netcdf_attrs(attrs))


class LyapunovDisplay:
    """HTML and conversions of :class:`gearsym.LyapunovResult` (its one-line ``repr`` is its own)."""

    def _repr_html_(self) -> str:
        r: Any = self
        table = html_table(("exponent", "value", "95 % half-width"),
                           [(i + 1, fmt(v), fmt(e, 3)) for i, (v, e) in enumerate(zip(r.exponents, r.errors))])
        rows = [("converged", r.converged if r.converged else f"no: {r.reason}"), ("periods", fmt(r.periods)),
                ("Kaplan-Yorke dimension", fmt(r.kaplan_yorke))]
        return html_card("LyapunovResult", f"{len(r.exponents)} exponents (per unit of the system's time)", rows,
                         [("exponents", table)])

    def to_dataframe(self) -> pd.DataFrame:
        """One row per exponent: ``exponent`` (per unit of the system's time) and ``error`` (95 %).

        Returns
        -------
        pandas.DataFrame
        """
        pd = _pandas("LyapunovResult.to_dataframe")
        r: Any = self
        df = pd.DataFrame({"exponent": r.exponents, "error": r.errors})
        df.index.name = "index"
        df.attrs.update({"converged": bool(r.converged), "periods": float(r.periods),
                         "kaplan_yorke": float(r.kaplan_yorke), "params": dict(r.params),
                         "units": {"exponent": "1/time unit", "error": "1/time unit"}})
        return df

    def to_xarray(self) -> xr.Dataset:
        """The exponents and their errors on the dimension ``exponent``, the block stretches on
        ``(block, exponent)``.

        Returns
        -------
        xarray.Dataset
        """
        xr = _xarray("LyapunovResult.to_xarray")
        r: Any = self
        data = {"exponent_value": ("exponent", r.exponents, {"units": "1/time unit"}),
                "error": ("exponent", r.errors, {"units": "1/time unit", "long_name": "95 % half-width"}),
                "stretch": (("block", "exponent"), r.stretches, {"long_name": "log |R_ii| of each block"})}
        attrs = {"source": "gearsym.lyapunov_exponents", "converged": bool(r.converged), "reason": r.reason,
                 "periods": float(r.periods), "time": float(r.time), "kaplan_yorke": float(r.kaplan_yorke),
                 **{f"param_{k}": float(v) for k, v in r.params.items()}}
        return xr.Dataset(data, attrs=netcdf_attrs(attrs))


class RunupDisplay:
    """HTML and the table of :class:`gearsym.RunupResult` (its ``repr`` and ``to_xarray`` are its own)."""

    def _repr_html_(self) -> str:
        r: Any = self
        fu = r.frequency_unit
        peaks = html_table(("mesh", "order", "largest amplitude", f"at {r.parameter} [{r.unit}]", f"frequency [{fu}]"),
                           [(p["mesh"], p["order"], fmt(p["amplitude"], 4), fmt(p["speed"]), fmt(p["frequency"]))
                            for p in r.peaks()])
        cross = html_table(("mesh", "order", "mode", f"frequency [{fu}]", f"{r.parameter} [{r.unit}]"),
                           [(c["mesh"], c["order"], c["mode"], fmt(c["frequency"]), fmt(c["speed"]))
                            for c in r.crossings()])
        rows = [("ramp", f"{r.parameter} {fmt(r.start)} -> {fmt(r.stop)} {r.unit} in {fmt(r.duration)} "
                         f"{r.time_unit or ''}"),
                ("signal", r.signal_name), ("spectra", f"{len(r.bin_speed)} speed bins, resolution "
                                                      f"{fmt(r.resolution, 4)} {fu}"),
                ("steps, breakpoints, events", f"{r.stats.get('n_steps')}, {r.stats.get('n_breaks')}, "
                                               f"{r.stats.get('n_events')}")]
        return html_card("RunupResult", r.scene, rows, [("mesh-order peaks", peaks), ("order x natural-frequency "
                                                                                     "crossings", cross)])

    def to_dataframe(self) -> pd.DataFrame:
        """One row per speed bin: its time and speed, and the amplitude of every mesh order.

        Returns
        -------
        pandas.DataFrame
            Columns ``time``, ``speed`` and ``<mesh>_order<k>``; ``df.attrs["units"]`` gives
            each column's unit.
        """
        pd = _pandas("RunupResult.to_dataframe")
        r: Any = self
        cols = {"time": r.bin_time, "speed": r.bin_speed}
        for i, m in enumerate(r.meshes):
            for k in range(r.order_amplitude.shape[1]):
                cols[f"{m}_order{k + 1}"] = r.order_amplitude[i, k]
        df = pd.DataFrame(cols)
        df.index.name = "bin"
        df.attrs.update({"parameter": r.parameter, "params": dict(r.params),
                         "units": {"time": r.time_unit or "", "speed": r.unit,
                                   **{c: "signal units" for c in cols if c not in ("time", "speed")}}})
        return df


class BasinDisplay:
    """HTML and conversions of :class:`gearsym.BasinResult` (its one-line ``repr`` is its own)."""

    def _repr_html_(self) -> str:
        r: Any = self
        rows = [(r.label_name(a.index), a.kind, a.period or "", "" if a.rattle_state is None else a.rattle_state,
                 fmt(a.max_multiplier, 4), fmt(a.lyapunov, 4), f"{r.count(a.index) / r.labels.size:.1%}")
                for a in r.attractors]
        table = html_table(("attractor", "kind", "period", "rattle state", "max|mu|", "Lyapunov", "basin"), rows)
        rest = [(name, f"{r.count(k) / r.labels.size:.1%}") for k, name in _special_labels(r).items() if r.count(k)]
        grid = (f"{r.y_values.size} x {r.x_values.size} cells: {r.x_state} {fmt(r.x_values[0])} .. "
                f"{fmt(r.x_values[-1])}, {r.y_state} {fmt(r.y_values[0])} .. {fmt(r.y_values[-1])}")
        return html_card("BasinResult", r.scene, [("grid", grid), ("phase", fmt(r.phase)), *rest],
                         [("attractors", table), ("parameters", _params_table(r.params, {}))]
                         ).replace("<details>", "<details open>", 1)

    def to_xarray(self) -> xr.Dataset:
        """The basin map and the attractor table as an :class:`xarray.Dataset` (a copy of ``dataset``).

        Returns
        -------
        xarray.Dataset
            ``label`` and ``periods`` on the grid, the attractors on ``attractor`` (see
            :attr:`~gearsym.BasinResult.dataset`); the states in the system's own variables
            (SI, or ``1`` for a system in dimensionless variables), the parameters as
            ``param_<name>`` (declared units).  Round-trips through netCDF.
        """
        r: Any = self
        ds = r.dataset.copy()
        ds.attrs.update(netcdf_attrs({"units_convention": UNITS_CONVENTION,
                                      **{f"param_{k}": float(v) for k, v in r.params.items()}}))
        return ds

    def to_dataframe(self) -> pd.DataFrame:
        """One row per attractor: name, kind, period, rattle state, max|mu|, Lyapunov exponent, basin fraction.

        Returns
        -------
        pandas.DataFrame
            Index ``attractor`` (the label of the map); ``df.attrs`` the grid, the fractions of
            the special labels (unresolved, unbounded, failed) and the parameters.
        """
        pd = _pandas("BasinResult.to_dataframe")
        r: Any = self
        a = r.attractors
        df = pd.DataFrame({"name": [x.name for x in a], "kind": [x.kind for x in a],
                           "period": [x.period or 0 for x in a],
                           "rattle_state": [-1 if x.rattle_state is None else x.rattle_state for x in a],
                           "max_multiplier": [x.max_multiplier for x in a], "lyapunov": [x.lyapunov for x in a],
                           "lyapunov_error": [x.lyapunov_error for x in a],
                           "fraction": [r.count(x.index) / r.labels.size for x in a]},
                          index=pd.Index([x.index for x in a], name="attractor"))
        df.attrs.update({"scene": r.scene, "x_state": r.x_state, "y_state": r.y_state, "params": dict(r.params),
                         "special_fractions": {n: r.count(k) / r.labels.size for k, n in _special_labels(r).items()}})
        return df


def _special_labels(r: Any) -> dict[int, str]:
    """The special labels of a basin map (unresolved, unbounded, failed): negative labels with a name."""
    return {k: r.label_name(k) for k in (-1, -2, -3) if not r.label_name(k).startswith("A")}


# ================================================================== gear quantities
#: SI unit of each kind of gear quantity (:data:`gearsym.quantities.QUANTITIES`; a model in
#: dimensionless variables gives them in its own scale).
_KIND_UNITS = {"deflection": "m", "force": "N", "velocity": "m/s", "1": "1"}
_SHOWN_QUANTITIES = ("dte_rms", "dte_peak_to_peak", "dynamic_factor", "contact_loss_ratio", "back_contact_ratio",
                     "impacts_per_period")


class MeshQuantitiesDisplay:
    """Display of :class:`gearsym.quantities.MeshQuantities`."""

    def __repr__(self) -> str:
        m: Any = self
        shown = ", ".join(f"{k} {fmt(m.value(k), 4)}" for k in _SHOWN_QUANTITIES
                          if not math.isnan(m.value(k)))
        return f"MeshQuantities('{m.name}': {shown})"


class GearQuantitiesDisplay:
    """Display and conversions of :class:`gearsym.GearQuantities` (one row per mesh; the class gives
    the table of quantities as ``_table``: name -> (kind, definition))."""

    def __repr__(self) -> str:
        g: Any = self
        meshes = "; ".join(repr(m)[len("MeshQuantities("):-1] for m in list(g.meshes.values())[:2])
        more = f"; ... (+{len(g.meshes) - 2} meshes)" if len(g.meshes) > 2 else ""
        return (f"GearQuantities({len(g.meshes)} mesh{'es' if len(g.meshes) != 1 else ''} over t {fmt(g.t_start, 5)} .. {fmt(g.t_end, 5)} "
                f"({fmt(g.periods, 4)} periods): {meshes}{more})")[:MAX_REPR_CHARS]

    def _repr_html_(self) -> str:
        g: Any = self
        df = self._rows()
        names = list(df)
        table = html_table(("quantity", *names), [(k, *(fmt(df[n][k], 5) for n in names)) for k in df[names[0]]]
                           if names else [])
        rows = [("window", f"t {fmt(g.t_start)} .. {fmt(g.t_end)}, {fmt(g.periods)} forcing periods, "
                           f"{g.samples} samples")] + [("note", n) for n in g.notes]
        return html_card("GearQuantities", f"{len(g.meshes)} mesh{'es' if len(g.meshes) != 1 else ''}", rows, [("quantities", table)]
                         ).replace("<details>", "<details open>", 1)

    def _rows(self) -> dict[str, dict[str, float]]:
        """Mesh -> quantity -> value (NaN where it does not apply)."""
        g: Any = self
        names = list(g._table)
        return {mesh: {k: m.value(k) for k in names} for mesh, m in g.meshes.items()}

    def _units(self) -> dict[str, str]:
        g: Any = self
        return {k: _KIND_UNITS.get(kind, kind) for k, (kind, _) in g._table.items()}

    def to_dataframe(self) -> pd.DataFrame:
        """One row per mesh, one column per scalar quantity (:data:`gearsym.quantities.QUANTITIES`).

        Returns
        -------
        pandas.DataFrame
            Index ``mesh``; NaN where a quantity does not apply (no backlash, no planet set);
            ``df.attrs["units"]``: the SI unit of each column (``m``, ``N``, ``m/s``, ``1``; a
            model in dimensionless variables gives them in its own scale), and the window.
        """
        pd = _pandas("GearQuantities.to_dataframe")
        g: Any = self
        df = pd.DataFrame.from_dict(self._rows(), orient="index")
        df.index.name = "mesh"
        df.attrs.update({"units": self._units(), "t_start": float(g.t_start), "t_end": float(g.t_end),
                         "periods": float(g.periods), "notes": list(g.notes)})
        return df

    def to_xarray(self) -> xr.Dataset:
        """The quantities on the dimension ``mesh`` and the DTE harmonics on ``(mesh, order)``.

        Returns
        -------
        xarray.Dataset
            One variable per scalar quantity (``units``: SI, ``long_name``: its definition),
            ``dte_harmonic`` (amplitude of mesh order ``order``), attributes: the window.
            Round-trips through netCDF.
        """
        xr = _xarray("GearQuantities.to_xarray")
        g: Any = self
        rows = self._rows()
        meshes = list(rows)
        units = self._units()
        data = {k: ("mesh", np.array([rows[m][k] for m in meshes], float), {"units": units[k], "long_name": d})
                for k, (_, d) in g._table.items()}
        n = max((len(m.dte_harmonics) for m in g.meshes.values()), default=0)
        H = np.full((len(meshes), n), np.nan)
        for i, m in enumerate(g.meshes.values()):
            H[i, :len(m.dte_harmonics)] = m.dte_harmonics
        data["dte_harmonic"] = (("mesh", "order"), H, {"units": units["dte_rms"],
                                                       "long_name": "amplitude of each mesh order of the DTE"})
        attrs = {"source": "gearsym.gear_quantities", "t_start": float(g.t_start), "t_end": float(g.t_end),
                 "periods": float(g.periods), "samples": int(g.samples), "notes": list(g.notes),
                 "units_convention": UNITS_CONVENTION}
        return xr.Dataset(data, coords={"mesh": meshes, "order": np.arange(1, n + 1)}, attrs=netcdf_attrs(attrs))


#: The longest one-line repr (characters).
MAX_REPR_CHARS = 500


# ================================================================== scenes, systems, equations
class SceneDisplay:
    """Display of :class:`gearsym.Scene` (never derives the equations)."""

    def __repr__(self) -> str:
        s: Any = self
        on = [k for k, v in s.resolved.effects.items() if v is not False]
        return (f"Scene('{s.name}': model {s.model_spec.name}, {len(s.resolved.state_names())} states "
                f"[{names_list(s.resolved.state_names())}], effects on: {names_list(on, 4) or 'none'}; "
                f"{params_text(s._declared_values(), s._parameter_units())})")

    def _declared_values(self) -> dict[str, float]:
        s: Any = self
        units = s._parameter_units()
        return {k: v / s.model_spec.parameters[k].si_scale if k in s.model_spec.parameters else v
                for k, v in s.resolved.values.items() if k in units}

    def _parameter_units(self) -> dict[str, str]:
        s: Any = self
        return {k: p.unit for k, p in s.model_spec.parameters.items()}

    def _repr_html_(self) -> str:
        s: Any = self
        ms = s.model_spec
        units = self._parameter_units()
        params = html_table(("parameter", "value", "unit", "meaning"),
                            [(k, fmt(v), units.get(k, ""), ms.parameters[k].meaning)
                             for k, v in self._declared_values().items()])
        effects = html_table(("effect", "state", "meaning"),
                             [(k, "off" if v is False else ("on" if v is True else f"on ({v})"), ms.effects[k].meaning)
                              for k, v in s.resolved.effects.items() if k in ms.effects])
        rows = [("model", f"{ms.name}: {ms.description}"), ("states", ", ".join(s.resolved.state_names())),
                ("file", str(s.path))]
        return html_card("Scene", s.name, rows, [("parameters", params), ("effects", effects)])


class SystemDisplay:
    """Display of :class:`gearsym.System`."""

    def __repr__(self) -> str:
        s: Any = self
        T = s.forcing_period
        units = s.units_table()
        per = f"forcing period {_with_unit(fmt(T), units.get('t', ''))}" if T else "no forcing period"
        form = ", dimensionless" if s.generated.dimensionless else ""
        return (f"System('{s.name}': {s.generated.nx} states [{names_list(s.state_names)}], "
                f"{len(s.params)} parameters, {len(s.surface_names)} switching surfaces, {per}{form})")

    def _repr_html_(self) -> str:
        s: Any = self
        units = s.units_table()
        T = s.forcing_period
        states = html_table(("state", "unit", "x0"), [(n, units.get(n, ""), fmt(v)) for n, v in zip(s.state_names, s.x0)])
        surf = html_table(("switching surface",), [(n,) for n in s.surface_names])
        rows = [("states", f"{s.generated.nx}: {names_list(s.state_names, 8)}"),
                ("forcing period", _with_unit(fmt(T), units.get("t", "")) if T else "none"),
                ("build", f"{(s.generated.build_key or '')[:12]} ({'cached' if s.generated.cached else 'built'})")]
        return html_card("System", s.name, rows, [("states", states), ("parameters", _params_table(s.params, units)),
                                                 ("switching surfaces", surf)])


def _latex_block(lines: Sequence[str]) -> str:
    return "$$\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}$$"


class SymbolicDisplay:
    """Display of :class:`~gearsym.symbolic.model.SymbolicModel`: the equations of motion and the
    switching surfaces in LaTeX (``\\ddot x = ...``, ``Piecewise`` as cases)."""

    def __repr__(self) -> str:
        m: Any = self
        per = f", forcing period {m.forcing_period}" if m.forcing_period is not None else ""
        return (f"SymbolicModel('{m.name}': {len(m.states)} states [{names_list(m.state_names)}], "
                f"{len(m.parameters)} parameters, {len(m.switching)} switching functions{per})")

    def _repr_latex_(self) -> str:
        m: Any = self
        return "$$" + m.latex() + "$$"


class DimensionlessDisplay:
    """Display of :class:`~gearsym.symbolic.dimensionless.DimensionlessForm`: the dimensionless
    equations, switching functions and groups (definition = value) in LaTeX."""

    def __repr__(self) -> str:
        d: Any = self
        groups = ", ".join(f"{k}={fmt(d.values.get(k, math.nan), 4)}" for k in list(d.groups)[:5])
        more = ", ..." if len(d.groups) > 5 else ""
        return f"DimensionlessForm({len(d.states)} states, {len(d.groups)} groups: {groups}{more})"

    def _repr_latex_(self) -> str:
        import sympy as sp

        d: Any = self
        lines = []
        n = len(d.states) // 2
        for i in range(n):
            if d.implicit:
                lines.append(f"0 &= {sp.latex(d.accelerations[i])}")
            else:
                lines.append(f"\\ddot{{{sp.latex(d.states[i])}}} &= {sp.latex(d.accelerations[i])}")
        lines += [f"g_{{{j}}} &= {sp.latex(g)}" for j, g in enumerate(d.switching)]
        for name, definition in (d.definitions or d.groups).items():
            sym = d.group_symbols.get(name, sp.Symbol(name))
            value = fmt(d.values.get(name, math.nan), 6)
            same = sp.latex(definition) == sp.latex(sym)
            lines.append(f"{sp.latex(sym)} &= {value}" if same else f"{sp.latex(sym)} &= {sp.latex(definition)} = {value}")
        return _latex_block(lines)
