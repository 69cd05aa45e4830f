"""Worker processes that die with their parent: the parallel runner of maps.

:func:`run_tasks` computes ``fn(shared, task)`` for every task, in this process
(``workers=1``), on local worker processes, or on a Dask cluster, and returns the results
in the order of the tasks.  ``shared`` (the compiled system) goes to each worker once.

Local workers are started with the ``spawn`` method (a fresh interpreter, never a fork of
a parent that may run threads) as direct children of the calling thread, and are tied to
the parent's life in three ways:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` set first thing in the worker (the kernel
  kills it when the thread that started it ends: SIGKILL of the parent included), followed
  by a check that the parent is still the one that started it (it may have died before);
* on every system, a *lifeline*: a pipe whose only writer is the parent; a thread of each
  worker blocks reading it and ends the worker as soon as it reads end-of-file, which the
  kernel delivers when the parent's end closes, whatever ended the parent;
* Ctrl-C / SIGTERM in the parent (``KeyboardInterrupt``; see :mod:`gearsym.signals`) stops
  every worker at once (SIGTERM, then SIGKILL after :data:`GRACE` seconds): no pending task
  is started after an interrupt.

Workers ignore SIGINT (Ctrl-C in a terminal reaches the whole process group; the parent
stops them).  A worker that dies while computing a task (a segmentation fault, an abort,
the out-of-memory killer) fails that task only: its result is a :class:`TaskFailure`
naming the signal, a new worker takes the remaining tasks.  An exception raised by
``fn`` is raised again in the parent (with the worker's traceback as a note), as from a
serial run.  No temporary file or folder is created (pipes only).

Progress: a task function may call :func:`report` (``report(n)``: ``n`` more units of its work
done); the parent's ``progress`` callback of :func:`run_tasks` receives them as they happen
(serial runs and local workers; on Dask a task's units arrive when it ends).  When a task ends,
whatever of its ``weights`` entry it has not reported is reported for it.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing as mp
import os
import pickle
import signal
import sys
import threading
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from ...errors import GearsymError

__all__ = ["GRACE", "TaskFailure", "WorkerStartError", "report", "run_tasks"]

#: Seconds a stopped worker gets to exit after SIGTERM before it is killed (SIGKILL).
GRACE = 1.0

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>

#: Where :func:`report` sends a task's progress (set while a task runs; ``None``: nowhere).
_REPORT: Callable[[int], None] | None = None


def report(n: int = 1) -> None:
    """Tell the parent that the running task has done ``n`` more units of its work (a no-op when
    nobody listens: on Dask, or outside :func:`run_tasks`).

    Parameters
    ----------
    n
        Units done since the last call (the task's ``weights`` entry counts them all).
    """
    if _REPORT is not None:
        _REPORT(int(n))


@dataclass(frozen=True)
class TaskFailure:
    """A task whose worker process died before returning its result.

    Attributes
    ----------
    index : int
        Position of the task.
    message : str
        What happened (``"the worker process died with signal SIGSEGV while computing this task"``).
    exitcode : int or None
        The worker's exit code (negative: ``-signal``).
    """

    index: int
    message: str
    exitcode: int | None


class WorkerStartError(GearsymError):
    """A worker process died before it could take tasks (while loading the shared object)."""


# ------------------------------------------------------------------ in the worker
def _die_with_parent(parent_pid: int, lifeline: Connection) -> None:
    """Tie this worker's life to its parent's (module docstring); end it now if the parent is gone."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the lifeline still works
            pass
    if os.getppid() != parent_pid:  # the parent died before the death signal was armed
        os._exit(1)

    def watch() -> None:
        with contextlib.suppress(EOFError, OSError):
            lifeline.recv()  # the parent never writes: this returns only at end-of-file
        os._exit(1)

    threading.Thread(target=watch, name="gearsym-lifeline", daemon=True).start()


def _send(conn: Connection, msg: tuple) -> None:
    """Send ``msg``; an unpicklable exception is sent as its text."""
    try:
        conn.send(msg)
    except (pickle.PicklingError, TypeError, AttributeError):
        kind, *rest = msg
        exc = rest[-2]
        conn.send((kind, *rest[:-2], RuntimeError(f"{type(exc).__name__}: {exc}"), rest[-1]))


def _worker_main(conn: Connection, lifeline: Connection, parent_pid: int, blob: bytes) -> None:
    """Entry point of a worker process: load ``(fn, shared)``, then run tasks until told to stop."""
    global _REPORT
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and stops us
    # started with Ctrl-C and SIGTERM blocked (_start_blocked): a Ctrl-C to the process group
    # during start-up stayed pending and is now discarded (SIGINT ignored); a pending SIGTERM
    # from the parent ends us now, as it would have
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STARTUP_BLOCKED)
    _die_with_parent(parent_pid, lifeline)
    try:
        fn, shared = pickle.loads(blob)
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises it
        _send(conn, ("init_error", exc, traceback.format_exc()))
        return
    conn.send(("ready",))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        index, task = msg
        _REPORT = lambda n, i=index: conn.send(("progress", i, n))  # noqa: E731
        try:
            result = fn(shared, task)
        except BaseException as exc:  # noqa: BLE001 - raised again in the parent
            _send(conn, ("raised", index, exc, traceback.format_exc()))
            return
        conn.send(("ok", index, result))


