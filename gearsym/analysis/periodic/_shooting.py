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

Where each rule lives (``docs/contributing.md``, "Where each numerical rule lives"): the
Newton iteration -- the damped step (halved until the residual decreases; a failed
integration halves it too), the convergence tests on the residual relative to the state
scales (at least ``atol / tol``), the truncated step, the anchor rows' least squares, the
noise floor -- is THE iteration of ``gearsym/engine/gs_newton.c``, and the residual is
evaluated in the same C call (``gs_shoot_ws``: one integration per segment; CVODE, or IDA's
variational equations for implicit models and DAEs, whose unknowns then include the algebraic
variables: their columns of the monodromy are 0, so ``M - I`` stays regular, and the Floquet
multipliers are those of the differential block, :func:`~gearsym.analysis.periodic._orbit.finish_orbit`).
:class:`ShootingProblem` sets the problem up (segment times, anchor rows from
:func:`~gearsym.analysis.periodic._stability.rigid_anchor_rows`, the first iterate), runs the
iteration (:meth:`ShootingProblem.solve`) and, where no damped step reduces the residual, the
relaxation by integration -- a different algorithm, Python's: integrate blocks of forcing
periods (contracting towards an attracting orbit) and restart the same iteration from there.
When the Newton iteration has ended, a :class:`~gearsym.errors.ConvergenceError` reports the
residual history, the last iterate and what to try.

