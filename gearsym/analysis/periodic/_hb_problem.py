"""The harmonic-balance periodic-orbit problem of the continuation.

:class:`HBResidual` wraps :class:`gearsym.analysis.periodic.HarmonicBalance` (its residual
and Jacobian at the period of each parameter value) in the
:class:`~gearsym.analysis.periodic.PeriodicOrbitProblem` interface.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError
from ._hbm import HarmonicBalance
from ._hbm_driver import FIXED_HARMONICS_DEFECT, state_sizes
from ._orbit import PeriodicOrbit
from ._problems import Evaluation as _Eval
from ._problems import PeriodicOrbitProblem as _Residual
from ._verification import Closure

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["HBResidual"]


class HBResidual(_Residual):
    """``F(C, lambda)``: the harmonic-balance (AFT) residual with ``H`` harmonics.

    The unknowns are the Fourier coefficients of every state (state-major, as
    :class:`gearsym.analysis.periodic.HarmonicBalance`); the base frequency is
    ``2*pi/P(lambda)``.  The Floquet multipliers of each point come from one
    integration of the variational equations from the series' ``x(t0)``.

    No steps in the parameter itself and no orientation of the tangent by them: those
    multipliers belong to the integrated orbit, not to the truncated balance, whose own
    fold can lie where none of them is near +1.
    """

    natural_steps = False

    def __init__(self, system: CompiledSystem, param: str, harmonics: int, periods: float = 1,
                 params: Mapping[str, float] | None = None, t0: float = 0.0, samples: int | None = None,
                 rtol: float = 1e-10, atol: float = 1e-12, fd_step: float = 1e-6):
        self.system = system
        self.param = param
        self.periods = float(periods)
        self.base_params = dict(params or {})
        self.H = int(harmonics)
        self.samples = samples
        self.t0 = float(t0)
        self.rtol, self.atol = float(rtol), float(atol)
        self.fd_step = float(fd_step)
        self.nx = system.generated.nx
        self.nc = 2 * self.H + 1
        self.n = self.nx * self.nc
        self._cache: dict[float, Any] = {}
        self.n_evals = 0
        self.n_integrations = 0

    def _hb(self, lam: float) -> HarmonicBalance:
        hb = self._cache.get(lam)
        if hb is None:
            if len(self._cache) > 8:
                self._cache.clear()
            hb = HarmonicBalance(self.system, self.period(lam), self.H, self.params(lam), self.t0, self.samples)
            self._cache[lam] = hb
        return hb

    def coefficients(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(u, float).reshape(self.nx, self.nc).T

    def _anchor_index(self) -> list[int]:
        return [i * self.nc for i in range(self.nx)]  # the mean (a0) of every state

    def x0_of(self, u: np.ndarray, lam: float | None = None) -> np.ndarray:
        """The series' state at ``t0`` (a DAE's algebraic variables solved for at ``lam`` when given)."""
        C = self.coefficients(u)
        if lam is not None and self.system.generated.algebraic:
            return self._hb(float(lam)).x_at_t0(C)
        return C[0] + sum(C[2 * k - 1] for k in range(1, self.H + 1)) if self.H else C[0].copy()

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:
        return np.repeat(state_scale, self.nc)

    def u_from_orbit(self, orbit: PeriodicOrbit | np.ndarray, lam: float) -> np.ndarray:
        if isinstance(orbit, PeriodicOrbit) and orbit.coefficients is not None and \
                orbit.coefficients.shape[0] == self.nc:
            return orbit.coefficients.T.ravel().copy()
        x0 = orbit.x0 if isinstance(orbit, PeriodicOrbit) else np.asarray(orbit, float)
        P = self.period(lam)
        n = max(64, 8 * self.H)
        tr = self.system.simulate(t_end=self.t0 + P, t0=self.t0, x0=x0, rtol=self.rtol, atol=self.atol,
                                  n_out=n + 1, params=self.params(lam))
        y = tr.y[:-1]
        Cf = np.fft.rfft(y, axis=0) / n
        C = np.zeros((self.nc, self.nx))
        C[0] = Cf[0].real
        for k in range(1, self.H + 1):
            C[2 * k - 1] = 2 * Cf[k].real
            C[2 * k] = -2 * Cf[k].imag
        return C.T.ravel()

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True) -> _Eval:
        hb = self._hb(lam)
        C = self.coefficients(u)
        R = hb.residual(C).T.ravel()
        self.n_evals += 1
        if not jac:
            return _Eval(R, None, None)
        J = hb.jacobian(C)
        Flam = self._fd_lambda(u, lam, R) if dlam else None
        x0 = self.x0_of(u)
        mono, events, x_end = None, [], None
        try:
            tr = self.system.simulate(t_end=self.t0 + hb.P, t0=self.t0, x0=x0, rtol=self.rtol, atol=self.atol,
                                      n_out=2, params=self.params(lam), monodromy=True)
            self.n_integrations += 1
            mono, events, x_end = tr.monodromy, list(tr.events), np.asarray(tr.x_final, float)
            nd = self.nx - len(self.system.generated.algebraic)
            mono = None if mono is None else mono[:nd, :nd]  # (a DAE: the differential states' multipliers)
        except GearsymError:
            pass
        return _Eval(R, J, Flam, monodromy=mono, events=events, x_end=x_end)

    def closure(self, u: np.ndarray, lam: float, ev: _Eval, ends: np.ndarray | None, Y: np.ndarray,
                scale: np.ndarray, tol: float, amplification: float) -> Closure | None:
        """The time-domain defect of the balance: one period integrated from the series' ``x(t0)``
        (the integration of :meth:`evaluate`, independent of the balance) must close to
        :data:`~gearsym.analysis.periodic._hbm_driver.FIXED_HARMONICS_DEFECT` of every state's peak-to-peak
        on the series (at least ``atol / FIXED_HARMONICS_DEFECT``), as an orbit of harmonic
        balance with fixed harmonics must."""
        how = "integration over one period from the balance's x(t0) (time-domain defect)"
        if ev.x_end is None:
            return Closure(math.inf, math.inf, False, how=how, error="the integration from the balance's x(t0) failed")
        nd = self.nx - len(self.system.generated.algebraic)  # (a DAE: closes in its differential states)
        d = np.abs(ev.x_end - self.x0_of(u))[:nd]
        ratio = d / state_sizes(Y, self.atol / FIXED_HARMONICS_DEFECT)[:nd] / FIXED_HARMONICS_DEFECT
        k = int(np.argmax(ratio))
        return Closure(float(np.max(d)), float(ratio[k]), bool(ratio[k] <= 1.0), k, how=how)

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        P = self.period(lam)
        n = max(64, int(n_per_period * self.periods))
        th = 2 * np.pi * np.arange(n) / n
        C = self.coefficients(u)
        Y = np.tile(C[0], (n, 1))
        for k in range(1, self.H + 1):
            Y += np.outer(np.cos(k * th), C[2 * k - 1]) + np.outer(np.sin(k * th), C[2 * k])
        return self.t0 + th / (2 * np.pi) * P, Y
