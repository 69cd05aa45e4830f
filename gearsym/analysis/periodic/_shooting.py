"""Shooting: periodic orbits by damped Newton on ``phi(t0 + P, t0, x0) - x0``.

Single shooting integrates one orbit period ``P`` (``periods`` forcing periods)
with the variational equations in the C engine, which returns the monodromy
``M = d phi / d x0`` including the saltation matrices at every crossing of a
switching surface where the vector field jumps (e.g. mesh damping acting only in
contact); the Newton matrix is ``M - I``.

Multiple shooting splits the period into ``segments`` pieces
``t0 = s_0 < s_1 < ... < s_N = t0 + P``; the unknowns are the states ``X_i`` at
``s_i`` and the residuals ``phi(s_{i+1}, s_i, X_i) - X_{i+1}`` (cyclically,
``X_N = X_0``).  The monodromy is the product of the segment monodromies, which
keeps the Floquet multipliers accurate for long periods (each segment's
variational equations start from the identity, so the integrator's tolerance is
relative to each segment's growth, not to the whole period's).

The Newton step is damped (halved until the residual norm decreases; a failed
integration also halves it); when no step helps or the iteration budget is spent
a :class:`~gearsym.errors.ConvergenceError` reports the residual history, the
last iterate and what to try.  For implicit (IDA) models the monodromy comes from
IDA's variational equations; with algebraic variables the unknowns include them (their
columns of the monodromy are 0, so ``M - I`` stays regular) and the Floquet multipliers
are those of the differential block (:func:`~gearsym.analysis.periodic._orbit.finish_orbit`).

Honest results: the Newton step is the minimum-norm solution with the directions
that the monodromy cannot resolve dropped (:func:`~gearsym.analysis.periodic._isolation.truncated_solve`:
singular values of the scaled ``M - I`` below its error level), so the state is never
moved by noise divided by noise; an orbit whose ``M - I`` is singular to working
precision outside the known trivial directions (``trivial=``) and whose residual
cannot be removed is reported as "no isolated periodic orbit: a Floquet multiplier at
+1" (the undamped oscillator at exact resonance has no periodic orbit).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_shooting
from ...engine.shoot import MAX_STATES, shoot_in_c
from ...errors import ConvergenceError, GearsymError, ParameterError
from ...integrators import default_method, supports_c_shooting
from .._options import check_tolerances, resolve_options
from ._floquet import monodromy_product
from ._isolation import Isolation, isolation, monodromy_error, truncated_solve
from ._newton import NewtonPolicy, damped_newton
from ._options import ShootingOptions
from ._orbit import PeriodicOrbit, SolvedOrbit, finish_orbit
from ._problems import flow_events, log_events, segment_jacobian, segment_times
from ._stability import rigid_state_basis
from ._verification import orbit_period, segment_closure

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["shoot"]

_log = logging.getLogger(__name__)


def shoot(system: CompiledSystem, period: float | None = None, periods: float = 1,
          x0: Sequence[float] | None = None, params: Mapping[str, float] | None = None, *,
          options: ShootingOptions | None = None, **keywords: Any) -> PeriodicOrbit:
    """Find a periodic orbit by (multiple) shooting with damped Newton.

    Parameters
    ----------
    system
        The compiled system.
    period
        Orbit period; default ``periods`` forcing periods.
    periods
        Number of forcing periods of the orbit (period-``k`` orbit): a positive whole number
        (a state that returns after a fraction of a forcing period is no periodic orbit of a
        forced system; ``period``, when given, must be a whole number of forcing periods).
    x0
        Initial guess of the state at ``t0``.  Default: the scene's initial state
        after ``transient`` periods.
    params
        Parameter overrides (declared units, as ``--set``).
    options
        The settings (:class:`~gearsym.analysis.periodic.ShootingOptions`: ``segments``,
        ``t0``, ``transient``, ``tol``, ``rtol``, ``atol``, ``max_iter``, ``min_step``,
        ``raise_on_failure``, ``method``, ``relax_periods``, ``trivial``; each documented
        there with its default).
    **keywords
        Any of those settings one by one (``shoot(system, rtol=1e-9)``); a keyword wins over
        ``options``.

    Returns
    -------
    PeriodicOrbit
        Verified before it is returned: one integration over its period without the
        variational equations must close (:mod:`gearsym.analysis.periodic._verification`;
        ``info["verification"]``).

    Raises
    ------
    ParameterError
        ``periods`` not a positive whole number (or ``period`` not a whole number of forcing
        periods), bad options, a keyword that is no setting of
        :class:`~gearsym.analysis.periodic.ShootingOptions`.
    ConvergenceError
        Newton did not converge (message: residual history, last iterate, advice), the
        converged state failed its verification, or there is no isolated orbit (a multiplier at +1 to working precision and a
        residual that no step can remove: e.g. an undamped system forced at resonance).
    SimulationError
        The first integration already fails.
    """
    wall = time.perf_counter()
    o = resolve_options(options, ShootingOptions, keywords, "shoot")
    check_tolerances(tol=o.tol, rtol=o.rtol, atol=o.atol)
    period, periods = orbit_period(system, params, period, periods)  # a whole number of forcing periods
    problem = ShootingProblem(system, params, o, period, periods)
    X = problem.initial_states(x0)
    newton = problem.solve(X)
    verdict = problem.judge(newton)
    if not verdict.converged and o.raise_on_failure:
        raise problem.failure_error(newton, verdict)
    wall = time.perf_counter() - wall
    orbit = finish_orbit(system, SolvedOrbit(
        x0=newton.X[0].copy(), period=period, periods=periods, t0=o.t0, monodromy=verdict.monodromy,
        iterations=newton.iterations, residual=newton.residual, converged=verdict.converged, method="shooting",
        params=system.run_params(params), events=newton.events,
        multipliers=newton.fast.multipliers if newton.fast is not None else None,
        g0=newton.fast.g0 if newton.fast is not None else None),
        segments=problem.segments, segment_states=newton.X.copy(),
        segment_monodromies=[np.asarray(M) for M in newton.monodromies if M is not None], history=problem.history,
        info={"rtol": o.rtol, "atol": o.atol, "tol": o.tol, "wall_s": wall, "failure": verdict.failure or None,
              "newton": problem.newton_engine,
              "monodromy_rtol": max(o.rtol / 1e-6, 1e-12) if system.generated.implicit else o.rtol,
              "rigid_anchor": problem.anchor is not None,
              "relative_residual": newton.relative_residual, "state_scales": problem.scale.tolist(),
              "isolation": verdict.isolation.to_dict() if verdict.isolation is not None else None})
    return _verified(orbit, problem.s, problem.pvec, method=o.method, max_step=problem.max_step,
                     raise_on_failure=o.raise_on_failure)


@dataclass
class NewtonRun:
    """Where the shooting Newton iteration ended (:meth:`ShootingProblem.solve`).

    Attributes
    ----------
    X : ndarray
        The segment start states, shape ``(segments, nx)``.
    monodromies : list of ndarray or None
        The segment monodromies at ``X``.
    events : list of Event
        The events of the last integration.
    iterations : int
        Newton steps (C and Python).
    converged : bool
        Whether the residual met the tolerance.
    residual, relative_residual : float
        ``max |R|`` and ``max |R_i| / s_i``.
    failure : str
        Why not (empty when converged).
    fast : ShootOutcome or None
        The C iteration's outcome where it converged (its multipliers, isolation, ``g0``).
    """

    X: np.ndarray
    monodromies: list[np.ndarray | None]
    events: list[Any]
    iterations: int
    converged: bool
    residual: float
    relative_residual: float
    failure: str = ""
    fast: Any = None


@dataclass
class ShootingVerdict:
    """The orbit's judgement after Newton (:meth:`ShootingProblem.judge`).

    Attributes
    ----------
    monodromy : ndarray or None
        The product of the segment monodromies.
    isolation : Isolation or None
        Whether the monodromy pins the orbit down.
    converged : bool
        Newton's answer, withdrawn where the orbit is not isolated.
    spurious : bool
        Newton converged, but along a direction the monodromy does not determine.
    failure : str
        Why the orbit is not reported as converged.
    """

    monodromy: np.ndarray | None
    isolation: Isolation | None
    converged: bool
    spurious: bool
    failure: str


@dataclass(eq=False)
class ShootingProblem:
    """The (multiple) shooting problem of one :func:`shoot` call (in the style of
    BifurcationKit's ``ShootingProblem``): one object called for the residual and its Jacobian
    (:meth:`evaluate`), the Newton step (:meth:`direction`), the convergence test
    (:meth:`converged`) and the relaxation by integration where Newton stalls (:meth:`stalled`);
    :meth:`solve` runs the damped Newton iteration (the C iteration first where it applies),
    :meth:`judge` decides what the monodromy says about the result.

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units).
    options
        The resolved settings.
    period, periods
        The orbit period and its number of forcing periods.
    """

    system: CompiledSystem
    params: Mapping[str, float] | None
    options: ShootingOptions
    period: float
    periods: float
    history: list[dict[str, Any]] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        system, o = self.system, self.options
        #: where the Newton iteration ran: ``"C"``, ``"C, then Python"`` (the C iteration gave up and
        #: the Python one resumed) or ``"Python: <why not C>"`` (:meth:`solve`)
        self.newton_engine = ""
        T = system.period(self.params)
        self.segments = segments = int(o.segments)
        if segments < 1:
            raise ParameterError(f"segments must be >= 1, got {segments}")
        self.nx = nx = system.generated.nx
        check_shooting(segments, nx)  # the (segments nx)^2 Jacobian within the budget (gearsym.budget)
        self.forcing_period = T if T else self.period
        self.s = segment_times(o.t0, self.period, segments)
        self.n_amp = max(3, int(math.ceil(16 / segments)) + 1)
        self.pvec = system.param_vector(self.params)
        self.max_step = T / 8 if T else 0.0  # System.flow's default, computed once
        self.scale = np.ones(nx)  # the per-state scales of the last evaluation
        self.anchor = _anchor_rows(system, self.params, segments)
        self.relaxed = 0  # forcing periods of relaxation by integration so far
        self.relax_block = max(1, int(math.ceil(10 * max(1.0, float(self.periods)))))
        self.it_offset = 0  # Newton steps the C iteration took before the Python one resumed

    # ------------------------------------------------------------ states
    def initial_states(self, x0: Sequence[float] | None) -> np.ndarray:
        """The segment start states of the first Newton iterate: ``x0`` (default the scene's
        initial state) after the transient, integrated to the segment times."""
        system, o = self.system, self.options
        guess = system.x0 if x0 is None else np.asarray(x0, float)
        if guess.shape != (self.nx,):
            raise ParameterError(f"x0 must have {self.nx} entries ({', '.join(system.state_names)}), "
                                 f"got {guess.shape}")
        transient = o.transient
        if transient is None:
            transient = 0 if x0 is not None else float(system.defaults.get("transient_periods", 20))
        if transient and transient > 0:
            guess = self._integrate_periods(guess, max(1, int(math.ceil(transient))))
        return self._spread(guess)

    def _integrate_periods(self, x: np.ndarray, n_periods: int) -> np.ndarray:
        """The state at ``t0`` after ``n_periods`` forcing periods from ``x``."""
        o = self.options
        tr = self.system.simulate(t_end=self.s[0], t0=self.s[0] - n_periods * self.forcing_period, x0=x,
                                  rtol=max(o.rtol, 1e-9), atol=max(o.atol, 1e-11), n_out=2, params=self.params,
                                  method=o.method)
        return tr.x_final

    def _spread(self, x: np.ndarray) -> np.ndarray:
        """The segment start states of the trajectory from ``x`` at ``t0``."""
        if self.segments == 1:
            return x[None, :].copy()
        o = self.options
        tr = self.system.simulate(t_end=self.s[-1], t0=self.s[0], x0=x, rtol=max(o.rtol, 1e-9),
                                  atol=max(o.atol, 1e-11), t_out=self.s, params=self.params, method=o.method)
        return np.array(tr.y[:-1], float)

    # ------------------------------------------------------------ residual
    def segment_flow(self, i: int, x: np.ndarray, jac: bool) -> tuple[np.ndarray, np.ndarray | None, list, np.ndarray]:
        """``phi(s_{i+1}, s_i, x)``, its Jacobian, the events on the way and ``max |x_j(t)|``.

        One call of :meth:`gearsym.system.CompiledSystem.flow` (the engine's cheap path: no
        output grid, no trajectory object).  The Jacobian is the engine's variational
        monodromy, or for an implicit model without one, central finite differences with step
        ``1e-6 max(1, |x_j|)``; the amplitude over ``n_amp`` evenly spaced points.
        """
        system, o = self.system, self.options
        t0, t1 = self.s[i], self.s[i + 1]
        fl = system.flow(x, t0, t1, self.pvec, rtol=o.rtol, atol=o.atol, monodromy=bool(jac),
                         method=o.method, n_samples=self.n_amp, max_step=self.max_step)
        M = fl.monodromy  # the engine's variational equations, where it has them
        if jac and system.generated.implicit and M is None:
            n = len(x)
            M = np.empty((n, n))
            for j in range(n):
                h = 1e-6 * max(1.0, abs(x[j]))
                e = np.zeros(n)
                e[j] = h
                xp = system.flow(x + e, t0, t1, self.pvec, rtol=o.rtol, atol=o.atol, monodromy=False,
                                 method=o.method).x_final
                xm = system.flow(x - e, t0, t1, self.pvec, rtol=o.rtol, atol=o.atol, monodromy=False,
                                 method=o.method).x_final
                M[:, j] = (xp - xm) / (2 * h)
        return np.asarray(fl.x_final, float), M, flow_events(system, fl), fl.amplitude

    def evaluate(self, X: np.ndarray, jac: bool = True) -> tuple[np.ndarray, list, list]:
        """The residual ``R_i = phi(s_{i+1}, s_i, X_i) - X_{i+1}`` (shape ``(segments, nx)``), the
        segment monodromies (``jac``) and the events; updates the per-state scales."""
        segments, nx, o = self.segments, self.nx, self.options
        xs, Ms, evs = [], [], []
        a = np.zeros(nx)
        for i in range(segments):
            xe, M, ev, ai = self.segment_flow(i, np.asarray(X[i], float), jac)
            xs.append(xe)
            Ms.append(M)
            evs.extend(ev)
            a = np.maximum(a, ai)
        # per-state scale: the largest |x_i| along the current trajectory (states in
        # different units, e.g. m and m/s, each get a relative tolerance)
        # (floor atol/tol: a residual below the integrator's atol always counts as
        # converged, e.g. for the trivial orbit x = 0 of a homogeneous linear system)
        top = float(a.max()) if a.size else 0.0
        self.scale = np.maximum(a, max(1e-9 * top, o.atol / o.tol)) if math.isfinite(top) else np.ones(nx)
        R = xs[0] - X[1 % segments] if segments == 1 else np.array(
            [xs[i] - X[(i + 1) % segments] for i in range(segments)])
        return R.reshape(segments, nx), Ms, evs

    def rel(self, A: np.ndarray) -> float:
        """``max |A_i| / s_i`` with the per-state scales of the last evaluation."""
        return float((np.abs(A) / self.scale).max())

    @staticmethod
    def norm(ev: tuple) -> float:
        """``max |R|`` of an evaluation."""
        return float(np.max(np.abs(ev[0])))

    # ------------------------------------------------------------ Newton
    def converged(self, ev: tuple, size: float, damping: float) -> str | None:
        """The convergence note (``""``: within tolerance), or ``None`` while not converged."""
        tol = self.options.tol
        r = self.rel(ev[0])
        if r <= tol:
            return ""
        if damping == 1.0 and size <= tol and r <= 100 * tol:
            # a full Newton step below the tolerance: the residual left is integration noise
            return "Newton step below tolerance (residual at the integration noise level)"
        if damping == 0.0 and size <= 10 * tol and r <= 100 * tol:
            # the next step is below 10 tol: taken without integrating again (its effect on the
            # residual is quadratic in its size, ~1e-18 here)
            return "Newton step below 10 tol applied without another integration"
        return None

    def direction(self, X: np.ndarray, ev: tuple) -> tuple[np.ndarray, float, dict[str, Any]]:
        """The Newton step, its scaled size and notes (the directions dropped)."""
        R, Ms, _ = ev
        J = segment_jacobian(Ms)
        rhs = -R.ravel()
        if self.anchor is not None:
            # a rigid-body mode makes J singular (a Jordan block of M at +1): keep the rigid
            # coordinates of the first segment where they are (anchor rows), least squares
            dz = np.linalg.lstsq(np.vstack([J, self.anchor]), np.concatenate([rhs, np.zeros(len(self.anchor))]),
                                 rcond=None)[0]
            n_drop = 0
        else:
            # minimum-norm step without the directions the monodromy cannot resolve: never move
            # the state by noise divided by noise (a multiplier at +1 to working precision)
            dz, n_drop = truncated_solve(J, rhs, np.tile(self.scale, self.segments), self.options.rtol)
        dX = dz.reshape(self.segments, self.nx)
        return dX, self.rel(dX) if np.all(np.isfinite(dX)) else math.inf, (
            {"dropped_directions": n_drop} if n_drop else {})

    def on_step(self, it: int, ev: tuple, damping: float, notes: dict[str, Any]) -> None:
        """Record an accepted Newton step."""
        self.history.append({"iteration": it + self.it_offset, "residual": self.norm(ev), "relative": self.rel(ev[0]),
                             "step": damping, **notes})

    def stalled(self, X: np.ndarray, ev: tuple, dX: np.ndarray, last_err: str) -> tuple[str, Any]:
        """No damped step reduces the residual: the noise floor (converged), relaxation by
        integration (restart from there) or failure."""
        o = self.options
        # at the integration noise floor a tiny Newton step cannot reduce the residual any more
        if self.rel(dX) <= 10 * o.tol and self.rel(ev[0]) <= 100 * o.tol:
            self.history.append({"iteration": len(self.history), "residual": self.norm(ev), "step": 0.0,
                                 "note": "noise floor: Newton step below tolerance"})
            return "converged", "noise floor"
        if self.relaxed < o.relax_periods:
            # Newton is stuck in a local minimum of the residual (the flow map of a
            # nonsmooth system is far from linear over large distances): integrate
            # a block of forcing periods (contracts towards an attracting orbit),
            # then resume Newton from there
            n_blk = int(min(self.relax_block, o.relax_periods - self.relaxed))
            try:
                Xr = self._spread(self._integrate_periods(X[0], n_blk))
                evr = self.evaluate(Xr)
            except GearsymError as exc:
                return "fail", f"relaxation by integration failed: {exc}"
            self.relaxed += n_blk
            self.history.append({"iteration": len(self.history), "residual": self.norm(evr),
                                 "relative": self.rel(evr[0]), "step": None,
                                 "note": f"Newton stalled: integrated {n_blk} forcing periods"})
            return "restart", (Xr, evr)
        return "fail", ("the damped Newton step does not reduce the residual (tried down to a factor "
                        f"{o.min_step:g}, after {self.relaxed} forcing periods of relaxation by integration)"
                        + (f"; last integration error: {last_err}" if last_err else ""))

    def solve(self, X: np.ndarray) -> NewtonRun:
        """Damped Newton from ``X``: the full-step iteration in one C call where it applies
        (single shooting without rigid-body anchors); where it gives up (damping, a nearly
        singular step, ...) the Python iteration resumes from its last accepted iterate (the
        steps before are the ones it would have taken itself)."""
        fast = None
        if self.segments > 1:
            self.newton_engine = "Python: multiple shooting"
        elif self.anchor is not None:
            self.newton_engine = "Python: rigid-body anchor rows"
        else:
            o = self.options
            fast = _newton_in_c(self.system, X[0], self.s[0], self.s[1], self.pvec, rtol=o.rtol, atol=o.atol,
                                tol=o.tol, max_iter=o.max_iter, method=o.method, max_step=self.max_step,
                                n_amp=self.n_amp)
            if fast is None or isinstance(fast, str):
                self.newton_engine, fast = f"Python: {fast or 'the C iteration does not apply'}", None
            else:
                self.newton_engine = "C" if fast.converged else "C, then Python"
        (_log.debug if self.newton_engine == "C" else _log.info)("shooting Newton: %s", self.newton_engine)
        if fast is not None and not fast.converged:
            if fast.code in (1, 2, 3, 4) and fast.iterations >= 1:
                X = fast.x[None, :].copy()
                self._c_history(fast, fast.iterations + 1, engine_each=True)
                self.it_offset = fast.iterations
            fast = None
        if fast is not None:
            return self._converged_in_c(fast)
        return self._python_newton(X)

    def _c_history(self, fast: Any, n: int, engine_each: bool) -> None:
        self.history.extend({"iteration": i, "residual": float(fast.history_abs[i]),
                             "relative": float(fast.history_rel[i]), "step": None if i == 0 else 1.0,
                             **({"engine": "C"} if engine_each else {})} for i in range(n))

    def _converged_in_c(self, fast: Any) -> NewtonRun:
        ev_log = fast.events
        evs = log_events(self.system, ev_log.t, ev_log.surface, ev_log.direction)
        note = _C_NOTES[fast.note]
        self.scale = fast.scale
        self._c_history(fast, len(fast.history_abs), engine_each=False)
        if note:
            self.history[-1]["note"] = note
        self.history[-1]["engine"] = "C"
        return NewtonRun(fast.x[None, :].copy(), [fast.monodromy], evs, fast.iterations, True,
                         float(fast.history_abs[-1]), float(fast.history_rel[-1]), fast=fast)

    def _python_newton(self, X: np.ndarray) -> NewtonRun:
        o = self.options
        ev0 = self.evaluate(X)
        if not self.it_offset:
            self.history.append({"iteration": 0, "residual": self.norm(ev0), "relative": self.rel(ev0[0]),
                                 "step": None})
        out = damped_newton(X, ev0, evaluate=self.evaluate, norm=self.norm, direction=self.direction,
                            converged=self.converged,
                            policy=NewtonPolicy(max_iter=o.max_iter - self.it_offset, min_damping=o.min_step,
                                                apply_final_step=True),
                            stalled=self.stalled, on_step=self.on_step)
        R, Ms, evs = out.ev
        failure = ""
        if out.converged and out.note and self.history[-1].get("note") is None and out.note != "noise floor":
            self.history[-1]["note"] = out.note
        if not out.converged:
            failure = (f"no convergence in max_iter={o.max_iter} Newton iterations" if out.failure == "max_iter"
                       else out.failure)
        return NewtonRun(out.x, Ms, evs, out.iterations + self.it_offset, out.converged, self.norm(out.ev),
                         self.rel(R), failure)

    # ------------------------------------------------------------ the result
    def judge(self, run: NewtonRun) -> ShootingVerdict:
        """The monodromy of the result and whether it pins the orbit down: a residual below tol
        is no orbit where the monodromy cannot (at an undamped resonance Newton can "converge"
        at a huge amplitude, on the periodic orbit of the integrator's own numerical damping)."""
        Ms, fast, rtol = run.monodromies, run.fast, self.options.rtol
        mono = monodromy_product(Ms) if all(M is not None for M in Ms) else None
        iso: Isolation | None = None
        trivial = self.options.trivial
        if trivial is None:  # the model's rigid-body subspace, found by the symbolic layer
            trivial = rigid_state_basis(self.system, self.params)
        if mono is not None and trivial is None and fast is not None and fast.isolation is not None:
            # computed by the driver, in the same scales (it also found the monodromy finite)
            sigma, norm_s, direction = fast.isolation
            threshold = monodromy_error(norm_s, rtol)
            iso = Isolation(sigma, threshold, sigma > threshold, direction, 0)
        elif mono is not None and np.isfinite(mono).all():
            iso = isolation(mono, self.scale, rtol, trivial)
        converged, failure = run.converged, run.failure
        spurious = converged and iso is not None and not iso.isolated
        if spurious:
            converged = False
            failure = (f"the residual fell below tol at max |x0| = {float(np.max(np.abs(run.X[0]))):.3g}, but "
                       f"along a direction the monodromy does not determine")
        verdict = ShootingVerdict(mono, iso, converged, spurious, failure)
        if not converged and not self.options.raise_on_failure and iso is not None and not iso.isolated:
            verdict.failure = f"{iso.reason()}; {failure}"
        return verdict

    def failure_error(self, run: NewtonRun, verdict: ShootingVerdict) -> ConvergenceError:
        """The error of a shooting that did not converge (residual history, advice)."""
        hist = ", ".join(f"{h['residual']:.3g}" for h in self.history[-12:])
        iso, failure = verdict.isolation, verdict.failure
        period, periods, rtol = self.period, self.periods, self.options.rtol
        if iso is not None and not iso.isolated:
            what = ("the state shooting reached is not an orbit" if verdict.spurious
                    else "shooting cannot remove the residual")
            return ConvergenceError(
                f"{iso.reason()}: {what} of period {period:.6g} ({periods:g} forcing period(s)): {failure}. "
                f"Residual history (max |phi(T,x0)-x0|): [{hist}]. Add damping, move the forcing off the "
                f"resonance, or tighten rtol (now {rtol:g}) if the system is lightly damped.")
        return ConvergenceError(
            f"shooting did not converge for the orbit of period {period:.6g} ({periods:g} forcing "
            f"period(s), {self.segments} segment(s)): {failure}. Residual history (max |phi(T,x0)-x0|): "
            f"[{hist}]; last x0 = {np.array2string(run.X[0], precision=8)}. Try a better initial guess "
            f"(x0=..., or transient=<more periods>), more segments (segments=N) for long or unstable "
            f"orbits, or method='hbm'.")


def _verified(orbit: PeriodicOrbit, times: np.ndarray, p: np.ndarray, *, method: str | None, max_step: float,
              raise_on_failure: bool) -> PeriodicOrbit:
    """A converged orbit after its verification by one plain integration over its period
    (:func:`~gearsym.analysis.periodic._verification.segment_closure`, recorded in ``info["verification"]``):
    unchanged when it passes, else not converged (raised with ``raise_on_failure``)."""
    if not orbit.converged or orbit.system is None:
        return orbit
    info = orbit.info
    c = segment_closure(orbit.system, orbit.segment_states, times, p, rtol=info["rtol"], atol=info["atol"],
                        tol=info["tol"], amplification=orbit.max_multiplier, method=method,
                        max_step=max_step or None, amplitude=np.asarray(info["state_scales"]))
    info["verification"] = c.to_dict()
    if c.ok:
        return orbit
    info["failure"] = failure = c.message(orbit.state_names)
    if raise_on_failure:
        raise ConvergenceError(
            f"shooting converged (residual {orbit.residual:.3g}) on a state that is not a periodic orbit of period "
            f"{orbit.period:.6g} ({orbit.periods:g} forcing period(s)): {failure}. Tighten rtol (now "
            f"{info['rtol']:g}) or the Newton tolerance (tol={info['tol']:g}), or use more segments (segments=N).")
    return dataclasses.replace(orbit, converged=False)


#: the notes of the C iteration's convergence (:class:`gearsym.engine.shoot.ShootOutcome` ``note``)
_C_NOTES = {0: "", 1: "Newton step below tolerance (residual at the integration noise level)",
            2: "Newton step below 10 tol applied without another integration"}


def _newton_in_c(system: CompiledSystem, x: np.ndarray, t0: float, t1: float, pvec: np.ndarray, *, rtol: float, atol: float,
                 tol: float, max_iter: int, method: str | None, max_step: float, n_amp: int) -> Any:
    """The full-step Newton iteration of :func:`shoot` in one C call
    (:func:`gearsym.engine.shoot.shoot_in_c`; its outcome, converged or not), or the reason why
    it does not apply (a method the C iteration does not run: IDA, for implicit and DAE models; a
    build without it; more than :data:`~gearsym.engine.shoot.MAX_STATES` states)."""
    gen = system.generated
    method = method or default_method(gen.implicit, system.defaults.get("method"))
    if not supports_c_shooting(method):
        return f"method '{method}' (the C iteration runs only the methods of the registry that allow it)"
    if gen.nx > MAX_STATES:
        return f"more than {MAX_STATES} states"
    if not hasattr(system.engine._lib, "gs_shoot_ws"):
        return "the build has no C iteration"
    max_steps = int(system.defaults.get("max_steps", 0))
    if max_step and (t1 - t0) / max_step > (max_steps or 10_000_000):
        return "the step budget"  # the Python path raises the step-budget error
    n = max(int(n_amp), 2)
    grid = _steps(n) * ((t1 - t0) / (n - 1)) + t0  # np.linspace(t0, t1, n)'s arithmetic
    grid[-1] = t1
    # the Python step drops singular values of the scaled M - I below monodromy_error; give up
    # when a pivot gets within a factor 10 of that level (a stricter factor, 1e3, sent
    # lightly damped 48- and 130-state models to the Python iteration after a wasted C one)
    pivot_tol = 10 * monodromy_error(1.0, rtol)
    out = shoot_in_c(system.engine, x, pvec, t0, t1, grid, method=method, rtol=rtol, atol=atol,
                     max_step=max_step, max_steps=max_steps, tol=tol, scale_floor=atol / tol,
                     pivot_tol=pivot_tol, max_iter=max_iter, want_run=False)
    return out


@functools.lru_cache(maxsize=64)
def _steps(n: int) -> np.ndarray:
    """``0, 1, ..., n - 1`` (read-only, shared)."""
    a = np.arange(n, dtype=float)
    a.flags.writeable = False
    return a


def _anchor_rows(system: CompiledSystem, params: Mapping[str, float] | None, segments: int) -> np.ndarray | None:
    """Rows ``[R^T 0 ... 0]`` that pin the rigid-body coordinates of the first segment's
    state in a Newton step (``None`` without rigid-body modes)."""
    V = rigid_state_basis(system, params)
    if V is None:
        return None
    k = V.shape[1] // 2
    Pq = V[:, :k]
    Pq = Pq / np.linalg.norm(Pq, axis=0)
    out = np.zeros((k, segments * Pq.shape[0]))
    out[:, : Pq.shape[0]] = Pq.T
    return out
