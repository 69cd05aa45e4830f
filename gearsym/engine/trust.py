"""Who made a build: the per-user signing key, folders only this user can change, and
files opened without following symbolic links.

A compiled model is native code: loading it runs it.  gearsym therefore loads only
builds that this user's gearsym made, and proves it with a secret key of the user:

* **The key**: 32 random bytes in ``<user cache>/.signing-key`` (:func:`user_cache_dir`:
  platformdirs' user cache, on Linux ``$XDG_CACHE_HOME/gearsym``, else
  ``~/.cache/gearsym``), created mode 0600 in one atomic ``link`` (no reader ever sees a partial key) and refused unless it is a regular
  file owned by the user that no other user can read or write (:func:`signing_key`).  It
  never lives in a build folder: a folder that came from elsewhere (a paper's supplement,
  a colleague's zip) cannot bring its own key.
* **Signatures**: HMAC-SHA256 with that key over a tag and length-prefixed parts
  (:func:`sign`, :func:`verify`); a model build signs its ``meta.json`` with the object's
  SHA-256, its build key and its sources' SHA-256 (:mod:`gearsym.codegen.cache`), the
  driver object its own bytes (:func:`gearsym.engine.build.driver_object`).  A copy of
  another user's build carries a signature made with another key and does not verify.
* **Folders**: a cache folder is used only if no other user can change it or the path
  to it (:func:`open_secure_directory`): the folder is owned by the user and not
  writable by other users; every folder above it is owned by root or the user and not
  writable by others unless it has the sticky bit (as ``/tmp``: others cannot rename
  or delete what is not theirs there); a symbolic link on the way is owned by root or
  the user.  Group write counts as write by others unless the group is the user's
  private group (same name as the user, no other members).
* **Files** in a verified folder are opened relative to its file descriptor with
  ``O_NOFOLLOW`` (a planted symbolic link is refused, never followed), ``O_NONBLOCK``
  (a planted FIFO cannot hang the open), checked to be regular files owned by the user,
  not writable by others, with one link, and read up to a size limit
  (:func:`read_file_at`).

* **Locks** (:func:`locked_file`): ``fcntl.flock`` on a lock file opened relative to
  the verified folder's descriptor with ``O_NOFOLLOW`` (a planted link is refused with
  a clear error, never followed), checked like any other file (regular, the user's,
  one link) and never truncated, removed by its holder on release (a waiter whose file
  was removed retries, comparing device and inode).  This is hand-written on purpose:
  ``filelock`` (its Unix lock opens with ``O_NOFOLLOW`` since 3.20.1 and, in current
  versions, unlinks on release as here) opens the lock by *path*, not relative to the checked folder's descriptor,
  opens with ``O_TRUNC`` and does not check the file's owner, type or link count (a
  hard link to another file of the user would be truncated), creates missing parent
  folders itself with the default mode (around :func:`open_secure_directory`'s
  checks), and reports a refused link as a bare ``OSError``.  Wrapping it to keep these
  guarantees would be longer than the 60 lines here.  POSIX only, as all of gearsym.

Between the check of a build and its ``dlopen`` (by path) only processes of this user
(or root) can change the folder or the file, and they can anyway run any code as the
user: loading the verified path is as safe as loading a private copy.  Measured on the
benchmark scene (a 137 kB object): the whole check 2 ms per lookup, ``dlopen`` of the
verified path 0.1-0.3 ms, a private copy re-hashed and loaded 9 ms (and a copy per
process and build); gearsym loads the verified path.
"""

from __future__ import annotations

import grp
import hmac
import os
import pwd
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import platformdirs

from gearsym.errors import CompileError

__all__ = [
    "KEY_FILE",
    "UntrustedCacheError",
    "locked_file",
    "open_secure_directory",
    "read_file_at",
    "sign",
    "signing_key",
    "user_cache_dir",
    "verify",
    "writable_by_others",
]

#: Name of the signing key in :func:`user_cache_dir`.
KEY_FILE = ".signing-key"
_KEY_BYTES = 32
_OPEN_READ = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC


class UntrustedCacheError(CompileError):
    """A cache folder, a file in it or the signing key is not safe to use (exit code 2:
    the message names the path and the reason; nothing was loaded or built)."""

    exit_code = 2


