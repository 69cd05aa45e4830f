"""Period-doubling route to chaos: continued branches over a brute-force bifurcation diagram.

The benchmark backlash oscillator with a strong transmission-error excitation
(``scenes/kahraman_singh.toml`` with Fa = 0.4) is continued in Omega from 0.55 to
0.72.  At every located period doubling the continuation switches onto the
doubled orbit (``switch=3``: period 1 -> 2 -> 4 -> 8) and continues it.  The
Poincare points of the continued orbits (one per forcing period; stable solid,
unstable dashed) are drawn over the brute-force bifurcation diagram (Poincare
points after a transient, sweeping Omega up): the cascade converges with the
Feigenbaum ratio towards the onset of chaos.

Writes ``OUT/period_doubling.png`` and ``OUT/period_doubling.json`` (all branches).

Run: ``python examples/period_doubling.py [--out out/period_doubling] [--n 300]``
(about 30 s).
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

import gearsym  # noqa: E402
from gearsym.analysis.continuation import add_legend  # noqa: E402
from gearsym.analysis.sweeps import bifurcation_diagram  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FA = 0.4
RANGE = (0.55, 0.72)


def brute_force_diagram(system, n, transient=200, keep=48):
    """Poincare points of x after a transient, sweeping up from the previous state
    (:func:`gearsym.analysis.sweeps.bifurcation_diagram`, forward only, no Lyapunov exponent)."""
    ds = bifurcation_diagram(system, "Omega", *RANGE, n, params={"Fa": FA}, directions=("forward",),
                             transient=transient, samples=keep, lyapunov=False, rtol=1e-9, atol=1e-11, workers=1)
    pts = ds["poincare"].sel(direction="forward", state="x").values  # (n, keep)
    return np.repeat(ds["Omega"].values, keep), pts.ravel()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/period_doubling", help="output folder")
    parser.add_argument("--n", type=int, default=300, help="parameter values of the brute-force diagram")
    parser.add_argument("--gallery", help="also write a small copy of the figure here (e.g. docs/gallery)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()

    t0 = time.perf_counter()
    branch = gearsym.continuation(system, "Omega", *RANGE, params={"Fa": FA}, switch=3, ds_max=0.02)
    print(f"continuation with branch switching: {time.perf_counter() - t0:.1f} s")
    pds = []
    for br in branch.all_branches():
        print(f"  period-{br.periods:g} branch: {len(br.points)} orbits, {br.stop_reason}")
        for b in br.of_type("period_doubling"):
            print(f"    period doubling at Omega = {b.value:.6f} (multiplier {b.info['multiplier'].real:+.6f})")
            pds.append(b.value)
    pds = sorted(pds)
    if len(pds) >= 3:
        ratios = [(pds[i + 1] - pds[i]) / (pds[i + 2] - pds[i + 1]) for i in range(len(pds) - 2)]
        print("  ratios of successive period-doubling intervals:", ", ".join(f"{r:.3f}" for r in ratios),
              "(Feigenbaum: 4.669)")
    (out / "period_doubling.json").write_text(json.dumps(branch.to_dict(), indent=1))

    t0 = time.perf_counter()
    om, pts = brute_force_diagram(system, args.n)
    print(f"brute-force bifurcation diagram ({args.n} values): {time.perf_counter() - t0:.1f} s")

    fig, (ax, axm) = plt.subplots(2, 1, figsize=(7.2, 6.6), sharex=True, gridspec_kw={"height_ratios": [2.3, 1]})
    ax.plot(om, pts, ",", color="0.55", alpha=0.7, rasterized=True)
    ax.plot([], [], ".", color="0.55", label="brute force (Poincare points)")
    for k, br in enumerate(branch.all_branches()):
        vals, P = br.poincare()
        st = br.stable
        col = f"C{k}"
        for j in range(P.shape[1]):
            _segments(ax, vals, P[:, j], st, col, f"period-{br.periods:g} orbit" if j == 0 else None)
        for b in br.of_type("period_doubling"):
            ax.plot([b.value], [b.point.x0[0]], "s", color="C3", mfc="none", ms=6, mew=1.4,
                    label="period doubling" if (k == 0) else None)
        br.plot_multipliers(axm, color=col)
    ax.set_ylabel("x at t = kT (Poincare section)")
    ax.set_title(f"Kahraman-Singh oscillator, Fa = {FA}: period-doubling cascade")
    add_legend(ax, loc="lower left")
    axm.set_xlabel("Omega")
    axm.set_ylim(1e-2, 10)
    fig.tight_layout()
    fig.savefig(out / "period_doubling.png", dpi=110)
    if args.gallery:
        Path(args.gallery).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(args.gallery) / "period_doubling.png", dpi=72)
    print(f"wrote {out / 'period_doubling.png'}, {out / 'period_doubling.json'}")


def _segments(ax, x, y, stable, color, label):
    start = 0
    first = True
    for i in range(1, len(x) + 1):
        if i == len(x) or stable[i] != stable[start]:
            j = min(i + 1, len(x))
            ax.plot(x[start:j], y[start:j], "-" if stable[start] else "--", color=color, lw=1.4 if stable[start]
                    else 0.9, label=label if first else None)
            first = False
            start = i


if __name__ == "__main__":
    main()
