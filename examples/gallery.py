"""Regenerate the figure gallery: every shipped scene simulated with its own settings.

For each ``scenes/*.toml`` this runs the equivalent of
``gearsym simulate SCENE --out OUT/<scene>`` (time history, phase portrait, Poincare
section, amplitude spectrum, trajectory ``.npz``) and writes an overview sheet
``OUT/overview_<model>.png`` per model with one row per scene (time history of the
steady state and phase portrait with Poincare points).  The Yu et al. sheet instead
overlays the fractal dimensions D = 1.2 ... 1.8 of its scenes (dynamic and constant
backlash) and plots peak-to-peak and mean DTE against D next to the paper's values, so
that it shows what gearsym gives for Figs. 10-12 (the paper's trends are not reproduced;
docs/reproduction.md).  ``--docs`` also copies the overview sheets to ``docs/gallery/``
(the README's gallery).

Run: ``python examples/gallery.py [--out out/gallery] [--docs] [--only PATTERN]``.
"""

from __future__ import annotations

import argparse
import fnmatch
import shutil
import time
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import gearsym  # noqa: E402
from gearsym.plots import plot_all, plot_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def simulate_scene(path: Path, out: Path):
    """Simulate one scene with its [simulate] settings and write its figures."""
    scene = gearsym.load_scene(path)
    system = scene.compile()
    sim = scene.spec.simulate
    traj = system.simulate(rtol=float(sim.get("rtol", 1e-8)), atol=float(sim.get("atol", 1e-10)))
    plot_all(traj, out / scene.name, title=scene.name)
    plot_outputs(traj.t, system.outputs(traj), out / scene.name, system.generated.output_units, scene.name)
    traj.save_npz(out / scene.name / "trajectory.npz")
    return scene, traj


