"""The build cache: where compiled scenes live, how a build is named, signed, verified
and installed.

A build is the folder ``<root>/<scene>-<key[:16]>/`` holding ``gs_model.c``,
``gs_model.h``, ``gs_<sha256[:16]>.so`` and ``meta.json``.  Its key
(:func:`build_key`) is a SHA-256 over everything that changes the binary: the model
file's text, the effect choices, the model form, the gearsym version and the
sources of the spec, symbolic and codegen layers, the CasADi version and the
toolchain (compiler path and ``--version``, flags, the SUNDIALS libraries' bytes,
the driver sources: :func:`gearsym.engine.build.toolchain_identity`).  The key is
compiled into the object (``gs_build_key()``) and recorded in ``meta.json``.

**Only this user's builds are loaded.**  When a build is installed, its ``meta.json``
is signed with the user's secret key (:func:`gearsym.engine.trust.signing_key`, kept in
the user cache, never in a build folder): an HMAC-SHA256 over the build key, the
SHA-256 of the object and of the sources, and the whole ``meta.json``
(:func:`build_signature`).  :meth:`BuildCache.lookup` reuses a build only if the
signature verifies and every file has the SHA-256 it was signed with -- checked before
any ``dlopen`` and before any serialised function is read -- so a build planted in a
folder (whatever its ``meta.json`` says) or copied from another user's cache is never
loaded, and ``cache clear`` removes only builds that verify.  Every cache folder is
checked to be one no other user can change (:func:`gearsym.engine.trust.open_secure_directory`),
and every file in it is opened relative to the folder's descriptor without following
symbolic links, as a regular file of the user with one link, up to a size limit
(:data:`META_LIMIT`, :data:`SO_LIMIT`).

Builds are made in a private folder ``<root>/.tmp-<name>-*`` under a per-build file
lock (``<root>/.<name>.lock``, :func:`gearsym.engine.trust.locked_file`) and renamed into
place, so N processes compiling one new model produce one build and N successes, and
a reader never sees a half-written build.  Lock files are removed when released (a
waiter that locked a removed file retries), so an idle cache holds only builds.
Staging and trash folders carry a signed marker: a leftover of a killed builder is
removed only if gearsym made it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import re
import shutil
import stat
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from ..engine.trust import (
    UntrustedCacheError,
    locked_file,
    open_secure_directory,
    read_file_at,
    sign,
    signing_key,
    verify,
    writable_by_others,
)
from ..errors import CompileError

__all__ = ["BuildCache", "BuildEntry", "CacheEntry", "UntrustedCacheError", "build_key", "build_signature",
           "safe_name"]

_log = logging.getLogger(__name__)
_PKG = Path(__file__).resolve().parent.parent
#: Python sources whose changes change the generated code (the spec -> symbolic ->
#: codegen chain); the driver sources enter through the toolchain identity.
_SOURCE_DIRS = ("spec", "symbolic", "codegen")
#: Marker in front of the key in the object's read-only data (gs_build_key()).
KEY_MARKER = b"gearsym-build-key:"
_ENTRY_RE = re.compile(r"^(?P<name>[A-Za-z0-9_][A-Za-z0-9_.-]*)-(?P<key>[0-9a-f]{16})$")
_SO_RE = re.compile(r"^gs_[0-9a-f]{16}\.so$")
#: The sources of a build (signed with it; the exported C program and FMU copy them).
_SOURCES = ("gs_model.c", "gs_model.h")
#: Largest ``meta.json``, shared object and source read from a cache (a larger file is
#: not read at all: it is not a build of ours).  The largest builds measured (130 states)
#: are far below: a few MB of metadata, a few MB of object.
META_LIMIT = 128 << 20
SO_LIMIT = 512 << 20
SOURCE_LIMIT = 256 << 20
#: Signed marker file of staging and trash folders.
_MARKER = ".gearsym-staging"
_SIG_TAG = "gearsym build v1"
_STAGE_TAG = "gearsym staging v1"


def safe_name(name: str, limit: int = 64) -> str:
    """A folder-name-safe form of a scene name: ``[A-Za-z0-9_.-]``, not starting with a
    dot, at most ``limit`` characters (other characters become ``_``)."""
    s = re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:limit].lstrip(".-")
    return s or "scene"


@functools.lru_cache(maxsize=1)
def _sources_digest() -> str:
    h = hashlib.sha256()
    for sub in _SOURCE_DIRS:  # every module below them (element modules in subpackages included)
        for f in sorted((_PKG / sub).rglob("*.py")):
            h.update(f.relative_to(_PKG).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def build_key(model_text: str, effects: dict, form: str, *, cc: str | None = None,
              derivatives: bool = False, data: str = "") -> tuple[str, dict]:
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
    data
        The digest of the data the model reads besides its file (its tables:
        :meth:`gearsym.spec.model.ModelSpec.data_digest`; a changed table file is a new build).

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
    if data:
        parts["data_sha256"] = data
    key = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return key, parts


def _canonical(obj: object) -> bytes:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()


def build_signature(key: bytes, meta: dict, files: dict[str, str]) -> str:
    """The HMAC of a build (:func:`gearsym.engine.trust.sign`): over its key, the shared
    object's SHA-256, the SHA-256 of each of its files and the whole ``meta.json``
    (without the signature)."""
    return sign(key, _SIG_TAG, str(meta.get("build_key", "")), str(meta.get("so_sha256", "")),
                _canonical(files), _canonical(meta))


def _sha256_at(dir_fd: int, name: str, limit: int) -> tuple[str, bytes] | None:
    data = read_file_at(dir_fd, name, limit)
    return None if data is None else (hashlib.sha256(data).hexdigest(), data)


def _open_dir_at(dir_fd: int, name: str) -> int | None:
    """A descriptor of the folder ``name`` in ``dir_fd`` if it is a real folder (not a link) of
    the user that no other user can write, else None."""
    try:
        fd = os.open(name, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC, dir_fd=dir_fd)
    except OSError:
        return None
    st = os.fstat(fd)
    if st.st_uid != os.geteuid() or writable_by_others(st):
        os.close(fd)
        return None
    return fd


def _read_signed(dir_fd: int, key: bytes | None) -> tuple[dict, dict[str, str]] | None:
    """``(meta, files)`` of the build folder ``dir_fd`` if its ``meta.json`` carries this
    user's signature, else None."""
    if key is None:
        return None
    raw = read_file_at(dir_fd, "meta.json", META_LIMIT)
    if raw is None:
        return None
    try:
        meta = json.loads(raw)
    except ValueError:
        return None
    sig = meta.pop("signature", None) if isinstance(meta, dict) else None
    files = sig.get("files") if isinstance(sig, dict) else None
    if not (isinstance(files, dict) and all(isinstance(v, str) for v in files.values())):
        return None
    if not verify(key, sig.get("hmac"), _SIG_TAG, str(meta.get("build_key", "")), str(meta.get("so_sha256", "")),
                  _canonical(files), _canonical(meta)):
        return None
    return meta, files


