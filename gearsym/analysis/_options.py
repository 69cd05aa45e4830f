"""The options objects of the analyses: frozen dataclasses, resolved once.

Every analysis takes its options object (``options=``, a frozen dataclass whose docstring
documents each setting and its default, once) and, for compatibility, the same settings as
keywords; :func:`resolve_options` merges the two and names a keyword that is no setting
(with the closest one).  :func:`check_tolerances` is the one check of a tolerance.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any, TypeVar

from ..errors import ParameterError
from ..spec.fields import did_you_mean

__all__ = ["check_tolerances", "resolve_options"]

T = TypeVar("T")


def resolve_options(options: T | None, cls: type[T], keywords: Mapping[str, Any], caller: str) -> T:
    """The options in effect for one call: ``options`` (default ``cls()``) with the keywords the
    caller gave replacing its fields.

    The keywords are the settings passed one by one (``shoot(system, rtol=1e-9)``, kept for
    compatibility); each must be a field of ``cls``.  A keyword given always wins over the
    options object (``shoot(system, options=o, rtol=1e-9)`` runs at ``rtol=1e-9``).  Each
    options class checks its values when it is made (bounded work, :mod:`gearsym.budget`), so
    the merged options are checked too.

    Parameters
    ----------
    options
        An options object of class ``cls``, or ``None``.
    cls
        The options class (a frozen dataclass).
    keywords
        The settings given as keywords.
    caller
        The function's name, for the error messages.

    Returns
    -------
    object
        An instance of ``cls``.

    Raises
    ------
    ParameterError
        ``options`` of another class, or a keyword that is not a field of ``cls`` (naming it
        and the closest field).
    """
    if options is not None and not isinstance(options, cls):
        raise ParameterError(f"options must be a {cls.__name__}, got {type(options).__name__}")
    default, names = _defaults(cls)
    for k in keywords:
        if k not in names:
            raise ParameterError(f"{caller}() got an unknown option '{k}'{did_you_mean(k, names)} (the settings "
                                 f"of {cls.__name__}: {', '.join(f.name for f in fields(cls))})")
    if not keywords:
        return options if options is not None else default
    if options is not None:
        return replace(options, **keywords)
    try:  # the same keywords give the same (frozen) options: kept for reuse (a map solves many orbits)
        key = (cls, *((k, type(v), v) for k, v in keywords.items()))
        hit = _RESOLVED.get(key)
    except TypeError:  # an unhashable value (an array, a list of harmonics)
        key = hit = None
    if hit is not None:
        return hit
    out = replace(default, **keywords)
    if key is not None:
        if len(_RESOLVED) >= 256:
            _RESOLVED.clear()
        _RESOLVED[key] = out
    return out


_RESOLVED: dict[tuple, Any] = {}


@functools.cache
def _defaults(cls: type[T]) -> tuple[T, frozenset[str]]:
    """The default instance of an options class (frozen: one can be shared) and its field names."""
    return cls(), frozenset(f.name for f in fields(cls))


def check_tolerances(**tols: float) -> None:
    """Each tolerance positive, finite and below 1 (``rtol`` at least 1e-15).

    Parameters
    ----------
    **tols
        The tolerances, by the keyword the caller gave them as (named in the error).

    Raises
    ------
    ParameterError
        A tolerance that is not a number in (0, 1), or ``rtol`` below 1e-15.
    """
    for name, v in tols.items():
        try:
            ok = math.isfinite(float(v)) and 0 < float(v) < 1
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ParameterError(f"{name} must be positive, finite and below 1, got {name}={v}")
    if "rtol" in tols and float(tols["rtol"]) < 1e-15:
        raise ParameterError(f"rtol={tols['rtol']:g} is below what double precision can deliver (1e-15)")

