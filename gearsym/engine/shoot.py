"""Newton's method for a periodic orbit, and the continuation's corrector, in one C call each.

:func:`shoot_in_c` runs the full-step Newton iteration of single shooting inside the
driver: one integration with the monodromy per iterate, the step from an LU solve of
``M - I`` in the variables scaled by the orbit's state magnitudes, the convergence tests
of :func:`gearsym.analysis.periodic.shoot`.  Where that function would do more than a
full step (damping, a truncated solve of a nearly singular matrix, a failed trial run,
the iteration budget) the C iteration gives up and says why; the caller then runs its
own iteration from its own start, so the outcome never differs from the Python path's
except by round-off.
"""

from __future__ import annotations

import ctypes as C
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError
from ..integrators import by_code, get_method
from ..options import cached_options, merge_options
from .driver import EventLog
from .errors import EngineInputError
from .sim_args import GsShootArgs

if TYPE_CHECKING:  # pragma: no cover
    from .driver import Engine, RunResult

__all__ = ["MAX_STATES", "OUTCOMES", "CorrectOutcome", "Corrector", "OrbitSamples", "SampleStats", "ShootOutcome",
           "ShootSettings", "Shooter", "c_method", "correct_in_c", "shoot_in_c"]

#: Largest model the C iterations take (``GS_SHOOT_MAXN`` in gs_internal.h); larger ones iterate in Python.
MAX_STATES = 256

#: ``gs_shoot_args.outcome`` codes (gs_driver.h) -> meaning.
OUTCOMES: dict[int, str] = {
    0: "converged",
    1: "the residual did not decrease (a full shooting step; the corrector's divergence test)",
    2: "the iteration budget is spent",
    3: "the Newton matrix is nearly singular",
    4: "an integration after the first failed",
    5: "more events than the event log holds",
    6: "a non-finite residual",
}


def _check_sizes(engine: Engine, **arrays: tuple[np.ndarray, int]) -> None:
    """Every array has the length the C side reads (a wrong one would be read out of bounds)."""
    for name, (a, n) in arrays.items():
        if a.shape[0] != n:
            raise EngineInputError(f"{name} has {a.shape[0]} entries, the C iteration needs {n} "
                                   f"(model: nx={engine.nx}, np={engine.np})")


@dataclass(frozen=True)
class ShootOutcome:
    """What :func:`shoot_in_c` returns.

    Attributes
    ----------
    converged : bool
        Whether the C iteration converged (else ``reason`` says why it gave up).
    reason : str
        :data:`OUTCOMES` entry.
    x : ndarray
        The last iterate (the orbit's state at ``t0`` when converged).
    run : RunResult or None
        The last evaluation (x_final, monodromy, events, samples) when converged.
    scale : ndarray
        The state scales of the last evaluation.
    history_abs, history_rel : ndarray
        ``max |R|`` and ``max |R_i| / scale_i`` of each evaluation.
    iterations : int
        Newton steps taken.
    note : int
        0: residual <= tol; 1: a full step below ``tol`` with the residual below ``100 tol``;
        2: a last step below ``10 tol`` applied without integrating again.
    code : int
        The outcome code (:data:`OUTCOMES`).  When the iteration gave up after ``iterations``
        accepted full steps, ``x`` is the last accepted iterate.
    multipliers : tuple or None
        ``(mu, tolerances, delta)`` of ``run.monodromy`` when converged, as
        :func:`gearsym.analysis.periodic.multiplier_tolerances` returns them (computed in the
        driver with scipy's LAPACK; ``None`` where that was not possible).
    isolation : tuple or None
        ``(sigma, norm, direction)`` of the converged orbit in the scales ``scale``, as
        :func:`gearsym.analysis.periodic.isolation` computes them without trivial
        directions (``norm``: the 2-norm of the scaled monodromy, from which the caller
        takes the error level); ``None`` where the driver could not compute them.
    g0 : ndarray or None
        The switching functions at ``(t0, x)`` of the converged orbit (``gs_eval``'s values);
        ``None`` when not converged or not computed.
    events, monodromy : EventLog or None, ndarray or None
        The converged orbit's events and monodromy (also without ``run``).
    """

    converged: bool
    reason: str
    x: np.ndarray
    run: RunResult | None
    scale: np.ndarray
    history_abs: np.ndarray
    history_rel: np.ndarray
    iterations: int
    note: int
    code: int = 0
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None
    isolation: tuple[float, float, np.ndarray] | None = None
    g0: np.ndarray | None = None
    events: EventLog | None = None
    monodromy: np.ndarray | None = None