def _intact(dir_fd: int, meta: dict, files: dict[str, str], key: str) -> bool:
    """Whether the files of a signed build have the SHA-256 it was signed with, and the
    shared object carries ``key``."""
    so_name = Path(str(meta.get("so_path", ""))).name
    if not _SO_RE.match(so_name) or set(files) != {so_name, *_SOURCES} or files[so_name] != meta.get("so_sha256"):
        return False
    for name, digest in files.items():
        got = _sha256_at(dir_fd, name, SO_LIMIT if name == so_name else SOURCE_LIMIT)
        if got is None or got[0] != digest:
            return False
        if name == so_name and KEY_MARKER + key.encode() not in got[1]:
            return False
    return True


@dataclass(frozen=True)
class BuildEntry:
    """Where one build lives: ``directory`` (inside the cache root) and its lock file."""

    root: Path
    name: str
    directory: Path
    lock: Path


@dataclass(frozen=True)
class CacheEntry:
    """One build found in a cache (for ``gearsym cache list``).

    ``verified``: signed by this user's gearsym (only such builds are loaded or removed);
    ``complete``: verified and its files intact.
    """

    directory: Path
    scene: str
    model: str
    size: int
    built: float
    key: str
    complete: bool
    verified: bool = False

    def as_dict(self) -> dict:
        """JSON-serialisable form."""
        return {"directory": str(self.directory), "scene": self.scene, "model": self.model,
                "size_bytes": self.size, "built": time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(self.built)),
                "key": self.key, "complete": self.complete, "verified": self.verified}


