"""An independent integration of Yu et al.'s gear pair (eqs. 12-16) for the readings of eq. 19.

Written from the paper's unreduced equations with the readings of ``models/yu_6dof.toml``
(base radii, eq. 8 with the pinion's +x towards the gear, the signed and smooth eq. 10,
``c_m delta'``, the force along the line of action as printed in eq. 12), in the six
coordinates of Fig. 7 (two rotations, four centre translations), with numpy and
:func:`scipy.integrate.solve_ivp` -- no gearsym.  The constant backlash ``b_s = b_0 - 2 b_i``
(eqs. 4-5) is summed and integrated by brute force on a grid (:func:`mean_height`).

:func:`run` returns the measures of ``examples/yu_readings.py`` (mean, extrema and
peak-to-peak of the DTE, impacts per period, Poincare points, mean dynamic backlash) over the
last ``keep`` of ``periods`` forcing periods, sampled the same way (``ppp`` samples per
period), so that its numbers can be compared with gearsym's one to one
(tests/test_yu_reference.py; ``python tests/yu_reference.py --compare out/yu_readings/yu_readings.json``
re-runs every row of the readings table and prints the differences, exit 1 above 1 %).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

I_P = I_G = 1.15e-3        # Table 1
R = 0.094
K_M = 3.0e8
XI = 0.1
B_N = 1e-3
ALPHA0 = math.radians(20.0)
M_C = 0.26                 # chosen centre masses, bearings (models/yu_6dof.toml)
K_B = 1.0e8
C_B = 510.0
EPS = 0.2
B_0 = 20e-6
LAM, L_C, L_A = 1.5, 150e-6, 100e-6
#: contact transitions are counted on a grid this many times finer than the measures' samples
DENSE = 16
#: absolute tolerances: rotations (rad), centres (m), angular velocities (rad/s), centre velocities (m/s)
ATOL = np.array([1e-12] * 2 + [1e-14] * 4 + [1e-9] * 2 + [1e-10] * 4)


@dataclass
class Reading:
    """Parameters of one reading (``T_ah`` as a function of omega*: the error-force reading)."""

    name: str
    T: float = 107.8
    T_ah: float = 0.019
    ah_over_w2: bool = False
    x0: list[float] = field(default_factory=lambda: [24.0e-6, -4.2e-6, -11.5e-6, 4.2e-6, 11.5e-6])

    def t_ah(self, omega: float) -> float:
        return self.T_ah / omega ** 2 if self.ah_over_w2 else self.T_ah


READINGS = {
    "shipped": Reading("shipped"),
    "tstar_literal": Reading("tstar_literal", T=9.5221, x0=[20.4e-6, -0.37e-6, -1.0e-6, 0.37e-6, 1.0e-6]),
    "error_force": Reading("error_force", ah_over_w2=True),
    "light_load": Reading("light_load", T=10.78, x0=[20.4e-6, -0.42e-6, -1.15e-6, 0.42e-6, 1.15e-6]),
}


def mean_height(D: float, G: float, terms: int = 28, per_wave: int = 16) -> float:
    """``b_i`` of eq. 4: the mean of ``|z(l)|`` over ``[0, L]`` of the W-M profile (eq. 2),
    ``lambda^k_min = 1/l_a``, the first ``terms`` levels, by the trapezoid rule on a grid of
    ``per_wave`` points per shortest wavelength."""
    k_min = -math.log(L_A) / math.log(LAM)
    ks = k_min + np.arange(terms)
    amp = G ** (D - 1) * LAM ** ((D - 2) * ks)
    freq = LAM ** ks
    n = int(per_wave * L_C * freq[-1]) + 1
    z = np.zeros(n)
    grid = np.linspace(0.0, L_C, n)
    for a, f in zip(amp, freq, strict=True):
        z += a * np.cos(2 * np.pi * f * grid)
    return float(np.trapezoid(np.abs(z), grid) / L_C)


class Pair:
    """The right-hand side of eqs. 12-16 for one reading, D, G and omega*."""

    def __init__(self, reading: Reading, D: float, omega: float, G: float = 1e-11, dynamic: bool = True,
                 b_s: float | None = None):
        self.rb = R * math.cos(ALPHA0)
        self.a0, self.ab = 2 * R, 2 * self.rb
        self.m_e = 1 / (self.rb ** 2 / I_P + self.rb ** 2 / I_G)
        self.w_n = math.sqrt(K_M / self.m_e)
        self.w_h = omega * self.w_n
        self.c_m = 2 * XI * math.sqrt(K_M * self.m_e)
        self.e_r = reading.t_ah(omega) * B_N
        self.T = reading.T
        self.b_s = B_0 - 2 * mean_height(D, G) if b_s is None else b_s
        self.dynamic = dynamic

    def geometry(self, y: np.ndarray) -> tuple[float, ...]:
        th_p, th_g, xp, yp, xg, yg = y[:6]
        u, w = xp - xg, yp - yg
        a = math.hypot(self.a0 - u, w)
        ca = self.ab / a
        sa = math.sqrt(1 - ca * ca)
        return u, w, a, sa, ca

    def dte(self, t: float, y: np.ndarray) -> tuple[float, float, float, float, float]:
        """delta, delta', B, sin(alpha), cos(alpha) at (t, y)."""
        u, w, a, sa, ca = self.geometry(y)
        wp, wg, vxp, vyp, vxg, vyg = y[6:]
        ud, wd = vxp - vxg, vyp - vyg
        ph = self.w_h * t
        e, ed = self.e_r * math.cos(ph), -self.e_r * self.w_h * math.sin(ph)
        delta = self.rb * (y[0] - y[1]) + u * sa + w * ca - e
        ad = (-(self.a0 - u) * ud + w * wd) / a
        al_d = self.ab / (a * math.sqrt(a * a - self.ab ** 2)) * ad          # eq. 16: alpha = acos(a_b/a)
        delta_d = self.rb * (wp - wg) + ud * sa + wd * ca + (u * ca - w * sa) * al_d - ed
        B = self.b_s
        if self.dynamic:                                                    # eq. 10 (signed, smooth)
            kappa = self.rb * (a + self.a0) / (2 * self.ab ** 2)
            B += (a - self.a0) * math.sqrt(max(0.0, 1 - kappa * kappa))
        return delta, delta_d, B, sa, ca

    def rhs(self, t: float, y: np.ndarray) -> list[float]:
        delta, delta_d, B, sa, ca = self.dte(t, y)
        f = delta - B if delta > B else (delta + B if delta < -B else 0.0)   # eq. 14
        Fm = K_M * (1 + EPS * math.sin(self.w_h * t)) * f + self.c_m * delta_d   # eqs. 13, 17
        xp, yp, xg, yg = y[2:6]
        vxp, vyp, vxg, vyg = y[8:]
        return [y[6], y[7], vxp, vyp, vxg, vyg,
                (self.T - self.rb * Fm) / I_P, (-self.T + self.rb * Fm) / I_G,       # eq. 12
                (-C_B * vxp - K_B * xp - Fm * sa) / M_C, (-C_B * vyp - K_B * yp - Fm * ca) / M_C,
                (-C_B * vxg - K_B * xg + Fm * sa) / M_C, (-C_B * vyg - K_B * yg + Fm * ca) / M_C]

    def initial(self, x0: list[float]) -> np.ndarray:
        """The state with DTE x0[0] and the centres at x0[1:] (rotations: gear at 0), at rest."""
        y = np.zeros(12)
        y[2:6] = x0[1:]
        u, w, _a, sa, ca = self.geometry(y)
        y[0] = (x0[0] - u * sa - w * ca + self.e_r) / self.rb
        return y