@dataclass(frozen=True)
class ShootSettings:
    """The settings of :func:`shoot_in_c` (one :class:`Shooter`, its buffers made once, per
    settings and thread).

    Parameters
    ----------
    method
        An integration method that runs the shooting Newton in C
        (:func:`gearsym.integrators.supports_c_shooting`), by name, or its ``GS_METHOD_*``
        code (:data:`gearsym.engine.driver.METHODS`).
    rtol, atol, max_step, max_steps
        Integration settings (scalar tolerances; the variational equations use them too).
    tol, scale_floor, pivot_tol, max_iter
        See ``gs_shoot_args`` in gs_driver.h.
    max_events_out
        Capacity of the event log (the iteration gives up if a run has more).

    Raises
    ------
    EngineInputError
        An unknown method, one without the Newton in C, or ``max_iter < 0``.
    """

    method: str | int
    rtol: float
    atol: float
    max_step: float
    max_steps: int
    tol: float
    scale_floor: float
    pivot_tol: float
    max_iter: int
    max_events_out: int = 4096
    codes: tuple[int, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "codes", c_method(self.method, "shooting", "c_shooting"))
        if int(self.max_iter) < 0:
            raise EngineInputError(f"shooting in C needs max_iter >= 0, got {self.max_iter}")


def c_method(method: str | int, what: str, flag: str) -> tuple[int, int]:
    """``(GS_METHOD_* code, GS_NONLIN_* code)`` of an integration method that runs ``what`` in C
    (the registry's ``flag``: ``"c_shooting"``, ``"c_corrector"``), given by name or by code.

    Raises
    ------
    EngineInputError
        An unknown method, or one that does not run ``what`` in C.
    """
    try:
        m = by_code(int(method)) if isinstance(method, (int, np.integer)) else get_method(method)
        nonlinear = m.nonlinear_code()
    except ParameterError as exc:
        raise EngineInputError(str(exc)) from None
    if not getattr(m, flag):
        raise EngineInputError(f"the {what} in C does not run with method '{m.name}'")
    return m.code, nonlinear


def shoot_in_c(engine: Engine, x0: np.ndarray, p: np.ndarray, t0: float, t1: float, grid: np.ndarray,
               settings: ShootSettings | None = None, *, want_run: bool = True, **keywords: Any) -> ShootOutcome:
    """Single-shooting Newton for ``x(t1; t0, x) = x`` in one driver call.

    Parameters
    ----------
    engine
        The loaded engine (explicit model).
    x0
        Start of the iteration, shape (nx,).
    p
        Parameter vector (C-contiguous float64).
    t0, t1
        The orbit's span.
    grid
        Sample times in ``[t0, t1]`` (>= 2) whose state magnitudes are the scales.
    settings
        The method, tolerances and Newton settings (:class:`ShootSettings`).
    want_run
        ``False``: the outcome's ``run`` is ``None`` (its ``events`` and ``monodromy`` are
        still given).
    **keywords
        The fields of :class:`ShootSettings` (``method=..., rtol=..., ...``), overriding those
        of ``settings``.

    Returns
    -------
    ShootOutcome

    Raises
    ------
    EngineError
        The first integration failed (a subclass per failure, as :meth:`Engine.run`).
    ParameterError
        A keyword that is no field of :class:`ShootSettings` (named, with the closest one).
    KeyboardInterrupt
        Ctrl-C during an integration.
    """
    if keywords:
        settings = cached_options(ShootSettings, keywords, "shoot_in_c") if settings is None else \
            merge_options(ShootSettings, settings, keywords, "shoot_in_c")
    elif not isinstance(settings, ShootSettings):
        raise EngineInputError(f"shoot_in_c needs a ShootSettings (or its keywords), got {type(settings).__name__}")
    if engine.implicit or engine.nalg or not hasattr(engine._lib, "gs_shoot_ws"):
        raise EngineInputError("shooting in C needs an explicit model built with this gearsym")
    nx = engine.nx
    xa = np.asarray(x0, dtype=float).reshape(-1)
    tout = np.asarray(grid, dtype=float).reshape(-1)
    p = np.asarray(p, dtype=float).reshape(-1)
    _check_sizes(engine, x0=(xa, nx), p=(p, engine.np))
    if tout.shape[0] < 2 or nx > MAX_STATES:
        raise EngineInputError(f"shooting in C needs >= 2 sample times, nx <= {MAX_STATES} and max_iter >= 0")
    key = (settings, tout.shape[0])
    # one Shooter per settings and thread (its buffers are reused; the workspace is per thread too)
    cache = engine._tls.__dict__.setdefault("shooters", {})
    shooter = cache.get(key)
    if shooter is None:
        if len(cache) >= 8:
            cache.pop(next(iter(cache)))
        shooter = cache[key] = Shooter(engine, settings, tout.shape[0])
    return shooter(engine, xa, p, float(t0), float(t1), tout, want_run)


