"""A speed ramp of one run: the engine-level description (``struct gs_ramp``, gs_ramp.c).

The parameter ``p[index]`` (the speed) runs linearly, ``Omega(t) = speed0 + rate (t - t0)``,
and the model's periodic time functions run on its phase ``theta(t) = speed0 tau(t)``,

    tau(t) = t + rate (t - t0)^2 / (2 speed0)        (the phase time),

the time at the constant speed ``speed0`` with the same phase.  The driver calls the
generated functions at ``s(t) = theta(t) / Omega(t)`` with ``p[index] = Omega(t)`` and runs
the schedules on ``tau(t)`` (their breakpoints are the roots of a quadratic); see
``gs_ramp.c``.  The closed forms below are the same formulas in numpy, for the analysis
(sampling in the angle domain, the speed at the output times).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import EngineInputError

__all__ = ["SpeedRamp"]


@dataclass(frozen=True)
class SpeedRamp:
    """A linear ramp of the speed parameter ``p[index]`` (SI values, the engine's time unit).

    Parameters
    ----------
    index
        The speed's index in the parameter vector.
    speed0
        The speed at ``t0`` (nonzero).
    rate
        ``d Omega / dt``.
    t0
        Start of the ramp (``tau(t0) = t0``: a run at constant ``speed0`` before ``t0`` joins
        it with the same phase).

    Raises
    ------
    EngineInputError
        A non-finite value or ``speed0 = 0``.
    """

    index: int
    speed0: float
    rate: float
    t0: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed0) and math.isfinite(self.rate) and math.isfinite(self.t0)) \
                or self.speed0 == 0.0 or self.index < 0:
            raise EngineInputError(f"bad speed ramp: index {self.index}, speed0 {self.speed0}, rate {self.rate}, "
                                   f"t0 {self.t0} (finite values, speed0 nonzero)")

    def speed(self, t: np.ndarray | float) -> np.ndarray:
        """``Omega(t)``."""
        return self.speed0 + self.rate * (np.asarray(t, float) - self.t0)

    def phase_time(self, t: np.ndarray | float) -> np.ndarray:
        """``tau(t) = t + rate (t - t0)^2 / (2 speed0)``."""
        d = np.asarray(t, float) - self.t0
        return np.asarray(t, float) + 0.5 * (self.rate / self.speed0) * d * d

    def time_at_phase(self, tau: np.ndarray | float) -> np.ndarray:
        """The inverse of :meth:`phase_time` on the branch where the speed keeps the sign of
        ``speed0`` (NaN where the speed would have to pass zero)."""
        D = np.asarray(tau, float) - self.t0
        q = 1.0 + 2.0 * (self.rate / self.speed0) * D
        with np.errstate(invalid="ignore"):
            return np.where(q >= 0, self.t0 + 2.0 * D / (1.0 + np.sqrt(np.maximum(q, 0.0))), np.nan)
