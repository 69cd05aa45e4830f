"""Bifurcation curves in two parameters: the result of :func:`gearsym.analysis.continuation.continue_bifurcation`.

A :class:`BifurcationCurve` is the list of :class:`CurvePoint` (periodic orbits at the bifurcation,
in the order of the curve) and the list of :class:`Codim2Point` found on it (the types of
:data:`CODIM2_TYPES`).  It serialises to the JSON of ``gearsym continue --follow ... --json``
(:meth:`BifurcationCurve.as_dict`, :meth:`BifurcationCurve.to_json`) and draws itself, over a
stability map of the same plane if one is given (:func:`plot_curves`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...files import save_figure, to_json, write_json
from ._points import _jsonable

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["CODIM2_TYPES", "CURVE_TYPES", "BifurcationCurve", "Codim2Point", "CurvePoint", "plot_curves"]

#: The bifurcation curves that can be continued (what ``follow`` takes) and what each is.
CURVE_TYPES: dict[str, str] = {
    "fold": "a real multiplier at +1 at a turning point of the orbit's branch (saddle-node of periodic orbits)",
    "branch_point": "a real multiplier at +1 on an orbit that persists through it (transcritical / pitchfork: "
                    "the trivial orbit x = 0 of a parametrically excited system, a symmetric orbit)",
    "period_doubling": "a real multiplier at -1 (flip)",
    "neimark_sacker": "a complex pair of multipliers exp(+-i omega) on the unit circle",
    "grazing": "the orbit touches a switching surface tangentially (its extremum of g is zero)",
}

#: The codimension-2 points detected on the curves (a test function changes sign between two points).
CODIM2_TYPES: dict[str, str] = {
    "cusp": "fold curve: the fold's quadratic normal-form coefficient vanishes (two fold curves meet in a cusp)",
    "fold_flip": "a fold (branch point) curve meets a period-doubling curve: multipliers +1 and -1 at once",
    "resonance_1_1": "a double multiplier +1: on a fold curve the null vectors become orthogonal; on a "
                     "Neimark-Sacker curve the pair meets at +1 (omega = 0, the curve ends)",
    "resonance_1_2": "a double multiplier -1: on a period-doubling curve the null vectors become orthogonal; on a "
                     "Neimark-Sacker curve the pair meets at -1 (omega = pi, the curve ends)",
    "fold_neimark_sacker": "a Neimark-Sacker curve meets a fold curve (a real multiplier +1 besides the pair)",
    "flip_neimark_sacker": "a Neimark-Sacker curve meets a period-doubling curve (a real multiplier -1 besides "
                           "the pair)",
    "fold_grazing": "a fold curve meets a grazing curve (the orbit at the fold starts touching a surface)",
    "branch_point_grazing": "a branch-point curve meets a grazing curve",
    "period_doubling_grazing": "a period-doubling curve meets a grazing curve",
    "neimark_sacker_grazing": "a Neimark-Sacker curve meets a grazing curve",
    "double_grazing": "a grazing curve meets the grazing curve of another surface (or the other side)",
}


@dataclass(frozen=True, eq=False)
class CurvePoint:
    """One periodic orbit on a bifurcation curve.

    Attributes
    ----------
    value, value2 : float
        The two parameters (declared units).
    x0 : ndarray
        The orbit's state at ``t0``.
    t0 : float
        The time of ``x0`` (the shooting section: moved along the curve away from the orbit's
        events, see :mod:`gearsym.analysis.continuation._augmented`).
    period : float
        The orbit's period.
    multipliers : ndarray (complex)
        Floquet multipliers (by decreasing modulus): one of them is the curve's (+1, -1, the pair).
    stability : str
        The stability rule's verdict on the orbit (at a bifurcation at best ``"neutral"``).
    n_unstable : int
        Multipliers outside the unit circle beyond their tolerances.
    extras : dict
        The extra unknowns: ``omega`` and ``kappa = cos omega`` (Neimark-Sacker), ``theta`` and
        ``t_touch`` (grazing: the phase and the time of the touch), ``mu`` (branch point: the
        unfolding, zero on the curve).
    max, min : float
        Of the first state over the orbit.
    surface_extrema : dict
        ``{surface: (min g, max g)}`` over the orbit.
    n_events : int
        Surface crossings in one period.
    residual : float
        Scaled residual of the corrector.
    iterations : int
        Newton iterations.
    """

    value: float
    value2: float
    x0: np.ndarray
    t0: float
    period: float
    multipliers: np.ndarray
    stability: str
    n_unstable: int
    extras: dict[str, float]
    max: float
    min: float
    surface_extrema: dict[str, tuple[float, float]]
    n_events: int
    residual: float
    iterations: int

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary.

        Returns
        -------
        dict
        """
        return {"value": float(self.value), "value2": float(self.value2), "x0": [float(v) for v in self.x0],
                "t0": float(self.t0), "period": float(self.period),
                "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
                "stability": self.stability, "n_unstable": int(self.n_unstable),
                **{k: float(v) for k, v in self.extras.items()},
                "max": float(self.max), "min": float(self.min),
                "surface_extrema": {k: [float(a), float(b)] for k, (a, b) in self.surface_extrema.items()},
                "n_events": int(self.n_events), "residual": float(self.residual), "iterations": int(self.iterations)}


