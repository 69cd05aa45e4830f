"""Yu et al. (2021) Figs. 9-12: every reading of the paper's parameters, run through the figures' criteria.

The paper's parameters contradict each other (see the notes of ``models/yu_6dof.toml``), so
several readings are possible.  The **readings** are scenes (the default run):

shipped          the model as shipped (scenes/yu_dynamic_D14.toml and its D12/D16/D18 and
                 constant-backlash companions): Table 1 for Figs. 9-12, static mesh force
                 T_p/R_pb = 1,220 N, inertial transmission-error forcing m_e*omega_h^2*e.
tstar_literal    eq. 19's T* = T/(k_m b_n) read literally (no 1/R): static mesh force 107.8 N
                 (scenes/yu_reading_tstar_literal.toml).
error_force      eq. 19's error term read as the force k_m*e(t) (T_ah without omega*^2;
                 scenes/yu_reading_error_force.toml).
light_load       a tenth of Table 1's torque, static force 122 N (scenes/yu_reading_light_load.toml).

For every reading and (D, omega*) it integrates ``--periods`` forcing periods from the
reading's initial state and measures the last ``--keep``: mean, extrema and peak-to-peak of
the DTE, contact transitions per period, the mean dynamic backlash B (Fig. 9), the number of
distinct Poincare points (when there are more than 16, the largest Lyapunov exponent and whether
the points lie on one closed curve: the rule of ``gearsym sweep``), and the
share of the amplitude spectrum off the mesh harmonics.  The criteria of the figures
(:func:`figure_criteria`, with the thresholds of ``examples/_verdicts.py``):

* ``fig9_above``   the dynamic backlash B(t) lies above the constant one for every D;
* ``fig9_grows``   its dynamic part B - b_s rises with D (every step by more than 1 %);
* ``fig10_loss``   the teeth separate (contact transitions) at omega* = 0.2 for every D;
* ``fig10_amp``    the peak-to-peak DTE at omega* = 0.2 falls with D (paper: 115, 30, 18, 16);
* ``fig10_route``  periodic at D = 1.2, multi-periodic at 1.6, chaotic at 1.8;
* ``fig10_dyn``    the DTE with dynamic backlash is larger than with constant backlash;
* ``fig11_plain``  only the mesh harmonics at D = 1.2 and 1.4 (share off them below 1 %);
* ``fig11_extra``  lines off the mesh harmonics at D = 1.6 and 1.8 (share above 1 %);
* ``fig12_falls``  at omega* = 0.31 the DTE (mean or peak-to-peak) falls with D;
* ``fig12_periodic`` every response at omega* = 0.31 periodic;
* ``fig12_G``      a larger G gives a larger amplitude at omega* = 0.31, D = 1.4;
* ``D_above_1.4``  an effect of D on the amplitude above 1.4: the relative spread of the
                   peak-to-peak DTE over D = 1.4, 1.6, 1.8 at omega* = 0.2 and 0.31 of at least
                   1 % (the shift of the mean, which follows b_s, and the kinds are reported).

``--candidates`` adds other readings explored before (``--list`` prints them all).
``tests/yu_reference.py`` integrates the same readings independently (numpy/scipy).

Run: ``python examples/yu_readings.py [--candidates shipped,eq19] [--fractal-only] [--out out/yu_readings]``
(about 10 s per reading; ``--sweep k_px=1e7,3e7,1e8`` adds a one-parameter sweep of the
shipped reading at omega* = 0.2).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import gearsym
from gearsym.analysis.sweeps import closed_curve
from gearsym.errors import GearsymError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _verdicts import kind_of, poincare_count, route_to_chaos, spread, trend  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DYN = ROOT / "scenes" / "yu_dynamic_D14.toml"
CONST = ROOT / "scenes" / "yu_constant_backlash.toml"
DS = (1.2, 1.4, 1.6, 1.8)
GS = (1e-12, 1e-11, 1e-10)
K_REF = 3.0e8          # Table 1 mesh stiffness
M_P = 0.26             # centre mass of models/yu_6dof.toml
SHIPPED_X0 = {"x": 24.0e-6, "xp": -4.2e-6, "yp": -11.5e-6, "xg": 4.2e-6, "yg": 11.5e-6}
LIGHT_X0 = {"x": 20.4e-6, "xp": -0.42e-6, "yp": -1.15e-6, "xg": 0.42e-6, "yg": 1.15e-6}
TSTAR_X0 = {"x": 20.4e-6, "xp": -0.37e-6, "yp": -1.0e-6, "xg": 0.37e-6, "yg": 1.0e-6}


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
    """A reading: parameter overrides (possibly depending on D), how omega* and the STE enter,
    its initial state and (for the readings) its scene."""

    def __init__(self, name: str, params: dict | None = None, *, eq19: bool = False,
                 per_D: Callable[[float], dict] | None = None, omega_scale: Callable[[float], float] | None = None,
                 effects: dict | None = None, note: str = "", scene: str = "", x0: dict | None = None):
        self.name, self.params, self.eq19, self.per_D = name, dict(params or {}), eq19, per_D
        self.effects = dict(effects or {})
        self.omega_scale = omega_scale
        self.note = note
        self.scene = scene
        self.x0 = dict(x0 or SHIPPED_X0)

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

    def state0(self, names: list[str]) -> list[float]:
        return [self.x0.get(n, 0.0) for n in names]


#: the readings of the paper (each a scene), the default run
READINGS = {c.name: c for c in [
    Candidate("shipped", note="models/yu_6dof.toml as shipped (static mesh force 1,220 N)",
              scene="yu_dynamic_D14"),
    Candidate("tstar_literal", {"T_p": 9.5221, "T_g": 9.5221}, x0=TSTAR_X0, scene="yu_reading_tstar_literal",
              note="eq. 19's T* without 1/R: static mesh force 107.8 N"),
    Candidate("error_force", eq19=True, scene="yu_reading_error_force",
              note="eq. 19's error term as the force k_m*e(t)"),
    Candidate("light_load", {"T_p": 10.78, "T_g": 10.78}, x0=LIGHT_X0, scene="yu_reading_light_load",
              note="a tenth of Table 1's torque (static mesh force 122 N)"),
]}

#: other readings explored before (not scenes; --candidates NAME)
CANDIDATES = READINGS | {c.name: c for c in [
    Candidate("eq19", eq19=True, note="= error_force"),
    Candidate("b0_5um", {"b_0": 5e-6}, note="b_0 = 5 um (Fig. 9 constant backlash ~5)"),
    Candidate("eq19_b0_5um", {"b_0": 5e-6}, eq19=True, note="eq. 19 literally and b_0 = 5 um"),
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


def measure(system, params: dict, periods: int, keep: int, x0: list[float], ppp: int = 64,
            lyapunov_periods: int = 400) -> dict:
    """Steady-state measures of the DTE over the last ``keep`` forcing periods."""
    try:
        tr = system.simulate(periods=periods, params=params, x0=x0, rtol=1e-8, atol=1e-14,
                             n_out=periods * ppp + 1)
    except GearsymError as exc:
        return {"error": f"{type(exc).__name__}: {str(exc)[:120]}"}
    n = keep * ppp
    x = tr["x"][-n - 1:]
    v = tr["v"][-n - 1:]
    B = system.outputs(tr)["backlash_B"][-n - 1:]
    t_start = tr.t[-n - 1]
    pc = np.column_stack([x[::ppp], v[::ppp]])
    clusters = poincare_count(pc, np.array([max(np.ptp(x), 1e-12), max(np.ptp(v), 1e-9)]))
    impacts = [e for e in tr.events if e.t > t_start and e.surface.startswith("mesh.")]
    back = any(e.surface == "mesh.back" for e in impacts)
    spec = np.abs(np.fft.rfft(x[:-1] - x[:-1].mean()))
    on = np.zeros(spec.size, bool)
    on[::keep] = True
    off_share = float(spec[~on].sum() / max(spec.sum(), 1e-300))
    off = np.argsort(-np.where(on, 0.0, spec))[:3]
    omega = params["Omega"]
    out = {
        "mean_um": float(x.mean() * 1e6), "max_um": float(x.max() * 1e6), "min_um": float(x.min() * 1e6),
        "ppv_um": float(np.ptp(x) * 1e6), "impacts_per_period": len(impacts) / keep,
        "rattle": 0 if not impacts else (2 if back else 1), "poincare_points": int(clusters),
        "mean_B_um": float(B.mean() * 1e6), "min_B_um": float(B.min() * 1e6), "off_harmonic_share": off_share,
        # the strongest off-harmonic lines in units of the model's omega_n
        "off_lines": [round(float(k) / keep * omega, 3) for k in off if spec[k] > 0.02 * spec.max()],
    }
    if clusters > 16:       # not periodic within the window: the largest Lyapunov exponent decides
        ly = gearsym.lyapunov_exponents(system, params, gearsym.LyapunovOptions(
            periods=lyapunov_periods, transient=0, exponents=1, rtol=1e-9), x0=tr.x_final)
        out |= {"lyapunov": float(ly.exponents[0]), "lyapunov_error": float(ly.errors[0]),
                "period": float(tr.period), "closed_curve": bool(closed_curve(pc))}
    return out


def kind(m: dict) -> str:
    if "error" in m:
        return "error"
    return kind_of(m["poincare_points"], m.get("lyapunov"), m.get("lyapunov_error"), m.get("period"),
                   m.get("closed_curve"))


def evaluate(cand: Candidate, systems: dict, periods: int, keep: int) -> dict:
    rows = {}
    names = systems["dynamic"].state_names
    x0 = cand.state0(names)
    for backlash in ("dynamic", "constant"):
        for omega in (0.2, 0.31):
            for D in DS:
                m = measure(systems[backlash], cand.run_params(D, omega), periods, keep, x0)
                rows[f"{backlash}/w{omega}/D{D}"] = m
    for G in GS:
        p = cand.run_params(1.4, 0.31)
        p["G"] = G
        rows[f"dynamic/w0.31/D1.4/G{G:g}"] = measure(systems["dynamic"], p, periods, keep, x0)
    return rows


def _fmt(v: list[float], d: int = 2) -> str:
    return ", ".join(f"{x:.{d}f}" for x in v)


def figure_criteria(rows: dict) -> dict[str, dict]:
    """The criteria of Figs. 9-12 on one reading's measures: ``{name: {"holds", "numbers"}}``."""
    if any("error" in m for m in rows.values()):
        return {"error": {"holds": False, "numbers": "a run failed"}}

    def col(backlash: str, omega: float, key: str) -> list[float]:
        return [rows[f"{backlash}/w{omega}/D{D}"][key] for D in DS]

    b_s = col("constant", 0.2, "mean_B_um")
    dyn_part = [b - s for b, s in zip(col("dynamic", 0.2, "mean_B_um"), b_s)]
    ppv02, ppv02c = col("dynamic", 0.2, "ppv_um"), col("constant", 0.2, "ppv_um")
    imp02, imp031 = col("dynamic", 0.2, "impacts_per_period"), col("dynamic", 0.31, "impacts_per_period")
    kinds02 = [kind(rows[f"dynamic/w0.2/D{D}"]) for D in DS]
    kinds031 = [kind(rows[f"dynamic/w0.31/D{D}"]) for D in DS]
    sh = col("dynamic", 0.2, "off_harmonic_share")
    mean031, ppv031 = col("dynamic", 0.31, "mean_um"), col("dynamic", 0.31, "ppv_um")
    g = [rows[f"dynamic/w0.31/D1.4/G{G:g}"]["ppv_um"] for G in GS]
    amp_above = max(spread([rows[f"dynamic/w{w}/D{D}"]["ppv_um"] for D in DS[1:]]) for w in (0.2, 0.31))
    mean_shift = max(abs(rows[f"dynamic/w{w}/D1.8"]["mean_um"] - rows[f"dynamic/w{w}/D1.4"]["mean_um"])
                     for w in (0.2, 0.31))
    bs_shift = b_s[-1] - b_s[1]
    return {
        "fig9_above": {"holds": all(x > 0 for x in dyn_part),
                       "numbers": f"B - b_s = {_fmt(dyn_part)} um for D = 1.2-1.8"},
        "fig9_grows": {"holds": trend(dyn_part) == "rises", "numbers": f"B - b_s {trend(dyn_part)}"},
        "fig10_loss": {"holds": all(x > 0 for x in imp02),
                       "numbers": f"contact transitions per period {_fmt(imp02, 1)} at omega* = 0.2"},
        "fig10_amp": {"holds": trend(ppv02) == "falls", "numbers": f"ppv {_fmt(ppv02)} um ({trend(ppv02)})"},
        "fig10_route": {"holds": route_to_chaos(kinds02), "numbers": "kinds " + ", ".join(kinds02)},
        "fig10_dyn": {"holds": all(a > 1.01 * b for a, b in zip(ppv02, ppv02c)),
                      "numbers": f"constant-backlash ppv {_fmt(ppv02c)} um"},
        "fig11_plain": {"holds": max(sh[:2]) < 0.01,
                        "numbers": "off-harmonic share " + ", ".join(f"{x:.1e}" for x in sh)},
        "fig11_extra": {"holds": min(sh[2:]) > 0.01,
                        "numbers": "off-harmonic share " + ", ".join(f"{x:.1e}" for x in sh)},
        "fig12_falls": {"holds": trend(mean031) == "falls" or trend(ppv031) == "falls",
                        "numbers": f"omega* = 0.31: mean {_fmt(mean031)} um ({trend(mean031)}), ppv "
                                   f"{_fmt(ppv031)} um ({trend(ppv031)}); transitions {_fmt(imp031, 1)}"},
        "fig12_periodic": {"holds": all(k == "periodic" for k in kinds031), "numbers": ", ".join(kinds031)},
        "fig12_G": {"holds": trend(g) == "rises", "numbers": f"ppv {_fmt(g)} um for G = 1e-12, 1e-11, 1e-10 m"},
        "D_above_1.4": {"holds": amp_above >= 0.01,
                        "numbers": f"ppv spread over D = 1.4-1.8 {amp_above:.2%}, mean shifted by at most "
                                   f"{mean_shift:.2f} um (b_s by {bs_shift:.2f} um); kinds at omega* = 0.2 "
                                   + ", ".join(kinds02[1:])},
    }