def run(reading: str, D: float, omega: float, G: float = 1e-11, dynamic: bool = True, periods: int = 400,
        keep: int = 150, ppp: int = 64, rtol: float = 1e-10, b_s: float | None = None) -> dict[str, float]:
    """Measures of the DTE over the last ``keep`` of ``periods`` forcing periods."""
    rd = READINGS[reading]
    pair = Pair(rd, D, omega, G, dynamic, b_s)
    T = 2 * math.pi / pair.w_h
    y0 = pair.initial(rd.x0)
    n = keep * ppp * DENSE
    t_eval = T * (periods - keep + np.arange(n + 1) / (ppp * DENSE))
    sol = solve_ivp(pair.rhs, (0.0, periods * T), y0, method="DOP853", rtol=rtol, atol=ATOL, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(sol.message)
    vals = np.array([pair.dte(t, y) for t, y in zip(sol.t, sol.y.T, strict=True)])
    # contact transitions: crossings of the drive and back surfaces x - B = 0 and x + B = 0 (gearsym's
    # events; the same as changes of contact side while B > 0, and still defined where the dynamic
    # backlash closes, B < 0), on the dense grid (short contacts fall between the ppp samples); every
    # other measure on the ppp samples, as examples/yu_readings.py samples gearsym's trajectory
    x, B = vals[:, 0], vals[:, 2]
    changes = sum(int(np.count_nonzero(np.diff(np.sign(g)))) for g in (x - B, x + B))
    vals = vals[::DENSE]
    x, v, B = vals[:, 0], vals[:, 1], vals[:, 2]
    pc = np.column_stack([x[::ppp], v[::ppp]])
    scale = np.array([max(np.ptp(x), 1e-12), max(np.ptp(v), 1e-9)])
    return {"mean_um": float(x.mean() * 1e6), "max_um": float(x.max() * 1e6), "min_um": float(x.min() * 1e6),
            "ppv_um": float(np.ptp(x) * 1e6), "impacts_per_period": changes / keep,
            "poincare_points": int(len(np.unique(np.round(pc / (1e-3 * scale)), axis=0))),
            "mean_B_um": float(B.mean() * 1e6), "min_B_um": float(B.min() * 1e6), "b_s_um": pair.b_s * 1e6}


#: measures compared with gearsym's (relative difference of the DTE's mean and peak-to-peak, and of the
#: dynamic backlash; contact transitions per period within 1 %)
COMPARED = ("mean_um", "ppv_um", "mean_B_um")


def compare(path: str, names: list[str] | None = None, rtol: float = 1e-9) -> float:
    """Re-run every row of ``examples/yu_readings.py``'s JSON (``OUT/yu_readings.json``) and print the
    relative differences; return the largest (scaled by the row's peak-to-peak for the mean)."""
    data = json.loads(Path(path).read_text())["candidates"]
    worst = 0.0
    for name in names or [n for n in data if n in READINGS]:
        for key, m in data[name]["rows"].items():
            backlash, w, D, *g = key.split("/")
            G = float(g[0][1:]) if g else 1e-11
            ref = run(name, float(D[1:]), float(w[1:]), G, dynamic=backlash == "dynamic", rtol=rtol)
            diffs = {k: abs(ref[k] - m[k]) / max(abs(m[k]), abs(m["ppv_um"]), 1e-9) for k in COMPARED}
            # a sampled count can only miss a contact shorter than its grid: within 1 %
            same_impacts = abs(ref["impacts_per_period"] - m["impacts_per_period"]) <= 0.01 * m["impacts_per_period"]
            worst = max(worst, *diffs.values())
            print(f"{name:14s} {key:26s} " + ", ".join(f"{k} {m[k]:.4g}/{ref[k]:.4g} ({diffs[k]:.1e})"
                                                        for k in COMPARED)
                  + f", transitions/T {m['impacts_per_period']:.2f}/{ref['impacts_per_period']:.2f}"
                  + ("" if same_impacts else " DIFFER"), flush=True)
    print(f"largest relative difference {worst:.2e}")
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", metavar="JSON", help="yu_readings.json of examples/yu_readings.py to re-run")
    parser.add_argument("--readings", default="", help="comma-separated readings (default: all)")
    args = parser.parse_args()
    names = [n for n in args.readings.split(",") if n] or None
    if args.compare:
        sys.exit(0 if compare(args.compare, names) <= 0.01 else 1)
    for name in names or list(READINGS):
        for omega in (0.2, 0.31):
            for D in (1.2, 1.4, 1.6, 1.8):
                m = run(name, D, omega)
                print(f"{name:14s} w{omega} D{D}: " + ", ".join(f"{k} {v:.4g}" for k, v in m.items()), flush=True)


if __name__ == "__main__":
    main()
