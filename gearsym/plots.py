"""Figures of a trajectory: time history, phase portrait, Poincare section, spectrum.

Needs the ``plots`` extra (matplotlib): importing this module without it raises
:class:`~gearsym.extras.MissingExtraError` naming the extra.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .extras import require

require("plots", "gearsym.plots (figures)")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .files import save_figure  # noqa: E402
from .results import Trajectory  # noqa: E402


def steady_part(traj: Trajectory, fraction: float = 0.5) -> slice:
    """Index range of the last ``fraction`` of a trajectory (whole periods if possible)."""
    n = len(traj.t)
    start = int(n * (1 - fraction))
    return slice(start, n)


def amplitude_spectrum(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum of an evenly sampled signal (mean removed).

    Returns angular frequencies and amplitudes (a pure ``A*cos(w*t)`` on an
    integer number of periods gives amplitude ``A`` at ``w``).
    """
    dt = t[1] - t[0]
    yy = y - np.mean(y)
    spec = np.abs(np.fft.rfft(yy)) * 2.0 / len(yy)
    w = 2 * np.pi * np.fft.rfftfreq(len(yy), dt)
    return w, spec


def surface_levels(system: Any) -> list[float]:
    """Levels of the switching surfaces of the form ``x[0] -/+ b`` (lines on the figures).

    Parameters
    ----------
    system : System
        The compiled system.

    Returns
    -------
    list of float
        Values of the first state at which a surface ``g = x[0] - c`` is zero; empty when
        they cannot be found (figures are a convenience: never an error).
    """
    levels = []
    try:
        x = np.zeros(system.generated.nx)
        g0 = np.asarray(system.switching(0.0, x), float).ravel()
        x[0] = 1.0
        g1 = np.asarray(system.switching(0.0, x), float).ravel()
        for a, b in zip(g0, g1):
            if abs((b - a) - 1.0) < 1e-12:
                levels.append(-a)
    except Exception:  # plots are a convenience; never fail the command for them
        return []
    return levels


def plot_time_history(traj: Trajectory, path: str | Path, states: Sequence[str | int] | None = None,
                      title: str = "", surfaces: list[float] | None = None) -> Path:
    """Time histories of the states, one panel each -> a PNG.

    Parameters
    ----------
    traj
        The trajectory.
    path
        The PNG file to write (atomically).
    states
        Names or indices of the states to show (default: every state).
    title
        Figure title prefix.
    surfaces
        Levels of the first state's contact surfaces, drawn as dashed lines on its panel.

    Returns
    -------
    Path
        ``path``.
    """
    idx = [traj.state_names.index(s) if isinstance(s, str) else int(s)
           for s in (states if states is not None else range(len(traj.state_names)))]
    fig, axes = plt.subplots(len(idx), 1, figsize=(8, 1.2 + 1.6 * len(idx)), sharex=True, squeeze=False)
    for ax, i in zip(axes[:, 0], idx):
        ax.plot(traj.t, traj.y[:, i], lw=0.7)
        if i == 0:
            for s in surfaces or []:
                ax.axhline(s, color="0.6", lw=0.6, ls="--")
        ax.set_ylabel(traj.state_names[i])
    axes[-1, 0].set_xlabel("t")
    axes[0, 0].set_title(f"{title} time history".strip())
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return Path(path)


