"""Branches of periodic orbits: the result of :func:`gearsym.continuation`.

A :class:`Branch` is the list of :class:`BranchPoint` (periodic orbits along a
one-parameter curve, in the order of the arclength) and the list of located
:class:`Bifurcation` (fold, period doubling, Neimark-Sacker, grazing, branch
point).  It serialises to the JSON object of ``gearsym continue --json``
(:meth:`Branch.to_dict`) and draws the response curve (stable parts solid,
unstable parts dashed, bifurcation markers) and the Floquet multipliers along
the branch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...display import BranchDisplay
from ...files import save_figure, write_json
from ._points import BIFURCATION_TYPES, Bifurcation, BranchPoint, ContinuationSetup, _jsonable

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

    from ...quantities import GearQuantities
    from ...system import CompiledSystem

__all__ = ["BIFURCATION_TYPES", "Bifurcation", "Branch", "BranchPoint", "ContinuationSetup", "add_legend"]


#: The quantities of the observed state (:meth:`Branch.quantity`; the others are gear quantities).
_STATE_QUANTITIES = ("max", "min", "rms", "ptp", "peak_to_peak", "x0")


@dataclass(frozen=True, eq=False, repr=False)
class Branch(BranchDisplay):
    """A continued branch of periodic orbits.

    Units: the parameter values in its declared unit, states in SI, periods in the model's time
    unit.  ``repr`` is one line (range, points, bifurcations); in Jupyter a table;
    ``to_dataframe()`` gives one row per point, ``to_xarray()`` a dataset on ``point``
    (:mod:`gearsym.display`).

    Attributes
    ----------
    param : str
        The continuation parameter.
    points : list of BranchPoint
        Orbits in the order of the arclength (located special points included).
    bifurcations : list of Bifurcation
        Located special points, in the order of the arclength.
    periods : float
        Forcing periods per orbit (2 for a branch switched on at a period doubling).
    method : str
        ``"shooting"`` or ``"hbm"``.
    state : str
        The observed state (``max``, ``min``, ``rms``).
    stop_reason : str
        Why the continuation ended.
    complete : bool
        Whether the branch ended where a branch may end: at an end of the parameter
        range (after any number of turning points) or, for a switched branch, where it
        merges back.  ``False`` when the continuation gave up before: the step size fell
        below ``ds_min``, ``max_points`` was reached, or the branch stopped advancing
        (the parameter stalled while the orbit grew, e.g. an undamped resonance).
    stop_value : float or None
        Parameter value of the last point (declared unit).
    state_names : list of str
        The system's state names.
    children : list of Branch
        Branches switched onto at period doublings of this one (the one thing that grows
        after the branch is made: :func:`~gearsym.analysis.continuation.switch_period_doubling`
        appends to it).
    parent : Bifurcation or None
        The period doubling this branch was switched on at.
    info : dict
        Settings, counts of residual evaluations, wall time, and ``"corrector"``: where the
        corrections ran (``"C"``, ``"C (the Python corrector took over N times)"`` or
        ``"Python: <why not C>"``, e.g. a DAE on IDA).
    system : System or None
        The compiled system (for :meth:`poincare`).
    setup : ContinuationSetup or None
        How the branch was computed (what branch switching starts from).
    """

    param: str
    points: list[BranchPoint]
    bifurcations: list[Bifurcation]
    periods: float = 1
    method: str = "shooting"
    state: str = ""
    state_names: list[str] = field(default_factory=list)
    stop_reason: str = ""
    complete: bool = True
    stop_value: float | None = None
    children: list[Branch] = field(default_factory=list)
    parent: Bifurcation | None = field(default=None, repr=False)
    info: dict[str, Any] = field(default_factory=dict)
    system: CompiledSystem | None = field(default=None, repr=False, compare=False)
    setup: ContinuationSetup | None = field(default=None, repr=False, compare=False)

    # ------------------------------------------------------------- arrays
    def __len__(self) -> int:
        return len(self.points)

    @property
    def values(self) -> np.ndarray:
        """Parameter values of the points."""
        return np.array([p.value for p in self.points])

    @property
    def stable(self) -> np.ndarray:
        """Stability of the points."""
        return np.array([p.stable for p in self.points], bool)

    @property
    def max(self) -> np.ndarray:
        """Maximum of the observed state along the branch."""
        return np.array([p.max for p in self.points])

    @property
    def min(self) -> np.ndarray:
        """Minimum of the observed state along the branch."""
        return np.array([p.min for p in self.points])

    @property
    def rms(self) -> np.ndarray:
        """RMS of the observed state along the branch."""
        return np.array([p.rms for p in self.points])

    @property
    def peak_to_peak(self) -> np.ndarray:
        """Peak-to-peak of the observed state along the branch."""
        return self.max - self.min

    @property
    def n_unstable(self) -> np.ndarray:
        """Number of unstable multipliers along the branch."""
        return np.array([p.n_unstable for p in self.points], int)

    @property
    def rattle_states(self) -> list[int | None]:
        """Rattle state of each point."""
        return [p.rattle_state for p in self.points]

    def quantity(self, name: str) -> np.ndarray:
        """One quantity of the observed state along the branch.

        Parameters
        ----------
        name
            ``"max"``, ``"min"``, ``"rms"``, ``"ptp"`` (peak-to-peak) or ``"x0"`` (first entry); or a
            gear quantity (:data:`gearsym.quantities.QUANTITIES`, e.g. ``"dynamic_factor"``, of the
            worst mesh, or ``"dynamic_factor[sp1]"`` of one mesh: :meth:`gear_quantities`).

        Returns
        -------
        ndarray
            One value per point (NaN where a gear quantity could not be computed).
        """
        if name in ("ptp", "peak_to_peak"):
            return self.peak_to_peak
        if name == "x0":
            return np.array([p.x0[0] for p in self.points])
        if name in ("max", "min", "rms"):
            return getattr(self, name)
        from ...quantities import parse_quantity

        parse_quantity(name)  # an unknown name: ParameterError naming the known ones
        return np.array([math.nan if g is None else g.value(name) for g in self.gear_quantities()])

    def gear_quantities(self) -> list[GearQuantities | None]:
        """The gear quantities of every point: per mesh, static and dynamic transmission error, mesh
        force, dynamic factor, DTE harmonics, contact ratios, impacts, load sharing over one period of
        the orbit (:func:`gearsym.quantities.branch_quantities`; one integration per point, once).

        Returns
        -------
        list
            One :class:`gearsym.quantities.GearQuantities` per point (``None`` where it failed).
        """
        from ...quantities import branch_quantities

        return branch_quantities(self)

    @property
    def mesh_names(self) -> list[str]:
        """Meshes reported at the points (every mesh element of the model)."""
        names: dict[str, None] = {}
        for p in self.points:
            names.update(dict.fromkeys(p.meshes))
        return list(names)

    def mesh_quantity(self, mesh: str, name: str = "peak_to_peak") -> np.ndarray:
        """One quantity of one mesh along the branch.

        Parameters
        ----------
        mesh
            The mesh (one of :attr:`mesh_names`).
        name
            ``"min"``, ``"max"``, ``"peak_to_peak"`` (``"ptp"``) of its dynamic deflection, or
            its ``"rattle_state"``.

        Returns
        -------
        ndarray
            One value per point (NaN, or -1 for the rattle state, where unknown).
        """
        if name == "ptp":
            name = "peak_to_peak"
        if name not in ("min", "max", "peak_to_peak", "rattle_state"):
            raise ValueError(f"unknown mesh quantity '{name}' (min, max, peak_to_peak, rattle_state)")
        default = -1 if name == "rattle_state" else math.nan
        vals = [p.meshes.get(mesh, {}).get(name) for p in self.points]
        return np.array([default if v is None else v for v in vals], float)

    def of_type(self, kind: str) -> list[Bifurcation]:
        """The located bifurcations of one type.

        Parameters
        ----------
        kind
            A key of :data:`BIFURCATION_TYPES`.

        Returns
        -------
        list of Bifurcation
        """
        return [b for b in self.bifurcations if b.type == kind]

    def params_at(self, value: float) -> dict[str, float]:
        """Parameter overrides of the orbit at ``value``.

        Parameters
        ----------
        value
            The continuation parameter's value (declared unit).

        Returns
        -------
        dict
            The branch's fixed overrides plus ``param = value``.
        """
        p = dict(self.info.get("params", {}))
        p[self.param] = float(value)
        return p

    def poincare(self, state: int | str | None = None, rtol: float = 1e-10, atol: float = 1e-12
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Poincare points (one per forcing period) of every orbit of the branch.

        Parameters
        ----------
        state
            The state (index or name; default the observed one).
        rtol, atol
            Integrator tolerances (period-``k`` branches integrate ``k - 1`` periods).

        Returns
        -------
        values, points : ndarray
            The parameter values and ``points`` of shape ``(n_points, k)`` for a period-``k``
            branch: the state at ``t0, t0 + T, ..., t0 + (k-1) T``.
        """
        if self.system is None:
            raise ValueError("the branch is not attached to a system")
        names = self.state_names or self.system.state_names
        i = names.index(state or self.state or names[0]) if not isinstance(state, int) else state
        k = max(1, int(round(self.periods)))
        pts = np.empty((len(self.points), k))
        for j, p in enumerate(self.points):
            pts[j, 0] = p.x0[i]
            if k > 1:
                T = p.period / self.periods
                t0 = float(self.info.get("t0", 0.0))
                tr = self.system.simulate(t_end=t0 + (k - 1) * T, t0=t0, x0=p.x0, rtol=rtol, atol=atol,
                                          t_out=t0 + T * np.arange(k), params=self.params_at(p.value))
                pts[j] = tr.y[:, i]
        return self.values, pts

    def all_branches(self) -> list[Branch]:
        """This branch and, recursively, its children.

        Returns
        -------
        list of Branch
        """
        out = [self]
        for c in self.children:
            out += c.all_branches()
        return out

    # --------------------------------------------------------------- I/O
    def to_dict(self, children: bool = True) -> dict[str, Any]:
        """The JSON object of ``gearsym continue --json``.

        ``{"param", "points": [{"value", "stable", "max", "min", "rms",
        "rattle_state", "x0", "period", "multipliers": [[re, im], ...], ...}],
        "bifurcations": [{"type", "value", "multipliers", ...}], "stop_reason",
        "complete", "stop_value", ...}``.

        Parameters
        ----------
        children
            Include the switched-on branches (``"children"``).

        Returns
        -------
        dict
        """
        d: dict[str, Any] = {
            "param": self.param,
            "points": [p.to_dict() for p in self.points],
            "bifurcations": [b.to_dict() for b in self.bifurcations],
            "periods": self.periods,
            "method": self.method,
            "state": self.state,
            "state_names": list(self.state_names),
            "stop_reason": self.stop_reason,
            "complete": bool(self.complete),
            "stop_value": None if self.stop_value is None else float(self.stop_value),
        }
        if self.parent is not None:
            d["switched_at"] = {"type": self.parent.type, "value": float(self.parent.value)}
        for k, v in self.info.items():
            d[k] = _jsonable(v)
        if children:
            d["children"] = [c.to_dict() for c in self.children]
        return d

    def save_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` to a file.

        Parameters
        ----------
        path
            The JSON file.

        Returns
        -------
        Path
            The file written.
        """
        return write_json(path, self.to_dict())

    # ------------------------------------------------------------- plots
    def plot(self, ax: Axes | None = None, quantity: str | list[str] = "max", color: str | None = None,
             label: str | None = None, markers: bool = True, children: bool = True,
             legend: bool = True, xscale: float = 1.0) -> Axes:
        """The response curve: stable parts solid, unstable dashed, bifurcation markers.

        Parameters
        ----------
        ax
            Axes to draw into (new figure if ``None``).
        quantity
            ``"max"``, ``"min"``, ``"rms"``, ``"ptp"``, a gear quantity (:meth:`quantity`) or a list
            of them.
        color
            Line colour (default: next in the cycle; children get their own).
        label
            Legend label of the branch.
        markers
            Mark the located bifurcations.
        children
            Also draw the branches switched onto at period doublings.
        legend
            Add a legend (line styles and marker types).
        xscale
            Multiply the parameter by this for the horizontal axis (unit change).

        Returns
        -------
        matplotlib.axes.Axes
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4.2))
        quantities = [quantity] if isinstance(quantity, str) else list(quantity)
        branches = self.all_branches() if children else [self]
        cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        seen: set[str] = set()
        for k, br in enumerate(branches):
            col = color if (color and k == 0) else cycle[k % len(cycle)]
            lab = label if k == 0 else f"period-{int(round(br.periods))} branch"
            if lab is None:
                lab = f"period-{int(round(br.periods))} branch" if br.periods != 1 else "branch"
            x = br.values * xscale
            st = br.stable
            ys = {q: br.quantity(q) for q in quantities}
            for qi, q in enumerate(quantities):
                _styled_line(ax, x, ys[q], st, col, lab if qi == 0 else None)
            if markers:
                for b in br.bifurcations:
                    for q in quantities:
                        y = {"max": b.point.max, "min": b.point.min, "rms": b.point.rms,
                             "ptp": b.point.max - b.point.min, "peak_to_peak": b.point.max - b.point.min,
                             "x0": b.point.x0[0]}.get(q, ys[q][b.index] if 0 <= b.index < len(ys[q]) else math.nan)
                        mk, mc = _MARKERS.get(b.type, ("x", "k"))
                        name = b.type.replace("_", " ")
                        ax.plot([b.value * xscale], [y], mk, color=mc, ms=7, mfc="none" if mk != "x" else mc,
                                mew=1.5, label=None if name in seen else name, zorder=5)
                        seen.add(name)
        ax.set_xlabel(self.param)
        sname = self.state or "x"
        ax.set_ylabel(" / ".join(f"{q} {sname}" if q in _STATE_QUANTITIES else q.replace("_", " ")
                                 for q in quantities))
        if legend:
            add_legend(ax)
        ax.grid(alpha=0.3)
        return ax

    def plot_multipliers(self, ax: Axes | None = None, children: bool = False, xscale: float = 1.0,
                         color: str | None = None) -> Axes:
        """``|mu|`` of every Floquet multiplier along the branch (log scale), the unit
        circle as a line, bifurcations as vertical lines.

        Parameters
        ----------
        ax
            Axes to draw into (new figure if ``None``).
        children
            Also draw the branches switched onto at period doublings.
        xscale
            Multiply the parameter by this for the horizontal axis.
        color
            One colour for all multipliers (default: one per multiplier).

        Returns
        -------
        matplotlib.axes.Axes
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.2))
        branches = self.all_branches() if children else [self]
        for br in branches:
            x = br.values * xscale
            mus = [p.multipliers for p in br.points]
            n = max(len(m) for m in mus)
            A = np.full((len(x), n), np.nan)
            R = np.full((len(x), n), np.nan)
            for i, m in enumerate(mus):
                A[i, :len(m)] = np.abs(m)
                R[i, :len(m)] = np.abs(m.imag) < 1e-9 * np.maximum(1, np.abs(m))
            for j in range(n):
                ax.semilogy(x, A[:, j], ".", ms=2.5, color=color or f"C{j % 10}")
            for b in br.bifurcations:
                mk, mc = _MARKERS.get(b.type, ("x", "k"))
                ax.axvline(b.value * xscale, color=mc, lw=0.8, ls=":")
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xlabel(self.param)
        ax.set_ylabel("|Floquet multiplier|")
        ax.grid(alpha=0.3, which="both")
        return ax

    def plot_meshes(self, axes: Sequence[Axes] | None = None, xscale: float = 1.0, yscale: float = 1.0,
                    yunit: str = "", xlabel: str | None = None, children: bool = True) -> list[Axes]:
        """One panel per mesh: max and min of its dynamic deflection along the branch
        (stable solid, unstable dashed), bifurcations marked, rattle state as the colour
        of the points (0 contact kept, 1 contact loss, 2 back-side contact).

        Parameters
        ----------
        axes
            One axes per mesh (a new figure if ``None``).
        xscale, yscale
            Factors for the parameter and the deflections (unit changes, e.g. 1e6 for um).
        yunit
            Unit label of the deflections.
        xlabel
            Label of the horizontal axis (default: the parameter name).
        children
            Also draw the branches switched onto at period doublings.

        Returns
        -------
        list of matplotlib.axes.Axes
        """
        import matplotlib.pyplot as plt

        names = self.mesh_names
        if axes is None:
            _, ax_arr = plt.subplots(len(names), 1, figsize=(7, 2.6 * max(1, len(names))), sharex=True,
                                     squeeze=False)
            axes = list(ax_arr[:, 0])
        axes = list(axes)
        colours = {0: "C2", 1: "C1", 2: "C3", -1: "0.5"}
        branches = self.all_branches() if children else [self]
        for ax, name in zip(axes, names):
            for k, br in enumerate(branches):
                x = br.values * xscale
                for q in ("max", "min"):
                    _styled_line(ax, x, br.mesh_quantity(name, q) * yscale, br.stable, f"C{k % 10}" if k else "C0",
                                 None)
                rs = br.mesh_quantity(name, "rattle_state").astype(int)
                for code in np.unique(rs):
                    sel = rs == code
                    lab = {0: "contact kept", 1: "contact loss", 2: "back-side contact"}.get(int(code), "no backlash")
                    ax.plot(x[sel], br.mesh_quantity(name, "max")[sel] * yscale, ".", ms=3,
                            color=colours.get(int(code), "k"), label=lab if k == 0 else None)
                for b in br.bifurcations:
                    mk, mc = _MARKERS.get(b.type, ("x", "k"))
                    ax.axvline(b.value * xscale, color=mc, lw=0.7, ls=":")
            ax.set_ylabel(f"{name} deflection" + (f" [{yunit}]" if yunit else ""))
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="best")
        if axes:
            axes[-1].set_xlabel(xlabel or self.param)
        return list(axes)

    def plot_figure(self, path: str | Path | None = None, quantity: str | list[str] = "max",
                    title: str = "", xscale: float = 1.0, children: bool = True):
        """A two-panel figure: response curve above, multipliers below.

        Parameters
        ----------
        path
            Save the figure there (and close it).
        quantity
            As for :meth:`plot`.
        title
            Title above the response curve.
        xscale
            Multiply the parameter by this for the horizontal axis.
        children
            Also draw the switched-on branches.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt

        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6.4), sharex=True,
                                     gridspec_kw={"height_ratios": [2.2, 1]})
        self.plot(a1, quantity=quantity, xscale=xscale, children=children)
        self.plot_multipliers(a2, children=children, xscale=xscale)
        a1.set_xlabel("")
        if title:
            a1.set_title(title)
        fig.tight_layout()
        if path is not None:
            save_figure(fig, path, dpi=110)
            plt.close(fig)
        return fig


def add_legend(ax: Axes, loc: str = "best", fontsize: float = 8) -> None:
    """A legend of everything drawn on ``ax`` plus the line styles (stable solid, unstable dashed)."""
    from matplotlib.lines import Line2D

    h, lab = ax.get_legend_handles_labels()
    h += [Line2D([], [], color="0.3", ls="-"), Line2D([], [], color="0.3", ls="--")]
    lab += ["stable", "unstable"]
    ax.legend(h, lab, fontsize=fontsize, loc=loc)


_MARKERS = {"fold": ("o", "C3"), "period_doubling": ("s", "C2"), "neimark_sacker": ("D", "C4"),
            "grazing": ("^", "k"), "branch_point": ("x", "C5")}


def _styled_line(ax: Axes, x: np.ndarray, y: np.ndarray, stable: np.ndarray, color: str,
                 label: str | None) -> None:
    """Draw ``y(x)`` solid where stable, dashed where not (segments share end points)."""
    if len(x) == 0:
        return
    start = 0
    first = True
    for i in range(1, len(x) + 1):
        if i == len(x) or stable[i] != stable[start]:
            j = min(i + 1, len(x)) if i < len(x) else i
            ax.plot(x[start:j], y[start:j], "-" if stable[start] else "--", color=color,
                    lw=1.6 if stable[start] else 1.2, label=label if first else None)
            first = False
            start = i
