"""The result of a run-up: the run, its waterfall, Campbell diagram and order tracks.

:class:`RunupResult` holds the samples of the run (states, the recorded signal, the speed),
the short-time spectra in speed bins, the mesh-order amplitudes (order tracking in the angle
domain) and the natural frequencies; :meth:`RunupResult.to_xarray` gives them as one
dataset (netCDF: :meth:`RunupResult.save`), and the figures are drawn from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...display import UNITS_CONVENTION, RunupDisplay, netcdf_attrs, netcdf_engine
from ...extras import require
from ...files import atomic_path

if TYPE_CHECKING:  # pragma: no cover
    import xarray as xr

__all__ = ["RunupResult"]


@dataclass(frozen=True, eq=False)
class RunupResult(RunupDisplay):
    """A run-up (:func:`gearsym.analysis.sweeps.runup`).

    Units: the speed in the declared unit of its parameter (``unit``); times in the
    model's time unit (``time_unit``: ``"s"``, or ``"1"`` for a dimensionless model);
    frequencies in cycles per time unit (Hz for ``"s"``: ``frequency_unit``); states,
    the signal and the amplitudes in the model's units (SI for a dimensional model: m or rad
    for a mesh deflection).

    Attributes
    ----------
    scene, parameter, unit : str
        The scene, the speed parameter and its declared unit.
    start, stop, duration : float
        The ramp: the speed from ``start`` to ``stop`` over ``duration``.
    time_unit : str or None
        The model's time unit (``None``: not known to the system).
    t, speed, phase_time : ndarray
        The samples at equal time steps (from 0, the ramp's start), the speed there, and the
        phase time ``tau(t)`` (the time at constant start speed with the same phase).
    states : ndarray, shape (len(t), n_states)
    state_names : list of str
    state_units : dict
        State name -> its unit (``"t"`` -> the time unit).
    signal, signal_name, signal_unit
        The recorded signal at ``t``, what it is and its unit (a state's, or ``"model units
        (SI)"`` for a mesh deflection: the unit of the mesh's deflection expression).
    angle_phase_time, angle_signal : ndarray
        The signal at equal steps of the phase time (the angle domain).
    bin_time, bin_speed : ndarray
        Centre of each speed bin (short-time spectrum) and the speed there.
    frequencies : ndarray
        Frequencies of the spectra.
    spectra : ndarray, shape (bins, frequencies)
        Amplitude spectra (Hann window of length ``window``).
    window : float
        Length of a spectrum's window (time unit); its frequency resolution is ``1 / window``.
    meshes : list of str
    mesh_frequency0 : ndarray
        Order-1 frequency of each mesh at the start speed (proportional to the speed).
    order_amplitude : ndarray, shape (meshes, orders, bins)
        Amplitude of mesh order ``k`` in each bin (angle domain, whole forcing periods).
    order_speed : ndarray
        The speed at the centre of each bin's angle-domain window.
    mode_speeds : ndarray
        Speeds of the modal analyses.
    natural_frequencies : ndarray, shape (len(mode_speeds), modes)
        Positive natural frequencies there (NaN padded).
    break_times : ndarray or None
        The scheduled breakpoints the integrator stopped at.
    event_times, event_surfaces, event_directions, event_speeds
        The switching events (contact loss, impacts): time, surface, direction of the
        crossing (+1: g from - to +), and ``dg/dt`` along the flow there (for a contact
        surface the closing speed of the flanks, with the ramp's time dependence).
    stats, settings, params, param_units : dict
        Integrator statistics; the settings used (tolerances, bins, ...; ``sweep_rate_ratio``
        ``|d speed/dt| / speed^2`` in SI, the relative size of the terms a ramp leaves out);
        the other parameter values (declared units) and their units.
    notes : list of str
    """

    scene: str
    parameter: str
    unit: str
    start: float
    stop: float
    duration: float
    time_unit: str | None
    t: np.ndarray
    speed: np.ndarray
    phase_time: np.ndarray
    states: np.ndarray
    state_names: list[str]
    state_units: dict[str, str]
    signal: np.ndarray
    signal_name: str
    signal_unit: str
    angle_phase_time: np.ndarray
    angle_signal: np.ndarray
    bin_time: np.ndarray
    bin_speed: np.ndarray
    frequencies: np.ndarray
    spectra: np.ndarray
    window: float
    meshes: list[str]
    mesh_frequency0: np.ndarray
    order_amplitude: np.ndarray
    order_speed: np.ndarray
    mode_speeds: np.ndarray
    natural_frequencies: np.ndarray
    break_times: np.ndarray | None
    event_times: np.ndarray
    event_surfaces: list[str]
    event_directions: np.ndarray
    event_speeds: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    params: dict[str, float] = field(default_factory=dict)
    param_units: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    # ------------------------------------------------------------ derived
    @property
    def frequency_unit(self) -> str:
        """``"Hz"`` for a model in seconds, else cycles per time unit."""
        return "Hz" if self.time_unit == "s" else "1/time unit"

    @property
    def rate(self) -> float:
        """The ramp's slope, ``(stop - start) / duration`` (declared unit per time unit)."""
        return (self.stop - self.start) / self.duration

    @property
    def resolution(self) -> float:
        """The frequency step of the spectra (``1 / window``)."""
        return float(self.frequencies[1] - self.frequencies[0])

    def mesh_frequency(self, mesh: str, speed: np.ndarray | float) -> np.ndarray:
        """Order-1 frequency of a mesh at a speed: proportional to the speed.

        Parameters
        ----------
        mesh
            One of ``meshes``.
        speed
            Speed(s) in the declared unit.

        Returns
        -------
        ndarray
            The frequency (``frequency_unit``).
        """
        return self.mesh_frequency0[self.meshes.index(mesh)] * np.asarray(speed, float) / self.start

    def order_frequency(self) -> np.ndarray:
        """Frequency of every mesh order in every bin (at ``order_speed``).

        Returns
        -------
        ndarray, shape (meshes, orders, bins)
        """
        k = np.arange(1, self.order_amplitude.shape[1] + 1)
        return self.mesh_frequency0[:, None, None] * k[None, :, None] * (self.order_speed / self.start)[None, None, :]

    def peaks(self) -> list[dict[str, Any]]:
        """The largest amplitude of every mesh order over the run.

        Returns
        -------
        list of dict
            One per mesh and order: ``mesh``, ``order``, ``amplitude``, ``speed`` (where it
            is largest) and ``frequency`` (of the order there).
        """
        out = []
        F = self.order_frequency()
        for i, m in enumerate(self.meshes):
            for k in range(self.order_amplitude.shape[1]):
                a = self.order_amplitude[i, k]
                if not np.any(np.isfinite(a)):
                    continue
                j = int(np.nanargmax(a))
                out.append({"mesh": m, "order": k + 1, "amplitude": float(a[j]), "speed": float(self.order_speed[j]),
                            "frequency": float(F[i, k, j])})
        return out

    def crossings(self) -> list[dict[str, Any]]:
        """Where a mesh order's line crosses a natural frequency within the run: the resonances
        to expect (from the natural frequencies at the start speed).

        Returns
        -------
        list of dict
            ``mesh``, ``order``, ``mode`` (index), ``frequency`` and ``speed`` of each crossing.
        """
        out = []
        if not self.natural_frequencies.size:
            return out
        lo, hi = sorted((self.start, self.stop))
        for i, m in enumerate(self.meshes):
            for k in range(1, self.order_amplitude.shape[1] + 1):
                for j, fn in enumerate(self.natural_frequencies[0]):
                    if not math.isfinite(fn):
                        continue
                    v = fn / (k * self.mesh_frequency0[i]) * self.start
                    if lo <= v <= hi:
                        out.append({"mesh": m, "order": k, "mode": j, "frequency": float(fn), "speed": float(v)})
        return out

    def __repr__(self) -> str:
        def unit(u: str | None) -> str:  # a dimensionless value carries no unit
            return f" {u}" if u and u != "1" else ""

        return (f"RunupResult({self.scene}: {self.parameter} {self.start:g} -> {self.stop:g}{unit(self.unit)} in "
                f"{self.duration:g}{unit(self.time_unit)}, {len(self.t)} samples, {len(self.bin_speed)} speed bins, "
                f"signal {self.signal_name})")

    # ------------------------------------------------------------ export
    def to_xarray(self) -> xr.Dataset:
        """The run-up as one ``xarray.Dataset`` (units and meanings in the attributes).

        Returns
        -------
        xarray.Dataset

        Dimensions ``time`` (the samples), ``state``, ``angle`` (the angle-domain samples),
        ``bin`` (the speed bins, coordinate ``bin_speed``), ``frequency``, and where they are not
        empty ``mesh`` and ``order`` (the order tracks), ``mode_speed`` and ``mode`` (the
        natural frequencies), ``break`` (the breakpoints), ``event`` (the switching events).
        """
        require("maps", "RunupResult.to_xarray")
        import xarray as xr

        fu, tu = self.frequency_unit, self.time_unit or ""
        coords = {
            "time": ("time", self.t, {"units": tu, "long_name": "time from the start of the ramp"}),
            "state": ("state", list(self.state_names)),
            "state_unit": ("state", [self.state_units.get(n, "") for n in self.state_names]),
            "angle": ("angle", self.angle_phase_time, {"units": tu, "long_name": "phase time of the angle samples"}),
            "bin_speed": ("bin", self.bin_speed, {"units": self.unit, "long_name": f"{self.parameter} at the bin"}),
            "bin_time": ("bin", self.bin_time, {"units": tu}),
            "frequency": ("frequency", self.frequencies, {"units": fu}),
        }
        data = {
            "speed": ("time", self.speed, {"units": self.unit, "long_name": self.parameter}),
            "phase_time": ("time", self.phase_time, {"units": tu, "long_name": "tau(t): time at the start speed "
                                                                              "with the same phase"}),
            "states": (("time", "state"), self.states, {"long_name": "the states (units: state_unit)"}),
            "signal": ("time", self.signal, {"long_name": self.signal_name, "units": self.signal_unit}),
            "angle_signal": ("angle", self.angle_signal, {"long_name": self.signal_name}),
            "spectrum": (("bin", "frequency"), self.spectra, {"long_name": f"amplitude spectrum of {self.signal_name}",
                                                              "units": "signal units"}),
        }
        # (a dimension of length 0 is left out: scipy's netCDF-3 reader cannot read it back)
        if self.meshes:
            coords["mesh"] = ("mesh", list(self.meshes))
            coords["order"] = ("order", np.arange(1, self.order_amplitude.shape[1] + 1))
            data["order_amplitude"] = (("mesh", "order", "bin"), self.order_amplitude, {"units": "signal units"})
            data["order_frequency"] = (("mesh", "order", "bin"), self.order_frequency(), {"units": fu})
            data["order_speed"] = ("bin", self.order_speed, {"units": self.unit})
            data["mesh_frequency0"] = ("mesh", self.mesh_frequency0, {"units": fu, "long_name": "order 1 at the start"})
        if self.natural_frequencies.size:
            coords["mode_speed"] = ("mode_speed", self.mode_speeds, {"units": self.unit})
            coords["mode"] = ("mode", np.arange(self.natural_frequencies.shape[1]))
            data["natural_frequency"] = (("mode_speed", "mode"), self.natural_frequencies, {"units": fu})
        if self.break_times is not None and len(self.break_times):
            data["break_time"] = ("break", np.asarray(self.break_times, float), {"units": tu})
        if len(self.event_times):
            data["event_time"] = ("event", np.asarray(self.event_times, float), {"units": tu})
            data["event_surface"] = ("event", np.asarray(self.event_surfaces, dtype=str))
            data["event_direction"] = ("event", np.asarray(self.event_directions, dtype=np.int32))
            data["event_speed"] = ("event", np.asarray(self.event_speeds, float), {"long_name": "dg/dt at the event"})
        attrs = {"scene": self.scene, "parameter": self.parameter, "unit": self.unit, "start": self.start,
                 "stop": self.stop, "duration": self.duration, "rate": self.rate, "time_unit": tu,
                 "frequency_unit": fu, "signal": self.signal_name, "window": self.window,
                 "notes": "; ".join(self.notes)}
        attrs["units_convention"] = UNITS_CONVENTION
        attrs.update({f"setting_{k}": v for k, v in self.settings.items()})
        attrs.update({f"stat_{k}": v for k, v in self.stats.items()})
        attrs.update({f"param_{k}": v for k, v in self.params.items()})
        attrs.update({f"param_{k}_units": u for k, u in self.param_units.items()})
        return xr.Dataset(data, coords=coords, attrs=netcdf_attrs(attrs))

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no sample arrays).

        Returns
        -------
        dict
            The ramp, statistics, the natural frequencies at the start, :meth:`peaks`,
            :meth:`crossings`, the settings and the notes.
        """
        nf0 = self.natural_frequencies[0] if self.natural_frequencies.size else np.empty(0)
        return {"scene": self.scene, "parameter": self.parameter, "unit": self.unit, "from": self.start,
                "to": self.stop, "duration": self.duration, "rate": self.rate, "time_unit": self.time_unit,
                "frequency_unit": self.frequency_unit, "signal": self.signal_name, "samples": len(self.t),
                "bins": len(self.bin_speed), "window": self.window, "resolution": self.resolution,
                "n_steps": self.stats.get("n_steps"), "n_events": self.stats.get("n_events"),
                "n_breaks": self.stats.get("n_breaks"),
                "meshes": {m: {"order1_frequency_per_speed": float(self.mesh_frequency0[i] / self.start)}
                           for i, m in enumerate(self.meshes)},
                "natural_frequencies": [float(f) for f in nf0 if math.isfinite(f)],
                "peaks": self.peaks(), "crossings": self.crossings(),
                "settings": {k: v.item() if isinstance(v, np.generic) else v for k, v in self.settings.items()},
                "notes": list(self.notes)}

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``runup.nc`` (:meth:`to_xarray`), ``campbell.png``, ``waterfall.png`` and, with
        meshes, ``orders.png``.

        Parameters
        ----------
        out_dir
            The folder (made if needed).

        Returns
        -------
        list of Path
            The files written.
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        nc = out / "runup.nc"
        with atomic_path(nc) as tmp:
            self.to_xarray().to_netcdf(tmp, engine=netcdf_engine())
        files = [nc, self.plot_campbell(out / "campbell.png"), self.plot_waterfall(out / "waterfall.png")]
        if self.meshes:
            files.append(self.plot_orders(out / "orders.png"))
        return files

    # ------------------------------------------------------------ figures
    def plot_campbell(self, path: str | Path) -> Path:
        """The Campbell diagram: frequency against speed, colour the amplitude (log scale), the
        mesh orders (dashed) and the natural frequencies (dotted) overlaid.

        Parameters
        ----------
        path
            The image file to write.

        Returns
        -------
        Path
        """
        plt = _pyplot()
        from matplotlib.colors import LogNorm

        fig, ax = plt.subplots(figsize=(7.5, 5.2))
        A = np.where(self.spectra > 0, self.spectra, np.nan)
        top = np.nanmax(A) if np.any(np.isfinite(A)) else 1.0
        pc = ax.pcolormesh(self.bin_speed, self.frequencies, A.T, shading="nearest", cmap="viridis",
                           norm=LogNorm(vmin=top * 1e-4, vmax=top))
        fig.colorbar(pc, ax=ax).set_label(f"amplitude of {self.signal_name}")
        self._overlay(ax, vertical=False)
        ax.set_xlabel(f"{self.parameter} [{self.unit}]")
        ax.set_ylabel(f"frequency [{self.frequency_unit}]")
        ax.set_ylim(0, self._fmax())
        ax.set_title(f"{self.scene}: Campbell diagram")
        return _finish(fig, path)

    def plot_waterfall(self, path: str | Path, decades: float = 3.0) -> Path:
        """The waterfall: one amplitude spectrum per speed bin, stacked along the speed axis.

        Parameters
        ----------
        path
            The image file to write.
        decades
            Heights are logarithmic over this many decades below the largest amplitude.

        Returns
        -------
        Path
        """
        plt = _pyplot()
        fig, ax = plt.subplots(figsize=(7.5, 6.0))
        top = float(np.max(self.spectra)) or 1.0
        step = float(np.ptp(self.bin_speed)) / max(len(self.bin_speed) - 1, 1) if len(self.bin_speed) > 1 else 1.0
        step = step if step != 0 else 1.0
        with np.errstate(divide="ignore"):
            level = np.clip(1.0 + np.log10(np.maximum(self.spectra, 1e-300) / top) / decades, 0.0, 1.0)
        for v, h in zip(self.bin_speed[::-1], level[::-1]):
            y = v + 4.0 * step * h
            ax.fill_between(self.frequencies, v, y, color="white", zorder=2)
            ax.plot(self.frequencies, y, color="C0", lw=0.7, zorder=3)
        self._overlay(ax, vertical=True)
        ax.set_xlabel(f"frequency [{self.frequency_unit}]")
        ax.set_ylabel(f"{self.parameter} [{self.unit}] (spectra offset by speed, {decades:g} decades)")
        ax.set_xlim(0, self._fmax())
        ax.set_title(f"{self.scene}: waterfall of {self.signal_name}")
        return _finish(fig, path)

    def plot_orders(self, path: str | Path) -> Path:
        """The order tracks: the amplitude of each mesh order against speed, the crossings with
        the natural frequencies marked.

        Parameters
        ----------
        path
            The image file to write.

        Returns
        -------
        Path
        """
        plt = _pyplot()
        fig, ax = plt.subplots(figsize=(7.5, 4.8))
        for i, m in enumerate(self.meshes):
            for k in range(self.order_amplitude.shape[1]):
                ax.semilogy(self.order_speed, self.order_amplitude[i, k], lw=1.0, label=f"{m} order {k + 1}")
        for c in self.crossings():
            ax.axvline(c["speed"], color="0.5", ls=":", lw=0.8)
        ax.set_xlabel(f"{self.parameter} [{self.unit}]")
        ax.set_ylabel(f"amplitude of {self.signal_name}")
        ax.legend(fontsize=8)
        ax.set_title(f"{self.scene}: mesh-order tracks")
        return _finish(fig, path)

    def _fmax(self) -> float:
        """The top of the figures' frequency axes: a quarter above the highest order line or
        natural frequency, at most the Nyquist frequency."""
        top = 0.0
        if self.meshes:
            top = float(np.max(self.order_amplitude.shape[1] * self.mesh_frequency0) * max(abs(self.start),
                                                                                          abs(self.stop)) / abs(self.start))
        if self.natural_frequencies.size and np.any(np.isfinite(self.natural_frequencies)):
            top = max(top, float(np.nanmax(self.natural_frequencies)))
        return float(min(self.frequencies[-1], 1.25 * top)) if top > 0 else float(self.frequencies[-1])

    def _overlay(self, ax: Any, vertical: bool) -> None:
        """Mesh orders (dashed) and natural frequencies (dotted) on a speed-frequency plane
        (``vertical``: frequency on the x axis)."""
        v = np.array([self.start, self.stop])
        fmax = self._fmax()
        for m in self.meshes:
            for k in range(1, self.order_amplitude.shape[1] + 1):
                f = k * self.mesh_frequency(m, v)
                xy = (f, v) if vertical else (v, f)
                ax.plot(*xy, ls="--", lw=0.8, color="w" if not vertical else "C3", zorder=4)
                if f.max() <= fmax:
                    j = int(np.argmax(f))
                    ax.annotate(f"{m} x{k}", (xy[0][j], xy[1][j]), fontsize=7, color="C3", zorder=5)
        if self.natural_frequencies.size:
            for j in range(self.natural_frequencies.shape[1]):
                f = self.natural_frequencies[:, j]
                if not np.all(np.isfinite(f)) or f.min() > fmax:
                    continue
                xy = (f, self.mode_speeds) if vertical else (self.mode_speeds, f)
                ax.plot(*xy, ls=":", lw=1.2, color="C1", zorder=4)
                ax.annotate(f"mode {j}: {f[0]:.5g} {self.frequency_unit}", (xy[0][0], xy[1][0]), fontsize=7,
                            color="C1", zorder=5)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(fig: Any, path: str | Path) -> Path:
    p = Path(path)
    fig.tight_layout()
    with atomic_path(p) as tmp:
        fig.savefig(tmp, dpi=120, format=p.suffix.lstrip(".") or "png")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return p
