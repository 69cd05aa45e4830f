"""The exported C program carries its SUNDIALS libraries (issue 29 item 5).

Before: the Makefile linked the scikit-sundae wheel's ``libsundials_*.so`` of the exporting
Python environment by absolute path with an absolute run path, so the program stopped
working (``error while loading shared libraries``) once that environment was deleted or the
folder went to another machine.  Now the libraries are copied into the project's ``lib/``
(with the SUNDIALS licence) and the program finds them through the run path ``$ORIGIN/lib``.

Checked here: the ELF dynamic entries of the program (``readelf -d``) and the libraries the
loader resolves (``ldd``) of a *moved* project name nothing outside it but the system
libraries, and it runs there with ``LD_LIBRARY_PATH`` unset and reproduces
``System.simulate``; and (marked ``wheel``, slow) a throwaway environment with its own copy
of scikit-sundae exports a scene, is deleted, and the program still runs.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gearsym.engine.build import find_sundials_libs

from .conftest import make, scene_path

#: Folders the system's dynamic loader takes libraries from (Debian multiarch and the rest).
SYSTEM_DIRS = ("/lib/", "/lib64/", "/usr/lib/", "/usr/lib64/", "/usr/local/lib/")


def _readelf(path: Path) -> dict[str, list[str]]:
    out = subprocess.run(["readelf", "-d", str(path)], capture_output=True, text=True, check=True).stdout
    found: dict[str, list[str]] = {}
    for tag, value in re.findall(r"\((NEEDED|SONAME|RPATH|RUNPATH)\)\s+[^\[]*\[([^\]]*)\]", out):
        found.setdefault(tag, []).append(value)
    return found


def _ldd(path: Path, env: dict) -> dict[str, str]:
    out = subprocess.run(["ldd", str(path)], capture_output=True, text=True, check=True, env=env).stdout
    return dict(re.findall(r"^\s*(\S+) => (.+?) \(0x[0-9a-f]+\)$", out, flags=re.M))


def _clean_env() -> dict:
    return {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH" and not k.startswith("PYTHON")}


def _read(path):
    return np.genfromtxt(path, delimiter=",", names=True)


needs_binutils = pytest.mark.skipif(shutil.which("readelf") is None or shutil.which("ldd") is None,
                                    reason="readelf / ldd not installed")


@needs_binutils
def test_elf_reader_agrees_with_readelf():
    # the bundle reads DT_SONAME / DT_NEEDED itself (no binutils needed at export)
    from gearsym.export.bundle import elf_dynamic

    for p in sorted(find_sundials_libs().libdir.glob("*.so*")):
        soname, needed = elf_dynamic(p.read_bytes())
        ref = _readelf(p)
        assert [soname] == ref.get("SONAME", [None]) and needed == ref.get("NEEDED", []), p.name


def test_bundle_is_the_linked_libraries_and_their_folder_dependencies():
    from gearsym.export.bundle import elf_dynamic, sundials_bundle

    b = sundials_bundle()
    libdir = find_sundials_libs().libdir
    # the six libraries the driver links, and everything they need from the wheel's folder
    assert len(b.linked) == 6 and set(b.linked) <= set(b.libs)
    for name, data in b.libs.items():
        assert data == (libdir / name).read_bytes()
        _, needed = elf_dynamic(data)
        assert all(n in b.libs for n in needed if (libdir / n).exists()), (name, needed)
    assert not any("openblas" in n or "gfortran" in n for n in b.libs)  # nothing unneeded
    assert re.fullmatch(r"7\.\d+\.\d+", b.version)
    lic = b.notices["LICENSE-SUNDIALS"]
    assert "BSD 3-Clause License" in lic and "Lawrence Livermore National Security" in lic
    assert "Redistributions in binary form must reproduce" in lic
    assert "DE-AC52-07NA27344" in b.notices["NOTICE-SUNDIALS"]


@needs_binutils
def test_moved_project_needs_nothing_outside_it(ks, tmp_path):
    # a copy of the built project under another name: the original stays for the other tests
    moved = tmp_path / "elsewhere" / "ks project"
    shutil.copytree(ks.c_dir, moved, symlinks=True)
    prog = moved / ks.program.name
    dyn = _readelf(prog)
    assert dyn.get("RUNPATH", []) + dyn.get("RPATH", []) == ["$ORIGIN/lib"]
    for name in dyn["NEEDED"]:
        assert (moved / "lib" / name).is_file() or name.startswith(("libc.so", "libm.so")), name
    resolved = _ldd(prog, _clean_env())
    assert any("sundials" in n for n in resolved)
    for name, path in resolved.items():
        ok = path.startswith(str(moved / "lib") + "/") if "sundials" in name else path.startswith(SYSTEM_DIRS)
        assert ok, (name, path)
    # no path of the exporting environment anywhere in the program
    data = prog.read_bytes()
    for outside in {sys.prefix, str(find_sundials_libs().libdir), str(ks.c_dir)}:
        assert outside.encode() not in data, outside
    assert "BSD 3-Clause" in (moved / "lib" / "LICENSE-SUNDIALS").read_text()
    # runs there with no library path set, in its impacting regime, as System.simulate
    params = {"Omega": 0.9}
    run = subprocess.run([str(prog), "Omega=0.9", "periods=50", "n_out=101", "rtol=1e-10", "atol=1e-12",
                          "--out", str(tmp_path / "run.csv")], capture_output=True, text=True, env=_clean_env(),
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    ref = ks.system.simulate(periods=50, n_out=101, rtol=1e-10, atol=1e-12, params=params)
    got = _read(tmp_path / "run.csv")
    assert len(ref.events) > 50
    assert max(np.abs(got["x"] - ref.y[:, 0]).max(), np.abs(got["v"] - ref.y[:, 1]).max()) < 1e-7


def _throwaway_env(tmp: Path) -> tuple[Path, Path]:
    """A virtual environment with its own copy of scikit-sundae (the package, its libraries,
    its metadata); gearsym and the other dependencies come from this one through a .pth."""
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    site = Path(subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    libdir = find_sundials_libs().libdir
    here = libdir.parent
    for name in [p.name for p in here.glob("scikit_sundae*")] + ["sksundae"]:
        shutil.copytree(here / name, site / name)
    import gearsym

    (site / "zz_gearsym_deps.pth").write_text(f"{Path(gearsym.__file__).parents[1]}\n{here}\n")
    return venv, py


@pytest.mark.wheel
@needs_binutils
def test_program_runs_after_the_exporting_environment_is_deleted(ks, tmp_path):
    venv, py = _throwaway_env(tmp_path)
    env = {**_clean_env(), "GEARSYM_GENERATED": str(tmp_path / "builds")}
    where = subprocess.run([py, "-c", "from gearsym.engine.build import find_sundials_libs as f; "
                            "print(f().libdir)"], capture_output=True, text=True, env=env, check=True)
    assert Path(where.stdout.strip()).is_relative_to(venv)  # the export links the throwaway's copy
    import gearsym

    which = subprocess.run([py, "-c", "import gearsym; print(gearsym.__file__)"], capture_output=True, text=True,
                           env=env, check=True, cwd=tmp_path)
    assert which.stdout.strip() == gearsym.__file__  # the gearsym under test
    d = tmp_path / "ks_c"
    # (not run from the repository: `-m` would import the gearsym in the working folder)
    exp = subprocess.run([py, "-m", "gearsym", "export", str(scene_path("kahraman_singh")), "--c", str(d)],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert exp.returncode == 0, exp.stderr
    assert make(d).returncode == 0
    shutil.rmtree(venv)
    shutil.rmtree(tmp_path / "builds")
    prog = d / "kahraman_singh"
    assert str(venv).encode() not in prog.read_bytes()
    run = subprocess.run([str(prog), "periods=20", "n_out=41", "--out", str(tmp_path / "run.csv")],
                         capture_output=True, text=True, env=_clean_env(), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    ref = ks.system.simulate(periods=20, n_out=41, rtol=1e-8, atol=1e-10)
    got = _read(tmp_path / "run.csv")
    assert max(np.abs(got["x"] - ref.y[:, 0]).max(), np.abs(got["v"] - ref.y[:, 1]).max()) < 1e-7
