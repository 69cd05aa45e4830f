"""Output files honour the umask; a set of files is written all or nothing; no command leaves a
temporary folder (issue 24 item 15, issue 25 items 7 and 10).

Before: every output went through ``tempfile.mkstemp`` (mode 0600) and was renamed onto its
name, so ``orbit.json``, ``branch.json``, ``map.nc``, ``trajectory.npz`` and the PNG figures
were private to their writer whatever the umask (collaborators on a shared folder could not
read them); ``gearsym inspect MODEL`` left a ``gearsym-*`` folder in TMPDIR, and a parallel
map a ``pymp-*`` folder (its forkserver's socket) until the process ended.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path

import numpy as np
import pytest

from gearsym.cli import main
from gearsym.files import atomic_path, save_npz, write_json, write_text

ROOT = Path(__file__).resolve().parents[1]
MEISSNER = ROOT / "scenes" / "meissner.toml"
MEISSNER_MODEL = ROOT / "models" / "meissner.toml"


@pytest.fixture(params=[0o022, 0o027, 0o077], ids=lambda u: f"umask{u:03o}")
def umask(request):
    old = os.umask(request.param)
    yield request.param
    os.umask(old)


def _modes(folder: Path) -> dict[str, int]:
    return {p.name: stat.S_IMODE(p.stat().st_mode) for p in folder.rglob("*") if p.is_file()}


@pytest.fixture
def empty_tmpdir(tmp_path, monkeypatch) -> Path:
    """TMPDIR (for this process and its children) is an empty folder."""
    tmp = tmp_path / "tmpdir"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.setenv("TMPDIR", str(tmp))
    return tmp


def test_helpers_give_the_mode_of_a_new_file(tmp_path, umask):
    from gearsym.files import write_files

    write_json(tmp_path / "a.json", {"x": 1})
    write_text(tmp_path / "b.txt", "b")
    save_npz(tmp_path / "c.npz", x=np.arange(3))
    with atomic_path(tmp_path / "d.bin") as tmp:
        tmp.write_bytes(b"d")
    write_files(tmp_path, {"e.sh": "#!/bin/sh\n", "f.txt": "f"}, executable=["e.sh"])
    plain = 0o666 & ~umask
    assert _modes(tmp_path) == {"a.json": plain, "b.txt": plain, "c.npz": plain, "d.bin": plain,
                                "e.sh": 0o777 & ~umask, "f.txt": plain}


def test_cli_outputs_honour_the_umask_and_no_temporary_folder_stays(tmp_path, empty_tmpdir):
    """Every file of ``simulate``, ``orbit``, ``map`` (on two worker processes) and ``continue``
    with ``--out`` (npz, json, nc, png) has the mode of a new file, and TMPDIR stays empty."""
    out = tmp_path / "out"
    umask = 0o027
    old = os.umask(umask)
    try:
        assert main(["simulate", str(MEISSNER), "--periods", "3", "--out", str(out / "sim")]) == 0
        assert main(["orbit", str(MEISSNER), "--out", str(out / "orbit")]) == 0
        assert main(["map", str(MEISSNER), "--method", "shooting", "--workers", "2", "--x", "T", "2", "4", "3",
                     "--y", "a", "0.1", "0.3", "2", "--out", str(out / "map")]) == 0
        assert main(["continue", str(MEISSNER), "--param", "T", "--from", "2", "--to", "2.3", "--no-progress",
                     "--out", str(out / "branch")]) == 0
    finally:
        os.umask(old)
    modes = _modes(out)
    names = {Path(n).suffix for n in modes}
    assert {".npz", ".json", ".nc", ".png"} <= names and "branch.json" in modes, modes
    assert modes == {n: 0o666 & ~umask for n in modes}
    assert sorted(p.name for p in empty_tmpdir.iterdir()) == []


def test_an_existing_private_file_gets_the_new_files_mode(tmp_path):
    """The mode does not depend on what the file was before (an output of an older gearsym is
    0600: rewriting it makes it readable as the umask says)."""
    target = tmp_path / "orbit.json"
    target.write_text("{}")
    target.chmod(0o600)
    old = os.umask(0o022)
    try:
        write_json(target, {"x0": [1.0]})
    finally:
        os.umask(old)
    assert stat.S_IMODE(target.stat().st_mode) == 0o644


def test_write_files_on_a_full_disk_changes_no_file(tmp_path, monkeypatch):
    from gearsym.files import write_files

    for name in ("a.txt", "b.txt", "c.txt"):
        (tmp_path / name).write_text(f"old {name}")
    real_open = open
    calls = []

    def failing_open(file, mode="r", *args, **kwargs):
        f = real_open(file, mode, *args, **kwargs)
        if "w" in mode and Path(file).parent == tmp_path:
            calls.append(file)
            if len(calls) == 3:  # the third file: the disk is full midway
                f.write(b"par")
                f.close()
                raise OSError(errno.ENOSPC, "No space left on device")
        return f

    monkeypatch.setattr("builtins.open", failing_open)
    with pytest.raises(OSError, match="No space left"):
        write_files(tmp_path, {"a.txt": "new a", "b.txt": "new b", "c.txt": "new c"})
    monkeypatch.undo()
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == {
        "a.txt": "old a.txt", "b.txt": "old b.txt", "c.txt": "old c.txt"}


def test_write_files_takes_plain_names_only(tmp_path):
    from gearsym.files import write_files

    with pytest.raises(ValueError, match="not a plain file name"):
        write_files(tmp_path / "d", {"../escape.txt": "x"})
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args", [["inspect", str(MEISSNER_MODEL)], ["inspect", str(MEISSNER), "--json"]],
                         ids=["inspect_model", "inspect_scene"])
def test_inspect_leaves_no_temporary_folder(tmp_path, empty_tmpdir, capsys, args):
    code = main(args)
    assert code == 0, capsys.readouterr().err
    assert sorted(p.name for p in empty_tmpdir.iterdir()) == []
