"""The settings of one engine run, as one frozen object.

:class:`RunSettings` holds everything of a :meth:`gearsym.engine.driver.Engine.run` call
but its data (the state, the parameters, the span, the output times, the initial sides,
per-component tolerances and sensitivity directions): the integration method (from the
registry :mod:`gearsym.integrators`), tolerances, step and event budgets, the nonlinear
iteration and the linear solver.  It is checked once, when it is made, and keeps the values
the C struct takes; a caller that runs many times with the same settings (a shooting Newton,
a sweep) makes it once.  :func:`settings_from_keywords` gives the object of the keywords
that stand in for it (``method="bdf", rtol=1e-10, ...``), cached by their values, so the
keyword form costs a dictionary lookup per call.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

from gearsym.budget import check_count, check_counts
from gearsym.errors import ParameterError
from gearsym.integrators import get_method
from gearsym.options import cached_options, merge_options

from .errors import EngineInputError

__all__ = ["CArgs", "RunSettings", "SensitivityRequest", "settings_from_keywords"]


class CArgs(NamedTuple):
    """The values of :class:`RunSettings` as the C struct ``gs_sim_args`` takes them."""

    method: int
    rtol: float
    atol: float
    want_monodromy: bool
    max_steps: int
    max_step: float
    init_step: float
    max_events: int
    storm_events: int
    storm_window: float
    max_events_out: int
    nonlinear: int
    linear_solver: int


@dataclass(frozen=True)
class RunSettings:
    """How one engine run integrates (see :meth:`gearsym.engine.driver.Engine.run`).

    Parameters
    ----------
    method
        A method of :data:`gearsym.integrators.INTEGRATION_METHODS` (``"bdf"``, ``"adams"``,
        ``"ida"``, ...).
    rtol, atol
        Scalar tolerances (with ``want_monodromy`` they apply to the variational states too).
    want_monodromy
        Integrate the variational equations and return ``d x(t_end) / d x0`` with saltation
        matrices at events.
    max_steps
        Total internal step budget (0: 10,000,000).
    max_step, init_step
        Maximal / initial internal step (0: the solver's choice).
    max_events
        Total events allowed (0: 1,000,000).
    storm_events, storm_window
        More than ``storm_events`` events each within ``storm_window`` of the previous one is
        an event storm (0: 50 and 1e-9*max(1,|t|)).
    max_events_out
        Initial capacity of the event log (the run is repeated with a larger log if more
        events occur; the result is deterministic).
    nonlinear
        CVODE's nonlinear iteration: ``"newton"``, ``"fixedpoint"`` or ``"auto"`` (the
        method's own: :attr:`gearsym.integrators.IntegrationMethod.nonlinear`).
    linear_solver
        Newton's linear solver: ``"dense"``, ``"blockdiag"`` (variational equations only) or
        ``"auto"`` (block-diagonal with variational equations, dense without).

    Attributes
    ----------
    c : CArgs
        The same values as the C struct takes them (codes, C numeric types).

    Raises
    ------
    EngineInputError
        An unknown method, nonlinear iteration or linear solver, or one the method does not use.
    ParameterError
        A count (``max_steps``, ``max_events``, ``storm_events``) beyond
        :data:`gearsym.budget.LIMITS`.
    """

    method: str = "bdf"
    rtol: float = 1e-8
    atol: float = 1e-10
    want_monodromy: bool = False
    max_steps: int = 0
    max_step: float = 0.0
    init_step: float = 0.0
    max_events: int = 0
    storm_events: int = 0
    storm_window: float = 0.0
    max_events_out: int = 4096
    nonlinear: str = "auto"
    linear_solver: str = "auto"
    c: CArgs = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            m = get_method(self.method)
            nonlin, linsol = m.nonlinear_code(self.nonlinear), m.linear_solver_code(self.linear_solver)
        except ParameterError as exc:
            raise EngineInputError(str(exc)) from None
        # (the C fields are long / int: a larger value would be truncated silently by ctypes)
        check_count("max_steps", self.max_steps, low=0)
        check_counts(max_events=self.max_events, storm_events=self.storm_events)
        object.__setattr__(self, "c", CArgs(
            m.code, float(self.rtol), float(self.atol), bool(self.want_monodromy), int(self.max_steps),
            float(self.max_step), float(self.init_step), int(self.max_events), int(self.storm_events),
            float(self.storm_window), max(int(self.max_events_out), 1), nonlin, linsol))


@dataclass(frozen=True)
class SensitivityRequest:
    """Forward parameter sensitivities of one run (CVODE, or IDA for implicit models and DAEs).

    Parameters
    ----------
    directions
        ``D = d p / d lambda``, shape (np, n_sens) (or (np,) for one direction).
    dt0, dt1
        ``d t0 / d lambda`` and ``d t_end / d lambda`` (n_sens,; default 0) of a span that
        moves with the parameters.
    at_outputs
        Also return them at the output times (``RunResult.sensitivity_out``).
    """

    directions: Any
    dt0: Any = None
    dt1: Any = None
    at_outputs: bool = False


#: The keywords of :meth:`Engine.run` that make its :class:`SensitivityRequest` -> its fields.
SENSITIVITY_KEYWORDS = {"sens_dir": "directions", "sens_dt0": "dt0", "sens_dt1": "dt1", "sens_out": "at_outputs"}

_DEFAULT = RunSettings()


def settings_from_keywords(settings: RunSettings | None, keywords: dict[str, Any]) -> RunSettings:
    """``settings`` (default :class:`RunSettings`) with the fields in ``keywords`` replaced.

    Without ``settings`` the object is cached by the keywords' names and values
    (:func:`gearsym.options.cached_options`: a call site passes the same keywords every time).

    Parameters
    ----------
    settings
        The settings object the caller gave, or ``None``.
    keywords
        Field -> value (the sensitivity keywords already taken out).

    Returns
    -------
    RunSettings

    Raises
    ------
    ParameterError
        A keyword that is no field of :class:`RunSettings` (named, with the closest field).
    EngineInputError
        As :class:`RunSettings`.
    """
    if not keywords:
        return settings if settings is not None else _DEFAULT
    if settings is None:
        return cached_options(RunSettings, keywords, "Engine.run")
    return merge_options(RunSettings, settings, keywords, "Engine.run")