class Shooter:
    """The driver's argument structs and buffers of :func:`shoot_in_c` for one set of settings,
    made once (building the ``ctypes`` structs and buffer addresses of a call cost about a
    sixth of a warm orbit solve's time outside C).  Kept in the engine's thread-local storage,
    so it holds no reference to the engine (no cycle keeps an engine's workspaces alive).

    Parameters
    ----------
    engine
        The engine it runs on.
    settings
        Its settings.
    n_grid
        The number of sample times.
    """

    def __init__(self, engine: Engine, settings: ShootSettings, n_grid: int):
        st = settings
        nx = self.nx = engine.nx
        method, nonlinear = st.codes
        max_iter = int(st.max_iter)
        self.x, self.p, self.tout = np.empty(nx), np.empty(engine.np), np.empty(n_grid)
        self.a, self.buf = engine._prepare(self.x, self.p, 0.0, 1.0, self.tout, method, float(st.rtol),
                                           float(st.atol), None, True, int(st.max_steps), float(st.max_step), 0.0,
                                           0, 0, 0.0, int(st.max_events_out), nonlinear)
        self.scale, self.h_abs, self.h_rel = np.empty(nx), np.empty(max_iter + 1), np.empty(max_iter + 1)
        self.direction = np.empty(nx)
        s = self.s = GsShootArgs()
        s.tol, s.scale_floor, s.pivot_tol, s.max_iter = float(st.tol), float(st.scale_floor), float(st.pivot_tol), \
            max_iter
        s.x, s.scale = self.x.ctypes.data, self.scale.ctypes.data
        s.hist_abs, s.hist_rel = self.h_abs.ctypes.data, self.h_rel.ctypes.data
        self.mult = MultiplierBuffers(s.mult, nx, float(st.rtol))  # the converged orbit's multipliers in the same call
        s.iso.direction = self.direction.ctypes.data  # and its isolation
        self.g0 = np.empty(engine.nsw)
        if engine.nsw:  # and the switching functions at its start
            s.g0_out = self.g0.ctypes.data

    def __call__(self, engine: Engine, x0: np.ndarray, p: np.ndarray, t0: float, t1: float, tout: np.ndarray,
                 want_run: bool = True) -> ShootOutcome:
        """One iteration from ``x0`` on ``engine`` (the one it was made for; sizes checked by
        :func:`shoot_in_c`); the outcome's arrays are its own copies."""
        a, s, buf = self.a, self.s, self.buf
        self.x[:] = x0
        self.p[:] = p
        self.tout[:] = tout
        a.t0, a.t_end = t0, t1
        a.n_events = 0
        engine._call(engine._lib.gs_shoot_ws, a, C.byref(s))
        n = int(s.n_hist)
        converged = int(s.outcome) == 0
        run = events = mono = None
        if converged:
            n_ev = int(a.n_events)
            if n_ev > buf["cap"]:  # the event log overflowed (the C side gives up first; kept for safety)
                converged = False
            elif want_run:
                run = engine._result(a, buf, copy=True)
                events, mono = run.events, run.monodromy
            else:
                events = EventLog(t=buf["ev_t"][:n_ev].copy(), surface=buf["ev_s"][:n_ev].astype(int),
                                  direction=buf["ev_d"][:n_ev].astype(int), speed=buf["ev_v"][:n_ev].copy())
                mono = buf["mono"].copy()
        multipliers = self.mult.read() if converged else None
        iso = (float(s.iso.sigma), float(s.iso.norm), self.direction.copy()) \
            if converged and int(s.iso.ok) == 1 else None
        g0 = self.g0.copy() if converged and (int(s.g0_ok) == 1 or not self.g0.size) else None
        return ShootOutcome(converged, OUTCOMES.get(int(s.outcome), "unknown"), self.x.copy(), run,
                            self.scale.copy(), self.h_abs[:n].copy(), self.h_rel[:n].copy(), int(s.iterations),
                            int(s.note), int(s.outcome), multipliers, iso, g0, events, mono)


