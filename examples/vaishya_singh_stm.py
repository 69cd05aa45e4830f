"""Vaishya & Singh (JSV 2001) by their own method: piecewise state-transition matrices (Sects. 4-5).

The gear pair of ``models/vaishya_singh.toml`` is written here a second time, by hand, from
the paper's equations (with the readings of the model file's header), and solved as the
paper solves it -- not by integrating it:

* **state-transition matrix over one mesh cycle** (eqs. 25-31), a product over the three
  segments of the cycle (double contact, single contact before and after the pitch
  point).  Formulation A (friction a pure excitation, eqs. 12-14) has constant
  coefficients in each segment: ``Phi_i = expm(G_i dt_i)`` (eq. 28).  Formulation B
  undamped (eqs. 17-19) has constant coefficients in double contact and a coefficient
  linear in time in single contact, ``delta'' + (b1 t + b2) delta = F`` (eq. 29 read
  with ``delta`` for the printed ``delta'``): its solutions are Airy functions
  ``Ai(z), Bi(z)``, ``z = -(b1 t + b2)/b1^(2/3)`` (the Bessel pair of eq. 30, read with
  ``sigma = 2 (b1 t + b2)^(3/2)/(3 b1)`` for the printed exponent 2/3);
* **forced response** (eqs. 34-39): the particular solution over a cycle from the zero
  state, exactly (constant-coefficient segments: the matrix exponential of the system
  augmented with the generator of the forcing -- constants, ramps and the 8 mesh
  harmonics of the transmission error; Airy segments: ``int Ai``, ``int Bi`` in closed
  form, :func:`scipy.special.itairy`), then the periodic response
  ``x_p(0) = (I - Phi)^-1 d`` and the response from the zero initial state that eq. 36
  implies, ``x((n + s) t_c) = Phi(s) x_n + d(s)``, ``x_{n+1} = Phi x_n + d``.

The script prints (and writes ``OUT/vaishya_singh_stm.json``) these numbers beside
gearsym's: its monodromy (variational equations, ``gearsym orbit``), its periodic orbit
and its simulation from the zero state (``gearsym simulate --x0 0,0``).  Everything
above the section "gearsym side" uses numpy/scipy only.

Run: ``python examples/vaishya_singh_stm.py [--out out/vaishya_singh_stm]`` (a few seconds).
"""

from __future__ import annotations

import argparse
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.linalg import expm
from scipy.special import airy, itairy

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "vaishya_singh.toml"
#: declared unit -> SI factor (the units models/vaishya_singh.toml uses)
UNITS = {"": 1.0, "mm": 1e-3, "um": 1e-6, "deg": math.pi / 180, "rpm": 2 * math.pi / 60, "N*m": 1.0,
         "N/m": 1.0, "kg*m^2": 1.0}
#: the cases compared: scene, parameter overrides (declared units), formulation
CASES = {
    "fig3": ("vaishya_singh_fig3", {}, "A"),
    "fig6a": ("vaishya_singh_fig6", {}, "B"),
    "fig6a_mu0": ("vaishya_singh_fig6", {"mu0": 0.0}, "B"),
    "fig6b": ("vaishya_singh_fig6", {"Gamma": 1.453}, "B"),
    "fig5": ("vaishya_singh_fig6", {"Gamma": 1.24, "Omega_p": 1500.0}, "B"),
}


def parameters(scene: str, overrides: dict[str, float]) -> tuple[dict[str, float], dict[str, object]]:
    """SI parameter values of a scene (model defaults, the scene's [parameters], overrides) and its effects."""
    model = tomllib.loads(MODEL.read_text())
    sc = tomllib.loads((ROOT / "scenes" / f"{scene}.toml").read_text())
    units = {k: v.get("unit", "") for k, v in model["parameters"].items()}
    declared = {k: float(v["value"]) for k, v in model["parameters"].items()}
    declared |= {k: float(v) for k, v in sc.get("parameters", {}).items()} | overrides
    return {k: v * UNITS[units[k]] for k, v in declared.items()}, sc["effects"]


