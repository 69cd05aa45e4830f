"""Start-up cost of the ``gearsym`` command: ``gearsym --version`` against its peers.

Each command runs ``--runs`` times, round-robin (so that load drifts hit them alike);
the wall and CPU (user + sys, of the child) times are reported as min and median:

* ``python -c pass``: the interpreter alone, the floor;
* ``python -c "import argparse"``: what any argparse CLI pays;
* ``gearsym --version``: the console script (only the parser: no numpy, sympy, CasADi);
* ``python -c "import numpy"``: what the command paid before its imports were made lazy.

Run: ``.venv/bin/python benchmarks/cli_startup.py [--runs 30] [--out out/bench]``; writes
``cli_startup.json``.  On a loaded machine compare the rows with each other, not with a
fixed number.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _time(cmd: list[str]) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--out", default="out/bench")
    args = parser.parse_args()
    exe = shutil.which("gearsym", path=str(Path(sys.executable).parent)) or "gearsym"
    cases = {
        "python -c pass": [sys.executable, "-c", "pass"],
        "python -c 'import argparse'": [sys.executable, "-c", "import argparse"],
        "gearsym --version": [exe, "--version"],
        "python -c 'import numpy'": [sys.executable, "-c", "import numpy"],
    }
    samples: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
    for _ in range(args.runs):
        for name, cmd in cases.items():
            samples[name].append(_time(cmd))
    rows = {}
    for name, s in samples.items():
        wall, cpu = [w for w, _ in s], [c for _, c in s]
        rows[name] = {"wall_min_s": min(wall), "wall_median_s": statistics.median(wall),
                      "cpu_min_s": min(cpu), "cpu_median_s": statistics.median(cpu)}
        print(f"{name:32s} wall min {min(wall) * 1e3:6.1f} ms, median {statistics.median(wall) * 1e3:6.1f} ms; "
              f"cpu min {min(cpu) * 1e3:6.1f} ms, median {statistics.median(cpu) * 1e3:6.1f} ms")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    data = {"runs": args.runs, "load_average": os.getloadavg(), "gearsym": exe, "cases": rows}
    (out / "cli_startup.json").write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {out / 'cli_startup.json'}")


if __name__ == "__main__":
    main()
