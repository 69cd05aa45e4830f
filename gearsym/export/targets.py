"""Checks of export targets (folders and files), done before any work."""

from __future__ import annotations

import os
from pathlib import Path

from .model_info import ExportError

__all__ = ["check_target_dir", "check_target_file"]


def _writable_ancestor(p: Path, what: str) -> None:
    anc = p
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise ExportError(f"{what}: cannot create '{p}' ('{anc}' is not a folder)")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise ExportError(f"{what}: cannot create '{p}' ('{anc}' is not writable)")


def check_target_dir(path: str | Path, force: bool = False, what: str = "--c") -> Path:
    """Check that ``path`` can receive an exported project.

    An existing non-empty folder is refused unless ``force`` (then the exported files
    overwrite their namesakes; other files are left alone).

    Raises
    ------
    ExportError
        The path is a file, a non-empty folder without ``force``, or cannot be created.
    """
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise ExportError(f"{what}: '{p}' exists and is not a folder")
        if any(p.iterdir()) and not force:
            raise ExportError(f"{what}: the folder '{p}' exists and is not empty (use --force to write into it)")
        if not os.access(p, os.W_OK | os.X_OK):
            raise ExportError(f"{what}: the folder '{p}' is not writable")
        return p
    _writable_ancestor(p, what)
    return p


def check_target_file(path: str | Path, suffix: str, force: bool = False, what: str = "--fmu") -> Path:
    """Check that the file ``path`` (with ``suffix``) can be written.

    Raises
    ------
    ExportError
        Wrong suffix, an existing file without ``force``, a folder, or not writable.
    """
    p = Path(path)
    if p.suffix.lower() != suffix:
        raise ExportError(f"{what}: '{p}' must end with {suffix}")
    if p.exists():
        if p.is_dir():
            raise ExportError(f"{what}: '{p}' is a folder")
        if not force:
            raise ExportError(f"{what}: '{p}' exists (use --force to overwrite it)")
        if not os.access(p, os.W_OK):
            raise ExportError(f"{what}: '{p}' is not writable")
    _writable_ancestor(p.parent if str(p.parent) else Path("."), what)
    return p
