"""The analysis settings of a scene: ``[simulate]``, ``[orbit]``, ``[continue]``, ``[map]``, ``[runup]``.

One definition of every setting (its type, range and default) and one resolution, used by
the command line and the Python API alike, so that one scene gives one answer:

* :func:`read_settings` checks a scene's table when the scene is read (unknown keys,
  with the closest known one; types; ranges);
* :func:`resolve_settings` gives the settings of one run: a value the caller gives
  (a ``gearsym`` option, a keyword of :meth:`gearsym.system.System.simulate` ...) wins over
  the scene's, which wins over the default below.  The command line passes only the
  options the user typed (``None`` otherwise), the API only the keywords the caller gave.

=============== ================================================================================
table           settings
=============== ================================================================================
``[simulate]``  ``periods``, ``t_end``, ``rtol``, ``atol``, ``points_per_period``, ``method``,
                ``transient_periods``, ``max_steps``, ``dimensionless``
``[orbit]``     ``periods``, ``method``, ``segments`` (shooting), ``harmonics`` (hbm),
                ``transient``, ``tol``, ``rtol``, ``atol``
``[continue]``  ``periods``, ``method``, ``segments``, ``harmonics``, ``switch``, ``ds_max``,
                ``max_points``, ``rtol``, ``atol``, ``tol``
``[map]``       ``periods``, ``method``, ``quantity``, ``harmonics``, ``rtol``
``[runup]``     ``parameter``, ``from``, ``to``, ``duration`` or ``rate``, ``profile``, ``signal``,
                ``settle``, ``samples_per_period``, ``bins``, ``orders``, ``modes``, ``rtol``,
                ``atol``, ``method``, ``max_steps`` (:mod:`gearsym.analysis.sweeps`: a run-up)
=============== ================================================================================

A default of ``None`` means "the solver's own default" (or, for ``periods`` / ``t_end`` of
``[simulate]``, the rule of :meth:`gearsym.system.System.simulate`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import ParameterError, SpecError
from ..integrators import method_names
from .fields import unknown_key

__all__ = ["MAP_QUANTITIES", "SETTINGS", "Setting", "read_settings", "resolve_settings"]


@dataclass(frozen=True)
class Setting:
    """One setting of a scene's analysis table.

    Attributes
    ----------
    types
        Accepted Python types (``bool`` only where listed).
    default
        Value when neither the caller nor the scene gives one (``None``: the solver's default).
    check
        Range rule: ``"positive"``, ``"nonnegative"``, ``"tolerance"`` (in (0, 1)),
        ``"rtol"`` (in [1e-15, 1)), ``"count"`` (integer >= 1), ``"count0"`` (>= 0),
        ``"fraction"`` (in (0, 1]) or ``None``.
    choices
        The allowed strings (for ``method``, ``quantity``).
    """

    types: tuple[type, ...]
    default: Any = None
    check: str | None = None
    choices: tuple[str, ...] = ()


_NUM = (int, float)
#: What a map can show: its own quantities (lyapunov: gearsym.analysis.sweeps), then the scalar gear quantities (defined in
#: gearsym.quantities; tests/test_quantities.py checks that the two lists agree).
MAP_QUANTITIES = ("max_multiplier", "peak_to_peak", "rattle_state", "lyapunov",
                  "static_deflection", "static_force", "dte_mean", "dte_rms", "dte_peak_to_peak", "dte_harmonic_1",
                  "dte_harmonic_2", "dte_harmonic_3", "force_mean", "force_rms", "force_min", "force_max",
                  "dynamic_factor", "dynamic_factor_rms", "contact_loss_ratio", "back_contact_ratio", "impact_count",
                  "impacts_per_period", "impact_velocity_max", "load_sharing_factor")
_PERIODS = Setting(_NUM, None, "positive")
_RTOL = Setting(_NUM, None, "rtol")
_TOL = Setting(_NUM, None, "tolerance")
_COUNT = Setting((int,), None, "count")
_COUNT0 = Setting((int,), None, "count0")

#: Every settings table of a scene: table -> setting -> :class:`Setting`.
SETTINGS: dict[str, dict[str, Setting]] = {
    "simulate": {
        "periods": _PERIODS,
        "t_end": Setting(_NUM, None, "positive"),
        "rtol": Setting(_NUM, 1e-8, "rtol"),
        "atol": Setting(_NUM, 1e-10, "tolerance"),
        "points_per_period": Setting((int,), 64, "count"),
        "method": Setting((str,), None, None, method_names()),
        "transient_periods": Setting(_NUM, None, "nonnegative"),
        "max_steps": Setting((int,), 0, "count0"),
        "dimensionless": Setting((bool,), False),
    },
    "orbit": {
        "periods": Setting(_NUM, 1, "positive"),
        "method": Setting((str,), "shooting", None, ("shooting", "hbm")),
        "segments": _COUNT,
        "transient": Setting(_NUM, None, "nonnegative"),
        "harmonics": _COUNT0,
        "tol": _TOL,
        "rtol": _RTOL,
        "atol": _TOL,
    },
    "continue": {
        "periods": Setting(_NUM, 1, "positive"),
        "method": Setting((str,), "shooting", None, ("shooting", "hbm")),
        "segments": _COUNT,
        "harmonics": _COUNT0,
        "switch": _COUNT0,
        "ds_max": Setting(_NUM, None, "fraction"),
        "max_points": _COUNT,
        "rtol": _RTOL,
        "atol": _TOL,
        "tol": _TOL,
    },
    "map": {
        "periods": Setting(_NUM, 1, "positive"),
        "method": Setting((str,), "auto", None, ("auto", "exact", "shooting", "hbm")),
        "quantity": Setting((str,), "max_multiplier", None, MAP_QUANTITIES),
        "harmonics": _COUNT0,
        "rtol": _RTOL,
    },
    "runup": {  # a linear ramp of a speed parameter (gearsym.analysis.sweeps.runup)
        "parameter": Setting((str,)),
        "from": Setting(_NUM),
        "to": Setting(_NUM),
        "duration": Setting(_NUM, None, "positive"),
        "rate": Setting(_NUM, None, "positive"),
        "profile": Setting((str,), "linear", None, ("linear",)),
        "signal": Setting((str,)),
        "settle": Setting(_NUM, 0, "nonnegative"),
        "samples_per_period": Setting((int,), 16, "count"),
        "bins": Setting((int,), 60, "count"),
        "orders": Setting((int,), 3, "count"),
        "modes": Setting((bool,), True),
        "rtol": _RTOL,
        "atol": _TOL,
        "method": Setting((str,), None, None, method_names()),
        "max_steps": Setting((int,), 0, "count0"),
    },
}

#: Settings that belong to one orbit method only (dropped for the other).
METHOD_ONLY: dict[str, str] = {"segments": "shooting", "harmonics": "hbm"}


def _problem(s: Setting, v: Any) -> str | None:
    """What is wrong with value ``v`` of setting ``s`` (``None``: nothing)."""
    if (isinstance(v, bool) and bool not in s.types) or not isinstance(v, s.types):  # TOML: int/float/bool
        want = " or ".join(sorted({"number" if t in _NUM else t.__name__.replace("str", "string")
                                   .replace("bool", "true/false") for t in s.types}))
        if s.types == (int,):
            want = "an integer"
        return f"wrong type: expected {want}, got {type(v).__name__} {v!r}"
    if s.choices and v not in s.choices:
        return f"must be one of {', '.join(s.choices)}, got '{v}'"
    if isinstance(v, bool) or not isinstance(v, _NUM):
        return None
    if not math.isfinite(v):
        return f"non-finite value {v}"
    rules = {"positive": (v > 0, "must be positive"), "nonnegative": (v >= 0, "must be >= 0"),
             "tolerance": (0 < v < 1, "must be positive and below 1"),
             "rtol": (0 < v < 1, "must be positive and below 1"),
             "count": (v >= 1, "must be at least 1"), "count0": (v >= 0, "must be >= 0"),
             "fraction": (0 < v <= 1, "must be in (0, 1]")}
    ok, text = rules.get(s.check or "", (True, ""))
    if ok and s.check == "rtol" and v < 1e-15:
        ok, text = False, "is below what double precision can deliver (1e-15)"
    return None if ok else f"{text}, got {v:g}"


def read_settings(section: str, table: Any, error: Callable[[str, str], SpecError]) -> dict[str, Any]:
    """Check a scene's settings table.

    Parameters
    ----------
    section
        ``"simulate"``, ``"orbit"``, ``"continue"`` or ``"map"``.
    table
        The TOML table.
    error
        ``error(field, message)`` -> the :class:`~gearsym.errors.SpecError` to raise (naming the file).

    Returns
    -------
    dict
        The table (a copy).

    Raises
    ------
    SpecError
        Not a table, an unknown key (with the closest known one), a wrong type or a value
        out of range, naming ``section.key``.
    """
    schema = SETTINGS[section]
    if not isinstance(table, Mapping):
        raise error(section, "wrong type: expected a table")
    for k, v in table.items():
        if k not in schema:
            raise error(f"{section}.{k}", unknown_key(k, schema))
        problem = _problem(schema[k], v)
        if problem:
            raise error(f"{section}.{k}", problem)
    if section == "simulate" and "periods" in table and "t_end" in table:
        raise error("simulate.t_end", "give one of periods and t_end (the horizon in forcing periods, or a time)")
    if section == "runup" and "duration" in table and "rate" in table:
        raise error("runup.rate", "give one of duration and rate (the ramp's length in time, or its slope)")
    return dict(table)


def resolve_settings(section: str, scene: Mapping[str, Any] | None, **given: Any) -> dict[str, Any]:
    """The settings of one run: the caller's values, else the scene's, else the defaults.

    Parameters
    ----------
    section
        ``"simulate"``, ``"orbit"``, ``"continue"`` or ``"map"``.
    scene
        The scene's table (checked by :func:`read_settings`).
    **given
        The caller's values; ``None`` means "not given".  A key that is not a setting of
        ``section`` is an error; the values themselves are checked by the caller (the
        command line's option checks, :meth:`gearsym.system.System.simulate`, the solvers).

    Returns
    -------
    dict
        Every setting of ``section`` -> its value (``None``: not set anywhere, the solver's
        default applies).  For ``orbit``, ``continue`` and ``map`` the scene's settings of the
        other orbit method are dropped (``segments`` with ``method = "hbm"``, ``harmonics``
        with ``"shooting"``).

    Raises
    ------
    ParameterError
        A given key that is not a setting of ``section``, or a given setting of the other
        orbit method (``segments`` with ``method = "hbm"``).
    """
    schema = SETTINGS[section]
    out: dict[str, Any] = {k: s.default for k, s in schema.items()}
    out.update({k: v for k, v in (scene or {}).items() if k in schema})
    mine: set[str] = set()
    for k, v in given.items():
        if k not in schema:
            raise ParameterError(f"'{k}' is not a setting of [{section}] (settings: {', '.join(schema)})")
        if v is not None:
            out[k] = v
            mine.add(k)
    method = out.get("method")
    for k, only in METHOD_ONLY.items():  # the scene's settings of the other method do not apply
        if section == "simulate" or k not in out or method not in ("shooting", "hbm") or method == only:
            continue
        if k in mine:
            raise ParameterError(f"{k} applies to method '{only}', not '{method}'")
        out[k] = None
    return out
