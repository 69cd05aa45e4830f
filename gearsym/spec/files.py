"""Reading spec files safely: regular files only, a size limit checked before reading.

A model path comes from a scene file, which is untrusted: it may name a device
(``/dev/urandom`` grows memory without bound), a FIFO (``open`` blocks forever), a
folder or a huge file.  :func:`read_toml` opens the path without blocking, checks
with ``fstat`` on the open file (no race between the check and the read) that it is a
regular file of at most :data:`MAX_SPEC_BYTES`, and reads at most that many bytes.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from ..errors import SpecError

#: Largest model or scene file (bytes).
MAX_SPEC_BYTES = 1_000_000


def read_text(path: str | Path, kind: str) -> str:
    """The text of a spec file.

    Parameters
    ----------
    path
        The file.
    kind
        ``"model file"`` or ``"scene file"`` (for messages).

    Raises
    ------
    SpecError
        Naming the file: not found, not a regular file, too large, unreadable, not UTF-8.
    """
    where = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise SpecError(f"{kind} not found", file=where) from None
    except IsADirectoryError:
        raise SpecError(f"cannot read {kind}: it is a folder", file=where) from None
    except OSError as exc:
        raise SpecError(f"cannot read {kind}: {exc.strerror}", file=where) from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise SpecError(f"cannot read {kind}: it is a folder", file=where)
        if not stat.S_ISREG(st.st_mode):
            raise SpecError(f"cannot read {kind}: not a regular file (a device, FIFO or socket)", file=where)
        if st.st_size > MAX_SPEC_BYTES:
            raise SpecError(f"{kind} too large ({st.st_size} bytes, limit {MAX_SPEC_BYTES})", file=where)
        chunks = []
        size = 0
        while size <= MAX_SPEC_BYTES:
            chunk = os.read(fd, MAX_SPEC_BYTES + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > MAX_SPEC_BYTES:  # grew while being read
            raise SpecError(f"{kind} too large (more than {MAX_SPEC_BYTES} bytes)", file=where)
        data = b"".join(chunks)
    except OSError as exc:
        raise SpecError(f"cannot read {kind}: {exc.strerror}", file=where) from None
    finally:
        os.close(fd)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise SpecError("not a text (UTF-8) file", file=where) from None


def read_toml(path: str | Path, kind: str) -> dict[str, Any]:
    """The TOML document of a spec file (see :func:`read_text` for the checks).

    Raises
    ------
    SpecError
        Naming the file, for everything :func:`read_text` rejects and for TOML syntax
        errors (including nesting too deep for the TOML reader).
    """
    text = read_text(path, kind)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"TOML syntax error: {exc}", file=str(path)) from None
    except RecursionError:
        raise SpecError("TOML syntax error: arrays or tables nested too deeply", file=str(path)) from None
