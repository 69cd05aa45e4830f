"""The one identifier rule for every user-written name.

Every name a spec file declares reaches a symbol table (sympy symbols, the state and
parameter lists), the generated C (header comments, mode names) or a path (the build
folder of a scene).  All of them obey one rule, checked here:

* **symbol names** (coordinates, velocities, parameters, derived quantities, outputs,
  effects, variants, schedules, elements, dimensionless groups, the reduction
  coordinate and velocity): an ASCII letter, then ASCII letters, digits and
  underscores, at most :data:`MAX_NAME_LENGTH` characters; not a Python or C keyword;
  not a reserved name (a function or constant of the expression language, the time
  ``t``, ``True``/``False``, sympy's single-letter names ``I S N O Q``);
* **model and scene names**: the same, with ``-`` also allowed after the first letter
  (they name build folders and appear in generated C comments).

Because a user name always starts with a letter and contains nothing but
``[A-Za-z0-9_]``, the internal symbols of the symbolic layer (surface sides, schedule
cycle and segment indices, implicit-residual placeholders) use names outside this
set, so a user name can never collide with one of them.
"""

from __future__ import annotations

import keyword
import re

from .syntax import BOUND_FUNCTIONS, CONSTANTS, FUNCTIONS

#: Longest accepted name.
MAX_NAME_LENGTH = 64

_SYMBOL = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_LABEL = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")

#: C (C11) keywords and names of the C preprocessor / standard types that generated C uses.
C_KEYWORDS = frozenset("""
auto break case char const continue default do double else enum extern float for goto if inline int
long register restrict return short signed sizeof static struct switch typedef union unsigned void
volatile while _Alignas _Alignof _Atomic _Bool _Complex _Generic _Imaginary _Noreturn _Static_assert
_Thread_local asm NULL casadi_real casadi_int
""".split())


def reserved_names() -> frozenset[str]:
    """Names no user symbol may take: functions, constants, time, booleans, sympy names."""
    return frozenset(FUNCTIONS) | frozenset(CONSTANTS) | frozenset(BOUND_FUNCTIONS) | {
        "t", "True", "False", "I", "S", "N", "O", "Q"}


def _describe(name: object) -> str:
    text = repr(name) if not isinstance(name, str) else "'" + name.encode("unicode_escape").decode() + "'"
    return text if len(text) <= 80 else text[:77] + "...'"


def check_symbol_name(name: object) -> str | None:
    """Return the problem with ``name`` as a symbol name, or ``None`` if it is fine.

    Parameters
    ----------
    name
        A coordinate, velocity, parameter, derived, output, effect, variant, schedule,
        element, group or reduction name.

    Returns
    -------
    str or None
        A one-line explanation of what is wrong.
    """
    if not isinstance(name, str):
        return f"expected a name (string), got {type(name).__name__}"
    if not name:
        return "empty name"
    if not _SYMBOL.fullmatch(name):
        return (f"{_describe(name)} is not a valid symbol name (an ASCII letter, then ASCII letters, "
                f"digits and underscores)")
    if len(name) > MAX_NAME_LENGTH:
        return f"name {_describe(name)} is longer than {MAX_NAME_LENGTH} characters"
    if keyword.iskeyword(name):
        return f"'{name}' is a Python keyword and cannot be a symbol name"
    if name in C_KEYWORDS:
        return f"'{name}' is a C keyword and cannot be a symbol name"
    if name in reserved_names():
        return f"'{name}' is reserved (function, constant, time or sympy name)"
    return None


def check_label(name: object, what: str = "name") -> str | None:
    """Return the problem with a model or scene name, or ``None`` if it is fine.

    Model and scene names name build folders and appear in generated C comments: an
    ASCII letter, then ASCII letters, digits, ``_`` and ``-`` (no path separators, no
    dots, no spaces), at most :data:`MAX_NAME_LENGTH` characters.
    """
    if not isinstance(name, str):
        return f"expected a {what} (string), got {type(name).__name__}"
    if not name:
        return f"empty {what}"
    if not _LABEL.fullmatch(name):
        return (f"{_describe(name)} is not a valid {what} (an ASCII letter, then ASCII letters, digits, "
                f"'_' and '-'; no path separators, dots or spaces)")
    if len(name) > MAX_NAME_LENGTH:
        return f"{what} {_describe(name)} is longer than {MAX_NAME_LENGTH} characters"
    return None


def sanitize_label(text: str, fallback: str = "scene") -> str:
    """A valid model/scene name made from ``text`` (e.g. a file stem).

    Characters outside ``[A-Za-z0-9_-]`` become ``_``; a name that does not start with a
    letter gets ``fallback + '_'`` in front; the result is cut to
    :data:`MAX_NAME_LENGTH` characters.
    """
    out = re.sub(r"[^A-Za-z0-9_-]", "_", text)
    if not out or not out[0].isascii() or not out[0].isalpha():
        out = f"{fallback}_{out}"
    return out[:MAX_NAME_LENGTH]
