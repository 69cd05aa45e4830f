"""How the cost of every analysis grows with the model: chains of meshes and planetary sets.

Models:

* **chain N**: N + 1 unit inertias in a line, neighbouring pairs coupled by a mesh with
  backlash (half backlash 1) and stiffness ``1 + 0.2 cos(0.9 t)``, the first inertia
  tied to ground by a spring and damper, a load force on the last one (dimensionless;
  2(N + 1) states).  N = 1, 2, 4, 8, 16, 32, 50, 64 by default: 4 ... 130 states.
* **planetary N**: ``scenes/planetary_n<N>.toml`` (Lin & Parker's set, 6(N + 3)
  states, 4N contact surfaces), and the 4-planet contact-loss scene (``planetary_n4cl``).

Per model, in fresh processes (so that each peak memory belongs to one model):

1. *build*: load, derive the equations (sympy), cold compile (code generation + gcc,
   a fresh ``GEARSYM_GENERATED`` folder); peak RSS of the process and of gcc;
2. *run*, once per CVODE nonlinear solver (``newton`` and ``fixedpoint``), on the cached
   build: simulate 100 forcing periods; one forcing period plain and with the
   monodromy (variational equations, block-diagonal Newton solve) from the state after
   those 100 periods -- the ratio is the issue's measure, to compare with ``n + 1``; up to
   ``--dense-max`` states also the monodromy with SUNDIALS' dense solver of the whole
   ``(n + n^2)`` system (the formulation before the block-diagonal solver), as the peer;
   one periodic-orbit solve by shooting from the scene's initial state (20 transient
   periods + Newton); one continuation step (``continuation(..., orbit=<that orbit>,
   max_points=2)``: the corrector at the start, one predictor-corrector step and the
   bifurcation tests between the two points).  The peak RSS of each phase is measured
   by resetting the process's high-water mark (``/proc/self/clear_refs``) before it.

Times are best-of-repeats wall seconds (repeats until 0.3 s or 5 runs) with the CPU
seconds of the same runs; on this shared 2-core machine compare within a run.
Growth exponents are least-squares slopes of log(cost) against log(states) over the
chains with at least 10 states.

Usage::

    .venv/bin/python benchmarks/scaling.py                    # -> out/scaling/scaling.{json,png}
    .venv/bin/python benchmarks/scaling.py --docs             # also docs/performance/ + docs/performance.md
    .venv/bin/python benchmarks/scaling.py --chain 1,4,16 --planetary 4 --solvers newton
    .venv/bin/python benchmarks/scaling.py --render out/scaling/scaling.json --docs   # plot/docs from JSON
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CHAIN = [1, 2, 4, 8, 16, 32, 50, 64]
DEFAULT_PLANETARY = ["3", "4", "5", "6", "4cl"]
BEGIN, END = "<!-- SCALING:BEGIN -->", "<!-- SCALING:END -->"


# ----------------------------------------------------------------------- models
def chain_model(N: int, folder: Path) -> Path:
    """Write the chain of N meshes (model and scene) into ``folder``; return the scene."""
    L = ["[model]", f'name = "chain{N}"', 'time_unit = "1"', ""]
    for i in range(N + 1):
        L += [f"[coordinates.q{i}]", 'unit = "1"', f'velocity = "w{i}"', ""]
    L += ["[parameters]", "zeta = 0.05", "eps = 0.2", "b = 1.0", "Omega = 0.9", "Fm = 0.1", "kg = 1.0", ""]
    L += ["[forcing]", 'period = "2*pi/Omega"', ""]
    for i in range(N + 1):
        L += [f"[elements.J{i}]", 'type = "inertia"', f'coordinate = "q{i}"', 'value = "1"', ""]
    L += ["[elements.ground]", 'type = "spring"', 'deflection = "q0"', 'stiffness = "kg"', ""]
    L += ["[elements.ground_d]", 'type = "damper"', 'deflection = "q0"', 'coefficient = "2*zeta"', ""]
    for i in range(N):
        L += [f"[elements.m{i}]", 'type = "mesh"', f'deflection = "q{i} - q{i + 1}"',
              'stiffness = "1 + eps*cos(Omega*t)"', 'damping = "2*zeta"', 'backlash = "b"', ""]
    L += ["[elements.load]", 'type = "force"', f'coordinate = "q{N}"', 'value = "-Fm"', ""]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"chain{N}.toml").write_text("\n".join(L))
    scene = folder / f"chain{N}_scene.toml"
    init = "\n".join(f"q{i} = {-1.1 * i}" for i in range(N + 1))
    scene.write_text(f'[scene]\nname = "chain{N}"\nmodel = "chain{N}.toml"\n\n[initial]\n{init}\n')
    return scene


#: per family: tolerances of simulate/monodromy and of the orbit, continuation parameter
FAMILY = {
    "chain": {"rtol": 1e-8, "atol": 1e-10, "orbit": {"rtol": 1e-11, "atol": 1e-13}, "param": "Omega",
              "cont": {"rtol": 1e-10}},
    # SI states of 1e-9 .. 1e-4 m; atol 1e-13 as shooting's default: the variational states share
    # atol, and 1e-16 made one monodromy 30x dearer (its entries have units of s and 1/s)
    "planetary": {"rtol": 1e-8, "atol": 1e-14, "orbit": {"rtol": 1e-11, "atol": 1e-13}, "param": "f_m",
                  "cont": {"rtol": 1e-10, "atol": 1e-13}},
}


def case_scene(case: str, work: Path) -> tuple[str, Path]:
    """Family and scene file of a case name (``chain16``, ``planetary4``, ``planetary4cl``)."""
    m = re.fullmatch(r"chain(\d+)", case)
    if m:
        return "chain", chain_model(int(m.group(1)), work / "models")
    m = re.fullmatch(r"planetary(\d+)(cl)?", case)
    if m:
        name = f"planetary_n{m.group(1)}" + ("_contact_loss" if m.group(2) else "")
        path = ROOT / "scenes" / f"{name}.toml"
        if not path.exists():
            raise SystemExit(f"no scene {path} (examples/make_planetary.py {m.group(1)} writes it)")
        return "planetary", path
    raise SystemExit(f"unknown case '{case}'")


# ---------------------------------------------------------------------- measuring
def _hwm_mb() -> float:
    """Peak resident memory of this process since the last reset (MB)."""
    try:
        text = Path("/proc/self/status").read_text()
        return int(re.search(r"VmHWM:\s+(\d+)", text).group(1)) / 1024  # type: ignore[union-attr]
    except (OSError, AttributeError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _rss_mb() -> float:
    try:
        text = Path("/proc/self/status").read_text()
        return int(re.search(r"VmRSS:\s+(\d+)", text).group(1)) / 1024  # type: ignore[union-attr]
    except (OSError, AttributeError):
        return math.nan


def _reset_hwm() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _timed(fn: Callable[[], Any], budget: float = 0.3, max_repeats: int = 5) -> dict[str, Any]:
    """Best-of-repeats wall and CPU seconds of ``fn`` and the peak RSS while it ran."""
    walls, cpus, out = [], [], None
    reset = _reset_hwm()
    base = _rss_mb()
    while True:
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
        if sum(walls) >= budget or len(walls) >= max_repeats:
            break
    return {"best_s": min(walls), "median_s": statistics.median(walls), "cpu_best_s": min(cpus),
            "repeats": len(walls), "peak_rss_mb": _hwm_mb() if reset else None,
            "rss_before_mb": base, "result": out}


def _strip(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if k != "result"}


# -------------------------------------------------------------------- child: build
def child_build(case: str, work: Path) -> dict[str, Any]:
    """Derive and cold-compile one case into a fresh folder (this process only)."""
    t_imp = time.perf_counter()
    import gearsym

    import_s = time.perf_counter() - t_imp
    family, scene_path = case_scene(case, work)
    gen_dir = work / "generated" / case
    if gen_dir.exists():
        shutil.rmtree(gen_dir)
    t = time.perf_counter()
    scene = gearsym.load_scene(scene_path)
    load_s = time.perf_counter() - t
    t, c = time.perf_counter(), time.process_time()
    model = scene.model
    derive_s, derive_cpu_s = time.perf_counter() - t, time.process_time() - c
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    t, c = time.perf_counter(), time.process_time()
    system = scene.compile(generated_dir=gen_dir)
    compile_s, compile_cpu_s = time.perf_counter() - t, time.process_time() - c
    ch2 = resource.getrusage(resource.RUSAGE_CHILDREN)
    gcc_cpu_s = (ch2.ru_utime + ch2.ru_stime) - (ch.ru_utime + ch.ru_stime)
    gen = system.generated
    c_lines = sum(1 for _ in open(Path(gen.directory) / "gs_model.c", encoding="utf-8"))
    return {"case": case, "family": family, "scene": str(scene_path), "states": gen.nx,
            "surfaces": gen.nsw, "params": len(gen.param_names), "n_ops_rhs": gen.n_ops.get("gs_rhs"),
            "n_ops_jac": gen.n_ops.get("gs_jac"), "c_lines": c_lines, "import_s": import_s, "load_s": load_s,
            "derive_s": derive_s, "compile_s": compile_s, "cc_s": gen.compile_seconds,
            "derive_cpu_s": derive_cpu_s, "compile_cpu_s": compile_cpu_s + gcc_cpu_s, "gcc_cpu_s": gcc_cpu_s,
            "codegen_s": compile_s - gen.compile_seconds, "cold_s": derive_s + compile_s,
            "n_switching_symbolic": len(model.switching),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "gcc_peak_rss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
            "generated_dir": str(gen_dir)}


# ---------------------------------------------------------------------- child: run
def child_run(case: str, work: Path, solver: str, dense_max: int, orbit_max: int) -> dict[str, Any]:
    """Simulate, monodromy, orbit, continuation step on the cached build, one solver."""
    import functools

    import numpy as np

    import gearsym
    from gearsym.analysis.continuation import continuation
    from gearsym.facade import System

    family, scene_path = case_scene(case, work)
    fam = FAMILY[family]
    scene = gearsym.load_scene(scene_path)
    system = scene.compile(generated_dir=work / "generated" / case)
    if not system.generated.cached:
        raise SystemExit(f"{case}: the build was not cached (run the build step first)")
    # every integration of this process (also those inside shooting and continuation) uses
    # the solver under test: System.simulate's nonlinear= bound on this instance
    system.simulate = functools.partial(System.simulate, system, nonlinear=solver)  # type: ignore[method-assign]
    n = system.generated.nx
    T = system.period()
    rtol, atol = fam["rtol"], fam["atol"]
    out: dict[str, Any] = {"case": case, "family": family, "solver": solver, "states": n, "period": T,
                           "rtol": rtol, "atol": atol, "rss_loaded_mb": _rss_mb()}
    system.simulate(periods=1, rtol=rtol, atol=atol, n_out=2)  # warm-up
    r = _timed(lambda: system.simulate(periods=100, rtol=rtol, atol=atol, n_out=101))
    tr = r["result"]
    out["simulate100"] = {**_strip(r), "n_steps": tr.stats["n_steps"], "n_rhs": tr.stats["n_rhs"],
                          "n_events": tr.stats["n_events"],
                          "us_per_step": 1e6 * r["best_s"] / max(tr.stats["n_steps"], 1)}
    x1, t1 = tr.x_final, 100 * T

    def one(mono: bool, linsol: str = "auto", tols: tuple[float, float] = (rtol, atol)):
        return system.simulate(t0=t1, t_end=t1 + T, x0=x1, rtol=tols[0], atol=tols[1], n_out=2, monodromy=mono,
                               linear_solver=linsol)

    r = _timed(lambda: one(False))
    out["plain1"] = {**_strip(r), "n_steps": r["result"].stats["n_steps"]}
    r = _timed(lambda: one(True))
    M = r["result"].monodromy
    out["monodromy1"] = {**_strip(r), "n_steps": r["result"].stats["n_steps"],
                         "n_events": r["result"].stats["n_events"]}
    out["monodromy_ratio"] = out["monodromy1"]["best_s"] / out["plain1"]["best_s"]
    out["monodromy_ratio_cpu"] = out["monodromy1"]["cpu_best_s"] / max(out["plain1"]["cpu_best_s"], 1e-9)
    # the same at the orbit solve's (tighter) tolerances: the variational states share atol
    otol = (fam["orbit"]["rtol"], fam["orbit"]["atol"])
    rp = _timed(lambda: one(False, tols=otol))
    rm = _timed(lambda: one(True, tols=otol))
    out["plain1_orbit_tol"] = {**_strip(rp), "n_steps": rp["result"].stats["n_steps"]}
    out["monodromy1_orbit_tol"] = {**_strip(rm), "n_steps": rm["result"].stats["n_steps"]}
    out["monodromy_ratio_orbit_tol"] = rm["best_s"] / rp["best_s"]
    if solver == "newton" and n <= dense_max:
        r = _timed(lambda: one(True, "dense"), budget=0.3, max_repeats=3)
        Md = r["result"].monodromy
        out["monodromy1_dense"] = {**_strip(r), "max_abs_diff_to_blockdiag": float(np.max(np.abs(Md - M))),
                                   "max_abs_monodromy": float(np.max(np.abs(M)))}
    if n > orbit_max:
        return out
    r = _timed(lambda: system.periodic_orbit(**fam["orbit"]), budget=0.0, max_repeats=1)
    orb = r["result"]
    out["orbit"] = {**_strip(r), "iterations": orb.iterations, "residual": orb.residual,
                    "max_multiplier": orb.max_multiplier, "n_events": len(orb.events),
                    "rattle_state": orb.rattle_state, "converged": orb.converged}
    p0 = system.params[fam["param"]]
    if system.has_derivatives:
        # the build with the parameter derivatives (exact F_lambda) is made on the first
        # continuation: a one-time cost, timed on its own, not in the step
        t_d = time.perf_counter()
        system.derivative_engine()
        out["derivative_build_s"] = time.perf_counter() - t_d
    r = _timed(lambda: continuation(system, fam["param"], p0, 1.02 * p0, orbit=orb, max_points=2,
                                    progress=False, **fam["cont"]), budget=0.0, max_repeats=1)
    br = r["result"]
    out["continuation_step"] = {**_strip(r), "points": len(br.points),
                                "step": float(abs(br.values[-1] - br.values[0])) if len(br.points) > 1 else None,
                                "stop_reason": br.stop_reason}
    return out


# ------------------------------------------------------------------------ parent
def _child(args: list[str], timeout: float) -> dict[str, Any]:
    cmd = [sys.executable, str(Path(__file__).resolve()), *args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0:
        tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
        return {"failed": " | ".join(tail) or f"exit {p.returncode}"}
    return json.loads(p.stdout.strip().splitlines()[-1])


def environment() -> dict[str, Any]:
    import casadi
    import numpy

    import gearsym

    return {"python": platform.python_version(), "platform": platform.platform(), "cpu_count": os.cpu_count(),
            "numpy": numpy.__version__, "casadi": casadi.__version__, "gearsym": gearsym.__version__,
            "loadavg": os.getloadavg(), "date": time.strftime("%Y-%m-%d %H:%M")}


def run_all(cases: list[str], solvers: list[str], out: Path, dense_max: int, orbit_max: int,
            timeout: float) -> dict[str, Any]:
    """Build and run every case in child processes; write the JSON after each case."""
    out.mkdir(parents=True, exist_ok=True)
    data: dict[str, Any] = {"benchmark": "scaling", "environment": environment(), "cases": [],
                            "settings": {"families": FAMILY, "dense_max": dense_max, "orbit_max": orbit_max,
                                         "solvers": solvers}}
    with tempfile.TemporaryDirectory(prefix="gearsym-scaling-") as tmp:
        work = Path(tmp)
        for case in cases:
            t = time.perf_counter()
            entry: dict[str, Any] = {"case": case, "loadavg_start": os.getloadavg()[0]}
            entry["build"] = _child(["--child", "build", case, "--work", str(work)], timeout)
            for s in solvers:
                if "failed" in entry["build"]:
                    break
                entry[s] = _child(["--child", "run", case, "--work", str(work), "--solver", s,
                                   "--dense-max", str(dense_max), "--orbit-max", str(orbit_max)], timeout)
            entry["wall_s"] = time.perf_counter() - t
            data["cases"].append(entry)
            print(summary_line(entry), flush=True)
            (out / "scaling.json").write_text(json.dumps(data, indent=1))
    data["exponents"] = exponents(data)
    (out / "scaling.json").write_text(json.dumps(data, indent=1))
    return data


def summary_line(e: dict[str, Any]) -> str:
    b = e["build"]
    if "failed" in b:
        return f"{e['case']}: build failed: {b['failed']}"
    parts = [f"{e['case']:>14s} n={b['states']:3d}  derive {b['derive_s']:6.2f} s  compile {b['compile_s']:6.2f} s"]
    for s in ("newton", "fixedpoint"):
        r = e.get(s)
        if not r:
            continue
        if "failed" in r:
            parts.append(f"{s}: failed ({r['failed']})")
            continue
        o = r.get("orbit", {}).get("best_s")
        c = r.get("continuation_step", {}).get("best_s")
        parts.append(f"{s}: sim100 {r['simulate100']['best_s']:.3g} s, mono {r['monodromy1']['best_s']:.3g} s "
                     f"({r['monodromy_ratio']:.1f}x plain, n+1 = {b['states'] + 1}), orbit "
                     f"{'-' if o is None else f'{o:.3g} s'}, cont step {'-' if c is None else f'{c:.3g} s'}")
    return "\n    ".join(parts)


# -------------------------------------------------------------------- exponents
def _cpu(r: dict, key: str) -> float | None:
    return r.get(key, {}).get("cpu_best_s")


#: the quantities of the plot, the exponents and the table: CPU seconds (on a shared machine
#: wall times carry the other users' load; the JSON has both)
METRICS: dict[str, tuple[str, Callable[[dict], float | None]]] = {
    "derive": ("build", lambda b: b.get("derive_cpu_s")),
    "cold compile": ("build", lambda b: b.get("compile_cpu_s")),
    "simulate 100 periods": ("run", lambda r: _cpu(r, "simulate100")),
    "one-period monodromy": ("run", lambda r: _cpu(r, "monodromy1")),
    "orbit solve": ("run", lambda r: _cpu(r, "orbit")),
    "continuation step": ("run", lambda r: _cpu(r, "continuation_step")),
    "monodromy peak RSS": ("run", lambda r: r.get("monodromy1", {}).get("peak_rss_mb")),
}


def ratios(r: dict[str, Any], suffix: str = "") -> dict[str, float] | None:
    """Monodromy against plain one-period integration (CPU): total, steps, per step."""
    p, m = r.get("plain1" + suffix), r.get("monodromy1" + suffix)
    if not p or not m or not p.get("cpu_best_s"):
        return None
    total = m["cpu_best_s"] / p["cpu_best_s"]
    steps = m["n_steps"] / max(p["n_steps"], 1)
    return {"total": total, "steps": steps, "per_step": total / steps}


def _series(data: dict[str, Any], family: str, metric: str, solver: str) -> tuple[list[int], list[float]]:
    where, get = METRICS[metric]
    pts = []
    for e in data["cases"]:
        b = e.get("build", {})
        if "failed" in b or not e["case"].startswith(family):
            continue
        src = b if where == "build" else e.get(solver, {})
        v = get(src) if src and "failed" not in src else None
        if v is not None and v > 0:
            pts.append((b["states"], float(v)))
    pts.sort()
    return [p[0] for p in pts], [p[1] for p in pts]


def exponents(data: dict[str, Any], n_min: int = 10) -> dict[str, Any]:
    """Slopes of log(CPU cost) vs log(states) over the chains with >= n_min states."""
    import numpy as np

    out: dict[str, Any] = {}
    for solver in ("newton", "fixedpoint"):
        for metric, (where, _) in METRICS.items():
            if where == "build" and solver != "newton":
                continue
            xs, ys = _series(data, "chain", metric, solver)
            pts = [(x, y) for x, y in zip(xs, ys) if x >= n_min]
            if len(pts) >= 3:
                X, Y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
                slope = float(np.polyfit(X, Y, 1)[0])
                key = metric if where == "build" else f"{metric} ({solver})"
                out[key] = {"exponent": slope, "n_range": [int(min(p[0] for p in pts)), int(max(p[0] for p in pts))],
                            "points": len(pts)}
    return out


# ------------------------------------------------------------------------ output
def plot(data: dict[str, Any], path: Path) -> Path:
    """Three panels: CPU cost against states, monodromy/plain ratios, peak memory."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    ax = axes[0]
    for k, metric in enumerate(["derive", "cold compile", "simulate 100 periods", "one-period monodromy",
                                "orbit solve", "continuation step"]):
        for solver, ls in (("newton", "-"), ("fixedpoint", "--")):
            if METRICS[metric][0] == "build" and solver != "newton":
                continue
            xs, ys = _series(data, "chain", metric, solver)
            if xs:
                lab = metric if METRICS[metric][0] == "build" else f"{metric} ({solver})"
                ax.loglog(xs, ys, ls, marker="o", ms=4, color=colors[k], label=lab)
            xs, ys = _series(data, "planetary", metric, solver)
            if xs:
                ax.loglog(xs, ys, marker="*" if solver == "newton" else "x", ls="none", ms=9, color=colors[k])
    ax.set_xlabel("states n")
    ax.set_ylabel("CPU seconds (best of repeats)")
    ax.set_title("cost against model size (lines: chains; stars, crosses: planetary)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, loc="upper left")
    ax = axes[1]
    for k, (solver, ls, mk) in enumerate((("newton", "-", "o"), ("fixedpoint", "--", "s"))):
        for what, lw, alpha in (("total", 1.5, 1.0), ("per_step", 0.8, 0.6)):
            for family in ("chain", "planetary"):
                pts = sorted((e[solver]["states"], ratios(e[solver])[what]) for e in data["cases"]
                             if e["case"].startswith(family) and e.get(solver) and ratios(e[solver]))
                if pts:
                    chain = family == "chain"
                    ax.loglog([p[0] for p in pts], [p[1] for p in pts], ls=ls if chain else "none", lw=lw,
                              marker=mk if chain else ("*" if what == "total" else "+"), ms=4 if chain else 9,
                              color=colors[k], alpha=alpha,
                              label=f"{family}, {solver}, {'per step' if what == 'per_step' else 'whole period'}")
    xs, ys = [], []
    for e in data["cases"]:
        d = e.get("newton", {}).get("monodromy1_dense")
        if d:
            xs.append(e["newton"]["states"])
            ys.append(d["cpu_best_s"] / e["newton"]["plain1"]["cpu_best_s"])
    if xs:
        ax.loglog(xs, ys, "k:", marker="^", ms=4, label="dense (n + n^2) Newton, whole period")
    nn = [2, 150]
    ax.loglog(nn, [n + 1 for n in nn], color="0.5", lw=1, label="n + 1")
    ax.set_xlabel("states n")
    ax.set_ylabel("CPU ratio")
    ax.set_title("one-period monodromy / plain one-period integration", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    ax = axes[2]
    for solver, ls in (("newton", "-"), ("fixedpoint", "--")):
        xs, ys = _series(data, "chain", "monodromy peak RSS", solver)
        if xs:
            ax.semilogx(xs, ys, ls=ls, marker="o", ms=4, label=f"monodromy, chain ({solver})")
    xd, yd = [], []
    for e in data["cases"]:
        d = e.get("newton", {}).get("monodromy1_dense")
        if d and d.get("peak_rss_mb"):
            xd.append(e["newton"]["states"])
            yd.append(d["peak_rss_mb"])
    if xd:
        ax.semilogx(xd, yd, "k:", marker="^", ms=4, label="monodromy, dense (n + n^2) Newton")
    xb, yb, yg = [], [], []
    for e in data["cases"]:
        b = e.get("build", {})
        if "failed" not in b and e["case"].startswith("chain"):
            xb.append(b["states"])
            yb.append(b["peak_rss_mb"])
            yg.append(b["gcc_peak_rss_mb"])
    if xb:
        ax.semilogx(xb, yb, ":", marker="v", ms=4, label="derive + code generation (python)")
        ax.semilogx(xb, yg, ":", marker="D", ms=4, label="gcc")
    ax.set_xlabel("states n")
    ax.set_ylabel("peak RSS, MB")
    ax.set_yscale("log")
    ax.set_title("memory (process high-water mark per phase)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _f(v: float | None) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return f"{v * 1e3:.3g} ms" if v < 1 else f"{v:.3g} s"


def _g(v: float) -> str:
    return f"{v:.2g}" if v < 10 else f"{v:.0f}"


def markdown(data: dict[str, Any]) -> str:
    """The generated section of docs/performance.md."""
    env = data["environment"]
    load = [e["loadavg_start"] for e in data["cases"] if "loadavg_start" in e]
    L = [BEGIN, "", f"### Results (`benchmarks/scaling.py`, one run, {env['date']})", "",
         f"Machine: {env['platform']}, {env['cpu_count']} cores, shared: 1-minute load average "
         f"{min(load):.1f}-{max(load):.1f} when the models started, so every time below is the **CPU time** "
         f"of the process (best of repeats; wall times, 1.5-4x larger in this run, are in the JSON).  Python "
         f"{env['python']}, numpy {env['numpy']}, casadi {env['casadi']}, gearsym {env['gearsym']}.", "",
         "Monodromy ratio: CPU of one period with the monodromy over one plain period, at the simulation "
         "tolerances, as *whole period* (= *steps* ratio x *per step* ratio) and at the orbit tolerances; "
         "the target is n + 1.", "",
         "| model | n | surfaces | derive | cold compile (gcc) | solver | simulate 100 T | monodromy 1 T "
         "| ratio: whole / steps / per step (n + 1) | at orbit tol. | dense monodromy | orbit | continuation step "
         "| peak RSS monodromy / orbit |", "|---" * 14 + "|"]
    for e in data["cases"]:
        b = e["build"]
        if "failed" in b:
            L.append(f"| {e['case']} | build failed: {b['failed']} |" + " |" * 12)
            continue
        first = True
        for s in data["settings"]["solvers"]:
            r = e.get(s)
            if not r:
                continue
            head = (f"| {e['case']} | {b['states']} | {b['surfaces']} | {_f(b.get('derive_cpu_s'))} "
                    f"| {_f(b.get('compile_cpu_s'))} ({_f(b.get('gcc_cpu_s'))}) " if first else "| | | | | ")
            first = False
            if "failed" in r:
                L.append(head + f"| {s} | failed: {r['failed']} |" + " |" * 7)
                continue
            q, qo = ratios(r), ratios(r, "_orbit_tol")
            d = r.get("monodromy1_dense")
            o = r.get("orbit")
            mem = (f"{r['monodromy1']['peak_rss_mb']:.0f} / {o['peak_rss_mb']:.0f} MB"
                   if o and r["monodromy1"].get("peak_rss_mb") and o.get("peak_rss_mb") else "-")
            L.append(head + f"| {s} | {_f(_cpu(r, 'simulate100'))} | {_f(_cpu(r, 'monodromy1'))} "
                     f"| {_g(q['total'])} / {_g(q['steps'])} / {_g(q['per_step'])} ({b['states'] + 1}) "
                     f"| {_g(qo['total'])} / {_g(qo['steps'])} / {_g(qo['per_step'])} "
                     f"| {_f(d['cpu_best_s']) if d else '-'} | {_f(_cpu(r, 'orbit'))} "
                     f"| {_f(_cpu(r, 'continuation_step'))} | {mem} |")
    L += ["", "Growth exponents (slope of log CPU time, or log peak RSS, against log states; chains with "
          ">= 10 states):", "", "| quantity | exponent | states |", "|---|---|---|"]
    for k, v in data.get("exponents", {}).items():
        L.append(f"| {k} | {v['exponent']:.2f} | {v['n_range'][0]}-{v['n_range'][1]} |")
    L += ["", "![scaling](performance/scaling.png)", "", END]
    return "\n".join(L)


def write_docs(data: dict[str, Any], out: Path) -> Path:
    """Copy the plot and JSON to docs/performance/ and rewrite the scaling section of docs/performance.md."""
    dest = ROOT / "docs" / "performance"
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copy(out / "scaling.png", dest / "scaling.png")
    shutil.copy(out / "scaling.json", dest / "scaling.json")
    page = ROOT / "docs" / "performance.md"
    text = page.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{page}: no '{BEGIN}' ... '{END}' block to rewrite")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    page.write_text(head + markdown(data) + tail)
    return page


# -------------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/scaling", help="folder for scaling.json and scaling.png")
    ap.add_argument("--chain", default=",".join(map(str, DEFAULT_CHAIN)), help="chain sizes N (meshes)")
    ap.add_argument("--planetary", default=",".join(DEFAULT_PLANETARY),
                    help="planet counts (scenes/planetary_n<N>.toml; '4cl': the contact-loss scene); '' for none")
    ap.add_argument("--solvers", default="newton,fixedpoint", help="CVODE nonlinear solvers to compare")
    ap.add_argument("--dense-max", type=int, default=34, help="largest n for the dense-monodromy peer")
    ap.add_argument("--orbit-max", type=int, default=1000, help="largest n for orbit and continuation")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds per child process")
    ap.add_argument("--docs", action="store_true", help="copy results into docs/performance(.md)")
    ap.add_argument("--render", metavar="JSON", help="only plot (and --docs) from an earlier run's JSON")
    ap.add_argument("--child", nargs=2, metavar=("STEP", "CASE"), help=argparse.SUPPRESS)
    ap.add_argument("--work", help=argparse.SUPPRESS)
    ap.add_argument("--solver", default="newton", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        step, case = args.child
        work = Path(args.work)
        res = child_build(case, work) if step == "build" else child_run(case, work, args.solver, args.dense_max,
                                                                        args.orbit_max)
        print(json.dumps(res, default=float))
        return
    out = Path(args.out)
    if args.render:
        data = json.loads(Path(args.render).read_text())
        data["exponents"] = exponents(data)
        out.mkdir(parents=True, exist_ok=True)
        (out / "scaling.json").write_text(json.dumps(data, indent=1))
    else:
        cases = [f"chain{int(n)}" for n in args.chain.split(",") if n.strip()]
        cases += [f"planetary{p.strip()}" for p in args.planetary.split(",") if p.strip()]
        solvers = [s.strip() for s in args.solvers.split(",") if s.strip()]
        data = run_all(cases, solvers, out, args.dense_max, args.orbit_max, args.timeout)
    plot(data, out / "scaling.png")
    print(f"wrote {out / 'scaling.json'} and {out / 'scaling.png'}")
    for k, v in data.get("exponents", {}).items():
        print(f"  exponent {k}: {v['exponent']:.2f} (n = {v['n_range'][0]}..{v['n_range'][1]})")
    if args.docs:
        print(f"wrote {write_docs(data, out)}")


if __name__ == "__main__":
    main()