Honest results: the Newton step is the minimum-norm solution with the directions
that the monodromy cannot resolve dropped (singular values of the scaled ``M - I`` below
its error level :func:`~gearsym.analysis.periodic._isolation.monodromy_error`), so the state
is never moved by noise divided by noise; an orbit whose ``M - I`` is singular to working
precision outside the known trivial directions (``trivial=``) and whose residual
cannot be removed is reported as "no isolated periodic orbit: a Floquet multiplier at
+1" (the undamped oscillator at exact resonance has no periodic orbit).
"""


from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_shooting, check_step_budget
from ...engine.newton import EVAL_FAILED, MAX_ITER, NONFINITE, NOTES, SINGULAR, STALLED
from ...engine.shoot import ShootOutcome, ShootSettings, VerifyRuns, shooter_for
from ...errors import ConvergenceError, GearsymError, ParameterError
from ...integrators import default_method
from .._options import check_tolerances, resolve_options
from ._floquet import monodromy_product
from ._isolation import Isolation, isolation, monodromy_error
from ._options import ShootingOptions
from ._orbit import PeriodicOrbit, SolvedOrbit, finish_orbit
from ._problems import log_events, segment_times
from ._stability import rigid_anchor_rows, rigid_state_basis
from ._verification import orbit_period, runs_closure, segment_closure

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
        variational equations (made in the C call that solved it) must close
        (:mod:`gearsym.analysis.periodic._verification`; ``info["verification"]``).

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
                     raise_on_failure=o.raise_on_failure,
                     runs=newton.fast.verification if newton.fast is not None else None)


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
        Newton steps taken.
    converged : bool
        Whether the residual met the tolerance.
    residual, relative_residual : float
        ``max |R|`` and ``max |R_i| / s_i``.
    failure : str
        Why not (empty when converged).
    fast : ShootOutcome or None
        The iteration's outcome where it converged (one segment: the multipliers, isolation and
        ``g0`` computed in its C call).
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
    BifurcationKit's ``ShootingProblem``): the segment times, the first iterate
    (:meth:`initial_states`), the settings of THE Newton iteration and its anchor rows; the
    iteration and the residual's evaluation run in C (:func:`gearsym.engine.shoot.shooter_for`),
    :meth:`solve` adds the relaxation by integration where Newton stalls and :meth:`judge`
    decides what the monodromy says about the result.

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
        #: where the Newton iteration ran: ``"C"`` (THE iteration of gs_newton.c, the residual
        #: evaluated in the same C call; there is no other)
        self.newton_engine = "C"
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
        V = rigid_state_basis(system, self.params)
        self.anchor = None if V is None else rigid_anchor_rows(V, segments * nx, range(nx))
        self.relaxed = 0  # forcing periods of relaxation by integration so far
        self.relax_block = max(1, int(math.ceil(10 * max(1.0, float(self.periods)))))
        self._steps = 0  # Newton steps attempted (the history's iteration numbers)

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

    # ------------------------------------------------------------ Newton
    def settings(self) -> ShootSettings:
        """THE Newton iteration's settings for this problem (:class:`gearsym.engine.shoot.ShootSettings`)."""
        system, o = self.system, self.options
        method = o.method or default_method(system.generated.implicit, system.defaults.get("method"))
        return ShootSettings(method=method, rtol=o.rtol, atol=o.atol, max_step=self.max_step,
                             max_steps=int(system.defaults.get("max_steps", 0)), tol=o.tol, max_iter=o.max_iter,
                             trunc_level=monodromy_error(1.0, o.rtol), scale_floor=o.atol / o.tol,
                             min_step=o.min_step, segments=self.segments, n_amp=self.n_amp,
                             n_anchor=0 if self.anchor is None else len(self.anchor))

    def solve(self, X: np.ndarray) -> NewtonRun:
        """THE Newton iteration from ``X`` (in C, :func:`gearsym.engine.shoot.shooter_for`), with the
        relaxation by integration where no damped step reduces the residual: integrate a block of
        forcing periods from the last iterate (contracting towards an attracting orbit), then go on
        with the same iteration from there, up to ``relax_periods`` forcing periods.

        Raises
        ------
        SimulationError
            The first integration fails (the engine's error).
        ParameterError
            A segment needs more steps of ``max_step`` than the step budget.
        """
        o, engine = self.options, self.system.engine
        for i in range(self.segments):  # (System.flow's check, before any work)
            check_step_budget(self.s[i], self.s[i + 1], self.max_step, int(self.system.defaults.get("max_steps", 0)))
        shooter = shooter_for(engine, self.settings())
        _log.debug("shooting Newton: %s", self.newton_engine)
        out = shooter.solve(engine, X, self.pvec, self.s, self.anchor)
        if out.code == EVAL_FAILED:
            raise out.error()  # the first integration fails
        self._record(out, None)
        failure = ""
        while out.code == STALLED and self.relaxed < o.relax_periods:
            # Newton is stuck in a local minimum of the residual (the flow map of a nonsmooth
            # system is far from linear over large distances)
            n_blk = int(min(self.relax_block, o.relax_periods - self.relaxed))
            try:
                Xr = self._spread(self._integrate_periods(out.X[0], n_blk))
            except GearsymError as exc:
                failure = f"relaxation by integration failed: {exc}"
                break
            self.relaxed += n_blk
            self._steps += 1  # (the stalled step counts)
            again = shooter.restart(engine, Xr)
            if again.code == EVAL_FAILED:
                failure = f"relaxation by integration failed: {again.error()}"
                break
            out = again
            self._record(out, n_blk)
        return self._run(out, failure)

    def _record(self, out: ShootOutcome, relaxed: int | None) -> None:
        """The history entries of one call of the iteration (``relaxed``: the forcing periods
        integrated before it)."""
        for kind, r, rel, step, drop in out.history:
            if kind == "start":
                self.history.append({"iteration": 0, "residual": r, "relative": rel, "step": None})
            elif kind == "restart":
                self.history.append({"iteration": len(self.history), "residual": r, "relative": rel, "step": None,
                                     "note": f"Newton stalled: integrated {relaxed} forcing periods"})
            elif kind == "noise floor":
                self.history.append({"iteration": len(self.history), "residual": r, "step": 0.0,
                                     "note": "noise floor: Newton step below tolerance"})
            else:
                self._steps += 1
                entry = {"iteration": self._steps, "residual": r, "relative": rel, "step": step}
                if drop:
                    entry["dropped_directions"] = drop
                self.history.append(entry)

    def _run(self, out: ShootOutcome, failure: str) -> NewtonRun:
        """The :class:`NewtonRun` of the iteration's last outcome (``failure``: the relaxation's)."""
        o = self.options
        self.scale = out.scale
        converged = out.converged and not failure
        if converged and out.note in (1, 2) and self.history[-1].get("note") is None:
            self.history[-1]["note"] = NOTES[out.note]
        if self.history:
            self.history[-1]["engine"] = "C"
        if not converged and not failure:
            failure = {MAX_ITER: f"no convergence in max_iter={o.max_iter} Newton iterations",
                       NONFINITE: "non-finite residual", SINGULAR: "the Newton matrix is not finite",
                       STALLED: "the damped Newton step does not reduce the residual (tried down to a factor "
                                f"{o.min_step:g}, after {self.relaxed} forcing periods of relaxation by integration)"
                                + (f"; last integration error: {out.message}" if out.message else "")
                       }.get(out.code, out.reason)
        ev = out.events
        evs = log_events(self.system, ev.t, ev.surface, ev.direction)
        return NewtonRun(out.X, list(out.monodromies), evs, out.iterations, converged, out.residual, out.relative,
                         failure, out if converged else None)

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
              raise_on_failure: bool, runs: VerifyRuns | None = None) -> PeriodicOrbit:
    """A converged orbit after its verification by one plain integration over its period
    (:func:`~gearsym.analysis.periodic._verification.segment_closure`, recorded in ``info["verification"]``):
    unchanged when it passes, else not converged (raised with ``raise_on_failure``).  ``runs``: those
    integrations, made in the C call that solved the orbit; they count when they started from the
    orbit's segment states (else the orbit is integrated here)."""
    if not orbit.converged or orbit.system is None:
        return orbit
    info = orbit.info
    kw = {"rtol": info["rtol"], "atol": info["atol"], "tol": info["tol"], "amplification": orbit.max_multiplier}
    amplitude = np.asarray(info["state_scales"])
    if runs is not None and np.array_equal(runs.starts, orbit.segment_states):
        c = runs_closure(runs.starts, runs.ends, runs.error, amplitude, **kw)
    else:
        c = segment_closure(orbit.system, orbit.segment_states, times, p, method=method, max_step=max_step or None,
                            amplitude=amplitude, **kw)
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
