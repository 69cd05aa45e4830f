"""Command-line interface: ``gearsym inspect|compile|simulate ...``.

Exit codes: 0 success, 2 bad input (message on stderr, no traceback), 1 internal
or numerical failure, or a command that did not do what was asked (an orbit that
does not converge, a continuation that stops before the end of its range, a map
whose every point failed), 130 on Ctrl-C and 143 on SIGTERM (both stop worker
processes and remove temporary files before the exit).  ``--json`` prints one JSON object on stdout (strict
JSON: non-finite numbers are ``null``).  Every numeric option is checked before any
work (:mod:`gearsym.cli.checks`); every output file is written atomically
(:mod:`gearsym.files`).  ``-v`` / ``-vv`` / ``-q`` (before or after the command) set how much
of the ``gearsym`` log shows on stderr (:mod:`~gearsym.cli.verbosity`).

One module per command or command group (:mod:`~gearsym.cli.inspect_model`,
:mod:`~gearsym.cli.simulate`, :mod:`~gearsym.cli.orbits`, :mod:`~gearsym.cli.maps`,
:mod:`~gearsym.cli.modes`, :mod:`~gearsym.cli.lyapunov`, :mod:`~gearsym.cli.basins`, :mod:`~gearsym.cli.benchmark`, :mod:`~gearsym.cli.cache`,
:mod:`~gearsym.cli.catalog`), the shared argument checks in :mod:`~gearsym.cli.checks` and the
parser in :mod:`~gearsym.cli.parser`.  Importing the package imports none of numpy, sympy,
CasADi or the benchmark harness: each command imports what it needs when it runs.
"""

from __future__ import annotations

import sys

from ..errors import GearsymError
from .checks import UsageError
from .parser import build_parser
from .verbosity import log_level, logging_to_stderr

__all__ = ["build_parser", "main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``gearsym`` console script."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:  # one line, exit 2 (argparse would print the usage and exit)
        print(f"gearsym: error: {exc}", file=sys.stderr)
        return exc.exit_code
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        from ..extras import require_for_command
        from ..signals import sigterm_interrupts

        require_for_command(args)  # a missing optional dependency: exit 2, naming the extra
        # the log on stderr (-v, -vv, -q; gearsym.cli.verbosity); SIGTERM cleans up like Ctrl-C
        with logging_to_stderr(log_level(args)), sigterm_interrupts():
            return int(args.func(args) or 0)
    except GearsymError as exc:
        print(f"gearsym: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt as exc:  # Ctrl-C (130), or SIGTERM (Terminated: 143)
        signum = int(getattr(exc, "signum", 2))
        print("gearsym: " + ("terminated" if signum != 2 else "interrupted"), file=sys.stderr)
        return 128 + signum
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`): no traceback, no message
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except Exception as exc:  # internal error: short message, traceback on request
        if args.debug:
            import traceback

            traceback.print_exc()
        print(f"gearsym: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the "
              f"traceback)", file=sys.stderr)
        return 1