# ------------------------------------------------------------------ in the parent
#: signals blocked while a worker starts (:func:`_start_blocked`)
_STARTUP_BLOCKED = frozenset({signal.SIGINT, signal.SIGTERM})


def _start_blocked(proc: Any) -> None:
    """Start a worker process with Ctrl-C and SIGTERM blocked in the starting thread: the child
    inherits the mask through fork and exec, so a Ctrl-C sent to the whole process group (a
    terminal) while it imports gearsym waits until it has set SIGINT to be ignored instead of
    printing a KeyboardInterrupt traceback from its start-up; the parent receives any such
    signal as soon as the start returns (blocked signals stay pending, none is lost)."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _STARTUP_BLOCKED)
    try:
        proc.start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class _Worker:
    """One worker process, its connection and the task it computes."""

    def __init__(self, ctx: Any, lifeline: Connection, blob: bytes) -> None:
        self.conn, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=_worker_main, args=(child, lifeline, os.getpid(), blob),
                                name="gearsym-worker", daemon=True)
        _start_blocked(self.proc)
        child.close()
        self.task: int | None = None
        self.ready = False

    def give(self, index: int, task: Any) -> bool:
        """Send a task; ``False`` if the worker is gone."""
        try:
            self.conn.send((index, task))
        except (BrokenPipeError, ConnectionResetError, EOFError):
            return False
        self.task = index
        return True

    def stop(self) -> None:
        """Ask the worker to exit after its current task (it is idle when this is called)."""
        with contextlib.suppress(OSError, ValueError):
            self.conn.send(None)


def _reap(proc: Any) -> None:
    """Wait for a process whose sentinel is ready (the kernel closes its files a moment before
    it can be waited for); kill it if it lingers."""
    proc.join(GRACE)
    if proc.exitcode is None:
        with contextlib.suppress(OSError):
            proc.kill()
        proc.join()


def _death(proc: Any) -> str:
    code = proc.exitcode
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"the worker process died with {name} (exit code {code}) while computing this task"
    return f"the worker process exited (exit code {code}) while computing this task"


def _stop_all(workers: list[_Worker], graceful: bool) -> None:
    """End every worker: idle ones are asked to exit; after an error or an interrupt they are
    terminated (SIGTERM, then SIGKILL after :data:`GRACE` seconds)."""
    for w in workers:
        if graceful and w.task is None:
            w.stop()
        else:
            with contextlib.suppress(OSError):
                w.proc.terminate()
    for w in workers:
        w.proc.join(GRACE if graceful else GRACE / 2)
    for w in workers:
        if w.proc.exitcode is None:
            with contextlib.suppress(OSError):
                w.proc.kill()
            w.proc.join()
        w.conn.close()
        w.proc.close()


class _Run:
    """The state of one :func:`run_tasks` call on local processes."""

    def __init__(self, tasks: Sequence[Any], n_workers: int, blob: bytes, meter: _Meter) -> None:
        self.meter = meter
        self.ctx = mp.get_context("spawn")
        self.tasks = tasks
        self.pending = deque(range(len(tasks)))
        self.results: list[Any] = [None] * len(tasks)
        self.blob = blob
        self.lifeline_r, self.lifeline_w = self.ctx.Pipe(duplex=False)
        self.n_workers = n_workers
        self.workers: list[_Worker] = []

    def _start(self) -> _Worker:
        return _Worker(self.ctx, self.lifeline_r, self.blob)

    def _next(self, w: _Worker) -> None:
        """Give ``w`` the next pending task, or tell it to stop."""
        w.task = None
        while self.pending:
            index = self.pending.popleft()
            if w.give(index, self.tasks[index]):
                return
            self.pending.appendleft(index)  # the worker is gone: its sentinel tells
            return
        w.stop()

    def _message(self, w: _Worker, msg: tuple) -> None:
        kind = msg[0]
        if kind == "ready":
            w.ready = True
            self._next(w)
        elif kind == "progress":
            self.meter.add(msg[1], msg[2])
        elif kind == "ok":
            self.results[msg[1]] = msg[2]
            self.meter.done(msg[1], msg[2])
            self._next(w)
        elif kind == "raised":
            exc, tb = msg[2], msg[3]
            exc.add_note(f"in a worker process, computing task {msg[1]}:\n{tb}")
            raise exc
        elif kind == "init_error":
            exc, tb = msg[1], msg[2]
            exc.add_note(f"in a worker process, loading the shared object:\n{tb}")
            raise exc

    def _died(self, w: _Worker) -> None:
        """``w``'s process ended: read what it sent, fail its task, replace it."""
        while True:
            try:
                if not w.conn.poll():
                    break
                self._message(w, w.conn.recv())
            except (EOFError, OSError):
                break
        self.workers.remove(w)
        _reap(w.proc)
        if not w.ready:
            code = w.proc.exitcode
            w.conn.close()
            raise WorkerStartError(f"a worker process ended (exit code {code}) before it could take tasks; its "
                                   f"error output, if any, is above (a script that runs maps in parallel needs "
                                   f"an 'if __name__ == \"__main__\":' guard)")
        if w.task is not None:
            self.results[w.task] = TaskFailure(w.task, _death(w.proc), w.proc.exitcode)
            self.meter.done(w.task, self.results[w.task])
        w.conn.close()
        w.proc.close()
        if self.pending:
            self.workers.append(self._start())

    def loop(self) -> list[Any]:
        """Start the workers and run until every task has a result."""
        for _ in range(min(self.n_workers, len(self.tasks))):
            self.workers.append(self._start())
        while self.workers:
            by_conn = {w.conn: w for w in self.workers}
            by_sentinel = {w.proc.sentinel: w for w in self.workers}
            for obj in wait(list(by_conn) + list(by_sentinel)):
                if obj in by_conn:
                    w = by_conn[obj]
                    if w not in self.workers:
                        continue
                    try:
                        msg = w.conn.recv()
                    except (EOFError, OSError):
                        continue  # it died: its sentinel is (or becomes) ready
                    self._message(w, msg)
                else:
                    w = by_sentinel[obj]
                    if w in self.workers:
                        self._died(w)
        return self.results

    def close(self, graceful: bool) -> None:
        _stop_all(self.workers, graceful)
        self.workers = []
        self.lifeline_w.close()
        self.lifeline_r.close()


