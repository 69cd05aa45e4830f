"""Pseudo-arclength continuation of periodic orbits in one run-time parameter.

The branch is the solution set of ``F(u, lambda) = 0`` with ``F`` the shooting
residual ``phi(t0 + P(lambda), t0, x0; lambda) - x0`` (or its multiple-shooting
form, or the harmonic-balance residual).  ``P(lambda)`` is ``periods`` forcing
periods *at the current parameter value*, so when the parameter is the forcing
frequency the orbit period follows it.  The method (Keller's pseudo-arclength,
in variables scaled by the state magnitudes and the parameter range):

* **predictor**: a step ``ds`` along the unit tangent ``t`` (the null vector of
  ``[F_u, F_lambda]``, oriented by the previous tangent);
* **corrector**: Newton on ``F = 0`` together with ``t . (w - w_pred) = 0``: the
  new point lies on the hyperplane through the prediction orthogonal to the
  tangent, so turning points (folds) are passed without special treatment.
  ``F_u`` is the monodromy minus the identity from the engine's variational
  equations (with saltation matrices), ``F_lambda`` exact from the parameter
  sensitivities (shooting; a finite difference for harmonic balance);
* **step control**: the step grows after easy corrections (<= 3 Newton steps)
  and shrinks after hard ones; a step is rejected (and halved) when Newton
  fails, the integration fails, or the tangent turns by more than
  ``max_angle`` -- which keeps the steps small where the branch turns sharply,
  e.g. next to grazing points where the multipliers of a non-smooth system
  change like a square root;
* **parameter steps where no fold is possible**: when no Floquet multiplier is
  near +1 (none within 0.2 at the last point, none crossed +1 since the point
  before), the implicit function theorem makes the branch a graph over the
  parameter; if the orbit's state also moves fast with the parameter (a
  rattling orbit whose impacts appear and disappear), the predictor-corrector
  steps in the parameter itself (Newton at fixed parameter), and the tangent is
  oriented so that the parameter keeps its direction.  A step in which a real
  multiplier crosses +1 is redone with the arclength.

**The branch must advance**: the continuation ends with ``complete = False`` and the
reason in ``Branch.stop_reason`` when the step size falls below ``ds_min``, when
``max_points`` is reached before the range is left, or when the parameter stays within
``stall_tol`` of the range over ``stall_points`` consecutive points (the orbit grows
without bound while the parameter converges: an undamped system at resonance, where
the branch never reaches the other side).

Between two accepted points the test functions of
:mod:`gearsym.analysis.continuation._bifurcation` are compared; a sign change is *located*
by solving ``tau(sigma) = 0`` in the arclength ``sigma`` (each evaluation is a
corrected point on the hyperplane ``t_A . (w - w_A) = sigma``), and the located
point is inserted into the branch: folds (tangent's parameter component),
period doublings, Neimark-Sacker points, branch points, and grazings (the
extremum of a switching function over the orbit crosses zero).  If the number of
unstable multipliers changes between two points without any located special
point (a multiplier jumping at a non-smooth point), the change is located by
bisection and classified by the multiplier that crossed.

At a period doubling, :func:`switch_period_doubling` starts the branch of the
doubled orbit: at the located point the ``2k``-period map has the multiplier
``(-1)^2 = 1`` with the eigenvector ``v`` of ``-1``; the new branch leaves the old
one along ``(v, 0)``, so the first corrector runs on the hyperplane orthogonal
to that direction a small distance away, and the continuation proceeds from
there (until the parameter range is left or the doubled orbit merges back into
the period-``k`` branch).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_branch, check_shooting
from ...errors import GearsymError, ParameterError
from ...spec.settings import resolve_settings
from .._inputs import SceneLike, as_system
from .._options import check_tolerances, resolve_options
from ..periodic import (
    ORBIT_METHODS,
    VANISHING,
    HBResidual,
    PeriodicOrbit,
    PeriodicOrbitProblem,
    ShootingResidual,
    harmonic_balance,
    shoot,
    whole_periods,
)
from ._arclength import Leg, formatter, run
from ._branch import Branch
from ._branch_switching import switch_all, switch_period_doubling
from ._corrector import Continuer
from ._detection import detect_types
from ._options import SCENE_DEFAULTS, ContinuationOptions

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ContinuationOptions", "continuation", "switch_period_doubling", "HBResidual", "ShootingResidual"]


def continuation(system: CompiledSystem | SceneLike, param: str, start: float, stop: float, *,
                 x0: Sequence[float] | None = None, orbit: PeriodicOrbit | None = None,
                 params: Mapping[str, float] | None = None, options: ContinuationOptions | None = None,
                 **keywords: Any) -> Branch:
    """Continue a periodic orbit in one parameter from ``start`` to ``stop``.

    Parameters
    ----------
    system
        Compiled system (or a scene, compiled here).
    param
        Name of the run-time parameter to vary.  When the forcing period depends on it,
        the orbit period follows it.
    start, stop
        Parameter range, in the parameter's declared unit (``b_m`` from 40 to 60 means
        um if the model declares ``unit = "um"``; the branch values are in it too): the
        branch starts at ``start`` and ends when it leaves the range (through ``stop``,
        after any number of turning points, or back through ``start``).
    x0
        Initial guess of the orbit's state at ``t0`` for ``param = start``
        (default: the scene's initial state after a transient).
    orbit
        A periodic orbit at ``param = start`` to start from (instead of solving).
    params
        Other parameter overrides, in their declared units (as ``--set``).
    options
        The settings (:class:`~gearsym.analysis.continuation.ContinuationOptions`:
        ``periods``, ``method``, ``segments``, ``harmonics``, ``t0``, ``ds``, ``ds_min``,
        ``ds_max``, ``max_angle``, ``max_points``, ``tol``, ``rtol``, ``atol``, ``max_newton``,
        ``detect``, ``locate``, ``state``, ``n_dense``, ``switch``, ``progress``,
        ``transient``, ``state_weight``, ``stall_points``, ``stall_tol``, ``display``,
        ``defect_tol``, ``f_lambda``; each documented there with its default, and which of
        them the scene's ``[continue]`` table sets).
    **keywords
        Any of those settings one by one (``continuation(system, "Omega", 0.6, 1.4,
        ds_max=0.01)``); a keyword wins over ``options``.

    Returns
    -------
    Branch
        Parameter values in the parameter's declared unit, states (``x0``, ``max``, ...) in SI,
        periods in the model's time unit; :meth:`Branch.to_dataframe` names the unit of every
        column.

    Raises
    ------
    ParameterError
        Unknown parameter, empty range, bad options, a keyword that is no setting of
        :class:`~gearsym.analysis.continuation.ContinuationOptions`.
    ConvergenceError
        No periodic orbit at ``start``.

    Notes
    -----
    A branch that stops early is returned, not raised: check ``branch.complete``.
    """
    system = as_system(system, "continuation")
    wall = time.perf_counter()
    o = _with_scene_settings(system, resolve_options(options, ContinuationOptions, keywords, "continuation"))
    task = _Task.make(system, param, start, stop, params, x0, orbit)
    o, types, state_idx = _check(task, o)
    fmt = formatter(o.display or (1.0, system.units.unit(param)))  # values in the declared unit
    n_dense = o.n_dense if o.n_dense is not None else max(1024, 8 * int(system.defaults.get("points_per_period", 64)))
    res, u0, state_scale = _first_point(task, o)
    info = {"rtol": res.rtol, "atol": res.atol, "tol": o.tol, "segments": o.segments if o.method == "shooting" else None,
            "harmonics": getattr(res, "H", None), "start": task.start, "stop": task.stop,
            "params": {k: float(v) for k, v in res.params(task.start).items() if k != param}, "t0": o.t0}
    branch = run(res, u0, Leg(task.start, task.stop, o, types, state_idx, n_dense, o.method, state_scale, fmt,
                              info=info))
    extra = {}
    if o.switch > 0:
        failures = switch_all(branch, o.switch, replace(o, n_dense=n_dense), types, fmt, stop=task.stop)
        if failures:
            extra["switch_failures"] = failures
    extra["wall_s"] = time.perf_counter() - wall
    return replace(branch, info={**branch.info, **extra})


def _with_scene_settings(system: CompiledSystem, o: ContinuationOptions) -> ContinuationOptions:
    """The options with the settings left at ``None`` taken from the scene's ``[continue]`` table,
    else :data:`~gearsym.analysis.continuation._options.SCENE_DEFAULTS` (one resolution with
    ``gearsym continue``); a first step at its default follows a smaller ``ds_max``."""
    st = resolve_settings("continue", getattr(system, "settings", {}).get("continue"),
                          **{k: getattr(o, k) for k in SCENE_DEFAULTS})
    resolved = {k: SCENE_DEFAULTS[k] if st[k] is None else st[k] for k in SCENE_DEFAULTS}
    ds, ds_min = o.ds, o.ds_min
    if ds == ContinuationOptions.ds and ds > resolved["ds_max"]:  # type: ignore[operator]
        ds = resolved["ds_max"]
        ds_min = min(ds_min, ds)  # type: ignore[type-var]
    return replace(o, ds=ds, ds_min=ds_min, **resolved)


@dataclass(frozen=True)
class _Task:
    """What is continued: the system, the parameter and its range, the other parameters, the start."""

    system: CompiledSystem
    param: str
    start: float
    stop: float
    base: dict[str, float]
    x0: Sequence[float] | None
    orbit: PeriodicOrbit | None

    @classmethod
    def make(cls, system: CompiledSystem, param: str, start: float, stop: float,
             params: Mapping[str, float] | None, x0: Sequence[float] | None, orbit: PeriodicOrbit | None) -> _Task:
        base = dict(params or {})
        base.pop(param, None)
        return cls(system, param, float(start), float(stop), base, x0, orbit)

    @property
    def p_start(self) -> dict[str, float]:
        """The parameters at ``param = start``."""
        return {**self.base, self.param: self.start}


def _check(task: _Task, o: ContinuationOptions) -> tuple[ContinuationOptions, tuple[str, ...], int]:
    """Refuse bad settings before any work; the options (``periods`` a whole number), the
    bifurcation types to detect and the observed state."""
    system, param = task.system, task.param
    check_branch(o.max_points, system.generated.nx)  # bounded memory and work (gearsym.budget)
    check_shooting(o.segments, system.generated.nx)
    if param not in system.params:
        raise ParameterError(f"'{param}' is not a run-time parameter of this system (have: "
                             f"{', '.join(system.params) or 'none'})")
    start, stop = task.start, task.stop
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise ParameterError(f"the parameter range must be two different finite values, got {start} .. {stop}")
    if o.method not in ORBIT_METHODS:
        raise ParameterError(f"method must be one of {', '.join(ORBIT_METHODS)}, got '{o.method}'")
    o = replace(o, periods=whole_periods(o.periods))  # a whole number of forcing periods
    types = detect_types(o.detect)
    if o.method == "hbm" and o.detect is True:
        # the multipliers of a harmonic-balance point come from integrating its truncated
        # orbit, so +1 is crossed slightly away from the balance's own fold: no branch points
        types = tuple(t for t in types if t != "branch_point")
    state_idx = _state_index(system, o.state)
    if not (0 < o.ds_min <= o.ds <= o.ds_max) or o.max_points < 2 or o.tol <= 0 or o.periods <= 0 \
            or o.switch < 0 or not 0 < o.state_weight or not 0 < o.max_angle or o.stall_points < 2 \
            or not 0 <= o.stall_tol < 1:
        raise ParameterError("need 0 < ds_min <= ds <= ds_max, max_points >= 2, tol > 0, periods > 0, "
                             "switch >= 0, state_weight > 0, max_angle > 0, stall_points >= 2, "
                             "0 <= stall_tol < 1")
    check_tolerances(tol=o.tol, rtol=o.rtol, **({"atol": o.atol} if o.atol is not None else {}))
    system.require_period(task.p_start, "continuation of periodic orbits")
    system.param_vector({**task.base, param: stop})  # the physical range (gearsym.spec.rules) at the other end too
    return o, types, state_idx


def _state_index(system: CompiledSystem, state: int | str) -> int:
    """The index of the observed state (a name or an index)."""
    if isinstance(state, str):
        if state not in system.state_names:
            raise ParameterError(f"state '{state}' is not a state of this system (have: "
                                 f"{', '.join(system.state_names)})")
        return system.state_names.index(state)
    state_idx = int(state)
    if not 0 <= state_idx < system.generated.nx:
        raise ParameterError(f"state index {state} out of range (0..{system.generated.nx - 1})")
    return state_idx


def _first_point(task: _Task, o: ContinuationOptions) -> tuple[PeriodicOrbitProblem, np.ndarray, np.ndarray]:
    """The periodic-orbit problem of the branch, the unknowns of its first orbit (at
    ``param = start``) and the state scales (the problem's ``atol`` is the default one where
    the options leave it open)."""
    system, param, start, stop = task.system, task.param, task.start, task.stop
    fd_step = _fd_step(start, stop, o.rtol)
    if o.method == "shooting":
        x_start, state_scale = _first_orbit_shooting(task, o)
        atol = o.atol if o.atol is not None else _default_atol(o.rtol, state_scale, system)
        res: PeriodicOrbitProblem = ShootingResidual(system, param, o.periods, task.base, o.segments, o.t0, o.rtol,
                                                     atol, fd_step=fd_step, f_lambda=o.f_lambda)
        return res, res.u_from_orbit(x_start, start), state_scale  # type: ignore[attr-defined]
    orbit = task.orbit
    if orbit is None:
        orbit = harmonic_balance(system, periods=o.periods, x0=task.x0, params=task.p_start, t0=o.t0,
                                 harmonics=o.harmonics, rtol=o.rtol, atol=o.atol or 1e-12, defect_tol=o.defect_tol)
    state_scale = _state_scale(system, orbit.x0, o.t0, float(orbit.period), task.p_start, o.rtol, o.atol or 1e-12)
    atol = o.atol if o.atol is not None else _default_atol(o.rtol, state_scale, system)
    H = int(o.harmonics or orbit.harmonics or 16)
    res = HBResidual(system, param, H, o.periods, task.base, o.t0, rtol=o.rtol, atol=atol, fd_step=fd_step)
    return res, res.u_from_orbit(orbit, start), state_scale  # type: ignore[attr-defined]


def _state_scale(system: CompiledSystem, x0: np.ndarray, t0: float, period: float, params: Mapping[str, float],
                 rtol: float, atol: float) -> np.ndarray:
    """Magnitude of each state over one period from ``x0`` (max of |x| and peak-to-peak).

    An orbit that is identically zero (``x = 0``) gets :func:`_zero_orbit_scale` for every state.
    """
    tr = system.simulate(t_end=t0 + period, t0=t0, x0=x0, rtol=rtol, atol=atol, n_out=257, params=params)
    sc = np.maximum(np.max(np.abs(tr.y), axis=0), np.ptp(tr.y, axis=0))
    top = float(np.max(sc))
    if not (math.isfinite(top) and top > 1e-280):
        return np.full(len(sc), _zero_orbit_scale(system))
    return np.maximum(sc, 1e-12 * top)


def _zero_orbit_scale(system: CompiledSystem) -> float:
    """A state magnitude for the trivial orbit ``x = 0``, from the scene.

    The largest entry of the scene's initial state; else the magnitude that the scene's
    ``[simulate]`` tolerances imply (``atol / (1e-2 * rtol)``, the convention of the
    continuation's default ``atol``); else 1.
    """
    x0 = np.abs(np.asarray(system.x0, float))
    if x0.size and np.all(np.isfinite(x0)) and float(np.max(x0)) > 0:
        return float(np.max(x0))
    d = system.defaults
    try:
        a, r = float(d["atol"]), float(d["rtol"])
        if a > 0 and r > 0 and math.isfinite(a / r):
            return a / (1e-2 * r)
    except (KeyError, TypeError, ValueError):
        pass
    return 1.0


def _default_atol(rtol: float, state_scale: np.ndarray, system: CompiledSystem) -> float:
    """``rtol * 1e-2 *`` the smallest state magnitude (positive by construction of the scales).

    With states that vanish on the orbit (:data:`VANISHING`) that rule would set ``atol`` at
    the round-off of those states (1.5e-26 for ``planetary_n4``, whose centre translations
    only round-off excites): the integrator then spent 10 million steps on one period.  The
    scene's ``[simulate]`` ``atol`` is taken instead, and without one the caller must choose.
    """
    sc = np.asarray(state_scale, float)
    top = float(np.max(sc))
    vanishing = sc <= VANISHING * top
    if not np.any(vanishing):
        return float(rtol * 1e-2 * np.min(sc))
    try:
        scene_atol = float(system.defaults["atol"])
    except (KeyError, TypeError, ValueError):
        scene_atol = math.nan
    if math.isfinite(scene_atol) and scene_atol > 0:
        return scene_atol
    names = [n for n, v in zip(system.state_names, vanishing, strict=True) if v]
    shown = ", ".join(names[:6]) + (f" and {len(names) - 6} more" if len(names) > 6 else "")
    raise ParameterError(
        f"atol: the states {shown} vanish on this orbit (at most {VANISHING:g} of the largest state "
        f"magnitude {top:.3g}: round-off), so the default atol (rtol * 1e-2 * the smallest magnitude) "
        f"would make the integrator chase round-off; give atol (in the states' units, e.g. the [simulate] "
        f"atol of the scene) or declare one in [simulate]")


def _first_orbit_shooting(task: _Task, o: ContinuationOptions) -> tuple[np.ndarray, np.ndarray]:
    """The state at ``t0`` of a periodic orbit at ``param = start`` and the state scales.

    A transient from the guess, then Newton at fixed parameter (the continuation's
    own corrector); if that fails, :func:`gearsym.analysis.periodic.shoot` with its
    relaxation by integration.
    """
    system, start, p_start, t0, rtol, atol = task.system, task.start, task.p_start, o.t0, o.rtol, o.atol
    P = float(o.periods) * float(system.period(p_start))
    if task.orbit is not None:
        guess = np.asarray(task.orbit.x0, float)
    else:
        guess = np.asarray(system.x0 if task.x0 is None else task.x0, float)
        if guess.shape != (system.generated.nx,):
            raise ParameterError(f"x0 must have {system.generated.nx} entries "
                                 f"({', '.join(system.state_names)}), got shape {guess.shape}")
        n_tr = o.transient if o.transient is not None else (
            0 if task.x0 is not None else float(system.defaults.get("transient_periods", 20)))
        if n_tr and n_tr > 0:
            T = float(system.period(p_start))
            n = max(1, int(math.ceil(n_tr)))
            guess = system.simulate(t_end=t0, t0=t0 - n * T, x0=guess, rtol=max(rtol, 1e-9),
                                    atol=max(atol or 1e-12, 1e-14), n_out=2, params=p_start).x_final
    scale = _state_scale(system, guess, t0, P, p_start, max(rtol, 1e-9), atol or 1e-12)
    a_tol = atol if atol is not None else _default_atol(rtol, scale, system)
    res = ShootingResidual(system, task.param, o.periods, task.base, o.segments, t0, rtol, a_tol, fd_step=1e-6,
                           f_lambda=o.f_lambda)
    C = Continuer(res, lam_scale=1.0, tol=o.tol, max_newton=25, state=0, n_dense=64, detect=())
    C.set_state_scale(scale)
    row = np.zeros(res.n + 1)
    row[-1] = 1.0
    try:
        z, _, _ = C.correct(np.concatenate([res.u_from_orbit(guess, start), [start]]), row, start)
        x_start = res.x0_of(z[:-1], float(z[-1]))
    except GearsymError:
        orbit = shoot(system, periods=o.periods, x0=guess, params=p_start, segments=o.segments, t0=t0, transient=0,
                      rtol=rtol, atol=a_tol, tol=min(o.tol, 1e-9))
        x_start = np.asarray(orbit.x0, float)
    return x_start, _state_scale(system, x_start, t0, P, p_start, rtol, a_tol)


def _fd_step(start: float, stop: float, rtol: float = 1e-10) -> float:
    """Step of the forward difference ``F_lambda``: ``sqrt(rtol)`` of the parameter range
    (at least 1e-6), the usual balance of the integration noise (~ rtol) divided by the
    step against the truncation error (~ the step).  Measured on the benchmark orbit
    against a central difference at rtol 1e-13: relative error 1e-2 at rtol 1e-5, 5e-5 at
    1e-10 (a fixed 1e-6 step gave 34 and 6e-4: at loose tolerances ``F_lambda`` was all
    noise and the corrector rejected step after step)."""
    return max(1e-6, math.sqrt(rtol)) * max(abs(stop - start), 1e-3 * max(abs(start), abs(stop)))
