"""Exported artefacts are never lost or corrupted (issue 25 items 7, 8, 9; issue 24 item 15).

Before:

* ``export --fmu F --force`` built the archive in TMPDIR and copied it onto F: on a full disk
  F was truncated first, then the copy failed (the old FMU lost);
* a control character in a description made an FMU whose ``modelDescription.xml`` is not
  well-formed XML, with exit 0;
* the C program read ``--file`` lines in 4 kB pieces (a setting hidden at the end of a long
  comment line was applied), and ``--file /dev/zero`` (or a FIFO) hung;
* a scene named ``Makefile`` gave a program named ``Makefile``, built over the Makefile.

A full disk is simulated by ``full_disk``: files opened for writing in one folder share a
few kB of room, then every write raises ENOSPC (and ``os.sendfile`` too), whatever writes
them; and, when this runs as root with ``mount`` allowed, by a real 1 MiB tmpfs.
"""

from __future__ import annotations

import builtins
import dataclasses
import errno
import io
import os
import shutil
import stat
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

from gearsym.cli import main
from gearsym.export import ExportError, collect, model_description, write_c_project, write_fmu

from .conftest import ROOT, make, scene_path

KS_MODEL = ROOT / "models" / "kahraman_singh.toml"


# ------------------------------------------------------------------ a full disk
def full_disk(monkeypatch, folder: Path, room: int) -> None:
    """Files opened for writing in ``folder`` share ``room`` bytes; then writes raise ENOSPC."""
    real_open = io.open
    left = [room]
    folder = folder.resolve()

    def enospc() -> OSError:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    class Writer:
        def __init__(self, f):
            self._f = f

        def write(self, data):
            if len(data) > left[0]:
                if left[0] > 0:
                    self._f.write(data[:left[0]])
                left[0] = 0
                raise enospc()
            left[0] -= len(data)
            return self._f.write(data)

        def __getattr__(self, name):
            return getattr(self._f, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self._f.close()

    def fake_open(file, mode="r", *args, **kwargs):
        f = real_open(file, mode, *args, **kwargs)
        if isinstance(file, (str, os.PathLike)) and any(c in mode for c in "wax+") and \
                folder in Path(file).resolve().parents:
            return Writer(f)
        return f

    def no_sendfile(*args, **kwargs):
        raise enospc()

    monkeypatch.setattr(io, "open", fake_open)
    monkeypatch.setattr(builtins, "open", fake_open)
    monkeypatch.setattr(os, "sendfile", no_sendfile)


@pytest.fixture(scope="module")
def em(ks):
    return collect(ks.scene)


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (the C project's ``lib/`` included) by relative path, and
    every folder (as ``b"<dir>"``)."""
    return {str(p.relative_to(folder)): b"<dir>" if p.is_dir() else p.read_bytes() for p in folder.rglob("*")}


def test_fmu_force_on_a_full_disk_keeps_the_old_fmu(em, ks, tmp_path, monkeypatch):
    target = tmp_path / "ks.fmu"
    shutil.copyfile(ks.fmu, target)
    before = _snapshot(tmp_path)
    full_disk(monkeypatch, tmp_path, room=20_000)
    with pytest.raises(ExportError, match="No space left on device"):
        write_fmu(em, target, force=True)
    monkeypatch.undo()
    assert _snapshot(tmp_path) == before  # the old FMU, and no temporary file beside it


def test_c_project_on_a_full_disk_changes_no_file(em, tmp_path, monkeypatch):
    d = tmp_path / "ks_c"
    write_c_project(em, d)
    for f in d.rglob("*"):  # an older export: every file differs from what is written now
        if f.is_file():
            f.write_bytes(b"old " + f.name.encode())
    before = _snapshot(d)
    full_disk(monkeypatch, d, room=60_000)
    with pytest.raises(ExportError, match="No space left on device"):
        write_c_project(em, d, force=True)
    monkeypatch.undo()
    assert _snapshot(d) == before


@pytest.fixture
def tiny_fs(tmp_path):
    """A real 1 MiB tmpfs (root only; skipped where mounting is not allowed)."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    d = tmp_path / "tiny"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(d)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode(errors='replace').strip()}")
    try:
        yield d
    finally:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


def _fill(folder: Path, keep_free: int) -> None:
    st = os.statvfs(folder)
    free = st.f_bavail * st.f_frsize
    with open(folder / "filler", "wb") as fh:
        fh.write(b"\0" * max(0, free - keep_free))


def test_fmu_force_on_a_real_full_disk_keeps_the_old_fmu(em, ks, tiny_fs):
    size = ks.fmu.stat().st_size
    target = tiny_fs / "ks.fmu"
    target.write_bytes(b"an older FMU" * 100)
    _fill(tiny_fs, keep_free=size // 2)  # not room for the new FMU, even with the old one's space
    before = _snapshot(tiny_fs)
    with pytest.raises(ExportError, match="No space left on device"):
        write_fmu(em, target, force=True)
    assert _snapshot(tiny_fs) == before


# ------------------------------------------------------------------ free text in XML
def _scene_with(tmp_path: Path, description: str) -> Path:
    text = scene_path("kahraman_singh").read_text()
    text = text.replace('"../models/kahraman_singh.toml"', f'"{KS_MODEL.as_posix()}"')
    lines = [ln for ln in text.splitlines() if not ln.startswith("description =")]
    i = lines.index("[scene]")
    lines.insert(i + 1, f"description = {description}")
    p = tmp_path / "ks_text.toml"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_control_character_in_a_description_is_refused_naming_it(tmp_path, capsys):
    scene = _scene_with(tmp_path, r'"gear pair \u0001 with a bell \u0007"')
    fmu = tmp_path / "out.fmu"
    code = main(["export", str(scene), "--fmu", str(fmu)])
    out, err = capsys.readouterr()
    if fmu.exists():  # what the defect produced: report whether the XML parses
        with zipfile.ZipFile(fmu) as zf:
            xml_text = zf.read("modelDescription.xml")
        try:
            ET.fromstring(xml_text)
        except ET.ParseError as exc:
            pytest.fail(f"exit {code}: the FMU's modelDescription.xml is not well-formed: {exc}")
    assert code == 2, err
    assert "the description of scene 'kahraman_singh'" in err and "U+0001" in err, err
    assert not fmu.exists() and list(tmp_path.iterdir()) == [scene]


def test_control_character_in_a_meaning_is_refused_naming_the_parameter(em):
    params = [dataclasses.replace(q, description="mesh \x1b[31mdamping") if q.name == "zeta" else q
              for q in em.params]
    with pytest.raises(ExportError, match=r"meaning of parameter 'zeta'.*U\+001B"):
        model_description(dataclasses.replace(em, params=params), "{guid}", False)


def test_allowed_whitespace_and_markup_characters_give_well_formed_xml(em):
    params = [dataclasses.replace(q, description='a <b> & "c"\tline\nnext \u00e9 \U0001F600')
              if q.name == "zeta" else q for q in em.params]
    root = ET.fromstring(model_description(dataclasses.replace(em, params=params), "{guid}", False).encode())
    zeta = next(sv for sv in root.iter("ScalarVariable") if sv.get("name") == "zeta")
    assert zeta.get("description") == 'a <b> & "c"\tline\nnext \u00e9 \U0001F600'


# ------------------------------------------------------------------ the C program's --file
def _default_run(ks) -> str:
    proc = ks.run("periods=1", "n_out=5")
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_a_setting_at_the_end_of_a_long_comment_line_is_not_applied(ks, tmp_path):
    f = tmp_path / "p.txt"
    f.write_text("#" + "x" * 4094 + "Omega=0.5\n")  # fgets(4096) used to cut the line before 'Omega'
    proc = ks.run("--file", str(f), "periods=1", "n_out=5")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == _default_run(ks)


def test_a_long_setting_line_is_read_whole(ks, tmp_path):
    f = tmp_path / "p.txt"
    f.write_text("Omega =" + " " * 6000 + "0.9   # " + "y" * 6000 + "\nperiods=1\nn_out=5\n")
    proc = ks.run("--file", str(f))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == _default_run(ks)


@pytest.mark.parametrize("kind", ["dev_zero", "fifo", "folder", "nul_byte", "too_big", "missing"])
def test_file_that_is_not_a_settings_file_is_refused(ks, tmp_path, kind):
    f = tmp_path / "p.txt"
    needle = {"dev_zero": "not a regular file", "fifo": "not a regular file", "folder": "not a regular file",
              "nul_byte": "a NUL byte on line 2", "too_big": "larger than 1 MiB", "missing": "cannot read"}[kind]
    if kind == "dev_zero":
        f = Path("/dev/zero")
    elif kind == "fifo":
        os.mkfifo(f)
    elif kind == "folder":
        f = tmp_path
    elif kind == "nul_byte":
        f.write_bytes(b"periods=1\nOmega=0.5\0\n")
    elif kind == "too_big":
        f.write_text(("#" * 99 + "\n") * 11_000)
    # a hang (the old reader on /dev/zero or a FIFO) ends here with TimeoutExpired
    proc = subprocess.run([str(ks.program), "--file", str(f)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert needle in proc.stderr and proc.stdout == ""


# ------------------------------------------------------------------ names that collide
def test_scene_named_makefile_does_not_overwrite_the_makefile(tmp_path):
    text = scene_path("meissner").read_text().replace('name = "meissner"', 'name = "Makefile"')
    text = text.replace('"../models/meissner.toml"', f'"{(ROOT / "models" / "meissner.toml").as_posix()}"')
    scene = tmp_path / "makefile_scene.toml"
    scene.write_text(text)
    d = tmp_path / "c"
    assert main(["export", str(scene), "--c", str(d)]) == 0
    proc = make(d)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (d / "Makefile").read_bytes().startswith(b"# Makefile of the exported gearsym model")
    prog = d / "Makefile_model"
    assert prog.is_file() and os.access(prog, os.X_OK)
    run = subprocess.run([str(prog), "periods=1", "n_out=3"], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.startswith("t,x,v"), run.stderr
    assert make(d).returncode == 0  # the Makefile still works


def test_program_names_avoid_the_projects_files_and_targets():
    from gearsym.export.model_info import program_name

    assert [program_name(n) for n in ("Makefile", "makefile", "GNUmakefile", "all", "check", "clean", "ks")] == \
        ["Makefile_model", "makefile_model", "GNUmakefile_model", "all_model", "check_model", "clean_model", "ks"]


# ------------------------------------------------------------------ permissions
def test_exported_files_have_the_permissions_of_new_files(em, ks, tmp_path):
    old = os.umask(0o027)
    try:
        d = tmp_path / "c"
        write_c_project(em, d)
        fmu = tmp_path / "ks.fmu"
        shutil.copyfile(ks.fmu, fmu)
        os.chmod(fmu, 0o600)
        write_fmu(em, fmu, force=True)
    finally:
        os.umask(old)
    modes = {str(p.relative_to(d)): stat.S_IMODE(p.stat().st_mode) for p in d.rglob("*")}
    assert modes.pop("find_sundials.sh") == 0o750
    assert modes.pop("lib") == 0o750  # a new folder: 0o777 less the umask
    assert any(n.startswith("lib/libsundials_cvode") for n in modes)
    assert set(modes.values()) == {0o640}
    assert stat.S_IMODE(fmu.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c", "ks.fmu"]


def test_export_leaves_no_temporary_folder(tmp_path, monkeypatch):
    import tempfile

    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    monkeypatch.setenv("TMPDIR", str(tmp))
    code = main(["export", str(scene_path("kahraman_singh")), "--fmu", str(tmp_path / "ks.fmu"), "--c", str(tmp_path / "c")])
    assert code == 0
    assert list(tmp.iterdir()) == []
