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
import math
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_shooting
from ...engine.driver import METHODS
from ...engine.shoot import MAX_STATES, shoot_in_c
from ...errors import ConvergenceError, GearsymError, ParameterError
from .._options import check_tolerances, resolve_options
from ._floquet import monodromy_product
from ._isolation import Isolation, isolation, monodromy_error, truncated_solve
from ._newton import NewtonPolicy, damped_newton
from ._options import ShootingOptions
from ._orbit import PeriodicOrbit, finish_orbit
from ._problems import flow_events, log_events, segment_jacobian, segment_times
from ._stability import rigid_state_basis
from ._verification import orbit_period, segment_closure

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["flow", "shoot"]


def flow(system: CompiledSystem, x: Sequence[float], t0: float, t1: float, params: Mapping[str, float] | np.ndarray | None,
         rtol: float, atol: float, jacobian: bool = True, fd_step: float = 1e-6,
         method: str | None = None, n_out: int = 2, with_amplitude: bool = False, max_step: float | None = None
         ) -> tuple[Any, ...]:
    """The flow map ``phi(t1, t0, x)``, its Jacobian and the events on the way.

    One call of :meth:`gearsym.system.System.flow` (the engine's cheap path: no output
    grid, no trajectory object).  The Jacobian is the engine's variational monodromy, or for an
    implicit model without one, central finite differences with step ``fd_step * max(1, |x_j|)``.  ``params`` may be the parameter vector itself.  With
    ``with_amplitude`` also ``max |x_i(t)|`` over ``n_out`` evenly spaced points.  ``max_step``
    as for :meth:`~gearsym.system.System.flow` (default an eighth of the forcing period).
    """
    x = np.asarray(x, float)
    pv = params if isinstance(params, np.ndarray) else system.param_vector(params)
    implicit = system.generated.implicit
    fl = system.flow(x, t0, t1, pv, rtol=rtol, atol=atol, monodromy=bool(jacobian),
                     method=method, n_samples=n_out, max_step=max_step)
    M = fl.monodromy  # the engine's variational equations, where it has them
    if jacobian and implicit and M is None:
        n = len(x)
        M = np.empty((n, n))
        for j in range(n):
            h = fd_step * max(1.0, abs(x[j]))
            e = np.zeros(n)
            e[j] = h
            xp = system.flow(x + e, t0, t1, pv, rtol=rtol, atol=atol, monodromy=False, method=method).x_final
            xm = system.flow(x - e, t0, t1, pv, rtol=rtol, atol=atol, monodromy=False, method=method).x_final
            M[:, j] = (xp - xm) / (2 * h)
    events = flow_events(system, fl)
    if with_amplitude:
        return np.asarray(fl.x_final, float), M, events, fl.amplitude
    return np.asarray(fl.x_final, float), M, events