@dataclass(frozen=True)
class CorrectOutcome:
    """What :func:`correct_in_c` returns.

    Attributes
    ----------
    converged : bool
        Whether the C corrector converged (else ``reason`` says why it gave up).
    reason : str
        :data:`OUTCOMES` entry.
    z : ndarray
        The corrected point ``(x, lambda)`` (the last iterate when not converged).
    R, monodromy, f_lambda : ndarray
        Residual, monodromy and ``F_lambda`` at ``z``.
    run : RunResult or None
        The run at ``z`` (its event log) when converged.
    residual : float
        ``max |R_i| / Rs_i``.
    iterations, n_runs : int
        Newton steps taken and integrations made.
    code : int
        The outcome code (:data:`OUTCOMES`).
    samples : OrbitSamples or None
        The corrected orbit sampled over one period, when asked for and obtained.
    tangent : ndarray or None
        With ``t_ref``: the solution ``t`` of ``[J_s; t_ref] t = e_n`` at ``z`` (``J_s`` the
        scaled ``[F_u, F_lambda]``), unnormalised; ``None`` when not asked for or singular.
    period : float
        The forcing period ``T(p(lambda))`` at ``z`` (NaN when not converged).
    events : EventLog or None
        The event log of the run at ``z`` when converged (also ``run.events``).
    multipliers : tuple or None
        ``(mu, tolerances, delta)`` of the monodromy at ``z``, unsorted, as
        :func:`gearsym.analysis.periodic.multiplier_tolerances` returns them (computed in the
        driver with scipy's LAPACK; ``None`` where that was not possible).
    """

    converged: bool
    reason: str
    z: np.ndarray
    R: np.ndarray
    monodromy: np.ndarray
    f_lambda: np.ndarray
    run: RunResult | None
    residual: float
    iterations: int
    n_runs: int
    code: int = 0
    samples: OrbitSamples | None = None
    tangent: np.ndarray | None = None
    period: float = float("nan")
    events: EventLog | None = None
    multipliers: tuple[np.ndarray, np.ndarray, float] | None = None


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


def correct_in_c(engine: Engine, z: np.ndarray, row: np.ndarray, target: float, S: np.ndarray, Rs: np.ndarray, *,
                 t_ref: np.ndarray | None = None, **corrector_args: Any) -> CorrectOutcome:
    """The continuation's pseudo-arclength corrector for single shooting in one driver call.

    ``F(x, lambda) = phi(t0 + P(lambda); t0, x, p(lambda)) - x`` with ``p(lambda) = p0 +
    (lambda - lam0) D`` and ``P = periods * T(p)``, plus ``row . (z / S) = target``; see
    ``gs_correct_args`` in gs_driver.h and :meth:`gearsym.analysis.continuation._corrector.Continuer.correct`,
    whose iteration it mirrors.  ``engine`` must be a build with the parameter derivatives.
    With ``n_samples >= 2`` the converged orbit is also sampled (:class:`OrbitSamples`) in the
    same call; ``samples`` is ``None`` when that run failed.  With ``t_ref`` (``nx + 1``
    entries) the point's unnormalised tangent along it comes back too (``tangent``).
    One call of a :class:`Corrector` made for it (a continuation keeps one and calls it at
    every point).

    Parameters
    ----------
    engine
        The engine with the parameter derivatives.
    z, row, target, S, Rs
        The start ``(x, lambda)``, the arclength row and its target, the scales of the
        unknowns and of the residual (see :meth:`Corrector.__call__`).
    t_ref
        A reference direction for the tangent (``nx + 1`` entries), or ``None``.
    **corrector_args
        The keywords of :class:`Corrector` (``tol``, ``max_iter``, ``min_damping``, ``periods``,
        ``lam0``, ``p0``, ``D``, ``atol``, ``t0``, ``method``, ``rtol``, ``max_steps``,
        ``max_events_out``, ``n_samples``).

    Returns
    -------
    CorrectOutcome

    Raises
    ------
    EngineInputError
        An engine without the corrector or the derivatives, a method without the corrector in
        C, or arrays of the wrong size.
    KeyboardInterrupt
        Ctrl-C during an integration.
    """
    return Corrector(engine, **corrector_args)(z, row, target, S, Rs, t_ref=t_ref)


_LAPACK: dict[str, int] | None = None


_LAPACK_ROUTINES = ("dgebal", "dgesdd", "dgeev", "dgelsd")


