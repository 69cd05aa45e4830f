"""Displays of trajectories, periodic orbits, branches and natural modes (:mod:`gearsym.display`)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

from ._text import (
    UNITS_CONVENTION,
    _json_default,
    _mu_text,
    _pandas,
    _param_attrs,
    _params_table,
    _series_dataset,
    _series_frame,
    _stability,
    _unit,
    _with_unit,
    _xarray,
    fmt,
    html_card,
    html_table,
    names_list,
    netcdf_attrs,
    params_text,
)


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
