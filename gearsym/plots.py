"""Figures of a trajectory: time history, phase portrait, Poincare section, spectrum."""

from __future__ import annotations

from pathlib import Path

import matplotlib

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


def plot_all(traj: Trajectory, out_dir: str | Path, title: str = "", state: int = 0,
             transient_fraction: float = 0.5, surfaces: list[float] | None = None) -> list[Path]:
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
        Index of the coordinate to plot (its velocity is taken as the state
        ``n_states // 2`` further on).
    transient_fraction
        The phase portrait, Poincare section and spectrum use the last
        ``1 - transient_fraction`` of the run.
    surfaces
        Coordinate values of contact surfaces to draw as lines (e.g. ``[-b, b]``).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = traj.y.shape[1]
    qname = traj.state_names[state]
    vidx = state + n // 2 if n >= 2 else state
    vname = traj.state_names[vidx]
    steady = steady_part(traj, 1 - transient_fraction)
    files = []

    fig, ax = plt.subplots(figsize=(8, 3.2))
    ax.plot(traj.t, traj.y[:, state], lw=0.7)
    for s in surfaces or []:
        ax.axhline(s, color="0.6", lw=0.6, ls="--")
    ax.set_xlabel("t")
    ax.set_ylabel(qname)
    ax.set_title(f"{title} time history".strip())
    fig.tight_layout()
    files.append(out / "time_history.png")
    save_figure(fig, files[-1], dpi=120)
    plt.close(fig)

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
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
