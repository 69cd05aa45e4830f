"""Output files: atomic writes and the one JSON encoder of every command.

Every file gearsym writes (``trajectory.npz``, ``outputs.npz``, the PNG figures,
``orbit.json``, ``branch.json``, ``map.nc``, the benchmark JSON) goes through
:func:`atomic_path`: the content is written to a temporary name in the target's
folder and renamed onto the target only when it is complete (``os.replace`` is
atomic within a file system).  A Ctrl-C, a full disk or any error while writing
leaves the previous file (or none) and no partial file behind.  The new file gets
the permissions a plain ``open(target, "w")`` would give a new file (``0o666`` less the
umask, ``0o644`` with the usual umask ``022``; ``0o777`` less the umask for executables),
not the ``0o600`` of a private temporary file: collaborators reading a shared folder see
what the umask lets them see.  :func:`write_files` writes several files the same way and
renames them only when all are complete.

:func:`to_json` is the JSON encoder of every ``--json`` output and JSON file:
numpy arrays and scalars become lists and numbers, complex numbers ``[re, im]``,
and non-finite floats (NaN, +-Infinity, which are not JSON) become ``null``.
"""

from __future__ import annotations

import errno
import json
import math
import os
import secrets
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["atomic_path", "check_out_dir", "jsonable", "save_figure", "save_npz", "to_json", "write_files",
           "write_json", "write_text"]


def check_out_dir(path: str | Path, flag: str = "--out") -> Path:
    """Check, without creating anything that stays, that ``path`` can become an output folder.

    It is an existing writable folder, or does not exist yet and its nearest existing
    ancestor is a writable folder.  Commands call this before their work, so that a bad
    ``--out`` is bad input (exit 2), not a failure after minutes of computing.

    Raises
    ------
    ParameterError
        ``path`` is an existing file (or other non-folder), or the place is not writable.
    """
    from .errors import ParameterError

    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ParameterError(f"{flag}: '{p}' exists and is not a folder")
    anc = p
    while not anc.exists():
        if anc.parent == anc:
            break
        anc = anc.parent
    if not anc.is_dir() or not os.access(anc, os.W_OK | os.X_OK) or not _can_write_in(anc):
        raise ParameterError(f"{flag}: cannot create '{p}' ('{anc}' is not a writable folder)")
    return p


def _can_write_in(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (a probe, removed at once: ``os.access``
    says yes to root on read-only file systems and pseudo file systems)."""
    try:
        fd, name = tempfile.mkstemp(prefix=".gearsym-probe-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(name)
    return True


def _new_temp(target: Path, executable: bool) -> tuple[Path, int]:
    """Create a new, empty, hidden file beside ``target``; return it and the mode it must end with.

    The file is created with ``O_CREAT | O_EXCL`` and mode ``0o666`` (``0o777`` for an
    executable), so the kernel applies the umask (and a default ACL) exactly as for any new
    file; that mode is read back and restored after the content is written, since some
    writers (netCDF libraries) delete and recreate the file.  ``O_NOFOLLOW``: a planted
    symlink of the same (random) name is never followed.
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0)
    for _ in range(100):
        tmp = target.parent / f".{target.name}.{secrets.token_hex(6)}.tmp{target.suffix}"
        try:
            fd = os.open(tmp, flags, 0o777 if executable else 0o666)
        except FileExistsError:
            continue
        try:
            mode = stat.S_IMODE(os.fstat(fd).st_mode)
        finally:
            os.close(fd)
        return tmp, mode
    raise FileExistsError(errno.EEXIST, f"no free temporary name beside '{target}'")


def _finish(tmp: Path, mode: int) -> None:
    """Give the written temporary file its final mode (see :func:`_new_temp`)."""
    if stat.S_IMODE(os.stat(tmp).st_mode) != mode:
        os.chmod(tmp, mode)


