"""Liu et al.'s R = 1 harmonic balance (eqs. 13-17, 22): gearsym's balance on the harmonic set of eq. 13
against a 15-unknown Galerkin solve of the paper's equation written here with numpy alone.

The equation is eq. 5 in the elastic angle reduced to q = q2 + e/rb2 (models/liu_nfg.toml), with
eq. 22's two-term rigid-angle acceleration; the series is eq. 13 with R = 1 (z0 .. z14, the
fifth term read sin(2 w_c tau)), f(q) sampled and projected on the same harmonics (eqs. 15-17).
"""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import root

import gearsym
from gearsym.analysis.periodic import harmonic_balance

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))
from liu_hbm_r1 import r1_set  # noqa: E402

UNITS = {"": 1.0, "mm": 1e-3, "um": 1e-6, "rad/s": 1.0, "kg*m^2": 1.0, "N/m": 1.0, "N*m": 1.0, "rad": 1.0}


def liu_parameters(omega1: float) -> dict[str, float]:
    model = tomllib.loads((ROOT / "models" / "liu_nfg.toml").read_text())
    p = {k: float(v["value"]) * UNITS[v.get("unit", "")] for k, v in model["parameters"].items()}
    p["omega1"] = omega1
    return p


class PaperR1:
    """Eq. 5 (reduced to q) with eq. 22's theta2'', balanced on eq. 13's 15 unknowns."""

    def __init__(self, p: dict[str, float], M: int = 4096):
        eps = p["eps"]
        self.H = r1_set(int(p["Z2"]))
        ij = p["Z2"] / p["Z1"]
        L = p["rb1"] * ij * (1 + eps ** 2) / (1 - eps ** 2)
        beta = 2 * eps / (1 + eps ** 2)
        wc = p["omega1"] * p["Z1"] / p["Z2"]
        we = p["Z2"] * wc
        wn = math.sqrt(p["k0"] * L ** 2 * (1 + beta ** 2 / 2) / p["I2"])
        cm = 2 * p["zeta"] * p["I2"] * wn / (L ** 2 * (1 + beta ** 2 / 2))
        self.wc, self.b, self.I2, self.T2, self.cm = wc, p["b"], p["I2"], p["T2"], cm
        t = 2 * np.pi / wc * np.arange(M) / M
        self.th = wc * t
        self.rb = L * (1 + beta * np.cos(wc * t))
        rbd = -L * beta * wc * np.sin(wc * t)
        rbdd = -L * beta * wc ** 2 * np.cos(wc * t)
        self.km = p["k0"] + p["kr"] * np.sin(we * t + p["phi_m"])
        e = p["e0"] + p["er"] * np.sin(we * t + p["phi_e"])
        ed = p["er"] * we * np.cos(we * t + p["phi_e"])
        edd = -p["er"] * we ** 2 * np.sin(we * t + p["phi_e"])
        self.e_rbd = e * rbd / self.rb
        e_over_rb_dd = edd / self.rb - 2 * ed * rbd / self.rb ** 2 + e * (2 * rbd ** 2 / self.rb ** 3 - rbdd / self.rb ** 2)
        theta2_dd = 2 * eps * wc ** 2 * (np.sin(wc * t) - 2 * eps * np.sin(2 * wc * t))      # eq. 22
        self.rhs0 = -self.T2 / self.I2 - theta2_dd + e_over_rb_dd
        k = np.array(self.H, float)
        self.C, self.S = np.cos(np.outer(self.th, k)), np.sin(np.outer(self.th, k))

    def series(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, b = z[1::2], z[2::2]
        k = np.array(self.H, float) * self.wc
        q = z[0] + self.C @ a + self.S @ b
        qd = self.C @ (k * b) - self.S @ (k * a)
        qdd = -(self.C @ (k ** 2 * a) + self.S @ (k ** 2 * b))
        return q, qd, qdd

    def residual(self, z: np.ndarray) -> np.ndarray:
        q, qd, qdd = self.series(z)
        d = self.rb * q                                        # mesh deflection rb2*q2 + e = rb2*q
        f = np.where(d < -self.b, d + self.b, np.where(d > self.b, d - self.b, 0.0))
        r = qdd - (-(self.rb * self.cm * (self.rb * qd + self.e_rbd)) - self.rb * self.km * f) / self.I2 - self.rhs0
        n = len(r)
        out = [r.mean()]
        for j in range(len(self.H)):
            out += [2 / n * r @ self.C[:, j], 2 / n * r @ self.S[:, j]]
        return np.array(out) / self.wc ** 2


@pytest.fixture(scope="module")
def eq22_system():
    return gearsym.load_scene(ROOT / "scenes" / "liu_nfg_eq22.toml").compile()


@pytest.mark.parametrize("omega1", [160.0, 180.0])
def test_r1_balance_is_the_papers_15_unknown_solution(eq22_system, omega1):
    H = r1_set(64)
    assert len(H) == 7          # with the mean: 15 unknowns (Sect. 3.2)
    o = harmonic_balance(eq22_system, params={"omega1": omega1}, harmonics=H, defect_tol=0.99, monodromy=False)
    q = o.coefficients[:, 0]
    z_gs = np.concatenate([[q[0]], *[[q[2 * k - 1], q[2 * k]] for k in H]])
    assert np.allclose(np.delete(q, [0, *[2 * k - 1 for k in H], *[2 * k for k in H]]), 0.0)
    paper = PaperR1(liu_parameters(omega1))
    start = z_gs * (1 + 0.02 * np.cos(np.arange(z_gs.size)))       # not gearsym's solution
    sol = root(paper.residual, start, method="hybr", options={"xtol": 1e-13})
    assert sol.success, sol.message
    scale = np.max(np.abs(z_gs))
    assert np.max(np.abs(sol.x - z_gs)) < 1e-5 * scale        # AFT samples differ (4096 here)
    assert o.peak_to_peak() == pytest.approx(np.ptp(paper.series(sol.x)[0]), rel=1e-4)