def user_cache_dir() -> Path:
    """The user's gearsym cache: ``platformdirs.user_cache_dir("gearsym")``.

    On Linux that is ``$XDG_CACHE_HOME/gearsym`` when ``XDG_CACHE_HOME`` holds an
    absolute path (a relative one is ignored, as the XDG specification says; platformdirs
    4.11.8 and later), else ``~/.cache/gearsym``.  Nothing is created here: the folder is
    made and checked by :func:`open_secure_directory`.

    Raises
    ------
    UntrustedCacheError
        If no absolute folder can be found (no absolute ``HOME`` and no absolute
        ``XDG_CACHE_HOME``): a relative folder would depend on the working directory.
    """
    try:
        path = Path(platformdirs.user_cache_dir("gearsym", appauthor=False, ensure_exists=False))
    except RuntimeError as exc:  # platformdirs: the home folder is unknown
        raise UntrustedCacheError(f"cannot find the user cache: {exc} (set GEARSYM_GENERATED to a folder "
                                  "only you can write)") from None
    if not path.is_absolute():  # never a folder relative to wherever gearsym runs
        raise UntrustedCacheError(f"the user cache {path} is not an absolute path (set XDG_CACHE_HOME or HOME to "
                                  "an absolute path, or GEARSYM_GENERATED to a folder only you can write)")
    return path



def _private_group(gid: int) -> bool:
    """Whether ``gid`` is the user's private group: named as the user, no other members."""
    try:
        user = pwd.getpwuid(os.geteuid()).pw_name
        g = grp.getgrgid(gid)
    except (KeyError, OSError):
        return False
    return g.gr_name == user and set(g.gr_mem) <= {user}


def writable_by_others(st: os.stat_result) -> bool:
    """Whether users other than the owner can write the file or folder of ``st``
    (world write, or group write by a group that is not the user's private group)."""
    if st.st_mode & stat.S_IWOTH:
        return True
    return bool(st.st_mode & stat.S_IWGRP) and not _private_group(st.st_gid)


def _mode(st: os.stat_result) -> str:
    return oct(stat.S_IMODE(st.st_mode))


def _check_ancestor(path: Path, st: os.stat_result, uid: int) -> str | None:
    """Why the folder ``path`` above a cache lets other users change what is below it, or None."""
    if st.st_uid not in (0, uid):
        return f"{path} is owned by uid {st.st_uid} (not by you or root)"
    if writable_by_others(st) and not st.st_mode & stat.S_ISVTX:
        return f"{path} is writable by other users (mode {_mode(st)}, no sticky bit)"
    return None


def _check_leaf(path: Path, st: os.stat_result, uid: int) -> str | None:
    """Why the cache folder ``path`` itself is unsafe, or None."""
    if not stat.S_ISDIR(st.st_mode):
        return f"{path} is not a folder"
    if st.st_uid != uid:
        return f"{path} is owned by uid {st.st_uid}, not by you (uid {uid})"
    if writable_by_others(st):
        return f"{path} is writable by other users (mode {_mode(st)})"
    return None


def _check_links(path: Path, uid: int) -> str | None:
    """Why a symbolic link on the way to ``path`` (absolute, unresolved) is unsafe, or None."""
    cur = Path(path.anchor)
    for part in path.parts[1:]:
        cur = cur / part
        try:
            st = os.lstat(cur)
        except OSError:
            return None  # does not exist (yet): nothing further to follow
        if stat.S_ISLNK(st.st_mode) and st.st_uid not in (0, uid):
            return f"{cur} is a symbolic link owned by uid {st.st_uid} (not by you or root)"
    return None


def _why_unsafe(path: Path, *, leaf: bool = True) -> str | None:
    """Why the existing folder ``path`` (absolute) is not safe as a cache (``leaf``), or
    as a folder to create a cache in (not ``leaf``: checked like the folders above), or None."""
    uid = os.geteuid()
    why = _check_links(path, uid)
    if why:
        return why
    real = Path(os.path.realpath(path))
    for anc in reversed(real.parents if leaf else (real, *real.parents)):
        why = _check_ancestor(anc, os.stat(anc), uid)
        if why:
            return why
    return _check_leaf(real, os.stat(real), uid) if leaf else None


def _create(path: Path, what: str) -> None:
    """Create ``path`` (mode 0700) after checking the nearest existing folder above it."""
    anc = path.parent
    while not os.path.lexists(anc):
        anc = anc.parent
    try:
        why = _why_unsafe(anc, leaf=False)
    except OSError as exc:
        raise UntrustedCacheError(f"cannot check the {what} {path}: {exc.strerror} ({exc.filename})") from None
    if why:
        raise UntrustedCacheError(f"refusing to create the {what} {path}: {why}")
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        raise CompileError(f"cannot create the {what} {path}: {exc.strerror}") from None


