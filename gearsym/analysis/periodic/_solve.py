"""The entry point of periodic-orbit solves: :func:`periodic_orbit`.

:meth:`gearsym.System.periodic_orbit` delegates here; the function dispatches
to :func:`~gearsym.analysis.periodic.shoot` (single / multiple shooting with the engine's
variational equations) or :func:`~gearsym.analysis.periodic.harmonic_balance` (harmonic balance
with alternating frequency/time), both of which return a
:class:`~gearsym.analysis.periodic.PeriodicOrbit`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ...errors import ParameterError
from ._hbm_driver import harmonic_balance
from ._orbit import PeriodicOrbit
from ._shooting import shoot

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ORBIT_METHODS", "periodic_orbit"]

_log = logging.getLogger(__name__)

#: Periodic-orbit solvers: method name -> what it is.
ORBIT_METHODS: dict[str, str] = {
    "shooting": "single or multiple shooting (segments=N) with the engine's variational monodromy",
    "hbm": "harmonic balance (alternating frequency/time), harmonics=H or grown until converged",
}


def periodic_orbit(system: CompiledSystem, period: float | None = None, periods: float = 1,
                   x0: Sequence[float] | None = None, method: str = "shooting",
                   params: Mapping[str, float] | None = None, **options: Any) -> PeriodicOrbit:
    """Find a periodic orbit of a compiled system.

    Parameters
    ----------
    system
        The compiled system.
    period
        Period of the orbit; default ``periods`` times the forcing period.
    periods
        Number of forcing periods the orbit spans (``k`` for a period-``k`` orbit): a positive
        whole number (:func:`gearsym.analysis.periodic.orbit_period`).
    x0
        Initial guess of the state at ``t0`` (shooting) or the starting point of
        the harmonic balance's initial guess; default: the scene's initial state
        after a transient (shooting) / a harmonic-balance continuation in the
        number of harmonics (hbm).
    method
        ``"shooting"`` (single or multiple shooting, ``segments=N``) or ``"hbm"``
        (harmonic balance, ``harmonics=H`` or grown until converged).
    params
        Parameter overrides (declared units, as ``--set``; ``b_m=50`` is 50 um if the model
        declares ``unit = "um"``).
    **options
        Passed on to :func:`gearsym.analysis.periodic.shoot` or
        :func:`gearsym.analysis.periodic.harmonic_balance`: their settings one by one, or
        ``options=`` a :class:`~gearsym.analysis.periodic.ShootingOptions` /
        :class:`~gearsym.analysis.periodic.HarmonicBalanceOptions`.

    Returns
    -------
    PeriodicOrbit
        Verified by one more integration over its period before it is returned
        (``info["verification"]``; :mod:`gearsym.analysis.periodic._verification`).

    Raises
    ------
    ParameterError
        ``periods`` not a positive whole number, unknown method, bad options.
    ConvergenceError
        No orbit found, or the state found failed its verification.
    """
    if method == "shooting":
        orbit = shoot(system, period=period, periods=periods, x0=x0, params=params, **options)
    elif method == "hbm":
        orbit = harmonic_balance(system, period=period, periods=periods, x0=x0, params=params, **options)
    else:
        raise ParameterError(f"method must be one of {', '.join(ORBIT_METHODS)}, got '{method}'")
    _log.info("periodic orbit (%s, period %.6g): %d iterations, residual %.2g, max |multiplier| %.6g, %s",
              orbit.method, orbit.period, orbit.iterations, orbit.residual, orbit.max_multiplier,
              orbit.stability or ("stable" if orbit.stable else "unstable"))
    return orbit
