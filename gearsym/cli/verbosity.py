"""``-v`` / ``-vv`` / ``-q`` of every command: how much of the ``gearsym`` log the CLI shows.

The library logs through :mod:`logging` (one logger per module under ``gearsym``) and
installs no handler; the CLI adds one for the duration of a command, writing to stderr:

========================  ==========  ==================================================
option                    level       what shows
========================  ==========  ==================================================
(none)                    WARNING     warnings and errors
``-v``                    INFO        also build cache hits / misses / rebuilds with the
                                      reason, compile times, the driver object, the static
                                      equilibrium's contact state, continuation stops
``-vv`` (or ``--debug``)  DEBUG       also the details (every cache check, every block of
                                      the dimensionless form)
``-q``                    ERROR       errors only
========================  ==========  ==================================================

The options are accepted before and after the command (``gearsym -v simulate ...``,
``gearsym simulate ... -v``; counts add up).  ``--debug`` (before the command) also prints
the traceback of an internal error, as before.  A command's own result messages
(``gearsym: error: ...`` and its exit code) do not depend on these options.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["FORMAT", "add_verbosity_options", "log_level", "logging_to_stderr"]

#: One log line on stderr: ``gearsym.facade: INFO: scene kahraman_singh: build cache hit, ...``.
FORMAT = "%(name)s: %(levelname)s: %(message)s"
_LEVELS = (logging.WARNING, logging.INFO, logging.DEBUG)


def add_verbosity_options(parser: argparse.ArgumentParser, *, dest_prefix: str = "") -> None:
    """Add ``-v/--verbose`` (repeatable) and ``-q/--quiet`` to ``parser`` (one or the other).

    ``dest_prefix`` keeps the counts of the top-level parser and of a subcommand apart
    (argparse would let the subcommand's default overwrite the top-level value).
    """
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-v", "--verbose", action="count", default=0, dest=f"{dest_prefix}verbose",
                       help="show what gearsym does on stderr: -v build cache, compile times, contact states, "
                            "why a continuation stopped; -vv also the details (log levels INFO, DEBUG)")
    group.add_argument("-q", "--quiet", action="store_true", dest=f"{dest_prefix}quiet",
                       help="show only errors on stderr (log level ERROR)")


def log_level(args: argparse.Namespace) -> int:
    """The log level of a parsed command line (see the module docstring)."""
    if getattr(args, "quiet", False) or getattr(args, "sub_quiet", False):
        return logging.ERROR
    count = int(getattr(args, "verbose", 0) or 0) + int(getattr(args, "sub_verbose", 0) or 0)
    if getattr(args, "debug", False):
        count = max(count, 2)
    return _LEVELS[min(count, len(_LEVELS) - 1)]


@contextmanager
def logging_to_stderr(level: int) -> Iterator[None]:
    """Show the ``gearsym`` log from ``level`` up on stderr while the block runs, then restore
    the logger's level and handlers (``main`` may run many times in one process)."""
    logger = logging.getLogger("gearsym")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(FORMAT))
    handler.setLevel(level)
    old_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(level)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
