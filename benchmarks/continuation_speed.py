"""Full frequency response of the benchmark scene: continuation vs. brute-force sweeps.

The response curve of ``scenes/kahraman_singh.toml`` (defaults) for Omega in
[0.6, 1.4], computed

* by ``gearsym.continuation`` (one call: pseudo-arclength on the shooting residual,
  both turning points passed, the unstable branch included, folds and grazings
  located), and
* the way users compute it today: brute-force sweeps up AND down (integrate to
  steady state at each Omega from the previous value's final state), with scipy
  ``solve_ivp`` (DOP853, the Python right-hand side of ``benchmarks/peers.py``), and
  for comparison with the gearsym engine (``System.simulate``) doing the same sweeps.

"The same accuracy": the sweeps' Omega step (default 0.01) puts the jumps within
+-0.005 of the truth (the done-when of the continuation is 0.005), their integrator
tolerance and steady-state criterion keep the peak-to-peak error below 1e-4 (both
measured here against tight-tolerance shooting orbits).  The continuation gets the
jumps to ~1e-9 and the unstable branch, which no sweep gives.

Usage::

    .venv/bin/python benchmarks/continuation_speed.py [--out out/bench] [--step 0.01] [--rounds 3]

Writes ``OUT/continuation_speed.json`` and ``OUT/continuation_speed.png``, prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
for _p in (ROOT, HERE):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

from c_reference import CTimer, bare_c_loop, interleaved  # noqa: E402
from peers import python_rhs  # noqa: E402

import gearsym  # noqa: E402
from gearsym.analysis.periodic import shoot  # noqa: E402

SCENE = ROOT / "scenes" / "kahraman_singh.toml"
RANGE = (0.6, 1.4)


def scipy_steady(params, x, rtol, atol, block=50, max_periods=3000, tol=1e-7):
    """Steady state with scipy: blocks of forcing periods until the Poincare point repeats."""
    rhs = python_rhs(params)
    T = 2 * np.pi / params["Omega"]
    n = 0
    while n < max_periods:
        s = solve_ivp(rhs, (0.0, block * T), x, method="DOP853", rtol=rtol, atol=atol,
                      t_eval=[(block - 1) * T, block * T])
        prev, x = s.y[:, 0], s.y[:, 1]
        n += block
        if np.max(np.abs(x - prev)) < tol:
            break
    s = solve_ivp(rhs, (0.0, T), x, method="DOP853", rtol=rtol, atol=atol, t_eval=np.linspace(0, T, 1025))
    return s.y[:, -1], float(s.y[0].max()), float(s.y[0].min()), n


def gearsym_steady(system, params, x, rtol, atol, block=50, max_periods=3000, tol=1e-7):
    """The same with the gearsym engine."""
    n = 0
    while n < max_periods:
        tr = system.simulate(periods=block, x0=x, params=params, rtol=rtol, atol=atol,
                             t_out=np.array([block - 1, block]) * system.period(params))
        prev, x = tr.y[0], tr.x_final
        n += block
        if np.max(np.abs(x - prev)) < tol:
            break
    tr = system.simulate(periods=1, x0=x, params=params, rtol=rtol, atol=atol, n_out=1025)
    return tr.x_final, float(tr.y[:, 0].max()), float(tr.y[:, 0].min()), n


def sweeps(steady, base, grid, x0):
    out = {}
    for name, values in (("up", grid), ("down", grid[::-1])):
        x = np.asarray(x0, float)
        rows = []
        periods = 0
        for w in values:
            p = dict(base, Omega=float(w))
            x, hi, lo, n = steady(p, x)
            periods += n
            rows.append((float(w), hi, lo, *x))
        out[name] = np.array(rows)
        out[name + "_periods"] = periods
    return out


def jump_brackets(rows, threshold=0.05):
    ptp = rows[:, 1] - rows[:, 2]
    i = np.nonzero(np.abs(np.diff(ptp)) > threshold)[0]
    return [(float(rows[k, 0]), float(rows[k + 1, 0])) for k in i]


def reference_ptp(system, rows):
    """Tight-tolerance shooting orbit from each steady state (the reference peak-to-peak)."""
    ref = []
    for r in rows:
        try:
            o = shoot(system, params={"Omega": r[0]}, x0=r[3:], rtol=1e-12, atol=1e-14, tol=1e-10)
        except gearsym.ConvergenceError:
            ref.append(np.nan)
            continue
        lo, hi = o.extrema(0)
        ref.append(hi - lo)
    return np.array(ref)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/bench", help="output folder (default out/bench)")
    ap.add_argument("--step", type=float, default=0.01, help="Omega step of the sweeps (default 0.01)")
    ap.add_argument("--rtol", type=float, default=1e-8, help="sweep integrator rtol (default 1e-8; atol = rtol/100)")
    ap.add_argument("--rounds", type=int, default=3, help="timing rounds of the continuation (best is reported)")
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--no-sweeps", action="store_true", help="only the continuation and its C reference")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()[0] if hasattr(os, "getloadavg") else None

    system = gearsym.load_scene(SCENE).compile()
    base = {k: system.params[k] for k in ("zeta", "Fm", "Fa", "eps", "b")}

    # ------------------------------------------------------------ continuation
    times, cpu = [], []
    branch = None
    for _ in range(max(1, args.rounds)):
        t0, c0 = time.perf_counter(), time.process_time()
        branch = gearsym.continuation(system, "Omega", *RANGE, progress=False)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    assert branch is not None
    special = {b.type: [] for b in branch.bifurcations}
    for b in branch.bifurcations:
        special[b.type].append(b.value)
    # accuracy of the stable branch points against tight shooting
    sample = [p for p in branch.points if p.stable][::6]
    errs = []
    for p in sample:
        try:
            o = shoot(system, params={"Omega": p.value}, x0=p.x0, rtol=1e-12, atol=1e-14, tol=1e-10)
        except gearsym.ConvergenceError:  # next to a fold the reference Newton is ill-conditioned
            continue
        lo, hi = o.extrema(0)
        errs.append(abs((hi - lo) - p.peak_to_peak))
    cont = {"wall_s_best": min(times), "wall_s_all": times, "n_points": len(branch.points),
            "n_stable": int(np.sum(branch.stable)), "bifurcations": special,
            "ptp_error_max": float(max(errs)), "ptp_error_points": len(errs), "stop_reason": branch.stop_reason,
            "n_integrations": branch.info.get("n_integrations")}
    # the C reference: a bare C CVODE loop over the same generated model, 200 periods at the
    # continuation's tolerances; and the share of a continuation's wall time spent outside C
    c_ref = bare_c_loop(system, dict(base, Omega=0.9), rtol=float(branch.info["rtol"]),
                        atol=float(branch.info["atol"]), repeats=5)
    # (over all rounds: one continuation is 0.2-0.3 s, and the CPU clock's share moves by a few
    # per cent between single runs on this shared machine)
    shares = []
    with CTimer(system) as ct:
        for _ in range(max(1, args.rounds)):
            c0, cpu0 = ct.c_cpu_s, time.process_time()
            gearsym.continuation(system, "Omega", *RANGE, progress=False)
            shares.append(1.0 - (ct.c_cpu_s - c0) / max(time.process_time() - cpu0, 1e-300))
    inter = interleaved(system, dict(base, Omega=0.9), lambda: gearsym.continuation(system, "Omega", *RANGE,
                                                                                     progress=False),
                        rounds=max(3, args.rounds), rtol=float(branch.info["rtol"]), atol=float(branch.info["atol"]))
    cont.update({"interleaved": inter, "bare_c_loop_200_periods": c_ref, "ratio_to_bare_c_loop": cont["wall_s_best"] / c_ref["best_s"],
                 "cpu_s_best": min(cpu), "ratio_to_bare_c_loop_cpu": min(cpu) / c_ref["cpu_best_s"],
                 "outside_c_fraction": ct.outside_c_fraction, "outside_c_fraction_per_round": shares,
                 "outside_c_fraction_wall": ct.outside_c_fraction_wall, "c_calls": ct.c_calls // len(shares),
                 "targets": {"ratio_to_bare_c_loop": 20.0, "outside_c_fraction": 0.3}})
    print(f"interleaved with the bare C loop ({inter['rounds']} rounds, CPU): continuation / bare loop = "
          f"{inter['ratio_cpu_best']:.1f} (ratio of the best times; median of the rounds "
          f"{inter['ratio_cpu_median_of_rounds']:.1f}; target 20)")
    print(f"bare C loop (200 periods, rtol {c_ref['rtol']:g}, atol {c_ref['atol']:.2g}): {c_ref['best_s'] * 1e3:.1f} ms; "
          f"continuation / bare loop = {cont['ratio_to_bare_c_loop']:.1f} (target 20), in CPU time "
          f"{cont['ratio_to_bare_c_loop_cpu']:.1f}; outside C "
          f"{100 * ct.outside_c_fraction:.1f} % of {ct.cpu_s:.2f} s CPU over {len(shares)} runs (target < 30 %; "
          f"per run {min(shares) * 100:.1f}-{max(shares) * 100:.1f} %), {ct.c_calls // len(shares)} C calls per run; load "
          f"{os.getloadavg()[0]:.1f}")
    print(f"continuation: {cont['wall_s_best']:.2f} s (best of {len(times)}), {cont['n_points']} orbits, "
          f"max ptp error {cont['ptp_error_max']:.1e}, " + ", ".join(
              f"{k} at {', '.join(f'{v:.6f}' for v in vs)}" for k, vs in special.items()))

    # ------------------------------------------------------------ sweeps
    grid = np.round(np.arange(RANGE[0], RANGE[1] + 1e-9, args.step), 10)
    rtol, atol = args.rtol, args.rtol * 1e-2
    res = {}
    for name, steady in () if args.no_sweeps else (("scipy DOP853", lambda p, x: scipy_steady(p, x, rtol, atol)),
                         ("gearsym simulate", lambda p, x: gearsym_steady(system, p, x, rtol, atol))):
        t0 = time.perf_counter()
        sw = sweeps(steady, base, grid, system.x0)
        wall = time.perf_counter() - t0
        ref_up = reference_ptp(system, sw["up"])
        ref_dn = reference_ptp(system, sw["down"])
        err = max(np.nanmax(np.abs(sw["up"][:, 1] - sw["up"][:, 2] - ref_up)),
                  np.nanmax(np.abs(sw["down"][:, 1] - sw["down"][:, 2] - ref_dn)))
        jumps = {"up": jump_brackets(sw["up"]), "down": jump_brackets(sw["down"])}
        all_special = np.array([v for vs in special.values() for v in vs])
        jump_err = [float(np.min(np.abs(all_special - 0.5 * (a + b)))) for k in ("up", "down") for a, b in jumps[k]]
        res[name] = {"wall_s": wall, "n_steady_states": 2 * len(grid),
                     "periods_integrated": int(sw["up_periods"] + sw["down_periods"]),
                     "ptp_error_max": float(err), "jumps": jumps,
                     "jump_midpoint_vs_located": jump_err,
                     "ratio_to_continuation": wall / cont["wall_s_best"]}
        np.savez(out / f"continuation_speed_{name.split()[0]}_sweeps.npz", up=sw["up"], down=sw["down"])
        print(f"{name} sweeps up+down ({2 * len(grid)} steady states, step {args.step}, rtol {rtol:g}): "
              f"{wall:.1f} s = {wall / cont['wall_s_best']:.1f} x the continuation; max ptp error {err:.1e}; "
              f"jumps {jumps}")

    data = {
        "scene": str(SCENE.relative_to(ROOT)), "range": RANGE, "step": args.step, "sweep_rtol": rtol,
        "sweep_atol": atol, "continuation": cont, "sweeps": res,
        "machine": {"platform": platform.platform(), "python": sys.version.split()[0],
                    "loadavg_start": load0,
                    "loadavg_end": os.getloadavg()[0] if hasattr(os, "getloadavg") else None},
        "note": ("sweeps give the stable attractors only, with jumps located to +-step/2; the continuation "
                 "also gives the unstable branch and the fold / grazing points themselves"),
    }
    (out / "continuation_speed.json").write_text(json.dumps(data, indent=1))
    print(f"wrote {out / 'continuation_speed.json'}")
    if not args.no_plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [2, 1]})
        branch.plot(a1, quantity="ptp", label="gearsym.continuation", legend=False)
        if not args.no_sweeps:
            sw = np.load(out / "continuation_speed_scipy_sweeps.npz")
            a1.plot(sw["up"][:, 0], sw["up"][:, 1] - sw["up"][:, 2], ">", ms=3, mfc="none", color="C1",
                    label="scipy sweep up")
            a1.plot(sw["down"][:, 0], sw["down"][:, 1] - sw["down"][:, 2], "<", ms=3, mfc="none", color="C2",
                    label="scipy sweep down")
        from gearsym.analysis.continuation import add_legend

        add_legend(a1, loc="upper right")
        a1.set_ylabel("peak-to-peak of x")
        names = ["bare C loop (200 periods)", "gearsym.continuation"] + list(res)
        walls = [c_ref["best_s"], cont["wall_s_best"]] + [res[k]["wall_s"] for k in res]
        a2.barh(names, walls, color=["C7", "C0", "C1", "C2"][:len(walls)])
        for i, w in enumerate(walls):
            a2.text(w, i, f" {w:.3g} s", va="center", fontsize=8)
        a2.set_xlabel("wall time of the full response curve [s]")
        a2.set_xlim(0, max(walls) * 1.3)
        fig.tight_layout()
        fig.savefig(out / "continuation_speed.png", dpi=100)
        print(f"wrote {out / 'continuation_speed.png'}")


if __name__ == "__main__":
    main()
