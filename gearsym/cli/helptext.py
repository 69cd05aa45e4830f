"""The ``Examples:`` section that ends every subcommand's ``--help``, and the help layout.

Every subcommand's epilog is :func:`examples`: one to three command lines on shipped
scenes, each with what it does, cheap enough that the test suite runs every one of them
(``tests/test_cli_examples.py`` iterates over the parser's subcommands, so a new command
needs its examples to pass).  The layout reads well in a terminal and is valid
reStructuredText, as the documentation renders epilogs (sphinx-argparse)::

    Examples:

      gearsym simulate kahraman_singh --periods 50 --json
          50 forcing periods of the benchmark oscillator; one JSON object on stdout

:class:`HelpFormatter` fills paragraphs to the terminal's width (as argparse does) but keeps
indented blocks such as the examples as they are written.
"""

from __future__ import annotations

import argparse
import re
import textwrap

__all__ = ["HEADING", "HelpFormatter", "examples"]

#: The line that starts the examples of a subcommand's epilog.
HEADING = "Examples:"


def examples(*pairs: tuple[str, str], note: str = "") -> str:
    """The epilog of a subcommand: ``HEADING``, then each ``(command line, what it does)``.

    Parameters
    ----------
    *pairs
        One to three ``(command, description)``; the command starts with ``gearsym`` and
        stays on one line (to be copied), the description is wrapped at 90 columns.
    note
        A paragraph after the examples (optional).

    Raises
    ------
    ValueError
        If there are no examples or more than three, or a command does not start with
        ``gearsym``.
    """
    if not 1 <= len(pairs) <= 3:
        raise ValueError(f"give one to three examples, got {len(pairs)}")
    lines = [HEADING, ""]
    for command, what in pairs:
        if not command.startswith("gearsym "):
            raise ValueError(f"an example command starts with 'gearsym ': {command!r}")
        lines += [f"  {command}", textwrap.fill(what, 90, initial_indent=" " * 6, subsequent_indent=" " * 6)]
    return "\n".join(lines) + (f"\n\n{note}" if note else "") + "\n"


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that a block of the description or epilog with
    indented lines (the examples) is kept line for line; other paragraphs are filled."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        blocks = re.split(r"\n[ \t]*\n", text.strip("\n"))
        out = []
        for block in blocks:
            lines = block.splitlines()
            if any(line.startswith((" ", "\t")) for line in lines):
                out.append("\n".join(indent + line.rstrip() for line in lines))
            else:
                out.append(super()._fill_text(block, width, indent))
        return "\n\n".join(out)
