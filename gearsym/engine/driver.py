"""ctypes binding of the C simulation driver (``gs_driver.h``).

One :meth:`Engine.run` call is one whole simulation in C (CVODE or IDA with
events, breakpoints, output grid and optionally the monodromy); ctypes releases
the GIL during the call, so several simulations may run in parallel threads.
"""

from __future__ import annotations

import ctypes as C
import math
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gearsym.budget import check_matrix
from gearsym.engine import interrupt as _interrupt
from gearsym.engine.errors import EngineABIError, EngineInputError, error_for_status
from gearsym.engine.ramp import SpeedRamp
from gearsym.engine.run_settings import (
    SENSITIVITY_KEYWORDS,
    RunSettings,
    SensitivityRequest,
    settings_from_keywords,
)
from gearsym.engine.sim_args import (
    GsCorrectorFlow,
    GsIsolation,
    GsMultipliers,
    GsNewton,
    GsOrbitFlow,
    GsRamp,
    GsSimArgs,
)
from gearsym.errors import ParameterError
from gearsym.integrators import INTEGRATION_METHODS, LINEAR_SOLVERS, NONLINEAR

__all__ = ["EVAL_FUNCTIONS", "Engine", "GsSimArgs", "LINEAR_SOLVERS", "METHODS", "NONLINEAR", "RunResult",
           "RunSettings", "SensitivityRequest", "SpeedRamp", "c_layout", "check_mirrors", "check_solver_size",
           "load_engine", "mirror_layout"]

#: Status of a run stopped by SIGINT (gs_driver.h).
GS_ERR_INTERRUPTED = -8
#: Largest ``sunindextype`` of the SUNDIALS libraries the driver links (32-bit; checked at load
#: by ``gs_check_abi``): the most components of a solver vector and entries of a dense matrix.
INDEX_MAX = 2 ** 31 - 1

#: Integration methods: name -> GS_METHOD_* code (read from the registry
#: :data:`gearsym.integrators.INTEGRATION_METHODS`, which also holds their settings).
METHODS: dict[str, int] = {name: m.code for name, m in INTEGRATION_METHODS.items()}
#: Functions of :meth:`Engine.evaluate`: name -> GS_EVAL_* code.
EVAL_FUNCTIONS: dict[str, int] = {"sw": 0, "out": 1, "rhs": 2, "jac": 3, "mode": 4, "mesh": 5, "dae": 6,
                                  "dae_jac": 7}
# CVODE's nonlinear solvers (NONLINEAR) and Newton's linear solvers (LINEAR_SOLVERS): name -> C
# code, from gearsym.integrators
_DEFAULT_SETTINGS = RunSettings()


@dataclass(frozen=True)
class EventLog:
    """Events of one run (parallel arrays).

    Attributes
    ----------
    t
        Event times.
    surface
        Index j of the switching function that crossed zero.
    direction
        +1: g_j went from - to +; -1: from + to -.
    speed
        dg_j/dt along the flow of the old mode at the event (~0: grazing).
    """

    t: np.ndarray
    surface: np.ndarray
    direction: np.ndarray
    speed: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


@dataclass(frozen=True)
class RunResult:
    """Result of one :meth:`Engine.run`.

    Attributes
    ----------
    t
        Output times, shape (n_out,).
    y
        States at the output times, shape (n_out, nx).
    x_final
        State at ``t_reached`` (== t_end).
    sigma_final
        Side (+1/-1) of each switching surface at the end, shape (nsw,).
    monodromy
        d x(t_end) / d x0, shape (nx, nx), or None if not requested.
    events
        The event log.
    stats
        n_steps, n_rhs, n_jac, n_root_evals, n_breaks, n_reinit, n_events.
    t_reached
        Last time reached.
    sensitivity, sensitivity_out
        ``d x(t_end) / d lambda_s`` (nx, n_sens; total when ``t_end`` moves) and at the fixed
        output times (n_out, nx, n_sens), or None.
    break_times
        The scheduled breakpoints reached, in order (with ``break_log``), or None.
    """

    t: np.ndarray
    y: np.ndarray
    x_final: np.ndarray
    sigma_final: np.ndarray
    monodromy: np.ndarray | None
    events: EventLog
    stats: dict[str, int] = field(default_factory=dict)
    t_reached: float = math.nan
    sensitivity: np.ndarray | None = None
    sensitivity_out: np.ndarray | None = None
    break_times: np.ndarray | None = None


def _ptr(a: np.ndarray | None) -> int | None:
    """Address of a C-contiguous numpy buffer (None for NULL)."""
    if a is None:
        return None
    return a.ctypes.data


