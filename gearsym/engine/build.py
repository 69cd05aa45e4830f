"""Build a model + driver shared object against the SUNDIALS 7 libraries of the
scikit-sundae wheel.

The wheel ships SUNDIALS 7.9 shared libraries (``scikit_sundae.libs/`` next to
the ``sksundae`` package) but no headers; the driver declares the API it uses in
``sundials7.h`` and links the libraries by full path with an rpath, so the built
object needs no environment variables at run time.  The ABI (version >= 7,
32-bit ``sunindextype``) is checked when the object is loaded
(:func:`gearsym.engine.driver.load_engine`).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from gearsym.engine.errors import EngineBuildError, SundialsNotFoundError

__all__ = [
    "ENGINE_DIR",
    "SundialsLibs",
    "build_shared_object",
    "content_hash",
    "driver_sources",
    "find_sundials_libs",
]

#: Directory holding the driver sources (gs_driver.c, gs_driver.h,
#: gs_model_abi.h, sundials7.h) -- package data.
ENGINE_DIR = Path(__file__).resolve().parent

#: Library stems needed by the driver, in link order.
_REQUIRED = (
    "sundials_cvode",
    "sundials_ida",
    "sundials_sunlinsoldense",
    "sundials_sunmatrixdense",
    "sundials_nvecserial",
    "sundials_core",
)


@dataclass(frozen=True)
class SundialsLibs:
    """The SUNDIALS shared libraries found in the scikit-sundae wheel.

    Attributes
    ----------
    libdir
        The ``scikit_sundae.libs`` directory (used as rpath).
    libs
        Full paths of the libraries, in link order.
    """

    libdir: Path
    libs: tuple[Path, ...]


def _sksundae_dir() -> Path:
    spec = importlib.util.find_spec("sksundae")
    if spec is None or not spec.submodule_search_locations:
        raise SundialsNotFoundError(
            "the Python package 'scikit-sundae' (module sksundae) is not installed; "
            "gearsym links the SUNDIALS 7 libraries shipped in its wheel "
            "(pip install scikit-sundae)"
        )
    return Path(list(spec.submodule_search_locations)[0]).resolve()


def find_sundials_libs() -> SundialsLibs:
    """Locate the SUNDIALS libraries shipped in the scikit-sundae wheel.

    Returns
    -------
    SundialsLibs
        Library directory and the full paths of the required libraries
        (core, cvode, ida, nvecserial, sunmatrixdense, sunlinsoldense).

    Raises
    ------
    SundialsNotFoundError
        If scikit-sundae is not installed or some library is missing; the
        message lists what is missing and where it was looked for.
    """
    pkg = _sksundae_dir()
    libdir = pkg.parent / "scikit_sundae.libs"
    if not libdir.is_dir():
        raise SundialsNotFoundError(
            f"the scikit-sundae wheel has no 'scikit_sundae.libs' directory next to {pkg}; "
            "gearsym needs the SUNDIALS 7 shared libraries that the manylinux wheel ships "
            "(reinstall scikit-sundae from a binary wheel)"
        )
    found: list[Path] = []
    missing: list[str] = []
    for stem in _REQUIRED:
        # auditwheel names them lib<stem>-<hash>.so.<version>
        cands = sorted(p for p in libdir.glob(f"lib{stem}-*.so*") if p.is_file())
        if stem == "sundials_core":
            cands = [p for p in cands if ".so.7" in p.name] or cands
        if not cands:
            missing.append(f"lib{stem}-*.so*")
        else:
            found.append(cands[-1])
    if missing:
        raise SundialsNotFoundError(f"SUNDIALS libraries missing in {libdir}: {', '.join(missing)}")
    return SundialsLibs(libdir=libdir, libs=tuple(found))


def driver_sources() -> tuple[list[Path], list[Path]]:
    """Driver C sources and include directories to add to a model build.

    Returns
    -------
    sources, include_dirs
        ``[ENGINE_DIR / "gs_driver.c"]`` and ``[ENGINE_DIR]``.  The model build
        must also provide ``gs_model.h`` on its include path.
    """
    return [ENGINE_DIR / "gs_driver.c"], [ENGINE_DIR]


def content_hash(paths: list[Path], extra: str = "") -> str:
    """A short hash of file contents (and an extra string), for naming builds.

    ``dlopen`` caches libraries by path, so a rebuilt object must get a new
    name; name it by the hash of everything that goes into it.

    Parameters
    ----------
    paths
        Files whose bytes enter the hash (order matters).
    extra
        Additional text (compiler flags, library paths, ...).

    Returns
    -------
    str
        16 hex digits.
    """
    h = hashlib.sha256()
    for p in paths:
        h.update(Path(p).read_bytes())
        h.update(b"\0")
    h.update(extra.encode())
    return h.hexdigest()[:16]


def build_shared_object(
    c_sources: list[Path],
    include_dirs: list[Path],
    out_path: Path,
    *,
    extra_cflags: list[str] | None = None,
    cc: str | None = None,
) -> Path:
    """Compile C sources into a shared object linked against SUNDIALS 7.

    Runs ``gcc -O3 -fPIC -shared -I... sources -o tmp <full library paths>
    -Wl,-rpath,<libdir> -lm``; the object is written to a temporary name in
    the destination directory and moved into place with :func:`os.replace`,
    so concurrent builders never see a half-written file.

    Parameters
    ----------
    c_sources
        C files (typically the generated model files and
        :func:`driver_sources`).
    include_dirs
        Include directories (the engine directory and the directory holding
        ``gs_model.h``).
    out_path
        Destination of the shared object (name it by content hash).
    extra_cflags
        Additional compiler flags.
    cc
        Compiler (default: ``$CC`` or ``gcc``).

    Returns
    -------
    Path
        ``out_path``.

    Raises
    ------
    SundialsNotFoundError
        If the SUNDIALS libraries cannot be found.
    EngineBuildError
        If the compiler is missing or fails (the message contains its stderr).
    """
    sl = find_sundials_libs()
    cc = cc or os.environ.get("CC") or "gcc"
    if shutil.which(cc) is None:
        raise EngineBuildError(f"C compiler '{cc}' not found; install gcc (e.g. apt-get install gcc)")
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out_path.name}.", suffix=".tmp", dir=out_path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    cmd = [cc, "-O3", "-fPIC", "-shared"]
    cmd += list(extra_cflags or [])
    for d in include_dirs:
        cmd.append(f"-I{Path(d)}")
    cmd += [str(Path(s)) for s in c_sources]
    cmd += ["-o", str(tmp)]
    cmd += [str(p) for p in sl.libs]
    cmd += [f"-Wl,-rpath,{sl.libdir}", "-lm"]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise EngineBuildError(
                f"C compilation failed (exit {proc.returncode}):\n{' '.join(cmd)}\n{proc.stderr.strip()}"
            )
        os.replace(tmp, out_path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return out_path