def compile_systems(effects: dict | None = None) -> dict:
    eff = {"fractal_mesh_stiffness": False} | (effects or {})
    return {"dynamic": gearsym.load_scene(DYN, effects=eff).compile(),
            "constant": gearsym.load_scene(CONST, effects=eff).compile()}


def print_rows(name: str, rows: dict, crit: dict) -> None:
    print(f"== {name}")
    for key, m in rows.items():
        if "error" in m:
            print(f"  {key:28s} {m['error']}")
            continue
        print(f"  {key:28s} mean {m['mean_um']:8.2f} ppv {m['ppv_um']:8.2f} um  B {m['mean_B_um']:7.2f}  "
              f"impacts/T {m['impacts_per_period']:5.2f} rattle {m['rattle']}  {kind(m):13s} "
              f"off-harm {m['off_harmonic_share']:.3f} {m['off_lines']}")
    for k, c in crit.items():
        print(f"  {k:15s} {'yes' if c['holds'] else 'no ':3s} {c['numbers']}")
    sys.stdout.flush()


def sweep(systems: dict, spec: str, periods: int, keep: int) -> list[dict]:
    """One-parameter sweep of the shipped reading at omega* = 0.2 (D = 1.2 ... 1.8)."""
    name, values = spec.split("=", 1)
    out = []
    x0 = READINGS["shipped"].state0(systems["dynamic"].state_names)
    for val in (float(v) for v in values.split(",")):
        over = _bearing(val) if name == "k_bearing" else {name: val}
        line = {"param": name, "value": val}
        for D in DS:
            m = measure(systems["dynamic"], over | {"D": D, "Omega": 0.2}, periods, keep, x0)
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
    parser.add_argument("--candidates", default=",".join(READINGS), help="comma-separated names")
    parser.add_argument("--list", action="store_true", help="list the readings and candidates and exit")
    parser.add_argument("--periods", type=int, default=400, help="forcing periods integrated")
    parser.add_argument("--keep", type=int, default=150, help="last periods measured")
    parser.add_argument("--sweep", action="append", default=[], help="NAME=v1,v2,... (k_bearing for all four)")
    parser.add_argument("--out", default="out/yu_readings", help="output folder (yu_readings.json)")
    parser.add_argument("--fractal-only", action="store_true", help="only the table of the constant backlash")
    args = parser.parse_args()
    if args.list:
        for c in CANDIDATES.values():
            print(f"{c.name:22s} {'scenes/' + c.scene + '.toml' if c.scene else '':40s} {c.note}")
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
        crit = figure_criteria(rows)
        print_rows(f"{name}: {cand.note} ({time.perf_counter() - t0:.0f} s)", rows, crit)
        result["candidates"][name] = {"note": cand.note, "scene": cand.scene, "rows": rows, "criteria": crit}
    for spec in args.sweep:
        result["sweeps"].append(sweep(systems, spec, args.periods, args.keep))
    (out / "yu_readings.json").write_text(json.dumps(result, indent=1))
    print(f"wrote {out / 'yu_readings.json'}")


if __name__ == "__main__":
    main()
