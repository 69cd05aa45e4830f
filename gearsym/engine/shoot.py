"""The shooting residuals over the flow, evaluated in C for THE Newton iteration.

The Newton iteration of the periodic-orbit solvers is written once, in C
(:mod:`gearsym.engine.newton`, ``gs_newton.c``).  This module runs it with its C evaluators,
in one driver call per solve:

* :class:`Shooter` / :func:`shoot_in_c`: shooting's Newton (``gs_shoot_ws``): the residual
  ``phi(s_{i+1}; s_i, X_i) - X_{i+1}`` of single or multiple shooting, one integration with the
  monodromy per segment (CVODE, or IDA for implicit models and DAEs), the amplitude of the
  samples for the state scales; the orbit's multipliers, isolation and switching functions at
  its start once it converged (one segment), and its verification runs (one plain integration
  per segment from the converged states, :class:`VerifyRuns`);
* :class:`Corrector` / :func:`correct_in_c`: the continuation's corrector (``gs_correct_ws``):
  the residual in the differential states with the exact ``F_lambda`` (the parameter
  sensitivity in the same integration), single or multiple shooting, DAEs; the corrected
  point's tangent, samples, statistics and multipliers.  Where the C evaluator does not apply
  (harmonic balance, a parameter that is no plain entry of the parameter vector, the
  finite-difference ``F_lambda``) or fails on one evaluation (the sensitivity at a grazing
  contact), the caller's ``evaluate`` answers that request in Python and the same iteration
  goes on (counted in :attr:`CorrectOutcome.n_python`).
"""

from __future__ import annotations

import ctypes as C
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import GearsymError, ParameterError
from ..integrators import by_code, get_method
from ..options import cached_options, merge_options
from .driver import EventLog
from .errors import EngineError, EngineInputError, error_for_status
from .newton import CONVERGED, CORRECTOR, ORBIT, OUTCOMES, NewtonCore, NewtonPolicy, _sized, lapack_pointers
from .sim_args import GsCorrectorFlow, GsOrbitFlow

if TYPE_CHECKING:  # pragma: no cover
    from .driver import Engine

__all__ = ["OUTCOMES", "CorrectOutcome", "Corrector", "CorrectorFlow", "OrbitSamples", "SampleStats",
           "ShootOutcome", "ShootSettings", "Shooter", "VerifyRuns", "c_method", "correct_in_c", "lapack_pointers",
           "shoot_in_c", "shooter_for"]

#: ``gs_orbit_flow.handback`` / ``gs_corrector_flow.handback``.
_HANDBACK_EVENTS, _HANDBACK_CALLER = 1, 2


def c_method(method: str | int) -> tuple[int, int]:
    """``(GS_METHOD_* code, GS_NONLIN_* code)`` of an integration method, given by name or by code.

    Raises
    ------
    EngineInputError
        An unknown method.
    """
    try:
        m = by_code(int(method)) if isinstance(method, (int, np.integer)) else get_method(method)
        return m.code, m.nonlinear_code()
    except ParameterError as exc:
        raise EngineInputError(str(exc)) from None


def _events(buf: dict[str, np.ndarray], n: int) -> EventLog:
    return EventLog(t=buf["t"][:n].copy(), surface=buf["s"][:n].astype(int), direction=buf["d"][:n].astype(int),
                    speed=buf["v"][:n].copy())


def _event_buffers(f: Any, cap: int) -> dict[str, np.ndarray]:
    """An evaluation's event log of capacity ``cap`` pointed at by the flow struct ``f``."""
    buf = {"t": np.empty(cap), "s": np.empty(cap, dtype=np.intc), "d": np.empty(cap, dtype=np.intc),
           "v": np.empty(cap)}
    f.ev_t, f.ev_surface, f.ev_dir, f.ev_speed = (buf[k].ctypes.data for k in "tsdv")
    f.ev_cap = cap
    return buf


