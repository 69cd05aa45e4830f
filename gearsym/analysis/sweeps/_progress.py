"""The progress bar of maps and sweeps: ``tqdm.auto`` on stderr, only where it is installed and wanted."""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["Bar", "progress_bar"]


class Bar:
    """A progress bar over ``total`` units, or a silent stand-in (no tqdm, or not wanted).

    Parameters
    ----------
    enabled
        ``True``: a bar; ``False``: none; ``None``: a bar when stderr is a terminal.
    total
        Units of work (map points, sweep values).
    desc
        The bar's label.
    unit
        The name of a unit.
    """

    def __init__(self, enabled: bool | None, total: int, desc: str, unit: str = "pt") -> None:
        self.bar: Any = None
        if enabled is None:
            enabled = bool(getattr(sys.stderr, "isatty", lambda: False)())
        if not enabled or total <= 0:
            return
        try:
            from tqdm.auto import tqdm
        except ImportError:  # pragma: no cover - tqdm is optional
            return
        self.bar = tqdm(total=int(total), desc=desc, file=sys.stderr, leave=False, unit=unit, dynamic_ncols=True)

    def __call__(self, n: int) -> None:
        """``n`` more units done."""
        if self.bar is not None:
            self.bar.update(int(n))

    def set_total(self, total: int) -> None:
        """Change the number of units (a further phase)."""
        if self.bar is not None:
            self.bar.total = int(total)
            self.bar.refresh()

    def describe(self, text: str) -> None:
        """Change the label (a new phase)."""
        if self.bar is not None:
            self.bar.set_description_str(text, refresh=False)

    def close(self) -> None:
        """Remove the bar."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def progress_bar(enabled: bool | None, total: int, desc: str, unit: str = "pt") -> Bar:
    """A :class:`Bar` (silent when disabled, when tqdm is missing, or for ``enabled=None`` when stderr
    is not a terminal).

    Parameters
    ----------
    enabled, total, desc, unit
        See :class:`Bar`.

    Returns
    -------
    Bar
    """
    return Bar(enabled, total, desc, unit)