@contextmanager
def atomic_path(target: str | Path, *, executable: bool = False) -> Iterator[Path]:
    """A temporary path next to ``target`` that becomes ``target`` when the block succeeds.

    The temporary file has the target's suffix (writers such as matplotlib and
    numpy choose the format from it) and a hidden, unique name in the same
    folder.  On success it is renamed onto ``target`` (atomically), with the
    permissions of a new file (``0o666`` less the umask; see the module docstring);
    on any exception, ``KeyboardInterrupt`` included, it is removed and the exception
    propagates, so ``target`` is either the old file (or absent) or the new,
    complete one.

    Parameters
    ----------
    target
        The file to write.
    executable
        Give the file the execute permissions the umask allows (``0o777`` less the umask).

    Yields
    ------
    Path
        Where to write the content.
    """
    target = Path(target)
    tmp, mode = _new_temp(target, executable)
    try:
        yield tmp
        _finish(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_files(folder: str | Path, files: Mapping[str, str | bytes], executable: Iterable[str] = ()) -> list[Path]:
    """Write several files into ``folder``, each renamed onto its name only when all are written.

    Every file is first written completely to a temporary file beside its target; if any
    write fails (a full disk, an interrupt) every temporary file is removed and no target is
    touched.  Only then are the temporary files renamed onto their targets (renames need no
    space).

    Parameters
    ----------
    folder
        An existing folder.
    files
        File name -> text (UTF-8) or bytes.  A name is a plain file name or a relative
        path of plain names (``"lib/libfoo.so"``): its folders are created (and removed
        again on failure if they were created here and are still empty).
    executable
        Names of the files to make executable (as far as the umask allows).

    Returns
    -------
    list of Path
        The written files, in the order of ``files``.
    """
    folder = Path(folder)
    execs = set(executable)
    done: list[tuple[Path, Path]] = []
    made: list[Path] = []
    try:
        for name, content in files.items():
            target = folder / name
            parts = Path(name).parts
            if not parts or Path(name).is_absolute() or any(p in ("", ".", "..") for p in parts) \
                    or target.name != parts[-1]:
                raise ValueError(f"'{name}' is not a plain file name or relative path")
            for sub in [folder.joinpath(*parts[:k]) for k in range(1, len(parts))]:
                if not sub.exists():
                    sub.mkdir()
                    made.append(sub)
            tmp, mode = _new_temp(target, name in execs)
            done.append((tmp, target))
            data = content.encode("utf-8") if isinstance(content, str) else bytes(content)
            with open(tmp, "wb") as fh:
                fh.write(data)
            _finish(tmp, mode)
        for tmp, target in done:
            os.replace(tmp, target)
    except BaseException:
        for tmp, _ in done:
            tmp.unlink(missing_ok=True)
        for sub in reversed(made):
            try:
                sub.rmdir()
            except OSError:
                pass
        raise
    return [t for _, t in done]


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy types, complex numbers and paths converted and non-finite floats as ``None``."""
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (complex, np.complexfloating)):
        return [jsonable(obj.real), jsonable(obj.imag)]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def to_json(obj: Any, indent: int | None = 1) -> str:
    """Strict JSON text of ``obj`` (see :func:`jsonable`): never ``NaN`` or ``Infinity``."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False)


def write_text(target: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    target = Path(target)
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return target


def write_json(target: str | Path, obj: Any) -> Path:
    """Write :func:`to_json` of ``obj`` to ``target`` atomically."""
    return write_text(target, to_json(obj) + "\n")


def save_npz(target: str | Path, **arrays: Any) -> Path:
    """``numpy.savez_compressed`` to ``target`` (a ``.npz`` name) atomically."""
    target = Path(target)
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:  # a file object: no ".npz" appended
        np.savez_compressed(fh, **arrays)
    return target


def save_figure(fig: Any, target: str | Path, **kwargs: Any) -> Path:
    """``fig.savefig(target, **kwargs)`` atomically (format from the target's suffix)."""
    target = Path(target)
    kwargs.setdefault("format", target.suffix.lstrip(".") or "png")
    with atomic_path(target) as tmp, open(tmp, "wb") as fh:
        fig.savefig(fh, **kwargs)
    return target
