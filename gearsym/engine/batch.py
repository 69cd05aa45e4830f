"""Many initial states over one time span in one C call (``gs_simulate_batch``, gs_batch.c).

:func:`run_batch` integrates ``n`` initial states from ``t0`` to ``t_end`` with the same
settings and output grid, in one ctypes call: the C driver runs :meth:`Engine.run`'s
integration once per state and returns every state's output grid, end state, surface sides,
status and counts.  One :meth:`Engine.run` per state costs about 30 us of Python (argument
struct, buffers, result object), as much as half a forcing period of the benchmark
oscillator's integration; a batch costs that once.  A state whose integration fails does not
stop the batch: its ``status`` says why (``GS_ERR_*`` of ``gs_driver.h``, names in
:data:`STATUS_NAMES`).  Used by basins of attraction (:func:`gearsym.analysis.sweeps.basins`).
"""

from __future__ import annotations

import ctypes as C
from dataclasses import dataclass
from typing import Any

import numpy as np

from gearsym.engine.driver import INDEX_MAX, METHODS, Engine, _ptr
from gearsym.engine.errors import EngineABIError, EngineInputError
from gearsym.engine.run_settings import RunSettings, settings_from_keywords
from gearsym.engine.sim_args import GsSimArgs
from gearsym.integrators import DEFAULT_METHOD, EXPLICIT

__all__ = ["STATUS_NAMES", "BatchResult", "run_batch"]

#: Status codes of ``gs_driver.h`` -> short names.
STATUS_NAMES: dict[int, str] = {0: "ok", -1: "too much work", -2: "event storm", -3: "non-finite", -4: "solver",
                                -5: "abi", -6: "input", -7: "max events", -8: "interrupted"}

_GS_ERR_INPUT = -6

#: Most values of one batch's output (states x output times x state entries).
MAX_BATCH_VALUES = 50_000_000


@dataclass(frozen=True)
class BatchResult:
    """The runs of one :func:`run_batch` call.

    Attributes
    ----------
    y : ndarray, shape (n, n_out, nx)
        Each state's states at the output times.
    x_final : ndarray, shape (n, nx)
        Each state's state at ``t_end`` (meaningless where ``status != 0``).
    sigma_final : ndarray, shape (n, nsw)
        Side (+1/-1) of each switching surface at ``t_end``.
    status : ndarray of int, shape (n,)
        0, or the ``GS_ERR_*`` code of the run's failure (:data:`STATUS_NAMES`).
    n_events, n_steps, n_rhs : ndarray of int, shape (n,)
        Events, internal steps and right-hand side evaluations of each run.
    message : str
        The first failed run's message (``"state i: ..."``), or ``""``.
    """

    y: np.ndarray
    x_final: np.ndarray
    sigma_final: np.ndarray
    status: np.ndarray
    n_events: np.ndarray
    n_steps: np.ndarray
    n_rhs: np.ndarray
    message: str = ""


def _bind(engine: Engine) -> Any:
    """The loaded ``gs_simulate_batch`` with its ctypes signature."""
    lib = engine._lib
    fn = getattr(lib, "gs_simulate_batch", None)
    if fn is None:
        raise EngineABIError(f"{engine.path} does not export gs_simulate_batch (built by an older gearsym); rebuild "
                             "it (gearsym compile --force)")
    if fn.restype is not C.c_int or fn.argtypes is None:
        fn.restype = C.c_int
        fn.argtypes = [C.c_void_p, C.POINTER(GsSimArgs), C.c_int, C.c_void_p, C.c_void_p, C.c_void_p, C.c_void_p,
                       C.c_void_p, C.c_void_p, C.c_void_p]
    return fn


