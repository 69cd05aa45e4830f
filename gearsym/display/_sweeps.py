"""Displays of the sweeps: Lyapunov exponents, run-ups, basins (:mod:`gearsym.display`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

from ._text import (
    UNITS_CONVENTION,
    _pandas,
    _params_table,
    _xarray,
    fmt,
    html_card,
    html_table,
    netcdf_attrs,
)


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