@dataclass
class Pair:
    """The gear pair of Vaishya & Singh with the readings of models/vaishya_singh.toml."""

    p: dict[str, float]
    formulation: str
    variation: bool = True
    ste: bool = True

    def __post_init__(self) -> None:
        p = self.p
        r_p = p["a_c"] * p["Pi_p"] / (p["Pi_p"] + p["Pi_g"])
        self.R_p, self.R_g = r_p * math.cos(p["phi"]), r_p * p["Pi_g"] / p["Pi_p"] * math.cos(p["phi"])
        self.m_e = 1 / (self.R_p ** 2 / p["J_p"] + self.R_g ** 2 / p["J_g"])
        self.N0 = p["T_p"] / self.R_p                       # T_g = T_p R_g/R_p: T_e/J_t = N
        self.t_c = 2 * math.pi / (p["Omega_p"] * p["Pi_p"])  # eq. 33
        self.w_m = p["Omega_p"] * p["Pi_p"]
        self.p_b = 2 * math.pi * self.R_p / p["Pi_p"]
        self.L12 = (self.R_p + self.R_g) * math.tan(p["phi"])
        G = p["Gamma"]
        self.breaks = [0.0, (G - 1) * self.t_c, p["r_ap"] * G * self.t_c, self.t_c]   # eq. 32, Table 1's t_b
        k_max, k_min = p["k_max"], p["k_max"] / p["k_ratio"]
        c_max, c_min = (2 * p["zeta"] * math.sqrt(self.m_e * k) for k in (k_max, k_min))
        if self.variation:
            self.k, self.c = [k_max, k_min, k_min], [c_max, c_min, c_min]
        else:                                               # the cycle means (eq. 3)
            km, cm = k_max * (G - 1) + k_min * (2 - G), c_max * (G - 1) + c_min * (2 - G)
            self.k, self.c = [km] * 3, [cm] * 3
        self.e_c = [p[f"e_c{h}"] if self.ste else 0.0 for h in range(1, 9)]
        self.e_s = [p[f"e_s{h}"] if self.ste else 0.0 for h in range(1, 9)]

    # --- friction (eqs. 1, 4, 20): S(t) = R_p/J_p sum mu_i n_i zeta_pi + R_g/J_g sum mu_i n_i zeta_gi
    def friction_slope(self, seg: int) -> tuple[float, float]:
        """``S(t) = s0 + s1 (t - t_i)`` in segment ``seg`` (the friction torques per unit normal load,
        weighted as they enter the DTE equation)."""
        p, mu0 = self.p, self.p["mu0"]
        n1, n2 = [(0.5, 0.5), (0.0, 1.0), (0.0, 1.0)][seg]
        mu1, mu2 = -mu0, (mu0 if seg < 2 else -mu0)
        t_i = self.breaks[seg]
        f_b = p["r_ap"] * p["Gamma"]

        def S(t: float) -> float:
            zp2 = self.R_p * math.tan(p["phi"]) + self.p_b * (t / self.t_c - f_b)
            zp1 = zp2 + self.p_b
            zg1, zg2 = self.L12 - zp1, self.L12 - zp2
            return (self.R_p / p["J_p"] * (mu1 * n1 * zp1 + mu2 * n2 * zp2)
                    + self.R_g / p["J_g"] * (mu1 * n1 * zg1 + mu2 * n2 * zg2))

        # the moment arms grow at p_b/t_c on the pinion and shrink as fast on the gear (eq. 20)
        slope = (mu1 * n1 + mu2 * n2) * self.p_b / self.t_c * (self.R_p / p["J_p"] - self.R_g / p["J_g"])
        return S(t_i), slope

    # --- one segment: delta'' + g(t) (c delta' + k delta)/m_e = f(t)
    def segment(self, seg: int) -> dict[str, float]:
        s0, s1 = self.friction_slope(seg)
        if self.formulation == "B":
            g0, g1 = 1 - self.m_e * s0, -self.m_e * s1      # eqs. 17-19: the load factor of the mesh force
        else:
            g0, g1 = 1.0, 0.0
        return {"t0": self.breaks[seg], "dt": self.breaks[seg + 1] - self.breaks[seg], "k": self.k[seg],
                "c": self.c[seg], "g0": g0, "g1": g1, "s0": s0, "s1": s1}


# ----------------------------------------------------------------- constant-coefficient segments
def generator(pair: Pair) -> np.ndarray:
    """``u' = U u`` for ``u = [1, t, cos(h w t), sin(h w t) (h = 1..8)]``: the forcing's generator."""
    U = np.zeros((18, 18))
    U[1, 0] = 1.0
    for h in range(1, 9):
        i = 2 * h
        U[i, i + 1] = -h * pair.w_m
        U[i + 1, i] = h * pair.w_m
    return U


def u_at(pair: Pair, t: float) -> np.ndarray:
    u = [1.0, t]
    for h in range(1, 9):
        u += [math.cos(h * pair.w_m * t), math.sin(h * pair.w_m * t)]
    return np.array(u)


