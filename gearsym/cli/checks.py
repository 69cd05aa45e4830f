"""Up-front checks of the command line: every numeric option, before any work.

Each ``check_<command>(args)`` validates the options of one ``gearsym`` command and
raises :class:`~gearsym.errors.ParameterError` (exit 2, one line naming the option and
the value) before the scene is loaded or compiled.  The limits keep a typo from
turning into a late ``MemoryError`` or an hour of computing:

* tolerances in ``(0, 1)`` (``--rtol`` at least 1e-15, what double precision delivers);
* counts within :data:`gearsym.budget.LIMITS`, the rules the library applies too (e.g. at
  most 1,000,000 points in a map: each point keeps its orbit summary, about 1 kB);
* ``--out`` a folder that exists and is writable, or can be created (checked
  without leaving anything behind).

Limits that need the compiled model (the output grid of ``simulate``, the step budget
of a horizon, the size of the harmonic-balance Jacobian) are checked by the library
before its work starts (:meth:`gearsym.system.System.simulate`,
:class:`gearsym.analysis.periodic.HarmonicBalance`).
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Iterator
from contextlib import contextmanager

from ..budget import LIMITS, check_count
from ..errors import OverrideError, ParameterError

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["LIMITS", "UsageError", "GearsymArgumentParser", "check_bench", "check_continue", "check_map",
           "check_orbit", "check_simulate", "emit", "float_list", "load", "parse_effects", "parse_set", "scene_args", "set_errors",
           "state_list", "unit_suffix"]

# the limits of counts (LIMITS, check_count): gearsym.budget, shared with the library


class UsageError(ParameterError):
    """A malformed command line (unknown option, missing argument, wrong type)."""


class GearsymArgumentParser(argparse.ArgumentParser):
    """``argparse`` with one-line errors (:class:`UsageError`, exit 2) and negative numbers
    in exponent form (``--rtol -1e-8``) read as values, not as options."""

    def __init__(self, *a: Any, **kw: Any):
        super().__init__(*a, **kw)
        # argparse (3.11) only takes '-5' and '-.5' for numbers; '-1e-8', '-1,0' (a list) and '-inf'
        # would be options.  No option of gearsym starts with '-' and a digit.
        self._negative_number_matcher = re.compile(r"^-\.?\d|^-(inf|infinity|nan)$", re.IGNORECASE)

    def error(self, message: str):  # type: ignore[override]
        sub = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        raise UsageError(" ".join(f"{sub + ': ' if sub else ''}{message}".split()))


# ------------------------------------------------------------------ single values
def _tol(flag: str, v: float | None, name: str) -> None:
    if v is None:
        return
    if not (math.isfinite(v) and 0 < v < 1):
        raise ParameterError(f"{flag}: tolerances must be positive, finite and below 1, got {name}={v:g}")
    if name == "rtol" and v < 1e-15:
        raise ParameterError(f"{flag}: rtol={v:g} is below what double precision can deliver (1e-15)")


def _positive(flag: str, v: float | None, name: str | None = None) -> None:
    if v is not None and not (math.isfinite(v) and v > 0):
        raise ParameterError(f"{flag}: {name or flag.lstrip('-').replace('-', '_')} must be positive and finite, "
                             f"got {v:g}")


def _whole_periods(flag: str, v: float | None) -> None:
    """Forcing periods of an orbit: a positive whole number (gearsym.analysis.periodic.whole_periods)."""
    if v is not None and not (math.isfinite(v) and v >= 1 and v == math.floor(v)):
        raise ParameterError(f"{flag} must be a positive whole number of forcing periods (1, 2, 3, ...), got {v:g}: "
                             f"a periodic orbit of a forced system returns after a whole number of forcing periods")


def _nonnegative(flag: str, v: float | None) -> None:
    if v is not None and not (math.isfinite(v) and v >= 0):
        raise ParameterError(f"{flag} must be >= 0 and finite, got {v:g}")


def _count(flag: str, v: int | None, lo: int, key: str | None = None) -> None:
    check_count(flag, v, rule=key, low=lo)


def float_list(text: str, flag: str) -> list[float]:
    """``"1,2.5,-3"`` -> floats, each finite."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise ParameterError(f"{flag}: '{text}' is not a comma-separated list of numbers") from None
    if not all(math.isfinite(v) for v in vals):
        raise ParameterError(f"{flag}: non-finite value in '{text}'")
    return vals