@dataclass(frozen=True, eq=False)
class Codim2Point:
    """A codimension-2 point found on a curve.

    Attributes
    ----------
    type : str
        A key of :data:`CODIM2_TYPES`.
    value, value2 : float
        The two parameters there.
    point : CurvePoint
        The orbit there.
    index : int
        Its index in ``BifurcationCurve.points``.
    info : dict
        ``located`` (False: detected between two points, not located: then ``reason``), ``bracket``
        (the parameter values of the two points around it), ``test_function``, ``surface`` and
        ``side`` for intersections with grazing.
    """

    type: str
    value: float
    value2: float
    point: CurvePoint
    index: int
    info: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary.

        Returns
        -------
        dict
        """
        return {"type": self.type, "value": float(self.value), "value2": float(self.value2), "index": int(self.index),
                "x0": [float(v) for v in self.point.x0], "t0": float(self.point.t0),
                "multipliers": [[float(m.real), float(m.imag)] for m in self.point.multipliers],
                **{k: _jsonable(v) for k, v in self.info.items()}}


@dataclass(frozen=True, eq=False)
class BifurcationCurve:
    """A bifurcation curve of periodic orbits in two parameters.

    Attributes
    ----------
    type : str
        A key of :data:`CURVE_TYPES`.
    param, param2 : str
        The two parameters.
    points : list of CurvePoint
        The curve's points in its order (the two directions from the start joined).
    special_points : list of Codim2Point
        The codimension-2 points found on it.
    start_index : int
        Index of the first (starting) point in ``points``.
    stop_reasons : list of str
        Why each direction ended (one entry per direction continued).
    complete : bool
        Whether every direction ended where a curve may end: on the boundary of the parameter box,
        closed on itself, or at a point where the bifurcation ceases to exist (a Neimark-Sacker pair
        at +1 or -1).  ``False``: a direction gave up before (then the reason in ``stop_reasons``).
    periods : float
        Forcing periods per orbit.
    state_names : list of str
        The system's states.
    info : dict
        The formulation, how the derivatives were made, the settings, the counts and the wall time.
    """

    type: str
    param: str
    param2: str
    points: list[CurvePoint]
    special_points: list[Codim2Point]
    start_index: int
    stop_reasons: list[str]
    complete: bool
    periods: float = 1.0
    state_names: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return (f"BifurcationCurve({self.type} in ({self.param}, {self.param2}), {len(self.points)} points, "
                f"{len(self.special_points)} special, complete={self.complete})")

    @property
    def value(self) -> np.ndarray:
        """``param`` along the curve."""
        return np.array([p.value for p in self.points])

    @property
    def value2(self) -> np.ndarray:
        """``param2`` along the curve."""
        return np.array([p.value2 for p in self.points])

    @property
    def values(self) -> np.ndarray:
        """``(param, param2)`` along the curve, shape (n, 2)."""
        return np.column_stack([self.value, self.value2])

    def of_type(self, kind: str) -> list[Codim2Point]:
        """The special points of one type.

        Parameters
        ----------
        kind
            A key of :data:`CODIM2_TYPES`.

        Returns
        -------
        list of Codim2Point
        """
        return [s for s in self.special_points if s.type == kind]

    def as_dict(self) -> dict[str, Any]:
        """The JSON object of ``gearsym continue --follow ... --json``.

        Returns
        -------
        dict
            ``{"type", "param", "param2", "points": [{"value", "value2", "x0", "multipliers",
            ...}], "special_points": [{"type", "value", "value2", "located", "bracket", ...}],
            "start_index", "stop_reasons", "complete", "periods", "state_names", ...}`` plus the
            entries of ``info``.
        """
        d: dict[str, Any] = {"type": self.type, "param": self.param, "param2": self.param2,
                             "points": [p.as_dict() for p in self.points],
                             "special_points": [s.as_dict() for s in self.special_points],
                             "start_index": int(self.start_index), "stop_reasons": list(self.stop_reasons),
                             "complete": bool(self.complete), "periods": float(self.periods),
                             "state_names": list(self.state_names)}
        for k, v in self.info.items():
            d[k] = _jsonable(v)
        return d

    def to_json(self, path: str | Path | None = None) -> str | Path:
        """The curve as strict JSON (non-finite numbers ``null``).

        Parameters
        ----------
        path
            Write it there (atomically); default: return the text.

        Returns
        -------
        str or Path
            The text, or the file written.
        """
        if path is None:
            return to_json(self.as_dict())
        return write_json(path, self.as_dict())

    def plot(self, ax: Axes | None = None, stability_map: Any = None, **kwargs: Any) -> Axes:
        """Draw the curve in the ``(param, param2)`` plane (see :func:`plot_curves`).

        Parameters
        ----------
        ax
            Axes to draw into (a new figure if ``None``).
        stability_map
            A stability map of the same plane to draw below the curve.
        **kwargs
            ``quantity``, ``path``, ``title`` of :func:`plot_curves`.

        Returns
        -------
        matplotlib.axes.Axes
        """
        return plot_curves([self], stability_map=stability_map, ax=ax, **kwargs)


_COLOURS = {"fold": "C3", "branch_point": "C1", "period_doubling": "C2", "neimark_sacker": "C4", "grazing": "k"}
_MARKERS = {"cusp": "v", "fold_flip": "s", "resonance_1_1": "D", "resonance_1_2": "d", "fold_neimark_sacker": "P",
            "flip_neimark_sacker": "X", "double_grazing": "^"}


def plot_curves(curves: Sequence[BifurcationCurve], stability_map: Any = None, ax: Axes | None = None,
                quantity: str = "max_multiplier", path: str | Path | None = None, title: str = "") -> Axes:
    """Bifurcation curves in their parameter plane, over a stability map of the same plane.

    Parameters
    ----------
    curves
        Curves in the same two parameters.
    stability_map
        An ``xarray.Dataset`` of :func:`gearsym.analysis.sweeps.stability_map` (or read from its
        netCDF) whose axes are the curves' two parameters (either way round); its ``quantity``
        is drawn below the curves.
    ax
        Axes to draw into (a new figure if ``None``).
    quantity
        The map's variable to show (``max_multiplier`` on a scale centred on 1; a count such as
        ``n_stable``, the coexisting stable responses, one colour per value).
    path
        Save the figure there (PNG) and close it.
    title
        The axes' title.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValueError
        Curves in different parameter planes, or a map whose axes are not theirs.
    """
    import matplotlib.pyplot as plt

    if not curves:
        raise ValueError("plot_curves needs at least one curve")
    xname, yname = curves[0].param, curves[0].param2
    if any((c.param, c.param2) != (xname, yname) for c in curves):
        raise ValueError("the curves are not in the same parameter plane: "
                         + ", ".join(f"({c.param}, {c.param2})" for c in curves))
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 5.2))
    if stability_map is not None:
        _draw_map(ax, stability_map, xname, yname, quantity)
    seen: set[str] = set()
    for c in curves:
        label = None if c.type in seen else c.type.replace("_", " ")
        seen.add(c.type)
        ax.plot(c.value, c.value2, "-", color=_COLOURS.get(c.type, "C0"), lw=1.8, label=label, zorder=4)
        for s in c.special_points:
            name = s.type.replace("_", " ")
            ax.plot([s.value], [s.value2], _MARKERS.get(s.type, "o"), color="k", mfc="w", ms=7, mew=1.4,
                    label=None if name in seen else name, zorder=5)
            seen.add(name)
    ax.set_xlabel(xname)
    ax.set_ylabel(yname)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    if title:
        ax.set_title(title)
    if path is not None:
        fig = ax.figure
        fig.tight_layout()
        save_figure(fig, path, dpi=120)
        plt.close(fig)
    return ax


def _draw_map(ax: Axes, ds: Any, xname: str, yname: str, quantity: str) -> None:
    """The map's ``quantity`` as a heat map with the axes of the curves."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm

    if quantity not in getattr(ds, "data_vars", {}):
        raise ValueError(f"the stability map has no variable '{quantity}' (have: {', '.join(ds.data_vars)})")
    da = ds[quantity]
    dims = tuple(da.dims)
    if set(dims) != {xname, yname}:
        raise ValueError(f"the stability map's axes {dims} are not the curves' parameters ({xname}, {yname})")
    Z = np.asarray(da.values, float)
    if dims == (xname, yname):
        Z = Z.T
    X, Y = np.asarray(ds[xname].values, float), np.asarray(ds[yname].values, float)
    if quantity == "max_multiplier":
        lo = min(float(np.nanmin(Z)), 0.999) if np.isfinite(Z).any() else 0.5
        hi = max(float(np.nanmax(Z)), 1.001) if np.isfinite(Z).any() else 1.5
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="RdBu_r", norm=TwoSlopeNorm(1.0, lo, hi), zorder=1)
    elif np.issubdtype(np.asarray(da.values).dtype, np.integer):  # counts, codes: one colour per value
        Z = np.where(Z < 0, np.nan, Z)
        top = int(np.nanmax(Z)) if np.isfinite(Z).any() else 1
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap=plt.get_cmap("viridis", top + 1), vmin=-0.5,
                           vmax=top + 0.5, zorder=1)
    else:
        pc = ax.pcolormesh(X, Y, Z, shading="nearest", cmap="viridis", zorder=1)
    ax.figure.colorbar(pc, ax=ax).set_label(quantity.replace("_", " "))


def load_json(path: str | Path) -> dict[str, Any]:
    """Read a curve's (or a branch's) JSON file."""
    return json.loads(Path(path).read_text(encoding="utf-8"))
