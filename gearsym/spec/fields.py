"""Reading the fields of a spec table: types, names, expressions and typed excitations.

Shared by the model and scene parsers.  Every problem is a
:class:`~gearsym.errors.SpecError` naming the file and the dotted field path.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import SpecError
from . import expressions as ex
from .names import check_symbol_name
from .units import Unit, UnitSyntaxError, parse_unit

if TYPE_CHECKING:
    from .model import Schedule


@dataclass(frozen=True)
class Term:
    """One term of an expression field, possibly tagged with an effect (variant).

    ``surface`` names the switching surfaces of the term's state-dependent conditions and
    kinks, in the order they are written (the ``surface`` key of a term table; see
    :mod:`gearsym.symbolic.surfaces`).
    """

    expr: str
    field: str
    effect: str | None = None
    variant: str | None = None
    surface: tuple[str, ...] = ()




class Ctx:
    """Parsing context: the file name for errors."""

    def __init__(self, path: str):
        self.path = path

    def error(self, field_path: str | None, message: str) -> SpecError:
        return SpecError(message, file=self.path, field=field_path)



def read_terms(ctx: Ctx, where: str, value: Any, schedules: dict[str, Schedule],
           effect: str | None = None, variant: str | None = None) -> tuple[Term, ...]:
    """Normalise an expression field into a tuple of terms."""
    if isinstance(value, list):
        out: list[Term] = []
        for i, v in enumerate(value):
            out.extend(read_terms(ctx, f"{where}[{i}]", v, schedules, effect, variant))
        return tuple(out)
    if isinstance(value, dict):
        kind = value.get("type")
        if kind is not None and kind not in _TERM_KEYS:
            raise ctx.error(f"{where}.type", f"unknown excitation type '{kind}'{did_you_mean(str(kind), _TYPES)} "
                                             f"(known: {', '.join(_TYPES)})")
        only_keys(ctx, where, value, {"effect", "variant", "type", "surface", *_TERM_KEYS[kind]})
        eff = value.get("effect", effect)
        var = value.get("variant", variant)
        for k, v in (("effect", eff), ("variant", var)):
            if v is not None and not isinstance(v, str):
                raise ctx.error(f"{where}.{k}", "must be a string")
        if kind is None:
            if "expr" not in value:
                raise ctx.error(where, "a term table needs 'expr' or 'type'")
            return (Term(expr_str(ctx, f"{where}.expr", value["expr"]), where, eff, var,
                         _surface_names(ctx, where, value)),)
        return (Term(_typed(ctx, where, kind, value, schedules), where, eff, var,
                     _surface_names(ctx, where, value)),)
    return (Term(expr_str(ctx, where, value), where, effect, variant),)


#: The keys of a term table besides ``effect``, ``variant`` and ``type``, by its ``type``.
_TERM_KEYS: dict[str | None, tuple[str, ...]] = {
    None: ("expr",),
    "sinusoid": ("amplitude", "frequency", "phase", "mean"),
    "fourier": ("frequency", "mean", "cos", "sin"),
    "piecewise_cycle": ("schedule", "values"),
}
_TYPES = tuple(k for k in _TERM_KEYS if k is not None)


def _surface_names(ctx: Ctx, where: str, table: dict[str, Any]) -> tuple[str, ...]:
    """The ``surface`` key of a term table: one name or an array of names (symbol names)."""
    if "surface" not in table:
        return ()
    value = table["surface"]
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not names:
        raise ctx.error(f"{where}.surface", "must be a name or a non-empty array of names")
    for i, name in enumerate(names):
        here = f"{where}.surface" if isinstance(value, str) else f"{where}.surface[{i}]"
        problem = check_symbol_name(name)
        if problem:
            raise ctx.error(here, problem)
    if len(set(names)) != len(names):
        raise ctx.error(f"{where}.surface", "a surface name is given twice")
    return tuple(names)


def _typed(ctx: Ctx, where: str, kind: str, v: dict[str, Any], schedules: dict[str, Schedule]) -> str:
    """Expand a typed excitation table into an expression string."""
    if kind == "sinusoid":
        amp = expr_str(ctx, f"{where}.amplitude", v.get("amplitude"))
        freq = expr_str(ctx, f"{where}.frequency", v.get("frequency"))
        phase = expr_str(ctx, f"{where}.phase", v.get("phase", 0))
        mean = expr_str(ctx, f"{where}.mean", v.get("mean", 0))
        wave = f"({amp})*cos(({freq})*t + ({phase}))"
        # an absent mean adds nothing (a literal 0 would be dimensionless and clash
        # with a dimensional amplitude in the unit check)
        return f"({mean}) + {wave}" if "mean" in v else wave
    if kind == "fourier":
        freq = expr_str(ctx, f"{where}.frequency", v.get("frequency"))
        mean = expr_str(ctx, f"{where}.mean", v.get("mean", 0))
        parts = [f"({mean})"] if "mean" in v else []  # see sinusoid: no dimensionless 0
        for key, fn in (("cos", "cos"), ("sin", "sin")):
            coefs = v.get(key, [])
            if not isinstance(coefs, list):
                raise ctx.error(f"{where}.{key}", "must be an array of coefficients")
            for n, c in enumerate(coefs, start=1):
                c = expr_str(ctx, f"{where}.{key}[{n - 1}]", c)
                parts.append(f"({c})*{fn}({n}*({freq})*t)")
        return " + ".join(parts) if parts else "0"
    if kind == "piecewise_cycle":
        sname = v.get("schedule")
        if sname not in schedules:
            raise ctx.error(f"{where}.schedule", f"unknown schedule '{sname}' "
                                                 f"(schedules: {', '.join(schedules) or 'none'})")
        values = v.get("values")
        nseg = len(schedules[sname].breaks) + 1
        if not isinstance(values, list) or len(values) != nseg:
            raise ctx.error(f"{where}.values", f"needs one value per segment of schedule '{sname}' "
                                               f"({nseg})")
        vals = []
        for i, val in enumerate(values):
            s = expr_str(ctx, f"{where}.values[{i}]", val)
            # 'phase' inside a value means this schedule's phase
            vals.append(ex.rename(s, {"phase": f"{sname}_phase"}))
        seg = f"{sname}_segment"
        pieces = [f"({val}, {seg} < {i + 0.5})" for i, val in enumerate(vals[:-1])]
        pieces.append(f"({vals[-1]}, True)")
        return f"Piecewise({', '.join(pieces)})"
    raise ctx.error(f"{where}.type", f"unknown excitation type '{kind}' "
                                     f"(known: sinusoid, fourier, piecewise_cycle)")


def expr_str(ctx: Ctx, where: str, value: Any) -> str:
    if value is None:
        raise ctx.error(where, "missing expression")
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ctx.error(where, f"wrong type: expected an expression (string or number), "
                               f"got {type(value).__name__}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ctx.error(where, f"non-finite value {value}")
    text = value if isinstance(value, str) else repr(value)
    try:
        ex.names_in(text)
    except ex.ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None
    return text


def table(ctx: Ctx, data: dict[str, Any], key: str, required: bool = False) -> dict[str, Any]:
    if key not in data:
        if required:
            raise ctx.error(key, f"missing section [{key}]")
        return {}
    return as_table(ctx, key, data[key])


def as_table(ctx: Ctx, where: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ctx.error(where, f"wrong type: expected a table, got {type(value).__name__}")
    return value


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the candidate closest to ``word`` (:mod:`difflib`), else ``""``."""
    close = difflib.get_close_matches(str(word), sorted(set(candidates)), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def unknown_key(key: str, allowed: Iterable[str], what: str = "field") -> str:
    """The message for a key a table does not have: the closest allowed key, then all of them."""
    allowed = sorted(set(allowed))
    return f"unknown {what} '{key}'{did_you_mean(key, allowed)} (allowed: {', '.join(allowed) or 'none'})"


def only_keys(ctx: Ctx, where: str, table: dict[str, Any], allowed: set[str]) -> None:
    """Reject a key of ``table`` that is not in ``allowed`` (naming the field and the closest key)."""
    for k in table:
        if k not in allowed:
            raise ctx.error(f"{where}.{k}" if where else k, unknown_key(k, allowed))


def string(ctx: Ctx, table: dict[str, Any], where: str, required: bool = False) -> str | None:
    key = where.rsplit(".", 1)[-1]
    if key not in table:
        if required:
            raise ctx.error(where, f"missing field '{key}'")
        return None
    v = table[key]
    if not isinstance(v, str):
        raise ctx.error(where, f"wrong type: expected a string, got {type(v).__name__}")
    return v


def string_list(ctx: Ctx, table: dict[str, Any], where: str) -> list[str]:
    key = where.rsplit(".", 1)[-1]
    v = table.get(key, [])
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise ctx.error(where, "wrong type: expected an array of strings")
    return v


def number(ctx: Ctx, where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ctx.error(where, f"wrong type: expected a number, got {type(v).__name__} {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise ctx.error(where, f"non-finite value {v}")
    return v


def unit_of(ctx: Ctx, where: str, text: str) -> Unit:
    try:
        return parse_unit(text)
    except UnitSyntaxError as exc:
        raise ctx.error(where, str(exc)) from None

