"""Vaishya & Singh (JSV 2001) Figs. 5, 6, 8 and 9: instability zones, their labels and the friction effect.

The undamped gear pair of ``scenes/vaishya_singh_fig6.toml`` (formulation B: friction on
the dynamic mesh load, so the friction enters the homogeneous equation; no transmission
error).  Undamped, the monodromy has determinant 1, so the pair is unstable exactly when
``|trace| > 2``; ``trace > 2`` (real positive multipliers) is a zone ``omega_m = omega_n/j``
(``j = 8``: "the 1/8 zone"), ``trace < -2`` (real negative multipliers) a zone
``omega_m = 2 omega_n/(2j + 1)`` ("the 2/17 zone" for ``2j + 1 = 17``).

It prints and writes (``OUT/vaishya_singh_zones.json``):

* the statements of Figs. 5, 6 and 8 at the model's inertias: trace, largest multiplier,
  zone, and ``omega_n/omega_m`` (mean natural frequency over mesh frequency);
* Fig. 9: the edges (rpm) of the instability zones at Gamma = 1.24 and 1.453 with and
  without friction, for the model's inertias and for equal inertias (the sign of the
  friction shift follows the sign of ``J_d = J_g R_p - J_p R_g``, eqs. 17 and 29);
* the windows of the equivalent mass (as ``omega_n/omega_m`` at Gamma = 1.433, 1500 rpm)
  in which all statements of Figs. 5, 6 and 8 hold, and where the 2/17 zone would reach
  Gamma = 1.24 at 1500 rpm;
* Fig. 8: the peak-to-peak DTE at Gamma = 1.374, 1484 rpm with and without friction, of the
  periodic orbit and of the scene's trajectory from its initial state.

Run: ``python examples/vaishya_singh_zones.py [--out out/vaishya_singh_zones] [--quick]``
(about a minute; ``--quick`` skips the window scans).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

import gearsym

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "vaishya_singh_fig6.toml"
STATEMENTS = [(1.24, 1500.0, "unstable", "Fig. 5 (paper: the 2/17 zone)"),
              (1.374, 1484.0, "stable", "Fig. 6(a)"),
              (1.453, 1484.0, "unstable", "Fig. 6(b)")]


def rpm(n: float) -> float:
    return n * 2 * math.pi / 60


class Pair:
    """The compiled undamped pair and the helpers of this script."""

    def __init__(self):
        self.scene = gearsym.load_scene(SCENE)
        self.system = self.scene.compile()
        v = self.scene.resolved.values
        self.v = v
        r = v["a_c"] / (v["Pi_p"] + v["Pi_g"]) * math.cos(v["phi"])
        self.R_p, self.R_g = r * v["Pi_p"], r * v["Pi_g"]
        self.J = (v["J_p"], v["J_g"])

    def k_mean(self, gamma: float) -> float:
        k_max = self.v["k_max"]
        return k_max * (gamma - 1) + k_max / self.v["k_ratio"] * (2 - gamma)

    def m_e(self, J: tuple[float, float]) -> float:
        return 1.0 / (self.R_p ** 2 / J[0] + self.R_g ** 2 / J[1])

    def ratio(self, gamma: float, n_rpm: float, J: tuple[float, float]) -> float:
        """Mean natural frequency over mesh frequency."""
        return math.sqrt(self.k_mean(gamma) / self.m_e(J)) / (rpm(n_rpm) * self.v["Pi_p"])

    def inertias(self, q: float, r: float) -> tuple[float, float]:
        """J_p, J_g with J_g/J_p = r and omega_n/omega_m = q at Gamma = 1.433, 1500 rpm."""
        m_e = self.k_mean(1.433) / (q * rpm(1500.0) * self.v["Pi_p"]) ** 2
        J_p = m_e * (self.R_p ** 2 + self.R_g ** 2 / r)
        return J_p, r * J_p

    def monodromy(self, gamma: float, n_rpm: float, mu: float, J: tuple[float, float]) -> np.ndarray:
        p = {"Gamma": gamma, "Omega_p": n_rpm, "mu0": mu, "zeta": 0.0, "J_p": J[0], "J_g": J[1]}
        T = self.system.period(p)
        return self.system.simulate(t_end=T, x0=[1e-6, 0.0], params=p, monodromy=True, rtol=1e-11,
                                    atol=1e-18, n_out=2).monodromy

    def trace(self, gamma: float, n_rpm: float, mu: float, J: tuple[float, float]) -> float:
        M = self.monodromy(gamma, n_rpm, mu, J)
        return float(M[0, 0] + M[1, 1])

    def edges(self, gamma: float, mu: float, J: tuple[float, float], lo: float, hi: float,
              step: float = 0.5) -> list[float]:
        """Speeds (rpm) in [lo, hi] where |trace| = 2 (zone edges), to 1e-3 rpm."""
        ns = np.arange(lo, hi + 1e-9, step)
        f = [abs(self.trace(gamma, n, mu, J)) - 2 for n in ns]
        out = []
        for a, b, fa, fb in zip(ns[:-1], ns[1:], f[:-1], f[1:]):
            if (fa > 0) != (fb > 0):
                out.append(brentq(lambda n: abs(self.trace(gamma, n, mu, J)) - 2, a, b, xtol=1e-3))
        return out


def zone_name(tr: float, ratio: float) -> str:
    if abs(tr) <= 2:
        return "stable"
    if tr > 2:
        return f"1/{round(ratio)} zone (real positive multipliers)"
    return f"2/{2 * math.floor(ratio) + 1} zone (real negative multipliers)"


def statements(pair: Pair, J: tuple[float, float]) -> list[dict]:
    out = []
    for gamma, n, verdict, fig in STATEMENTS:
        row = {"figure": fig, "Gamma": gamma, "rpm": n, "paper": verdict}
        for mu in (0.1, 0.0):
            tr = pair.trace(gamma, n, mu, J)
            lam = abs(tr) / 2 + math.sqrt(tr * tr / 4 - 1) if abs(tr) > 2 else 1.0   # det = 1
            row[f"mu{mu}"] = {"trace": tr, "max_multiplier": lam,
                              "zone": zone_name(tr, pair.ratio(gamma, n, J))}
        row["omega_n_over_omega_m"] = pair.ratio(gamma, n, J)
        out.append(row)
    return out


def fig8(pair: Pair, J: tuple[float, float]) -> dict:
    """Peak-to-peak DTE at Gamma = 1.374, 1484 rpm: periodic orbit and the scene's trajectory."""
    s = pair.system
    out = {}
    for mu in (0.1, 0.0):
        p = {"Gamma": 1.374, "Omega_p": 1484.0, "mu0": mu, "zeta": 0.0, "J_p": J[0], "J_g": J[1]}
        o = s.periodic_orbit(params=p, x0=list(s.x0))
        orb = s.simulate(periods=1, x0=o.x0, params=p, rtol=1e-12, atol=1e-18, n_out=4001)
        tr = s.simulate(periods=200, params=p, rtol=1e-11, atol=1e-18, n_out=200 * 200 + 1)
        out[f"mu{mu}"] = {"orbit_ppv_um": float(np.ptp(orb["x"]) * 1e6),
                          "trajectory_ppv_um": float(np.ptp(tr["x"]) * 1e6),
                          "multipliers_abs": [float(abs(m)) for m in o.multipliers]}
    return out


