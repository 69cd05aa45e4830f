"""THE damped Newton iteration of the periodic-orbit solvers, in C (``gs_newton.c``).

Shooting's Newton (:func:`gearsym.analysis.periodic.shoot`) and the continuation's
pseudo-arclength corrector (:class:`gearsym.analysis.continuation._corrector.Continuer`) are two
problems of one iteration, written once in ``gearsym/engine/gs_newton.c``: the damped step and
its acceptance, the convergence tests, the orbit's state scales, the truncated and the bordered
steps, the anchor rows of rigid-body models, the corrector's chord ``F_lambda`` and its tangent.
No Python code iterates Newton on these problems.

The iteration asks for evaluations (reverse communication): :class:`NewtonCore` holds its
``gs_newton`` struct and the buffers; the C evaluators of the shooting residuals
(:mod:`gearsym.engine.shoot`: ``gs_shoot_ws``, ``gs_correct_ws``) answer in the same C call,
and :meth:`NewtonCore.answer` takes an evaluation made in Python (harmonic balance, a parameter
that does not enter the parameter vector linearly, ...).  Where the evaluations are made is the
caller's reported choice; the iteration is the same.
"""

from __future__ import annotations

import ctypes as C
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import EngineInputError
from .sim_args import GsNewton

__all__ = ["CORRECTOR", "DONE", "EVALUATE", "HISTORY_KINDS", "NOTES", "ORBIT", "OUTCOMES", "NewtonCore",
           "NewtonPolicy", "lapack_pointers"]

#: ``gs_newton.kind``: shooting's Newton, the continuation's corrector.
ORBIT, CORRECTOR = 0, 1
#: ``gs_newton.request``.
DONE, EVALUATE = 0, 1

#: ``gs_newton.outcome`` -> meaning.
OUTCOMES: dict[int, str] = {
    0: "converged",
    1: "the residual fell by less than the divergence test's ratio",
    2: "the iteration budget is spent",
    3: "the Newton step is not finite (singular Newton matrix)",
    4: "an evaluation that had to succeed failed",
    5: "no damped step reduces the residual",
    6: "a non-finite residual",
}
CONVERGED, DIVERGED, MAX_ITER, SINGULAR, EVAL_FAILED, STALLED, NONFINITE = range(7)

#: ``gs_newton.note`` of a converged orbit -> the note of its last history entry.
NOTES: dict[int, str] = {0: "", 1: "Newton step below tolerance (residual at the integration noise level)",
                         2: "Newton step below 10 tol applied without another integration", 3: "noise floor"}

#: ``gs_newton.hist_kind`` -> name.
HISTORY_KINDS: dict[int, str] = {0: "start", 1: "step", 2: "restart", 3: "noise floor"}


@dataclass(frozen=True)
class NewtonPolicy:
    """How the damped Newton iteration proceeds (``gs_newton``'s policy fields).

    Attributes
    ----------
    max_iter : int
        Newton steps allowed (over restarts).
    min_damping : float
        Smallest damping factor tried (halving from 1).
    decrease : float
        Sufficient decrease: a damped step ``a`` is accepted when the norm falls below
        ``(1 - decrease * a)`` times the current one.
    accept_below : float
        A damped step whose norm is below this is accepted whatever the decrease.
    accept_last : bool
        Take the smallest damped step even if it does not decrease the norm (its evaluation
        must then succeed).
    diverge : tuple of float or None
        ``(ratio, floor)``: after two steps, stop when the norm falls by less than ``ratio``
        while above ``floor``.
    apply_final_step : bool
        When a step below the tolerance is found, add it without evaluating its end (its
        effect on the residual is quadratic in its size).
    """

    max_iter: int
    min_damping: float = 2.0 ** -12
    decrease: float = 1e-4
    accept_below: float = 0.0
    accept_last: bool = False
    diverge: tuple[float, float] | None = None
    apply_final_step: bool = False


_LAPACK: dict[str, int] | None = None
_LAPACK_ROUTINES = ("dgebal", "dgesdd", "dgeev", "dgelsd", "dgetrf", "dgetrs")


