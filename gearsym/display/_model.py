"""Displays of gear quantities, scenes, systems and the symbolic model (:mod:`gearsym.display`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

from ._text import (
    MAX_REPR_CHARS,
    UNITS_CONVENTION,
    _pandas,
    _params_table,
    _with_unit,
    _xarray,
    fmt,
    html_card,
    html_table,
    names_list,
    netcdf_attrs,
    params_text,
)

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
