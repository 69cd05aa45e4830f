"""Time of ``gearsym inspect --json`` (derivation + dimensionless form) on every shipped scene.

For each scene in ``scenes/`` the command runs once in a fresh process; the wall and CPU
(user + sys, of the child) times are recorded with the number of dimensionless groups and
equations it printed, and the time the dimensionless form itself took
(``dimensionless_seconds``).  A scene fails when the command exits non-zero, prints no
dimensionless group or equation, or takes longer than ``--limit`` seconds of CPU.

Run: ``.venv/bin/python benchmarks/inspect_times.py [--out out/bench] [--limit 60]``;
writes ``inspect_times.json`` and exits 1 when a scene fails.  CPU time is the number to
compare across machines (wall time includes the load of a shared machine).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _inspect(scene: Path) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "gearsym.cli", "inspect", str(scene), "--json"],
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    row = {"scene": scene.stem, "exit": r.returncode, "wall_s": round(wall, 2),
           "cpu_s": round((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), 2)}
    if r.returncode == 0:
        info = json.loads(r.stdout)
        row.update(groups=len(info.get("dimensionless_groups") or {}),
                   equations=len(info.get("dimensionless_equations") or []),
                   dimensionless_s=info.get("dimensionless_seconds"))
    else:
        row["error"] = r.stderr.strip().splitlines()[-1:] if r.stderr else []
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/bench", help="output folder (default out/bench)")
    parser.add_argument("--limit", type=float, default=60.0, help="CPU seconds allowed per scene")
    parser.add_argument("scenes", nargs="*", help="scene files (default: every shipped scene)")
    args = parser.parse_args()
    scenes = [Path(s) for s in args.scenes] or sorted((ROOT / "scenes").glob("*.toml"))
    rows, failed = [], []
    for s in scenes:
        row = _inspect(s)
        ok = row["exit"] == 0 and row.get("groups", 0) > 0 and row.get("equations", 0) > 0 \
            and row["cpu_s"] <= args.limit
        row["ok"] = ok
        rows.append(row)
        if not ok:
            failed.append(s.stem)
        print(f"{s.stem:32s} exit {row['exit']}  wall {row['wall_s']:6.2f} s  cpu {row['cpu_s']:6.2f} s  "
              f"groups {row.get('groups', '-'):>3}  equations {row.get('equations', '-'):>3}"
              + ("" if ok else "  FAILED"), flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "inspect_times.json").write_text(json.dumps({"limit_cpu_s": args.limit, "scenes": rows}, indent=1))
    print(f"max cpu {max(r['cpu_s'] for r in rows):.2f} s over {len(rows)} scenes; wrote {out / 'inspect_times.json'}")
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
