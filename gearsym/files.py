"""Output files: atomic writes and the one JSON encoder of every command.

Every file gearsym writes (``trajectory.npz``, ``outputs.npz``, the PNG figures,
``orbit.json``, ``branch.json``, ``map.nc``, the benchmark JSON) goes through
:func:`atomic_path`: the content is written to a temporary name in the target's
folder and renamed onto the target only when it is complete (``os.replace`` is
atomic within a file system).  A Ctrl-C, a full disk or any error while writing
leaves the previous file (or none) and no partial file behind.

:func:`to_json` is the JSON encoder of every ``--json`` output and JSON file:
numpy arrays and scalars become lists and numbers, complex numbers ``[re, im]``,
and non-finite floats (NaN, +-Infinity, which are not JSON) become ``null``.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["atomic_path", "check_out_dir", "jsonable", "save_figure", "save_npz", "to_json", "write_json",
           "write_text"]


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


@contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """A temporary path next to ``target`` that becomes ``target`` when the block succeeds.

    The temporary file has the target's suffix (writers such as matplotlib and
    numpy choose the format from it) and a hidden, unique name in the same
    folder.  On success it is renamed onto ``target`` (atomically); on any
    exception, ``KeyboardInterrupt`` included, it is removed and the exception
    propagates, so ``target`` is either the old file (or absent) or the new,
    complete one.

    Parameters
    ----------
    target
        The file to write.

    Yields
    ------
    Path
        Where to write the content.
    """
    target = Path(target)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}",
                                    dir=target.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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
