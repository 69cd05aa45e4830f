"""Speed of periodic-orbit solves and of a 100 x 100 stability map, against scipy.

What is timed (all in one run, on this machine):

1. **One orbit solve** on the benchmark scene (scenes/kahraman_singh.toml, Omega = 0.9,
   impacting orbit): gearsym shooting from the scene's initial state (20 transient
   periods + damped Newton with the engine's variational equations), gearsym shooting
   from a guess 1e-3 away, gearsym harmonic balance (32 harmonics), and the same
   orbit by **scipy**: Newton shooting with ``solve_ivp`` (DOP853) on a hand-written
   right-hand side with contact events and the variational equations (saltation at
   the events), from the same 1e-3 guess.
2. **A 100 x 100 stability map** (max |Floquet multiplier|):
   * Meissner (scenes/meissner.toml, T x a): the exact matrix-exponential path
     (vectorised) and the numerical monodromy (shooting, engine variational
     equations, all local cores);
   * the nonlinear benchmark (Omega x Fa, periodic orbit by shooting at every point,
     all local cores);
   * **scipy** computing the same multipliers with ``solve_ivp`` variational
     equations on a random subset of the grid, scaled to the whole grid: for
     Meissner the monodromy (restart at the stiffness jump); for the backlash model
     only the monodromy at gearsym's orbit (events + saltation), i.e. a lower bound of
     what a scipy map would cost (no Newton).  The subset's multipliers are compared
     with gearsym's.

Usage::

    .venv/bin/python benchmarks/orbit_speed.py [--out DIR] [--n 100] [--subset 60] [--workers N]

Writes ``DIR/orbit_speed.json`` (default ``out/bench``) and prints a table.
``OPENBLAS_NUM_THREADS`` is set to 1 (unless set): on a loaded machine OpenBLAS
threads make the small dense algebra here (2x2 .. 500x500) several times slower,
for scipy and gearsym alike.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gearsym  # noqa: E402
from gearsym.analysis.periodic import harmonic_balance  # noqa: E402
from gearsym.analysis.sweeps import stability_map  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from c_reference import CTimer, bare_c_loop, interleaved  # noqa: E402

KS = ROOT / "scenes" / "kahraman_singh.toml"
MEISSNER = ROOT / "scenes" / "meissner.toml"
P_KS = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}
P_ME = {"zeta": 0.02, "w0": 1.0, "d": 0.5}


def _timeit(fn, repeats: int = 5) -> dict:
    times, cpu = [], []
    out = None
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return {"best_s": min(times), "median_s": statistics.median(times), "cpu_best_s": min(cpu), "result": out}


# ----------------------------------------------------------- scipy peers
def ks_flow(p, x0, T, variational=True):
    """Hand-written backlash oscillator: DOP853 per contact mode, events, saltation."""
    b, W = p["b"], p["Omega"]

    def acc(t, x, v, mode):
        f = x - b if mode == 1 else (x + b if mode == -1 else 0.0)
        return -2 * p["zeta"] * v - (1 + p["eps"] * np.cos(W * t)) * f + p["Fm"] + p["Fa"] * W**2 * np.cos(W * t)

    y = np.concatenate([x0, np.eye(2).ravel()]) if variational else np.asarray(x0, float)
    mode = 1 if y[0] > b else (-1 if y[0] < -b else 0)
    t = 0.0
    while t < T:
        def rhs(tt, yy, mode=mode):
            a = acc(tt, yy[0], yy[1], mode)
            if not variational:
                return [yy[1], a]
            k = (1 + p["eps"] * np.cos(W * tt)) if mode else 0.0
            J = np.array([[0.0, 1.0], [-k, -2 * p["zeta"]]])
            return np.concatenate([[yy[1], a], (J @ yy[2:].reshape(2, 2)).ravel()])

        if mode == 0:
            e1 = lambda tt, yy: yy[0] - b  # noqa: E731
            e1.terminal, e1.direction = True, 1
            e2 = lambda tt, yy: yy[0] + b  # noqa: E731
            e2.terminal, e2.direction = True, -1
            events = [e1, e2]
        else:
            e = (lambda tt, yy: yy[0] - b) if mode == 1 else (lambda tt, yy: yy[0] + b)
            e.terminal, e.direction = True, -mode
            events = [e]
        s = solve_ivp(rhs, (t, T), y, method="DOP853", rtol=1e-10, atol=1e-12, events=events)
        y, t = s.y[:, -1].copy(), s.t[-1]
        if s.status == 1:
            new = (1 if y[0] > 0 else -1) if mode == 0 else 0
            if variational:  # continuous field (always-on damping): saltation = identity
                pass
            mode = new
    return (y[:2], y[2:].reshape(2, 2)) if variational else (y, None)


def scipy_shooting(p, x0, tol=1e-10, max_iter=30):
    T = 2 * np.pi / p["Omega"]
    x = np.asarray(x0, float)
    for it in range(max_iter):
        xT, M = ks_flow(p, x, T)
        r = xT - x
        if np.max(np.abs(r)) < tol:
            return x, M, it
        x = x - np.linalg.solve(M - np.eye(2), r)
    return x, M, max_iter


def meissner_monodromy_scipy(p):
    T, d = p["T"], p["d"]

    def rhs(sign):
        def f(t, y):
            A = np.array([[0.0, 1.0], [-p["w0"] ** 2 * (1 + sign * p["a"]), -2 * p["zeta"] * p["w0"]]])
            return (A @ y.reshape(2, 2)).ravel()
        return f

    y = np.eye(2).ravel()
    y = solve_ivp(rhs(+1), (0, d * T), y, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
    y = solve_ivp(rhs(-1), (d * T, T), y, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
    return y.reshape(2, 2)


# -------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--n", type=int, default=100, help="grid points per axis (default 100)")
    ap.add_argument("--subset", type=int, default=60, help="grid points scipy computes (default 60)")
    ap.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--orbit-only", action="store_true", help="only the one-orbit timings (no maps)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    res: dict = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                             "load_start": os.getloadavg()[0]}}
    import xarray  # noqa: F401  (imported before timing: its first import probes dask, seconds)

    ks = gearsym.load_scene(KS).compile()
    ks_scene = gearsym.load_scene(KS)
    me_scene = gearsym.load_scene(MEISSNER)
    me_scene.compile()

    # ------------------------------------------------------------ one orbit
    ref = ks.periodic_orbit()
    guess = ref.x0 + 1e-3
    o_cold = _timeit(lambda: ks.periodic_orbit(), args.repeats)
    o_warm = _timeit(lambda: ks.periodic_orbit(x0=guess, transient=0), args.repeats)
    o_hbm = _timeit(lambda: harmonic_balance(ks, harmonics=32, initial_guess="simulation"), args.repeats)
    o_sci = _timeit(lambda: scipy_shooting(P_KS, guess), max(1, args.repeats // 2))
    x_sci, M_sci, it_sci = o_sci["result"]
    mu_sci = np.sort(np.abs(np.linalg.eigvals(M_sci)))
    res["orbit"] = {
        "scene": "kahraman_singh, Omega = 0.9 (impacting)",
        "gearsym_shooting_from_scene_s": o_cold["best_s"],
        "gearsym_shooting_from_scene_median_s": o_cold["median_s"],
        "gearsym_shooting_warm_s": o_warm["best_s"],
        "gearsym_shooting_warm_iterations": o_warm["result"].iterations,
        "gearsym_hbm_H32_s": o_hbm["best_s"],
        "scipy_shooting_warm_s": o_sci["best_s"],
        "scipy_shooting_iterations": it_sci,
        "ratio_scipy_to_gearsym_warm": o_sci["best_s"] / o_warm["best_s"],
        "x0_difference_scipy_vs_gearsym": float(np.max(np.abs(x_sci - ref.x0))),
        "max_multiplier_difference": float(abs(mu_sci[-1] - ref.max_multiplier)),
        "hbm_peak_to_peak_rel_error": abs(o_hbm["result"].peak_to_peak() - ref.peak_to_peak()) / ref.peak_to_peak(),
    }
    # the C reference: a bare C CVODE loop over the same generated model (one driver call, 200 periods)
    # at the solve's tolerances (shooting's defaults rtol 1e-11, atol 1e-13)
    c_ref = bare_c_loop(ks, P_KS, rtol=1e-11, atol=1e-13, repeats=max(args.repeats, 5))
    # the share outside C pooled over 7 rounds of 20 solves (one solve is ~1 ms: the CPU clock's
    # share of a handful of solves moves by several per cent on this shared machine)
    shares = []
    with CTimer(ks) as ct:
        for _ in range(7):
            c0, cpu0 = ct.c_cpu_s, time.process_time()
            for _ in range(20):
                ks.periodic_orbit(x0=guess, transient=0)
            shares.append(1.0 - (ct.c_cpu_s - c0) / max(time.process_time() - cpu0, 1e-300))
    inter = interleaved(ks, P_KS, lambda: [ks.periodic_orbit(x0=guess, transient=0) for _ in range(10)],
                        rounds=max(7, args.repeats), rtol=1e-11, atol=1e-13)
    for k in ("fn_cpu_best_s", "fn_wall_best_s"):
        inter[k] /= 10  # ten solves per round (a single solve is too short for the CPU clock)
    for k in ("ratio_cpu_best", "ratio_wall_best", "ratio_cpu_median_of_rounds"):
        inter[k] /= 10
    res["orbit"].update({
        "interleaved": inter,
        "bare_c_loop_200_periods": c_ref,
        "ratio_warm_solve_to_bare_c_loop": o_warm["best_s"] / c_ref["best_s"],
        "ratio_warm_solve_median_to_bare_c_loop_median": o_warm["median_s"] / c_ref["median_s"],
        "ratio_warm_solve_to_bare_c_loop_cpu": o_warm["cpu_best_s"] / c_ref["cpu_best_s"],
        "warm_solve_outside_c_fraction": ct.outside_c_fraction,
        "warm_solve_outside_c_fraction_wall": ct.outside_c_fraction_wall,
        "warm_solve_outside_c_fraction_per_round": shares,
        "warm_solve_c_calls": ct.c_calls / 140,
        "targets": {"ratio_warm_solve_to_bare_c_loop": 0.06, "warm_solve_outside_c_fraction": 0.3},
    })
    print(f"interleaved with the bare C loop ({inter['rounds']} rounds of 10 solves, CPU): one orbit / bare loop = "
          f"{inter['ratio_cpu_best']:.3f} (ratio of the best times; median of the rounds "
          f"{inter['ratio_cpu_median_of_rounds']:.3f}; target 0.06)")
    print(f"one orbit (warm, Omega 0.9): {o_warm['best_s'] * 1e3:.2f} ms best, {o_warm['median_s'] * 1e3:.2f} ms "
          f"median; bare C loop (200 periods): {c_ref['best_s'] * 1e3:.2f} ms best; ratio "
          f"{res['orbit']['ratio_warm_solve_to_bare_c_loop']:.3f} (target 0.06), in CPU time "
          f"{res['orbit']['ratio_warm_solve_to_bare_c_loop_cpu']:.3f}; outside C "
          f"{100 * ct.outside_c_fraction:.1f} % of the CPU time of 140 solves (target < 30 %; per round of 20 "
          f"{100 * min(shares):.1f}-{100 * max(shares):.1f} %), {ct.c_calls / 140:.0f} C calls per solve; load "
          f"{os.getloadavg()[0]:.1f}")
    if args.orbit_only:
        (out / "orbit_speed.json").write_text(json.dumps(res, indent=1, default=float))
        print(f"wrote {out / 'orbit_speed.json'}")
        return 0

    # ------------------------------------------------------------- the maps
    n = args.n
    me_x, me_y = ("T", 1.0, 10.0, n), ("a", 0.0, 0.8, n)
    t = time.perf_counter()
    ds_exact = stability_map(me_scene, me_x, me_y, method="exact")
    t_exact = time.perf_counter() - t
    t = time.perf_counter()
    ds_num = stability_map(me_scene, me_x, me_y, method="shooting", workers=args.workers)
    t_num = time.perf_counter() - t
    dnum = np.nanmax(np.abs(ds_num["max_multiplier"].values - ds_exact["max_multiplier"].values)
                     / ds_exact["max_multiplier"].values)
    ks_x, ks_y = ("Omega", 0.6, 1.6, n), ("Fa", 0.02, 0.2, n)
    t = time.perf_counter()
    ds_ks = stability_map(ks_scene, ks_x, ks_y, method="shooting", workers=args.workers)
    t_ks = time.perf_counter() - t
    # one process, on a coarse sub-grid with the same ranges, scaled to n x n (per-core comparison)
    ns = max(2, n // 5)
    t = time.perf_counter()
    stability_map(me_scene, ("T", 1.0, 10.0, ns), ("a", 0.0, 0.8, ns), method="shooting", workers=1)
    t_num_serial = (time.perf_counter() - t) * (n * n) / (ns * ns)
    t = time.perf_counter()
    stability_map(ks_scene, ("Omega", 0.6, 1.6, ns), ("Fa", 0.02, 0.2, ns), method="shooting", workers=1)
    t_ks_serial = (time.perf_counter() - t) * (n * n) / (ns * ns)

    rng = np.random.default_rng(0)
    sub = rng.choice(n * n, size=min(args.subset, n * n), replace=False)
    Ts, As = ds_exact["T"].values, ds_exact["a"].values
    t = time.perf_counter()
    diffs = []
    for k in sub:
        j, i = divmod(int(k), n)
        M = meissner_monodromy_scipy(dict(P_ME, T=Ts[i], a=As[j]))
        diffs.append(abs(np.max(np.abs(np.linalg.eigvals(M))) - ds_exact["max_multiplier"].values[j, i]))
    t_sci_me = (time.perf_counter() - t) / len(sub) * n * n
    Om, Fa = ds_ks["Omega"].values, ds_ks["Fa"].values
    t_sub = 0.0
    diffs_ks = []
    for k in sub:
        j, i = divmod(int(k), n)
        if not ds_ks["converged"].values[j, i]:
            continue
        p = dict(P_KS, Omega=float(Om[i]), Fa=float(Fa[j]))
        o = ks.periodic_orbit(params={"Omega": float(Om[i]), "Fa": float(Fa[j])}, transient=300)
        t = time.perf_counter()
        _, M = ks_flow(p, o.x0, 2 * np.pi / p["Omega"])
        t_sub += time.perf_counter() - t
        diffs_ks.append(abs(np.max(np.abs(np.linalg.eigvals(M))) - ds_ks["max_multiplier"].values[j, i]))
    t_sci_ks = t_sub / max(1, len(diffs_ks)) * n * n
    res["map"] = {
        "grid": f"{n} x {n}",
        "workers": args.workers or os.cpu_count(),
        "meissner_exact_vectorised_s": t_exact,
        "meissner_numerical_monodromy_s": t_num,
        "meissner_numerical_vs_exact_max_rel_diff": float(dnum),
        "meissner_scipy_variational_scaled_s": t_sci_me,
        "meissner_scipy_subset_points": int(len(sub)),
        "meissner_scipy_max_abs_diff": float(np.max(diffs)),
        "meissner_numerical_one_process_scaled_s": t_num_serial,
        "ratio_scipy_to_gearsym_numerical": t_sci_me / t_num,
        "ratio_scipy_to_gearsym_numerical_one_process": t_sci_me / t_num_serial,
        "ratio_scipy_to_gearsym_exact": t_sci_me / t_exact,
        "ks_orbit_map_s": t_ks,
        "ks_orbit_map_failed_points": int(ds_ks.attrs["n_failed"]),
        "ks_scipy_monodromy_only_scaled_s": t_sci_ks,
        "ks_scipy_subset_points": len(diffs_ks),
        "ks_scipy_max_abs_diff": float(np.max(diffs_ks)) if diffs_ks else None,
        "ks_orbit_map_one_process_scaled_s": t_ks_serial,
        "ratio_scipy_monodromy_only_to_gearsym_orbits": t_sci_ks / t_ks,
        "ratio_scipy_monodromy_only_to_gearsym_orbits_one_process": t_sci_ks / t_ks_serial,
    }
    res["machine"]["load_end"] = os.getloadavg()[0]
    (out / "orbit_speed.json").write_text(json.dumps(res, indent=1))
    o, m = res["orbit"], res["map"]
    print(f"one orbit (K&S, Omega=0.9): gearsym shooting {o['gearsym_shooting_from_scene_s'] * 1e3:.1f} ms from the "
          f"scene's state, {o['gearsym_shooting_warm_s'] * 1e3:.2f} ms from a 1e-3 guess "
          f"({o['gearsym_shooting_warm_iterations']} it); hbm H=32 {o['gearsym_hbm_H32_s'] * 1e3:.1f} ms; "
          f"scipy shooting {o['scipy_shooting_warm_s'] * 1e3:.0f} ms (x{o['ratio_scipy_to_gearsym_warm']:.0f})")
    print(f"{m['grid']} map, Meissner: exact {m['meissner_exact_vectorised_s']:.2f} s, numerical monodromy "
          f"{m['meissner_numerical_monodromy_s']:.1f} s (max rel diff {m['meissner_numerical_vs_exact_max_rel_diff']:.1e}), "
          f"scipy (scaled from {m['meissner_scipy_subset_points']} points) {m['meissner_scipy_variational_scaled_s']:.0f} s "
          f"(x{m['ratio_scipy_to_gearsym_numerical']:.0f} vs numerical on {m['workers']} processes, "
          f"x{m['ratio_scipy_to_gearsym_numerical_one_process']:.0f} per process, "
          f"x{m['ratio_scipy_to_gearsym_exact']:.0f} vs exact)")
    print(f"{m['grid']} map, backlash orbits: gearsym {m['ks_orbit_map_s']:.1f} s ({m['ks_orbit_map_failed_points']} failed); "
          f"scipy monodromy alone (scaled) {m['ks_scipy_monodromy_only_scaled_s']:.0f} s "
          f"(x{m['ratio_scipy_monodromy_only_to_gearsym_orbits']:.0f}; per process "
          f"x{m['ratio_scipy_monodromy_only_to_gearsym_orbits_one_process']:.1f}), multiplier diff "
          f"{m['ks_scipy_max_abs_diff']:.1e}")
    print(f"wrote {out / 'orbit_speed.json'} (load {res['machine']['load_start']:.1f} -> {res['machine']['load_end']:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
