"""The period map of a periodic orbit in two run-time parameters: what bifurcation curves are built on.

:class:`OrbitMap` integrates ``x0 -> phi(t0 + P(lambda), t0, x0; lambda)`` (``P = periods * T``,
the forcing period at ``lambda = (lambda_1, lambda_2)``, so a forcing-frequency parameter moves
the end of the period) with, in the same C call,

* the monodromy ``M = d phi / d x0`` from the engine's variational equations with the
  saltation matrices at every event, and
* the exact total derivative ``S = d phi / d lambda`` (two columns) from the engine's
  parameter sensitivities, including the move of the period's end (``span_derivative``).

Where the exact derivative is not available (no build with the parameter derivatives, or an
integration that fails for the sensitivities only, e.g. at a grazing event) ``S`` is a central
difference of the end state (:attr:`OrbitMap.exact_sensitivities` tells which).  The map can
also be integrated over a part of the period (``theta_a`` to ``theta_b``, fractions of ``P``):
the grazing curve splits the period at the touching time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ...errors import CompileError, GearsymError, ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["MapRun", "OrbitMap"]


@dataclass
class MapRun:
    """One integration of (a part of) the period map.

    Attributes
    ----------
    x_end : ndarray
        The state at the end.
    M : ndarray or None
        ``d x_end / d x_start`` (with saltation), when asked for.
    S : ndarray or None
        ``d x_end / d (lambda_1, lambda_2)``, shape (nx, 2), total (the span moves with the
        parameters), when asked for.
    n_events : int
        Surface crossings in the integrated span.
    event_t, event_surface : ndarray
        Their times and surfaces (indices).
    sigma_end : ndarray
        Side of each switching surface at the end.
    samples : ndarray or None
        Evenly spaced samples of the span (``n_samples`` of :meth:`OrbitMap.run`).
    """

    x_end: np.ndarray
    M: np.ndarray | None
    S: np.ndarray | None
    n_events: int
    sigma_end: np.ndarray
    samples: np.ndarray | None = None
    event_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    event_surface: np.ndarray = field(default_factory=lambda: np.zeros(0, int))


class OrbitMap:
    """The period map of ``periods`` forcing periods in the parameters ``(param, param2)``.

    Parameters
    ----------
    system
        The compiled (explicit) system.
    param, param2
        The two run-time parameters (declared units).
    base
        The other parameter overrides (declared units).
    periods
        Forcing periods per orbit.
    t0
        Phase of the orbit's reference state.
    rtol, atol
        Integrator tolerances.
    method
        Integrator (``None``: the scene's).
    fd_rel
        Relative step of the central differences in the parameters (the fallback of ``S``).
    """

    def __init__(self, system: CompiledSystem, param: str, param2: str, base: Mapping[str, float], periods: float,
                 t0: float, rtol: float, atol: float, method: str | None = None, fd_rel: float = 1e-5):
        self.system, self.names = system, (param, param2)
        self.base = {k: float(v) for k, v in base.items() if k not in self.names}
        self.periods, self.t0 = float(periods), float(t0)
        self.rtol, self.atol, self.method = float(rtol), float(atol), method
        self.fd_rel = float(fd_rel)
        self.nx = system.generated.nx
        self.n_integrations = 0
        self._exact: bool | None = None if system.has_derivatives else False
        self._cache: dict[tuple[float, float], tuple[np.ndarray, float, np.ndarray]] = {}

    # ---------------------------------------------------------------- parameters
    def params(self, lam: np.ndarray | tuple[float, float]) -> dict[str, float]:
        """The parameter overrides at ``lam`` (declared units)."""
        return {**self.base, self.names[0]: float(lam[0]), self.names[1]: float(lam[1])}

    def setup(self, lam: np.ndarray | tuple[float, float]) -> tuple[np.ndarray, float, np.ndarray]:
        """``(p, P, dP)``: the parameter vector, the orbit period and ``d P / d lambda`` at ``lam``
        (cached: the correctors ask for a few values many times)."""
        key = (float(lam[0]), float(lam[1]))
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        params = self.params(key)
        p = self.system.param_vector(params)
        T = self.system.period_of(p) or self.system.require_period(params, "bifurcation curves")
        dP = np.zeros(2)
        if self.exact_sensitivities:
            try:
                dP = self.periods * np.asarray(self.system.period_gradient(list(self.names), p, params), float)
            except GearsymError:
                self._exact = False
        if not self.exact_sensitivities:
            dP = np.array([self._fd_period(key, k) for k in range(2)])
        if len(self._cache) > 256:
            self._cache.clear()
        self._cache[key] = out = (p, self.periods * float(T), dP)
        return out

    def period(self, lam: np.ndarray | tuple[float, float]) -> float:
        """The orbit period at ``lam``."""
        return self.setup(lam)[1]

    def step(self, lam: np.ndarray | tuple[float, float], k: int) -> float:
        """The central-difference step of parameter ``k`` at ``lam``."""
        return self.fd_rel * max(abs(float(lam[k])), 1e-3)

    def _fd_period(self, lam: tuple[float, float], k: int) -> float:
        h = self.step(lam, k)
        out = []
        for s in (1.0, -1.0):
            q = list(lam)
            q[k] += s * h
            params = self.params(q)
            out.append(self.system.period_of(self.system.param_vector(params)) or 0.0)
        return self.periods * (out[0] - out[1]) / (2 * h)

    @property
    def exact_sensitivities(self) -> bool:
        """Whether ``S`` comes from the engine's parameter sensitivities (else a central difference)."""
        if self._exact is None:
            try:
                self.system.derivative_engine()
                self._exact = True
            except CompileError:
                self._exact = False
        return bool(self._exact)

    # ---------------------------------------------------------------- integration
    def run(self, x: np.ndarray, lam: np.ndarray, *, monodromy: bool = True, sens: bool = True,
            theta: tuple[float, float] = (0.0, 1.0), sigma0: np.ndarray | None = None,
            n_samples: int = 2) -> MapRun:
        """Integrate from the phase ``theta[0]`` to ``theta[1]`` of the period (fractions of ``P``).

        Parameters
        ----------
        x
            The state at ``t0 + theta[0] P``.
        lam
            ``(lambda_1, lambda_2)``.
        monodromy
            Also the monodromy of the span.
        sens
            Also ``S``, the total derivative of the end state in the two parameters.
        theta
            The span in fractions of the period.
        sigma0
            Side of each switching surface at the start (default: from the state).
        n_samples
            Evenly spaced samples of the span (:attr:`MapRun.samples`).

        Returns
        -------
        MapRun

        Raises
        ------
        SimulationError
            The integration failed.
        """
        lam = np.asarray(lam, float)
        p, P, dP = self.setup(lam)
        ta, tb = self.t0 + theta[0] * P, self.t0 + theta[1] * P
        kw: dict = {"rtol": self.rtol, "atol": self.atol, "monodromy": monodromy, "method": self.method,
                    "max_step": P / self.periods / 8, "n_samples": max(2, int(n_samples))}
        if sigma0 is not None:
            kw["sigma0"] = sigma0
        if sens and self.exact_sensitivities:
            try:
                fl = self.system.flow(x, ta, tb, p, sensitivities=list(self.names),
                                      span_derivative=(tuple(theta[0] * dP), tuple(theta[1] * dP)),
                                      inputs=self.params(lam), **kw)
                self.n_integrations += 1
                return _run_of(fl, fl.sensitivity, n_samples)
            except GearsymError:
                pass  # e.g. a grazing event (infinite event-time derivative): the difference below
        fl = self.system.flow(x, ta, tb, p, **kw)
        self.n_integrations += 1
        S = self._fd_sens(x, lam, theta, sigma0) if sens else None
        return _run_of(fl, S, n_samples)

    def _fd_sens(self, x: np.ndarray, lam: np.ndarray, theta: tuple[float, float],
                 sigma0: np.ndarray | None) -> np.ndarray:
        """``S`` by central differences of the end state (the span moves with the period)."""
        S = np.empty((self.nx, 2))
        for k in range(2):
            h = self.step(lam, k)
            ends = []
            for s in (1.0, -1.0):
                q = lam.copy()
                q[k] += s * h
                p, P, _ = self.setup(q)
                kw = {} if sigma0 is None else {"sigma0": sigma0}
                fl = self.system.flow(x, self.t0 + theta[0] * P, self.t0 + theta[1] * P, p, rtol=self.rtol,
                                      atol=self.atol, monodromy=False, method=self.method,
                                      max_step=P / self.periods / 8, **kw)
                self.n_integrations += 1
                ends.append(fl.x_final)
            S[:, k] = (ends[0] - ends[1]) / (2 * h)
        return S

    def monodromy(self, x: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """The monodromy alone (no parameter derivative) at ``(x, lam)``."""
        run = self.run(x, lam, monodromy=True, sens=False)
        assert run.M is not None
        return run.M


def _run_of(fl, S: np.ndarray | None, n_samples: int) -> MapRun:
    return MapRun(x_end=np.asarray(fl.x_final, float), M=None if fl.monodromy is None else np.asarray(fl.monodromy),
                  S=None if S is None else np.asarray(S, float), n_events=len(fl.event_t),
                  sigma_end=np.asarray(fl.sigma_final), samples=fl.samples if n_samples > 2 else None,
                  event_t=np.asarray(fl.event_t, float), event_surface=np.asarray(fl.event_surface, int))


def check_params(system: CompiledSystem, param: str, param2: str) -> None:
    """Both names are run-time parameters, and different.

    Raises
    ------
    ParameterError
        Naming the parameter and the ones the system has.
    """
    for flag, name in (("param", param), ("param2", param2)):
        if name not in system.params:
            raise ParameterError(f"{flag} '{name}' is not a run-time parameter of this system (have: "
                                 f"{', '.join(system.params) or 'none'})")
    if param == param2:
        raise ParameterError(f"a bifurcation curve needs two different parameters, got '{param}' twice")
    if system.generated.implicit:
        raise ParameterError("bifurcation curves need an explicit model (variational equations for the monodromy)")


def fd_step(rtol: float) -> float:
    """Relative step of the central differences of the test functions: ``rtol ** (1/3)``, the balance
    of the integration noise (``rtol / h``) and the truncation error (``h ** 2``), within [1e-6, 1e-3]."""
    return min(1e-3, max(1e-6, math.pow(rtol, 1.0 / 3.0)))