def forcing_rows(pair: Pair, s: dict[str, float]) -> np.ndarray:
    """``f(t) = F . u(t)`` in a segment (per unit m_e): load, friction and transmission error."""
    F = np.zeros(18)
    me, k, c, N0 = pair.m_e, s["k"], s["c"], pair.N0
    if pair.formulation == "A":       # N0 + m_e S(t) N0 + k eps + c eps' (eqs. 12-14)
        F[0] = (N0 + me * N0 * (s["s0"] - s["s1"] * s["t0"])) / me
        F[1] = me * N0 * s["s1"] / me
        g = 1.0
    else:                             # N0 + g (k eps + c eps') (eqs. 17-19); g constant here
        if s["g1"] != 0.0 and any(pair.e_c + pair.e_s):
            raise NotImplementedError("formulation B with a transmission error in a sawtooth segment")
        F[0] = N0 / me
        g = s["g0"]
    for h in range(1, 9):             # eps = sum e_ch cos + e_sh sin; eps' = h w (e_sh cos - e_ch sin)
        i, hw = 2 * h, h * pair.w_m
        F[i] += g * (k * pair.e_c[h - 1] + c * hw * pair.e_s[h - 1]) / me
        F[i + 1] += g * (k * pair.e_s[h - 1] - c * hw * pair.e_c[h - 1]) / me
    return F