def yu_sheet(out: Path) -> Path:
    """Yu et al. Figs. 10-12 setups: D = 1.2 ... 1.8 overlaid, and amplitude / mean against D and G."""
    import numpy as np

    dyn = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml").compile()
    con = gearsym.load_scene(ROOT / "scenes" / "yu_constant_backlash.toml").compile()
    Ds = (1.2, 1.4, 1.6, 1.8)
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    stats = {"dynamic": [], "constant": []}
    for i, D in enumerate(Ds):
        for kind, system, ls in (("dynamic", dyn, "-"), ("constant", con, "--")):
            tr = system.simulate(periods=300, params={"D": D, "Omega": 0.2}, rtol=1e-8, atol=1e-14,
                                 n_out=300 * 64 + 1)
            x = tr["x"][-100 * 64:] * 1e6
            stats[kind].append((np.ptp(x), x.mean(), len([e for e in tr.events if e.t > tr.t[-100 * 64]])))
            tt = (tr.t[-4 * 64:] - tr.t[-4 * 64]) / tr.period
            ax[0, 0].plot(tt, x[-4 * 64:], ls, color=f"C{i}", lw=1.0,
                          label=f"D = {D} {kind}" if kind == "dynamic" or i == 0 else None)
            if kind == "dynamic":
                ax[0, 1].plot(x, tr["v"][-100 * 64:], color=f"C{i}", lw=0.8, label=f"D = {D}")
    ax[0, 0].set_xlabel("t / mesh period")
    ax[0, 0].set_ylabel("DTE [um]")
    ax[0, 0].set_title("omega* = 0.2: DTE (dashed: constant backlash)", fontsize=9)
    ax[0, 0].legend(fontsize=7, ncol=2)
    ax[0, 1].set_xlabel("DTE [um]")
    ax[0, 1].set_ylabel("DTE rate [m/s]")
    ax[0, 1].set_title("omega* = 0.2, dynamic backlash: phase portraits (periodic, same shape)", fontsize=9)
    ax[0, 1].legend(fontsize=7)
    a = ax[1, 0]
    for kind, mk in (("dynamic", "o"), ("constant", "s")):
        st = np.array(stats[kind])
        a.plot(Ds, st[:, 0], mk + "-", color="C0", mfc="none", label=f"gearsym ppv, {kind}")
        a.plot(Ds, st[:, 1], mk + "-", color="C1", mfc="none", label=f"gearsym mean, {kind}")
    a.plot(Ds, [115, 30, 18, 16], "k*", ms=9, label="paper (Fig. 10 text): amplitude")
    a.plot(Ds, [70, 22, 12, 0], "kx", ms=8, label="paper (Fig. 10 text): mean")
    a.set_xlabel("fractal dimension D")
    a.set_ylabel("um")
    a.set_title("omega* = 0.2: no contact loss in gearsym, D only shifts the mean", fontsize=9)
    a.legend(fontsize=7)
    a = ax[1, 1]
    for j, (name, vals) in enumerate((("D", Ds), ("G", (1e-12, 1e-11, 1e-10)))):
        st = []
        for v in vals:
            tr = dyn.simulate(periods=300, params={name: v, "Omega": 0.31}, rtol=1e-8, atol=1e-14,
                              n_out=300 * 64 + 1)
            x = tr["x"][-100 * 64:] * 1e6
            st.append((np.ptp(x), x.mean()))
        st = np.array(st)
        xs = np.arange(len(vals)) + 4 * j
        a.plot(xs, st[:, 0], "o-", color="C0", mfc="none", label="ppv" if j == 0 else None)
        a.plot(xs, st[:, 1], "s-", color="C1", mfc="none", label="mean" if j == 0 else None)
    a.set_xticks(list(range(4)) + [4, 5, 6], [f"D={v}" for v in Ds] + ["G=1e-12", "1e-11", "1e-10"], fontsize=7)
    a.set_ylabel("DTE [um]")
    a.set_title("omega* = 0.31 (Fig. 12): paper: DTE falls with D, rises with G", fontsize=9)
    a.legend(fontsize=7)
    fig.suptitle("Yu et al. Figs. 10-12 setups, shipped parameters: the paper's D and G trends are NOT "
                 "reproduced (docs/reproduction.md)", fontsize=10)
    fig.tight_layout()
    sheet = out / "overview_yu_6dof.png"
    fig.savefig(sheet, dpi=90)
    plt.close(fig)
    return sheet


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/gallery", help="output folder")
    parser.add_argument("--docs", action="store_true", help="copy overview sheets to docs/gallery/")
    parser.add_argument("--only", default="*", help="glob on scene file names (default: all)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    by_model = defaultdict(list)
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        if not fnmatch.fnmatch(path.name, args.only):
            continue
        t0 = time.perf_counter()
        try:
            scene, traj = simulate_scene(path, out)
        except gearsym.GearsymError as exc:
            print(f"{path.name}: FAILED: {exc}")
            continue
        by_model[scene.model_spec.name].append((scene, traj))
        print(f"{path.name:34s} {traj.stats['n_events']:6d} events {traj.stats['wall_s'] * 1e3:8.1f} ms "
              f"(total {time.perf_counter() - t0:5.1f} s)", flush=True)
    for model, runs in by_model.items():
        if model == "yu_6dof":
            sheet = yu_sheet(out)
            print(f"wrote {sheet}")
            if args.docs:
                shutil.copy(sheet, ROOT / "docs" / "gallery" / sheet.name)
            continue
        fig, axes = plt.subplots(len(runs), 2, figsize=(11, 2.6 * len(runs)), squeeze=False,
                                 gridspec_kw={"width_ratios": [2.2, 1]})
        for row, (scene, traj) in enumerate(runs):
            n = len(traj.t)
            tail = slice(int(n * 0.85), n)
            steady = slice(n // 2, n)
            nq = traj.y.shape[1] // 2 if traj.y.shape[1] > 1 else 0
            ax = axes[row, 0]
            ax.plot(traj.t[tail], traj.y[tail, 0], lw=0.7)
            ax.set_ylabel(traj.state_names[0])
            ax.set_title(scene.spec.description or scene.name, fontsize=9)
            ax = axes[row, 1]
            ax.plot(traj.y[steady, 0], traj.y[steady, nq], lw=0.5)
            if traj.period:
                pts = traj.poincare()
                pts = pts[len(pts) // 2:]
                ax.plot(pts[:, 0], pts[:, nq], ".", color="C3", ms=4)
            ax.set_xlabel(traj.state_names[0])
            ax.set_ylabel(traj.state_names[nq])
        axes[-1, 0].set_xlabel("t")
        fig.suptitle(f"{model}: steady time histories and phase portraits (Poincare points red)")
        fig.tight_layout()
        sheet = out / f"overview_{model}.png"
        fig.savefig(sheet, dpi=90)
        plt.close(fig)
        print(f"wrote {sheet}")
        if args.docs:
            dest = ROOT / "docs" / "gallery" / sheet.name
            shutil.copy(sheet, dest)
            print(f"  copied to {dest}")


if __name__ == "__main__":
    main()
