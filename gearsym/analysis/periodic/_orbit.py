"""Periodic orbits: the result object :class:`PeriodicOrbit`.

Shooting (:mod:`gearsym.analysis.periodic._shooting`) and harmonic balance
(:mod:`gearsym.analysis.periodic._hbm`) both return one, assembled by :func:`finish_orbit`
(multipliers, stability verdict, rattle states); the entry point that dispatches
between them is :func:`gearsym.analysis.periodic.periodic_orbit`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...display import OrbitDisplay
from ...errors import ParameterError
from ...files import save_figure
from ._fourier import synthesize
from ._meshes import mesh_names, mesh_report
from ._rattle import RATTLE_STATES, mesh_rattle_states
from ._stability import floquet, rigid_state_basis, verdict

if TYPE_CHECKING:  # pragma: no cover
    from ...quantities import GearQuantities
    from ...results import Event, Trajectory
    from ...system import CompiledSystem

__all__ = ["VANISHING", "PeriodicOrbit", "SolvedOrbit", "finish_orbit"]

#: A state whose magnitude over an orbit is at most this fraction of the largest state's
#: vanishes on it: it is round-off (e.g. the centre translations of a planetary set with
#: equally spaced planets, which only round-off excites), and nothing may be measured relative
#: to its own size.  The shipped scenes' smallest genuine magnitudes are above 3e-7 of their
#: largest, their vanishing ones near 1e-12.
VANISHING = 1e-9

@dataclass(frozen=True, eq=False, repr=False)
class PeriodicOrbit(OrbitDisplay):
    """A periodic orbit of a compiled system and its Floquet multipliers.

    Units: ``x0`` in SI (the system's ``units_table()``), ``period`` and ``t0`` in the model's
    time unit (seconds), ``params`` in the declared units.  ``repr`` is one line; in Jupyter a
    table; ``to_xarray()`` / ``to_dataframe()`` give the sampled orbit (:mod:`gearsym.display`).

    Attributes
    ----------
    x0 : ndarray
        The state on the orbit at ``t0`` (a whole multiple of the forcing period,
        ``t0 = 0`` by default: the start of the forcing period).
    period : float
        Period of the orbit (``periods`` forcing periods).
    periods : float
        Number of forcing periods the orbit spans, a whole number (1: period-one orbit).
    t0 : float
        Time at which ``x0`` is taken.
    monodromy : ndarray or None
        ``d x(t0 + period) / d x(t0)``, with saltation matrices at the events.
    multipliers : ndarray (complex)
        The non-trivial Floquet multipliers, by decreasing modulus: the eigenvalues of
        the monodromy, or -- when the model keeps rigid-body modes -- of the monodromy
        on the complement of the rigid-body subspace (:mod:`gearsym.analysis.periodic._stability`).
    stable : bool
        No multiplier outside the unit circle beyond its tolerance
        (``stability != "unstable"``).
    iterations : int
        Newton (shooting) or quasi-Newton (harmonic balance) iterations.
    residual : float
        Final residual: ``max |phi(t0 + period, x0) - x0|`` over the shooting
        segments (shooting), or the maximum harmonic-balance residual (hbm).
    converged : bool
        Whether the solver met its tolerance.
    method : str
        ``"shooting"`` or ``"hbm"``.
    state_names : list of str
    params : dict
        Parameter values of the solve (declared units, as :attr:`System.params`).
    rattle_state : int or None
        For backlash models: 0 no contact loss, 1 contact loss only, 2 back-side
        contact (see :data:`RATTLE_STATES`); ``None`` without contact surfaces.
    events : list of Event
        Surface crossings along one period of the orbit.
    segments : int
        Number of shooting segments (1: single shooting).
    segment_states : ndarray, shape (segments, nx)
        The state at the start of each segment.
    segment_monodromies : list of ndarray
        Monodromy of each segment (their product, last first, is ``monodromy``).
    harmonics : int or None
        Number of harmonics (harmonic balance).
    coefficients : ndarray or None
        Harmonic-balance coefficients, shape (2*harmonics + 1, nx), rows
        ``[a0, a1, b1, a2, b2, ...]`` of ``a0 + sum a_k cos(k w t) + b_k sin(k w t)``
        with ``w = 2*pi/period`` and ``t`` measured from ``t0``.
    history : list of dict
        One entry per iteration: ``residual``, ``step`` (damping factor), ...
    info : dict
        Method-specific extras (tolerances, harmonic growth history, wall time) and
        ``"verification"``: the orbit integrated once more over its period, the check every
        converged orbit passes before it is reported (:mod:`gearsym.analysis.periodic._verification`);
        shooting's ``"newton"``: where the Newton iteration ran (``"C"``, ``"C, then Python"``
        or ``"Python: <why not C>"``, e.g. a DAE on IDA).
    stability : str
        ``"asymptotically_stable"``, ``"neutral"`` (a multiplier on the unit circle
        within the monodromy's error) or ``"unstable"`` (the rule of
        :mod:`gearsym.analysis.periodic._stability`); ``"unknown"`` without a monodromy.
    trivial_multipliers : ndarray (complex)
        The multipliers of the rigid-body modes (two at +1 per mode), reported apart.
    multiplier_tolerances : ndarray
        Tolerance of each non-trivial multiplier (the neutral band around the circle).
    rattle_states : dict
        Rattle state of every mesh with contact surfaces (``rattle_state`` is the worst).
    system : System or None
        The compiled system (for :meth:`trajectory`, :meth:`extrema`, :meth:`meshes`).
    """

    x0: np.ndarray
    period: float
    periods: float
    t0: float
    monodromy: np.ndarray | None
    multipliers: np.ndarray
    stable: bool
    iterations: int
    residual: float
    converged: bool
    method: str
    state_names: list[str]
    params: dict[str, float]
    rattle_state: int | None = None
    events: list[Event] = field(default_factory=list)
    segments: int = 1
    segment_states: np.ndarray | None = None
    segment_monodromies: list[np.ndarray] = field(default_factory=list)
    harmonics: int | None = None
    coefficients: np.ndarray | None = None
    history: list[dict[str, Any]] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    system: CompiledSystem | None = field(default=None, repr=False, compare=False)
    _traj: Trajectory | None = field(default=None, init=False, repr=False, compare=False)
    stability: str = ""
    trivial_multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    multiplier_tolerances: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rattle_states: dict[str, int] = field(default_factory=dict)

    # ------------------------------------------------------------ derived
    @property
    def max_multiplier(self) -> float:
        """``max |mu|`` (the stability parameter lambda of Vaishya & Singh)."""
        return float(np.max(np.abs(self.multipliers))) if len(self.multipliers) else math.nan

    def trajectory(self, n_out: int | None = None, rtol: float | None = None,
                   atol: float | None = None) -> Trajectory:
        """One period of the orbit, integrated from ``x0`` with the engine.

        Parameters
        ----------
        n_out
            Output points (default 1024 per forcing period, at least 2048).
        rtol, atol
            Tolerances (default: those of the solve).

        Returns
        -------
        Trajectory
            Cached for the default arguments.
        """
        if self.system is None:
            raise ParameterError("this orbit is not attached to a system")
        if n_out is None and rtol is None and atol is None and self._traj is not None:
            return self._traj
        n = n_out or max(2048, int(1024 * self.periods) + 1)
        tr = self.system.simulate(t_end=self.t0 + self.period, t0=self.t0, x0=self.x0,
                                  rtol=rtol or self.info.get("rtol", 1e-10),
                                  atol=atol or self.info.get("atol", 1e-12),
                                  n_out=n, params=self.params)
        if n_out is None and rtol is None and atol is None:
            object.__setattr__(self, "_traj", tr)  # a cache of the result, not state
        return tr

    def extrema(self, state: int | str = 0) -> tuple[float, float]:
        """``(min, max)`` of one state over the orbit.

        From the harmonic series for harmonic balance, from a dense engine
        trajectory (refined by parabolic interpolation) for shooting.

        Parameters
        ----------
        state
            Index or name of the state.

        Returns
        -------
        tuple of float
            ``(min, max)``.
        """
        i = self.state_names.index(state) if isinstance(state, str) else int(state)
        if self.method == "hbm" and self.coefficients is not None:
            y = synthesize(self.coefficients[:, i], 8192)
            return _refined_min(y), _refined_max(y)
        y = self.trajectory().y[:, i]
        return _refined_min(y), _refined_max(y)

    def peak_to_peak(self, state: int | str = 0) -> float:
        """``max - min`` of one state over the orbit.

        Parameters
        ----------
        state
            Index or name of the state.

        Returns
        -------
        float
        """
        lo, hi = self.extrema(state)
        return hi - lo

    def save_plots(self, out_dir: str | Path, title: str = "") -> list[Path]:
        """Write ``orbit_phase.png`` (phase portrait and time history over one
        period, events marked) and ``orbit_multipliers.png`` (the multipliers and
        the unit circle) into ``out_dir``.

        Parameters
        ----------
        out_dir
            Folder (created if missing).
        title
            Title of the phase-portrait figure (default: method, stability, max ``|mu|``).

        Returns
        -------
        list of Path
            The two files.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        files = []
        names = self.state_names
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.3))
        if self.system is not None:
            tr = self.trajectory()
            t, y = tr.t, tr.y
        elif self.coefficients is not None:
            n = 2048
            t = self.t0 + self.period * np.arange(n + 1) / n
            y = synthesize(self.coefficients, n)
            y = np.vstack([y, y[:1]])
        else:
            t, y = np.array([self.t0]), self.x0[None, :]
        j = 1 if len(names) > 1 else 0
        ax1.plot(y[:, 0], y[:, j], lw=1.0)
        ax1.plot(self.x0[0], self.x0[j], "ko", ms=5, label="x0 (t = t0)")
        if self.system is not None and self.events:
            ev_t = np.array([e.t for e in self.events])
            ev_y = np.array([np.interp(ev_t, t, y[:, k]) for k in range(y.shape[1])]).T
            ax1.plot(ev_y[:, 0], ev_y[:, j], "r.", ms=6, label="surface crossings")
        ax1.set_xlabel(names[0])
        ax1.set_ylabel(names[j])
        ax1.set_title("phase portrait (one period)")
        ax1.legend(loc="best", fontsize=8)
        ax2.plot(t, y[:, 0], lw=1.0)
        ax2.set_xlabel("t")
        ax2.set_ylabel(names[0])
        ax2.set_title(f"period {self.period:.6g} ({self.periods:g} forcing period(s))")
        fig.suptitle(title or f"periodic orbit ({self.method}), "
                     f"{(self.stability or '').replace('_', ' ')}, max|mu| = {self.max_multiplier:.6g}")
        fig.tight_layout()
        f1 = out / "orbit_phase.png"
        save_figure(fig, f1, dpi=120)
        plt.close(fig)
        files.append(f1)
        fig, ax = plt.subplots(figsize=(5, 5))
        th = np.linspace(0, 2 * np.pi, 400)
        ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8)
        mu = self.multipliers
        tol = self.multiplier_tolerances if len(self.multiplier_tolerances) == len(mu) else np.zeros(len(mu))
        inside = np.abs(mu) <= 1 + tol
        ax.plot(mu.real[inside], mu.imag[inside], "bo", label="|mu| <= 1 (within tolerance)")
        ax.plot(mu.real[~inside], mu.imag[~inside], "rx", ms=9, mew=2, label="|mu| > 1")
        triv = self.trivial_multipliers
        if len(triv):
            ax.plot(triv.real, triv.imag, "s", mfc="none", color="0.4", ms=9, label="trivial (rigid-body)")
        r = max(1.1, float(np.max(np.abs(mu))) * 1.1 if len(mu) else 1.1)
        ax.set_xlim(-r, r)
        ax.set_ylim(-r, r)
        ax.set_aspect("equal")
        ax.axhline(0, color="0.8", lw=0.5)
        ax.axvline(0, color="0.8", lw=0.5)
        ax.set_xlabel("Re mu")
        ax.set_ylabel("Im mu")
        ax.set_title("Floquet multipliers")
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        f2 = out / "orbit_multipliers.png"
        save_figure(fig, f2, dpi=120)
        plt.close(fig)
        files.append(f2)
        return files

    def meshes(self) -> dict[str, dict[str, Any]]:
        """Per mesh: rattle state and the extrema / peak-to-peak of its dynamic deflection
        over the orbit.

        Returns
        -------
        dict
            Mesh name -> summary (``{}`` for a model without meshes or an orbit without a system).
        """
        if self.system is None:
            return {}
        if not mesh_names(self.system):
            return {}
        if self.method == "hbm" and self.coefficients is not None:
            n = 8192
            t = self.t0 + self.period * np.arange(n) / n
            Y = synthesize(self.coefficients, n)
        else:
            tr = self.trajectory()
            t, Y = tr.t, tr.y
        return mesh_report(self.system, t, Y, self.params, self.rattle_states)

    def gear_quantities(self, **options: Any) -> GearQuantities:
        """Per mesh: static and dynamic transmission error, mesh force, dynamic factor, DTE harmonics,
        contact-loss and back-contact ratios, impacts, load sharing, over one period of the orbit
        (:func:`gearsym.quantities.gear_quantities`, where every quantity is defined).

        Parameters
        ----------
        **options
            ``harmonics``, ``mesh_periods``, ``planet_sets`` of
            :func:`~gearsym.quantities.gear_quantities`.

        Returns
        -------
        gearsym.quantities.GearQuantities
        """
        from ...quantities import orbit_gear_quantities

        if self.system is None:
            raise ParameterError("this orbit is not attached to a system")
        return orbit_gear_quantities(self.system, self, **options)

    def to_dict(self, extrema: bool = True) -> dict[str, Any]:
        """JSON-ready summary (multipliers as ``[re, im]`` pairs).

        Parameters
        ----------
        extrema
            Include ``min``, ``max`` of the first state and the per-mesh summary (one dense
            integration).

        Returns
        -------
        dict
        """
        d: dict[str, Any] = {
            "method": self.method,
            "state_names": list(self.state_names),
            "x0": [float(v) for v in self.x0],
            "t0": self.t0,
            "period": self.period,
            "periods": self.periods,
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "max_multiplier": self.max_multiplier,
            "monodromy": None if self.monodromy is None else self.monodromy.tolist(),
            "stable": bool(self.stable),
            "stability": self.stability,
            "trivial_multipliers": [[float(m.real), float(m.imag)] for m in self.trivial_multipliers],
            "multiplier_tolerances": [float(v) for v in self.multiplier_tolerances],
            "converged": bool(self.converged),
            "iterations": int(self.iterations),
            "residual": float(self.residual),
            "rattle_state": self.rattle_state,
            "rattle_state_meaning": RATTLE_STATES.get(self.rattle_state) if self.rattle_state is not None
            else None,
            "segments": self.segments,
            "harmonics": self.harmonics,
            "n_events": len(self.events),
            "params": dict(self.params),
        }
        d["rattle_states"] = dict(self.rattle_states)
        if extrema:
            lo, hi = self.extrema(0)
            d["min"], d["max"] = lo, hi
            d["meshes"] = self.meshes()
        for k in ("wall_s", "harmonic_growth", "rtol", "atol", "tol", "defect", "defect_relative", "harmonic_set",
                  "verification", "newton"):
            if k in self.info:
                d[k] = self.info[k]
        return d