class Engine:
    """A loaded model + driver shared object.

    Use :func:`load_engine` to create one.

    Attributes
    ----------
    path
        The shared object.
    nx, np, nm, nsw, nsched
        Model sizes: states, parameters, mode entries, switching functions,
        schedules.
    implicit
        True for residual-form models (IDA only).
    nalg
        Number of algebraic variables (the last ``nalg`` states of a DAE model; IDA's
        id vector is 0 there).  With the monodromy, ``d x(t_end) / d x0`` has zero
        columns for them: their initial values follow from the differential states.
    nb
        Number of breaks of each schedule.
    sundials_version
        Version string of the SUNDIALS runtime.
    """

    def __init__(self, lib: C.CDLL, path: Path, version: str):
        self._lib = lib
        self.path = path
        self.sundials_version = version
        # one C workspace per thread (work buffers, SUNDIALS context, integrator
        # memory reused across calls: gs_simulate_ws), freed with the engine
        self._tls = threading.local()
        self._workspaces: list[int] = []
        self._ws_lock = threading.Lock()
        info = (C.c_int * 64)()
        n = lib.gs_model_info(info, 64)
        if n < 6:
            raise EngineInputError(f"{path}: gs_model_info failed (returned {n})")
        self.nx, self.np, self.nm, self.nsw, self.nsched = (int(info[i]) for i in range(5))
        self.implicit = bool(info[5])
        self.nb = tuple(int(info[6 + k]) for k in range(self.nsched))
        #: algebraic variables (the last states; models built before they existed have none)
        self.nalg = int(info[6 + self.nsched]) if n > 6 + self.nsched else 0

    def _ws(self) -> int:
        """This thread's workspace (created on first use)."""
        ws = getattr(self._tls, "ws", None)
        if ws is None:
            ws = self._lib.gs_ws_new()
            if not ws:
                raise MemoryError("gs_ws_new: out of memory")
            with self._ws_lock:
                self._workspaces.append(ws)
            self._tls.ws = ws
        return ws

    def __del__(self) -> None:
        lib = getattr(self, "_lib", None)
        for ws in getattr(self, "_workspaces", ()):
            if lib is not None:
                lib.gs_ws_free(ws)
        self._workspaces = []

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("an Engine holds a loaded shared object and C workspaces; pickle the System "
                        "(or its generated model) instead")

    def period(self, p: np.ndarray) -> float:
        """The forcing period ``T(p)`` from the generated ``gs_period`` (NaN if none).

        Parameters
        ----------
        p
            Parameter vector, shape (np,), C-contiguous float64.

        Returns
        -------
        float
        """
        out = C.c_double(math.nan)
        msg = C.create_string_buffer(256)
        pa = p if p.shape[0] else None
        if self._lib.gs_eval_period(self._ws(), _ptr(pa), C.byref(out), msg, 256) != 0:
            raise EngineInputError(msg.value.decode(errors="replace"))
        return float(out.value)

    def period_gradient(self, p: np.ndarray) -> np.ndarray:
        """``d T / d p`` (shape (np,)) of the forcing period at the parameter vector ``p``
        (C-contiguous float64) from the generated ``gs_periodp``."""
        out = np.zeros(max(self.np, 1))
        msg = C.create_string_buffer(256)
        pa = p if p.shape[0] else None
        if self._lib.gs_eval_period_grad(self._ws(), _ptr(pa), _ptr(out), msg, 256) != 0:
            raise EngineInputError(msg.value.decode(errors="replace"))
        return out[: self.np]

    def n_outputs(self) -> int:
        """Number of model outputs (``gs_out``)."""
        return int(self._lib.gs_n_outputs(self._ws()))

    def n_meshes(self) -> int:
        """Number of mesh deflections (``gs_mesh``; 0 for a model without meshes)."""
        return int(self._lib.gs_n_meshes(self._ws()))

    def evaluate(self, function: str, t: Any, x: Any, p: Any, sigma: Any = None, *,
                 ramp: SpeedRamp | None = None) -> np.ndarray:
        """Evaluate a generated function at many points, in the driver's mode there.

        Parameters
        ----------
        function
            ``"sw"`` (switching functions), ``"out"`` (the model's outputs),
            ``"rhs"``, ``"jac"`` (dense ``d xdot / d x``), ``"mode"`` (the mode
            vector: surface sides, schedule cycle and segment), ``"mesh"`` (the
            dynamic deflection of each mesh), or the model as the ODE of its ``nd``
            differential states ``x_d' = f_d(t, x_d)`` with its algebraic variables
            ``z = h(t, x_d)`` solved for (any form; the ``x`` given for ``z`` is only the
            Newton iteration's start): ``"dae"`` (``[y, f_d]``, ``y`` the state with the
            consistent ``z``) or ``"dae_jac"`` (``[d f_d / d x_d; d h / d x_d]``, by the
            implicit function theorem).
        t
            Times, shape (n,).
        x
            States, shape (n, nx).
        p
            Parameter vector, shape (np,).
        sigma
            Sides (+1/-1) of the switching surfaces at each point, shape (n, nsw);
            default: from the signs of the switching functions (``g >= 0`` -> +1).
        ramp
            A speed ramp (:class:`~gearsym.engine.ramp.SpeedRamp`): each point at the time
            and speed the ramped run has there (``gs_eval_ramp``).

        Returns
        -------
        ndarray
            Shape (n, k) with ``k`` = nsw, number of outputs, nx or nm; for
            ``"jac"`` shape (n, nx, nx); ``"dae"`` (n, nx + nd); ``"dae_jac"`` (n, nx, nd).
        """
        code = EVAL_FUNCTIONS[function]
        ta = np.ascontiguousarray(np.asarray(t, dtype=float).reshape(-1))
        n = ta.shape[0]
        xa = np.ascontiguousarray(np.asarray(x, dtype=float).reshape(n, self.nx))
        pa = np.ascontiguousarray(np.asarray(p, dtype=float).reshape(-1))
        sg = None
        if sigma is not None:
            sg = np.ascontiguousarray(np.asarray(sigma, dtype=float).reshape(n, self.nsw))
        if function == "out":  # the counts that need a call into the driver: only when asked for
            k = max(self.n_outputs(), 0)
        elif function == "mesh":
            k = max(self.n_meshes(), 0)
        else:
            nd = self.nx - self.nalg
            k = {"sw": self.nsw, "rhs": self.nx, "jac": self.nx * self.nx, "mode": self.nm, "dae": self.nx + nd,
                 "dae_jac": self.nx * nd}[function]
        out = np.empty((n, max(k, 1)))
        msg = C.create_string_buffer(256)
        if ramp is None:
            rc = self._lib.gs_eval(self._ws(), code, n, _ptr(ta), _ptr(xa), _ptr(pa) if pa.shape[0] else None,
                                   _ptr(sg), _ptr(out), msg, 256)
        else:
            if not hasattr(self._lib, "gs_eval_ramp"):
                raise EngineInputError(f"{self.path} has no gs_eval_ramp (built by an older gearsym); rebuild it")
            rc = self._lib.gs_eval_ramp(self._ws(), code, n, _ptr(ta), _ptr(xa), _ptr(pa) if pa.shape[0] else None,
                                        _ptr(sg), C.byref(self._c_ramp(ramp)), _ptr(out), msg, 256)
        if rc != 0:
            raise EngineInputError(msg.value.decode(errors="replace"))
        out = out[:, :k]
        if function == "jac":
            return out.reshape(n, self.nx, self.nx).transpose(0, 2, 1)  # column-major -> [i, row, col]
        if function == "dae_jac":
            return out.reshape(n, self.nx - self.nalg, self.nx).transpose(0, 2, 1)
        return out

    def __repr__(self) -> str:
        return (
            f"Engine({self.path.name}, nx={self.nx}, np={self.np}, nsw={self.nsw}, "
            f"nsched={self.nsched}, implicit={self.implicit}, SUNDIALS {self.sundials_version})"
        )

    def _c_ramp(self, ramp: SpeedRamp) -> GsRamp:
        """The C struct of a speed ramp (its index checked)."""
        if not 0 <= ramp.index < self.np:
            raise EngineInputError(f"speed ramp: parameter index {ramp.index} outside [0, {self.np})")
        return GsRamp(1, int(ramp.index), float(ramp.t0), float(ramp.speed0), float(ramp.rate))

    def run(self, x0: Any, p: Any, t0: float, t_end: float, t_out: Any = None, settings: RunSettings | None = None,
            *, sigma0: Any = None, atol_vec: Any = None, sensitivities: SensitivityRequest | None = None,
            ramp: SpeedRamp | None = None, break_log: int = 0, **keywords: Any) -> RunResult:
        """Integrate the model from ``t0`` to ``t_end`` in one C call.

        Parameters
        ----------
        x0
            Initial state, shape (nx,).
        p
            Parameters, shape (np,).
        t0, t_end
            Time span, ``t_end > t0``.
        t_out
            Ascending output times in [t0, t_end] (default: none).
        settings
            How to integrate: the method (CVODE ``"bdf"`` / ``"adams"`` for explicit models,
            IDA ``"ida"``; :data:`gearsym.integrators.INTEGRATION_METHODS`), tolerances, step
            and event budgets, nonlinear iteration, linear solver; see
            :class:`~gearsym.engine.run_settings.RunSettings` for each and its default.  With
            ``want_monodromy`` the variational equations are integrated (CVODE, or IDA: the
            DAE's ``F_y S + F_y' S' = 0``) and ``d x(t_end) / d x0`` is returned with saltation
            matrices at events; with algebraic variables its columns for them are 0 (see
            :attr:`nalg`).
        sigma0
            Initial side (+1/-1) of each switching surface; default: from the
            sign of g(t0, x0) (g >= 0 -> +1).
        atol_vec
            One absolute tolerance per solver component instead of ``atol``:
            ``nx * (1 + nd * want_monodromy + n_sens)`` entries (``nd = nx - nalg``) (the state, then the
            variational matrix column by column, then the sensitivities column by
            column), so that the variational entries, whose scale is that of
            ``x_i / x0_j`` (or ``x_i / p_k``), get a tolerance of their own.
        sensitivities
            Parameter sensitivities (CVODE; IDA: the residual's, gs_resp): directions ``D = d p / d lambda``,
            the span's derivatives, whether at the output times too
            (:class:`~gearsym.engine.run_settings.SensitivityRequest`; see ``gs_driver.c`` for
            the equations and jumps).
        ramp
            A speed ramp (:class:`~gearsym.engine.ramp.SpeedRamp`, ``gs_ramp.c``): the speed
            parameter runs linearly and the model's time functions and schedules run on its
            phase (no monodromy, no sensitivities with it).
        break_log
            Capacity of the breakpoint log (:attr:`RunResult.break_times`; 0: none).
        **keywords
            The fields of :class:`~gearsym.engine.run_settings.RunSettings` (``method="adams",
            rtol=1e-10, want_monodromy=True, ...``; they override those of ``settings``) and,
            for :class:`~gearsym.engine.run_settings.SensitivityRequest`, ``sens_dir``,
            ``sens_dt0``, ``sens_dt1``, ``sens_out``.

        Returns
        -------
        RunResult

        Raises
        ------
        EngineError
            A subclass per failure (:class:`~gearsym.engine.errors.TooMuchWorkError`,
            :class:`~gearsym.engine.errors.EventStormError`, ...); bad input is
            :class:`~gearsym.engine.errors.EngineInputError` (a
            :class:`~gearsym.errors.ParameterError`), as is a run whose solver sizes do not fit
            (:func:`check_solver_size`).
        ParameterError
            An unknown keyword (with the closest one); ``max_steps``, ``max_events`` or
            ``storm_events`` beyond :data:`gearsym.budget.LIMITS`.
        KeyboardInterrupt
            On Ctrl-C (SIGINT) during the integration, within a few thousand
            right-hand side evaluations (calls from the main thread; see
            :mod:`gearsym.engine.interrupt`); likewise :class:`~gearsym.engine.interrupt.Terminated`
            on SIGTERM inside :func:`~gearsym.signals.sigterm_interrupts`.
        """
        if keywords:
            if not SENSITIVITY_KEYWORDS.keys().isdisjoint(keywords):
                sens_kw = {SENSITIVITY_KEYWORDS[k]: keywords.pop(k) for k in list(keywords)
                           if k in SENSITIVITY_KEYWORDS}
                if sens_kw.get("directions") is not None:
                    if sensitivities is not None:
                        raise EngineInputError("give the sensitivities once: sensitivities= or sens_dir=, not both")
                    sensitivities = SensitivityRequest(**sens_kw)
            settings = settings_from_keywords(settings, keywords)
        elif settings is None:
            settings = _DEFAULT_SETTINGS
        elif not isinstance(settings, RunSettings):
            raise EngineInputError(f"settings must be a RunSettings, got {type(settings).__name__}")
        c = settings.c
        x0a, pa, tout, sig = self._run_inputs(x0, p, t_out, sigma0)
        sens = None if sensitivities is None else self._sensitivity_input(sensitivities)
        av = None if atol_vec is None else self._atol_vec_input(atol_vec, c.want_monodromy, sens)
        cap = c.max_events_out
        extra = {"ramp": None if ramp is None else self._c_ramp(ramp), "break_log": max(int(break_log), 0)}
        while True:
            res = self._run_once(x0a, pa, float(t0), float(t_end), tout, c.method, c.rtol, c.atol, sig,
                                 c.want_monodromy, c.max_steps, c.max_step, c.init_step, c.max_events,
                                 c.storm_events, c.storm_window, cap, c.nonlinear, c.linear_solver, av, sens,
                                 **extra)
            if isinstance(res, int):  # event log too small: rerun with the exact size
                cap = res
                continue
            return res

    def _run_inputs(self, x0: Any, p: Any, t_out: Any, sigma0: Any
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """The state, parameters, output times and initial sides of a run as the C side reads them
        (C-contiguous float64, sizes checked)."""
        x0a = np.ascontiguousarray(np.asarray(x0, dtype=float).reshape(-1))
        pa = np.ascontiguousarray(np.asarray(p if p is not None else [], dtype=float).reshape(-1))
        if x0a.shape[0] != self.nx:
            raise EngineInputError(f"x0 has {x0a.shape[0]} entries, the model has nx={self.nx} states")
        if pa.shape[0] != self.np:
            raise EngineInputError(f"p has {pa.shape[0]} entries, the model has np={self.np} parameters")
        tout = np.ascontiguousarray(np.asarray(t_out if t_out is not None else [], dtype=float).reshape(-1))
        sig = None
        if sigma0 is not None:
            sig = np.ascontiguousarray(np.asarray(sigma0, dtype=float).reshape(-1))
            if sig.shape[0] != self.nsw:
                raise EngineInputError(f"sigma0 has {sig.shape[0]} entries, the model has nsw={self.nsw}")
        return x0a, pa, tout, sig

    def _sensitivity_input(self, req: SensitivityRequest) -> tuple[Any, ...]:
        """``(D^T flattened, n_sens, dt0, dt1, at_outputs)`` of a sensitivity request, as
        :meth:`_prepare` takes it."""
        D = np.asarray(req.directions, dtype=float).reshape(self.np, -1)  # ValueError on a wrong shape
        vec = [None if v is None else np.ascontiguousarray(np.broadcast_to(np.asarray(v, float), D.shape[1:]))
               for v in (req.dt0, req.dt1)]
        return np.ascontiguousarray(D.T).reshape(-1), D.shape[1], vec[0], vec[1], bool(req.at_outputs)

    def _atol_vec_input(self, atol_vec: Any, mono: bool, sens: tuple[Any, ...] | None) -> np.ndarray:
        """The per-component absolute tolerances, their number checked."""
        av = np.ascontiguousarray(np.asarray(atol_vec, dtype=float).reshape(-1))
        n_s = 0 if sens is None else int(sens[1])
        want = self.nx * (1 + ((self.nx - self.nalg) if mono else 0) + n_s)
        if av.shape[0] != want:
            raise EngineInputError(f"atol_vec has {av.shape[0]} entries, need {want}")
        return av

    def _run_once(self, *args: Any, **extra: Any) -> RunResult | int:
        a, buf = self._prepare(*args, **extra)
        self._call(self._lib.gs_simulate_ws, a)
        return self._result(a, buf)

    def _prepare(
        self,
        x0,
        p,
        t0,
        t_end,
        tout,
        method,
        rtol,
        atol,
        sig,
        mono,
        max_steps,
        max_step,
        init_step,
        max_events,
        storm_events,
        storm_window,
        cap,
        nonlin=0,
        linsol=0,
        av=None,
        sens=None,
        ramp: GsRamp | None = None,
        break_log: int = 0,
    ) -> tuple[GsSimArgs, dict[str, Any]]:
        """The argument struct of one run and the numpy buffers it points at."""
        nx, nsw = self.nx, self.nsw
        check_solver_size(nx, nx - self.nalg, mono, sens[1] if sens is not None else 0, nonlin, linsol)
        n_out = int(tout.shape[0])
        if n_out > INDEX_MAX:  # (the C field is an int)
            raise EngineInputError(f"{n_out:,} output times: the driver takes at most {INDEX_MAX:,}")
        # the driver writes every entry before it returns success (and a failure raises)
        buf: dict[str, Any] = {
            "x0": x0, "p": p, "tout": tout, "sig": sig, "av": av,
            "y": np.empty((n_out, nx)), "x_final": np.empty(nx), "sigma_final": np.zeros(max(nsw, 1)),
            "mono": np.empty((nx, nx)) if mono else None, "ev_t": np.empty(cap),
            "ev_s": np.empty(cap, dtype=np.intc), "ev_d": np.empty(cap, dtype=np.intc), "ev_v": np.empty(cap),
            "cap": cap, "s_final": None, "s_out": None, "brk": np.empty(break_log) if break_log else None}
        a = GsSimArgs()
        a.method = method
        a.rtol, a.atol, a.t0, a.t_end = rtol, atol, t0, t_end
        a.x0 = _ptr(x0)
        a.p = _ptr(p) if p.shape[0] else None
        a.sigma0 = _ptr(sig)
        a.n_out = n_out
        a.t_out = _ptr(tout) if n_out else None
        a.max_steps, a.max_events = max_steps, max_events
        a.storm_events, a.storm_window = storm_events, storm_window
        a.max_step, a.init_step = max_step, init_step
        a.want_monodromy = 1 if mono else 0
        a.max_events_out = cap
        a.nonlinear, a.linear_solver = nonlin, linsol
        a.atol_vec = _ptr(av)
        a.y_out = _ptr(buf["y"]) if n_out else None
        a.x_final = _ptr(buf["x_final"])
        a.sigma_final = _ptr(buf["sigma_final"])
        a.monodromy = _ptr(buf["mono"])
        a.ev_t, a.ev_surface, a.ev_dir, a.ev_speed = (
            _ptr(buf["ev_t"]),
            _ptr(buf["ev_s"]),
            _ptr(buf["ev_d"]),
            _ptr(buf["ev_v"]),
        )
        if ramp is not None:
            a.ramp = ramp
        if break_log:
            a.max_breaks_out, a.brk_t = break_log, _ptr(buf["brk"])
        if sens is not None:
            sdir, ns, dt0, dt1, want_out = sens
            buf["s_final"] = np.empty((nx, ns))
            buf["s_out"] = np.empty((n_out, nx, ns)) if want_out and n_out else None
            buf["sens"] = sens
            a.n_sens = ns
            a.sens_dir = _ptr(sdir)
            a.sens_dt0, a.sens_dt1 = _ptr(dt0), _ptr(dt1)
            a.sens_final, a.sens_out = _ptr(buf["s_final"]), _ptr(buf["s_out"])
        return a, buf

    def _call(self, fn: Any, a: GsSimArgs, *extra: Any) -> None:
        """Call a driver entry point on this thread's workspace with Ctrl-C armed; raise on failure."""
        a.interrupt_fd, previous = _interrupt.arm()
        a.check_interrupt = _interrupt.signal_mask() if a.interrupt_fd >= 0 else 0
        try:
            status = fn(self._ws(), C.byref(a), *extra)
        finally:
            _interrupt.disarm(previous)
        if status == GS_ERR_INTERRUPTED:
            # Python's SIGINT handler has normally raised KeyboardInterrupt already
            # (when the call returned); this covers a handler that did not raise.
            raise KeyboardInterrupt(f"simulation interrupted at t={float(a.t_reached):.6g}")
        if status != 0:
            msg = a.errmsg.decode("utf-8", errors="replace")
            raise error_for_status(int(status), msg, float(a.t_reached))

    def _result(self, a: GsSimArgs, buf: dict[str, Any], copy: bool = False) -> RunResult | int:
        """The result of a successful run (or the event count when the log was too small);
        ``copy``: its arrays are copies of the buffers (which are reused)."""
        n_ev = int(a.n_events)
        if n_ev > buf["cap"]:
            return n_ev
        events = EventLog(
            t=buf["ev_t"][:n_ev].copy(),
            surface=buf["ev_s"][:n_ev].astype(int),
            direction=buf["ev_d"][:n_ev].astype(int),
            speed=buf["ev_v"][:n_ev].copy(),
        )
        stats = {
            "n_steps": int(a.n_steps),
            "n_rhs": int(a.n_rhs),
            "n_jac": int(a.n_jac),
            "n_root_evals": int(a.n_root_evals),
            "n_breaks": int(a.n_breaks),
            "n_reinit": int(a.n_reinit),
            "n_events": n_ev,
        }
        def own(x: np.ndarray | None) -> np.ndarray | None:
            return x.copy() if copy and x is not None else x

        return RunResult(
            t=buf["tout"].copy(),
            y=own(buf["y"]),
            x_final=own(buf["x_final"]),
            sigma_final=buf["sigma_final"][: self.nsw].copy(),
            monodromy=own(buf["mono"]),
            events=events,
            stats=stats,
            t_reached=float(a.t_reached),
            sensitivity=own(buf["s_final"]),
            sensitivity_out=own(buf["s_out"]),
            break_times=None if buf.get("brk") is None else buf["brk"][: min(int(a.n_breaks), buf["brk"].size)].copy(),
        )


def check_solver_size(nx: int, nd: int, monodromy: bool, n_sens: int = 0, nonlinear: int = 0,
                      linear_solver: int = 0) -> None:
    """Refuse, before the driver allocates anything, a run whose solver sizes do not fit
    SUNDIALS' 32-bit index or the memory budget of a dense matrix.

    The solver state has ``nA = nx * (1 + nvc)`` components, ``nvc = nd * monodromy + n_sens``
    variational columns; Newton's matrix is ``nA x nA`` (dense) or ``nA x nx``
    (block-diagonal, the default with variational columns), none for the fixed-point
    iteration.  The driver checks the index limit again (``solver_sizes`` in gs_driver.c).

    Parameters
    ----------
    nx, nd
        States and differential states of the model.
    monodromy
        The variational equations of the state are integrated.
    n_sens
        Parameter sensitivity directions.
    nonlinear, linear_solver
        The solver codes (:data:`NONLINEAR`, :data:`LINEAR_SOLVERS`).

    Raises
    ------
    EngineInputError
        (A :class:`~gearsym.errors.ParameterError`.)  Naming the number of states and what to
        change.
    """
    nvc = (nd if monodromy else 0) + max(int(n_sens), 0)
    nA = nx * (1 + nvc)
    what = (f"{nx} states with {nvc} variational columns ({nd if monodromy else 0} of the monodromy, "
            f"{max(int(n_sens), 0)} sensitivity directions)")
    if nA > INDEX_MAX:
        raise EngineInputError(f"{what}: the solver state of nx*(1 + nvc) = {nA:,} components is above the "
                               f"{INDEX_MAX:,} that SUNDIALS' 32-bit index holds: drop the monodromy or integrate "
                               "fewer sensitivity directions at once")
    if nonlinear == NONLINEAR["fixedpoint"]:
        return
    dense = nvc == 0 or linear_solver == LINEAR_SOLVERS["dense"]
    cols = nA if dense else nx
    change = ("use the block-diagonal linear solver (linear_solver='blockdiag', the default 'auto' with the "
              "monodromy)" if dense and nvc else "use the fixed-point iteration (nonlinear='fixedpoint')")
    if nA * cols > INDEX_MAX:
        raise EngineInputError(f"{what}: Newton's {'dense' if dense else 'block-diagonal'} matrix of {nA:,} x "
                               f"{cols:,} = {nA * cols:.3g} entries is above the {INDEX_MAX:,} that SUNDIALS' 32-bit "
                               f"index addresses: {change}")
    try:
        check_matrix(nA, cols, f"{what}: Newton's {'dense' if dense else 'block-diagonal'} matrix", change)
    except ParameterError as exc:
        raise EngineInputError(str(exc)) from None


def _newton_signatures(lib: Any) -> None:
    """The signatures of THE Newton iteration (gs_newton.c) and its C evaluators (absent from
    objects built before them)."""
    for name, args in (("gs_shoot_ws", [C.c_void_p, C.POINTER(GsSimArgs), C.c_void_p]),
                       ("gs_correct_ws", [C.c_void_p, C.POINTER(GsSimArgs), C.c_void_p]),
                       ("gs_newton_work_size", [C.c_void_p]), ("gs_newton_tangent", [C.c_void_p])):
        if hasattr(lib, name):
            getattr(lib, name).restype = C.c_int
            getattr(lib, name).argtypes = args
    for name in ("gs_newton_start", "gs_newton_restart", "gs_newton_next"):
        if hasattr(lib, name):
            getattr(lib, name).restype = None
            getattr(lib, name).argtypes = [C.c_void_p]


def load_engine(so_path: str | os.PathLike[str], *, sha256: str | None = None,
                build_key: str | None = None) -> Engine:
    """Load a model + driver shared object and check it and the SUNDIALS runtime.

    ``dlopen`` caches libraries by path: a rebuilt object at the same path
    silently keeps running the old code, so callers must name builds by
    content hash (see :func:`gearsym.engine.build.content_hash`).  The object is
    linked without an rpath; the installed wheel's SUNDIALS libraries are loaded
    first (:func:`gearsym.engine.build.preload_sundials`).

    Parameters
    ----------
    so_path
        The shared object built by :func:`gearsym.engine.build.build_shared_object`.
    sha256
        Expected SHA-256 of the file, checked *before* ``dlopen`` (a truncated
        object would otherwise kill the process with SIGBUS).
    build_key
        Expected value of the object's ``gs_build_key()`` (generated models
        record the key of their build there).

    Returns
    -------
    Engine

    Raises
    ------
    EngineABIError
        If the object is missing, does not match ``sha256`` or ``build_key``,
        cannot be loaded, the layout of an argument struct (``gs_sim_args``, ...) differs
        from its ctypes mirror in size or in any field's offset, size or kind, or the
        SUNDIALS runtime is not version >= 7 with 32-bit indices.
    """
    from gearsym.engine.build import file_sha256, preload_sundials

    path = Path(so_path).resolve()
    if sha256 is not None:
        try:
            actual = file_sha256(path)
        except OSError as exc:
            raise EngineABIError(f"cannot read the compiled model {path}: {exc.strerror}") from exc
        if actual != sha256:
            raise EngineABIError(f"the compiled model {path} is damaged (its SHA-256 differs from the one "
                                 "recorded when it was built); rebuild it (gearsym compile --force)")
    preload_sundials()
    try:
        lib = C.CDLL(str(path))
    except OSError as exc:
        raise EngineABIError(f"cannot load the compiled model {path}: {exc}") from exc
    for name in ("gs_simulate", "gs_simulate_ws", "gs_ws_new", "gs_ws_free", "gs_eval", "gs_eval_period",
                 "gs_check_abi", "gs_sizeof_args", "gs_model_info"):
        if not hasattr(lib, name):
            raise EngineABIError(f"{path} does not export {name}; was it built with gs_driver.c?")
    if build_key is not None:
        if not hasattr(lib, "gs_build_key"):
            raise EngineABIError(f"{path} does not export gs_build_key; rebuild it (gearsym compile --force)")
        lib.gs_build_key.restype = C.c_char_p
        lib.gs_build_key.argtypes = []
        found = (lib.gs_build_key() or b"").decode(errors="replace")
        if found != build_key:
            raise EngineABIError(f"{path} was built for key {found[:16]}, expected {build_key[:16]}; "
                                 "rebuild it (gearsym compile --force)")
    lib.gs_sizeof_args.restype = C.c_int
    lib.gs_sizeof_args.argtypes = []
    lib.gs_check_abi.restype = C.c_int
    lib.gs_check_abi.argtypes = [C.c_char_p, C.c_int]
    lib.gs_simulate.restype = C.c_int
    lib.gs_simulate.argtypes = [C.POINTER(GsSimArgs)]
    lib.gs_model_info.restype = C.c_int
    lib.gs_model_info.argtypes = [C.POINTER(C.c_int), C.c_int]
    lib.gs_ws_new.restype = C.c_void_p
    lib.gs_ws_new.argtypes = []
    lib.gs_ws_free.restype = None
    lib.gs_ws_free.argtypes = [C.c_void_p]
    lib.gs_simulate_ws.restype = C.c_int
    lib.gs_simulate_ws.argtypes = [C.c_void_p, C.POINTER(GsSimArgs)]
    lib.gs_eval_period.restype = C.c_int
    lib.gs_eval_period.argtypes = [C.c_void_p, C.c_void_p, C.POINTER(C.c_double), C.c_char_p, C.c_int]
    if hasattr(lib, "gs_eval_period_grad"):
        lib.gs_eval_period_grad.restype = C.c_int
        lib.gs_eval_period_grad.argtypes = [C.c_void_p, C.c_void_p, C.c_void_p, C.c_char_p, C.c_int]
    lib.gs_n_outputs.restype = C.c_int
    lib.gs_n_outputs.argtypes = [C.c_void_p]
    lib.gs_n_meshes.restype = C.c_int
    lib.gs_n_meshes.argtypes = [C.c_void_p]
    lib.gs_eval.restype = C.c_int
    lib.gs_eval.argtypes = [C.c_void_p, C.c_int, C.c_int, C.c_void_p, C.c_void_p, C.c_void_p, C.c_void_p,
                            C.c_void_p, C.c_char_p, C.c_int]
    if hasattr(lib, "gs_eval_ramp"):
        lib.gs_eval_ramp.restype = C.c_int
        lib.gs_eval_ramp.argtypes = [C.c_void_p, C.c_int, C.c_int, C.c_void_p, C.c_void_p, C.c_void_p, C.c_void_p,
                                     C.POINTER(GsRamp), C.c_void_p, C.c_char_p, C.c_int]
    _newton_signatures(lib)
    for fn, struct, mirror in (("gs_sizeof_args", "gs_sim_args", GsSimArgs),
                               ("gs_sizeof_newton", "gs_newton", GsNewton),
                               ("gs_sizeof_orbit_flow", "gs_orbit_flow", GsOrbitFlow),
                               ("gs_sizeof_corrector_flow", "gs_corrector_flow", GsCorrectorFlow)):
        if not hasattr(lib, fn):  # (the Newton structs' checks are absent from objects built before them)
            continue
        getattr(lib, fn).restype, getattr(lib, fn).argtypes = C.c_int, []
        size_c = getattr(lib, fn)()
        if size_c != C.sizeof(mirror):
            raise EngineABIError(
                f"{path}: sizeof({struct}) is {size_c} in C but {C.sizeof(mirror)} in the ctypes "
                "mirror (gearsym/engine/sim_args.py out of sync with gs_driver.h)"
            )
    check_mirrors(c_layout(lib, path), path)
    buf = C.create_string_buffer(256)
    if lib.gs_check_abi(buf, 256) != 0:
        raise EngineABIError(f"{path}: SUNDIALS runtime check failed: {buf.value.decode(errors='replace')}")
    return Engine(lib, path, buf.value.decode())


#: A field of a C struct: (name, offset, size, kind), kind as ``gs_abi_field`` gives it
#: ('d' double, 'i' int, 'l' long, 'p' pointer, 'a' char array, 's' struct).
Field = tuple[str, int, int, str]


def c_layout(lib: C.CDLL, path: Path | str = "") -> dict[str, list[Field]]:
    """The driver's argument structs, field by field, from its ``gs_abi_field`` table.

    Parameters
    ----------
    lib
        The loaded model + driver shared object.
    path
        Its path, for messages.

    Returns
    -------
    dict
        Struct name (``"gs_sim_args"``, ...) -> its fields in declaration order.

    Raises
    ------
    EngineABIError
        The object does not export ``gs_abi_field`` (built by an older gearsym).
    """
    if not hasattr(lib, "gs_abi_field"):
        raise EngineABIError(f"{path} does not export gs_abi_field (built by an older gearsym); rebuild it "
                             "(gearsym compile --force)")
    fn = lib.gs_abi_field
    fn.restype = C.c_int
    fn.argtypes = [C.c_int, C.POINTER(C.c_char_p), C.POINTER(C.c_char_p), C.POINTER(C.c_long),
                   C.POINTER(C.c_long), C.POINTER(C.c_int)]
    out: dict[str, list[Field]] = {}
    struct, name, off, size, kind = C.c_char_p(), C.c_char_p(), C.c_long(), C.c_long(), C.c_int()
    i = 0
    while fn(i, C.byref(struct), C.byref(name), C.byref(off), C.byref(size), C.byref(kind)) == 0:
        out.setdefault((struct.value or b"").decode(), []).append(
            ((name.value or b"").decode(), int(off.value), int(size.value), chr(kind.value)))
        i += 1
    return out


def _kind(ctype: Any) -> str:
    """The ``gs_abi_field`` kind of a ctypes field type."""
    if isinstance(ctype, type) and issubclass(ctype, C.Structure):
        return "s"
    if isinstance(ctype, type) and issubclass(ctype, C.Array):
        return "a"
    return {C.c_double: "d", C.c_int: "i", C.c_long: "l", C.c_void_p: "p"}.get(ctype, "?")


def mirror_layout(mirror: type[C.Structure]) -> list[Field]:
    """The fields of a ctypes mirror as :func:`c_layout` gives those of its C struct."""
    return [(f[0], getattr(mirror, f[0]).offset, getattr(mirror, f[0]).size, _kind(f[1]))
            for f in mirror._fields_]


def _mirrors() -> dict[str, type[C.Structure]]:
    """C struct name -> its ctypes mirror (read from this module when called, so that a test
    may replace a mirror)."""
    return {"gs_sim_args": GsSimArgs, "gs_newton": GsNewton, "gs_orbit_flow": GsOrbitFlow,
            "gs_corrector_flow": GsCorrectorFlow, "gs_multipliers": GsMultipliers, "gs_isolation": GsIsolation,
            "gs_ramp": GsRamp}


def check_mirrors(layout: dict[str, list[Field]], path: Path | str = "",
                  mirrors: dict[str, type[C.Structure]] | None = None) -> None:
    """Compare every ctypes mirror with its C struct field by field: the same fields, each at
    the same offset with the same size and kind.

    Parameters
    ----------
    layout
        The C side, :func:`c_layout`.
    path
        The shared object, for messages.
    mirrors
        C struct name -> ctypes mirror (default: those of :mod:`gearsym.engine.sim_args`).

    Raises
    ------
    EngineABIError
        Naming the struct and the first field that differs.
    """
    kinds = {"d": "double", "i": "int", "l": "long", "p": "pointer", "a": "char array", "s": "struct", "?": "other"}
    where = f"{path}: " if path else ""
    hint = " (gearsym/engine/sim_args.py out of sync with gs_driver.h)"
    for struct, mirror in (mirrors or _mirrors()).items():
        c_fields = layout.get(struct)
        if not c_fields:
            raise EngineABIError(f"{where}the driver's layout table has no struct {struct}{hint}")
        py = {f[0]: f for f in mirror_layout(mirror)}
        for name, off, size, kind in c_fields:
            if name not in py:
                raise EngineABIError(f"{where}{struct}.{name} (offset {off}) has no field in the ctypes mirror "
                                     f"{mirror.__name__}{hint}")
            _, m_off, m_size, m_kind = py.pop(name)
            if (off, size, kind) != (m_off, m_size, m_kind):
                raise EngineABIError(
                    f"{where}{struct}.{name} is at offset {off} ({size} bytes, {kinds[kind]}) in C but at offset "
                    f"{m_off} ({m_size} bytes, {kinds[m_kind]}) in the ctypes mirror {mirror.__name__}{hint}")
        if py:
            raise EngineABIError(f"{where}the ctypes mirror {mirror.__name__} has field(s) {', '.join(py)} that "
                                 f"{struct} lacks{hint}")