def shoot(system: CompiledSystem, period: float | None = None, periods: float = 1,
          x0: Sequence[float] | None = None, params: Mapping[str, float] | None = None, *,
          segments: int = 1, t0: float = 0.0, transient: float | None = None, tol: float = 1e-10,
          rtol: float = 1e-11, atol: float = 1e-13, max_iter: int = 50, min_step: float = 2.0 ** -12,
          raise_on_failure: bool = True, method: str | None = None,
          relax_periods: float = 200, trivial: np.ndarray | None = None,
          options: ShootingOptions | None = None) -> PeriodicOrbit:
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
    segments
        Number of shooting segments (1: single shooting).
    t0
        Phase of the orbit's reference state (a multiple of the forcing period).
    transient
        Number of forcing periods to integrate before Newton (default: 0 when
        ``x0`` is given, else the scene's ``transient_periods`` or 20), ending at a
        time congruent to ``t0``.
    tol
        Convergence: ``max_i |residual_i| / s_i <= tol`` with ``s_i`` the largest
        ``|x_i|`` along the trajectory, at least ``atol / tol`` (a relative tolerance per
        state, so states in different units are treated alike, and a residual below
        ``atol`` always converges); also accepted: a full Newton step below ``tol``
        (relative) with the residual within ``100 tol`` (integration noise).
    rtol, atol
        Integrator tolerances (the variational equations use them too).
    max_iter
        Newton iteration limit.
    min_step
        Smallest damping factor tried before giving up.
    raise_on_failure
        Raise :class:`ConvergenceError` if Newton fails (else return the last
        iterate with ``converged=False``).
    method
        Integrator (``"bdf"``, ``"adams"``; ``"ida"`` for implicit models).
    relax_periods
        When the damped Newton step cannot reduce the residual, integrate blocks
        of forcing periods from the current iterate (this converges towards an
        attracting orbit) and resume Newton, up to this many periods in all
        (0: never; unstable orbits need a good ``x0`` instead).
    trivial
        Known trivial directions of the state space (nx x k), e.g. the rigid-body mode
        of a semi-definite model: a multiplier +1 whose eigenvector lies in their span
        does not count against the orbit's isolation.  Default: none.
    options
        A :class:`~gearsym.analysis.periodic.ShootingOptions` with all of the settings above
        (``segments`` .. ``trivial``); a keyword not at its default overrides it.

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
        periods), bad options.
    ConvergenceError
        Newton did not converge (message: residual history, last iterate, advice), the
        converged state failed its verification, or there is no isolated orbit (a multiplier at +1 to working precision and a
        residual that no step can remove: e.g. an undamped system forced at resonance).
    SimulationError
        The first integration already fails.
    """
    wall = time.perf_counter()
    o = resolve_options(options, ShootingOptions, segments=segments, t0=t0, transient=transient, tol=tol,
                        rtol=rtol, atol=atol, max_iter=max_iter, min_step=min_step,
                        raise_on_failure=raise_on_failure, method=method, relax_periods=relax_periods,
                        trivial=trivial)
    segments, t0, transient, tol, rtol, atol = o.segments, o.t0, o.transient, o.tol, o.rtol, o.atol
    max_iter, min_step, raise_on_failure, method = o.max_iter, o.min_step, o.raise_on_failure, o.method
    relax_periods, trivial = o.relax_periods, o.trivial
    check_tolerances(tol=tol, rtol=rtol, atol=atol)
    period, periods = orbit_period(system, params, period, periods)  # a whole number of forcing periods
    T = system.period(params)
    segments = int(segments)
    if segments < 1:
        raise ParameterError(f"segments must be >= 1, got {segments}")
    nx = system.generated.nx
    check_shooting(segments, nx)  # the (segments nx)^2 Jacobian within the budget (gearsym.budget)

    # ---------------------------------------------------------------- initial guess
    guess = system.x0 if x0 is None else np.asarray(x0, float)
    if guess.shape != (nx,):
        raise ParameterError(f"x0 must have {nx} entries ({', '.join(system.state_names)}), got {guess.shape}")
    if transient is None:
        transient = 0 if x0 is not None else float(system.defaults.get("transient_periods", 20))
    Tt = T if T else period
    if transient and transient > 0:
        n_tr = max(1, int(math.ceil(transient)))
        tr = system.simulate(t_end=t0, t0=t0 - n_tr * Tt, x0=guess, rtol=max(rtol, 1e-9),
                             atol=max(atol, 1e-11), n_out=2, params=params, method=method)
        guess = tr.x_final
    s = segment_times(t0, period, segments)
    if segments == 1:
        X = guess[None, :].copy()
    else:
        tr = system.simulate(t_end=s[-1], t0=s[0], x0=guess, rtol=max(rtol, 1e-9), atol=max(atol, 1e-11),
                             t_out=s, params=params, method=method)
        X = np.array(tr.y[:-1], float)

    # ---------------------------------------------------------------- residual
    n_amp = max(3, int(math.ceil(16 / segments)) + 1)
    pvec = system.param_vector(params)
    max_step = T / 8 if T else 0.0  # System.flow's default, computed once
    scale_box = [np.ones(nx)]  # the scales of the last evaluation (see scales())

    def evaluate(X: np.ndarray, jac: bool = True):
        xs, Ms, evs = [], [], []
        a = np.zeros(nx)
        for i in range(segments):
            xe, M, ev, ai = flow(system, X[i], s[i], s[i + 1], pvec, rtol, atol, jacobian=jac,
                                 method=method, n_out=n_amp, with_amplitude=True, max_step=max_step)
            xs.append(xe)
            Ms.append(M)
            evs.extend(ev)
            a = np.maximum(a, ai)
        # per-state scale: the largest |x_i| along the current trajectory (states in
        # different units, e.g. m and m/s, each get a relative tolerance)
        # (floor atol/tol: a residual below the integrator's atol always counts as
        # converged, e.g. for the trivial orbit x = 0 of a homogeneous linear system)
        top = float(a.max()) if a.size else 0.0
        scale_box[0] = np.maximum(a, max(1e-9 * top, atol / tol)) if math.isfinite(top) else np.ones(nx)
        R = xs[0] - X[1 % segments] if segments == 1 else np.array(
            [xs[i] - X[(i + 1) % segments] for i in range(segments)])
        return R.reshape(segments, nx), Ms, evs

    def scales() -> np.ndarray:
        return scale_box[0]

    def rel(A: np.ndarray) -> float:
        return float((np.abs(A) / scale_box[0]).max())

    def _relax(X: np.ndarray, n_periods: int) -> np.ndarray:
        tr = system.simulate(t_end=s[0], t0=s[0] - n_periods * Tt, x0=X[0], rtol=max(rtol, 1e-9),
                             atol=max(atol, 1e-11), n_out=2, params=params, method=method)
        x = tr.x_final
        if segments == 1:
            return x[None, :].copy()
        tr = system.simulate(t_end=s[-1], t0=s[0], x0=x, rtol=max(rtol, 1e-9), atol=max(atol, 1e-11),
                             t_out=s, params=params, method=method)
        return np.array(tr.y[:-1], float)

    anchor = _anchor_rows(system, params, segments)
    relaxed = 0
    relax_block = max(1, int(math.ceil(10 * max(1.0, float(periods)))))
    history: list[dict[str, Any]] = []

    def norm(ev: tuple) -> float:
        return float(np.max(np.abs(ev[0])))

    def is_converged(ev: tuple, size: float, damping: float) -> str | None:
        r = rel(ev[0])
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

    def direction(X: np.ndarray, ev: tuple) -> tuple[np.ndarray, float, dict[str, Any]]:
        R, Ms, _ = ev
        J = segment_jacobian(Ms)
        rhs = -R.ravel()
        if anchor is not None:
            # a rigid-body mode makes J singular (a Jordan block of M at +1): keep the rigid
            # coordinates of the first segment where they are (anchor rows), least squares
            dz = np.linalg.lstsq(np.vstack([J, anchor]), np.concatenate([rhs, np.zeros(len(anchor))]),
                                 rcond=None)[0]
            n_drop = 0
        else:
            # minimum-norm step without the directions the monodromy cannot resolve: never move
            # the state by noise divided by noise (a multiplier at +1 to working precision)
            dz, n_drop = truncated_solve(J, rhs, np.tile(scales(), segments), rtol)
        dX = dz.reshape(segments, nx)
        return dX, rel(dX) if np.all(np.isfinite(dX)) else math.inf, (
            {"dropped_directions": n_drop} if n_drop else {})

    it_offset = [0]  # Newton steps the C iteration took before the Python one resumed

    def on_step(it: int, ev: tuple, damping: float, notes: dict[str, Any]) -> None:
        history.append({"iteration": it + it_offset[0], "residual": norm(ev), "relative": rel(ev[0]),
                        "step": damping, **notes})

    def stalled(X: np.ndarray, ev: tuple, dX: np.ndarray, last_err: str) -> tuple[str, Any]:
        nonlocal relaxed
        # at the integration noise floor a tiny Newton step cannot reduce the residual any more
        if rel(dX) <= 10 * tol and rel(ev[0]) <= 100 * tol:
            history.append({"iteration": len(history), "residual": norm(ev), "step": 0.0,
                            "note": "noise floor: Newton step below tolerance"})
            return "converged", "noise floor"
        if relaxed < relax_periods:
            # Newton is stuck in a local minimum of the residual (the flow map of a
            # nonsmooth system is far from linear over large distances): integrate
            # a block of forcing periods (contracts towards an attracting orbit),
            # then resume Newton from there
            n_blk = int(min(relax_block, relax_periods - relaxed))
            try:
                Xr = _relax(X, n_blk)
                evr = evaluate(Xr)
            except GearsymError as exc:
                return "fail", f"relaxation by integration failed: {exc}"
            relaxed += n_blk
            history.append({"iteration": len(history), "residual": norm(evr), "relative": rel(evr[0]), "step": None,
                            "note": f"Newton stalled: integrated {n_blk} forcing periods"})
            return "restart", (Xr, evr)
        return "fail", ("the damped Newton step does not reduce the residual (tried down to a factor "
                        f"{min_step:g}, after {relaxed} forcing periods of relaxation by integration)"
                        + (f"; last integration error: {last_err}" if last_err else ""))

    fast = None
    if segments == 1 and anchor is None:
        # the full-step Newton iteration in one C call; where it gives up (damping, a nearly
        # singular step, ...) the Python iteration below resumes from its last accepted
        # iterate (the steps before are the ones it would have taken itself)
        fast = _newton_in_c(system, X[0], s[0], s[1], pvec, rtol=rtol, atol=atol, tol=tol, max_iter=max_iter,
                            method=method, max_step=max_step, n_amp=n_amp)
    if fast is not None and not fast.converged:
        if fast.code in (1, 2, 3, 4) and fast.iterations >= 1:
            X = fast.x[None, :].copy()
            history.extend({"iteration": i, "residual": float(fast.history_abs[i]),
                            "relative": float(fast.history_rel[i]), "step": None if i == 0 else 1.0, "engine": "C"}
                           for i in range(fast.iterations + 1))
            it_offset[0] = fast.iterations
        fast = None
    if fast is not None:
        ev_log = fast.events
        evs = log_events(system, ev_log.t, ev_log.surface, ev_log.direction)
        X, Ms, it, converged = fast.x[None, :].copy(), [fast.monodromy], fast.iterations, True
        note = _C_NOTES[fast.note]
        scale_box[0] = fast.scale
        history.extend({"iteration": i, "residual": float(fast.history_abs[i]), "relative": float(fast.history_rel[i]),
                        "step": None if i == 0 else 1.0} for i in range(len(fast.history_abs)))
        if note:
            history[-1]["note"] = note
        history[-1]["engine"] = "C"
        rnorm, rel_res = float(fast.history_abs[-1]), float(fast.history_rel[-1])
        failure = ""
    else:
        ev0 = evaluate(X)
        if not it_offset[0]:
            history.append({"iteration": 0, "residual": norm(ev0), "relative": rel(ev0[0]), "step": None})
        out = damped_newton(X, ev0, evaluate=evaluate, norm=norm, direction=direction, converged=is_converged,
                            policy=NewtonPolicy(max_iter=max_iter - it_offset[0], min_damping=min_step,
                                                apply_final_step=True),
                            stalled=stalled,
                            on_step=on_step)
        X, (R, Ms, evs), it, converged = out.x, out.ev, out.iterations + it_offset[0], out.converged
        rnorm, rel_res = norm(out.ev), rel(R)
        failure = ""
        if converged and out.note and history[-1].get("note") is None and out.note != "noise floor":
            history[-1]["note"] = out.note
        if not converged:
            failure = (f"no convergence in max_iter={max_iter} Newton iterations" if out.failure == "max_iter"
                       else out.failure)
    mono = monodromy_product(Ms) if all(M is not None for M in Ms) else None
    iso: Isolation | None = None
    if trivial is None:  # the model's rigid-body subspace, found by the symbolic layer
        trivial = rigid_state_basis(system, params)
    if mono is not None and trivial is None and fast is not None and fast.isolation is not None:
        # computed by the driver, in the same scales (it also found the monodromy finite)
        sigma, norm_s, direction = fast.isolation
        threshold = monodromy_error(norm_s, rtol)
        iso = Isolation(sigma, threshold, sigma > threshold, direction, 0)
    elif mono is not None and np.isfinite(mono).all():
        iso = isolation(mono, scales(), rtol, trivial)
    wall = time.perf_counter() - wall
    spurious = converged and iso is not None and not iso.isolated
    if spurious:
        # a residual below tol is no orbit where the monodromy cannot pin the state down: at an
        # undamped resonance Newton can "converge" at a huge amplitude, on the periodic orbit of
        # the integrator's own numerical damping
        converged = False
        failure = (f"the residual fell below tol at max |x0| = {float(np.max(np.abs(X[0]))):.3g}, but along a "
                   f"direction the monodromy does not determine")
    if not converged and raise_on_failure:
        hist = ", ".join(f"{h['residual']:.3g}" for h in history[-12:])
        if iso is not None and not iso.isolated:
            what = "the state shooting reached is not an orbit" if spurious else "shooting cannot remove the residual"
            raise ConvergenceError(
                f"{iso.reason()}: {what} of period {period:.6g} ({periods:g} forcing period(s)): {failure}. "
                f"Residual history (max |phi(T,x0)-x0|): [{hist}]. Add damping, move the forcing off the "
                f"resonance, or tighten rtol (now {rtol:g}) if the system is lightly damped.")
        raise ConvergenceError(
            f"shooting did not converge for the orbit of period {period:.6g} ({periods:g} forcing "
            f"period(s), {segments} segment(s)): {failure}. Residual history (max |phi(T,x0)-x0|): "
            f"[{hist}]; last x0 = {np.array2string(X[0], precision=8)}. Try a better initial guess "
            f"(x0=..., or transient=<more periods>), more segments (segments=N) for long or unstable "
            f"orbits, or method='hbm'.")
    if not converged and iso is not None and not iso.isolated:
        failure = f"{iso.reason()}; {failure}"
    orbit = finish_orbit(
        system, x0=X[0].copy(), period=period, periods=periods, t0=t0, monodromy=mono, iterations=it,
        residual=rnorm, converged=converged, method="shooting", params=system.run_params(params),
        events=evs, segments=segments, segment_states=X.copy(),
        multipliers=fast.multipliers if fast is not None else None, g0=fast.g0 if fast is not None else None,
        segment_monodromies=[np.asarray(M) for M in Ms if M is not None], history=history,
        info={"rtol": rtol, "atol": atol, "tol": tol, "wall_s": wall, "failure": failure or None,
              "monodromy_rtol": max(rtol / 1e-6, 1e-12) if system.generated.implicit else rtol,
              "rigid_anchor": anchor is not None,
              "relative_residual": rel_res, "state_scales": scales().tolist(),
              "isolation": iso.to_dict() if iso is not None else None})
    return _verified(orbit, s, pvec, method=method, max_step=max_step, raise_on_failure=raise_on_failure)


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
    (:func:`gearsym.engine.shoot.shoot_in_c`; its outcome, converged or not), or ``None`` where
    it does not apply (implicit models, a build without it)."""
    gen = system.generated
    if gen.implicit or gen.nx > MAX_STATES or not hasattr(system.engine._lib, "gs_shoot_ws"):
        return None
    method = method or str(system.defaults.get("method", "adams"))
    if method not in ("adams", "bdf"):
        return None
    max_steps = int(system.defaults.get("max_steps", 0))
    if max_step and (t1 - t0) / max_step > (max_steps or 10_000_000):
        return None  # the Python path raises the step-budget error
    n = max(int(n_amp), 2)
    grid = _steps(n) * ((t1 - t0) / (n - 1)) + t0  # np.linspace(t0, t1, n)'s arithmetic
    grid[-1] = t1
    # the Python step drops singular values of the scaled M - I below monodromy_error; give up
    # when a pivot gets within a factor 10 of that level (a stricter factor, 1e3, sent
    # lightly damped 48- and 130-state models to the Python iteration after a wasted C one)
    pivot_tol = 10 * monodromy_error(1.0, rtol)
    out = shoot_in_c(system.engine, x, pvec, t0, t1, grid, method=METHODS[method], rtol=rtol, atol=atol,
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