def _refined_max(y: np.ndarray) -> float:
    """Maximum of samples refined by a parabola through the top three points."""
    i = int(np.argmax(y))
    if 0 < i < len(y) - 1:
        a, b, c = y[i - 1], y[i], y[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return float(b - 0.125 * (c - a) ** 2 / den)
    return float(y[i])


def _refined_min(y: np.ndarray) -> float:
    return -_refined_max(-np.asarray(y))


@dataclass(frozen=True)
class SolvedOrbit:
    """What a periodic-orbit solver found, before the verdict: the input of :func:`finish_orbit`.

    Attributes
    ----------
    x0 : ndarray
        The state at ``t0``.
    period, periods, t0 : float
        The orbit period, its forcing periods and the phase of ``x0``.
    monodromy : ndarray or None
        The monodromy (``None``: no multipliers, "unknown" stability).
    iterations : int
        Newton (or quasi-Newton) iterations.
    residual : float
        The solver's final residual.
    converged : bool
        The solver's answer.
    method : str
        ``"shooting"`` or ``"hbm"``.
    params : mapping
        The run-time parameter values (declared units).
    events : sequence of Event
        The events over one period.
    samples : tuple of ndarray or None
        ``(t, x)`` of a dense series of the orbit (harmonic balance), for the rattle states.
    multipliers : tuple or None
        ``(mu, tolerances, delta)`` of the whole monodromy as
        :func:`~gearsym.analysis.periodic.multiplier_tolerances` gives them, already computed (by
        the driver); used for a model without rigid-body modes or algebraic states.
    g0 : ndarray or None
        The switching functions at ``(t0, x0)``, already evaluated (by the driver).
    """

    x0: np.ndarray
    period: float
    periods: float
    t0: float
    monodromy: np.ndarray | None
    iterations: int
    residual: float
    converged: bool
    method: str
    params: Mapping[str, float]
    events: Sequence[Event]
    samples: tuple[np.ndarray, np.ndarray] | None = None
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None
    g0: np.ndarray | None = None


def finish_orbit(system: CompiledSystem, solved: SolvedOrbit, **extra: Any) -> PeriodicOrbit:
    """Assemble a :class:`PeriodicOrbit` (multipliers, verdict, rattle state).

    The multipliers are judged by :func:`gearsym.analysis.periodic.floquet` with the
    integration tolerance ``extra["info"]["monodromy_rtol"]`` (else ``["rtol"]``) and the
    model's rigid-body subspace; the driver's ``solved.multipliers`` are taken as they are
    where they apply.  ``extra``: further fields of the orbit (``info``, ``history``,
    ``segments``, ``harmonics``, ...).
    """
    info = extra.get("info") or {}
    rtol = float(info.get("monodromy_rtol", info.get("rtol", 1e-10)))
    nd = getattr(system, "differential_states", None)  # DAE: the multipliers of the differential states
    monodromy, multipliers = solved.monodromy, solved.multipliers
    basis = rigid_state_basis(system, solved.params)
    if multipliers is not None and basis is None and monodromy is not None and \
            nd in (None, np.shape(monodromy)[0]) and len(multipliers[0]) == np.shape(monodromy)[0]:
        fq = verdict(*multipliers)
    else:
        fq = floquet(None if monodromy is None else np.asarray(monodromy)[:nd, :nd], rtol, basis)
    info.update({"monodromy_error": fq.monodromy_error, "rigid_split": fq.info.get("rigid_split"),
                 "invariance_defect": fq.invariance_defect})
    rss = mesh_rattle_states(system, solved.x0, solved.t0, solved.events, solved.params, samples=solved.samples,
                             g0=solved.g0)
    return PeriodicOrbit(x0=np.asarray(solved.x0, float), period=float(solved.period),
                         periods=float(solved.periods), t0=float(solved.t0), monodromy=monodromy,
                         multipliers=fq.multipliers, stable=fq.stable, iterations=int(solved.iterations),
                         residual=float(solved.residual), converged=bool(solved.converged), method=solved.method,
                         state_names=system.state_names, params=dict(solved.params),
                         rattle_state=max(rss.values()) if rss else None, events=list(solved.events),
                         system=system, stability=fq.stability, trivial_multipliers=fq.trivial,
                         multiplier_tolerances=fq.tolerances, rattle_states=rss, **extra)
