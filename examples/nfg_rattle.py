"""Noncircular face gear: rattle state and peak-to-peak value against pinion speed (Liu et al. Fig. 11).

The NFG pair of ``models/liu_nfg.toml`` (scene ``scenes/liu_nfg_160.toml``: backlash,
mesh stiffness, transmission error and instantaneous-center excitation) is
continued in the pinion speed omega1 from 100 to 250 rad/s.  The orbit is one
instantaneous-center cycle (Z2 = 64 mesh cycles), so a rattling orbit has dozens
of impacts per period and every impact that appears or disappears kinks the
branch; the continuation steps in the parameter itself where no turning point is
possible (all Floquet multipliers far from +1) and locates the two grazings that
change the rattle state (Liu's rsv): the drive flank starts separating
(no rattle -> unilateral rattle) and the back flank is first touched
(unilateral -> bilateral rattle, where the peak-to-peak value ppv shoots up).

Brute-force steady states (integrate from the previous speed's state, then
classify the last periods with ``gearsym.analysis.periodic.rattle_state``) are overlaid, as in
the paper's Fig. 11a (rsv) and 11b (ppv).

Writes ``OUT/nfg_rattle.png`` and ``OUT/nfg_rattle.json``.

Run: ``python examples/nfg_rattle.py [--out out/nfg_rattle] [--step 5]`` (about 1-2 minutes: a
rattling orbit spans 64 mesh cycles, so each shooting integration is long).
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
from gearsym.analysis.periodic import peak_to_peak, rattle_state  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "liu_nfg_160.toml"
RANGE = (100.0, 250.0)


def brute_force(system, speeds, x, transient=20, keep=2):
    """Steady response at each speed from the previous one's final state: rsv and ppv."""
    out = []
    for w in speeds:
        p = {"omega1": float(w)}
        x = system.simulate(periods=transient, x0=x, params=p, rtol=1e-9, atol=1e-15, n_out=2).x_final
        tr = system.simulate(periods=keep, x0=x, params=p, rtol=1e-9, atol=1e-15, n_out=keep * 8192 + 1)
        x = tr.x_final
        out.append((float(w), rattle_state(tr, system=system, steady_fraction=1.0),
                    peak_to_peak(tr, steady_fraction=1.0)))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/nfg_rattle", help="output folder")
    parser.add_argument("--step", type=float, default=5.0, help="speed step of the brute-force sweep [rad/s]")
    parser.add_argument("--gallery", help="also write a small copy of the figure here (e.g. docs/gallery)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    system = gearsym.load_scene(SCENE).compile()
    t0 = time.perf_counter()
    branch = gearsym.continuation(system, "omega1", *RANGE, rtol=1e-9, tol=1e-7)
    print(f"continuation: {len(branch.points)} orbits in {time.perf_counter() - t0:.0f} s ({branch.stop_reason})")
    for b in branch.bifurcations:
        extra = f" of {b.info['surface']} ({b.info['side']} of g)" if b.type == "grazing" else ""
        print(f"  {b.type}{extra} at omega1 = {b.value:.3f} rad/s, rattle state there: {b.point.rattle_state}")

    t0 = time.perf_counter()
    bf = brute_force(system, np.arange(RANGE[0], RANGE[1] + 1e-9, args.step), branch.points[0].x0)
    print(f"brute-force steady states ({len(bf)} speeds): {time.perf_counter() - t0:.0f} s")
    data = branch.to_dict()
    data["brute_force"] = {"omega1": bf[:, 0].tolist(), "rattle_state": bf[:, 1].astype(int).tolist(),
                           "peak_to_peak": bf[:, 2].tolist()}
    (out / "nfg_rattle.json").write_text(json.dumps(data, indent=1))

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.2, 6.2), sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    rs = np.array([np.nan if r is None else r for r in branch.rattle_states], float)
    a1.step(branch.values, rs, where="post", color="C0", lw=1.5, label="continued orbit")
    a1.plot(bf[:, 0], bf[:, 1], "o", ms=4, mfc="none", color="C1", label="brute force")
    a1.set_yticks([0, 1, 2], ["no rattle", "unilateral", "bilateral"])
    a1.set_ylim(-0.4, 2.4)
    a1.set_ylabel("rattle state (rsv)")
    a1.legend(fontsize=8, loc="upper left")
    a1.grid(alpha=0.3)
    a1.set_title("Noncircular face gear (Liu et al. 2021, Fig. 11 setup)")
    branch.plot(a2, quantity="ptp", xscale=1.0, label="continued orbit", legend=False)
    a2.plot(bf[:, 0], bf[:, 2], "o", ms=4, mfc="none", color="C1", label="brute force")
    for b in branch.of_type("grazing"):
        a1.axvline(b.value, color="k", lw=0.7, ls=":")
        a2.axvline(b.value, color="k", lw=0.7, ls=":")
    add_legend(a2, loc="upper left")
    a2.set_ylabel("peak-to-peak value of q [rad] (ppv)")
    a2.set_xlabel("pinion speed omega1 [rad/s]")
    fig.tight_layout()
    fig.savefig(out / "nfg_rattle.png", dpi=110)
    if args.gallery:
        Path(args.gallery).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(args.gallery) / "nfg_rattle.png", dpi=72)
    print(f"wrote {out / 'nfg_rattle.png'}, {out / 'nfg_rattle.json'}")


if __name__ == "__main__":
    main()