class BuildCache:
    """A folder of builds (the user cache, ``$GEARSYM_GENERATED`` or a folder named explicitly).

    Every use checks that no other user can change the folder
    (:func:`gearsym.engine.trust.open_secure_directory`: an :class:`UntrustedCacheError`
    names the folder and the reason otherwise) and opens what is in it relative to the
    folder's descriptor without following symbolic links.

    Parameters
    ----------
    root
        The cache folder (created, mode 0700, on the first build).
    """

    def __init__(self, root: str | os.PathLike[str]):
        self.root = Path(root).absolute()

    @contextmanager
    def _opened(self, create: bool) -> Iterator[tuple[int, Path] | None]:
        """``(descriptor, real path)`` of the verified root; None if it does not exist and not ``create``."""
        try:
            fd, real = open_secure_directory(self.root, create=create, what="build cache")
        except FileNotFoundError:
            if create:
                raise CompileError(f"cannot create the build cache {self.root}") from None
            fd = None
        if fd is None:
            yield None
            return
        try:
            yield fd, real
        finally:
            os.close(fd)

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
        try:
            root_r = self.root.resolve()
            dir_r = directory.resolve()
        except (OSError, RuntimeError) as exc:  # a symbolic link loop
            raise CompileError(f"the build folder {directory} cannot be resolved ({exc}); "
                               "refusing to build there") from None
        if dir_r.parent != root_r or dir_r.name != name:
            raise CompileError(f"the build folder of scene {scene!r} would be {dir_r}, which is not a folder "
                               f"directly inside the build cache {root_r}; refusing to build there")
        return BuildEntry(self.root, name, directory, self.root / f".{name}.lock")

    # ---------------------------------------------------------------- verify
    def lookup(self, entry: BuildEntry, key: str):
        """The verified build of ``entry`` for ``key``, or None.

        A build verifies if its ``meta.json`` carries this user's signature
        (:func:`build_signature`) and records ``key``, and its files (shared object and
        sources, regular files of the user with one link, read without following links
        and up to a size limit) have the SHA-256 it was signed with, the object
        containing the key.  Nothing is loaded.

        Returns
        -------
        GeneratedModel or None

        Raises
        ------
        UntrustedCacheError
            If the cache folder or the signing key is not safe to use.
        """
        gen, why = self.check(entry, key)
        _log.debug("build cache %s: %s", "hit" if gen is not None else "miss", why)
        return gen

    def check(self, entry: BuildEntry, key: str):
        """:meth:`lookup` with the reason: ``(build or None, why)``, ``why`` one line
        for the logs ("no build folder ...", "... is not signed by this user's gearsym", ...).

        Raises
        ------
        UntrustedCacheError
            If the cache folder or the signing key is not safe to use.
        """
        from .artifact import GeneratedModel

        key_bytes = signing_key(create=False)
        with self._opened(create=False) as opened:
            if opened is None:
                return None, f"no build cache folder {self.root} yet"
            if key_bytes is None:
                return None, "no signing key yet (this user's gearsym has made no build)"
            dfd = _open_dir_at(opened[0], entry.name)
            if dfd is None:
                return None, f"no build folder {entry.directory} (or not a folder of yours)"
            try:
                signed = _read_signed(dfd, key_bytes)
                if signed is None:
                    return None, (f"{entry.directory}/meta.json is missing, unreadable or not signed by this "
                                  "user's gearsym (planted, edited or copied from elsewhere)")
                if signed[0].get("build_key") != key:
                    return None, f"{entry.directory} holds a build of another key"
                if not _intact(dfd, *signed, key):
                    return None, (f"a file of {entry.directory} is missing or does not have the SHA-256 it was "
                                  "signed with (damaged or edited)")
            finally:
                os.close(dfd)
        try:
            gen = GeneratedModel(**signed[0])
        except TypeError:
            return None, f"{entry.directory}/meta.json does not describe a build of this gearsym"
        gen.directory, gen.so_path = str(entry.directory), str(entry.directory / Path(gen.so_path).name)
        return gen, f"verified build {entry.directory}"

    # ---------------------------------------------------------------- build
    @contextmanager
    def locked(self, entry: BuildEntry) -> Iterator[None]:
        """Hold the build lock of ``entry`` (blocks while another process builds it).

        The lock file is created without following links and removed on release
        (:func:`gearsym.engine.trust.locked_file`).

        Raises
        ------
        CompileError
            If the cache folder or the lock file cannot be created, or is not safe.
        """
        with self._opened(create=True) as (rfd, _), locked_file(rfd, entry.lock.name, self.root):
            yield

    @staticmethod
    def _mark(directory: str, key: bytes) -> None:
        """Sign a staging or trash folder gearsym just made (so that it may remove it later)."""
        fd = os.open(os.path.join(directory, _MARKER), os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW
                     | os.O_CLOEXEC, 0o600)
        try:
            os.write(fd, sign(key, _STAGE_TAG, os.path.basename(directory)).encode())
        finally:
            os.close(fd)

    def _temp_dir(self, real: Path, prefix: str, key: bytes) -> str:
        """A new signed private folder ``<prefix>*`` in the root (its name)."""
        d = tempfile.mkdtemp(prefix=prefix, dir=real)
        self._mark(d, key)
        return os.path.basename(d)

    @staticmethod
    def _remove_leftover(rfd: int, name: str, key: bytes | None) -> bool:
        """Remove a staging / trash folder if gearsym signed it (or it is empty)."""
        dfd = _open_dir_at(rfd, name)
        if dfd is None:
            return False
        try:
            mark = read_file_at(dfd, _MARKER, 256)
            ours = mark is not None and verify(key, mark.decode("ascii", "replace"), _STAGE_TAG, name)
            empty = not os.listdir(dfd)
        finally:
            os.close(dfd)
        try:
            if ours:
                shutil.rmtree(name, dir_fd=rfd)
            elif empty:
                os.rmdir(name, dir_fd=rfd)
            else:
                return False
        except OSError:
            return False
        return True

    @contextmanager
    def staging(self, entry: BuildEntry) -> Iterator[Path]:
        """A private folder for a new build of ``entry`` (call with the lock held).

        Leftover staging and trash folders of the same build (from a killed builder)
        are removed first if gearsym signed them; the folder is removed on exit unless
        :meth:`install` moved it.
        """
        key = signing_key()
        with self._opened(create=True) as (rfd, real):
            for name in os.listdir(rfd):
                if name.startswith((f".tmp-{entry.name}-", f".trash-{entry.name}-")):
                    self._remove_leftover(rfd, name, key)
            tmp = self.root / self._temp_dir(real, f".tmp-{entry.name}-", key)
        try:
            yield tmp
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    @staticmethod
    def _sign_staged(sfd: int, key: bytes, where: Path) -> None:
        """Sign the build in the staging folder ``sfd``: no file writable by others, the
        signature (:func:`build_signature`) written into its ``meta.json``."""
        for name in os.listdir(sfd):
            fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC, dir_fd=sfd)
            try:
                os.fchmod(fd, stat.S_IMODE(os.fstat(fd).st_mode) & ~0o022)
            finally:
                os.close(fd)
        raw = read_file_at(sfd, "meta.json", META_LIMIT)
        meta = json.loads(raw) if raw is not None else {}
        meta.pop("signature", None)
        so_name = Path(str(meta.get("so_path", ""))).name
        files = {}
        for name in (so_name, *_SOURCES):
            got = _sha256_at(sfd, name, SO_LIMIT if name == so_name else SOURCE_LIMIT) if name else None
            if got is None:
                raise CompileError(f"the new build in {where} has no readable {name or 'shared object'}")
            files[name] = got[0]
        if files[so_name] != meta.get("so_sha256"):
            raise CompileError(f"the shared object of the new build in {where} changed after it was checked")
        meta["signature"] = {"files": files, "hmac": build_signature(key, meta, files)}
        fd = os.open("meta.json.tmp", os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644,
                     dir_fd=sfd)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(json.dumps(meta, indent=1))
        os.replace("meta.json.tmp", "meta.json", src_dir_fd=sfd, dst_dir_fd=sfd)

    def install(self, staged: Path, entry: BuildEntry) -> None:
        """Sign a complete staged build and move it into place (call with the lock held).

        An existing folder at the build's place (a build that did not verify, or one
        replaced by ``force``) is first renamed into a signed trash folder, so the new
        one appears in one rename.
        """
        key = signing_key()
        with self._opened(create=True) as (rfd, real):
            sfd = _open_dir_at(rfd, staged.name)
            if sfd is None:
                raise CompileError(f"the staging folder {staged} is gone or not yours")
            try:
                self._sign_staged(sfd, key, staged)
                os.unlink(_MARKER, dir_fd=sfd)
            finally:
                os.close(sfd)
            trash = None
            if os.path.lexists(real / entry.name):
                trash = self._temp_dir(real, f".trash-{entry.name}-", key)
                os.rename(entry.name, f"{trash}/old", src_dir_fd=rfd, dst_dir_fd=rfd)
            os.rename(staged.name, entry.name, src_dir_fd=rfd, dst_dir_fd=rfd)
            if trash is not None:
                shutil.rmtree(trash, dir_fd=rfd, ignore_errors=True)

    # ---------------------------------------------------------------- manage
    @staticmethod
    def _describe(dfd: int, d: Path, m: re.Match, key: bytes | None) -> CacheEntry:
        size = 0
        for name in os.listdir(dfd):
            st = os.stat(name, dir_fd=dfd, follow_symlinks=False)
            size += st.st_size if stat.S_ISREG(st.st_mode) else 0
        signed = _read_signed(dfd, key)
        if signed is None:
            return CacheEntry(d, m["name"], "?", size, os.fstat(dfd).st_mtime, m["key"], False, False)
        meta, files = signed
        bkey = str(meta.get("build_key", ""))
        built = meta.get("built")
        return CacheEntry(d, str(meta.get("scene", m["name"])), str(meta.get("model", "?")), size,
                          float(built) if isinstance(built, (int, float)) else os.fstat(dfd).st_mtime,
                          bkey or m["key"], _intact(dfd, meta, files, bkey), True)

    def builds(self) -> list[CacheEntry]:
        """The builds in the cache, oldest first (folders ``<name>-<16 hex>`` of the user).

        ``verified`` tells those signed by this user's gearsym; the others (copied from
        elsewhere, made by another user, or by a gearsym before signatures) are never
        loaded nor removed."""
        key = signing_key(create=False)
        out = []
        with self._opened(create=False) as opened:
            if opened is None:
                return out
            for name in sorted(os.listdir(opened[0])):
                m = _ENTRY_RE.match(name)
                dfd = _open_dir_at(opened[0], name) if m else None
                if dfd is None:
                    continue
                try:
                    out.append(self._describe(dfd, self.root / name, m, key))
                finally:
                    os.close(dfd)
        return sorted(out, key=lambda e: e.built)

    def clear(self, *, scene: str | None = None, older_than_days: float | None = None) -> list[CacheEntry]:
        """Remove builds (all, those of one scene, or those built more than N days ago).

        Only builds this user's gearsym signed are removed (any other folder, even one
        named like a build, is left alone), and, when clearing everything, leftovers of
        killed builders (``.tmp-*``, ``.trash-*`` folders gearsym signed, whose build is
        not locked); a build being made by another process right now is skipped.

        Returns
        -------
        list of CacheEntry
            What was removed.
        """
        removed = []
        now = time.time()
        key = signing_key(create=False)
        builds = self.builds()
        with self._opened(create=False) as opened:
            if opened is None or key is None:
                return removed
            rfd, real = opened
            for e in builds:
                if not e.verified:
                    continue
                if scene is not None and e.scene != scene and safe_name(scene) != e.directory.name[:-17]:
                    continue
                if older_than_days is not None and now - e.built < older_than_days * 86400.0:
                    continue
                if self._try_remove(rfd, real, e.directory.name, key):
                    removed.append(e)
            if scene is None and older_than_days is None:
                for name in os.listdir(rfd):
                    m = re.match(r"^\.(?:tmp|trash)-(.+-[0-9a-f]{16})-", name)
                    if m:
                        self._try_remove(rfd, real, m[1], key, leftover=name)
        return removed

    def _try_remove(self, rfd: int, real: Path, name: str, key: bytes, leftover: str | None = None) -> bool:
        """Remove the build ``name`` (or its ``leftover`` folder) if its build lock is free."""
        try:
            with locked_file(rfd, f".{name}.lock", self.root, blocking=False) as held:
                if not held:
                    return False  # a build of it is being made right now
                if leftover is not None:
                    return self._remove_leftover(rfd, leftover, key)
                trash = self._temp_dir(real, f".trash-{name}-", key)
                os.rename(name, f"{trash}/old", src_dir_fd=rfd, dst_dir_fd=rfd)
                shutil.rmtree(trash, dir_fd=rfd, ignore_errors=True)
                return True
        except (OSError, CompileError):
            return False