class _Meter:
    """The progress of the tasks (units reported per task, the rest of its weight when it ends) and
    the ``on_result`` callback of each finished task."""

    def __init__(self, progress: Callable[[int], None] | None, weights: Sequence[int] | None, n: int,
                 on_result: Callable[[int, Any], None] | None) -> None:
        self.progress = progress
        self.on_result = on_result
        self.weights = [int(w) for w in weights] if weights is not None else [1] * n
        self.reported = [0] * n

    def add(self, index: int, n: int) -> None:
        """``n`` more units of task ``index`` (at most its weight in all)."""
        n = min(int(n), max(0, self.weights[index] - self.reported[index]))
        if n > 0 and self.progress is not None:
            self.reported[index] += n
            self.progress(n)

    def done(self, index: int, result: Any) -> None:
        """Task ``index`` finished with ``result``."""
        self.add(index, self.weights[index] - self.reported[index])
        if self.on_result is not None:
            self.on_result(index, result)


def _run_serial(fn: Callable[[Any, Any], Any], shared: Any, tasks: Sequence[Any], meter: _Meter) -> list[Any]:
    global _REPORT
    saved = _REPORT
    out = []
    try:
        for i, t in enumerate(tasks):
            _REPORT = lambda n, i=i: meter.add(i, n)  # noqa: E731
            out.append(fn(shared, t))
            meter.done(i, out[-1])
    finally:
        _REPORT = saved
    return out


