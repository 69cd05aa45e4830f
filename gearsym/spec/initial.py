"""The ``[initial]`` table of models and scenes: initial states and the static start.

::

    [initial]
    x = "F_m/k_m + b_m"    # an expression of the model's parameters (SI values), or a number
    v = 0.0
    static = true          # solve for the static equilibrium before integrating

A number is the state's value in SI units.  A string is an expression of the model's
parameters, read by the spec's whitelist parser (:mod:`gearsym.spec.syntax`: no
``eval``) and evaluated with the parameter values of the scene, after ``--set``
overrides, in SI units; it must have the unit of the state (a coordinate's unit, or that
unit per time unit for a velocity).  ``static = true`` asks for the static equilibrium
(:mod:`gearsym.static`): the coordinates are solved for, the values given for them are the
starting guess, velocities are zero unless given.  A scene's ``[initial]`` overrides the
model's entry by entry, ``static`` included.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from ..errors import SpecError
from . import expressions as ex
from .units import Unit

__all__ = ["evaluate_initial", "read_initial"]

#: an initial value: a number (SI) or an expression of the parameters
Value = float | str


def read_initial(table: Mapping[str, Any], error: Callable[[str, str], SpecError]
                 ) -> tuple[dict[str, Value], bool | None]:
    """Read an ``[initial]`` table (the syntax only: names are checked by :func:`evaluate_initial`).

    Parameters
    ----------
    table
        The TOML table.
    error
        ``error(field, message)`` -> the :class:`SpecError` to raise (naming the file).

    Returns
    -------
    values : dict
        State name -> number or expression string.
    static : bool or None
        The ``static`` option, ``None`` when absent.

    Raises
    ------
    SpecError
        A value that is neither a finite number nor a valid expression, or a
        ``static`` that is not a boolean.
    """
    if not isinstance(table, Mapping):
        raise error("initial", "wrong type: expected a table")
    values: dict[str, Value] = {}
    static: bool | None = None
    for k, v in table.items():
        where = f"initial.{k}"
        if k == "static":
            if not isinstance(v, bool):
                raise error(where, f"must be true or false, got {v!r}")
            static = v
        elif isinstance(v, str):
            try:
                ex.parse(v)
            except ex.ExpressionError as exc:
                raise error(where, str(exc)) from None
            values[k] = v
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise error(where, f"expected a finite number or an expression of the parameters, got {v!r}")
        else:
            values[k] = float(v)
    return values, static


def evaluate_initial(name: str, value: Value, params: Mapping[str, float], units: Mapping[str, Unit],
                     state_unit: Unit | None, error: Callable[[str, str], SpecError]) -> float:
    """The value of one initial state in SI units.

    Parameters
    ----------
    name
        The state's name (for messages: field ``initial.NAME``).
    value
        A number (returned as is) or an expression of the parameters.
    params
        Parameter values (SI units) the expression may use.
    units
        Units of the parameters.
    state_unit
        The state's unit, checked against the expression's (``None``: not checked).
    error
        ``error(field, message)`` -> the :class:`SpecError` to raise.

    Returns
    -------
    float
        The value, SI units.

    Raises
    ------
    SpecError
        Unknown names (only parameters may appear), a unit mismatch, or a value that
        is not finite.
    """
    if not isinstance(value, str):
        return float(value)
    where = f"initial.{name}"
    names = ex.names_in(value)
    unknown = sorted(names - set(params))
    if unknown:
        raise error(where, f"'{unknown[0]}' is not a parameter of the model (initial values are numbers "
                           f"or expressions of the parameters)")
    if names and state_unit is not None:
        try:
            got = ex.infer_unit(value, {n: units[n] for n in names})
        except ex.ExpressionError as exc:
            raise error(where, str(exc)) from None
        if not got.same_dimension(state_unit):
            raise error(where, f"unit mismatch: the state is [{state_unit.si_string()}], the expression "
                               f"[{got.si_string()}]")
    v = ex.constant_value(value, {n: params[n] for n in names})
    if v is None:
        raise error(where, f"'{value}' is not finite at the parameter values "
                           + ", ".join(f"{n} = {params[n]:g}" for n in sorted(names)) + " (SI)")
    return v
