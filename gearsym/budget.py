"""Bounded work: the limits of every count a user gives, in one place.

A count typed by a user (``--samples 1000000000``, ``segments=10**6``, a 1e5 x 1e5 map)
must be refused before any work, with a :class:`~gearsym.errors.ParameterError` (exit 2)
naming the option and the limit, not end in a ``MemoryError`` after minutes or in an
hour of computing.  The command line (:mod:`gearsym.cli.checks`, before the scene is
loaded) and the library (:meth:`gearsym.system.System.simulate`, the orbit solvers,
:func:`gearsym.continuation`, the maps, :func:`gearsym.analysis.linear.modal_analysis`,
the options objects and the engine's Newton matrices) take their rules from here:

* :data:`LIMITS`: the range of each count, by the name of its keyword argument;
* memory of arrays whose size depends on the model as well (the output grid, a dense
  Newton matrix): :data:`MAX_OUTPUT_VALUES` and :data:`MAX_MATRIX_VALUES` numbers,
  :func:`check_values` and :func:`check_matrix`;
* time of an integration: at most ``max_steps`` steps of the largest step allowed
  (:func:`check_step_budget`).

The limits are ceilings against typos and runaway requests, far above what any shipped
scene uses (e.g. 32 samples per period for the modes, 5000 branch points).  The module
imports nothing heavy (``gearsym --version`` stays light).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from .errors import ParameterError

__all__ = ["DEFAULT_MAX_STEPS", "LIMITS", "Limit", "MAX_MATRIX_VALUES", "MAX_OUTPUT_VALUES", "check_amount",
           "check_branch", "check_count", "check_counts", "check_harmonics", "check_matrix", "check_orbit_options",
           "check_output_grid", "check_shooting", "check_step_budget", "check_values"]

#: Largest output array (points x values): 2**28 doubles = 2 GiB (plots and outputs copy it again).
MAX_OUTPUT_VALUES = 2 ** 28
#: Largest dense matrix (entries) a solver builds: a harmonic-balance or multiple-shooting
#: Jacobian, the engine's Newton matrix of the variational equations: 2**28 doubles = 2 GiB
#: (and its LU costs about (2**14)**3 = 4e12 operations).
MAX_MATRIX_VALUES = 2 ** 28
#: The engine's internal step budget when none is given (``max_steps=0``).
DEFAULT_MAX_STEPS = 10_000_000


@dataclass(frozen=True)
class Limit:
    """The range of one count.

    Attributes
    ----------
    low, high
        Smallest and largest value accepted.
    what
        What the count is (for messages).
    """

    low: int
    high: int
    what: str


#: The range of every count, by the name of its keyword argument (the command line's option
#: without the dashes, ``-`` as ``_``).
LIMITS: dict[str, Limit] = {
    "samples": Limit(1, 100_000, "samples per forcing period of the averages (modes, static equilibrium)"),
    "aft_samples": Limit(1, 1 << 20, "time samples per period of the harmonic balance"),
    "harmonics": Limit(0, 4096, "harmonics of the harmonic balance"),
    "max_harmonics": Limit(1, 4096, "harmonics of the harmonic balance"),
    "segments": Limit(1, 10_000, "shooting segments"),
    "max_iter": Limit(0, 100_000, "Newton iterations"),
    "max_newton": Limit(1, 10_000, "Newton steps per branch point"),
    "max_points": Limit(2, 1_000_000, "points of a branch"),
    "stall_points": Limit(2, 1_000_000, "branch points of the stall test"),
    "n_dense": Limit(2, 1 << 20, "samples per period of each branch point"),
    "switch": Limit(0, 8, "levels of branch switching (each one can double the branches)"),
    "map_points": Limit(1, 1_000_000, "points of a map (about 1 kB of memory each)"),
    "map_axis": Limit(1, 1_000_000, "points of a map axis"),
    "rows_per_task": Limit(1, 1_000_000, "map rows per task"),
    "sweep_values": Limit(1, 1_000_000, "parameter values of a brute-force sweep"),
    "sweep_samples": Limit(2, 1_000_000, "Poincare points kept per parameter value of a sweep"),
    "points_per_period": Limit(2, 100_000, "output points per forcing period"),
    "rounds": Limit(0, 100, "timing rounds"),
    "workers": Limit(1, 1024, "worker processes"),
    "max_steps": Limit(1, 2 ** 62, "internal integrator steps"),
    "max_events": Limit(0, 2 ** 62, "events of one integration"),
    "storm_events": Limit(0, 2 ** 31 - 1, "events of an event storm"),
    # amounts (need not be integers)
    "transient": Limit(0, 1_000_000, "forcing periods integrated before Newton"),
    "relax_periods": Limit(0, 1_000_000, "forcing periods of relaxation"),
}


def check_count(name: str, value: object, *, rule: str | None = None, low: int | None = None) -> None:
    """Refuse a count outside its range (:data:`LIMITS`).

    Parameters
    ----------
    name
        The option or keyword as the user wrote it (``"--samples"``, ``"samples"``): the
        message names it.
    value
        The count (an integer; a float with an integral value counts as one).  ``None``
        passes (not given).
    rule
        The entry of :data:`LIMITS` (default: ``name`` without leading dashes, ``-`` as ``_``).
    low
        Smallest value, instead of the rule's.

    Raises
    ------
    ParameterError
        Not an integer, or outside ``[low, high]``: naming ``name``, the value and the range.
    """
    if value is None:
        return
    limit = LIMITS[rule or name.lstrip("-").replace("-", "_")]
    lo = limit.low if low is None else low
    try:
        integral = not isinstance(value, (bool, str, bytes)) and float(value) == int(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        integral = False
    if not integral:
        raise ParameterError(f"{name} must be an integer in [{lo:,}, {limit.high:,}], got {value!r}")
    v = int(value)  # type: ignore[call-overload]
    if v < lo or v > limit.high:
        raise ParameterError(f"{name} must be an integer in [{lo:,}, {limit.high:,}], got {v}"
                             + (f" (the limit on {limit.what} keeps memory and work bounded)" if v > limit.high
                                else ""))


def check_counts(rules: dict[str, str] | None = None, /, **counts: object) -> None:
    """:func:`check_count` for each keyword; ``None`` values pass.

    Parameters
    ----------
    rules
        Keyword -> entry of :data:`LIMITS` where they differ (default: the keyword's own).
    **counts
        The counts, by the keyword the user gave them as.

    Raises
    ------
    ParameterError
    """
    for name, value in counts.items():
        check_count(name, value, rule=(rules or {}).get(name))


def check_amount(name: str, value: object, *, rule: str | None = None) -> None:
    """Refuse an amount (a real number, e.g. forcing periods) outside its range (:data:`LIMITS`).

    Parameters
    ----------
    name
        The option or keyword as the user wrote it.
    value
        The amount; ``None`` passes (not given).
    rule
        The entry of :data:`LIMITS` (default: ``name`` without leading dashes, ``-`` as ``_``).

    Raises
    ------
    ParameterError
        Not a finite number in ``[low, high]``.
    """
    if value is None:
        return
    limit = LIMITS[rule or name.lstrip("-").replace("-", "_")]
    try:
        v = float(value) if not isinstance(value, (bool, str, bytes)) else math.nan  # type: ignore[arg-type]
    except (TypeError, ValueError):
        v = math.nan
    if not limit.low <= v <= limit.high:
        raise ParameterError(f"{name} must be a number in [{limit.low:,}, {limit.high:,}], got {value!r}"
                             + (f" (the limit on {limit.what} keeps the work bounded)" if v > limit.high else ""))


def check_harmonics(name: str, harmonics: object) -> None:
    """Refuse a number of harmonics, or a set of harmonic numbers, beyond :data:`LIMITS`
    ``["harmonics"]`` (the time samples of the balance grow with the highest harmonic).

    Parameters
    ----------
    name
        The option or keyword, for messages.
    harmonics
        ``None``, a count ``H`` or an iterable of harmonic numbers.

    Raises
    ------
    ParameterError
    """
    if harmonics is None or isinstance(harmonics, (int, float, str, bytes)) or not hasattr(harmonics, "__iter__"):
        check_count(name, harmonics, rule="harmonics")
        return
    for k in harmonics:  # type: ignore[attr-defined]
        check_count(f"a harmonic number of {name}", k, rule="harmonics")


def check_orbit_options(options: Mapping[str, object] | None) -> None:
    """The counts among the keyword options of a periodic-orbit solver (shooting or harmonic
    balance), for a caller that passes them on to many solves (a map): refused once, up front.

    Parameters
    ----------
    options
        Keyword options (``segments``, ``max_iter``, ``harmonics``, ``max_harmonics``,
        ``samples``, ``max_samples``, ``transient``, ``relax_periods``; others are not looked at).

    Raises
    ------
    ParameterError
    """
    opts = dict(options or {})
    check_harmonics("harmonics", opts.get("harmonics"))
    check_counts({"samples": "aft_samples", "max_samples": "aft_samples"},
                 **{k: opts[k] for k in ("segments", "max_iter", "max_harmonics", "samples", "max_samples") if k in opts})
    for k in ("transient", "relax_periods"):
        check_amount(k, opts.get(k))


def check_shooting(segments: int, nx: int) -> None:
    """The number of shooting segments (:data:`LIMITS`) and the dense multiple-shooting
    Jacobian, ``(segments * nx)**2`` entries, within :data:`MAX_MATRIX_VALUES`.

    Raises
    ------
    ParameterError
    """
    check_count("segments", segments)
    n = float(segments) * nx
    check_matrix(n, n, f"with {nx} states and {segments} segments, the multiple-shooting Jacobian",
                 "use fewer segments")


def check_branch(max_points: int, nx: int) -> None:
    """The number of branch points (:data:`LIMITS`) and the memory of a full branch: every point
    keeps its monodromy (``nx**2`` numbers) and a summary (about 1 kB), within
    :data:`MAX_OUTPUT_VALUES` numbers.

    Raises
    ------
    ParameterError
    """
    check_count("max_points", max_points)
    check_values(float(max_points) * (nx * nx + 128),
                 f"a branch of up to {int(max_points):,} points, each with its {nx} x {nx} monodromy, would hold "
                 f"{float(max_points) * (nx * nx + 128):.3g} numbers", "use a smaller max_points")


def check_values(n_values: float, what: str, hint: str, limit: int = MAX_OUTPUT_VALUES) -> None:
    """Refuse an array of more than ``limit`` numbers (8 bytes each) before it is allocated.

    Parameters
    ----------
    n_values
        Numbers the array would hold (a float: products of counts may be huge).
    what
        What the array is, with its shape (``"the output grid has 1e12 points x 3 values"``).
    hint
        What to change (``"use fewer periods"``).
    limit
        The budget (default :data:`MAX_OUTPUT_VALUES`).

    Raises
    ------
    ParameterError
    """
    if not n_values <= limit:  # (NaN too)
        raise ParameterError(f"{what} ({n_values * 8 / 2**30:.3g} GiB); the limit is {limit:.3g} values "
                             f"({limit * 8 / 2**30:g} GiB): {hint}")


def check_output_grid(n_points: float, width: int, hint: str) -> None:
    """Refuse an output grid of ``n_points`` x ``width`` numbers above :data:`MAX_OUTPUT_VALUES`.

    Parameters
    ----------
    n_points
        Output times.
    width
        Numbers stored per time (states + 1).
    hint
        What to change.

    Raises
    ------
    ParameterError
    """
    check_values(float(n_points) * width, f"the output grid has {float(n_points):.3g} points x {width} values", hint)


def check_matrix(rows: float, cols: float, what: str, hint: str) -> None:
    """Refuse a dense ``rows`` x ``cols`` matrix above :data:`MAX_MATRIX_VALUES` entries.

    Parameters
    ----------
    rows, cols
        Its shape.
    what
        What the matrix is (``"the multiple-shooting Jacobian"``).
    hint
        What to change.

    Raises
    ------
    ParameterError
    """
    n = float(rows) * float(cols)
    check_values(n, f"{what} would have {float(rows):.6g} x {float(cols):.6g} = {n:.3g} entries", hint,
                 MAX_MATRIX_VALUES)


def check_step_budget(t0: float, t_end: float, max_step: float, max_steps: int, t8: bool = False) -> None:
    """Refuse, before any work, a horizon that needs more steps of ``max_step`` than the budget.

    Parameters
    ----------
    t0, t_end
        The horizon.
    max_step
        The largest internal step (0 or non-finite: unlimited, nothing to check).
    max_steps
        The step budget (0: :data:`DEFAULT_MAX_STEPS`).
    t8
        ``max_step`` is the default ``T/8`` (said in the message).

    Raises
    ------
    ParameterError
    """
    budget = max_steps or DEFAULT_MAX_STEPS
    if max_step and math.isfinite(max_step) and max_step > 0 and (t_end - t0) / max_step > budget:
        raise ParameterError(
            f"integrating to t_end = {t_end:g} needs at least {(t_end - t0) / max_step:.3g} steps "
            f"(largest step {max_step:.3g}{' = T/8' if t8 else ''}), more than "
            f"max_steps = {budget:d}: raise max_steps (--max-steps) or integrate fewer periods")
