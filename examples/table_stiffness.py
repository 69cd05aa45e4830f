"""Mesh stiffness from data: a table from gear geometry and an LTCA-like table over (phase, load).

Two shipped scenes whose mesh stiffness is a table (``docs/spec.md``: tables):

* ``scenes/yu_fig14_geometry.toml`` -- the 50/50-tooth, 3 mm module pair with 340 N m that Yu
  et al. compare with in their Fig. 14, its stiffness computed from its geometry when the model
  is read (``[tables.k_mesh.gears]`` -> :func:`gearsym.gears.mesh_stiffness`, a cubic spline per
  contact zone, jumping where a tooth pair enters or leaves);
* ``scenes/ltca_pair.toml`` -- a 26/39, 4 mm pair whose stiffness is a 64 x 5 table over (mesh
  phase, torque) read from ``models/ltca_pair_k.csv`` (LTCA-like, made by
  ``examples/make_ltca_table.py``: not an LTCA result, its docstring says how), evaluated at the
  run-time torque ``T1``.

For each: the table (what ``gearsym inspect`` reports of it), a simulation, the periodic orbit
at the scene's speed (shooting, Floquet multipliers), and the frequency response: the orbit
continued in the pinion speed (one call of ``gearsym.continuation``; the 64 knots a mesh cycle
are scheduled breakpoints in every integration).  The LTCA pair is continued at two torques --
the same build, the torque is a parameter.

Writes ``OUT/table_stiffness.png`` and ``OUT/table_stiffness.json``; ``--docs`` also writes the
README's gallery figure ``docs/gallery/table_stiffness.png``.

Run: ``python examples/table_stiffness.py [--out out/table_stiffness] [--docs]`` (about a minute
with the first compiles).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402

import gearsym  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
YU = ROOT / "scenes" / "yu_fig14_geometry.toml"
LTCA = ROOT / "scenes" / "ltca_pair.toml"
YU_RANGE = (2500.0, 6000.0)        # pinion rpm (mesh frequency 2.1 - 5 kHz; resonance near 4200 rpm)
LTCA_RANGE = (6000.0, 12000.0)     # pinion rpm (resonance near 9000 rpm)
LTCA_TORQUES = (200.0, 500.0)


def describe(scene, name: str) -> dict:
    """What ``gearsym inspect`` shows of a scene's table, as numbers."""
    table = scene.model_spec.tables[name]
    info = table.to_dict(data=False)
    line = (f"{name}({', '.join(info['domain'])}) [{info['unit']}]: {info['interpolation']}, "
            f"{' x '.join(map(str, info['knots']))} knots, from {info['source']}, "
            f"{info['min']:.4g} .. {info['max']:.4g}")
    print(line)
    if "gears" in info:
        g = info["gears"]
        print(f"  contact ratio {g['contact_ratio']:.4f}, mean {g['mean_N_per_m']:.4g} N/m, ISO 6336 c_gamma "
              f"{g['iso6336_c_gamma_N_per_m']:.4g} N/m (potential energy / ISO = {g['mean_over_iso_c_gamma']:.4f})")
    return info


def orbit_at(system, label: str) -> dict:
    """Simulate the scene, then its periodic orbit from the final state."""
    tr = system.simulate()
    orbit = system.periodic_orbit(x0=tr.final_state)
    mult = [abs(m) for m in orbit.multipliers]
    print(f"{label}: {tr.stats['n_steps']} steps, {tr.stats['n_breaks']} scheduled breaks, {tr.stats['n_events']} "
          f"contact events in {tr.stats['wall_s'] * 1e3:.0f} ms; orbit {orbit.stability}, rattle state "
          f"{orbit.rattle_state}, |multipliers| {', '.join(f'{m:.4f}' for m in mult)}")
    return {"trajectory": tr, "orbit": orbit, "summary": {
        "steps": tr.stats["n_steps"], "breaks": tr.stats["n_breaks"], "events": tr.stats["n_events"],
        "x0": orbit.x0.tolist(), "multipliers_abs": mult, "stability": orbit.stability,
        "rattle_state": orbit.rattle_state}}


