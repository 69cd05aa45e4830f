"""Ctrl-C inside a C integration.

While a ctypes call runs, Python's own SIGINT handler only sets a flag: the
``KeyboardInterrupt`` is raised when the call returns, which for a long
integration can be many seconds later.  Around each driver call made from the
main thread, :func:`arm` installs a private non-blocking pipe as the signal wakeup
fd (:func:`signal.set_wakeup_fd`: the C-level handler writes the signal number to
it); the driver reads that pipe every few thousand right-hand side evaluations and
returns ``GS_ERR_INTERRUPTED`` when it holds a SIGINT byte.  :func:`disarm`
restores the previous wakeup fd.

Calls from other threads run without interrupt polling (only the main thread may
set the wakeup fd, and it is the one that receives the ``KeyboardInterrupt``); a
wakeup fd that somebody else installed (asyncio) is left alone.
"""

from __future__ import annotations

import os
import signal
import threading

__all__ = ["arm", "disarm"]

_pipe: tuple[int, int] | None = None  # (read end, write end)
_pipe_pid = -1  # process that created the pipe (a forked child makes its own)


def _get_pipe() -> tuple[int, int]:
    global _pipe, _pipe_pid
    if _pipe is None or _pipe_pid != os.getpid():
        _pipe = os.pipe2(os.O_NONBLOCK | os.O_CLOEXEC)
        _pipe_pid = os.getpid()
    return _pipe


def arm() -> tuple[int, int | None]:
    """Install the interrupt pipe as the signal wakeup fd, if this is the main thread.

    Returns
    -------
    fd, previous
        The read end the driver polls (``-1``: no polling) and the wakeup fd to
        give back to :func:`disarm` (``None``: nothing to restore).
    """
    if threading.current_thread() is not threading.main_thread():
        return -1, None
    r, w = _get_pipe()
    try:  # bytes left from an earlier signal are stale
        while os.read(r, 512):
            pass
    except BlockingIOError:
        pass
    try:
        old = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    except (ValueError, OSError):
        return -1, None
    if old not in (-1, w):  # somebody else's (e.g. asyncio's): leave it to them
        signal.set_wakeup_fd(old)
        return -1, None
    return r, old


def disarm(previous: int | None) -> None:
    """Restore the wakeup fd that :func:`arm` replaced."""
    if previous is not None:
        signal.set_wakeup_fd(previous)