class MultiplierBuffers:
    """The output arrays of a ``gs_multipliers`` struct (gs_driver.h), pointed at once with
    scipy's LAPACK routines; :meth:`read` gives ``(mu, tolerances, delta)`` or ``None``."""

    def __init__(self, m: C.Structure, nx: int, rtol: float):
        self.m = m
        self.re, self.im, self.tol = np.empty(nx), np.empty(nx), np.empty(nx)
        lap = lapack_pointers()
        if lap:  # else the struct's routines stay NULL and the driver computes nothing
            m.lapack_dgebal, m.lapack_dgesdd, m.lapack_dgeev = lap["dgebal"], lap["dgesdd"], lap["dgeev"]
            m.rtol = float(rtol)
            m.mu_re, m.mu_im, m.mu_tol = self.re.ctypes.data, self.im.ctypes.data, self.tol.ctypes.data

    def read(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The multipliers of the last call (copies), ``None`` when it did not compute them."""
        if int(self.m.ok) != 1:
            return None
        mu = np.empty(self.re.shape[0], complex)
        mu.real, mu.imag = self.re, self.im
        return mu, self.tol.copy(), float(self.m.delta)


# ================================================================== shooting's Newton
@dataclass(frozen=True)
class ShootSettings:
    """The settings of shooting's Newton in C (one :class:`Shooter`, its buffers made once, per
    settings and thread).

    Parameters
    ----------
    method
        An integration method of the registry, by name or by its ``GS_METHOD_*`` code.
    rtol, atol, max_step, max_steps
        Integration settings (scalar tolerances; the variational equations use them too).
    tol, max_iter, min_step
        The convergence tolerance on the residual relative to the state scales, the Newton
        steps allowed, the smallest damping.
    trunc_level
        Singular values of the scaled Jacobian below ``trunc_level * max(1, sigma_1)`` are
        dropped from a step (:func:`gearsym.analysis.periodic.monodromy_error` at norm 1).
    scale_floor
        The state scales' floor (``atol / tol``).
    segments, n_amp
        Shooting segments, and samples per segment whose magnitudes give the scales.
    n_anchor
        Anchor rows pinning rigid-body coordinates (0: none).
    max_events_out
        First capacity of the event log (grown when an evaluation needs more).

    Raises
    ------
    EngineInputError
        An unknown method, ``max_iter < 0``, ``segments < 1``, ``n_amp < 2`` or ``max_events_out < 1``.
    """

    method: str | int
    rtol: float
    atol: float
    max_step: float
    max_steps: int
    tol: float
    max_iter: int
    trunc_level: float
    scale_floor: float
    min_step: float = 2.0 ** -12
    segments: int = 1
    n_amp: int = 17
    n_anchor: int = 0
    max_events_out: int = 4096
    codes: tuple[int, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "codes", c_method(self.method))
        if int(self.max_iter) < 0 or int(self.segments) < 1 or int(self.n_amp) < 2 or int(self.max_events_out) < 1:
            raise EngineInputError(f"shooting in C needs max_iter >= 0, segments >= 1, n_amp >= 2 and max_events_out "
                                   f">= 1 (got {self.max_iter}, {self.segments}, {self.n_amp}, {self.max_events_out})")


@dataclass(frozen=True)
class VerifyRuns:
    """A converged orbit's verification runs, made in the C call that solved it (one plain run
    per segment, no variational equations, from the converged segment start states: what
    :func:`gearsym.analysis.periodic._verification.segment_closure` integrates).

    Attributes
    ----------
    starts : ndarray, shape (segments, nx)
        The states the runs started from (the orbit's segment start states).
    ends : ndarray or None
        Each run's end state, same shape; ``None`` when a run failed.
    error : str
        The failed run's error, as the engine raises it (empty when they ran).
    """

    starts: np.ndarray
    ends: np.ndarray | None
    error: str = ""


@dataclass(frozen=True)
class ShootOutcome:
    """Where shooting's Newton ended (:meth:`Shooter.solve` / :meth:`Shooter.restart`).

    Attributes
    ----------
    converged : bool
        Whether it converged (else ``reason`` says why not).
    code, reason : int, str
        The outcome (:data:`OUTCOMES`).
    note : int
        A converged orbit's note (:data:`gearsym.engine.newton.NOTES`).
    X : ndarray, shape (segments, nx)
        The last iterate (the orbit's segment start states when converged).
    iterations : int
        Newton steps taken (over restarts).
    residual, relative : float
        ``max |R|`` and ``max |R_i| / scale_i`` at ``X``'s evaluation.
    scale : ndarray
        The state scales of the last evaluation.
    history : list of tuple
        ``(kind, residual, relative, damping, dropped)`` since the start / restart
        (:meth:`gearsym.engine.newton.NewtonCore.history`).
    monodromies : list of ndarray
        The segment monodromies of ``X``'s evaluation (of the iterate before a final step
        added without one, note 2).
    events : EventLog
        The events of that evaluation, all segments.
    message, status, t_reached : str, int, float
        A failed evaluation's message and ``GS_ERR_*`` status (``EVAL_FAILED``: the start's;
        ``STALLED``: the last failed trial's, if any) and where its run stopped.
    multipliers, isolation, g0 : tuple, tuple, ndarray or None
        One converged segment: ``(mu, tolerances, delta)``, ``(sigma, norm, direction)`` in the
        scales ``scale`` and the switching functions at the orbit's start, computed in the
        driver (``None`` where not).
    n_runs : int
        Integrations made by this call.
    verification : VerifyRuns or None
        Converged: the verification runs (``None`` where not made).
    """

    converged: bool
    code: int
    reason: str
    note: int
    X: np.ndarray
    iterations: int
    residual: float
    relative: float
    scale: np.ndarray
    history: list[tuple[str, float, float, float, int]]
    monodromies: list[np.ndarray]
    events: EventLog
    message: str
    status: int
    t_reached: float
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None
    isolation: tuple[float, float, np.ndarray] | None = None
    g0: np.ndarray | None = None
    n_runs: int = 0
    verification: VerifyRuns | None = None

    def error(self) -> EngineError:
        """The engine's error of the failed evaluation (``EVAL_FAILED``), as its run raises it."""
        return error_for_status(int(self.status), self.message, self.t_reached)


class Shooter:
    """Shooting's Newton in C for one set of settings: the iteration's struct
    (:class:`~gearsym.engine.newton.NewtonCore`), the run's and the evaluator's structs and
    buffers, made once (setting up ``ctypes`` structs costs about a sixth of a warm solve).  Kept
    in the engine's thread-local storage (:func:`shooter_for`), so it holds no reference to the
    engine.

    Parameters
    ----------
    engine
        The engine it runs on.
    settings
        Its settings.
    """

    def __init__(self, engine: Engine, settings: ShootSettings):
        st = self.settings = settings
        nx, N = engine.nx, int(st.segments)
        self.nx, self.N = nx, N
        self.core = NewtonCore(engine._lib, ORBIT, N * nx, N * nx,
                               NewtonPolicy(max_iter=int(st.max_iter), min_damping=float(st.min_step), decrease=1e-4,
                                            apply_final_step=True),
                               tol=float(st.tol), nx=nx, segments=N, trunc_level=float(st.trunc_level),
                               scale_floor=float(st.scale_floor), n_anchor=int(st.n_anchor),
                               hist_cap=int(st.max_iter) + 4)
        method, nonlinear = st.codes
        self.x, self.p, self.tout = np.empty(nx), np.empty(engine.np), np.empty(int(st.n_amp))
        self.a, self.buf = engine._prepare(self.x, self.p, 0.0, 1.0, self.tout, method, float(st.rtol),
                                           float(st.atol), None, True, int(st.max_steps), float(st.max_step), 0.0,
                                           0, 0, 0.0, 1, nonlinear)
        self.s = np.empty(N + 1)
        f = self.f = GsOrbitFlow()
        f.s, f.n_amp, f.grid = self.s.ctypes.data, int(st.n_amp), self.tout.ctypes.data
        self.events = _event_buffers(f, int(st.max_events_out))
        self.mult = MultiplierBuffers(f.mult, nx, float(st.rtol))
        self.direction = np.empty(nx)
        f.iso.direction = self.direction.ctypes.data
        self.g0 = np.empty(engine.nsw)
        if engine.nsw:
            f.g0_out = self.g0.ctypes.data
        self.verify_ends = np.empty((N, nx))
        f.verify_ends = self.verify_ends.ctypes.data
        self.fref = C.byref(f)

    def solve(self, engine: Engine, X0: np.ndarray, p: np.ndarray, times: np.ndarray,
              anchor: np.ndarray | None = None) -> ShootOutcome:
        """Newton from the segment start states ``X0`` (segments x nx) over the segment times
        ``times`` (segments + 1) with parameters ``p``; ``anchor``: the anchor rows (n_anchor x
        segments nx) when the settings have them."""
        self.p[:] = _sized("p", p, self.p)
        self.s[:] = _sized("times", times, self.s)
        if self.core.anchor.shape[0]:
            if anchor is None:
                raise EngineInputError(f"this shooter takes {self.core.anchor.shape[0]} anchor rows")
            self.core.anchor[...] = _sized("anchor", anchor, self.core.anchor)
        self.core.start(_sized("X0", X0, self.core.z))
        return self._drive(engine)

    def restart(self, engine: Engine, X: np.ndarray) -> ShootOutcome:
        """Go on from ``X`` (after a relaxation by integration), the steps so far counted."""
        self.core.restart(_sized("X", X, self.core.z))
        return self._drive(engine)

    def _drive(self, engine: Engine) -> ShootOutcome:
        f = self.f
        runs = int(f.n_runs)
        while True:
            engine._call(engine._lib.gs_shoot_ws, self.a, self.core.ref, self.fref)
            if int(f.handback) == _HANDBACK_EVENTS:  # the event log is too small: grow it, same request
                self.events = _event_buffers(f, max(int(f.events_needed), 2 * int(f.ev_cap)))
                continue
            break
        return self._outcome(int(f.n_runs) - runs)

    def _outcome(self, n_runs: int) -> ShootOutcome:
        core, nw, f, nx, N = self.core, self.core.nw, self.f, self.nx, self.N
        converged = core.outcome == CONVERGED
        monos = [core.J[i * nx * nx:(i + 1) * nx * nx].reshape(nx, nx).copy() for i in range(N)]
        one = converged and N == 1
        iso = (float(f.iso.sigma), float(f.iso.norm), self.direction.copy()) if one and int(f.iso.ok) == 1 else None
        g0 = self.g0.copy() if one and (int(f.g0_ok) == 1 or not self.g0.size) else None
        return ShootOutcome(converged, core.outcome, OUTCOMES.get(core.outcome, "unknown"), int(nw.note),
                            core.z.reshape(N, nx).copy(), int(nw.iterations), float(nw.residual), float(nw.relative),
                            core.scale.copy(), core.history(), monos, _events(self.events, int(f.n_events)),
                            core.message, int(nw.eval_status), float(f.t_reached),
                            self.mult.read() if one else None, iso, g0, n_runs, self._verification(converged))

    def _verification(self, converged: bool) -> VerifyRuns | None:
        """The verification runs of a converged orbit (made after its convergence, same call)."""
        f = self.f
        ok = int(f.verify_ok)
        if not converged or ok == 0:
            return None
        X = self.core.z.reshape(self.N, self.nx).copy()
        if ok == 1:
            return VerifyRuns(X, self.verify_ends.copy())
        err = error_for_status(int(f.verify_status), f.verify_msg.decode("utf-8", errors="replace"),
                               float(f.verify_t_reached))
        return VerifyRuns(X, None, str(err))


def shooter_for(engine: Engine, settings: ShootSettings | None = None, **keywords: Any) -> Shooter:
    """The :class:`Shooter` of ``settings`` (or of the keywords, the fields of
    :class:`ShootSettings`) on this thread, made on first use (eight kept per engine and thread).

    Raises
    ------
    ParameterError
        A keyword that is no field of :class:`ShootSettings` (named, with the closest one).
    EngineInputError
        Bad settings.
    """
    if keywords:
        settings = cached_options(ShootSettings, keywords, "shoot_in_c") if settings is None else \
            merge_options(ShootSettings, settings, keywords, "shoot_in_c")
    elif not isinstance(settings, ShootSettings):
        raise EngineInputError(f"shooting in C needs a ShootSettings (or its keywords), got {type(settings).__name__}")
    cache = engine._tls.__dict__.setdefault("shooters", {})
    shooter = cache.get(settings)
    if shooter is None:
        if len(cache) >= 8:
            cache.pop(next(iter(cache)))
        shooter = cache[settings] = Shooter(engine, settings)
    return shooter


def shoot_in_c(engine: Engine, X0: np.ndarray, p: np.ndarray, times: np.ndarray,
               settings: ShootSettings | None = None, *, anchor: np.ndarray | None = None,
               **keywords: Any) -> ShootOutcome:
    """Shooting's Newton for ``phi(s_{i+1}; s_i, X_i) = X_{i+1}`` (cyclically) in one driver call
    (with a converged orbit's verification runs, :attr:`ShootOutcome.verification`).

    Parameters
    ----------
    engine
        The loaded engine (explicit or implicit model).
    X0
        Start of the iteration: the segment start states, shape (segments, nx) (or (nx,) for
        one segment).
    p
        Parameter vector.
    times
        The segment times ``s_0 < ... < s_N`` (segments + 1).
    settings
        The method, tolerances and Newton settings (:class:`ShootSettings`).
    anchor
        Anchor rows (with ``n_anchor`` in the settings).
    **keywords
        The fields of :class:`ShootSettings`, overriding those of ``settings``.

    Returns
    -------
    ShootOutcome
        Also when the iteration did not converge; ``code`` ``EVAL_FAILED`` when the first
        integration failed (:meth:`ShootOutcome.error` is its error).

    Raises
    ------
    EngineInputError
        Arrays of the wrong size, bad settings.
    KeyboardInterrupt
        Ctrl-C during an integration.
    """
    shooter = shooter_for(engine, settings, **keywords)
    N, nx = shooter.N, shooter.nx
    X = np.asarray(X0, dtype=float).reshape(-1)
    pa = np.asarray(p, dtype=float).reshape(-1)
    s = np.asarray(times, dtype=float).reshape(-1)
    if X.shape[0] != N * nx or pa.shape[0] != engine.np or s.shape[0] != N + 1 or not np.all(np.diff(s) > 0):
        raise EngineInputError(f"shooting in C needs X0 of {N} x {nx} states, p of {engine.np} entries and "
                               f"{N + 1} increasing segment times (got {X.shape[0]}, {pa.shape[0]}, {s.shape[0]})")
    return shooter.solve(engine, X, pa, s, anchor)


# ================================================================== the continuation's corrector
@dataclass(frozen=True)
class SampleStats:
    """Statistics of an orbit's samples over one period, the last sample (the first again)
    excluded; first indices of the extrema, as ``numpy.argmax`` / ``argmin`` give them.

    Attributes
    ----------
    max, min, sum_squares : ndarray, shape (nx,)
        Per state.
    argmax, argmin : list of int, length nx
        Per state.
    g_argmin, g_argmax : list of int, length nsw
        Per switching function.
    mesh_argmin, mesh_argmax : list of int, length nmesh
        Per mesh deflection.
    """

    max: np.ndarray
    min: np.ndarray
    sum_squares: np.ndarray
    argmax: list[int]
    argmin: list[int]
    g_argmin: list[int]
    g_argmax: list[int]
    mesh_argmin: list[int]
    mesh_argmax: list[int]


@dataclass(frozen=True)
class OrbitSamples:
    """A periodic orbit sampled at ``n`` evenly spaced times over one period (both ends included).

    Attributes
    ----------
    t : ndarray, shape (n,)
        The times, ``numpy.linspace(t0, t0 + P, n)``.
    y : ndarray, shape (n, nx)
        The states: the same integration as :meth:`gearsym.System.flow` without the monodromy.
    g : ndarray, shape (n, nsw)
        The switching functions at the samples.
    mesh : ndarray, shape (n, nmesh)
        The dynamic deflection of every mesh at the samples (as :meth:`gearsym.System.mesh_deflections`).
    stats : SampleStats or None
        Their statistics, computed in the same C call (``None`` when not).
    """

    t: np.ndarray
    y: np.ndarray
    g: np.ndarray
    mesh: np.ndarray
    stats: SampleStats | None = None


@dataclass(frozen=True)
class CorrectorFlow:
    """The C evaluator of the continuation's shooting residual (``gs_corrector_flow``): what
    stays fixed along a continuation.

    Attributes
    ----------
    engine : Engine
        The build with the parameter derivatives.
    method : str or int
        The integration method (any of the registry's: CVODE, or IDA for implicit models).
    rtol : float
    atol : ndarray
        One absolute tolerance per state.
    max_steps : int
    segments, nd : int
        Shooting segments and unknowns per segment (the differential states).
    periods, t0 : float
        The orbit's forcing periods and phase.
    lam0 : float
    p0, D : ndarray
        ``p(lambda) = p0 + (lambda - lam0) D``.
    n_samples : int
        Samples of a corrected point (one segment; 0: none).
    max_events_out : int
        First capacity of the event log.
    """

    engine: Any
    method: str | int
    rtol: float
    atol: np.ndarray
    max_steps: int
    segments: int
    nd: int
    periods: float
    t0: float
    lam0: float
    p0: np.ndarray
    D: np.ndarray
    n_samples: int = 0
    max_events_out: int = 4096


@dataclass(frozen=True)
class CorrectOutcome:
    """What :meth:`Corrector.__call__` returns.

    Attributes
    ----------
    converged : bool
        Whether the corrector converged (else ``reason``).
    code, reason : int, str
        The outcome (:data:`OUTCOMES`).
    z : ndarray
        The corrected point ``(u, lambda)`` (the last iterate when not converged).
    iterations : int
        Newton steps taken.
    residual, residual_prev : float
        ``max |R_i| / Rs_i`` at ``z`` and before the last step.
    message : str
        A failed evaluation's message.
    by_python : bool
        The evaluation at ``z`` was made by the caller's ``evaluate`` (its record is the
        caller's); else the fields below hold it.
    R, F_u, f_lambda : ndarray or None
        The C evaluation at ``z``.
    monodromies : list of ndarray
        Its segment monodromies (the differential blocks).
    events : EventLog or None
        Its events, all segments.
    period : float
        The forcing period at ``z`` (NaN when not converged or not by C).
    samples : OrbitSamples or None
        One segment, C: the corrected orbit sampled over one period.
    multipliers : tuple or None
        One segment, C: ``(mu, tolerances, delta)`` of the monodromy, unsorted.
    tangent : ndarray or None
        With ``t_ref``: the unit tangent along it at ``z`` (scaled unknowns), where the
        evaluation at ``z`` gave ``F_lambda``.
    n_runs, n_c, n_python : int
        Integrations made in C, evaluations made in C and in Python, by this call.
    """

    converged: bool
    code: int
    reason: str
    z: np.ndarray
    iterations: int
    residual: float
    residual_prev: float
    message: str
    by_python: bool
    R: np.ndarray | None = None
    F_u: np.ndarray | None = None
    f_lambda: np.ndarray | None = None
    monodromies: list[np.ndarray] = field(default_factory=list)
    events: EventLog | None = None
    period: float = float("nan")
    samples: OrbitSamples | None = None
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None
    tangent: np.ndarray | None = None
    n_runs: int = 0
    n_c: int = 0
    n_python: int = 0


#: What a Python evaluation gives the corrector: ``(R, F_u, F_lambda or None, anchor rows or None)``.
Evaluated = tuple[np.ndarray, np.ndarray, "np.ndarray | None", "np.ndarray | None"]


class Corrector:
    """The continuation's corrector: THE Newton iteration (corrector kind) with its struct and
    buffers made once per continuation, and the C evaluator of the shooting residual where
    given (``flow``); the caller's ``evaluate`` answers what that does not.

    Parameters
    ----------
    engine
        An engine of the system (its build carries the iteration); with ``flow``, its engine.
    nr
        The unknowns of the residual (the iteration's are ``nr + 1``: with lambda).
    tol, max_iter, min_damping
        The convergence tolerance, the Newton steps allowed, the smallest damping (the step is
        halved from 1 while the scaled residual does not decrease, the last one taken anyway;
        the divergence test stops when it fell by less than 10 % above ``100 tol``).
    n_anchor
        Anchor rows (0: none).
    flow
        The C evaluator's settings, or ``None`` (every evaluation by ``evaluate``).
    """

    def __init__(self, engine: Engine, nr: int, *, tol: float, max_iter: int, min_damping: float = 0.125,
                 n_anchor: int = 0, flow: CorrectorFlow | None = None):
        if flow is not None:
            engine = flow.engine
        self.engine, self.nr, self.flow = engine, int(nr), flow
        policy = NewtonPolicy(max_iter=int(max_iter), min_damping=float(min_damping), decrease=0.0,
                              accept_below=float(tol), accept_last=True, diverge=(0.9, 100.0 * float(tol)))
        self.core = NewtonCore(engine._lib, CORRECTOR, self.nr + 1, self.nr, policy, tol=float(tol),
                               n_anchor=int(n_anchor))
        if flow is not None:
            self._setup_flow(engine, flow)

    def _setup_flow(self, engine: Engine, fl: CorrectorFlow) -> None:
        if not hasattr(engine._lib, "gs_correct_ws"):
            raise EngineInputError("the corrector's C evaluator needs a build with gs_correct_ws")
        nx, nd, N = engine.nx, int(fl.nd), int(fl.segments)
        if nd != nx - engine.nalg or self.nr != N * nd:
            raise EngineInputError(f"the corrector's C evaluator needs nd = {nx - engine.nalg} differential states "
                                   f"per segment and {N} x nd unknowns (got nd={nd}, nr={self.nr})")
        self.p0 = np.array(fl.p0, dtype=float).reshape(-1)
        self.D = np.array(fl.D, dtype=float).reshape(-1)
        self.atol = np.array(np.broadcast_to(np.asarray(fl.atol, float), (nx,)))
        if int(fl.max_events_out) < 1:
            raise EngineInputError(f"the corrector's C evaluator needs max_events_out >= 1 (got {fl.max_events_out})")
        if self.p0.shape[0] != engine.np or self.D.shape[0] != engine.np:
            raise EngineInputError(f"p0 and D need {engine.np} entries (got {self.p0.shape[0]}, {self.D.shape[0]})")
        code, nonlinear = c_method(fl.method)
        sens = (self.D, 1, None, None, False)
        self.a, self.buf = engine._prepare(np.zeros(nx), self.p0, float(fl.t0), float(fl.t0) + 1.0, np.empty(0),
                                           code, float(fl.rtol), float(np.min(self.atol)), None, True,
                                           int(fl.max_steps), 0.0, 0.0, 0, 0, 0.0, int(fl.max_events_out),
                                           nonlinear, 0, None, sens)  # (its event log: the samples' run)
        self.Ms = np.zeros((N, nd, nd))
        f = self.f = GsCorrectorFlow()
        f.segments, f.nd, f.periods, f.t0, f.lam0 = N, nd, float(fl.periods), float(fl.t0), float(fl.lam0)
        f.p0 = self.p0.ctypes.data if self.p0.size else None
        f.D, f.atol, f.Ms = self.D.ctypes.data, self.atol.ctypes.data, self.Ms.ctypes.data
        self.events = _event_buffers(f, int(fl.max_events_out))
        self.mult = MultiplierBuffers(f.mult, nd, float(fl.rtol))
        self.n_samples = n_s = int(fl.n_samples) if int(fl.n_samples) >= 2 and N == 1 else 0
        if n_s:
            nsw = engine.nsw
            self.ts, self.Ys = np.empty(n_s), np.empty((n_s, nx))
            self.Gs, self.Hs = np.empty((n_s, nsw)), np.empty((n_s, max(engine.n_meshes(), 0)))
            self.stats = np.empty(3 * nx)
            self.args = np.empty(2 * nx + 2 * nsw + 2 * self.Hs.shape[1], dtype=np.intc)
            f.n_samples, f.t_samples, f.Y_samples = n_s, self.ts.ctypes.data, self.Ys.ctypes.data
            f.G_samples = self.Gs.ctypes.data if self.Gs.size else None
            f.H_samples = self.Hs.ctypes.data if self.Hs.size else None
            f.col_stats, f.col_args = self.stats.ctypes.data, self.args.ctypes.data
        self.fref = C.byref(f)

    def __call__(self, z: np.ndarray, row: np.ndarray, target: float, S: np.ndarray, Rs: np.ndarray, *,
                 t_ref: np.ndarray | None = None, anchor: np.ndarray | None = None,
                 zalg: np.ndarray | None = None,
                 evaluate: Callable[[np.ndarray, bool], Evaluated] | None = None) -> CorrectOutcome:
        """Correct ``z`` onto ``F = 0``, ``row . (z / S) = target``.

        Parameters
        ----------
        z, row, target, S, Rs
            The start ``(u, lambda)``, the constraint row and its target, the scales of the
            unknowns and of the residual rows.
        t_ref
            The reference direction of the point's tangent, or ``None``.
        anchor
            The anchor rows (in the scaled unknowns) when the corrector has them.
        zalg
            A DAE's algebraic variables at the segment starts (segments x nalg, float64,
            C-contiguous), updated in place by the C evaluator.
        evaluate
            ``evaluate(z_eval, first) -> (R, F_u, F_lambda or None, anchor or None)`` for the
            requests the C evaluator does not answer (all of them without ``flow``); raises
            :class:`~gearsym.errors.GearsymError` when the evaluation fails (raised on when the
            iteration cannot go on without it: the start, the last damped trial).

        Returns
        -------
        CorrectOutcome
        """
        core, nw = self.core, self.core.nw
        n = self.nr + 1
        for name, dst, src in (("z", core.z, z), ("row", core.row, row), ("S", core.S, S), ("Rs", core.Rs, Rs)):
            if np.shape(src) != dst.shape:
                raise EngineInputError(f"{name} has {np.size(src)} entries, the corrector needs {dst.size}")
        core.row[:] = row
        core.S[:] = S
        core.Rs[:] = Rs
        nw.target = float(target)
        if t_ref is not None:
            core.t_ref[:] = _sized("t_ref", t_ref, core.t_ref)
            nw.t_ref = core.t_ref.ctypes.data
        else:
            nw.t_ref = None
        if core.anchor.shape[0]:
            if anchor is None:
                raise EngineInputError(f"this corrector takes {core.anchor.shape[0]} anchor rows")
            core.anchor[...] = _sized("anchor", anchor, core.anchor)
        if self.flow is not None:
            self.f.zalg = self._zalg(zalg)
        if evaluate is None and self.flow is None:
            raise EngineInputError("a corrector without the C evaluator needs evaluate")
        core.start(np.asarray(z, float))
        runs0, c0 = (int(self.f.n_runs), int(self.f.n_evals)) if self.flow is not None else (0, 0)
        py_id, n_py = -1, 0
        while True:
            if self.flow is not None:
                self.engine._call(self.engine._lib.gs_correct_ws, self.a, core.ref, self.fref)
                if int(self.f.handback) == _HANDBACK_EVENTS:
                    self.events = _event_buffers(self.f, max(int(self.f.events_needed), 2 * int(self.f.ev_cap)))
                    continue
            if core.done:
                break
            if core.pending:
                if evaluate is None:
                    raise EngineInputError("the corrector's C evaluator handed a request back and there is no "
                                           "evaluate")
                self._answer(evaluate, nw.n_evals == 1)
                py_id, n_py = int(nw.n_evals), n_py + 1
            if self.flow is None:
                core.next()
        return self._outcome(n, py_id == int(nw.n_evals), n_py, runs0, c0)

    def _zalg(self, zalg: np.ndarray | None) -> int | None:
        """The address of a DAE's algebraic variables at the segment starts for the C evaluator
        (which reads and writes ``segments * nalg`` doubles there), checked; ``None`` without
        algebraic variables.  Never kept from an earlier call (that array may be gone)."""
        nalg = self.engine.nx - int(self.f.nd)
        if nalg == 0:
            return None
        shape = (int(self.f.segments), nalg)
        if not (isinstance(zalg, np.ndarray) and zalg.dtype == np.float64 and zalg.flags.c_contiguous
                and zalg.flags.writeable and zalg.size == shape[0] * nalg):
            got = "None" if zalg is None else f"{type(zalg).__name__} {getattr(zalg, 'shape', '')} " \
                f"{getattr(zalg, 'dtype', '')}"
            raise EngineInputError(f"zalg: the corrector of a DAE needs its algebraic variables at the segment starts "
                                   f"as a writeable C-contiguous float64 array of shape {shape} (got {got})")
        return zalg.ctypes.data

    def _answer(self, evaluate: Callable[[np.ndarray, bool], Evaluated], first: bool) -> None:
        core = self.core
        try:
            R, Fu, Flam, anchor = evaluate(core.z_eval.copy(), first)
        except GearsymError as exc:
            if core.nw.must_succeed:
                raise
            core.answer_failed(str(exc))
            return
        core.answer(R, Fu, Flam, anchor)

    def _outcome(self, n: int, by_python: bool, n_py: int, runs0: int, c0: int) -> CorrectOutcome:
        core, nw = self.core, self.core.nw
        converged = core.outcome == CONVERGED
        tangent = core.tangent.copy() if converged and nw.t_ref and int(nw.tangent_ok) == 1 else None
        base = dict(converged=converged, code=core.outcome, reason=OUTCOMES.get(core.outcome, "unknown"),
                    z=core.z.copy(), iterations=int(nw.iterations), residual=float(nw.residual),
                    residual_prev=float(nw.residual_prev), message=core.message, by_python=by_python,
                    tangent=tangent, n_python=n_py)
        if self.flow is None:
            return CorrectOutcome(**base)
        f = self.f
        base.update(n_runs=int(f.n_runs) - runs0, n_c=int(f.n_evals) - c0)
        if by_python or not converged:
            return CorrectOutcome(**base)
        return CorrectOutcome(**base, R=core.R.copy(), F_u=core.J.copy(), f_lambda=core.Flam.copy(),
                              monodromies=[M.copy() for M in self.Ms], events=_events(self.events, int(f.n_events)),
                              period=float(f.period), samples=self._samples(),
                              multipliers=self.mult.read() if self.Ms.shape[0] == 1 else None)

    def _samples(self) -> OrbitSamples | None:
        f, engine = self.f, self.engine
        if not self.n_samples or int(f.samples_ok) != 1:
            return None
        st = None
        if int(f.stats_ok) == 1:
            nx, nsw, nm = engine.nx, engine.nsw, self.Hs.shape[1]
            stats, args = self.stats.copy(), self.args.tolist()
            g, h = 2 * nx, 2 * nx + 2 * nsw
            st = SampleStats(stats[:nx], stats[nx:2 * nx], stats[2 * nx:], args[:nx], args[nx:g],
                             args[g:g + nsw], args[g + nsw:h], args[h:h + nm], args[h + nm:])
        return OrbitSamples(self.ts.copy(), self.Ys.copy(), self.Gs.copy(), self.Hs.copy(), st)

    def tangent(self, Fu: np.ndarray, Flam: np.ndarray, t_ref: np.ndarray, S: np.ndarray, Rs: np.ndarray,
                anchor: np.ndarray | None = None) -> np.ndarray | None:
        """The unit tangent along ``t_ref`` at ``[F_u, F_lambda]`` by the iteration's own rule
        (:meth:`~gearsym.engine.newton.NewtonCore.tangent_at`)."""
        out = self.core.tangent_at(Fu, Flam, t_ref, S, Rs, anchor)
        self.core.nw.t_ref = None
        return out


def correct_in_c(engine: Engine, z: np.ndarray, row: np.ndarray, target: float, S: np.ndarray, Rs: np.ndarray, *,
                 t_ref: np.ndarray | None = None, tol: float, max_iter: int, min_damping: float = 0.125,
                 **flow: Any) -> CorrectOutcome:
    """The continuation's pseudo-arclength corrector on the single-shooting residual of an ODE,
    evaluated in C, in one driver call (a :class:`Corrector` made for it; a continuation keeps
    one and calls it at every point).

    Parameters
    ----------
    engine
        The engine with the parameter derivatives.
    z, row, target, S, Rs
        The start ``(x, lambda)``, the arclength row and its target, the scales.
    t_ref
        A reference direction for the tangent (``nx + 1`` entries), or ``None``.
    tol, max_iter, min_damping
        The iteration's settings.
    **flow
        The fields of :class:`CorrectorFlow` but ``engine``, ``segments`` and ``nd`` (``method``,
        ``rtol``, ``atol``, ``max_steps``, ``periods``, ``t0``, ``lam0``, ``p0``, ``D``, ``n_samples``).

    Returns
    -------
    CorrectOutcome
    """
    nd = engine.nx - engine.nalg
    fl = CorrectorFlow(engine=engine, segments=1, nd=nd, **flow)
    return Corrector(engine, nd, tol=tol, max_iter=max_iter, min_damping=min_damping, flow=fl)(
        z, row, target, S, Rs, t_ref=t_ref)
