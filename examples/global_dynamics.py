"""The global picture of the benchmark oscillator and a dimensional pair, through the Python API.

Four analyses beyond one orbit, each written by its own ``save`` / figure function and put
together on one sheet (``docs/gallery/global_dynamics.png`` with ``--docs``):

* the **basins of attraction** of the two coexisting period-1 orbits of the backlash oscillator
  at Omega = 0.87 (in contact, and impacting): which initial state at phase 0 leads to which
  (:func:`gearsym.basins`);
* a **brute-force bifurcation diagram** with the largest Lyapunov exponent: the period-doubling
  route to chaos in Omega at Fa = 0.4 (:func:`gearsym.bifurcation_diagram`);
* the **fold curve** of the frequency response in (Omega, Fa): the jump's two folds meet in a
  cusp, below which the response has no jump (:func:`gearsym.continue_bifurcation`);
* a **run-up** of the dimensional pair ``spur_pair_torsional`` through its mesh resonance: the
  Campbell diagram with the mesh orders and the natural frequency (:func:`gearsym.runup`).

Run: ``python examples/global_dynamics.py [--out out/global_dynamics] [--docs]`` (about a
minute on one core).
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import gearsym  # noqa: E402
from gearsym.analysis.continuation import plot_curves  # noqa: E402
from gearsym.analysis.sweeps import save_bifurcation_diagram  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def panels(out: Path) -> list[tuple[Path, str]]:
    """Run the four analyses; return their figures with a caption each."""
    ks = gearsym.load_scene("kahraman_singh").compile()
    figures = []

    t0 = time.perf_counter()
    basin = gearsym.basins(ks, ("x", -2, 4, 120), ("v", -2, 2, 80), params={"Omega": 0.87})
    basin.save(out / "basins")
    figures.append((out / "basins" / "basins.png", f"basins, Omega = 0.87 ({time.perf_counter() - t0:.0f} s)"))

    t0 = time.perf_counter()
    sweep = gearsym.bifurcation_diagram(ks, "Omega", 0.55, 0.85, 41, params={"Fa": 0.4}, directions=("forward",),
                                        lyapunov_periods=200, workers=1)
    save_bifurcation_diagram(sweep, out / "sweep")
    figures.append((out / "sweep" / "sweep.png", f"route to chaos, Fa = 0.4 ({time.perf_counter() - t0:.0f} s)"))

    t0 = time.perf_counter()
    curve = gearsym.continue_bifurcation(ks, "fold", "Omega", "Fa", 0.5, 1.3, bounds2=(0.0, 0.2),
                                         start_from=gearsym.CurveStart.guess({"Omega": 0.8356, "Fa": 0.05}, x0=(1.11, 0.193)))
    (out / "fold").mkdir(parents=True, exist_ok=True)
    plot_curves([curve], path=out / "fold" / "curve.png", title="kahraman_singh: fold curve")
    figures.append((out / "fold" / "curve.png", f"fold curve and cusp ({time.perf_counter() - t0:.0f} s)"))

    t0 = time.perf_counter()
    pair = gearsym.load_scene("spur_pair_torsional").compile()
    run = gearsym.runup(pair, parameter="omega", start=1e4, stop=3e4, duration=0.2, settle=20)
    (out / "runup").mkdir(parents=True, exist_ok=True)
    run.plot_campbell(out / "runup" / "campbell.png")
    figures.append((out / "runup" / "campbell.png", f"run-up, Campbell diagram ({time.perf_counter() - t0:.0f} s)"))
    return figures


def sheet(figures: list[tuple[Path, str]], path: Path) -> Path:
    """The four figures on one 2 x 2 sheet."""
    fig, axes = plt.subplots(2, 2, figsize=(14, 10.5))
    for ax, (png, caption) in zip(axes.flat, figures):
        ax.imshow(plt.imread(png))
        ax.set_axis_off()
        ax.set_title(caption, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/global_dynamics", help="output folder")
    parser.add_argument("--docs", action="store_true", help="copy the sheet to docs/gallery/")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = sheet(panels(out), out / "global_dynamics.png")
    print(f"wrote {path}")
    if args.docs:
        shutil.copy(path, ROOT / "docs" / "gallery" / path.name)
        print(f"copied to {ROOT / 'docs' / 'gallery' / path.name}")


if __name__ == "__main__":
    main()
