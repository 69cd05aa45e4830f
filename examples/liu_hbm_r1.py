"""Liu et al. (2021) by their own method: the R = 1 harmonic balance (eqs. 13-17, Sect. 3.2) beside the exact orbit.

The paper solves eq. 9 by harmonic balance with the series of eq. 13 truncated at R = 1:
the harmonics {0, w_c, 2 w_c, w_e, w_e +- w_c, w_e +- 2 w_c} of the response, i.e. the
multiples {0, 1, 2, Z2-2 .. Z2+2} of w_c (Z2 = 64: 1, 2, 62-66), "15 unknown variables", with
the rigid-angle acceleration truncated to the first two terms of its Fourier series (eq. 22;
variant ``instantaneous_center = "eq22"`` of ``models/liu_nfg.toml``, scene
``scenes/liu_nfg_eq22.toml``), f(q) by a DFT of M samples (eqs. 15-17) and a quasi-Newton
(Broyden) solve.  :func:`gearsym.analysis.periodic.harmonic_balance` with that harmonic set is
this method: AFT with quasi-Newton; it balances q and v = q' (30 coefficients), and since the
set is closed under d/dt the v-equation makes v's coefficients those of q', so the solution is
the paper's 15 (tests/test_liu_hbm_r1.py checks it against a 15-unknown Galerkin solve written
with numpy alone).  Because the set holds no harmonic 3..61 of w_c, the terms of theta2''
beyond the second are orthogonal to it: with R = 1 the truncation of eq. 22 changes nothing
(the script checks it).

Beside it, the exact periodic orbit (shooting, closed-form theta2'') and the exact orbit of the
truncated equation (shooting on ``liu_nfg_eq22``), at 140/160/180 rad/s (Figs. 8-10), and the
speeds where each changes rattle state (bisection of the rattle state to ``--tol`` rad/s): which
transitions the paper's method moves, and by how much.

Writes ``OUT/liu_hbm_r1.json``.

Run: ``python examples/liu_hbm_r1.py [--out out/liu_hbm_r1] [--step 2] [--tol 0.05]`` (a minute or two).
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
from gearsym.analysis.periodic import harmonic_balance
from gearsym.errors import GearsymError

ROOT = Path(__file__).resolve().parents[1]
EXACT = ROOT / "scenes" / "liu_nfg_160.toml"
EQ22 = ROOT / "scenes" / "liu_nfg_eq22.toml"
SPEEDS = (140.0, 160.0, 180.0)


def r1_set(Z2: int) -> list[int]:
    """Eq. 13 with R = 1: the multiples 1, 2, Z2 - 2 .. Z2 + 2 of w_c (with the mean: 15 unknowns)."""
    return [1, 2, *range(Z2 - 2, Z2 + 3)]


class R1:
    """The R = 1 balance of one system, warm-started from the previous solution."""

    def __init__(self, system, harmonics: list[int]):
        self.system, self.h, self.prev = system, harmonics, None

    def solve(self, w: float):
        kw = {"harmonics": self.h, "defect_tol": 0.99, "monodromy": False}
        for guess in (self.prev, None):
            try:
                o = harmonic_balance(self.system, params={"omega1": w}, guess=guess, **kw)
                self.prev = o
                return o
            except GearsymError:
                continue
        self.prev = None
        return None


def shoot(system, w: float, x0=None):
    try:
        return system.periodic_orbit(params={"omega1": w}, x0=x0)
    except GearsymError:
        return None


def bisect(state_at: Callable[[float], int | None], lo: float, hi: float, s_lo: int, tol: float) -> float:
    """The speed where the rattle state leaves ``s_lo`` in ``[lo, hi]`` (state ``s_lo`` at lo, other at hi)."""
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        s = state_at(mid)
        if s is None:                       # no solution there: nudge
            s = state_at(mid + 0.25 * (hi - lo))
            mid = mid + 0.25 * (hi - lo)
        if s == s_lo:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def transitions_of(values: list[float], states: list[int | None]) -> list[tuple[float, float, int, int]]:
    pts = [(v, s) for v, s in zip(values, states, strict=True) if s is not None]
    return [(a, b, sa, sb) for (a, sa), (b, sb) in zip(pts, pts[1:]) if sa != sb]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/liu_hbm_r1", help="output folder")
    parser.add_argument("--step", type=float, default=2.0, help="speed step of the sweep [rad/s]")
    parser.add_argument("--range", default="100,250", help="speed range of the sweep [rad/s]")
    parser.add_argument("--tol", type=float, default=0.05, help="bisection tolerance of the transitions [rad/s]")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    exact = gearsym.load_scene(EXACT).compile()
    eq22 = gearsym.load_scene(EQ22).compile()
    H = r1_set(int(exact.params["Z2"]))
    res: dict = {"harmonics": H, "unknowns": 2 * len(H) + 1, "speeds": {}}

    # Figs. 8-10: the three speeds by the three computations
    for w in SPEEDS:
        a, b = shoot(exact, w), shoot(eq22, w)
        r = R1(eq22, H).solve(w)
        r_exact = R1(exact, H).solve(w)
        same = (float(np.max(np.abs(r.coefficients - r_exact.coefficients)) / np.max(np.abs(r.coefficients)))
                if r is not None and r_exact is not None else math.nan)
        res["speeds"][f"{w:g}"] = {
            "exact": {"rattle_state": a.rattle_state, "ppv": a.peak_to_peak()} if a else None,
            "eq22_exact": {"rattle_state": b.rattle_state, "ppv": b.peak_to_peak()} if b else None,
            "r1": {"rattle_state": r.rattle_state, "ppv": r.peak_to_peak(),
                   "defect_relative": r.info.get("defect_relative")} if r else None,
            "r1_eq22_vs_closed_form": same}
        print(f"{w:g} rad/s: exact {a.rattle_state if a else '-'} {a.peak_to_peak() * 1e3 if a else math.nan:.4f} mrad; "
              f"eq. 22 exact {b.rattle_state if b else '-'} {b.peak_to_peak() * 1e3 if b else math.nan:.4f}; R = 1 "
              f"{r.rattle_state if r else '-'} {r.peak_to_peak() * 1e3 if r else math.nan:.4f} mrad "
              f"(R = 1 with the closed-form theta2'': max rel. coefficient difference {same:.1e})", flush=True)

    # sweep of the R = 1 balance, transitions bisected
    lo_w, hi_w = (float(x) for x in args.range.split(","))
    ws = list(np.arange(lo_w, hi_w + 1e-9, args.step))
    bal = R1(eq22, H)
    sols = [bal.solve(w) for w in ws]
    states = [s.rattle_state if s is not None else None for s in sols]
    res["sweep"] = {"omega1": ws, "rattle_state": states,
                    "ppv": [s.peak_to_peak() if s is not None else None for s in sols]}

    def r1_state(w: float) -> int | None:
        s = R1(eq22, H)
        s.prev = min((x for x in sols if x is not None), key=lambda o: abs(o.params["omega1"] - w), default=None)
        o = s.solve(w)
        return None if o is None else o.rattle_state

    res["transitions"] = {"r1": [], "exact": [], "eq22_exact": []}
    for a, b, sa, sb in transitions_of(ws, states):
        res["transitions"]["r1"].append({"from": sa, "to": sb, "at": bisect(r1_state, a, b, sa, args.tol)})
    for name, system in (("exact", exact), ("eq22_exact", eq22)):
        coarse = [(w, shoot(system, w)) for w in np.arange(lo_w, hi_w + 1e-9, 5.0)]
        st = [o.rattle_state if o is not None else None for _, o in coarse]
        for a, b, sa, sb in transitions_of([w for w, _ in coarse], st):
            def state_at(w: float, system=system) -> int | None:
                o = shoot(system, w)
                return None if o is None else o.rattle_state
            res["transitions"][name].append({"from": sa, "to": sb, "at": bisect(state_at, a, b, sa, args.tol)})
    for name, trs in res["transitions"].items():
        print(f"transitions ({name}): " + ", ".join(f"{t['from']} -> {t['to']} at {t['at']:.2f}" for t in trs),
              flush=True)
    res["wall_s"] = round(time.perf_counter() - t0, 1)
    (out / "liu_hbm_r1.json").write_text(json.dumps(res, indent=1))
    print(f"wrote {out / 'liu_hbm_r1.json'} ({res['wall_s']} s)")


if __name__ == "__main__":
    main()