def _out(args: argparse.Namespace) -> None:
    if getattr(args, "out", None):
        from ..files import check_out_dir

        check_out_dir(args.out)


# ------------------------------------------------------------------ commands
def check_simulate(args: argparse.Namespace) -> None:
    """``gearsym simulate``: --periods, --t-end, --rtol, --atol, --max-steps, --x0, --out."""
    _positive("--periods", args.periods, "periods")
    _positive("--t-end", args.t_end, "t_end")
    if args.periods is not None and args.t_end is not None:
        raise ParameterError("--periods and --t-end: give one of them")
    _tol("--rtol", args.rtol, "rtol")
    _tol("--atol", args.atol, "atol")
    _count("--max-steps", args.max_steps, 1)
    if args.x0:
        float_list(args.x0, "--x0")
    _out(args)


def check_bench(args: argparse.Namespace) -> None:
    """``gearsym bench``: --periods, --points-per-period, --rounds, --out (``--rtols`` and ``--methods``
    are parsed by :mod:`gearsym.bench`)."""
    _positive("--periods", args.periods, "periods")
    _count("--points-per-period", args.points_per_period, 2)
    _count("--rounds", args.rounds, 0)
    _out(args)


def check_orbit(args: argparse.Namespace) -> None:
    """``gearsym orbit``: --periods, --segments, --harmonics, --transient, --tol, --rtol, --atol, --x0, --out."""
    _whole_periods("--periods", args.periods)
    _count("--segments", args.segments, 1)
    _count("--harmonics", args.harmonics, 0)
    _nonnegative("--transient", args.transient)
    _tol("--tol", args.tol, "tol")
    _tol("--rtol", args.rtol, "rtol")
    _tol("--atol", args.atol, "atol")
    if args.x0:
        float_list(args.x0, "--x0")
    _out(args)


def check_continue(args: argparse.Namespace) -> None:
    """``gearsym continue``: --from, --to, --periods, --segments, --harmonics, --switch, --ds-max,
    --max-points, --rtol, --atol, --x0, --out."""
    for flag, v in (("--from", args.start), ("--to", args.stop)):
        if not math.isfinite(v):
            raise ParameterError(f"{flag}: non-finite value {v}")
    if args.start == args.stop:
        raise ParameterError(f"--from and --to must differ (both {args.start:g})")
    _whole_periods("--periods", args.periods)
    _count("--segments", args.segments, 1)
    _count("--harmonics", args.harmonics, 0)
    _count("--switch", args.switch, 0)
    _count("--max-points", args.max_points, 2)
    if args.ds_max is not None and not (math.isfinite(args.ds_max) and 0 < args.ds_max <= 1):
        raise ParameterError(f"--ds-max must be in (0, 1] (a step in scaled arclength), got {args.ds_max:g}")
    _tol("--rtol", args.rtol, "rtol")
    _tol("--atol", args.atol, "atol")
    if args.x0:
        float_list(args.x0, "--x0")
    _out(args)


def axis(values: list[str], flag: str) -> tuple[str, float, float, int]:
    """``NAME LO HI N`` of ``map --x/--y``."""
    name, lo, hi, n = values
    try:
        lo_f, hi_f, n_i = float(lo), float(hi), int(n)
    except ValueError:
        raise ParameterError(f"{flag} expects NAME LO HI N (numbers LO, HI and an integer N), got "
                             f"{' '.join(values)}") from None
    if not (math.isfinite(lo_f) and math.isfinite(hi_f)) or n_i < 1:
        raise ParameterError(f"{flag}: need finite LO, HI and N >= 1, got {' '.join(values)}")
    return name, lo_f, hi_f, n_i


def check_map(args: argparse.Namespace) -> tuple[tuple[str, float, float, int], tuple[str, float, float, int]]:
    """``gearsym map``: the axes (and the number of points), --periods, --harmonics, --rtol, --workers,
    --out.  Returns the parsed axes."""
    xa, ya = axis(args.x, "--x"), axis(args.y, "--y")
    n = xa[3] * ya[3]
    if n > LIMITS["map_points"].high:
        raise ParameterError(f"--x/--y: a map of {xa[3]} x {ya[3]} = {n:.3g} points is above the limit of "
                             f"{LIMITS['map_points'].high:,} points (about 1 kB of memory each); use coarser "
                             f"axes or several maps")
    _whole_periods("--periods", args.periods)
    _count("--harmonics", args.harmonics, 0)
    _tol("--rtol", args.rtol, "rtol")
    _count("--workers", args.workers, 1)
    _search(getattr(args, "search", None))
    _out(args)
    return xa, ya


