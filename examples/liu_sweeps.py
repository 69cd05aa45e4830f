"""Noncircular face gear (Liu et al. Figs. 12-15): the response against one parameter, every sample classified.

For each value of ``--param`` the periodic orbit is shot from the scene's initial state, as
``gearsym orbit scenes/liu_nfg_160.toml --set NAME=VALUE`` does.  Where shooting does not
converge, or converges on an orbit that is not asymptotically stable, the response is not left
as "shooting failed": it is integrated (``--transient`` forcing periods discarded, ``--keep``
kept, as ``gearsym simulate``), its rattle state and peak-to-peak value measured, its
Poincare section (one point per forcing period) counted, and its largest Lyapunov exponent
computed (:func:`gearsym.lyapunov_exponents`, as ``gearsym lyapunov``); the kind follows the
criteria of ``examples/_verdicts.py`` (periodic, P k; otherwise the rule of ``gearsym sweep``,
:mod:`gearsym.analysis.sweeps`: chaotic, quasi-periodic -- the exponent zero and the Poincare
points on one closed curve, :func:`gearsym.analysis.sweeps.closed_curve` --, converging, unclassified).

With ``--continue FROM,TO`` the periodic orbit is also continued in the parameter
(``gearsym continue``): its points (rattle state, ppv, stability), located bifurcations
(grazings that change the rattle state, folds, ...) and why it stopped.  The verdicts of
docs/reproduction.md use the continued branch for "a jump at the transition" (a fold or a
bifurcation there, not a steep continuous rise).

Writes ``OUT/liu_sweeps.json``.

Run: ``python examples/liu_sweeps.py --param er --values 0,2,4,5,6,7 [--continue 0,15] [--set omega1=140]
[--out out/liu_sweeps]``
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import gearsym
from gearsym.analysis.periodic import peak_to_peak, rattle_state
from gearsym.analysis.sweeps import closed_curve
from gearsym.errors import GearsymError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _verdicts import kind_of, poincare_count  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "liu_nfg_160.toml"
PPP = 4096            # samples per forcing period (64 mesh cycles: 64 per mesh cycle)


def orbit_sample(system, params: dict) -> dict | None:
    """The shot orbit (as ``gearsym orbit``), or None when shooting fails or the orbit is not stable."""
    try:
        o = system.periodic_orbit(params=params)
    except GearsymError as exc:
        return {"failed": f"{type(exc).__name__}: {str(exc)[:160]}"}
    if o.stability != "asymptotically_stable":
        return {"failed": f"orbit {o.stability} (max |mu| {o.max_multiplier:.3g})", "orbit_ppv": o.peak_to_peak()}
    return {"method": "orbit", "rattle_state": o.rattle_state, "ppv": o.peak_to_peak(), "kind": "periodic",
            "max_multiplier": o.max_multiplier}


def simulated_sample(system, params: dict, transient: int, keep: int, lyap_periods: int) -> dict:
    """The steady response by integration: rattle state, ppv, Poincare points, largest Lyapunov exponent."""
    rtol, atol = 1e-10, 1e-15
    x = system.simulate(periods=transient, params=params, rtol=rtol, atol=atol, n_out=2).x_final
    tr = system.simulate(periods=keep, x0=x, params=params, rtol=rtol, atol=atol, n_out=keep * PPP + 1)
    points = tr.y[::PPP][:keep]
    n_pts = poincare_count(points, np.ptp(tr.y, axis=0))
    spread = float(np.max(np.ptp(points, axis=0) / np.maximum(np.ptp(tr.y, axis=0), 1e-300)))
    ly = gearsym.lyapunov_exponents(system, params, gearsym.LyapunovOptions(
        periods=lyap_periods, transient=0, exponents=1, rtol=1e-9), x0=tr.x_final)
    lam, err = float(ly.exponents[0]), float(ly.errors[0])
    T = system.period(params) if hasattr(system, "period") else tr.period
    closed = bool(closed_curve(points)) if n_pts > 16 else None
    return {"method": "simulation", "rattle_state": rattle_state(tr, system=system, steady_fraction=1.0),
            "ppv": peak_to_peak(tr, steady_fraction=1.0), "poincare_points": n_pts, "poincare_spread": spread,
            "lyapunov": lam, "lyapunov_error": err, "lyapunov_converged": bool(ly.converged), "period": T,
            "closed_curve": closed, "kind": kind_of(n_pts, lam, err, T, closed)}


def continued(system, name: str, lo: float, hi: float) -> dict:
    """The continued periodic orbit in ``name`` (as ``gearsym continue``)."""
    t0 = time.perf_counter()
    br = gearsym.continuation(system, name, lo, hi, progress=False)
    d = br.to_dict()
    return {"points": [{"value": p["value"], "rattle_state": p["rattle_state"], "ppv": p["max"] - p["min"],
                        "stability": p["stability"], "bifurcation": p.get("bifurcation")} for p in d["points"]],
            "bifurcations": [{"type": b["type"], "value": b["value"], "surface": b.get("surface")}
                             for b in d["bifurcations"]],
            "stop_reason": d["stop_reason"], "complete": bool(d.get("complete")),
            "wall_s": round(time.perf_counter() - t0, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--param", required=True, help="parameter swept (declared units)")
    parser.add_argument("--values", required=True, help="comma-separated values")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="other overrides")
    parser.add_argument("--continue", dest="cont", help="FROM,TO: also continue the orbit over this range")
    parser.add_argument("--transient", type=int, default=200, help="periods discarded before classifying")
    parser.add_argument("--keep", type=int, default=100, help="periods classified")
    parser.add_argument("--lyapunov-periods", type=int, default=400, help="periods of the Lyapunov average")
    parser.add_argument("--out", default="out/liu_sweeps", help="output folder")
    args = parser.parse_args()
    extra = {k: float(v) for k, v in (s.split("=", 1) for s in args.set)}
    system = gearsym.load_scene(SCENE, **extra).compile()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    samples = []
    for v in (float(s) for s in args.values.split(",")):
        p = {args.param: v}
        s = orbit_sample(system, p)
        if "failed" in s:
            s = {**simulated_sample(system, p, args.transient, args.keep, args.lyapunov_periods),
                 "orbit": s["failed"]}
        s["value"] = v
        samples.append(s)
        extra_txt = (f", {s['poincare_points']} Poincare point(s), lambda_1 = {s['lyapunov']:.4g} +- "
                     f"{s['lyapunov_error']:.2g} 1/s ({s['orbit']})" if s["method"] == "simulation" else "")
        print(f"{args.param} = {v:g}: {s['method']}, rattle state {s['rattle_state']}, ppv {s['ppv'] * 1e3:.4f} mrad, "
              f"{s['kind']}{extra_txt}", flush=True)
    result = {"param": args.param, "set": extra, "samples": samples}
    if args.cont:
        lo, hi = (float(x) for x in args.cont.split(","))
        result["branch"] = continued(system, args.param, lo, hi)
        b = result["branch"]
        print(f"continuation {lo:g} -> {hi:g}: {len(b['points'])} orbits, {b['stop_reason']}; "
              + ", ".join(f"{x['type']} at {x['value']:.5g}" for x in b["bifurcations"]), flush=True)
    (out / "liu_sweeps.json").write_text(json.dumps(result, indent=1, default=lambda o: None if isinstance(
        o, float) and not math.isfinite(o) else str(o)))
    print(f"wrote {out / 'liu_sweeps.json'}")


if __name__ == "__main__":
    main()
