"""The one progress bar of every long computation: ``tqdm.auto`` in terminals and notebooks.

Continuation, the Lyapunov exponents, maps and sweeps draw their progress through
:func:`progress_bar`; each takes ``progress=`` (``True`` / ``False`` / ``None``) and the CLI
``--no-progress``.  ``None`` (the default) means *where someone watches* (:func:`wanted`):

* stderr is a terminal (the CLI, a script run by hand), or
* the code runs in a Jupyter kernel (``tqdm.auto`` then draws a widget; without
  ``ipywidgets`` a text bar on stderr);

and never in a worker process of a pool (a map's points, a Dask worker): the parent draws
the bar of the whole job there.  Without tqdm (an optional dependency, ``gearsym[all]``)
there is no bar and nothing fails.

>>> bar = progress_bar(False, total=10, desc="points")
>>> bar(3); bar.close()        # a silent stand-in: the same calls, no output
"""

from __future__ import annotations

import multiprocessing
import sys
import warnings
from typing import Any

__all__ = ["Bar", "in_notebook", "progress_bar", "wanted"]


def in_notebook() -> bool:
    """Whether this code runs in a Jupyter kernel (notebook, JupyterLab, VS Code).

    Returns
    -------
    bool
        ``False`` in a terminal IPython, a script or a test run.
    """
    if "ipykernel" not in sys.modules:
        return False
    ipython = sys.modules.get("IPython")
    shell = getattr(ipython, "get_ipython", lambda: None)() if ipython is not None else None
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def wanted(enabled: bool | None) -> bool:
    """Whether to draw a bar: ``enabled`` when given, else where someone watches (module notes).

    Parameters
    ----------
    enabled
        ``True`` / ``False``: as given; ``None``: stderr is a terminal or the code runs in a
        Jupyter kernel, and this is not a worker process.

    Returns
    -------
    bool
    """
    if enabled is not None:
        return bool(enabled)
    if multiprocessing.parent_process() is not None:
        return False
    return bool(getattr(sys.stderr, "isatty", lambda: False)()) or in_notebook()


def _tqdm_class() -> Any:
    """``tqdm.auto.tqdm`` (a widget in a notebook with ipywidgets, else the text bar), or None."""
    try:
        with warnings.catch_warnings():  # "IProgress not found": the text bar is the fallback
            warnings.simplefilter("ignore")
            from tqdm.auto import tqdm
    except ImportError:  # tqdm is optional (gearsym[all])
        return None
    return tqdm


class Bar:
    """A progress bar over ``total`` units, or a silent stand-in (not wanted, or no tqdm).

    Parameters
    ----------
    enabled
        ``True``: a bar; ``False``: none; ``None``: :func:`wanted` decides.
    total
        Units of work (points, blocks, ...; ``1000`` for a fraction in thousandths).
    desc
        The bar's label.
    unit
        The name of a unit.
    **options
        Further :class:`tqdm.tqdm` settings (``bar_format``, ...).

    Attributes
    ----------
    bar : tqdm.tqdm or None
        The bar itself (``None``: silent).
    """

    def __init__(self, enabled: bool | None, total: int, desc: str, unit: str = "it", **options: Any) -> None:
        self.bar: Any = None
        if not wanted(enabled) or total <= 0:
            return
        tqdm = _tqdm_class()
        if tqdm is None:
            return
        self.bar = tqdm(total=int(total), desc=desc, file=sys.stderr, leave=False, unit=unit, dynamic_ncols=True,
                        **options)

    def __call__(self, n: int = 1) -> None:
        """``n`` more units done."""
        if self.bar is not None and n:
            self.bar.update(int(n))

    update = __call__

    def set_total(self, total: int) -> None:
        """Change the number of units (a further phase)."""
        if self.bar is not None:
            self.bar.total = int(total)
            self.bar.refresh()

    def describe(self, text: str) -> None:
        """Change the label (a new phase)."""
        if self.bar is not None:
            self.bar.set_description_str(text, refresh=False)

    def postfix(self, text: str) -> None:
        """Show ``text`` after the bar (the current value, counts)."""
        if self.bar is not None:
            self.bar.set_postfix_str(text, refresh=False)

    def close(self) -> None:
        """Remove the bar."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_bar(enabled: bool | None, total: int, desc: str, unit: str = "it", **options: Any) -> Bar:
    """A :class:`Bar`: ``tqdm.auto`` where wanted (:func:`wanted`), else a silent stand-in.

    Parameters
    ----------
    enabled, total, desc, unit, **options
        See :class:`Bar`.

    Returns
    -------
    Bar
        Call it with the units done (``bar(n)``), :meth:`Bar.close` it at the end (or use it
        as a context manager).
    """
    return Bar(enabled, total, desc, unit, **options)
