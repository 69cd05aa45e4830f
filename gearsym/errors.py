"""Exception hierarchy of gearsym.

Every error a user can provoke (bad spec, bad scene, bad parameter, failed
simulation, non-converged Newton) is a :class:`GearsymError`; the CLI turns these
into a one-line message on stderr and exit code 2 (bad input) or 1 (internal
or numerical failure).
"""

from __future__ import annotations

import re

_CONTROL = re.compile(r"[\x00-\x1f\x7f\x85\u2028\u2029]")


def one_line(text: str) -> str:
    """``text`` with control characters and line breaks escaped (``\\n``), so that a
    message quoting user input stays on one line."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode(), text)


class GearsymError(Exception):
    """Base class of all gearsym errors."""

    exit_code = 1


class SpecError(GearsymError):
    """A model or scene file is malformed or inconsistent.

    Parameters
    ----------
    message
        What is wrong.
    file
        The file the problem is in (path as given), if known.
    field
        Dotted field path inside the file, e.g. ``elements.mesh.stiffness``.
    """

    exit_code = 2

    def __init__(self, message: str, file: str | None = None, field: str | None = None):
        message, file, field = one_line(message), file and one_line(file), field and one_line(field)
        self.message = message
        self.file = file
        self.field = field
        where = ""
        if file:
            where += f"{file}"
        if field:
            where += f": field '{field}'" if where else f"field '{field}'"
        super().__init__(f"{where}: {message}" if where else message)


class ParameterError(GearsymError):
    """A parameter override or value is invalid (unknown, non-finite, wrong effect)."""

    exit_code = 2


class OverrideError(ParameterError):
    """A parameter override (``load_scene(**overrides)``, ``--set``) is invalid.

    Parameters
    ----------
    parameter
        The parameter's name.
    reason
        What is wrong (the command line reports it as ``--set NAME: reason``).
    named
        Whether ``reason`` names the parameter itself (the message is then ``reason``, else
        ``parameter 'NAME': reason``).
    """

    def __init__(self, parameter: str, reason: str, named: bool = False):
        self.parameter = one_line(str(parameter))
        self.reason = one_line(reason)
        super().__init__(self.reason if named else f"parameter '{self.parameter}': {self.reason}")


class CompileError(GearsymError):
    """Code generation or the C compiler failed."""


class SimulationError(GearsymError):
    """The integrator failed (too much work, non-finite state, solver failure)."""


class ConvergenceError(GearsymError):
    """An iterative solver (Newton, continuation corrector) did not converge."""