def lapack_pointers() -> dict[str, int]:
    """Addresses of scipy's ``cython_lapack`` routines (C functions with Fortran's by-reference
    arguments) that the driver calls: the Newton iteration's solves (``dgetrf``, ``dgetrs``,
    ``dgesdd``, ``dgelsd``: numpy.linalg's routines) and a converged orbit's multipliers and
    isolation (``dgebal``, ``dgesdd``, ``dgeev``); empty if unavailable."""
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
        except Exception:  # noqa: BLE001 - reported by NewtonCore
            out = {}
        _LAPACK = out if len(out) == len(_LAPACK_ROUTINES) and all(out.values()) else {}
    return _LAPACK


def _check_sizes(kind: int, n: int, nr: int, nx: int, segments: int) -> None:
    """The sizes of one problem (every buffer the C iteration reads is sized from them):
    orbit ``n = nr = segments * nx`` with ``nx, segments >= 1``; corrector ``n = nr + 1 >= 2``."""
    if kind == ORBIT:
        if nx < 1 or segments < 1 or n != nr or n != segments * nx:
            raise EngineInputError(f"an orbit's Newton iteration needs n = nr = segments * nx with nx, segments >= 1 "
                                   f"(got n={n}, nr={nr}, nx={nx}, segments={segments})")
    elif kind == CORRECTOR:
        if nr < 1 or n != nr + 1:
            raise EngineInputError(f"the corrector's Newton iteration needs n = nr + 1 unknowns, nr >= 1 (got n={n}, "
                                   f"nr={nr})")
    else:
        raise EngineInputError(f"a Newton iteration's kind is ORBIT ({ORBIT}) or CORRECTOR ({CORRECTOR}), got {kind}")


def _sized(name: str, value: Any, dst: np.ndarray) -> np.ndarray:
    """``value`` as float64 in ``dst``'s shape, or EngineInputError when its size differs (numpy
    would broadcast a scalar or a row into the buffer the C iteration reads)."""
    a = np.asarray(value, dtype=float)
    if a.size != dst.size:
        raise EngineInputError(f"{name} has {a.size} entries, this Newton iteration takes {dst.size}")
    return a.reshape(dst.shape)


def _ptr(a: np.ndarray | None) -> int | None:
    return None if a is None or a.size == 0 else a.ctypes.data


