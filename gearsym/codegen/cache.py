"""The build cache: where compiled scenes live, how a build is named, verified and
installed.

A build is the folder ``<root>/<scene>-<key[:16]>/`` holding ``gs_model.c``,
``gs_model.h``, ``gs_<sha256[:16]>.so`` and ``meta.json``.  Its key
(:func:`build_key`) is a SHA-256 over everything that changes the binary: the model
file's text, the effect choices, the model form, the gearsym version and the
sources of the spec, symbolic and codegen layers, the CasADi version and the
toolchain (compiler path and ``--version``, flags, the SUNDIALS libraries' bytes,
the driver sources: :func:`gearsym.engine.build.toolchain_identity`).  The key is
compiled into the object (``gs_build_key()``) and recorded in ``meta.json`` with
the object's SHA-256; a build is reused only if all of them agree
(:meth:`BuildCache.lookup`, before any ``dlopen``).

Builds are made in a private folder ``<root>/.tmp-<name>-*`` under a per-build file
lock (``<root>/.<name>.lock``, :func:`fcntl.flock`) and renamed into place, so N
processes compiling one new model produce one build and N successes, and a reader
never sees a half-written build.  Lock files are removed when released (a waiter
that locked a removed file retries), so an idle cache holds only builds.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from ..errors import CompileError

__all__ = ["BuildCache", "BuildEntry", "CacheEntry", "build_key", "safe_name"]

_PKG = Path(__file__).resolve().parent.parent
#: Python sources whose changes change the generated code (the spec -> symbolic ->
#: codegen chain); the driver sources enter through the toolchain identity.
_SOURCE_DIRS = ("spec", "symbolic", "codegen")
#: Marker in front of the key in the object's read-only data (gs_build_key()).
KEY_MARKER = b"gearsym-build-key:"
_ENTRY_RE = re.compile(r"^(?P<name>[A-Za-z0-9_][A-Za-z0-9_.-]*)-(?P<key>[0-9a-f]{16})$")


def safe_name(name: str, limit: int = 64) -> str:
    """A folder-name-safe form of a scene name: ``[A-Za-z0-9_.-]``, not starting with a
    dot, at most ``limit`` characters (other characters become ``_``)."""
    s = re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:limit].lstrip(".-")
    return s or "scene"


@functools.lru_cache(maxsize=1)
def _sources_digest() -> str:
    h = hashlib.sha256()
    for sub in _SOURCE_DIRS:
        for f in sorted((_PKG / sub).glob("*.py")):
            h.update(f"{sub}/{f.name}".encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def build_key(model_text: str, effects: dict, form: str, *, cc: str | None = None,
              derivatives: bool = False) -> tuple[str, dict]:
    """The key of a build: SHA-256 over everything that changes the binary.

    Parameters
    ----------
    model_text
        The model file's text.
    effects
        The resolved effect choices.
    form
        ``"explicit"`` or ``"implicit"``.
    cc
        Compiler (default ``$CC`` or ``gcc``).
    derivatives
        The build carries the parameter derivatives (``gs_jacp``, ...) of the
        sensitivities (a separate build: :func:`gearsym.codegen.generate.build_functions`).

    Returns
    -------
    key, parts
        64 hex digits, and the JSON-serialisable parts it was computed from (recorded
        in ``meta.json``; the model text enters as its SHA-256).  The scene's name is
        not part of it: it does not change the binary.
    """
    from .._version import __version__
    from ..engine.build import toolchain_identity
    from .artifact import CODEGEN_VERSION

    parts = {
        "gearsym": __version__,
        "codegen_version": CODEGEN_VERSION,
        "sources": _sources_digest(),
        "casadi": ca.__version__,
        "model_sha256": hashlib.sha256(model_text.encode()).hexdigest(),
        "effects": {k: effects[k] for k in sorted(effects)},
        "form": form,
        "toolchain": toolchain_identity(cc),
    }
    if derivatives:
        parts["parameter_derivatives"] = True
    key = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return key, parts


@dataclass(frozen=True)
class BuildEntry:
    """Where one build lives: ``directory`` (inside the cache root) and its lock file."""

    root: Path
    name: str
    directory: Path
    lock: Path


@dataclass(frozen=True)
class CacheEntry:
    """One build found in a cache (for ``gearsym cache list``)."""

    directory: Path
    scene: str
    model: str
    size: int
    built: float
    key: str
    complete: bool

    def as_dict(self) -> dict:
        """JSON-serialisable form."""
        return {"directory": str(self.directory), "scene": self.scene, "model": self.model,
                "size_bytes": self.size, "built": time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(self.built)),
                "key": self.key, "complete": self.complete}


class BuildCache:
    """A folder of builds (``generated/``, ``$GEARSYM_GENERATED`` or ``~/.cache/gearsym``).

    Parameters
    ----------
    root
        The cache folder (created on the first build).
    """

    def __init__(self, root: str | os.PathLike[str]):
        self.root = Path(root).absolute()

    # ---------------------------------------------------------------- naming
    def entry(self, scene: str, key: str) -> BuildEntry:
        """The build folder of a scene and key, checked to lie inside the root.

        Raises
        ------
        CompileError
            If the folder would resolve outside the cache root (a scene name or a
            symbolic link pointing elsewhere).
        """
        name = f"{safe_name(scene)}-{key[:16]}"
        directory = self.root / name
        root_r = self.root.resolve()
        dir_r = directory.resolve()
        if dir_r.parent != root_r or dir_r.name != name:
            raise CompileError(f"the build folder of scene {scene!r} would be {dir_r}, which is not a folder "
                               f"directly inside the build cache {root_r}; refusing to build there")
        return BuildEntry(self.root, name, directory, self.root / f".{name}.lock")

    # ---------------------------------------------------------------- verify
    def lookup(self, entry: BuildEntry, key: str):
        """The verified build of ``entry`` for ``key``, or None.

        A build verifies if ``meta.json`` parses and records ``key``, and the shared
        object's bytes have the SHA-256 recorded there and contain the key.  Nothing
        is loaded (a truncated object would kill the process in ``dlopen``).

        Returns
        -------
        GeneratedModel or None
        """
        from .artifact import GeneratedModel

        try:
            gen = GeneratedModel.from_json((entry.directory / "meta.json").read_text(encoding="utf-8"))
        except (OSError, ValueError, TypeError, KeyError):
            return None
        if gen.build_key != key or not gen.so_sha256:
            return None
        so = entry.directory / Path(gen.so_path).name
        try:
            data = so.read_bytes()
        except OSError:
            return None
        if hashlib.sha256(data).hexdigest() != gen.so_sha256 or KEY_MARKER + key.encode() not in data:
            return None
        gen.directory, gen.so_path = str(entry.directory), str(so)
        return gen

    # ---------------------------------------------------------------- build
    @contextmanager
    def locked(self, entry: BuildEntry) -> Iterator[None]:
        """Hold the build lock of ``entry`` (blocks while another process builds it).

        The lock file is removed on release; a waiter that then holds a lock on the
        removed file notices (the path no longer names its file) and retries.

        Raises
        ------
        CompileError
            If the cache folder or the lock file cannot be created.
        """
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise CompileError(f"cannot create the build cache {self.root}: {exc.strerror}") from None
        while True:
            try:
                fd = os.open(entry.lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
            except OSError as exc:
                raise CompileError(f"cannot create the lock file {entry.lock}: {exc.strerror}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)
                st = os.fstat(fd)
                try:
                    cur = os.stat(entry.lock)
                    same = (cur.st_dev, cur.st_ino) == (st.st_dev, st.st_ino)
                except FileNotFoundError:
                    same = False
            except BaseException:
                os.close(fd)
                raise
            if same:
                break
            os.close(fd)
        try:
            yield
        finally:
            try:
                os.unlink(entry.lock)
            finally:
                os.close(fd)

    @contextmanager
    def staging(self, entry: BuildEntry) -> Iterator[Path]:
        """A private folder for a new build of ``entry`` (call with the lock held).

        Stale staging folders of the same build (from a killed builder) are removed
        first; the folder is removed on exit unless :meth:`install` moved it.
        """
        for old in self.root.glob(f".tmp-{entry.name}-*"):
            shutil.rmtree(old, ignore_errors=True)
        for old in self.root.glob(f".trash-{entry.name}-*"):
            shutil.rmtree(old, ignore_errors=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".tmp-{entry.name}-", dir=self.root))
        try:
            yield tmp
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def install(self, staged: Path, entry: BuildEntry) -> None:
        """Move a complete staged build into place (call with the lock held).

        An existing folder (a build that did not verify, or one replaced by
        ``force``) is first renamed away, so the new one appears in one rename.
        """
        trash = None
        if entry.directory.exists() or entry.directory.is_symlink():
            trash = Path(tempfile.mkdtemp(prefix=f".trash-{entry.name}-", dir=self.root))
            os.rename(entry.directory, trash / "old")
        os.rename(staged, entry.directory)
        if trash is not None:
            shutil.rmtree(trash, ignore_errors=True)

    # ---------------------------------------------------------------- manage
    def builds(self) -> list[CacheEntry]:
        """The builds in the cache, oldest first (folders ``<name>-<16 hex>`` only)."""
        out = []
        if not self.root.is_dir():
            return out
        for d in sorted(self.root.iterdir()):
            m = _ENTRY_RE.match(d.name)
            if not m or d.is_symlink() or not d.is_dir():
                continue
            files = [f for f in d.iterdir() if f.is_file()]
            size = sum(f.stat().st_size for f in files)
            meta_path = d / "meta.json"
            scene, model, key, complete = m["name"], "?", m["key"], False
            built = d.stat().st_mtime
            try:
                meta = json.loads(meta_path.read_text(encoding="utf-8"))
                scene = str(meta.get("scene", scene))
                model = str(meta.get("model", "?"))
                key = str(meta.get("build_key") or meta.get("key") or key)
                built = float(meta.get("built") or meta_path.stat().st_mtime)
                complete = bool(meta.get("so_sha256")) and (d / Path(str(meta.get("so_path", ""))).name).is_file()
            except (OSError, ValueError, TypeError, AttributeError):
                pass
            out.append(CacheEntry(d, scene, model, size, built, key, complete))
        return sorted(out, key=lambda e: e.built)

    def clear(self, *, scene: str | None = None, older_than_days: float | None = None) -> list[CacheEntry]:
        """Remove builds (all, those of one scene, or those built more than N days ago).

        Only folders that look like builds (``<name>-<16 hex>``) and leftovers of
        killed builders (``.tmp-*``, ``.trash-*`` whose build is not locked) are
        removed; a build being made by another process right now is skipped.

        Returns
        -------
        list of CacheEntry
            What was removed.
        """
        removed = []
        now = time.time()
        for e in self.builds():
            if scene is not None and e.scene != scene and safe_name(scene) != e.directory.name[:-17]:
                continue
            if older_than_days is not None and now - e.built < older_than_days * 86400.0:
                continue
            name = e.directory.name
            lock = BuildEntry(self.root, name, e.directory, self.root / f".{name}.lock")
            if not self._try_remove(lock):
                continue
            removed.append(e)
        if scene is None and older_than_days is None:
            for d in [*self.root.glob(".tmp-*"), *self.root.glob(".trash-*")]:
                m = re.match(r"^\.(?:tmp|trash)-(.+-[0-9a-f]{16})-", d.name)
                if m and d.is_dir() and not d.is_symlink():
                    self._try_remove(BuildEntry(self.root, m[1], d, self.root / f".{m[1]}.lock"))
        return removed

    def _try_remove(self, entry: BuildEntry) -> bool:
        """Remove ``entry.directory`` if its build lock is free; False if in use."""
        try:
            fd = os.open(entry.lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError:
            return False
        held = False
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                return False  # a build of it is being made right now
            st, cur = os.fstat(fd), os.stat(entry.lock)
            held = (cur.st_dev, cur.st_ino) == (st.st_dev, st.st_ino)
            if not held:
                return False
            trash = Path(tempfile.mkdtemp(prefix=f".trash-{entry.name}-", dir=self.root))
            os.rename(entry.directory, trash / "old")
            shutil.rmtree(trash, ignore_errors=True)
            return True
        except OSError:
            return False
        finally:
            if held:
                try:
                    os.unlink(entry.lock)
                except OSError:
                    pass
            os.close(fd)
