"""The options objects of the analyses: frozen dataclasses, resolved once.

Every analysis takes its options object (``options=``, a frozen dataclass whose docstring
documents each setting and its default) and, for compatibility, the same settings as
keywords; :func:`resolve_options` merges the two.
"""

from __future__ import annotations

import functools
import math
from dataclasses import fields, replace
from typing import Any, TypeVar

import numpy as np

from ..errors import ParameterError

__all__ = ["check_tolerances", "resolve_options"]

T = TypeVar("T")


def _same(a: Any, b: Any) -> bool:
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return False
    try:
        return bool(a == b) and type(a) is type(b)
    except (TypeError, ValueError):
        return False


def resolve_options(options: T | None, cls: type[T], **keywords: Any) -> T:
    """The options in effect: ``options`` (default ``cls()``) with every keyword that is not
    at its default overriding it.

    Parameters
    ----------
    options
        An options object, or ``None``.
    cls
        Its class.
    **keywords
        The keyword arguments of the call (one per field).

    Returns
    -------
    ShootingOptions or ContinuationOptions
    """
    if options is not None and not isinstance(options, cls):
        raise ParameterError(f"options must be a {cls.__name__}, got {type(options).__name__}")
    if options is None:  # the same keywords give the same (frozen) options: kept for reuse
        try:
            key = (cls, *((k, type(v), v) for k, v in keywords.items()))
            hit = _RESOLVED.get(key)
        except TypeError:  # an unhashable value (an array)
            key = hit = None
        if hit is not None:
            return hit
        out = _resolve(None, cls, keywords)
        if key is not None:
            if len(_RESOLVED) >= 256:
                _RESOLVED.clear()
            _RESOLVED[key] = out
        return out
    return _resolve(options, cls, keywords)


_RESOLVED: dict[tuple, Any] = {}


def _resolve(options: T | None, cls: type[T], keywords: dict[str, Any]) -> T:
    default, names = _defaults(cls)
    base = options if options is not None else default
    changes = {k: v for k, v in keywords.items() if k in names and not _same(v, getattr(default, k))}
    return replace(base, **changes) if changes else base


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

