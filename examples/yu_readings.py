"""Yu et al. (2021) Figs. 9-12: which reading of the paper's parameters reproduces the D and G trends?

The paper's parameters contradict each other (see the notes of ``models/yu_6dof.toml``),
so several readings are possible.  This script evaluates each candidate reading on
the trends that Figs. 10-12 show, at the paper's frequencies:

* ``loss``   the pair loses contact at omega* = 0.2 and 0.31 (else D and G only shift
             a constant);
* ``amp``    the peak-to-peak DTE at omega* = 0.2 falls with D (paper: 115 -> 30 -> 18
             -> 16 for D = 1.2 ... 1.8), by more than 1 % per step;
* ``route``  periodic at D = 1.2, multi-periodic at D = 1.6, non-periodic at D = 1.8
             (dynamic backlash; Fig. 10);
* ``lines``  spectral lines off the mesh harmonics at D = 1.6 and 1.8, not at 1.2 and
             1.4 (Fig. 11);
* ``w031``   the DTE (mean, and separately peak-to-peak) falls with D at omega* = 0.31 (Fig. 12a),
             by more than 1 % per step;
* ``G``      a larger G gives a larger amplitude at omega* = 0.31, D = 1.4 (Fig. 12b), by more
             than 1 % from G = 1e-12 to 1e-10 m.

For every (reading, D, omega*) it integrates ``--periods`` forcing periods from the
scene's initial state and measures the last ``--keep`` periods: mean, maximum and
peak-to-peak of the DTE, impacts (contact transitions) per period, the number of
distinct Poincare points (1 periodic, 2-16 multi-periodic, more: not periodic within
the window) and the share of the amplitude spectrum off the mesh harmonics.

Candidate readings (``--candidates`` picks some; ``--list`` prints them):

shipped        the model file as shipped (inertial STE forcing m_e*omega_h^2*e_r, bearings
               1e8 N/m, b_0 = 20 um, constant mesh stiffness).
eq19           eq. 19 read literally: the STE enters as the force k_m*e(t) (T_ah = e/b_n on
               the right-hand side, no omega*^2), i.e. 1/omega*^2 = 25 times the shipped
               forcing at omega* = 0.2.  Emulated by T_ah -> T_ah/omega*^2.
b0_5um         b_0 = 5 um: the constant backlash of Fig. 9 (4.5 / 4.9 / 5.0 for D = 1.2 /
               1.4 / 1.6, "almost b_0" for D = 1.8), read in um.
eq19_b0_5um    both.
light_load     T_p = T_g = 10.78 N*m (a tenth of Table 1): contact loss by a lighter load.
bearing_1e7, bearing_1e9
               bearing stiffness 1e7 / 1e9 N/m (damping kept at 5 % of critical).
bearing_fig11  bearing stiffness chosen so that the centres' natural frequency is the
               extra line omega* = 0.75 of Fig. 11(c) (the paper attributes the extra
               lines to "gear centre translation motion frequency").
me_table1      omega* referred to Table 1's equivalent mass 0.23 kg (omega_n = 36.1e3 rad/s
               instead of 63.7e3): the same omega* is a lower mesh frequency.
kfrac_rising   the mesh stiffness of eq. 18 rising with D as the paper states ("smooth
               surface with high stiffness"): k_am = k_m*10^(2.5*(D - 1.5)) (0.18, 1, 5.6 x),
               omega* referred to the Table 1 stiffness (the physical frequency is fixed).
kfrac_rising_eq19   the same with the literal eq. 19 forcing.
kfrac_rising_own_wn the same, but omega* referred to each surface's own omega_n.

Run: ``python examples/yu_readings.py [--candidates shipped,eq19] [--fractal-only] [--out out/yu_readings]``
(about 10 s per candidate; ``--sweep k_px=1e7,3e7,1e8`` adds a one-parameter sweep of the
shipped reading at omega* = 0.2).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import gearsym
from gearsym.errors import GearsymError

ROOT = Path(__file__).resolve().parents[1]
DYN = ROOT / "scenes" / "yu_dynamic_D14.toml"
CONST = ROOT / "scenes" / "yu_constant_backlash.toml"
DS = (1.2, 1.4, 1.6, 1.8)
GS = (1e-12, 1e-11, 1e-10)
K_REF = 3.0e8          # Table 1 mesh stiffness
M_P = 0.26             # centre mass of models/yu_6dof.toml


def _bearing(k: float) -> dict[str, float]:
    """Bearing stiffness k in x and y for both centres, damping 5 % of critical."""
    c = 2 * 0.05 * math.sqrt(k * M_P)
    return {n: k for n in ("k_px", "k_py", "k_gx", "k_gy")} | {n: c for n in ("c_px", "c_py", "c_gx", "c_gy")}


def _k_rising(D: float) -> float:
    return K_REF * 10 ** (2.5 * (D - 1.5))


# omega_n of the shipped model (base radii): sqrt(k_m/m_e), m_e = I/(2 R_pb^2)
_M_E = 1.0 / (2 * (0.094 * math.cos(math.radians(20))) ** 2 / 1.15e-3)
_W_N = math.sqrt(K_REF / _M_E)
_K_FIG11 = M_P * (0.75 * _W_N) ** 2


class Candidate:
    """A reading: parameter overrides (possibly depending on D) and how omega* and the STE enter."""

    def __init__(self, name: str, params: dict | None = None, *, eq19: bool = False,
                 per_D: Callable[[float], dict] | None = None, omega_scale: Callable[[float], float] | None = None,
                 effects: dict | None = None, note: str = ""):
        self.name, self.params, self.eq19, self.per_D = name, dict(params or {}), eq19, per_D
        self.effects = dict(effects or {})
        self.omega_scale = omega_scale
        self.note = note

    def run_params(self, D: float, omega: float) -> dict[str, float]:
        p = dict(self.params)
        if self.per_D:
            p.update(self.per_D(D))
        scale = self.omega_scale(D) if self.omega_scale else 1.0
        p["D"] = D
        p["Omega"] = omega * scale          # the model's Omega is referred to its own k_m
        if self.eq19:
            # literal eq. 19: force k_m*e_r*cos; the model's term is m_e*omega_h^2*e_r*cos
            # = Omega^2*k_m*e_r*cos, so T_ah -> T_ah/Omega^2 gives exactly k_m*e_r*cos
            p["T_ah"] = p.get("T_ah", 0.019) / p["Omega"] ** 2
        return p


CANDIDATES = {c.name: c for c in [
    Candidate("shipped", note="models/yu_6dof.toml as shipped"),
    Candidate("eq19", eq19=True, note="eq. 19 literally: STE force k_m*e(t)"),
    Candidate("b0_5um", {"b_0": 5e-6}, note="b_0 = 5 um (Fig. 9 constant backlash ~5)"),
    Candidate("eq19_b0_5um", {"b_0": 5e-6}, eq19=True, note="eq. 19 literally and b_0 = 5 um"),
    Candidate("light_load", {"T_p": 10.78, "T_g": 10.78}, note="a tenth of Table 1's torque"),
    Candidate("bearing_1e7", _bearing(1e7), note="bearing stiffness 1e7 N/m"),
    Candidate("bearing_1e9", _bearing(1e9), note="bearing stiffness 1e9 N/m"),
    Candidate("bearing_fig11", _bearing(_K_FIG11),
              note=f"bearing stiffness {_K_FIG11:.3g} N/m: centre frequency at omega* = 0.75 (Fig. 11 c)"),
    Candidate("me_table1", omega_scale=lambda D: math.sqrt(_M_E / 0.23),
              note="omega* referred to Table 1's m_e = 0.23 kg"),
    # a D-dependent mesh stiffness k_am(D); the model's k_m is both k_am and the reference of
    # Omega, so Omega is rescaled to keep omega* referred to the Table 1 stiffness
    Candidate("kfrac_rising", per_D=lambda D: {"k_m": _k_rising(D)},
              omega_scale=lambda D: math.sqrt(K_REF / _k_rising(D)),
              note="k_am = k_m*10^(2.5(D-1.5)), omega* referred to Table 1's k_m"),
    Candidate("kfrac_rising_eq19", per_D=lambda D: {"k_m": _k_rising(D)}, eq19=True,
              omega_scale=lambda D: math.sqrt(K_REF / _k_rising(D)),
              note="k_am rising with D and eq. 19 literally"),
    Candidate("eq18_printed", effects={"fractal_mesh_stiffness": True},
              note="eq. 18 as shipped (ratio to D_ref = 1.5; falls with D, rises with G)"),
    Candidate("eq18_printed_eq19", effects={"fractal_mesh_stiffness": True}, eq19=True,
              note="eq. 18 as shipped and eq. 19 literally"),
    Candidate("kfrac_rising_light", {"T_p": 10.78, "T_g": 10.78}, per_D=lambda D: {"k_m": _k_rising(D)},
              omega_scale=lambda D: math.sqrt(K_REF / _k_rising(D)),
              note="k_am rising with D and a tenth of Table 1's torque"),
    Candidate("kfrac_rising_own_wn", per_D=lambda D: {"k_m": _k_rising(D)},
              note="k_am rising with D, omega* referred to each surface's own omega_n"),
]}


def measure(system, params: dict, periods: int, keep: int, ppp: int = 64) -> dict:
    """Steady-state measures of the DTE over the last ``keep`` forcing periods."""
    try:
        tr = system.simulate(periods=periods, params=params, rtol=1e-8, atol=1e-14, n_out=periods * ppp + 1)
    except GearsymError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:120]}"}
    n = keep * ppp
    x = tr["x"][-n - 1:]
    v = tr["v"][-n - 1:]
    t_start = tr.t[-n - 1]
    pc = np.column_stack([x[::ppp], v[::ppp]])
    scale = np.array([max(np.ptp(x), 1e-12), max(np.ptp(v), 1e-9)])
    clusters = len(np.unique(np.round(pc / (1e-3 * scale)), axis=0))
    impacts = [e for e in tr.events if e.t > t_start and e.surface.startswith("mesh.")]
    back = any(e.surface == "mesh.back" for e in impacts)
    spec = np.abs(np.fft.rfft(x[:-1] - x[:-1].mean()))
    on = np.zeros(spec.size, bool)
    on[::keep] = True
    off_share = float(spec[~on].sum() / max(spec.sum(), 1e-300))
    off = np.argsort(-np.where(on, 0.0, spec))[:3]
    omega = params["Omega"]
    return {
        "mean_um": float(x.mean() * 1e6), "max_um": float(x.max() * 1e6), "min_um": float(x.min() * 1e6),
        "ppv_um": float(np.ptp(x) * 1e6), "impacts_per_period": len(impacts) / keep,
        "rattle": 0 if not impacts else (2 if back else 1), "poincare_points": int(clusters),
        "off_harmonic_share": off_share,
        # the strongest off-harmonic lines in units of the model's omega_n
        "off_lines": [round(float(k) / keep * omega, 3) for k in off if spec[k] > 0.02 * spec.max()],
    }


def kind(m: dict) -> str:
    if "error" in m:
        return "error"
    n = m["poincare_points"]
    return "periodic" if n == 1 else (f"P{n}" if n <= 16 else "non-periodic")


def evaluate(cand: Candidate, systems: dict, periods: int, keep: int) -> dict:
    rows = {}
    for backlash in ("dynamic", "constant"):
        for omega in (0.2, 0.31):
            for D in DS:
                m = measure(systems[backlash], cand.run_params(D, omega), periods, keep)
                rows[f"{backlash}/w{omega}/D{D}"] = m
    for G in GS:
        p = cand.run_params(1.4, 0.31)
        p["G"] = G
        rows[f"dynamic/w0.31/D1.4/G{G:g}"] = measure(systems["dynamic"], p, periods, keep)
    return rows


def verdicts(rows: dict) -> dict[str, bool]:
    def col(backlash, omega, key):
        return [rows[f"{backlash}/w{omega}/D{D}"].get(key, math.nan) for D in DS]

    def falling(v):                   # by more than 1 % per step (not numerical noise)
        return all(a > b + 0.01 * abs(b) for a, b in zip(v, v[1:]))

    dyn02 = [rows[f"dynamic/w0.2/D{D}"] for D in DS]
    ok = not any("error" in m for m in rows.values())
    out = {"no_errors": ok}
    out["loss"] = ok and all(rows[f"dynamic/w{w}/D{D}"]["impacts_per_period"] > 0 for w in (0.2, 0.31) for D in DS)
    out["amp"] = ok and falling(col("dynamic", 0.2, "ppv_um"))
    kinds = [kind(m) for m in dyn02]
    out["route"] = ok and kinds[0] == "periodic" and kinds[2].startswith("P") and kinds[3] == "non-periodic"
    sh = col("dynamic", 0.2, "off_harmonic_share")
    out["lines"] = ok and min(sh[2], sh[3]) > 0.01 and max(sh[0], sh[1]) < 0.01
    out["w031_mean"] = ok and falling(col("dynamic", 0.31, "mean_um"))
    out["w031_ppv"] = ok and falling(col("dynamic", 0.31, "ppv_um"))
    g = [rows[f"dynamic/w0.31/D1.4/G{G:g}"].get("ppv_um", math.nan) for G in GS]
    out["G"] = ok and all(a < b for a, b in zip(g, g[1:])) and g[-1] > 1.01 * g[0]     # "in a minor degree"
    return out


def compile_systems(effects: dict | None = None) -> dict:
    eff = {"fractal_mesh_stiffness": False} | (effects or {})
    return {"dynamic": gearsym.load_scene(DYN, effects=eff).compile(),
            "constant": gearsym.load_scene(CONST, effects=eff).compile()}


def print_rows(name: str, rows: dict, verdict: dict) -> None:
    print(f"== {name}")
    for key, m in rows.items():
        if "error" in m:
            print(f"  {key:28s} {m['error']}")
            continue
        print(f"  {key:28s} mean {m['mean_um']:8.2f} max {m['max_um']:8.2f} ppv {m['ppv_um']:8.2f} um  "
              f"impacts/T {m['impacts_per_period']:5.2f} rattle {m['rattle']}  {kind(m):13s} "
              f"off-harm {m['off_harmonic_share']:.3f} {m['off_lines']}")
    print("  verdicts: " + ", ".join(f"{k}={'yes' if v else 'no'}" for k, v in verdict.items()), flush=True)


def sweep(systems: dict, spec: str, periods: int, keep: int) -> list[dict]:
    """One-parameter sweep of the shipped reading at omega* = 0.2 (D = 1.2 ... 1.8)."""
    name, values = spec.split("=", 1)
    out = []
    for val in (float(v) for v in values.split(",")):
        over = _bearing(val) if name == "k_bearing" else {name: val}
        line = {"param": name, "value": val}
        for D in DS:
            m = measure(systems["dynamic"], over | {"D": D, "Omega": 0.2}, periods, keep)
            line[f"D{D}"] = m
        out.append(line)
        print(f"{name}={val:g}: " + "  ".join(
            f"D{D}: ppv {line[f'D{D}'].get('ppv_um', math.nan):.1f} imp {line[f'D{D}'].get('impacts_per_period', 0):.1f}"
            f" {kind(line[f'D{D}'])}" for D in DS), flush=True)
    return out


def backlash_table() -> list[dict]:
    """b_s(1.6) - b_s(1.8) for scalings of the W-M profile: the two surfaces' constant backlash differ
    by a tiny amount for any physical l_a and G (so D = 1.6 and 1.8 can differ only through eq. 18)."""
    from gearsym.fractal import wm_mean_height

    rows = []
    for l_a in (10e-6, 100e-6, 1e-3):
        for G in GS:
            b = []
            for D in DS:
                try:
                    b.append(2 * wm_mean_height(D, G, 1.5, 1.5 * l_a, l_a))
                except GearsymError:      # the series needs more than the work limit: report nan
                    b.append(math.nan)
            rows.append({"l_a": l_a, "L_c": 1.5 * l_a, "G": G, "two_b_i_um": [v * 1e6 for v in b]})
            print(f"l_a {l_a * 1e6:6.0f} um  G {G:.0e} m: 2*b_i(D = 1.2 .. 1.8) = "
                  + "  ".join(f"{v * 1e6:.4g}" for v in b) + " um")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", default=",".join(CANDIDATES), help="comma-separated names")
    parser.add_argument("--list", action="store_true", help="list the candidate readings and exit")
    parser.add_argument("--periods", type=int, default=400, help="forcing periods integrated")
    parser.add_argument("--keep", type=int, default=150, help="last periods measured")
    parser.add_argument("--sweep", action="append", default=[], help="NAME=v1,v2,... (k_bearing for all four)")
    parser.add_argument("--out", default="out/yu_readings", help="output folder (yu_readings.json)")
    parser.add_argument("--fractal-only", action="store_true", help="only the table of the constant backlash")
    args = parser.parse_args()
    if args.list:
        for c in CANDIDATES.values():
            print(f"{c.name:22s} {c.note}")
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.fractal_only:
        (out / "yu_readings.json").write_text(json.dumps({"fractal_backlash": backlash_table()}, indent=1))
        print(f"wrote {out / 'yu_readings.json'}")
        return
    cache: dict = {}

    def systems_for(effects: dict) -> dict:
        key = tuple(sorted(effects.items()))
        if key not in cache:
            cache[key] = compile_systems(effects)
        return cache[key]

    systems = systems_for({})
    result: dict = {"candidates": {}, "sweeps": [], "fractal_backlash": backlash_table()}
    for name in args.candidates.split(","):
        if not name:
            continue
        cand = CANDIDATES[name]
        t0 = time.perf_counter()
        rows = evaluate(cand, systems_for(cand.effects), args.periods, args.keep)
        verdict = verdicts(rows)
        print_rows(f"{name}: {cand.note} ({time.perf_counter() - t0:.0f} s)", rows, verdict)
        result["candidates"][name] = {"note": cand.note, "rows": rows, "verdicts": verdict}
    for spec in args.sweep:
        result["sweeps"].append(sweep(systems, spec, args.periods, args.keep))
    (out / "yu_readings.json").write_text(json.dumps(result, indent=1))
    print(f"wrote {out / 'yu_readings.json'}")


if __name__ == "__main__":
    main()
