"""Dynamic factor against mesh frequency: Yu et al. 6-DOF gear pair with dynamic backlash (Fig. 13 setup).

The transverse-torsional spur pair of ``models/yu_6dof.toml`` with the Table 1
parameters (the Kahraman-Singh DF rig: 25/25 teeth, I = 1.15e-3 kg m^2,
R = 94 mm, k_m = 3e8 N/m, T = 107.8 N m, xi = 0.1, T_ah = 0.019) and, as in
Yu's Fig. 13, without surface topography (``fractal_backlash`` off) but with the
dynamic, state-dependent backlash (``dynamic_backlash`` on, bearing flexibility
and time-varying pressure angle on).  The periodic orbit is continued in the
dimensionless mesh frequency omega* = Omega from 0.2 to 1.2 (10 states, one call);
along the branch the dynamic factor

    DF = max_t F_m(t) / F_s,   F_m = k_m(t) f(delta; B(x)) + c_m delta',   F_s = T_p / R_pb

(Yu eq. 20) is evaluated on each orbit; brute-force sweeps up and down are
overlaid.  The continuation locates the folds of the jump, the grazings where
contact loss starts, a Neimark-Sacker pair (quasi-periodic response between them,
where the sweeps scatter) and a period doubling.

The mesh force is written here from the model's [derived] section (k_mt, c_m, B,
f_d, F_m of models/yu_6dof.toml) -- keep them in step if the model changes.

Writes ``OUT/yu_dynamic_factor.png`` and ``OUT/yu_dynamic_factor.json``.

Run: ``python examples/yu_dynamic_factor.py [--out out/yu_dynamic_factor] [--step 0.025] [--no-sweeps]``
(about a minute: the continuation ~20-40 s, the sweeps ~10 s, plus the first compile).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gearsym  # noqa: E402
from gearsym.analysis.continuation import add_legend  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "yu_dynamic_D14.toml"
EFFECTS = {"fractal_backlash": False, "fractal_mesh_stiffness": False, "dynamic_backlash": True}
RANGE = (0.2, 1.2)


class MeshForce:
    """``F_m(t, x)`` and ``F_s`` of models/yu_6dof.toml (fractal effects off, dynamic backlash on)."""

    def __init__(self, system):
        p = system.units.to_si(system.params)  # SI: the mesh force below is written in SI
        self.p = p
        self.R_pb = p["R_p"] * math.cos(p["alpha0"])
        self.R_gb = p["R_g"] * math.cos(p["alpha0"])
        self.a_0 = p["R_p"] + p["R_g"]
        self.a_b = self.R_pb + self.R_gb
        self.m_e = 1.0 / (self.R_pb ** 2 / p["I_p"] + self.R_gb ** 2 / p["I_g"])
        self.omega_n = math.sqrt(p["k_m"] / self.m_e)
        self.c_m = 2 * p["xi"] * math.sqrt(p["k_m"] * self.m_e)
        self.F_s = p["T_p"] / self.R_pb
        self.idx = {n: i for i, n in enumerate(system.state_names)}

    def __call__(self, t: np.ndarray, Y: np.ndarray, Omega: float) -> np.ndarray:
        p, i = self.p, self.idx
        x, v = Y[:, i["x"]], Y[:, i["v"]]
        u = Y[:, i["xp"]] - Y[:, i["xg"]]
        w = Y[:, i["yp"]] - Y[:, i["yg"]]
        a_c = np.sqrt((self.a_0 - u) ** 2 + w ** 2)
        kappa = self.R_pb * (a_c + self.a_0) / (2 * self.a_b ** 2)
        B = p["b_0"] + (a_c - self.a_0) * np.sqrt(np.maximum(0.0, 1 - kappa ** 2))
        f = np.where(x > B, x - B, np.where(x < -B, x + B, 0.0))
        k_mt = p["k_m"] * (1 + p["eps"] * np.sin(Omega * self.omega_n * t + p["phi0"]))
        return k_mt * f + self.c_m * v


def dynamic_factor(system, force, Omega, x0, periods=1, n=2048):
    T = system.period({"Omega": Omega})
    t = np.linspace(0.0, periods * T, periods * n + 1)
    tr = system.simulate(t_end=t[-1], x0=x0, params={"Omega": Omega}, t_out=t, rtol=1e-9, atol=1e-16)
    return float(np.max(force(t, tr.y, Omega)) / force.F_s), tr.x_final


def sweep(system, force, values, x):
    out = []
    for w in values:
        x = system.simulate(periods=150, x0=x, params={"Omega": float(w)}, rtol=1e-8, atol=1e-16,
                            n_out=2).x_final
        df, x = dynamic_factor(system, force, float(w), x, periods=20, n=256)
        out.append((float(w), df))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/yu_dynamic_factor", help="output folder")
    parser.add_argument("--step", type=float, default=0.025, help="Omega step of the brute-force sweeps")
    parser.add_argument("--no-sweeps", action="store_true", help="skip the brute-force sweeps")
    parser.add_argument("--gallery", help="also write a small copy of the figure here (e.g. docs/gallery)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    scene = gearsym.load_scene(SCENE, effects=EFFECTS)
    system = scene.compile()
    force = MeshForce(system)
    print(f"{scene.name} ({', '.join(system.state_names)}): F_s = {force.F_s:.1f} N, "
          f"omega_n = {force.omega_n:.0f} rad/s")

    t0 = time.perf_counter()
    branch = gearsym.continuation(system, "Omega", *RANGE, ds_max=0.02)
    print(f"continuation: {len(branch.points)} orbits in {time.perf_counter() - t0:.0f} s ({branch.stop_reason})")
    for b in branch.bifurcations:
        mu = b.multipliers[np.argsort(-np.abs(b.multipliers))][:2]
        extra = f" of {b.info['surface']}" if b.type == "grazing" else ""
        print(f"  {b.type}{extra} at omega* = {b.value:.5f}, leading multipliers "
              + ", ".join(f"{m.real:+.4f}{m.imag:+.4f}j" for m in mu))
    df = np.array([dynamic_factor(system, force, p.value, p.x0)[0] for p in branch.points])
    data = branch.to_dict()
    for q, d in zip(data["points"], df):
        q["dynamic_factor"] = d
    for b in data["bifurcations"]:
        b["dynamic_factor"] = float(df[b["index"]])

    sweeps = {}
    if not args.no_sweeps:
        t0 = time.perf_counter()
        grid = np.arange(RANGE[0], RANGE[1] + 1e-9, args.step)
        sweeps["up"] = sweep(system, force, grid, branch.points[0].x0)
        sweeps["down"] = sweep(system, force, grid[::-1], branch.points[-1].x0)
        print(f"brute-force sweeps: {time.perf_counter() - t0:.0f} s")
        data["sweeps"] = {k: v.tolist() for k, v in sweeps.items()}
    (out / "yu_dynamic_factor.json").write_text(json.dumps(data, indent=1))

    fig, (ax, axm) = plt.subplots(2, 1, figsize=(7.2, 6.6), sharex=True, gridspec_kw={"height_ratios": [2.3, 1]})
    st = branch.stable
    vals = branch.values
    start, first = 0, True
    for i in range(1, len(vals) + 1):
        if i == len(vals) or st[i] != st[start]:
            j = min(i + 1, len(vals))
            ax.plot(vals[start:j], df[start:j], "-" if st[start] else "--", color="C0", lw=1.6 if st[start] else 1.1,
                    label="periodic orbit (continued)" if first else None)
            first = False
            start = i
    markers = {"fold": ("o", "C3"), "grazing": ("^", "k"), "neimark_sacker": ("D", "C4"),
               "period_doubling": ("s", "C2")}
    seen = set()
    for b in branch.bifurcations:
        mk, c = markers.get(b.type, ("x", "k"))
        ax.plot([b.value], [df[b.index]], mk, color=c, mfc="none", ms=7, mew=1.5,
                label=None if b.type in seen else b.type.replace("_", "-"))
        seen.add(b.type)
    if sweeps:
        ax.plot(sweeps["up"][:, 0], sweeps["up"][:, 1], ">", ms=3.5, color="C1", mfc="none", label="sweep up")
        ax.plot(sweeps["down"][:, 0], sweeps["down"][:, 1], "<", ms=3.5, color="C2", mfc="none", label="sweep down")
    ax.set_ylabel("dynamic factor DF = max F_m / F_s")
    ax.set_title("Yu et al. 6-DOF pair, dynamic backlash, Table 1 (Fig. 13 setup)")
    add_legend(ax, loc="upper left", fontsize=7.5)
    ax.grid(alpha=0.3)
    branch.plot_multipliers(axm)
    axm.set_xlabel("omega* = mesh frequency / omega_n")
    fig.tight_layout()
    fig.savefig(out / "yu_dynamic_factor.png", dpi=110)
    if args.gallery:
        Path(args.gallery).mkdir(parents=True, exist_ok=True)
        fig.savefig(Path(args.gallery) / "yu_dynamic_factor.png", dpi=72)
    print(f"wrote {out / 'yu_dynamic_factor.png'}, {out / 'yu_dynamic_factor.json'}")


if __name__ == "__main__":
    main()