def open_secure_directory(path: str | os.PathLike[str], *, create: bool = False,
                          what: str = "build cache") -> tuple[int, Path]:
    """Open a folder that no other user can change (see the module docstring).

    Parameters
    ----------
    path
        The folder.
    create
        Create it (mode 0700; the folders above it checked first) if it does not exist.
    what
        What the folder is, for messages ("build cache", "driver cache", ...).

    Returns
    -------
    fd, real
        A file descriptor of the folder (``O_DIRECTORY``; close it) and its real path.

    Raises
    ------
    FileNotFoundError
        If it does not exist and ``create`` is False.
    UntrustedCacheError
        If it, a folder above it or a link on the way lets another user change it
        (the message names the path and the reason).
    CompileError
        If it cannot be created.
    """
    p = Path(os.path.abspath(path))
    if create and not os.path.isdir(p):
        _create(p, what)
    try:
        why = _why_unsafe(p)
        real = Path(os.path.realpath(p))
        fd = os.open(real, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise UntrustedCacheError(f"cannot use the {what} {p}: {exc.strerror} ({exc.filename})") from None
    st = os.fstat(fd)
    why = why or _check_leaf(real, st, os.geteuid())  # the folder opened is the one checked
    if why:
        os.close(fd)
        raise UntrustedCacheError(f"refusing the {what} {p}: {why}; other users could plant code there "
                                  "(choose a folder only you can write: GEARSYM_GENERATED, XDG_CACHE_HOME)")
    return fd, real


def _file_ok(st: os.stat_result, *, links: bool = True) -> bool:
    """A regular file of this user that no other user can write (and, with ``links``, one link)."""
    return (stat.S_ISREG(st.st_mode) and st.st_uid == os.geteuid() and not writable_by_others(st)
            and (not links or st.st_nlink == 1))


def read_file_at(dir_fd: int, name: str, limit: int) -> bytes | None:
    """The bytes of ``name`` in the folder ``dir_fd``, or None if it is not a trustworthy file.

    Opened with ``O_NOFOLLOW | O_NONBLOCK``; None if it is missing, a symbolic link, not a
    regular file (a FIFO, a device), not owned by the user, writable by other users,
    has more than one link (a hard link from elsewhere), or is larger than ``limit``
    bytes (never read then).
    """
    try:
        fd = os.open(name, _OPEN_READ, dir_fd=dir_fd)
    except OSError:
        return None
    try:
        st = os.fstat(fd)
        if not _file_ok(st) or st.st_size > limit:
            return None
        chunks, left = [], st.st_size + 1  # one byte more: a file that grew is refused
        while left > 0:
            b = os.read(fd, min(left, 1 << 20))
            if not b:
                break
            chunks.append(b)
            left -= len(b)
        data = b"".join(chunks)
        return data if len(data) == st.st_size else None
    except OSError:
        return None
    finally:
        os.close(fd)


def _read_key(dir_fd: int, where: Path) -> bytes | None:
    path = where / KEY_FILE
    try:
        fd = os.open(KEY_FILE, _OPEN_READ, dir_fd=dir_fd)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise UntrustedCacheError(f"cannot use the signing key {path}: {exc.strerror} (a symbolic link "
                                  "is never followed); remove it and gearsym makes a new one") from None
    try:
        st = os.fstat(fd)
        why = None
        if not stat.S_ISREG(st.st_mode):
            why = "it is not a regular file"
        elif st.st_uid != os.geteuid():
            why = f"it is owned by uid {st.st_uid}, not by you (uid {os.geteuid()})"
        elif st.st_mode & 0o077:
            why = f"other users can read or write it (mode {_mode(st)}): builds signed with it can be forged"
        elif st.st_size != _KEY_BYTES:
            why = f"it has {st.st_size} bytes, not {_KEY_BYTES}"
        if why:
            raise UntrustedCacheError(f"refusing the signing key {path}: {why}; remove it and gearsym "
                                      "makes a new one (builds signed with the old key are rebuilt)")
        key = os.read(fd, _KEY_BYTES + 1)
    finally:
        os.close(fd)
    if len(key) != _KEY_BYTES:
        raise UntrustedCacheError(f"refusing the signing key {path}: it changed while being read")
    return key


def _make_key(dir_fd: int, where: Path) -> None:
    """Create the key file atomically: a private temporary file, linked to the key's name
    (``link`` fails if another process made the key first: then that key is used)."""
    tmp = f"{KEY_FILE}.{secrets.token_hex(8)}.tmp"
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600,
                     dir_fd=dir_fd)
        try:
            os.fchmod(fd, 0o600)
            os.write(fd, secrets.token_bytes(_KEY_BYTES))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(tmp, KEY_FILE, src_dir_fd=dir_fd, dst_dir_fd=dir_fd, follow_symlinks=False)
        except FileExistsError:
            pass
    except OSError as exc:
        raise CompileError(f"cannot create the signing key {where / KEY_FILE}: {exc.strerror}") from None
    finally:
        try:
            os.unlink(tmp, dir_fd=dir_fd)
        except OSError:
            pass


