"""The C reference of the analysis benchmarks: a bare C CVODE loop, and time spent in C.

* :func:`bare_c_loop` times **one call of the C driver** (``gs_simulate`` through the
  engine's ctypes binding, no output grid: the CVODE loop with root finding and mode
  switches runs entirely in C over the same generated model) integrating 200 forcing
  periods of the benchmark oscillator.  The Python cost of the call (one ctypes call,
  ~50 us) is included; it is ~0.3 % of the loop.
* :class:`CTimer` counts the wall time spent inside the driver's C entry points
  (``gs_simulate_ws``, ``gs_shoot_ws``, ``gs_eval``, ``gs_eval_period``, ...) during a piece of Python code, by
  wrapping them on the system's engines; the rest is time outside C (Python, numpy, CasADi).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np

#: The C entry points of the driver that do numerical work.
C_ENTRY_POINTS = ("gs_simulate_ws", "gs_simulate", "gs_shoot_ws", "gs_correct_ws", "gs_eval", "gs_eval_period", "gs_eval_period_grad")


def bare_c_loop(system: Any, params: dict[str, float], periods: int = 200, rtol: float = 1e-10,
                atol: float = 1e-12, repeats: int = 5) -> dict[str, Any]:
    """Best and median wall time of one C-driver call integrating ``periods`` forcing periods."""
    p = system.param_vector(params)
    T = system.period(params)
    x0 = np.asarray(system.x0, float)
    method = str(system.defaults.get("method", "adams"))
    grid = np.array([0.0, periods * T])
    times, cpu, stats = [], [], {}
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        res = system.engine.run(x0, p, 0.0, periods * T, grid, method=method, rtol=rtol, atol=atol,
                                max_step=T / 8)
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
        stats = res.stats
    return {"periods": periods, "rtol": rtol, "atol": atol, "method": method, "best_s": min(times),
            "median_s": statistics.median(times), "cpu_best_s": min(cpu), "n_steps": stats.get("n_steps"),
            "n_events": stats.get("n_events")}


class _TimedLib:
    """A proxy of the driver library that accumulates the time of its C entry points."""

    def __init__(self, lib: Any, timer: CTimer):
        self._lib = lib
        self._timer = timer

    def __getattr__(self, name: str) -> Any:
        fn = getattr(self._lib, name)
        if name not in C_ENTRY_POINTS:
            return fn
        timer = self._timer

        def timed(*args: Any) -> Any:
            t, c = time.perf_counter(), time.process_time()
            try:
                return fn(*args)
            finally:
                timer.c_s += time.perf_counter() - t
                timer.c_cpu_s += time.process_time() - c
                timer.c_calls += 1

        return timed


class CTimer:
    """``with CTimer(system) as ct: ...``: ``ct.c_cpu_s`` CPU seconds in C of ``ct.cpu_s`` in all
    (``c_s`` / ``wall_s``: the same in wall time)."""

    def __init__(self, system: Any):
        # the system's engine and, once made, the engine of its build with parameter derivatives
        # (continuation integrates the monodromy and F_lambda there)
        engines = [system.engine, getattr(system, "_derivative_engine", None)]
        self.engines = [e for i, e in enumerate(engines) if e is not None and e not in engines[:i]]
        self.c_s = 0.0
        self.c_cpu_s = 0.0
        self.c_calls = 0
        self.wall_s = 0.0
        self.cpu_s = 0.0

    def __enter__(self) -> CTimer:
        self._orig = [e._lib for e in self.engines]
        for e in self.engines:
            e._lib = _TimedLib(e._lib, self)
        self._t, self._c = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.wall_s = time.perf_counter() - self._t
        self.cpu_s = time.process_time() - self._c
        for e, lib in zip(self.engines, self._orig, strict=True):
            e._lib = lib

    @property
    def outside_c_fraction(self) -> float:
        """Share of the CPU time spent outside the C entry points (CPU time: robust on a loaded
        machine, where wall time also counts the time the process waits for a core)."""
        return 1.0 - self.c_cpu_s / self.cpu_s if self.cpu_s > 0 else float("nan")

    @property
    def outside_c_fraction_wall(self) -> float:
        """Share of the wall time spent outside the C entry points."""
        return 1.0 - self.c_s / self.wall_s if self.wall_s > 0 else float("nan")


def interleaved(system: Any, params: dict[str, float], fn: Any, rounds: int = 7, rtol: float = 1e-10,
                atol: float = 1e-12, periods: int = 200) -> dict[str, Any]:
    """The ratio of ``fn()`` to the bare C loop, timed **in alternation** (loop, fn, loop, fn, ...).

    On a shared machine the speed of the host drifts by up to 2x between seconds (measured:
    the bare loop took 18.5-39.9 ms in three runs a minute apart at load 0.6), so a ratio of
    two phases timed one after the other moves with it; alternating puts both under the same
    conditions.  Reported: the ratio of the best CPU times, and the median of the per-round
    ratios (CPU).
    """
    loop_cpu, fn_cpu, loop_wall, fn_wall, per_round = [], [], [], [], []
    for _ in range(max(1, rounds)):
        r = bare_c_loop(system, params, periods=periods, rtol=rtol, atol=atol, repeats=1)
        t, c = time.perf_counter(), time.process_time()
        fn()
        fw, fc = time.perf_counter() - t, time.process_time() - c
        loop_cpu.append(r["cpu_best_s"])
        loop_wall.append(r["best_s"])
        fn_cpu.append(fc)
        fn_wall.append(fw)
        per_round.append(fc / max(r["cpu_best_s"], 1e-9))
    return {"rounds": len(per_round), "bare_loop_cpu_best_s": min(loop_cpu), "fn_cpu_best_s": min(fn_cpu),
            "bare_loop_wall_best_s": min(loop_wall), "fn_wall_best_s": min(fn_wall),
            "ratio_cpu_best": min(fn_cpu) / max(min(loop_cpu), 1e-9),
            "ratio_wall_best": min(fn_wall) / max(min(loop_wall), 1e-9),
            "ratio_cpu_median_of_rounds": float(statistics.median(per_round))}
