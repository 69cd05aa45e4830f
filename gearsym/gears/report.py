"""A text summary and the figure of a :class:`~gearsym.gears.stiffness.MeshStiffness`.

The figure needs the ``plots`` extra (matplotlib): :func:`plot_mesh_stiffness` raises
:class:`~gearsym.extras.MissingExtraError` naming it when it is absent.
"""

from __future__ import annotations

import math
from pathlib import Path

from .stiffness import MeshStiffness

__all__ = ["plot_mesh_stiffness", "summary"]


def summary(result: MeshStiffness) -> str:
    """A few lines for a terminal: geometry, contact ratio, zones, potential-energy and ISO values.

    Parameters
    ----------
    result
        The mesh stiffness (:func:`~gearsym.gears.stiffness.mesh_stiffness`).

    Returns
    -------
    str
        The summary (no trailing newline).
    """
    g = result.geometry
    t1, t2 = g.pinion, g.wheel
    iso = result.iso
    lines = [
        f"spur pair z1={t1.teeth} z2={t2.teeth}, m={g.module * 1e3:g} mm, alpha={math.degrees(g.alpha):g} deg, "
        f"b={g.face_width * 1e3:g} mm, x1={t1.profile_shift:g}, x2={t2.profile_shift:g}",
        f"  centre distance {g.a_w * 1e3:.4f} mm, working pressure angle {math.degrees(g.alpha_w):.4f} deg, "
        f"base pitch {g.base_pitch * 1e3:.4f} mm",
        f"  bore radius {t1.bore_radius * 1e3:.4g} / {t2.bore_radius * 1e3:.4g} mm (h_f = "
        f"{t1.r_f / t1.bore_radius:.3g} / {t2.r_f / t2.bore_radius:.3g}), E = {t1.youngs_modulus:.4g} / "
        f"{t2.youngs_modulus:.4g} Pa, nu = {t1.poisson:g} / {t2.poisson:g}",
        f"contact ratio {result.contact_ratio:.6f}",
    ]
    for a, b, n in result.zones:
        lines.append(f"  phase [{a:.4f}, {b:.4f}]: {n} pair{'s' if n != 1 else ''} in contact")
    lines += [
        f"potential energy: mean {result.mean:.6g} N/m, min {result.minimum:.6g} N/m, max {result.maximum:.6g} N/m",
        f"ISO 6336-1 (B): c' = {iso.c_prime:.5g} N/(mm um) -> {iso.single_stiffness:.6g} N/m, c_gamma_alpha = "
        f"{iso.c_gamma_alpha:.5g} N/(mm um) -> {iso.mesh_stiffness:.6g} N/m",
        f"potential-energy mean / ISO c_gamma_alpha = {result.mean / iso.mesh_stiffness:.4f} "
        f"({100 * (result.mean / iso.mesh_stiffness - 1):+.1f} %)",
    ]
    return "\n".join(lines)


def plot_mesh_stiffness(result: MeshStiffness, path: str | Path) -> Path:
    """Save a PNG of the mesh stiffness over one mesh cycle.

    The curve is :math:`k(\\varphi)`; the zones of one and of two (or more) pairs in contact
    are shaded, the potential-energy mean is a dashed line and ISO 6336's
    :math:`c_{\\gamma\\alpha} b` a solid line.

    Parameters
    ----------
    result
        The mesh stiffness (:func:`~gearsym.gears.stiffness.mesh_stiffness`).
    path
        The PNG file (written atomically).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    MissingExtraError
        matplotlib (the ``plots`` extra) is not installed.
    """
    from ..extras import require

    require("plots", "the mesh stiffness figure")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..files import save_figure

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    try:
        colours = {1: "#f3d9b1", 2: "#cfe3f3", 3: "#d8eed0"}
        for a, b, n in result.zones:
            ax.axvspan(a, b, color=colours.get(n, "#e6e6e6"), alpha=0.8, lw=0,
                       label=f"{n} pair{'s' if n != 1 else ''} in contact")
        # evaluate on a fine grid inside each zone, so the jumps are vertical
        for a, b, _ in result.zones:
            ph = np.linspace(a, b, 120)
            ph[0], ph[-1] = np.nextafter(a, b), np.nextafter(b, a)
            ax.plot(ph, result.at(ph) / 1e6, color="k", lw=1.6)
        ax.axhline(result.mean / 1e6, color="k", ls="--", lw=1, label=f"mean {result.mean / 1e6:.4g} N/um")
        ax.axhline(result.iso.mesh_stiffness / 1e6, color="#c0392b", lw=1.2,
                   label=f"ISO 6336 c_gamma_alpha b = {result.iso.mesh_stiffness / 1e6:.4g} N/um")
        g = result.geometry
        ax.set_title(f"mesh stiffness, z = {g.pinion.teeth}/{g.wheel.teeth}, m = {g.module * 1e3:g} mm, "
                     f"b = {g.face_width * 1e3:g} mm, contact ratio {result.contact_ratio:.3f}", fontsize=10)
        ax.set_xlabel("mesh phase (cycles)")
        ax.set_ylabel("stiffness (N/um = 1e6 N/m)")
        ax.set_xlim(0, 1)
        handles, labels = ax.get_legend_handles_labels()
        keep = dict(zip(labels, handles))
        ax.legend(keep.values(), keep.keys(), fontsize=8, loc="best")
        fig.tight_layout()
        return save_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)
