"""Text, HTML and conversion helpers of the displays (:mod:`gearsym.display`)."""

from __future__ import annotations

import html
import json
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..extras import require

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

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

#: The longest one-line repr (characters).
MAX_REPR_CHARS = 500
