"""SIGTERM handled like Ctrl-C.

A process that is asked to stop (``kill PID``, a batch scheduler's time limit, a container
shutdown) gets SIGTERM, whose default action ends the process at once: worker processes,
temporary files and folders stay behind.  Inside :func:`sigterm_interrupts` (the CLI runs
every command in it) SIGTERM raises :class:`Terminated` in the main thread instead, a
``KeyboardInterrupt``: every clean-up that runs on Ctrl-C runs (``finally`` blocks, worker
pools stopped, atomic writes undone), a running C integration stops within a few thousand
right-hand side evaluations (:func:`gearsym.engine.interrupt.signal_mask`), and the CLI exits
with ``128 + 15``.

:func:`run_child` runs a child process (the C compiler) so that an interrupt lets it clean up:
it is asked to stop with SIGTERM (gcc then removes its temporary files) and killed only if it
does not.
"""

from __future__ import annotations

import signal
import subprocess
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

__all__ = ["Terminated", "run_child", "sigterm_interrupts", "sigterm_raises"]


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived inside :func:`sigterm_interrupts`: a request to stop, handled like Ctrl-C.

    Attributes
    ----------
    signum : int
        ``signal.SIGTERM`` (the CLI exits with ``128 + signum``).
    """

    signum = int(signal.SIGTERM)


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated(f"terminated by signal {signum}")


@contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread.

    Only in the main thread, and only when SIGTERM has its default action (an ignored
    SIGTERM, or a handler somebody else installed, is left alone); the previous handler is
    restored when the block ends.
    """
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def sigterm_raises() -> bool:
    """Whether SIGTERM raises :class:`Terminated` now (inside :func:`sigterm_interrupts`)."""
    return signal.getsignal(signal.SIGTERM) is _raise_terminated


def run_child(cmd: Sequence[str], *, grace: float = 2.0, **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(cmd, capture_output=True, text=True, **kwargs)``, stopped gently on an interrupt.

    On any exception while the child runs (Ctrl-C, :class:`Terminated`), the child gets
    SIGTERM and ``grace`` seconds to exit (a compiler removes its temporary files), then
    SIGKILL; the exception propagates.  (``subprocess.run`` kills at once: gcc's ``cc*.s``
    files stay in TMPDIR.)
    """
    with subprocess.Popen(list(cmd), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs) as proc:
        try:
            out, err = proc.communicate()
        except BaseException:
            proc.terminate()
            try:
                proc.wait(grace)
            except subprocess.TimeoutExpired:
                proc.kill()
            raise
    return subprocess.CompletedProcess(list(cmd), proc.returncode, out, err)
