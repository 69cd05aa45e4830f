"""Periodic-orbit problems: the residual ``F(u, lambda)`` that continuation drives.

:class:`PeriodicOrbitProblem` is the interface (residual, Jacobian, parameter
derivative, state at ``t0``, dense evaluation); :class:`ShootingResidual` is single
and multiple shooting over the C engine's flow with its variational monodromy;
harmonic balance is :class:`gearsym.analysis.periodic.HBResidual`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import GearsymError, ParameterError
from ...results import Event, Flow
from ._floquet import monodromy_product
from ._parameter_derivative import F_LAMBDA, exact_f_lambda, sensitivity_setup
from ._stability import rigid_anchor_rows, rigid_state_basis
from ._verification import Closure, closure

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["Evaluation", "PeriodicOrbitProblem", "ShootingResidual", "flow_events", "log_events",
           "segment_jacobian", "segment_times"]


@dataclass
class Evaluation:
    """One evaluation of a periodic-orbit problem at ``(u, lambda)``.

    A work record of the solvers (not a result): the corrector fills ``Flam`` in
    when it was not computed with the residual.

    Attributes
    ----------
    R : ndarray
        The residual ``F(u, lambda)``.
    Fu : ndarray or None
        The Jacobian ``dF/du`` (``None`` when not asked for).
    Flam : ndarray or None
        The parameter derivative ``dF/dlambda`` (``None`` when not asked for).
    monodromy : ndarray or None
        The monodromy of the orbit (product of the segment monodromies).
    events : list of Event
        Surface crossings along one period.
    samples : OrbitSamples or None
        The orbit sampled over one period (:class:`gearsym.engine.shoot.OrbitSamples`) when the
        evaluation came with it (the corrector in C), else ``None``.
    tangent : tuple (ndarray, ndarray) or None
        ``(t_ref, t)``: the unnormalised solution ``t`` of ``[J_s; t_ref] t = e_n`` (the
        continuation's tangent along ``t_ref``) when the corrector in C computed it.
    period : float or None
        The forcing period at the point when the evaluation came with it.
    multipliers : tuple or None
        ``(mu, tolerances, delta)`` of the monodromy (as
        :func:`~gearsym.analysis.periodic.multiplier_tolerances`) when the corrector in C
        computed them.
    x_end : ndarray or None
        The state after one period integrated from the point's ``x(t0)`` when the evaluation
        made that integration apart from the residual (harmonic balance): its verification.
    """

    R: np.ndarray
    Fu: np.ndarray | None
    Flam: np.ndarray | None
    monodromy: np.ndarray | None = None
    events: list = field(default_factory=list)
    samples: Any = None
    tangent: tuple[np.ndarray, np.ndarray] | None = None
    period: float | None = None
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None
    x_end: np.ndarray | None = None


class PeriodicOrbitProblem:
    """A periodic-orbit problem ``F(u, lambda) = 0`` in one run-time parameter.

    The interface that shooting (:class:`ShootingResidual`) and harmonic balance
    (:class:`~gearsym.analysis.periodic.HBResidual`) implement and that the
    continuation's predictor-corrector drives: the residual with its Jacobian
    and parameter derivative (:meth:`evaluate`), the state at ``t0`` of the
    unknowns (:meth:`x0_of`), the parameter derivative alone (:meth:`_fd_lambda`,
    the one place where ``F_lambda`` is computed), the orbit on a dense grid
    (:meth:`dense`) and the unknowns of a given orbit (``u_from_orbit``).
    """

    #: steps in the parameter itself where no multiplier is near +1 (see
    #: :mod:`gearsym.analysis.continuation._arclength`)
    natural_steps = True

    system: CompiledSystem
    param: str
    periods: float
    t0: float
    n: int

    def params(self, lam: float) -> dict[str, float]:
        p = dict(self.base_params)
        p[self.param] = float(lam)
        return p

    def pvec(self, lam: float) -> np.ndarray:
        """The parameter vector at ``lambda`` (cached: the corrector asks for a few values many times)."""
        cache = self.__dict__.setdefault("_pvec_cache", {})
        p = cache.get(lam)
        if p is None:
            if len(cache) > 64:
                cache.clear()
            p = cache[lam] = self.system.param_vector(self.params(lam))
        return p

    def period(self, lam: float) -> float:
        cache = self.__dict__.setdefault("_period_cache", {})
        T = cache.get(lam)
        if T is None:
            T = self.system.period_of(self.pvec(lam))
            if not T:
                T = self.system.require_period(self.params(lam), "continuation of periodic orbits")
            if len(cache) > 64:
                cache.clear()
            cache[lam] = T
        return float(self.periods) * T

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True
                 ) -> Evaluation:  # pragma: no cover
        raise NotImplementedError

    def x0_of(self, u: np.ndarray, lam: float | None = None) -> np.ndarray:  # pragma: no cover
        """The state at ``t0`` of the unknowns ``u`` (at ``lambda``: a DAE's algebraic variables
        depend on the parameters)."""
        raise NotImplementedError

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        """``(t, Y)``: the orbit on ``n`` evenly spaced times of one period (end excluded)."""
        raise NotImplementedError  # pragma: no cover

    def dense_ends(self, u: np.ndarray, lam: float, n_per_period: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """:meth:`dense` and the state at the end of every segment of that integration (shape
        (segments, nx)), or ``None`` when the dense orbit is no integration."""
        t, Y = self.dense(u, lam, n_per_period)
        return t, Y, None

    def closure(self, u: np.ndarray, lam: float, ev: Evaluation, ends: np.ndarray | None, Y: np.ndarray,
                scale: np.ndarray, tol: float, amplification: float) -> Closure | None:
        """The verification of a corrected point (:mod:`gearsym.analysis.periodic._verification`) from
        ``ends``, the segment ends of an integration without the variational equations
        (:meth:`dense_ends`, or the corrector's samples), or ``None`` where the problem has none.
        ``Y``: the dense orbit; ``scale``: every state's magnitude on it."""
        return None

    def rigid_basis(self, lam: float) -> np.ndarray | None:
        """The rigid-body subspace of the state at ``lambda`` (``None`` without rigid-body modes)."""
        if not getattr(self.system.generated, "rigid_modes", None):
            return None  # (what rigid_state_basis answers; asked at every branch point)
        return rigid_state_basis(self.system, self.params(lam))

    def anchor_rows(self, lam: float) -> np.ndarray | None:
        """Rows ``(k, n)`` that pin the rigid-body coordinates of the orbit (one per mode):
        without them ``F_u`` is singular along the rigid-body shift
        (:func:`~gearsym.analysis.periodic._stability.rigid_anchor_rows`)."""
        V = self.rigid_basis(lam)
        if V is None:
            return None
        return rigid_anchor_rows(V, self.n, self._anchor_index())

    def _anchor_index(self) -> list[int]:
        """Index in the unknowns of the quantity of each state the anchor acts on."""
        raise NotImplementedError  # pragma: no cover

    def _fd_lambda(self, u: np.ndarray, lam: float, R: np.ndarray | None = None) -> np.ndarray:
        """``dF/dlambda``: exact from the parameter sensitivities where available
        (:mod:`gearsym.analysis.periodic._parameter_derivative`), else a forward difference from
        ``R = F(u, lambda)`` (central without it)."""
        exact = exact_f_lambda(self, u, lam)
        if exact is not None:
            return exact
        h = self.fd_step
        Rp = self.evaluate(u, lam + h, jac=False).R
        if R is not None:
            return (Rp - R) / h
        Rm = self.evaluate(u, lam - h, jac=False).R
        return (Rp - Rm) / (2 * h)


class ShootingResidual(PeriodicOrbitProblem):
    """``F(X, lambda)``: the (multiple) shooting residual of ``periods`` forcing periods.

    The unknowns are the differential states at the segment starts: a DAE's algebraic
    variables are functions of them (index 1), made consistent by the integrator (IDA's
    ``IDACalcIC``) at every segment start, so the residual, its Jacobian (the differential
    block of the monodromy) and ``F_lambda`` are those of the ODE of the differential states,
    and the algebraic variables appear in the states of the orbit (:meth:`x0_of`,
    :meth:`dense`).

    Parameters
    ----------
    system
        The compiled system.
    param
        The continuation parameter (a run-time parameter of ``system``).
    periods
        Forcing periods per orbit.
    params
        Other parameter overrides (declared units, as ``--set``).
    segments
        Shooting segments (1: single shooting); the unknowns are the states at
        the segment starts.
    t0
        Phase of the orbit's reference state.
    rtol, atol
        Integrator tolerances.
    fd_step
        Step of the central difference ``F_lambda``.
    method
        Integrator.
    f_lambda
        ``"exact"`` (default): ``F_lambda`` from the engine's parameter sensitivities where
        they are available, else the finite difference; ``"finite_difference"``: always the
        finite difference (:mod:`gearsym.analysis.periodic._parameter_derivative`).
    """

    def __init__(self, system: CompiledSystem, param: str, periods: float = 1, params: Mapping[str, float] | None = None,
                 segments: int = 1, t0: float = 0.0, rtol: float = 1e-10, atol: float = 1e-12,
                 fd_step: float = 1e-6, method: str | None = None, f_lambda: str = "exact"):
        self.system = system
        self.param = param
        self.periods = float(periods)
        self.base_params = dict(params or {})
        self.segments = int(segments)
        if self.segments < 1:
            raise ParameterError(f"segments must be >= 1, got {segments}")
        self.t0 = float(t0)
        self.rtol, self.atol = float(rtol), float(atol)
        self.fd_step = float(fd_step)
        self.method = method
        if f_lambda not in F_LAMBDA:
            raise ParameterError(f"f_lambda must be one of {', '.join(F_LAMBDA)}, got '{f_lambda}'")
        self.f_lambda = f_lambda
        #: unknowns per segment: the differential states (all states of an ODE)
        self.nx = system.generated.nx - len(system.generated.algebraic)
        self.n = self.segments * self.nx
        self.n_evals = 0
        self.n_integrations = 0
        #: a DAE's algebraic variables at each segment start (the last consistent values: the
        #: start of the integrator's consistent initialisation)
        self._z = np.zeros((self.segments, system.generated.nx - self.nx))

    def times(self, lam: float) -> np.ndarray:
        """Segment boundaries ``t0 = s_0 < ... < s_N = t0 + P(lambda)``."""
        return segment_times(self.t0, self.period(lam), self.segments)

    def x0_of(self, u: np.ndarray, lam: float | None = None) -> np.ndarray:
        """The state at ``t0``; a DAE's algebraic variables solved for at ``lam`` (required then)."""
        x = np.asarray(u[: self.nx], float)
        if not self._z.shape[1]:
            return x
        if lam is None:
            raise ParameterError("the state of a DAE's orbit needs the parameter value (its algebraic variables "
                                 "depend on it)")
        y = self.system.engine.evaluate("dae", [self.t0], np.concatenate([x, self._z[0]])[None, :], self.pvec(lam))
        return np.asarray(y[0, : self.system.generated.nx], float)

    def _anchor_index(self) -> list[int]:
        return list(range(self.nx))  # the states of the first segment

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:
        return np.tile(np.asarray(state_scale, float)[: self.nx], self.segments)

    def u_from_orbit(self, x0: np.ndarray, lam: float) -> np.ndarray:
        """Unknowns (segment start states) of the orbit through ``x0`` (all states)."""
        x0 = np.asarray(x0, float)
        if self.segments == 1:
            Y = x0[None, :]
        else:
            s = self.times(lam)
            tr = self.system.simulate(t_end=s[-1], t0=s[0], x0=x0, rtol=self.rtol, atol=self.atol, t_out=s,
                                      params=self.params(lam), method=self.method)
            Y = np.asarray(tr.y[:-1], float)
        self._z = Y[:, self.nx:].copy()
        return Y[:, : self.nx].ravel().copy()

    def _start(self, i: int, x: np.ndarray) -> np.ndarray:
        """The integration's start of segment ``i`` from its unknowns ``x``: with a DAE's algebraic
        variables appended (their last consistent values)."""
        return np.concatenate([x, self._z[i]]) if self._z.shape[1] else x

    def flam_with_residual(self, lam: float) -> bool:
        """Whether :meth:`evaluate` gets ``F_lambda`` from the residual's own integration (the
        parameter sensitivity as one more variational column: exact and nearly free)."""
        return sensitivity_setup(self, lam) is not None

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True) -> Evaluation:
        """The residual, with ``F_u`` (``jac``) and ``F_lambda`` (``dlam``).

        With both, one integration per segment carries the state, the monodromy and the
        parameter sensitivity when the exact derivative is available
        (:func:`~gearsym.analysis.periodic._parameter_derivative.sensitivity_setup`); where the
        sensitivity cannot be integrated (a grazing event: infinite event-time
        derivative) the segment is integrated again without it and ``F_lambda`` comes
        from :meth:`_fd_lambda`.
        """
        setup = sensitivity_setup(self, lam) if (jac and dlam) else None
        if setup is not None:
            try:
                return self._integrate(u, lam, jac, setup)
            except GearsymError:
                pass  # e.g. a grazing event; the residual alone may still be fine
        ev = self._integrate(u, lam, jac, None)
        if jac and dlam:
            ev.Flam = self._fd_lambda(u, lam, ev.R)
        return ev

    def _integrate(self, u: np.ndarray, lam: float, jac: bool, setup: tuple | None, count: bool = True
                   ) -> Evaluation:
        """One integration per segment: the residual, with the monodromy (``jac``) and the
        parameter sensitivity (``setup`` from :func:`sensitivity_setup`) when asked for;
        ``count``: a residual evaluation (not ``F_lambda`` alone, see :func:`exact_f_lambda`)."""
        N, nx = self.segments, self.nx
        X = np.asarray(u, float).reshape(N, nx)
        s = self.times(lam)
        p = self.pvec(lam)
        max_step = self.period(lam) / self.periods / 8  # System.flow's default (T/8), without asking the engine
        xs, Ms, evs = [], [], []
        Flam = np.empty(N * nx) if setup is not None else None
        for i in range(N):
            sens: dict = {}
            if setup is not None:
                inputs, _, dP = setup
                sens = {"sensitivities": [self.param], "span_derivative": (dP * i / N, dP * (i + 1) / N),
                        "inputs": inputs}
            fl = self.system.flow(self._start(i, X[i]), s[i], s[i + 1], p, rtol=self.rtol, atol=self.atol,
                                  monodromy=jac, method=self.method, max_step=max_step, **sens)
            self.n_integrations += 1
            xs.append(fl.x_final[:nx])
            self._keep_z((i + 1) % N, fl.x_final)
            Ms.append(None if fl.monodromy is None else fl.monodromy[:nx, :nx])  # (a DAE: the differential block)
            evs.extend(flow_events(self.system, fl))
            if Flam is not None:
                Flam[i * nx:(i + 1) * nx] = fl.sensitivity[:nx, 0]
        R = np.concatenate([xs[i] - X[(i + 1) % N] for i in range(N)])
        self.n_evals += int(count)
        if not jac:
            return Evaluation(R, None, Flam, events=evs)
        if any(M is None for M in Ms):
            raise GearsymError(f"the engine returned no monodromy (method '{self.method}')")
        return Evaluation(R, segment_jacobian(Ms), Flam, monodromy=monodromy_product(Ms), events=evs)

    def _keep_z(self, i: int, x: np.ndarray) -> None:
        """Keep the consistent algebraic variables of a segment end for segment ``i``'s next start."""
        if self._z.shape[1] and np.all(np.isfinite(x)):
            self._z[i] = x[self.nx:]

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        t, Y, _ = self.dense_ends(u, lam, n_per_period)
        return t, Y

    def closure(self, u: np.ndarray, lam: float, ev: Evaluation, ends: np.ndarray | None, Y: np.ndarray,
                scale: np.ndarray, tol: float, amplification: float) -> Closure | None:
        """The mismatch of the plain integration's segment ends with the next segments' starts,
        against the integration's error (:func:`~gearsym.analysis.periodic._verification.closure`)."""
        if ends is None:
            return Closure(math.inf, math.inf, False, error="no integration of the orbit without the variational "
                                                           "equations")
        nx = self.nx  # (a DAE: the differential states, which determine the orbit)
        return closure(np.reshape(u, (self.segments, nx)), np.asarray(ends)[:, :nx], np.asarray(scale)[:nx],
                       rtol=self.rtol, atol=self.atol, tol=tol, amplification=amplification)

    def dense_ends(self, u: np.ndarray, lam: float, n_per_period: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        N, nx = self.segments, self.nx
        X = np.asarray(u, float).reshape(N, nx)
        s = self.times(lam)
        p = self.pvec(lam)
        n_seg = max(8, int(math.ceil(n_per_period * self.periods / N)))
        max_step = self.period(lam) / self.periods / 8
        ts, ys = [], []
        ends = np.empty((N, self.system.generated.nx))
        for i in range(N):
            # the flow's samples: the same integration as System.simulate on this grid, without
            # the trajectory object
            fl = self.system.flow(self._start(i, X[i]), s[i], s[i + 1], p, rtol=self.rtol, atol=self.atol,
                                  monodromy=False, method=self.method, max_step=max_step, n_samples=n_seg + 1)
            self.n_integrations += 1
            grid = np.linspace(s[i], s[i + 1], n_seg + 1)
            ts.append(grid[:-1])
            ys.append(fl.samples[:-1])
            ends[i] = fl.x_final
        return np.concatenate(ts), np.vstack(ys), ends




def segment_times(t0: float, P: float, segments: int) -> np.ndarray:
    """Boundaries ``s_0 = t0 < s_1 < ... < s_N = t0 + P`` of ``segments`` equal shooting segments."""
    if segments == 1:
        return np.array([t0, t0 + P])
    s = t0 + P * np.arange(segments + 1) / segments
    s[-1] = t0 + P
    return s


def segment_jacobian(Ms: list[np.ndarray]) -> np.ndarray:
    """Jacobian of the cyclic multiple-shooting residual ``phi_i(X_i) - X_{i+1}``.

    Block row ``i`` holds the segment monodromy ``M_i`` in column ``i`` and ``-I`` in
    column ``i + 1`` (cyclically; ``M_0 - I`` for single shooting).
    """
    N = len(Ms)
    nx = Ms[0].shape[0]
    if N == 1:  # M - I
        J = np.array(Ms[0], float)
        J.flat[::nx + 1] -= 1.0
        return J
    J = np.zeros((N * nx, N * nx))
    eye = np.eye(nx)
    for i in range(N):
        J[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = Ms[i]
        k = (i + 1) % N
        J[i * nx:(i + 1) * nx, k * nx:(k + 1) * nx] -= eye
    return J


def flow_events(system: CompiledSystem, fl: Flow) -> list[Event]:
    """The events of a :class:`~gearsym.results.Flow` as :class:`~gearsym.results.Event` objects."""
    return log_events(system, fl.event_t, fl.event_surface, fl.event_direction)


def log_events(system: CompiledSystem, t: np.ndarray, surface: np.ndarray, direction: np.ndarray) -> list[Event]:
    """Events from the engine's parallel arrays (times, surface indices, directions)."""
    if not len(t):
        return []
    names = system.surface_names
    return [Event(tt, names[j], d) for tt, j, d in zip(np.asarray(t).tolist(), np.asarray(surface).tolist(),
                                                       np.asarray(direction).tolist(), strict=True)]