def frequency_response(system, lo: float, hi: float, label: str, params=None):
    """The orbit continued in the pinion speed from both ends of the range (a softening resonance
    turns back at its folds: the branch from below may return below ``lo`` before the jump down)."""
    branches, info = [], []
    for a, b in ((lo, hi), (hi, lo)):
        t0 = time.perf_counter()
        branch = gearsym.continuation(system, "n1", a, b, params=params)
        dt = time.perf_counter() - t0
        kinds = [f"{x.type} at {x.value:.0f} rpm" for x in branch.bifurcations]
        print(f"{label}, from {a:g} rpm: {len(branch.points)} orbits in {dt:.1f} s ({branch.stop_reason}); "
              + "; ".join(kinds))
        branches.append(branch)
        info.append({"from_rpm": a, "points": len(branch.points), "seconds": dt, "stop": branch.stop_reason,
                     "bifurcations": [{"type": x.type, "n1_rpm": x.value} for x in branch.bifurcations]})
    return branches, info


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/table_stiffness")
    ap.add_argument("--docs", action="store_true", help="also write docs/gallery/table_stiffness.png")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    summary: dict = {}

    yu_scene, ltca_scene = gearsym.load_scene(YU), gearsym.load_scene(LTCA)
    summary["yu_table"] = describe(yu_scene, "k_mesh")
    summary["ltca_table"] = describe(ltca_scene, "k_ltca")
    yu, ltca = yu_scene.compile(), ltca_scene.compile()
    yu_run = orbit_at(yu, "Yu pair at 4000 rpm")
    ltca_run = orbit_at(ltca, "LTCA pair at 6000 rpm, 200 N m")
    summary["yu_orbit"], summary["ltca_orbit"] = yu_run["summary"], ltca_run["summary"]
    yu_branch, summary["yu_continuation"] = frequency_response(yu, *YU_RANGE, "Yu pair, frequency response")
    ltca_branches = []
    for T in LTCA_TORQUES:
        b, summary[f"ltca_continuation_{T:g}Nm"] = frequency_response(ltca, *LTCA_RANGE,
                                                                      f"LTCA pair at {T:g} N m", {"T1": T})
        ltca_branches.append(b)

    fig, ax = plt.subplots(2, 3, figsize=(15, 8.2))
    k_tab = yu_scene.model_spec.tables["k_mesh"]
    ph = np.linspace(0, 2, 2001)
    ax[0, 0].plot(ph, k_tab(ph) / 1e8, lw=1.2, label="table (cubic per contact zone)")
    ax[0, 0].plot(np.array(k_tab.axes[0].knots), np.array(k_tab.columns[0]) / 1e8, ".", ms=3, label="samples")
    ax[0, 0].axhline(k_tab.info["iso6336_c_gamma_N_per_m"] / 1e8, color="k", ls="--", lw=0.8,
                     label="ISO 6336 $c_{\\gamma\\alpha} b$")
    ax[0, 0].set(xlabel="mesh phase (cycles)", ylabel="k (1e8 N/m)",
                 title=f"50/50, m = 3 mm: from geometry (eps = {k_tab.info['contact_ratio']:.3f})")
    ax[0, 0].legend(fontsize=8)
    l_tab = ltca_scene.model_spec.tables["k_ltca"]
    for T in l_tab.axes[1].knots:
        ax[0, 1].plot(ph, l_tab(ph, T) / 1e8, lw=1, label=f"{T:g} N m")
    ax[0, 1].set(xlabel="mesh phase (cycles)", ylabel="k (1e8 N/m)", title="26/39, m = 4 mm: LTCA-like table")
    ax[0, 1].legend(fontsize=8, title="torque")
    for run, label in ((yu_run, "Yu pair, 4000 rpm"), (ltca_run, "LTCA pair, 6000 rpm")):
        one = run["orbit"].trajectory()
        ax[0, 2].plot(one["x"] * 1e6, one["v"], lw=1.2, label=label)
    ax[0, 2].axvline(50.0, color="C0", ls=":", lw=0.8)
    ax[0, 2].axvline(40.0, color="C1", ls=":", lw=0.8)
    ax[0, 2].set(xlabel="DTE x (um)", ylabel="v (m/s)", title="periodic orbits (dotted: backlash)")
    ax[0, 2].legend(fontsize=8)
    for b in yu_branch:
        b.plot(ax[1, 0], quantity="ptp", color="C0", legend=False)
    ax[1, 0].set(xlabel="pinion speed (rpm)", ylabel="peak-to-peak of x (um)",
                 title="Yu pair: frequency response (continued from both ends)")
    for pair, T, c in zip(ltca_branches, LTCA_TORQUES, ("C0", "C1")):
        for b in pair:
            b.plot(ax[1, 1], quantity="ptp", color=c, legend=False)
        ax[1, 1].plot([], [], color=c, label=f"{T:g} N m", gid="key")
    ax[1, 1].set(xlabel="pinion speed (rpm)", ylabel="peak-to-peak of x (um)",
                 title="LTCA pair: frequency response at two torques")
    for axis in (ax[1, 0], ax[1, 1]):
        axis.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v * 1e6:g}"))
        keys = [h for h in axis.lines if h.get_gid() == "key"]
        keys += axis.plot([], [], "k-", label="stable") + axis.plot([], [], "k--", label="unstable")
        keys += axis.plot([], [], "k^", mfc="none", label="grazing")
        keys += axis.plot([], [], "o", color="C3", mfc="none", label="fold")
        axis.legend(handles=keys, fontsize=8)
    tr = yu_run["trajectory"]
    last = tr.t >= tr.t[-1] - 5 * yu.period()
    ax[1, 2].plot((tr.t[last] - tr.t[last][0]) * 1e3, tr["x"][last] * 1e6, lw=1)
    ax[1, 2].axhline(50.0, color="k", ls=":", lw=0.8)
    ax[1, 2].set(xlabel="t (ms)", ylabel="x (um)", title="Yu pair: DTE over 5 mesh periods (contact loss)")
    fig.tight_layout()
    fig.savefig(out / "table_stiffness.png", dpi=110)
    if a.docs:
        fig.savefig(ROOT / "docs" / "gallery" / "table_stiffness.png", dpi=72)
    (out / "table_stiffness.json").write_text(json.dumps(summary, indent=1, default=float))
    print(f"wrote {out / 'table_stiffness.png'} and {out / 'table_stiffness.json'}")


if __name__ == "__main__":
    main()