def run_batch(engine: Engine, x0s: Any, p: Any, t0: float, t_end: float, t_out: Any = None,
              settings: RunSettings | None = None, *, sigma0s: Any = None, atol_vec: Any = None,
              **keywords: Any) -> BatchResult:
    """Integrate ``n`` initial states from ``t0`` to ``t_end`` in one C call.

    Parameters
    ----------
    engine
        The loaded model (:attr:`gearsym.System.engine`).
    x0s
        Initial states, shape (n, nx).
    p
        Parameter vector, shape (np,) (SI: :meth:`gearsym.system.System.param_vector`).
    t0, t_end
        Time span of every run, ``t_end > t0``.
    t_out
        Ascending output times in ``[t0, t_end]``, the same for every run (default: none).
    sigma0s
        Side (+1/-1) of each switching surface at ``t0`` per state, shape (n, nsw) (default:
        from the signs of the switching functions), e.g. the ``sigma_final`` of a previous batch.
    settings
        The run settings of every state (:class:`~gearsym.engine.run_settings.RunSettings`: ``method``,
        ``rtol``, ``atol``, ``max_step``, ``max_steps``, ``max_events``; default: the registry's method
        for explicit models, as :meth:`gearsym.engine.driver.Engine.run` otherwise).
    atol_vec
        Absolute tolerance per state (nx entries).
    **keywords
        Fields of ``settings`` to replace (``method="adams"``, ``rtol=1e-9``, ...).

    Returns
    -------
    BatchResult

    Raises
    ------
    EngineInputError
        Wrong shapes, an unknown method, a batch above :data:`MAX_BATCH_VALUES` output values,
        or settings the driver refuses for every state (bad time span, tolerances, output grid).
    KeyboardInterrupt
        Ctrl-C during the batch (checked between runs and within each).
    """
    if settings is None and "method" not in keywords:  # the registry's default for explicit models
        keywords = {"method": DEFAULT_METHOD[EXPLICIT], **keywords}
    s = settings_from_keywords(settings, keywords)  # checks the method and the counts
    method, rtol, atol, max_step, max_steps, max_events = (s.method, s.rtol, s.atol, s.max_step, s.max_steps,
                                                           s.max_events)
    nx, nsw = engine.nx, engine.nsw
    X = np.ascontiguousarray(np.asarray(x0s, dtype=float))
    if X.ndim != 2 or X.shape[1] != nx:
        raise EngineInputError(f"x0s must have shape (n, {nx}), got {X.shape}")
    n = X.shape[0]
    if n > INDEX_MAX:
        raise EngineInputError(f"{n:,} states: a batch takes at most {INDEX_MAX:,}")
    pa = np.ascontiguousarray(np.asarray(p, dtype=float).reshape(-1))
    if pa.shape[0] != engine.np:
        raise EngineInputError(f"p has {pa.shape[0]} entries, the model has np={engine.np} parameters")
    tout = np.ascontiguousarray(np.asarray(t_out if t_out is not None else [], dtype=float).reshape(-1))
    if n * tout.shape[0] * nx > MAX_BATCH_VALUES:
        raise EngineInputError(f"a batch of {n} states x {tout.shape[0]} output times x {nx} states is above "
                               f"{MAX_BATCH_VALUES:,} values: split it")
    S = None
    if sigma0s is not None:
        S = np.ascontiguousarray(np.asarray(sigma0s, dtype=float))
        if S.shape != (n, nsw):
            raise EngineInputError(f"sigma0s must have shape ({n}, {nsw}), got {S.shape}")
    av = None
    if atol_vec is not None:
        av = np.ascontiguousarray(np.broadcast_to(np.asarray(atol_vec, dtype=float), (nx,)))
    fn = _bind(engine)
    first = X[0] if n else np.zeros(nx)
    a, keep = engine._prepare(first, pa, float(t0), float(t_end), tout, METHODS[method], float(rtol), float(atol),
                              None, False, int(max_steps), float(max_step), 0.0, int(max_events), 0, 0.0, 1, 0, 0,
                              av, None)
    y = np.empty((n, tout.shape[0], nx))
    xf = np.empty((n, nx))
    sf = np.zeros((n, max(nsw, 1)))
    status = np.zeros(n, dtype=np.intc)
    counts = np.zeros((n, 3), dtype=np.int_)
    if C.sizeof(C.c_long) != counts.itemsize:  # (np.int_ is C long on every platform numpy supports but Windows)
        counts = np.zeros((n, 3), dtype=np.int64 if C.sizeof(C.c_long) == 8 else np.int32)
    if n:
        engine._call(fn, a, n, _ptr(X), _ptr(S), _ptr(y) if tout.shape[0] else None, _ptr(xf),
                     _ptr(sf) if nsw else None, _ptr(status), _ptr(counts))
    del keep  # (the template's buffers lived until the call returned)
    msg = a.errmsg.decode("utf-8", errors="replace")
    if n and np.all(status == _GS_ERR_INPUT):  # the template itself (time span, tolerances, grid) is refused
        raise EngineInputError(f"every state of the batch was refused; {msg}")
    return BatchResult(y=y, x_final=xf, sigma_final=sf[:, :nsw], status=status.astype(int),
                       n_events=counts[:, 0].astype(int), n_steps=counts[:, 1].astype(int),
                       n_rhs=counts[:, 2].astype(int), message=msg)