def _search(text: str | None) -> None:
    """``--search``: auto, all, none, or a comma-separated list of rows, columns, starts."""
    if text is None or text in ("auto", "all", "none"):
        return
    items = [s.strip() for s in text.split(",")]
    allowed = ("rows", "columns", "starts")
    bad = [s for s in items if s not in allowed]
    if bad or not items:
        raise ParameterError(f"--search: {', '.join(repr(b) for b in bad) or 'empty'} is not a search; give auto, "
                             f"all, none or a comma-separated list of {', '.join(allowed)}")


def state_list(text: str | None, names: list[str], flag: str) -> list[str] | None:
    """Comma-separated state names (``--plot-states x,v``), each checked against ``names``.

    Parameters
    ----------
    text
        The option's value (``None``: not given).
    names
        The states of the scene.
    flag
        The option, for messages.

    Returns
    -------
    list of str or None
        The names in the order given, ``None`` when ``text`` is ``None``.

    Raises
    ------
    ParameterError
        An empty list or a name that is not a state.
    """
    if text is None:
        return None
    out = [s.strip() for s in text.split(",") if s.strip()]
    if not out:
        raise ParameterError(f"{flag}: expected comma-separated state names, got '{text}'")
    for s in out:
        if s not in names:
            raise ParameterError(f"{flag}: '{s}' is not a state (states: {', '.join(names)})")
    return out


# --------------------------------------------------- arguments every scene command shares
def parse_set(items: list[str] | None) -> dict[str, float | str]:
    """``--set NAME=VALUE`` items -> ``{name: value}``.

    A number is in the parameter's declared unit (checked finite here); any other value is
    kept as text for :func:`gearsym.load_scene`, which converts a number with a unit
    (``50um``, ``2e13 N/m``) to the declared unit or says why it cannot (:func:`set_errors`
    reports that as ``--set NAME: ...``).
    """
    out: dict[str, float | str] = {}
    for item in items or []:
        if "=" not in item:
            raise ParameterError(f"--set expects NAME=VALUE, got '{item}'")
        name, value = item.split("=", 1)
        try:
            v: float | str = float(value)
        except ValueError:
            v = value.strip()
        if isinstance(v, float) and not math.isfinite(v):
            raise ParameterError(f"--set {name}: non-finite value {value}")
        out[name.strip()] = v
    return out


@contextmanager
def set_errors() -> Iterator[None]:
    """Report a bad ``--set`` value (an :class:`~gearsym.errors.OverrideError` of the scene) as
    ``--set NAME: what is wrong``."""
    try:
        yield
    except OverrideError as exc:
        raise ParameterError(f"--set {exc.parameter}: {exc.reason}") from None


def parse_effects(on: list[str] | None, off: list[str] | None) -> dict[str, bool | str]:
    """``--effect NAME[=VARIANT]`` and ``--no-effect NAME`` -> effect choices."""
    eff: dict[str, bool | str] = {}
    for item in on or []:
        if "=" in item:
            name, variant = item.split("=", 1)
            eff[name.strip()] = variant.strip()
        else:
            eff[item.strip()] = True
    for item in off or []:
        eff[item.strip()] = False
    return eff


def scene_args(p: argparse.ArgumentParser) -> None:
    """The arguments of every command that takes a scene."""
    p.add_argument("scene", help="scene file, or the name of a shipped scene (gearsym models lists them)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a parameter: a number in the model's declared unit, or a number with a "
                        "unit (50um, '2e13 N/m'); repeatable")
    p.add_argument("--effect", action="append", metavar="NAME[=VARIANT]",
                   help="switch an effect on (optionally choosing a variant); repeatable")
    p.add_argument("--no-effect", action="append", metavar="NAME", help="switch an effect off; repeatable")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def load(args: argparse.Namespace):
    """The scene of a parsed command line (``scene``, ``--set``, ``--effect``, ``--no-effect``)."""
    from ..facade import load_scene

    with set_errors():
        return load_scene(args.scene, effects=parse_effects(args.effect, args.no_effect) or None,
                          **parse_set(args.set))


def emit(obj: dict[str, Any]) -> None:
    """Print one strict-JSON object on stdout."""
    from ..files import to_json

    print(to_json(obj))


def unit_suffix(unit: str) -> str:
    """`` [unit]``-less suffix for printing a value: omitted for dimensionless ``1``."""
    return "" if unit in ("", "1") else f" {unit}"
