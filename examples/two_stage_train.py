"""Two-stage spur gear train: frequency response of both mesh deflections against input speed.

``models/two_stage_train.toml`` is the train as a gear researcher writes it: four
wheels in absolute (vibratory) rotations, two meshes with their own backlash,
rectangular stiffness (mesh frequencies in ratio 8:5) and transmission error, a shaft
spring and damper in between, drive torque on the motor, load torque on the output.
Nothing ties it to the ground, so it keeps a rigid-body mode; gearsym finds it
symbolically, and the Floquet analysis reports its two multipliers at +1 apart from the
six that decide stability.  ``models/two_stage_train_deflections.toml`` is the same
train reduced to its three deflections (``[reduction] mode = "deflections"``).

The script

1. solves the periodic orbit of both models at 3500 rpm and compares their non-trivial
   multipliers (they agree to about 1e-12);
2. continues the orbit of the reduced train in the input speed ``n_in`` (declared in
   rpm) from 2000 to 6500 rpm: both mesh deflections (max and min over the orbit),
   stable parts solid, unstable dashed, the rattle state of each mesh as the colour of
   the points, located folds / Neimark-Sacker points / grazings;
3. overlays brute-force steady states of the *free* train (integration from the
   previous speed's state, extrema of the last periods), an independent check.  Between
   the two Neimark-Sacker points (about 3730 and 4790 rpm) the periodic orbit is
   unstable and the brute-force steady state is quasi-periodic: its extrema scatter.

Writes ``OUT/two_stage_train.png`` and ``OUT/two_stage_train.json`` (``--gallery DIR``:
a small copy of the figure).

Run: ``python examples/two_stage_train.py [--out out/two_stage_train] [--gallery docs/gallery]``
(about 6 minutes on a loaded 2-core machine: the continuation follows the softening folds
between 3725 and 4137 rpm with small steps, about 1200 orbits).
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
from gearsym.analysis.periodic import mesh_deflections  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FREE = ROOT / "scenes" / "two_stage_train.toml"
REDUCED = ROOT / "scenes" / "two_stage_train_deflections.toml"
RANGE = (2000.0, 6500.0)  # rpm


def free_state(free: gearsym.System, x: np.ndarray) -> np.ndarray:
    """A state of the free train with the deflections ``x`` of the reduced one at t = 0 (th4 = 0)."""
    p = free.units.to_si(free.params)  # SI: the kinematics below are written in SI
    rb = [p["m_n"] * p[z] * np.cos(p["alpha"]) / 2 for z in ("z1", "z2", "z3", "z4")]
    x1, xs, x2, v1, vs, v2 = x
    w2 = p["z3"] * p["n_in"] * p["z1"] / p["z2"]
    th3 = (x2 + p["e2"] * np.cos(p["phi2"])) / rb[2]
    th2 = th3 + xs
    th1 = (x1 + p["e1"] + rb[1] * th2) / rb[0]
    w3 = (v2 - p["e2"] * w2 * np.sin(p["phi2"])) / rb[2]
    dw2 = w3 + vs
    w1 = (v1 + rb[1] * dw2) / rb[0]
    return np.array([th1, th2, th3, 0.0, w1, dw2, w3, 0.0])


def brute_force(free, speeds_rpm, x, periods=60, keep=4):
    """Steady mesh-deflection extrema of the free train, sweeping up from the previous state."""
    out = []
    for n in speeds_rpm:
        p = {"n_in": n}  # rpm, the declared unit
        x = free.simulate(periods=periods, x0=x, params=p, rtol=1e-9, atol=1e-14, n_out=2).x_final
        tr = free.simulate(periods=keep, x0=x, params=p, rtol=1e-9, atol=1e-14, n_out=keep * 2048 + 1)
        x = tr.x_final
        d = mesh_deflections(free, tr.t, tr.y, p)
        out.append([n] + [f(d[m]) for m in ("mesh1", "mesh2") for f in (np.min, np.max)])
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/two_stage_train", help="output folder")
    parser.add_argument("--gallery", help="also write a small copy of the figure here (e.g. docs/gallery)")
    parser.add_argument("--step", type=float, default=250.0, help="speed step of the brute-force sweep [rpm]")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = gearsym.load_scene(REDUCED)
    reduced = scene.compile()
    free = gearsym.load_scene(FREE).compile()

    # 1. the same orbit in both models
    o_red = reduced.periodic_orbit()
    o_free = free.periodic_orbit(x0=free_state(free, o_red.x0))
    diff = float(np.max(np.abs(np.sort_complex(o_free.multipliers) - np.sort_complex(o_red.multipliers))))
    print(f"3500 rpm: reduced train {o_red.stability}, max|mu| = {o_red.max_multiplier:.6f}; free train "
          f"{o_free.stability}, trivial multipliers "
          + ", ".join(f"{m.real:.7f}{m.imag:+.1e}j" for m in o_free.trivial_multipliers)
          + f"; non-trivial multipliers agree to {diff:.1e}")
    print("  rattle state per mesh: " + ", ".join(f"{k}: {v}" for k, v in o_free.rattle_states.items()))

    # 2. the frequency response
    t0 = time.perf_counter()
    # tol 1e-8 at rtol 1e-10: the middle branch between the folds has a multiplier of ~120, which
    # amplifies the integration noise of the residual (rtol 1e-9 / tol 1e-9 crawls there, a looser
    # tol lets the steps jump across the folds; so do natural-parameter steps longer than ~25 rpm)
    branch = gearsym.continuation(reduced, "n_in", RANGE[0], RANGE[1], x0=o_red.x0, rtol=1e-10,
                                  tol=1e-8, ds_max=0.005)
    print(f"continuation: {len(branch.points)} orbits in {time.perf_counter() - t0:.0f} s ({branch.stop_reason})")
    for b in branch.bifurcations:
        extra = f" of {b.info['surface']}" if b.type == "grazing" else ""
        print(f"  {b.type}{extra} at n_in = {b.value:.1f} rpm")

    # 3. brute force on the free train
    t0 = time.perf_counter()
    speeds = np.arange(RANGE[0], RANGE[1] + 1e-9, args.step)
    bf = brute_force(free, speeds, o_free.x0)
    print(f"brute-force steady states of the free train ({len(bf)} speeds): {time.perf_counter() - t0:.0f} s")

    data = branch.to_dict()
    data["unit"] = "rpm"
    data["orbit_3500rpm"] = {"reduced": o_red.to_dict(extrema=False), "free": o_free.to_dict(extrema=False),
                             "max_multiplier_difference": diff}
    data["brute_force"] = {"n_in_rpm": bf[:, 0].tolist(), "mesh1_min": bf[:, 1].tolist(),
                           "mesh1_max": bf[:, 2].tolist(), "mesh2_min": bf[:, 3].tolist(),
                           "mesh2_max": bf[:, 4].tolist()}
    (out / "two_stage_train.json").write_text(json.dumps(data, indent=1, default=str))

    fig, axes = plt.subplots(3, 1, figsize=(7.4, 8.4), sharex=True, gridspec_kw={"height_ratios": [2, 2, 1.3]})
    branch.plot_meshes(axes[:2], yscale=1e6, yunit="um", xlabel="")
    for k in range(2):
        axes[k].plot(bf[:, 0], bf[:, 1 + 2 * k] * 1e6, "k+", ms=5, label="brute force (free train)")
        axes[k].plot(bf[:, 0], bf[:, 2 + 2 * k] * 1e6, "k+", ms=5)
        b = reduced.params[f"bh{k + 1}"]  # um, the declared unit
        axes[k].axhline(b, color="0.6", lw=0.8, ls="--")
        axes[k].legend(fontsize=7, loc="upper left", ncol=2)
    axes[0].set_title("Two-stage spur gear train: dynamic transmission errors (max / min over the orbit)")
    branch.plot_multipliers(axes[2])
    axes[2].set_xlabel("input speed n_in [rpm]")
    fig.tight_layout()
    fig.savefig(out / "two_stage_train.png", dpi=110)
    if args.gallery:
        Path(args.gallery).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(args.gallery) / "two_stage_train.png", dpi=72)
    print(f"wrote {out / 'two_stage_train.png'}, {out / 'two_stage_train.json'}")


if __name__ == "__main__":
    main()
