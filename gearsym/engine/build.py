"""Build a model + driver shared object against the SUNDIALS 7 libraries of the
scikit-sundae wheel.

The wheel ships SUNDIALS 7.9 shared libraries (``scikit_sundae.libs/`` next to
the ``sksundae`` package) but no headers; the driver declares the API it uses in
``sundials7.h`` and links the libraries by full path **without** an rpath: the
object records only the libraries' SONAMEs, and :func:`preload_sundials` loads the
installed wheel's libraries (``RTLD_LOCAL``, in dependency order) before a model
is loaded, so a build survives the deletion or move of the venv that built it.
:func:`toolchain_identity` (compiler path and ``--version``, flags, content hashes
of the libraries and driver sources) enters the build cache key, so a build made
against other libraries or another compiler is never reused.  The ABI (version
>= 7, 32-bit ``sunindextype``) is checked when the object is loaded
(:func:`gearsym.engine.driver.load_engine`).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import importlib.util
import json
import logging
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from gearsym.engine.errors import EngineABIError, EngineBuildError, SundialsNotFoundError
from gearsym.engine.trust import (
    locked_file,
    open_secure_directory,
    read_file_at,
    sign,
    signing_key,
    user_cache_dir,
    verify,
)

_log = logging.getLogger(__name__)

__all__ = [
    "CFLAGS",
    "DRIVER_C_FILES",
    "ENGINE_DIR",
    "SundialsLibs",
    "build_shared_object",
    "content_hash",
    "driver_sources",
    "file_sha256",
    "find_sundials_libs",
    "preload_sundials",
    "resolve_compiler",
    "toolchain_identity",
]

#: Directory holding the driver sources (:data:`DRIVER_C_FILES`, gs_driver.h,
#: gs_internal.h, gs_model_abi.h, sundials7.h) -- package data.
ENGINE_DIR = Path(__file__).resolve().parent

#: Library stems needed by the driver, in dependency order (each needs only the
#: ones before it): the order in which :func:`preload_sundials` loads them.
_REQUIRED = (
    "sundials_core",
    "sundials_nvecserial",
    "sundials_sunmatrixdense",
    "sundials_sunlinsoldense",
    "sundials_cvode",
    "sundials_ida",
)

#: Compiler flags of every build (they enter the cache key through
#: :func:`toolchain_identity`).  No rpath: see the module docstring.
CFLAGS: tuple[str, ...] = ("-O3", "-fPIC", "-shared")
#: Flags of the driver object (compiled once per driver version and toolchain:
#: :func:`driver_object`).
DRIVER_CFLAGS: tuple[str, ...] = ("-O3", "-fPIC", "-c")
#: Generated model sources longer than this many bytes are compiled with -O1: gcc's
#: -O3 on the large, straight-line CasADi code of big models costs seconds and
#: hundreds of MB for no run-time gain (measured: a 66-state chain, 17.6 s at -O3
#: against 9.9 s at -O1 under load, same step cost).
LARGE_MODEL_BYTES = 400_000
_LDLIBS: tuple[str, ...] = ("-lm",)

#: The driver's translation units (in :data:`ENGINE_DIR`): the integration loop
#: (gs_driver.c) and the parts it is split into, which share ``gs_internal.h``.
DRIVER_C_FILES: tuple[str, ...] = (
    "gs_driver.c",
    "gs_util.c",
    "gs_callbacks.c",
    "gs_events.c",
    "gs_workspace.c",
    "gs_eval.c",
    "gs_shoot.c",
    "gs_correct.c",
    "gs_newton.c",
    "gs_batch.c",
    "gs_ramp.c",
)
#: Files of this package whose bytes change the binary of every build.
_DRIVER_FILES = (*DRIVER_C_FILES, "gs_driver.h", "gs_internal.h", "gs_model_abi.h", "sundials7.h", "build.py")


@dataclass(frozen=True)
class SundialsLibs:
    """The SUNDIALS shared libraries found in the scikit-sundae wheel.

    Attributes
    ----------
    libdir
        The ``scikit_sundae.libs`` directory.
    libs
        Full paths of the libraries, in dependency order (core first).
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
        (core, nvecserial, sunmatrixdense, sunlinsoldense, cvode, ida).

    Raises
    ------
    SundialsNotFoundError
        If scikit-sundae is not installed or some library is missing; the
        message lists what is missing and where it was looked for.
    """
    pkg = _sksundae_dir()
    libdir = pkg.parent / "scikit_sundae.libs"
    try:
        mtime = libdir.stat().st_mtime_ns
    except OSError:
        mtime = -1
    return _scan_libdir(pkg, libdir, mtime)


@functools.lru_cache(maxsize=8)
def _scan_libdir(pkg: Path, libdir: Path, mtime_ns: int) -> SundialsLibs:
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


_PRELOADED: dict[Path, list[ctypes.CDLL]] = {}


def preload_sundials() -> SundialsLibs:
    """Load the installed wheel's SUNDIALS libraries (``RTLD_LOCAL``).

    Model objects are linked without an rpath: their ``DT_NEEDED`` entries name the
    libraries by SONAME only, and the dynamic loader satisfies them from objects
    already loaded (glibc matches a ``DT_NEEDED`` SONAME against every loaded object,
    local or global).  ``RTLD_LOCAL`` keeps the SUNDIALS 7 symbols out of the
    process's global scope: with ``RTLD_GLOBAL`` they interposed on other libraries
    that bundle their own SUNDIALS (fmpy's CVODE crashed with a segmentation fault).  Called by :func:`gearsym.engine.driver.load_engine` before
    every model is loaded (once per process and library folder).

    Returns
    -------
    SundialsLibs
        The libraries that are now loaded.

    Raises
    ------
    SundialsNotFoundError
        If the libraries are missing.
    EngineABIError
        If one of them cannot be loaded.
    """
    sl = find_sundials_libs()
    if sl.libdir not in _PRELOADED:
        handles = []
        for p in sl.libs:
            try:
                handles.append(ctypes.CDLL(str(p), mode=ctypes.RTLD_LOCAL))
            except OSError as exc:
                raise EngineABIError(f"cannot load the SUNDIALS library {p}: {exc}") from exc
        _PRELOADED[sl.libdir] = handles
    return sl


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


@functools.lru_cache(maxsize=64)
def _sha256_cached(path: str, size: int, mtime_ns: int, ino: int) -> str:
    return _sha256(path)


def file_sha256(path: str | os.PathLike[str], *, cache: bool = False) -> str:
    """SHA-256 of a file's bytes (hex).

    Parameters
    ----------
    path
        The file.
    cache
        Reuse the digest computed earlier in this process while the file's size,
        modification time and inode are unchanged (for read-only inputs such as the
        SUNDIALS libraries; never for cache entries that are being verified).
    """
    p = os.fspath(path)
    if cache:
        st = os.stat(p)
        return _sha256_cached(p, st.st_size, st.st_mtime_ns, st.st_ino)
    return _sha256(p)


def resolve_compiler(cc: str | None = None) -> str:
    """The C compiler to use: ``cc``, else ``$CC``, else ``gcc``, as an absolute path.

    Raises
    ------
    EngineBuildError
        If it is not found.
    """
    cc = cc or os.environ.get("CC") or "gcc"
    path = shutil.which(cc)
    if path is None:
        raise EngineBuildError(f"C compiler '{cc}' not found; install gcc (e.g. apt-get install gcc)")
    return os.path.realpath(path)


@functools.lru_cache(maxsize=8)
def _compiler_version(path: str, size: int, mtime_ns: int) -> str:
    try:
        proc = subprocess.run([path, "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as exc:
        raise EngineBuildError(f"cannot run the C compiler {path} --version: {exc}") from exc
    return (proc.stdout or proc.stderr).strip()


def toolchain_identity(cc: str | None = None, extra_cflags: list[str] | tuple[str, ...] = ()) -> dict[str, object]:
    """Everything outside the generated model source that changes the binary.

    Parameters
    ----------
    cc
        Compiler (default: ``$CC`` or ``gcc``).
    extra_cflags
        Flags added to :data:`CFLAGS`.

    Returns
    -------
    dict
        ``compiler`` (absolute path), ``compiler_version`` (its ``--version``),
        ``cflags``, ``sundials`` (library file name -> SHA-256 of its bytes; the
        file names carry the SONAMEs) and ``driver`` (SHA-256 of the driver sources
        and of this module).  JSON-serialisable; computed once per process.

    Raises
    ------
    EngineBuildError, SundialsNotFoundError
        If the compiler or the libraries are missing.
    """
    path = resolve_compiler(cc)
    st = os.stat(path)
    sl = find_sundials_libs()
    stamps = tuple((name, *(lambda st: (st.st_size, st.st_mtime_ns))(os.stat(ENGINE_DIR / name)))
                   for name in _DRIVER_FILES)
    return {
        "compiler": path,
        "compiler_version": _compiler_version(path, st.st_size, st.st_mtime_ns),
        "cflags": [*CFLAGS, *extra_cflags, *_LDLIBS],
        "sundials": {p.name: file_sha256(p, cache=True) for p in sl.libs},
        "driver": _driver_digest(stamps),
    }


@functools.lru_cache(maxsize=8)
def _driver_digest(stamps: tuple) -> str:
    h = hashlib.sha256()
    for name, *_ in stamps:
        h.update(name.encode() + b"\0" + (ENGINE_DIR / name).read_bytes() + b"\0")
    return h.hexdigest()


def model_cflags(source_bytes: int) -> list[str]:
    """Optimisation flags for a generated model source of ``source_bytes`` bytes
    (appended after :data:`CFLAGS`; see :data:`LARGE_MODEL_BYTES`)."""
    return ["-O1"] if source_bytes > LARGE_MODEL_BYTES else []


def driver_cache_dir(fallback: str | os.PathLike[str]) -> Path:
    """Where driver objects are kept: ``$GEARSYM_DRIVER_CACHE``, else ``driver/`` in the
    user cache (:func:`gearsym.engine.trust.user_cache_dir`: on Linux
    ``$XDG_CACHE_HOME/gearsym/driver``, else ``~/.cache/gearsym/driver``), shared by every build
    root of the user (objects are named by content hash); ``fallback`` if that folder
    cannot be created.  :func:`driver_object` checks the folder (no other user can change
    it) and verifies what it finds there."""
    env = os.environ.get("GEARSYM_DRIVER_CACHE")
    if env:
        return Path(env)
    base = user_cache_dir() / "driver"
    try:
        base.mkdir(mode=0o700, parents=True, exist_ok=True)
        if os.access(base, os.W_OK):
            return base
    except OSError:
        pass
    return Path(fallback)


#: Largest driver object read from the driver cache.
_DRIVER_LIMIT = 256 << 20
_DRIVER_TAG = "gearsym driver v1"


def _driver_verified(dir_fd: int, name: str) -> bool:
    """Whether the driver object ``name`` in ``dir_fd`` is an ELF relocatable object signed by
    this user's gearsym (its ``.sig`` holds the HMAC of its name and SHA-256)."""
    data = read_file_at(dir_fd, name, _DRIVER_LIMIT)
    sig = read_file_at(dir_fd, name + ".sig", 256)
    if data is None or sig is None or not _is_elf_relocatable_bytes(data):
        return False
    return verify(signing_key(create=False), sig.decode("ascii", "replace"), _DRIVER_TAG, name,
                  hashlib.sha256(data).hexdigest())


def _driver_why(dir_fd: int, name: str, force: bool) -> str:
    """Why the driver object ``name`` is (re)built, for the log."""
    if force:
        return "rebuild asked for (force)"
    try:
        os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except OSError:
        return "none yet for this driver version and compiler"
    return "the object there does not verify: damaged, truncated, unsigned or not made by this user's gearsym"


def _install_driver(dir_fd: int, tmpdir: str, name: str, key: bytes) -> None:
    """Sign the new driver object ``<tmpdir>/driver.o`` and move it (then its signature) into place."""
    obj = os.path.join(tmpdir, "driver.o")
    os.chmod(obj, 0o644)
    with open(obj, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    sig = os.path.join(tmpdir, "driver.sig")
    with open(sig, "x", encoding="ascii") as f:
        f.write(sign(key, _DRIVER_TAG, name, digest))
    os.replace(obj, name, dst_dir_fd=dir_fd)
    os.replace(sig, name + ".sig", dst_dir_fd=dir_fd)


def driver_object(folder: str | os.PathLike[str], cc: str | None = None, *, force: bool = False) -> Path:
    """The driver compiled to one position-independent object, once per driver version.

    The driver (:data:`DRIVER_C_FILES`, about 2,800 lines) compiled into every model cost
    70-80 % of a small model's cold compile.  Its files are compiled concurrently (one
    compiler per CPU) and joined by a relocatable link (``cc -nostdlib -r``) into one
    object, named by a SHA-256 over the driver sources, the compiler identity and
    :data:`DRIVER_CFLAGS`, made under a file lock in a private temporary folder and
    renamed into place, so concurrent builders share one compile.  The helpers the files
    share have hidden visibility (``gs_internal.h``): a model's shared object exports only
    the entry points of ``gs_driver.h``.

    Like a model build, the object is signed with the user's key (``<object>.sig``) and
    used only if it verifies (an ELF relocatable object with the signed SHA-256, in a
    folder no other user can change, read without following links); a damaged,
    truncated, planted or unsigned object is rebuilt.

    Parameters
    ----------
    folder
        Where driver objects are kept (:func:`driver_cache_dir`).
    cc
        Compiler (default: ``$CC`` or ``gcc``).
    force
        Rebuild it even if it verifies (``gearsym compile --force``).

    Returns
    -------
    Path
        The object file.

    Raises
    ------
    EngineBuildError
        If the compiler or the relocatable link fails.
    UntrustedCacheError
        If the folder, its lock file or the signing key is not safe to use.
    """
    cc = resolve_compiler(cc)
    tc = toolchain_identity(cc)
    h = hashlib.sha256(json.dumps([tc["driver"], tc["compiler"], tc["compiler_version"],
                                   list(DRIVER_CFLAGS)]).encode())
    name = f"gs_driver-{h.hexdigest()[:16]}.o"
    key = signing_key()
    dir_fd, real = open_secure_directory(folder, create=True, what="driver cache")
    try:
        if not force and _driver_verified(dir_fd, name):
            _log.debug("driver object %s: verified, reused", real / name)
            return real / name
        with locked_file(dir_fd, f".{name}.lock", Path(folder)):
            if not force and _driver_verified(dir_fd, name):  # made by another process while we waited
                return real / name
            _log.info("driver object %s: compiling it (%s)", real / name, _driver_why(dir_fd, name, force))
            t0 = time.perf_counter()
            with tempfile.TemporaryDirectory(prefix=f".{name}.", dir=real) as td:
                tmp = Path(td) / "driver.o"
                (Path(td) / "units").mkdir()
                _compile_driver(cc, Path(td) / "units", tmp)
                # an ELF relocatable object, never a damaged file, goes in the cache
                if not _is_elf_relocatable(tmp):
                    raise EngineBuildError(f"the compiler {cc} wrote an invalid ELF object for the driver")
                _install_driver(dir_fd, td, name, key)
            _log.info("driver object %s: compiled in %.2f s", real / name, time.perf_counter() - t0)
        return real / name
    finally:
        os.close(dir_fd)


def _run_compiler(cmds: list[list[str]], what: str) -> None:
    """Run compiler command lines, at most one per CPU at a time; raise on the first failure."""
    width = max(1, min(len(cmds), os.cpu_count() or 1))
    pending = list(cmds)
    running: list[tuple[list[str], subprocess.Popen]] = []
    failure: tuple[list[str], int, str] | None = None
    try:
        while pending or running:
            while pending and len(running) < width and failure is None:
                cmd = pending.pop(0)
                try:
                    running.append((cmd, subprocess.Popen(cmd, cwd=ENGINE_DIR, stdout=subprocess.PIPE,
                                                          stderr=subprocess.PIPE, text=True)))
                except OSError as exc:
                    raise EngineBuildError(f"cannot run the C compiler {cmd[0]}: {exc}") from exc
            if not running:
                break
            cmd, proc = running.pop(0)
            _, err = proc.communicate()
            if proc.returncode != 0 and failure is None:
                failure = (cmd, proc.returncode, err)
    finally:
        for _, proc in running:
            proc.kill()
            proc.wait()
    if failure is not None:
        cmd, code, err = failure
        raise EngineBuildError(f"{what} failed (exit {code}):\n{' '.join(cmd)}\n{err.strip()}")


def _is_elf_relocatable_bytes(head: bytes) -> bool:
    """Whether ``head`` starts like an ELF relocatable object (e_type ET_REL = 1)."""
    return head[:4] == b"\x7fELF" and int.from_bytes(head[16:18], "little") == 1


def _is_elf_relocatable(path: Path) -> bool:
    """Whether the file ``path`` starts like an ELF relocatable object."""
    with open(path, "rb") as f:
        return _is_elf_relocatable_bytes(f.read(18))


def _compile_driver(cc: str, workdir: Path, out: Path) -> None:
    """Compile :data:`DRIVER_C_FILES` into ``workdir`` and link them into the relocatable ``out``."""
    objs = [workdir / (Path(src).stem + ".o") for src in DRIVER_C_FILES]
    _run_compiler([[cc, *DRIVER_CFLAGS, f"-I{ENGINE_DIR}", src, "-o", str(o)]
                   for src, o in zip(DRIVER_C_FILES, objs)], "compiling the driver")
    for src, o in zip(DRIVER_C_FILES, objs):
        if not _is_elf_relocatable(o):
            raise EngineBuildError(f"the compiler {cc} wrote an invalid ELF object for the driver's {src}")
    _run_compiler([[cc, "-nostdlib", "-r", *map(str, objs), "-o", str(out)]], "linking the driver object")


def driver_sources() -> tuple[list[Path], list[Path]]:
    """Driver C sources and include directories to add to a model build.

    Returns
    -------
    sources, include_dirs
        The files of :data:`DRIVER_C_FILES` and ``[ENGINE_DIR]``.  The model build
        must also provide ``gs_model.h`` on its include path.
    """
    return [ENGINE_DIR / name for name in DRIVER_C_FILES], [ENGINE_DIR]


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
    cwd: Path | None = None,
) -> Path:
    """Compile C sources into a shared object linked against SUNDIALS 7.

    Runs ``gcc -O3 -fPIC -shared -I... sources -o tmp <full library paths> -lm``
    (no rpath: load it with :func:`gearsym.engine.driver.load_engine`, which
    preloads the libraries); the object is written to a temporary name in the
    destination directory and moved into place with :func:`os.replace`, so a
    reader never sees a half-written file.

    Parameters
    ----------
    c_sources
        C files (typically the generated model files and
        :func:`driver_sources`); relative paths are relative to ``cwd``.
    include_dirs
        Include directories (the engine directory and the directory holding
        ``gs_model.h``).
    out_path
        Destination of the shared object (name it by content hash).
    extra_cflags
        Additional compiler flags.
    cc
        Compiler (default: ``$CC`` or ``gcc``).
    cwd
        Working directory of the compiler (default: the current one).  Passing the
        model's folder and relative source names keeps temporary folder names out
        of the object, so equal sources give equal bytes.

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
    cc = resolve_compiler(cc)
    out_path = Path(out_path).absolute()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out_path.name}.", suffix=".tmp", dir=out_path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    cmd = [cc, *CFLAGS]
    cmd += list(extra_cflags or [])
    for d in include_dirs:
        cmd.append(f"-I{Path(d)}")
    cmd += [str(Path(s)) for s in c_sources]
    cmd += ["-o", str(tmp)]
    cmd += [str(p) for p in sl.libs]
    cmd += list(_LDLIBS)
    try:
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
        except OSError as exc:
            raise EngineBuildError(f"cannot run the C compiler {cc}: {exc}") from exc
        if proc.returncode != 0:
            raise EngineBuildError(
                f"C compilation failed (exit {proc.returncode}):\n{' '.join(cmd)}\n{proc.stderr.strip()}"
            )
        os.replace(tmp, out_path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return out_path
