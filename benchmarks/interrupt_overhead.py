"""What Ctrl-C polling and the verified build cache cost, and how fast Ctrl-C acts.

In one run, on the benchmark scene (scenes/kahraman_singh.toml, x0 = [1.1, 0]):

1. ``System.simulate`` with interrupt polling on (the default: the signal wakeup pipe is
   installed around the C call and read every 1024 right-hand side evaluations) and off
   (``gearsym.engine.interrupt.ENABLED = False``), interleaved round-robin: a long call
   (200 forcing periods, rtol 1e-8) and a short one (0.05 period: the per-call overhead).
   Timed as process CPU time (steadier than wall time on a shared machine, and the
   overhead is CPU work).
2. A cached ``scene.compile()`` (key computation, verification of the object's SHA-256
   and key, loading).
3. The latency from SIGINT (sent by a timer thread) to ``KeyboardInterrupt`` during a
   200,000-period simulation.

Usage::

    .venv/bin/python benchmarks/interrupt_overhead.py [--out DIR] [--rounds 7]

Writes ``DIR/interrupt_overhead.json`` (default ``out/bench``) and prints a table.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import signal  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import gearsym  # noqa: E402
from gearsym.engine import interrupt  # noqa: E402

KS = ROOT / "scenes" / "kahraman_singh.toml"
X0 = [1.1, 0.0]


def _time(fn, n: int, clock=time.perf_counter) -> float:
    t0 = clock()
    for _ in range(n):
        fn()
    return (clock() - t0) / n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "bench"))
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args()
    gen = tempfile.mkdtemp(prefix="gearsym-bench-")
    system = gearsym.load_scene(KS).compile(generated_dir=gen)
    cases = {
        "simulate_200_periods": (lambda: system.simulate(periods=200, x0=X0, rtol=1e-8, atol=1e-10), 5),
        "simulate_0.05_period": (lambda: system.simulate(periods=0.05, x0=X0, rtol=1e-8, atol=1e-10), 200),
    }
    samples: dict[str, dict[str, list[float]]] = {c: {"on": [], "off": []} for c in cases}
    for fn, _ in cases.values():  # warm-up
        fn()
    for r in range(args.rounds):
        for mode in (("on", "off") if r % 2 == 0 else ("off", "on")):
            interrupt.ENABLED = mode == "on"
            for name, (fn, n) in cases.items():
                samples[name][mode].append(_time(fn, n, time.process_time))
    interrupt.ENABLED = True
    compile_cached = [_time(lambda: gearsym.load_scene(KS).compile(generated_dir=gen), 3)
                      for _ in range(args.rounds)]
    latencies = []
    for _ in range(5):
        timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
        t0 = time.perf_counter()
        timer.start()
        try:
            system.simulate(periods=200000, n_out=2)
        except KeyboardInterrupt:
            latencies.append(time.perf_counter() - t0 - 0.2)
        finally:
            timer.cancel()
    result = {
        "clock": "process CPU time (time.process_time) for simulate; wall time for the rest",
        "machine": {"platform": platform.platform(), "python": platform.python_version(),
                    "cpus": os.cpu_count(), "load_avg": os.getloadavg()},
        "rounds": args.rounds,
        "simulate": {name: {mode: {"best_us": min(v) * 1e6, "median_us": statistics.median(v) * 1e6}
                            for mode, v in modes.items()} | {
                                "ratio_best_on_off": min(modes["on"]) / min(modes["off"]),
                                "ratio_median_on_off": statistics.median(modes["on"]) / statistics.median(modes["off"])}
                     for name, modes in samples.items()},
        "compile_cached_ms": {"best": min(compile_cached) * 1e3, "median": statistics.median(compile_cached) * 1e3},
        "sigint_to_keyboardinterrupt_ms": [v * 1e3 for v in latencies],
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "interrupt_overhead.json").write_text(json.dumps(result, indent=1))
    for name, d in result["simulate"].items():
        print(f"{name:22s} polling on {d['on']['best_us']:10.1f} us  off {d['off']['best_us']:10.1f} us CPU  "
              f"(best; ratio {d['ratio_best_on_off']:.3f}, medians {d['ratio_median_on_off']:.3f})")
    print(f"cached compile: {result['compile_cached_ms']['best']:.1f} ms (best), "
          f"{result['compile_cached_ms']['median']:.1f} ms (median)")
    print("SIGINT -> KeyboardInterrupt: " + ", ".join(f"{v:.1f}" for v in result["sigint_to_keyboardinterrupt_ms"])
          + " ms")
    print(f"wrote {out / 'interrupt_overhead.json'}")


if __name__ == "__main__":
    main()