def windows(pair: Pair, r: float, lo: float = 7.8, hi: float = 9.2, step: float = 0.0025) -> dict:
    """omega_n/omega_m (Gamma = 1.433, 1500 rpm) where all statements hold (with friction,
    and Fig. 8 stable without), and where Gamma = 1.24 at 1500 rpm is in the 2/17 zone."""
    ok, in_217 = [], []
    for q in np.arange(lo, hi, step):
        J = pair.inertias(q, r)
        a = pair.trace(1.24, 1500.0, 0.1, J)
        b = pair.trace(1.374, 1484.0, 0.1, J)
        c = pair.trace(1.453, 1484.0, 0.1, J)
        d = pair.trace(1.374, 1484.0, 0.0, J)
        if abs(a) > 2 and abs(b) < 2 and abs(c) > 2 and abs(d) < 2:
            ok.append(round(float(q), 4))
        if a < -2 and round(pair.ratio(1.24, 1500.0, J) * 2) == 17:
            in_217.append((round(float(q), 4), round(c, 4)))
    return {"J_g/J_p": r, "all_statements_hold": _runs(ok, step), "gamma124_in_2_17_zone": in_217}


def _runs(values: list[float], step: float) -> list[list[float]]:
    runs: list[list[float]] = []
    for v in values:
        if runs and v - runs[-1][1] <= 1.5 * step:
            runs[-1][1] = v
        else:
            runs.append([v, v])
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/vaishya_singh_zones", help="output folder")
    parser.add_argument("--quick", action="store_true", help="skip the equivalent-mass window scans")
    args = parser.parse_args()
    pair = Pair()
    J = pair.J
    equal = (pair.m_e(J) * (pair.R_p ** 2 + pair.R_g ** 2),) * 2      # same m_e, J_p = J_g
    res: dict = {"inertias": {"J_p": J[0], "J_g": J[1], "m_e": pair.m_e(J),
                              "J_d": J[1] * pair.R_p - J[0] * pair.R_g}}
    res["statements"] = statements(pair, J)
    for row in res["statements"]:
        print(f"{row['figure']:30s} Gamma {row['Gamma']} at {row['rpm']:.0f} rpm (paper: {row['paper']}): "
              f"omega_n/omega_m = {row['omega_n_over_omega_m']:.3f}; with friction trace "
              f"{row['mu0.1']['trace']:+.4f} |lambda| {row['mu0.1']['max_multiplier']:.4f} {row['mu0.1']['zone']}; "
              f"without {row['mu0.0']['trace']:+.4f} {row['mu0.0']['zone']}")
    res["fig9"] = {}
    for label, JJ in (("model inertias", J), ("equal inertias", equal)):
        for gamma in (1.24, 1.453):
            e0 = pair.edges(gamma, 0.0, JJ, 1470.0, 1515.0)
            e1 = pair.edges(gamma, 0.1, JJ, 1470.0, 1515.0)
            res["fig9"][f"{label}/Gamma{gamma}"] = {"without_friction_rpm": e0, "with_friction_rpm": e1}
            print(f"Fig. 9, {label:15s} Gamma {gamma}: zone edges without friction "
                  + ", ".join(f"{e:.3f}" for e in e0) + " rpm; with friction "
                  + ", ".join(f"{e:.3f}" for e in e1) + " rpm; shift "
                  + ", ".join(f"{b - a:+.3f}" for a, b in zip(e0, e1)))
    res["fig8"] = fig8(pair, J)
    for mu, d in res["fig8"].items():
        print(f"Fig. 8 ({mu}): ppv of the periodic orbit {d['orbit_ppv_um']:.2f} um, of 200 periods from the "
              f"scene's initial state {d['trajectory_ppv_um']:.2f} um, |multipliers| {d['multipliers_abs']}")
    if not args.quick:
        res["windows"] = [windows(pair, J[1] / J[0]), windows(pair, 1.0)]
        for w in res["windows"]:
            print(f"J_g/J_p = {w['J_g/J_p']:.4f}: all statements hold for omega_n/omega_m (1.433, 1500 rpm) in "
                  f"{w['all_statements_hold']}; Gamma = 1.24 in the 2/17 zone at "
                  f"{[q for q, _ in w['gamma124_in_2_17_zone']]} where the Fig. 6(b) trace is "
                  f"{[c for _, c in w['gamma124_in_2_17_zone']]}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "vaishya_singh_zones.json").write_text(json.dumps(res, indent=1))
    print(f"wrote {out / 'vaishya_singh_zones.json'}")


if __name__ == "__main__":
    main()
