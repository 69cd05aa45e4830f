"""The coexistence panels of a map's figure (:func:`gearsym.analysis.sweeps.save_map`).

Next to the map's own heat map (whose cells with two or more coexisting stable responses are
outlined in black), a map with the attractor layers (:mod:`gearsym.analysis.sweeps._coexist`) gets

* a panel of the number of coexisting stable periodic orbits (``n_stable``), with the points where a
  non-periodic attractor was found hatched (``..`` chaotic, ``oo`` quasi-periodic, ``++`` not
  classified);
* one panel per response index (at most :data:`MAX_PANELS`): the quantity of the ``j``-th attractor
  of each point (sorted as the layers are: the stable orbits by rattle state first), blank where a
  point has fewer, hatched by kind where it is non-periodic (never given an orbit's colour), and
  ``P<k>`` written in the cells of an orbit of ``k > 1`` forcing periods.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ._attractor_id import CHAOTIC, PERIODIC, QUASI_PERIODIC, UNCLASSIFIED

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

__all__ = ["MAX_PANELS", "NONPERIODIC_HATCHES", "attractor_panels", "draw_panels", "outline_coexistence"]

#: Most per-response panels drawn.
MAX_PANELS = 3
#: Hatch of each non-periodic kind (:data:`gearsym.analysis.sweeps.ATTRACTOR_KINDS`).
NONPERIODIC_HATCHES = {CHAOTIC: ("..", "chaotic"), QUASI_PERIODIC: ("oo", "quasi-periodic"),
                       UNCLASSIFIED: ("++", "non-periodic, not classified")}
#: The attractor variable drawn for each map quantity.
_PER_ATTRACTOR = {"rattle_state": "attractor_rattle_state", "max_multiplier": "attractor_max_multiplier",
                  "peak_to_peak": "attractor_peak_to_peak", "lyapunov": "attractor_lyapunov"}


def attractor_panels(ds: xr.Dataset) -> int:
    """Panels the coexistence part of the figure takes (0 without attractor layers)."""
    if "attractor_kind" not in ds:
        return 0
    return 1 + min(MAX_PANELS, int(ds.sizes["attractor"]))


def outline_coexistence(ax: Any, X: np.ndarray, Y: np.ndarray, n_stable: np.ndarray) -> None:
    """Outline (black, no hatch) the cells where two or more stable periodic orbits coexist."""
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Rectangle

    def edges(v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, float)
        if len(v) == 1:
            return np.array([v[0] - 0.5, v[0] + 0.5])
        mid = 0.5 * (v[1:] + v[:-1])
        return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])

    ex, ey = edges(X), edges(Y)
    rects = [Rectangle((ex[i], ey[j]), ex[i + 1] - ex[i], ey[j + 1] - ey[j])
             for j, i in zip(*np.nonzero(n_stable >= 2), strict=True)]
    if rects:
        ax.add_collection(PatchCollection(rects, facecolor="none", edgecolor="k", linewidth=1.6,
                                          label="coexisting stable responses"))


def _hatch_kinds(ax: Any, X: np.ndarray, Y: np.ndarray, kinds: np.ndarray) -> list[Any]:
    """Hatch the cells of each non-periodic kind present (``kinds``: one kind per cell, or -1)."""
    from matplotlib.patches import Patch

    handles = []
    for code, (hatch, label) in NONPERIODIC_HATCHES.items():
        mask = kinds == code
        if mask.any():
            ax.pcolor(X, Y, np.ma.masked_where(~mask, np.ones(mask.shape)), shading="nearest", hatch=hatch,
                      facecolor="none", edgecolor="0.2", linewidth=0.0)
            handles.append(Patch(facecolor="none", edgecolor="0.2", hatch=hatch, label=label))
    return handles


def _mark_periods(ax: Any, X: np.ndarray, Y: np.ndarray, periods: np.ndarray) -> None:
    """Write ``P<k>`` in the cells of orbits of more than one forcing period (grids of at most 400 cells)."""
    if periods.size > 400:
        return
    for j, i in zip(*np.nonzero(periods > 1), strict=True):
        ax.text(X[i], Y[j], f"P{int(periods[j, i])}", ha="center", va="center", fontsize=7, color="w")


def _labels(ax: Any, ds: xr.Dataset, xname: str, yname: str) -> None:
    xu = ds[xname].attrs.get("units", "")
    yu = ds[yname].attrs.get("units", "")
    ax.set_xlabel(f"{xname} [{xu}]" if xu and xu != "1" else xname)
    ax.set_ylabel(f"{yname} [{yu}]" if yu and yu != "1" else yname)


def draw_panels(fig: Any, axes: list[Any], ds: xr.Dataset, quantity: str) -> None:
    """Draw the count panel and the per-response panels (module docstring) on ``axes``."""
    yname, xname = ds["n_stable"].dims
    X, Y = ds[xname].values, ds[yname].values
    kinds = ds["attractor_kind"].values
    n = ds["n_stable"].values.astype(float)
    top = max(2, int(np.nanmax(n)) if n.size else 2)
    pc = axes[0].pcolormesh(X, Y, n, shading="nearest", cmap="Blues", vmin=-0.5, vmax=top + 0.5)
    cb = fig.colorbar(pc, ax=axes[0], ticks=range(top + 1))
    cb.set_label("stable periodic orbits")
    nonper = np.where(np.isin(kinds, list(NONPERIODIC_HATCHES)), kinds, -1).max(axis=2)
    handles = _hatch_kinds(axes[0], X, Y, nonper)
    if handles:
        axes[0].legend(handles=handles, loc="upper right", fontsize=7, framealpha=0.85)
    axes[0].set_title("coexisting stable responses")
    _labels(axes[0], ds, xname, yname)
    var = _PER_ATTRACTOR.get(quantity, "attractor_rattle_state")
    for j, ax in enumerate(axes[1:]):
        Z = ds[var].values[:, :, j].astype(float)
        if var != "attractor_lyapunov":
            Z[kinds[:, :, j] != PERIODIC] = np.nan  # an orbit's quantity: none for a non-periodic attractor
        elif np.isfinite(Z).any():
            Z[~np.isfinite(Z)] = np.nan
        kw: dict[str, Any] = {"vmin": -1, "vmax": 2} if var == "attractor_rattle_state" else {}
        if var == "attractor_lyapunov" and np.isfinite(Z).any():
            from matplotlib.colors import TwoSlopeNorm

            lo, hi = float(np.nanmin(Z)), float(np.nanmax(Z))
            kw = {"norm": TwoSlopeNorm(0.0, min(lo, -1e-12), max(hi, 1e-12)), "cmap": "RdBu_r"}
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", **({"cmap": "viridis"} | kw))
        fig.colorbar(pc, ax=ax).set_label(var.replace("attractor_", "").replace("_", " "))
        _hatch_kinds(ax, X, Y, np.where(kinds[:, :, j] > PERIODIC, kinds[:, :, j], -1))
        _mark_periods(ax, X, Y, ds["attractor_periods"].values[:, :, j])
        ax.set_title(f"response {j + 1} at each point")
        _labels(ax, ds, xname, yname)
