"""Timing: interleaved best-of-repeats of the methods, compile times, and the environment
the numbers were measured in."""

from __future__ import annotations

import gc
import math
import os
import platform
import shutil
import tempfile
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .peers import RunOutput

__all__ = ["compile_times", "environment"]


def _time_round_robin(fns: list[Callable[[], RunOutput]], rounds: int, slot: float, single_run_s: float,
                      max_per_slot: int = 30) -> tuple[list[RunOutput | Exception], list[list[float]]]:
    """Warm-up run of each (its output gives the error), then interleaved timed repeats.

    A method whose warm-up took more than ``single_run_s`` is timed by that run alone.
    """
    firsts: list[RunOutput | Exception] = []
    reps: list[int] = []
    times: list[list[float]] = [[] for _ in fns]
    for i, fn in enumerate(fns):
        gc.collect()
        t = time.perf_counter()
        try:
            firsts.append(fn())
        except Exception as exc:  # a failing method must not lose the others' numbers
            firsts.append(exc)
        est = time.perf_counter() - t
        if est > single_run_s or rounds <= 0:
            times[i].append(est)
            reps.append(0)
        else:
            reps.append(int(min(max_per_slot, max(1, math.ceil(slot / max(est, 1e-6))))))
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            if isinstance(firsts[i], Exception) or reps[i] == 0:
                continue
            for _ in range(reps[i]):
                gc.collect()
                t = time.perf_counter()
                fn()
                times[i].append(time.perf_counter() - t)
    return firsts, times



def compile_times(scene_path: str | Path, effects: Mapping[str, bool | str] | None = None,
                  overrides: Mapping[str, float] | None = None) -> dict[str, Any]:
    """Cold compile (fresh build folder: derivation, code generation, gcc, load) and
    cached compile (load_scene + compile again, served from the cache)."""
    from ..facade import load_scene

    d = Path(tempfile.mkdtemp(prefix="gearsym_bench_"))
    try:
        t = time.perf_counter()
        sc = load_scene(scene_path, effects, **(overrides or {}))
        sc.compile(generated_dir=d)
        cold = time.perf_counter() - t
        cached = []
        hit = True
        for _ in range(3):
            t = time.perf_counter()
            sys2 = load_scene(scene_path, effects, **(overrides or {})).compile(generated_dir=d)
            cached.append(time.perf_counter() - t)
            hit = hit and bool(sys2.generated.cached)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    return {"cold_s": cold, "cached_s": min(cached), "cached_hit": hit}


def environment() -> dict[str, Any]:
    """Versions and machine (the numbers are ratios from one run on this machine)."""
    import casadi
    import scipy
    import sksundae

    from .. import __version__

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"python": platform.python_version(), "platform": platform.platform(), "cpu": cpu,
            "cpu_count": os.cpu_count(),
            "loadavg": os.getloadavg() if hasattr(os, "getloadavg") else None,
            "numpy": np.__version__, "scipy": scipy.__version__, "casadi": casadi.__version__,
            "sksundae": getattr(sksundae, "__version__", "?"), "gearsym": __version__}