class NewtonCore:
    """THE Newton iteration's ``gs_newton`` struct and the numpy buffers it points at, for one
    problem shape (made once, reused by every iteration of that shape).

    Parameters
    ----------
    lib
        A loaded model's shared object (every build carries the driver, ``gs_newton.c``).
    kind
        :data:`ORBIT` or :data:`CORRECTOR`.
    n, nr
        Unknowns and residual rows (orbit: ``segments * nx`` both; corrector: ``nr + 1``, ``nr``).
    policy
        The damping and budget rules.
    tol
        The convergence tolerance.
    nx, segments
        Orbit: states per segment and segments.
    trunc_level, scale_floor
        Orbit: the truncation level of the step (singular values of the scaled Jacobian below
        ``trunc_level * max(1, sigma_1)`` are dropped) and the floor of the state scales.
    n_anchor
        Rows pinning the rigid-body coordinates (0: none).
    hist_cap
        History entries kept between a start / restart and the iteration's end.

    Raises
    ------
    EngineInputError
        A build without the iteration, no LAPACK from scipy, or bad sizes.
    """

    def __init__(self, lib: Any, kind: int, n: int, nr: int, policy: NewtonPolicy, *, tol: float, nx: int = 0,
                 segments: int = 1, trunc_level: float = 0.0, scale_floor: float = 0.0, n_anchor: int = 0,
                 hist_cap: int = 0):
        if not hasattr(lib, "gs_newton_next"):
            raise EngineInputError("this build has no Newton iteration (gs_newton.c): rebuild it")
        lap = lapack_pointers()
        if not lap:
            raise EngineInputError("the Newton iteration needs scipy's LAPACK (scipy.linalg.cython_lapack)")
        _check_sizes(int(kind), int(n), int(nr), int(nx), int(segments))
        big = 2 ** 31 - 8  # the C struct's ints
        if not (0 <= int(policy.max_iter) <= big and 0 <= n_anchor <= big and int(hist_cap) <= big):
            raise EngineInputError(f"a Newton iteration needs 0 <= max_iter, n_anchor, hist_cap <= {big} (got "
                                   f"max_iter={policy.max_iter}, n_anchor={n_anchor}, hist_cap={hist_cap})")
        self.lib, self.kind, self.n, self.nr = lib, int(kind), int(n), int(nr)
        nw = self.nw = GsNewton()
        nw.kind, nw.n, nw.nr, nw.nx, nw.segments = self.kind, self.n, self.nr, int(nx), int(segments)
        nw.max_iter, nw.tol, nw.min_damping = int(policy.max_iter), float(tol), float(policy.min_damping)
        nw.decrease, nw.accept_below = float(policy.decrease), float(policy.accept_below)
        nw.accept_last, nw.apply_final_step = int(bool(policy.accept_last)), int(bool(policy.apply_final_step))
        nw.diverge_ratio, nw.diverge_floor = (float(policy.diverge[0]), float(policy.diverge[1])) if policy.diverge \
            else (0.0, 0.0)
        nw.trunc_level, nw.scale_floor = float(trunc_level), float(scale_floor)
        nw.lapack_dgetrf, nw.lapack_dgetrs, nw.lapack_dgesdd, nw.lapack_dgelsd = (
            lap["dgetrf"], lap["dgetrs"], lap["dgesdd"], lap["dgelsd"])
        orbit = self.kind == ORBIT
        self.z, self.z_eval, self.R = np.zeros(n), np.zeros(n), np.zeros(nr)
        self.J = np.zeros((int(segments) * nx * nx,) if orbit else (nr, nr))
        self.Flam = np.zeros(0 if orbit else nr)
        self.amplitude, self.scale = np.zeros(nx if orbit else 0), np.ones(nx if orbit else 0)
        self.row, self.S, self.t_ref, self.tangent = (np.zeros(0 if orbit else n) for _ in range(4))
        self.Rs = np.zeros(0 if orbit else nr)
        self.anchor = np.zeros((int(n_anchor), n))
        cap = max(int(hist_cap), 0)
        self.h_kind, self.h_drop = np.zeros(cap, dtype=np.intc), np.zeros(cap, dtype=np.intc)
        self.h_abs, self.h_rel, self.h_step = np.zeros(cap), np.zeros(cap), np.zeros(cap)
        nw.z, nw.z_eval, nw.R, nw.J = _ptr(self.z), _ptr(self.z_eval), _ptr(self.R), _ptr(self.J)
        nw.Flam, nw.amplitude, nw.scale = _ptr(self.Flam), _ptr(self.amplitude), _ptr(self.scale)
        nw.row, nw.S, nw.Rs, nw.tangent = _ptr(self.row), _ptr(self.S), _ptr(self.Rs), _ptr(self.tangent)
        nw.n_anchor, nw.anchor = int(n_anchor), _ptr(self.anchor)
        nw.hist_cap = cap
        nw.hist_kind, nw.hist_abs, nw.hist_rel = _ptr(self.h_kind), _ptr(self.h_abs), _ptr(self.h_rel)
        nw.hist_step, nw.hist_drop = _ptr(self.h_step), _ptr(self.h_drop)
        size = lib.gs_newton_work_size(C.byref(nw))
        if size < 1:
            raise EngineInputError(f"the Newton iteration refused its sizes (n={n}, nr={nr})")
        self.work = np.zeros(size)
        nw.work = self.work.ctypes.data
        self.ref = C.byref(nw)

    # ------------------------------------------------------------ driving
    def start(self, z: np.ndarray) -> None:
        """Begin an iteration from ``z`` (its first request: the evaluation at ``z``)."""
        self.z[:] = _sized("z", z, self.z)
        self.lib.gs_newton_start(self.ref)

    def restart(self, z: np.ndarray) -> None:
        """Go on from ``z`` (shooting's relaxation), the steps taken so far counted."""
        self.z[:] = _sized("z", z, self.z)
        self.lib.gs_newton_restart(self.ref)

    def next(self) -> None:
        """Take the answered evaluation and make the next request (or end)."""
        self.lib.gs_newton_next(self.ref)

    @property
    def pending(self) -> bool:
        """An evaluation is requested and not answered yet."""
        return self.nw.request == EVALUATE and not self.nw.answered

    @property
    def done(self) -> bool:
        return self.nw.request == DONE

    def answer(self, R: np.ndarray, J: np.ndarray, Flam: np.ndarray | None = None,
               anchor: np.ndarray | None = None) -> None:
        """Answer the pending request with an evaluation made in Python (corrector: ``J`` is
        ``F_u``; ``Flam`` ``None`` keeps the last one given; ``anchor``: the anchor rows at
        the point, where they move with it)."""
        nw = self.nw
        self.R[:] = _sized("R", R, self.R)
        self.J[...] = _sized("J", J, self.J)
        if Flam is not None:
            self.Flam[:] = _sized("Flam", Flam, self.Flam)
        nw.flam_given = int(Flam is not None)
        if anchor is not None:
            self.anchor[...] = _sized("anchor", anchor, self.anchor)
        nw.eval_status = 0
        nw.answered = 1

    def answer_failed(self, message: str) -> None:
        """Answer the pending request with a failed evaluation."""
        nw = self.nw
        nw.eval_status = 1
        nw.eval_msg = message.encode("utf-8", errors="replace")[:255]
        nw.answered = 1

    def solve_in_python(self, evaluate: Any) -> None:
        """Run the iteration to its end with every evaluation made by ``evaluate(z_eval)``
        (which answers through :meth:`answer` / :meth:`answer_failed`)."""
        while not self.done:
            if self.pending:
                evaluate(self.z_eval)
                if self.pending:
                    raise EngineInputError("the evaluation did not answer the Newton iteration's request (answer or "
                                           "answer_failed)")
            self.next()

    def tangent_at(self, Fu: np.ndarray, Flam: np.ndarray, t_ref: np.ndarray, S: np.ndarray, Rs: np.ndarray,
                   anchor: np.ndarray | None = None) -> np.ndarray | None:
        """The corrector's unit tangent along ``t_ref`` at ``[F_u, F_lambda]`` (scaled by ``S``,
        ``Rs``; ``anchor`` rows in the scaled unknowns): ``gs_newton_tangent``, the rule the
        iteration applies at convergence; ``None`` where it has none."""
        nw = self.nw
        if self.kind != CORRECTOR:
            raise EngineInputError("the tangent is the corrector's (this is an orbit's iteration)")
        self.J[...] = _sized("F_u", Fu, self.J)
        self.Flam[:] = _sized("F_lambda", Flam, self.Flam)
        nw.flam_given = 1
        self.t_ref[:] = _sized("t_ref", t_ref, self.t_ref)
        self.S[:] = _sized("S", S, self.S)
        self.Rs[:] = _sized("Rs", Rs, self.Rs)
        nw.t_ref = _ptr(self.t_ref)
        na = self.anchor.shape[0]
        if anchor is not None:
            rows = np.asarray(anchor, float)
            if rows.shape != self.anchor.shape:
                raise EngineInputError(f"{rows.shape[0]} anchor rows of {rows.shape[-1]}; this iteration takes "
                                       f"{na} of {self.n}")
            self.anchor[...] = rows
        nw.n_anchor = na if anchor is not None else 0  # (without rows at hand: none)
        try:
            ok = self.lib.gs_newton_tangent(self.ref)
        finally:
            nw.n_anchor = na
        return self.tangent.copy() if ok == 1 else None

    # ------------------------------------------------------------ results
    @property
    def outcome(self) -> int:
        return int(self.nw.outcome)

    @property
    def message(self) -> str:
        """The failed evaluation's message (EVAL_FAILED; STALLED: the last failed trial's)."""
        return self.nw.eval_msg.decode("utf-8", errors="replace")

    def history(self) -> list[tuple[str, float, float, float, int]]:
        """The entries since the last start / restart: ``(kind, norm, relative, damping, dropped)``."""
        n = int(self.nw.n_hist)
        return list(zip([HISTORY_KINDS[int(k)] for k in self.h_kind[:n]], self.h_abs[:n].tolist(),
                        self.h_rel[:n].tolist(), self.h_step[:n].tolist(), self.h_drop[:n].tolist(), strict=True))
