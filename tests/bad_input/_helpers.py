"""Shared helpers of the bad-input suite: run the CLI, write malformed files, check nothing was written.

Every case runs ``python -m gearsym.cli ...`` in a fresh working folder with
``GEARSYM_GENERATED`` pointing at a build cache shared by the module, and checks:
exit code 2, a one-line ``gearsym: error: ...`` message on stderr naming the file /
field / value, no traceback, nothing on stdout, no file created or changed in the
working folder (``--out`` folders included), and no half-written build in the cache.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"
KS_MODEL_PATH = ROOT / "models" / "kahraman_singh.toml"
SPUR_MODEL_PATH = ROOT / "models" / "spur_pair_torsional.toml"
KS_MODEL = KS_MODEL_PATH.read_text()
SPUR_MODEL = SPUR_MODEL_PATH.read_text()


@dataclass
class Case:
    """One bad input: how to set it up (in a working folder) and what the message must name.

    ``setup(work)`` returns the CLI arguments; ``needles`` must all appear on stderr
    (``{work}`` is replaced by the working folder).  ``compiles`` marks cases that fail
    after a (complete, cached) compile, e.g. a bad tolerance.
    """

    id: str
    setup: Callable[[Path], list[str]]
    needles: Sequence[str]
    compiles: bool = False
    argparse: bool = False
    extra: dict = field(default_factory=dict)


def model(work: Path, text: str, name: str = "m.toml") -> Path:
    """Write a model file into the working folder."""
    p = work / name
    p.write_text(text)
    return p


def scene(work: Path, model_name: str = "m.toml", extra: str = "", name: str = "s.toml") -> Path:
    """Write a scene file using ``model_name`` (relative to the working folder)."""
    p = work / name
    p.write_text(f'[scene]\nname = "s"\nmodel = "{model_name}"\n{extra}')
    return p


def sub(text: str, old: str, new: str) -> str:
    """Replace the first ``old`` (which must be there) by ``new``."""
    assert old in text, f"test setup: {old!r} not found"
    return text.replace(old, new, 1)


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Every file / folder below ``folder`` with its size and mtime."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.stat()
        out[str(p.relative_to(folder))] = (st.st_size if p.is_file() else -1, st.st_mtime_ns)
    return out


def run_cli(args: Sequence[str], cwd: Path, gen: Path) -> subprocess.CompletedProcess:
    """``python -m gearsym.cli ARGS`` with the build cache in ``gen``."""
    env = dict(os.environ, GEARSYM_GENERATED=str(gen))
    return subprocess.run([sys.executable, "-m", "gearsym.cli", *args], capture_output=True, text=True,
                          cwd=cwd, env=env, timeout=300)


def check_case(case: Case, tmp_path: Path, gen: Path) -> None:
    """Run one case and assert everything the suite promises."""
    work = tmp_path / "work"
    work.mkdir()
    args = case.setup(work)
    builds_before = snapshot(gen) if gen.exists() else {}
    before = snapshot(work)
    r = run_cli(args, work, gen)
    err = r.stderr
    assert r.returncode == 2, f"exit {r.returncode}, stderr: {err}"
    assert "Traceback" not in err, err
    assert r.stdout == "", r.stdout
    if case.argparse:
        assert "error:" in err, err
    else:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("gearsym: error: "), err
    for n in case.needles:
        n = n.replace("{work}", str(work))
        assert n in err, f"{n!r} not in: {err}"
    assert snapshot(work) == before, "the command wrote into the working folder"
    builds_after = snapshot(gen) if gen.exists() else {}
    if not case.compiles:
        assert builds_after == builds_before, "a failing command left a build behind"
    for d in (gen.iterdir() if gen.exists() else []):  # whatever is cached is complete
        if d.name.startswith("."):
            continue  # .driver/: the driver object shared by the builds
        assert (d / "meta.json").is_file() and any(d.glob("gs_*.so")), f"half-written build {d}"
