"""Exceptions of the simulation engine.

Every failure of :meth:`gearsym.engine.driver.Engine.run` is an
:class:`EngineError` (a :class:`gearsym.errors.SimulationError`), one subclass
per status code of the C driver (``gs_driver.h``).  Build problems are
:class:`EngineBuildError` (a :class:`gearsym.errors.CompileError`).
"""

from __future__ import annotations

from gearsym.errors import CompileError, ParameterError, SimulationError

__all__ = [
    "EngineABIError",
    "EngineBuildError",
    "EngineError",
    "EngineInputError",
    "EventStormError",
    "MaxEventsError",
    "NonFiniteError",
    "SolverError",
    "SundialsNotFoundError",
    "TooMuchWorkError",
    "error_for_status",
]


class EngineError(SimulationError):
    """A simulation in the C driver failed.

    Parameters
    ----------
    message
        The driver's message (``errmsg``).
    status
        The driver's status code (``GS_ERR_*``).
    t_reached
        The last time the integration reached.

    Attributes
    ----------
    status, t_reached, message
        As given.
    """

    status_code: int = 0

    def __init__(self, message: str, status: int | None = None, t_reached: float | None = None):
        self.message = message
        self.status = self.status_code if status is None else status
        self.t_reached = t_reached
        super().__init__(message)


class TooMuchWorkError(EngineError):
    """The total internal step budget (``max_steps``) was exhausted."""

    status_code = -1


class EventStormError(EngineError):
    """Too many events within a tiny time window (chattering / Zeno)."""

    status_code = -2


class NonFiniteError(EngineError):
    """NaN/Inf in the state, right-hand side, Jacobian or switching functions."""

    status_code = -3


class SolverError(EngineError):
    """Any other SUNDIALS failure; the message has the flag name and SUNDIALS' text."""

    status_code = -4


class EngineABIError(EngineError):
    """The SUNDIALS runtime is not what the driver was built for (version, index size)."""

    status_code = -5


class EngineInputError(EngineError, ParameterError):
    """Bad arguments to the driver (non-finite x0 / parameter, bad sizes, bad time span)."""

    status_code = -6


class MaxEventsError(EngineError):
    """More events than ``max_events``."""

    status_code = -7


class EngineBuildError(CompileError):
    """Compiling or linking the model + driver shared object failed."""


class SundialsNotFoundError(EngineBuildError):
    """The SUNDIALS 7 libraries of the scikit-sundae wheel were not found."""


_BY_STATUS: dict[int, type[EngineError]] = {
    cls.status_code: cls
    for cls in (
        TooMuchWorkError,
        EventStormError,
        NonFiniteError,
        SolverError,
        EngineABIError,
        EngineInputError,
        MaxEventsError,
    )
}


def error_for_status(status: int, message: str, t_reached: float | None = None) -> EngineError:
    """Build the exception for a driver status code.

    Parameters
    ----------
    status
        ``GS_ERR_*`` code (negative).
    message
        The driver's message.
    t_reached
        Last time reached.

    Returns
    -------
    EngineError
        An instance of the matching subclass (``EngineError`` for unknown codes).
    """
    cls = _BY_STATUS.get(status, EngineError)
    return cls(message or f"simulation failed with status {status}", status=status, t_reached=t_reached)