def _run_local(fn: Callable[[Any, Any], Any], shared: Any, tasks: Sequence[Any], n_workers: int,
               meter: _Meter) -> list[Any]:
    run = _Run(tasks, n_workers, pickle.dumps((fn, shared)), meter)
    graceful = False
    try:
        results = run.loop()
        graceful = True
        return results
    finally:
        run.close(graceful)


def _run_dask(fn: Callable[[Any, Any], Any], shared: Any, tasks: Sequence[Any], dask: Any, meter: _Meter
              ) -> list[Any]:
    from distributed import Client, as_completed

    client = dask if isinstance(dask, Client) else Client(dask)
    try:
        futures = client.map(_apply, [(fn, shared, t) for t in tasks], pure=False)
        where = {f.key: i for i, f in enumerate(futures)}
        results: list[Any] = [None] * len(tasks)
        for f in as_completed(futures):
            i = where[f.key]
            results[i] = f.result()  # (raises the task's exception, as the serial run would)
            meter.done(i, results[i])
        return results
    finally:
        if client is not dask:  # our own Client: close it (Client.shutdown would stop the cluster)
            client.close()


def _apply(args: tuple[Callable[[Any, Any], Any], Any, Any]) -> Any:
    fn, shared, task = args
    return fn(shared, task)


def run_tasks(fn: Callable[[Any, Any], Any], shared: Any, tasks: Sequence[Any], *, workers: int = 1,
              dask: Any = None, on_result: Callable[[int, Any], None] | None = None,
              progress: Callable[[int], None] | None = None,
              weights: Sequence[int] | None = None) -> tuple[list[Any], str]:
    """Compute ``fn(shared, task)`` for every task.

    Parameters
    ----------
    fn
        A module-level (picklable) function.
    shared
        Its first argument, the same for every task (pickled once per worker).
    tasks
        Its second arguments.
    workers
        Local worker processes (``1``, or a single task: this process).
    dask
        Scheduler address or ``distributed.Client``: run on that cluster instead.
    on_result
        Called in this process with ``(index, result)`` as each task finishes (in the order
        they finish; a progress bar), the result a :class:`TaskFailure` for a task whose local
        worker died.
    progress
        Called in this process with the units of work done (module docstring: :func:`report`).
    weights
        The units of work of each task (default 1 each).

    Returns
    -------
    results, runner
        One result per task, in order (a :class:`TaskFailure` for a task whose local worker
        died), and a label of how they ran (``"serial"``, ``"processes(N)"``, ``"dask"``).

    Raises
    ------
    Exception
        Whatever ``fn`` raised (the first one), or :class:`WorkerStartError`.
    KeyboardInterrupt
        Ctrl-C or SIGTERM (:class:`gearsym.signals.Terminated`): the workers are stopped first.
    """
    meter = _Meter(progress, weights, len(tasks), on_result)
    if dask is not None:
        return _run_dask(fn, shared, tasks, dask, meter), "dask"
    if workers <= 1 or len(tasks) <= 1:
        return _run_serial(fn, shared, tasks, meter), "serial"
    n = min(workers, len(tasks))
    return _run_local(fn, shared, tasks, n, meter), f"processes({n})"