def plot_all(traj: Trajectory, out_dir: str | Path, title: str = "", state: int = 0,
             transient_fraction: float = 0.5, surfaces: list[float] | None = None,
             states: Sequence[str | int] | None = None) -> list[Path]:
    """Write time history, phase portrait, Poincare section and spectrum PNGs.

    Parameters
    ----------
    traj
        The trajectory.
    out_dir
        Folder for the PNG files (created).
    title
        Figure title prefix.
    state
        Index of the coordinate of the phase portrait, Poincare section and spectrum
        (its velocity is taken as the state ``n_states // 2`` further on).
    transient_fraction
        The phase portrait, Poincare section and spectrum use the last
        ``1 - transient_fraction`` of the run.
    surfaces
        Coordinate values of contact surfaces to draw as lines (e.g. ``[-b, b]``).
    states
        Names or indices of the states in the time-history figure, one panel each
        (default: every state).

    Returns
    -------
    list of Path
        The files written: ``time_history.png``, ``phase_portrait.png``,
        ``poincare.png`` (with a forcing period) and ``spectrum.png``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = traj.y.shape[1]
    qname = traj.state_names[state]
    vidx = state + n // 2 if n >= 2 else state
    vname = traj.state_names[vidx]
    steady = steady_part(traj, 1 - transient_fraction)
    files = [plot_time_history(traj, out / "time_history.png", states, title, surfaces)]

    fig, ax = plt.subplots(figsize=(4.8, 4.2))
    ax.plot(traj.y[steady, state], traj.y[steady, vidx], lw=0.7)
    for s in surfaces or []:
        ax.axvline(s, color="0.6", lw=0.6, ls="--")
    if traj.period:
        pts = traj.poincare()
        pts = pts[len(pts) // 2:]
        ax.plot(pts[:, state], pts[:, vidx], "o", ms=3, color="C3", label="Poincare")
        ax.legend(loc="best", fontsize=8)
    ax.set_xlabel(qname)
    ax.set_ylabel(vname)
    ax.set_title(f"{title} phase portrait".strip())
    fig.tight_layout()
    files.append(out / "phase_portrait.png")
    save_figure(fig, files[-1], dpi=120)
    plt.close(fig)

    if traj.period:
        pts = traj.poincare()
        fig, ax = plt.subplots(figsize=(4.8, 4.2))
        half = len(pts) // 2
        ax.plot(pts[half:, state], pts[half:, vidx], ".", ms=4)
        ax.set_xlabel(qname)
        ax.set_ylabel(vname)
        ax.set_title(f"{title} Poincare section (t = kT)".strip())
        fig.tight_layout()
        files.append(out / "poincare.png")
        save_figure(fig, files[-1], dpi=120)
        plt.close(fig)

    w, a = amplitude_spectrum(traj.t[steady], traj.y[steady, state])
    fig, ax = plt.subplots(figsize=(8, 3.2))
    if traj.period:
        wf = 2 * np.pi / traj.period
        ax.semilogy(w / wf, np.maximum(a, 1e-16), lw=0.8)
        ax.set_xlabel("frequency / forcing frequency")
        ax.set_xlim(0, min(10, w[-1] / wf))
    else:
        ax.semilogy(w, np.maximum(a, 1e-16), lw=0.8)
        ax.set_xlabel("angular frequency")
    ax.set_ylabel(f"|{qname}| amplitude")
    ax.set_title(f"{title} amplitude spectrum".strip())
    fig.tight_layout()
    files.append(out / "spectrum.png")
    save_figure(fig, files[-1], dpi=120)
    plt.close(fig)
    return files


def plot_outputs(t: np.ndarray, outputs: dict[str, np.ndarray], out_dir: str | Path,
                 units: dict[str, str] | None = None, title: str = "") -> Path | None:
    """Time histories of a model's ``[outputs]`` (one panel each) -> ``outputs.png``."""
    if not outputs:
        return None
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(len(outputs), 1, figsize=(8, 2.4 * len(outputs)), sharex=True,
                             squeeze=False)
    for ax, (name, y) in zip(axes[:, 0], outputs.items()):
        ax.plot(t, y, lw=0.7)
        unit = (units or {}).get(name, "")
        ax.set_ylabel(f"{name} [{unit}]" if unit else name)
    axes[-1, 0].set_xlabel("t")
    axes[0, 0].set_title(f"{title} outputs".strip())
    fig.tight_layout()
    path = out / "outputs.png"
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def plot_mesh_deflections(t: np.ndarray, deflections: dict[str, np.ndarray], out_dir: str | Path,
                          flanks: dict[str, tuple[np.ndarray, np.ndarray]] | None = None, title: str = "",
                          rattle: dict[str, int | None] | None = None) -> Path | None:
    """Time history of every mesh's dynamic deflection (one panel each, in um), with its
    contact flanks (backlash) as dashed lines -> ``mesh_deflections.png``."""
    if not deflections:
        return None
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(len(deflections), 1, figsize=(8, 2.4 * len(deflections)), sharex=True, squeeze=False)
    for ax, (name, d) in zip(axes[:, 0], deflections.items()):
        ax.plot(t, d * 1e6, lw=0.7)
        for level in (flanks or {}).get(name, ()):
            ax.plot(t, level * 1e6, color="0.5", lw=0.6, ls="--")
        rs = (rattle or {}).get(name)
        ax.set_ylabel(f"{name} [um]")
        if rs is not None:
            ax.set_title(f"{name}: rattle state {rs} (steady part)", fontsize=9)
    axes[-1, 0].set_xlabel("t")
    fig.suptitle(f"{title} mesh deflections (dynamic transmission errors)".strip(), fontsize=10)
    fig.tight_layout()
    path = out / "mesh_deflections.png"
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path