def signing_key(create: bool = True) -> bytes | None:
    """This user's secret key for signing builds (made on first use).

    Parameters
    ----------
    create
        Make the key (and the user cache) if there is none; otherwise return None then.

    Returns
    -------
    bytes or None
        32 bytes.

    Raises
    ------
    UntrustedCacheError
        If the user cache or the key file is not safe (owned by another user, readable
        by others, a symbolic link, ...): the message names it and the reason.
    """
    where = user_cache_dir()
    try:
        dir_fd, real = open_secure_directory(where, create=create, what="user cache (signing key)")
    except FileNotFoundError:
        return None
    try:
        key = _read_key(dir_fd, where)
        if key is None and create:
            _make_key(dir_fd, where)
            key = _read_key(dir_fd, where)
        return key
    finally:
        os.close(dir_fd)


def _message(tag: str, parts: tuple[bytes | str, ...]) -> bytes:
    out = [tag.encode()]
    for p in parts:
        b = p.encode() if isinstance(p, str) else bytes(p)
        out.append(len(b).to_bytes(8, "big") + b)
    return b"\0".join(out)


def sign(key: bytes, tag: str, *parts: bytes | str) -> str:
    """HMAC-SHA256 (hex) of ``tag`` and the length-prefixed ``parts`` under ``key``."""
    return hmac.new(key, _message(tag, parts), "sha256").hexdigest()


def verify(key: bytes | None, signature: object, tag: str, *parts: bytes | str) -> bool:
    """Whether ``signature`` is :func:`sign` of the same tag and parts (constant time)."""
    if key is None or not isinstance(signature, str):
        return False
    return hmac.compare_digest(sign(key, tag, *parts), signature)


def _acquire(dir_fd: int, name: str, where: Path, blocking: bool) -> int | None:
    """The descriptor of the locked file ``name`` (see :func:`locked_file`), None if busy."""
    import errno
    import fcntl

    while True:
        try:
            fd = os.open(name, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o600,
                         dir_fd=dir_fd)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise UntrustedCacheError(f"refusing the lock file {where / name}: it is a symbolic link "
                                          "(gearsym never makes one; remove it)") from None
            raise CompileError(f"cannot create the lock file {where / name}: {exc.strerror}") from None
        try:
            st = os.fstat(fd)
            if not _file_ok(st):
                raise UntrustedCacheError(f"refusing the lock file {where / name}: it is not a regular file of "
                                          "yours with one link that only you can write (remove it)")
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
            except BlockingIOError:
                os.close(fd)
                return None
            try:
                cur = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
                same = (cur.st_dev, cur.st_ino) == (st.st_dev, st.st_ino)
            except FileNotFoundError:
                same = False
        except BaseException:
            os.close(fd)
            raise
        if same:
            return fd
        os.close(fd)  # the file was removed by its previous holder: lock the new one


@contextmanager
def locked_file(dir_fd: int, name: str, where: Path, *, blocking: bool = True) -> Iterator[bool]:
    """Hold the ``flock`` of the lock file ``name`` in the folder ``dir_fd``.

    The file is created mode 0600 with ``O_NOFOLLOW`` (a planted symbolic link is refused,
    never followed: nothing is created or truncated through it) and removed on release;
    a waiter whose file was removed meanwhile (the name no longer names its file)
    retries.  Yields True when held; with ``blocking=False``, False at once if another
    process holds it.

    Raises
    ------
    UntrustedCacheError
        If the lock file is a symbolic link or not a regular file of the user.
    CompileError
        If it cannot be created.
    """
    fd = _acquire(dir_fd, name, where, blocking)
    if fd is None:
        yield False
        return
    try:
        yield True
    finally:
        try:
            os.unlink(name, dir_fd=dir_fd)
        except OSError:
            pass
        finally:
            os.close(fd)
