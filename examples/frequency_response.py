"""Frequency response of the benchmark backlash oscillator: continuation vs. brute-force sweeps.

The Kahraman & Singh gear pair (``scenes/kahraman_singh.toml``) is continued in the
mesh frequency Omega from 0.6 to 1.4 in ONE call of ``gearsym.continuation``: the
branch passes both turning points of the softening resonance, the stable parts are
drawn solid, the unstable part dashed, and the located folds and grazings are
marked.  Brute-force sweeps up and down (integrate to steady state at each Omega,
starting from the previous one's final state -- the way the response curve is
usually computed) are overlaid: they follow the stable parts and jump at the
located folds.

Writes ``OUT/frequency_response.png``, ``OUT/frequency_response.json`` (the branch,
as ``gearsym continue --json`` prints it) and the sweeps.

Run: ``python examples/frequency_response.py [--out out/frequency_response] [--step 0.01]``
(about 20 s; the continuation alone takes a few seconds).
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

ROOT = Path(__file__).resolve().parents[1]


def steady_state(system, params, x, block=50, max_periods=3000, tol=1e-9):
    """Integrate blocks of forcing periods until the Poincare point repeats; then
    return the final state and max / min of x over one more period."""
    n = 0
    while n < max_periods:
        tr = system.simulate(periods=block, x0=x, params=params, rtol=1e-9, atol=1e-11, n_out=block + 1)
        x = tr.x_final
        n += block
        if np.max(np.abs(tr.y[-1] - tr.y[-2])) < tol and np.max(np.abs(tr.y[-1] - tr.y[-block // 2])) < tol:
            break
    tr = system.simulate(periods=1, x0=x, params=params, rtol=1e-9, atol=1e-11, n_out=2049)
    return tr.x_final, float(tr.y[:, 0].max()), float(tr.y[:, 0].min())


def sweep(system, values, x):
    """Brute-force sweep: steady state at each value, continuing from the previous state."""
    out = []
    for w in values:
        x, hi, lo = steady_state(system, {"Omega": float(w)}, x)
        out.append((float(w), hi, lo))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/frequency_response", help="output folder")
    parser.add_argument("--step", type=float, default=0.01, help="Omega step of the brute-force sweeps")
    parser.add_argument("--gallery", help="also write a small copy of the figure here (e.g. docs/gallery)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()

    t0 = time.perf_counter()
    branch = gearsym.continuation(system, "Omega", 0.6, 1.4)
    t_cont = time.perf_counter() - t0
    print(f"continuation: {len(branch.points)} orbits in {t_cont:.2f} s ({branch.stop_reason})")
    for b in branch.bifurcations:
        extra = f" of {b.info['surface']}" if b.type == "grazing" else ""
        print(f"  {b.type}{extra} at Omega = {b.value:.6f}, |multipliers| = "
              + ", ".join(f"{abs(m):.4f}" for m in b.multipliers))
    branch.save_json(out / "frequency_response.json")

    t0 = time.perf_counter()
    grid = np.arange(0.6, 1.4 + 1e-9, args.step)
    up = sweep(system, grid, system.x0)
    down = sweep(system, grid[::-1], system.x0)
    t_sweep = time.perf_counter() - t0
    print(f"brute-force sweeps up and down ({2 * len(grid)} steady states): {t_sweep:.2f} s")
    np.savez(out / "sweeps.npz", up=up, down=down)

    fig, (ax, axm) = plt.subplots(2, 1, figsize=(7.2, 6.6), sharex=True, gridspec_kw={"height_ratios": [2.3, 1]})
    branch.plot(ax, quantity="ptp", label="continued branch (peak-to-peak)", legend=False)
    ax.plot(up[:, 0], up[:, 1] - up[:, 2], ">", ms=3.5, color="C1", mfc="none", label="sweep up")
    ax.plot(down[:, 0], down[:, 1] - down[:, 2], "<", ms=3.5, color="C2", mfc="none", label="sweep down")
    add_legend(ax, loc="upper right")
    ax.set_ylabel("peak-to-peak of x")
    ax.set_xlabel("")
    ax.set_title("Kahraman-Singh backlash oscillator: frequency response")
    branch.plot_multipliers(axm)
    axm.set_xlabel("Omega (mesh frequency / natural frequency)")
    fig.tight_layout()
    fig.savefig(out / "frequency_response.png", dpi=110)
    if args.gallery:
        Path(args.gallery).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(args.gallery) / "frequency_response.png", dpi=72)
    print(f"wrote {out / 'frequency_response.png'}, {out / 'frequency_response.json'}, {out / 'sweeps.npz'}")
    (out / "timing.json").write_text(json.dumps({"continuation_s": t_cont, "sweeps_s": t_sweep,
                                                 "n_points": len(branch.points), "n_sweep": 2 * len(grid)}))


if __name__ == "__main__":
    main()
