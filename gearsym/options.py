"""Frozen options objects, and the keywords that may stand in for their fields.

An options class is a frozen dataclass: its fields are the settings of one call, their
defaults documented once, in its docstring.  A function that takes one (``options=``) also
takes its fields as keywords, so that callers written before the object existed keep
working; :func:`merge_options` is the one rule for both: the keywords override the object's
fields, and a keyword that is no field is a :class:`~gearsym.errors.ParameterError` naming it
with the closest field (never silently ignored).

Merging is on hot paths (one engine call per shooting residual): the field names of a class
are read once, and a call without keywords returns the object itself.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from .errors import ParameterError

__all__ = ["cached_options", "did_you_mean", "merge_options", "option_fields"]

T = TypeVar("T")

_FIELDS: dict[type, frozenset[str]] = {}
_CACHE: dict[tuple[Any, ...], Any] = {}
_CACHE_SIZE = 512


def did_you_mean(word: object, candidates: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the candidate closest to ``word`` (:mod:`difflib`), else ``""``.

    Parameters
    ----------
    word
        What was given.
    candidates
        What is known.

    Returns
    -------
    str
    """
    close = difflib.get_close_matches(str(word), sorted(set(candidates)), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def option_fields(cls: type) -> frozenset[str]:
    """The names of the fields of the options dataclass ``cls`` that its constructor takes (read
    once per class).

    Parameters
    ----------
    cls
        A dataclass.

    Returns
    -------
    frozenset of str
    """
    names = _FIELDS.get(cls)
    if names is None:
        names = _FIELDS[cls] = frozenset(f.name for f in dataclasses.fields(cls) if f.init)
    return names


def merge_options(cls: type[T], options: T | None, keywords: Mapping[str, Any], where: str) -> T:
    """``options`` (default: ``cls()``) with the fields named in ``keywords`` replaced.

    Parameters
    ----------
    cls
        The options class (a frozen dataclass).
    options
        An instance of ``cls``, or ``None``.
    keywords
        Field name -> value.
    where
        The function that took them, for messages (e.g. ``"System.simulate"``).

    Returns
    -------
    cls instance
        ``options`` itself when there are no keywords.

    Raises
    ------
    ParameterError
        A keyword that is no field of ``cls`` (named, with the closest field and the list), or
        ``options`` that is not a ``cls``.
    """
    if options is not None and not isinstance(options, cls):
        raise ParameterError(f"{where}: options must be a {cls.__name__}, got {type(options).__name__}")
    if not keywords:
        return options if options is not None else cls()
    names = option_fields(cls)
    if not names.issuperset(keywords):
        bad = next(k for k in keywords if k not in names)
        raise ParameterError(f"{where}() got an unknown keyword '{bad}'{did_you_mean(bad, names)} "
                             f"(the keywords of {cls.__name__}: {', '.join(sorted(names))})")
    if options is None:
        return cls(**keywords)
    return dataclasses.replace(options, **keywords)  # type: ignore[type-var]


def cached_options(cls: type[T], keywords: Mapping[str, Any], where: str) -> T:
    """``cls(**keywords)`` (checked as :func:`merge_options` checks them), cached by the class and
    the keywords' names and values: a call site that passes the same keywords at every call
    (one engine run per shooting residual) gets the same object back for a dictionary lookup,
    without making and checking it again.  Values that cannot be hashed skip the cache.

    Parameters
    ----------
    cls
        The options class (a frozen dataclass, so the shared object cannot change).
    keywords
        Field name -> value.
    where
        The function that took them, for messages.

    Returns
    -------
    cls instance

    Raises
    ------
    ParameterError
        As :func:`merge_options`; and whatever ``cls`` raises for bad values (never cached).
    """
    try:
        key = (cls, *keywords.items())
        out = _CACHE.get(key)
    except TypeError:  # an unhashable value
        return merge_options(cls, None, keywords, where)
    if out is None:
        out = merge_options(cls, None, keywords, where)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.clear()
        _CACHE[key] = out
    return out
