"""Regenerate the figure gallery: every shipped scene simulated with its own settings.

For each ``scenes/*.toml`` this runs the equivalent of
``gearsym simulate SCENE --out OUT/<scene>`` (time history, phase portrait, Poincare
section, amplitude spectrum, trajectory ``.npz``) and writes an overview sheet
``OUT/overview_<model>.png`` per model with one row per scene (time history of the
steady state and phase portrait with Poincare points).  ``--docs`` also copies the
overview sheets to ``docs/gallery/`` (the README's gallery).

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
