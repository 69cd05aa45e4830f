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

SIGTERM: inside :func:`gearsym.signals.sigterm_interrupts` (the CLI runs every command in
it) a SIGTERM raises :class:`~gearsym.signals.Terminated` (a ``KeyboardInterrupt``) in the
main thread, and the driver stops on it as on SIGINT (:func:`signal_mask`), so that a
terminated command cleans up as an interrupted one does.
"""

from __future__ import annotations

import os
import signal
import threading

from ..signals import sigterm_raises

__all__ = ["ENABLED", "arm", "disarm", "signal_mask"]

#: Poll for Ctrl-C during driver calls (benchmarks/interrupt_overhead.py turns it off to
#: measure what it costs).
ENABLED = True

_pipe: tuple[int, int] | None = None  # (read end, write end)
_MAIN_THREAD = threading.main_thread().ident

#: ``check_interrupt`` bits of the driver (gs_driver.h): the signals that stop a run
GS_INTR_SIGINT = 1
GS_INTR_SIGTERM = 2


def signal_mask() -> int:
    """The driver's ``check_interrupt`` bits now: SIGINT always, SIGTERM inside
    :func:`gearsym.signals.sigterm_interrupts` (while its handler raises
    :class:`~gearsym.signals.Terminated`)."""
    return GS_INTR_SIGINT | (GS_INTR_SIGTERM if sigterm_raises() else 0)


def _reset_after_fork() -> None:  # a forked child makes its own pipe
    global _pipe
    _pipe = None


os.register_at_fork(after_in_child=_reset_after_fork)


def arm() -> tuple[int, int | None]:
    """Install the interrupt pipe as the signal wakeup fd, if this is the main thread.

    Bytes left in the pipe from an earlier call are discarded by the driver when it
    starts (cheaper there than here; a signal in the microseconds between this call
    and the driver's start is still handled by Python when the call returns).

    Returns
    -------
    fd, previous
        The read end the driver polls (``-1``: no polling) and the wakeup fd to
        give back to :func:`disarm` (``None``: nothing to restore).
    """
    global _pipe
    if not ENABLED or threading.get_ident() != _MAIN_THREAD:
        return -1, None
    if _pipe is None:
        _pipe = os.pipe2(os.O_NONBLOCK | os.O_CLOEXEC)
    r, w = _pipe
    try:
        old = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    except (ValueError, OSError):
        return -1, None
    if old != -1 and old != w:  # somebody else's (e.g. asyncio's): leave it to them
        signal.set_wakeup_fd(old)
        return -1, None
    return r, old


def disarm(previous: int | None) -> None:
    """Restore the wakeup fd that :func:`arm` replaced."""
    if previous is not None:
        signal.set_wakeup_fd(previous)
