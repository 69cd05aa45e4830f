"""Optional dependencies: which commands need which extra, and a clear message when one is missing.

The core install (casadi, scikit-sundae, numpy, sympy, scipy) derives, compiles,
simulates, finds orbits and continues them.  The extras add:

============  =====================================  ==========================================
extra         packages                               needed by
============  =====================================  ==========================================
``plots``     matplotlib                             figures: ``--out`` of ``simulate``, ``orbit``,
                                                     ``continue``, ``bench``
``maps``      xarray, dask, distributed, matplotlib  ``gearsym map``, ``gearsym sweep``,
                                                     ``runup --out`` (netCDF + figures)
``all``       both, and tqdm                         tqdm draws the progress bars (continuation,
                                                     maps, sweeps, Lyapunov exponents)
``notebook``  ``all``, ipykernel, ipywidgets         Jupyter: the widget progress bars
============  =====================================  ==========================================

``to_xarray()`` / ``to_dataframe()`` of the results need xarray and pandas (``maps``).

A command that needs a missing extra stops before any work with
:class:`MissingExtraError` (exit 2): ``gearsym map needs the optional dependencies of
gearsym[maps] (missing: xarray); install them with: pip install 'gearsym[maps]'``.
"""

from __future__ import annotations

import argparse
import importlib.util

from .errors import GearsymError

__all__ = ["EXTRAS", "MissingExtraError", "missing", "require", "require_for_command"]

#: extra -> the modules it provides (import names)
EXTRAS: dict[str, tuple[str, ...]] = {
    "plots": ("matplotlib",),
    "maps": ("xarray", "dask", "distributed", "matplotlib"),
}


class MissingExtraError(GearsymError):
    """An optional dependency is not installed; the message names the extra to install."""

    exit_code = 2


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a parent package missing, or a module without a spec
        return False


def missing(extra: str) -> list[str]:
    """The modules of an extra that are not installed.

    Parameters
    ----------
    extra
        A key of :data:`EXTRAS`.

    Returns
    -------
    list of str
        Import names of the missing modules (empty when the extra is complete).
    """
    return [m for m in EXTRAS[extra] if not _installed(m)]


def require(extra: str, what: str) -> None:
    """Raise :class:`MissingExtraError` unless every module of ``extra`` is installed.

    Parameters
    ----------
    extra
        A key of :data:`EXTRAS`.
    what
        What needs it, for the message (``"gearsym map"``).

    Raises
    ------
    MissingExtraError
        Naming the extra, the missing modules and the ``pip install`` command.
    """
    gone = missing(extra)
    if gone:
        raise MissingExtraError(f"{what} needs the optional dependencies of gearsym[{extra}] (missing: "
                                f"{', '.join(gone)}); install them with: pip install 'gearsym[{extra}]'")


def require_for_command(args: argparse.Namespace) -> None:
    """Check the extras a parsed ``gearsym`` command line needs, before any work.

    Parameters
    ----------
    args
        The parsed command line (``args.command`` and its options).

    Raises
    ------
    MissingExtraError
        The command needs an extra that is not installed.
    """
    command = getattr(args, "command", None)
    if command in ("map", "sweep"):
        require("maps", f"gearsym {command}")
    elif command == "continue" and getattr(args, "map", None):
        require("maps", "gearsym continue --map")
    elif command in ("simulate", "orbit", "continue", "bench") and getattr(args, "out", None):
        require("plots", f"gearsym {command} --out (figures)")
    elif command == "runup" and getattr(args, "out", None):
        require("maps", "gearsym runup --out (netCDF and figures)")