def lapack_pointers() -> dict[str, int]:
    """Addresses of scipy's ``cython_lapack`` ``dgebal``, ``dgesdd``, ``dgeev`` and ``dgelsd`` (C
    functions with Fortran's by-reference arguments), for the driver's multipliers, isolation
    and anchored least squares; empty if unavailable."""
    global _LAPACK
    if _LAPACK is None:
        out: dict[str, int] = {}
        try:
            from scipy.linalg import cython_lapack

            get_name, get_ptr = C.pythonapi.PyCapsule_GetName, C.pythonapi.PyCapsule_GetPointer
            get_name.restype, get_name.argtypes = C.c_char_p, [C.py_object]
            get_ptr.restype, get_ptr.argtypes = C.c_void_p, [C.py_object, C.c_char_p]
            for name in _LAPACK_ROUTINES:
                cap = cython_lapack.__pyx_capi__[name]
                out[name] = int(get_ptr(cap, get_name(cap)))
        except Exception:  # noqa: BLE001 - the multipliers are then computed in Python
            out = {}
        _LAPACK = out if len(out) == len(_LAPACK_ROUTINES) and all(out.values()) else {}
    return _LAPACK


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


class Corrector:
    """The arguments of :func:`correct_in_c` that stay fixed along a continuation, with the
    driver's argument structs and buffers made once (setting up the ``ctypes`` structs and
    buffer addresses of a call cost about a fifth of the corrector's time outside C)."""

    def __init__(self, engine: Engine, *, tol: float, max_iter: int, min_damping: float, periods: float, lam0: float,
                 p0: np.ndarray, D: np.ndarray, atol: float, t0: float, method: int, rtol: float, max_steps: int,
                 max_events_out: int = 4096, n_samples: int = 0, n_anchor: int = 0):
        if engine.implicit or engine.nalg or not hasattr(engine._lib, "gs_correct_ws"):
            raise EngineInputError("the corrector in C needs an explicit model built with this gearsym")
        from .sim_args import GsCorrectArgs

        nx, nsw = engine.nx, engine.nsw
        self.engine, self.nx = engine, nx
        self.p0 = np.array(p0, dtype=float).reshape(-1)
        self.D = np.array(D, dtype=float).reshape(-1)
        _check_sizes(engine, p0=(self.p0, engine.np), D=(self.D, engine.np))
        if nx > MAX_STATES or engine.np > MAX_STATES or int(max_iter) < 0:
            raise EngineInputError(f"the corrector in C needs nx, np <= {MAX_STATES} and max_iter >= 0")
        # inputs copied in at every call, outputs read out
        self.z, self.row, self.S, self.t_ref = (np.empty(nx + 1) for _ in range(4))
        self.Rs, self.R, self.Fl = np.empty(nx), np.empty(nx), np.empty(nx)
        self.M = np.empty((nx, nx))
        self.tangent = np.empty(nx + 1)
        sens = (self.D, 1, None, None, False)
        code, nonlinear = c_method(method, "corrector", "c_corrector")
        self.a, self.buf = engine._prepare(np.zeros(nx), self.p0, float(t0), float(t0) + 1.0, np.empty(0),
                                           code, float(rtol), float(atol), None, True, int(max_steps), 0.0,
                                           0.0, 0, 0, 0.0, int(max_events_out), nonlinear, 0, None, sens)
        c = self.c = GsCorrectArgs()
        c.nx = nx
        c.z, c.row, c.S, c.Rs = self.z.ctypes.data, self.row.ctypes.data, self.S.ctypes.data, self.Rs.ctypes.data
        c.tol, c.max_iter, c.min_damping, c.periods = float(tol), int(max_iter), float(min_damping), float(periods)
        c.lam0, c.p0, c.D, c.atol = float(lam0), self.p0.ctypes.data if self.p0.size else None, self.D.ctypes.data, \
            float(atol)
        c.R_out, c.M_out, c.Flam_out = self.R.ctypes.data, self.M.ctypes.data, self.Fl.ctypes.data
        self._t_ref_ptr, self._tangent_ptr = self.t_ref.ctypes.data, self.tangent.ctypes.data
        self.mult = MultiplierBuffers(c.mult, nx, rtol)  # the converged point's multipliers
        self.anchor = np.zeros((int(n_anchor), nx + 1))
        if n_anchor:  # rigid-body modes: the anchored least-squares steps (dgelsd)
            lap = lapack_pointers()
            if not lap or not 1 <= int(n_anchor) <= nx:
                raise EngineInputError("anchor rows need scipy's LAPACK and 1 <= n_anchor <= nx")
            c.n_anchor, c.anchor, c.lapack_dgelsd = int(n_anchor), self.anchor.ctypes.data, lap["dgelsd"]
        self.n_samples = n_s = int(n_samples) if int(n_samples) >= 2 else 0
        if n_s:
            self.ts, self.Ys = np.empty(n_s), np.empty((n_s, nx))
            self.Gs, self.Hs = np.empty((n_s, nsw)), np.empty((n_s, max(engine.n_meshes(), 0)))
            self.stats = np.empty(3 * nx)
            self.args = np.empty(2 * nx + 2 * nsw + 2 * self.Hs.shape[1], dtype=np.intc)
            c.n_samples, c.t_samples, c.Y_samples = n_s, self.ts.ctypes.data, self.Ys.ctypes.data
            c.G_samples = self.Gs.ctypes.data if self.Gs.size else None
            c.H_samples = self.Hs.ctypes.data if self.Hs.size else None
            c.col_stats, c.col_args = self.stats.ctypes.data, self.args.ctypes.data

    def __call__(self, z: np.ndarray, row: np.ndarray, target: float, S: np.ndarray, Rs: np.ndarray, *,
                 t_ref: np.ndarray | None = None, want_run: bool = True,
                 anchor: np.ndarray | None = None) -> CorrectOutcome:
        """Correct ``z`` (see :func:`correct_in_c`); the outcome's arrays are its own copies.
        ``want_run=False``: no ``run`` (its ``events`` only).  ``anchor``: the ``n_anchor`` rows
        (in the scaled unknowns ``z / S``) that pin the rigid-body coordinates, required when the
        corrector was made with ``n_anchor > 0``."""
        nx, c, engine = self.nx, self.c, self.engine
        if self.anchor.shape[0] and anchor is None:
            raise EngineInputError(f"this corrector takes {self.anchor.shape[0]} anchor rows")
        for name, dst, src in (("z", self.z, z), ("row", self.row, row), ("S", self.S, S), ("Rs", self.Rs, Rs),
                               ("t_ref", self.t_ref, t_ref), ("anchor", self.anchor, anchor)):
            if src is None and name in ("t_ref", "anchor"):
                continue
            if getattr(src, "shape", None) != dst.shape and np.shape(src) != dst.shape:
                raise EngineInputError(f"{name} has {np.size(src)} entries, the C iteration needs {dst.size} "
                                       f"(model: nx={engine.nx}, np={engine.np})")
            dst[:] = src
        c.target = float(target)
        if t_ref is not None:
            c.t_ref, c.tangent_out = self._t_ref_ptr, self._tangent_ptr
        else:
            c.t_ref = c.tangent_out = None
        engine._call(engine._lib.gs_correct_ws, self.a, C.byref(c))
        converged = int(c.outcome) == 0
        run = events = None
        if converged:
            n_ev, buf = int(self.a.n_events), self.buf
            if n_ev > buf["cap"]:  # the event log overflowed (the C side gives up first; kept for safety)
                converged = False
            elif want_run:
                run = engine._result(self.a, buf, copy=True)  # (the buffers are reused)
                events = run.events
            else:
                events = EventLog(t=buf["ev_t"][:n_ev].copy(), surface=buf["ev_s"][:n_ev].astype(int),
                                  direction=buf["ev_d"][:n_ev].astype(int), speed=buf["ev_v"][:n_ev].copy())
        samples = None
        if converged and self.n_samples and int(c.samples_ok) == 1:
            st = None
            if int(c.stats_ok) == 1:
                nsw, nm, stats, args = engine.nsw, self.Hs.shape[1], self.stats.copy(), self.args.tolist()
                g, h = 2 * nx, 2 * nx + 2 * nsw
                st = SampleStats(stats[:nx], stats[nx:2 * nx], stats[2 * nx:], args[:nx], args[nx:g],
                                 args[g:g + nsw], args[g + nsw:h], args[h:h + nm], args[h + nm:])
            samples = OrbitSamples(self.ts.copy(), self.Ys.copy(), self.Gs.copy(), self.Hs.copy(), st)
        tangent = self.tangent.copy() if converged and t_ref is not None and int(c.tangent_ok) == 1 else None
        multipliers = self.mult.read() if converged else None
        return CorrectOutcome(converged, OUTCOMES.get(int(c.outcome), "unknown"), self.z.copy(), self.R.copy(),
                              self.M.copy(), self.Fl.copy(), run, float(c.residual), int(c.iterations),
                              int(c.n_runs), int(c.outcome), samples, tangent, float(c.period_out), events,
                              multipliers)