def const_segment(pair: Pair, s: dict[str, float], taus: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Transition matrices ``Phi(t0 + tau, t0)`` and particular solutions from the zero state at ``taus``."""
    A = np.zeros((20, 20))
    A[0, 1] = 1.0
    A[1, 0] = -s["g0"] * s["k"] / pair.m_e
    A[1, 1] = -s["g0"] * s["c"] / pair.m_e
    A[1, 2:] = forcing_rows(pair, s)
    A[2:, 2:] = generator(pair)
    z0 = np.concatenate([[0.0, 0.0], u_at(pair, s["t0"])])
    Phis, ds = [], []
    for tau in taus:
        E = expm(A * tau)
        Phis.append(E[:2, :2])
        ds.append(E[:2, :] @ z0)
    return Phis, ds


# ----------------------------------------------------------------- Airy segments (formulation B, undamped)
def airy_segment(pair: Pair, s: dict[str, float], taus: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``delta'' + (a1 tau + a0) delta = F`` (tau = t - t0): ``Ai(z), Bi(z)``, ``z = -(a1 tau + a0)/a1^(2/3)``;
    the particular solution from the zero state by variation of constants with ``int Ai, int Bi`` closed form."""
    if s["c"] != 0.0:
        raise NotImplementedError("eqs. 18-19 with damping have no closed-form solution (the paper: numerical)")
    a0, a1 = s["g0"] * s["k"] / pair.m_e, s["g1"] * s["k"] / pair.m_e
    F = pair.N0 / pair.m_e
    c3 = math.copysign(abs(a1) ** (1 / 3), a1)

    def basis(tau: float) -> tuple[np.ndarray, float]:
        z = -(a1 * tau + a0) / c3 ** 2
        ai, aip, bi, bip = airy(z)
        return np.array([[ai, bi], [-c3 * aip, -c3 * bip]]), z

    def integrals(z: float) -> np.ndarray:
        """``int_0^z Ai``, ``int_0^z Bi`` (z < 0 here: itairy's integrals of Ai(-t), Bi(-t))."""
        _apt, _bpt, ant, bnt = itairy(-z)
        return -np.array([ant, bnt])

    W0, z_start = basis(0.0)
    I0 = integrals(z_start)
    wr = -c3 / math.pi                                   # y1 y2' - y1' y2 (Wronskian of Ai, Bi in z: 1/pi)
    Phis, ds = [], []
    for tau in taus:
        W, z = basis(tau)
        Phis.append(W @ np.linalg.inv(W0))
        # int_0^tau y_j(s) ds = (int_{z0}^{z} y_j(z') dz') / (dz/ds), dz/ds = -c3
        J = (integrals(z) - I0) / (-c3)
        d = F / wr * np.array([W[0, 1] * J[0] - W[0, 0] * J[1], W[1, 1] * J[0] - W[1, 0] * J[1]])
        ds.append(d)
    return Phis, ds


def cycle(pair: Pair, per_segment: int = 0) -> dict[str, object]:
    """Monodromy ``Phi = Phi_3 Phi_2 Phi_1`` (eq. 31), the particular solution ``d`` over the cycle,
    and (``per_segment`` > 0) ``Phi(t, 0)``, ``d(t)`` at that many points per segment."""
    Phi, d = np.eye(2), np.zeros(2)
    ts, Phis, dts = [0.0], [np.eye(2)], [np.zeros(2)]
    for seg in range(3):
        s = pair.segment(seg)
        taus = np.linspace(0.0, s["dt"], max(per_segment, 1) + 1)[1:]
        airy_case = pair.formulation == "B" and s["g1"] != 0.0
        P, D = (airy_segment if airy_case else const_segment)(pair, s, taus)
        for tau, Pk, Dk in zip(taus, P, D, strict=True):
            ts.append(s["t0"] + tau)
            Phis.append(Pk @ Phi)
            dts.append(Pk @ d + Dk)
        Phi, d = Phis[-1], dts[-1]
    return {"Phi": Phi, "d": d, "t": np.array(ts), "Phis": Phis, "ds": dts}


def periodic_response(pair: Pair, per_segment: int = 400) -> dict[str, object]:
    """The forced periodic response ``x_p(0) = (I - Phi)^-1 d`` and its DTE over one cycle."""
    cy = cycle(pair, per_segment)
    x0 = np.linalg.solve(np.eye(2) - cy["Phi"], cy["d"])
    dte = np.array([(P @ x0 + d)[0] for P, d in zip(cy["Phis"], cy["ds"], strict=True)])
    return {"x0": x0, "dte": dte, "Phi": cy["Phi"]}


def from_zero(pair: Pair, periods: int, keep: tuple[int, int], per_segment: int = 200) -> np.ndarray:
    """DTE from the zero initial state (eq. 36: the initial state ignored) over ``periods`` cycles; the
    samples of cycles ``keep[0] <= n < keep[1]``."""
    cy = cycle(pair, per_segment)
    x = np.zeros(2)
    out = []
    for n in range(periods):
        if keep[0] <= n < keep[1]:
            out.extend((P @ x + d)[0] for P, d in zip(cy["Phis"][:-1], cy["ds"][:-1], strict=True))
        x = cy["Phi"] @ x + cy["d"]
    if keep[1] == periods:
        out.append(x[0])
    return np.array(out)


def pair_of(case: str) -> Pair:
    scene, over, form = CASES[case]
    p, eff = parameters(scene, over)
    return Pair(p, form, variation=bool(eff.get("mesh_stiffness_variation", True)),
                ste=bool(eff.get("static_transmission_error", True)))


# ----------------------------------------------------------------- gearsym side
def gearsym_side(case: str) -> dict[str, object]:
    import gearsym

    scene, over, _ = CASES[case]
    system = gearsym.load_scene(ROOT / "scenes" / f"{scene}.toml", **over).compile()
    orbit = system.periodic_orbit()
    return {"monodromy": np.asarray(orbit.monodromy), "x0": np.asarray(orbit.x0),
            "ppv": orbit.peak_to_peak(), "max_multiplier": orbit.max_multiplier, "system": system}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/vaishya_singh_stm", help="output folder")
    parser.add_argument("--periods", type=int, default=200, help="cycles from the zero state (Fig. 8 comparison)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result: dict[str, object] = {"cases": {}}
    for case in CASES:
        pair = pair_of(case)
        per = periodic_response(pair)
        stm_mult = float(np.max(np.abs(np.linalg.eigvals(per["Phi"]))))
        g = gearsym_side(case)
        M = g["monodromy"]
        rel = float(np.max(np.abs(per["Phi"] - M) / (np.abs(M).max(axis=1, keepdims=True))))
        row = {"formulation": pair.formulation, "stm_max_multiplier": stm_mult,
               "gearsym_max_multiplier": float(g["max_multiplier"]), "monodromy_rel_diff": rel,
               "stm_ppv_um": float(np.ptp(per["dte"]) * 1e6), "gearsym_ppv_um": float(g["ppv"] * 1e6),
               "stm_x0": per["x0"].tolist(), "gearsym_x0": g["x0"].tolist()}
        if case.startswith("fig6a"):   # Fig. 8: from the zero state (eq. 36), second half of the run
            half = args.periods // 2
            dte = from_zero(pair, args.periods, (half, args.periods))
            tr = g["system"].simulate(periods=args.periods, x0=[0.0, 0.0], rtol=1e-11, atol=1e-16,
                                      n_out=args.periods * 200 + 1)
            gx = tr["x"][len(tr.t) // 2:]
            row |= {"zero_state_window": [half, args.periods], "zero_state_stm_ppv_um": float(np.ptp(dte) * 1e6),
                    "zero_state_gearsym_ppv_um": float(np.ptp(gx) * 1e6)}
        result["cases"][case] = row
        print(f"{case} ({pair.formulation}): max|lambda| STM {stm_mult:.6f} / gearsym {g['max_multiplier']:.6f}, "
              f"monodromy rel. diff {rel:.1e}; periodic ppv {row['stm_ppv_um']:.3f} / {row['gearsym_ppv_um']:.3f} um"
              + (f"; from the zero state, cycles {row['zero_state_window'][0]}-{row['zero_state_window'][1]}: "
                 f"{row['zero_state_stm_ppv_um']:.2f} / {row['zero_state_gearsym_ppv_um']:.2f} um"
                 if "zero_state_window" in row else ""), flush=True)
    (out / "vaishya_singh_stm.json").write_text(json.dumps(result, indent=1))
    print(f"wrote {out / 'vaishya_singh_stm.json'}")


if __name__ == "__main__":
    main()
