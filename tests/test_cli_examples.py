"""Every subcommand's ``--help`` ends with examples on shipped scenes, and every example runs (issue 29).

The subcommands are taken from the parser itself (its subparsers action), so a command
added later is covered without touching this file: it needs an ``Examples:`` epilog
(:func:`gearsym.cli.helptext.examples`) of one to three commands that exit 0 here.  Each
example runs in-process in a fresh folder (``--out`` and ``init`` write there) and with the
build cache of the test run, so compiled scenes are reused; an example with ``--json``
must print one JSON object.  The epilogs are parsed here with a regular expression of
this file (not with gearsym's own helper) and checked to be clean reStructuredText, as
the documentation renders them (sphinx-argparse).
"""

from __future__ import annotations

import argparse
import json
import re
import shlex

import pytest

from gearsym.cli import build_parser, main

#: an example line of an epilog: two spaces, then the command
_EXAMPLE = re.compile(r"^  (gearsym\s.*?)\s*$")


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert len(actions) == 1
    return dict(actions[0].choices)


def _examples(epilog: str | None) -> list[str]:
    """The command lines of the ``Examples:`` block of an epilog ([] if there is none)."""
    lines = (epilog or "").splitlines()
    if "Examples:" not in lines:
        return []
    out = []
    for line in lines[lines.index("Examples:") + 1:]:
        if not line.strip():
            if out:
                break  # the blank line after the examples ends them
            continue
        m = _EXAMPLE.match(line)
        if m:
            out.append(m.group(1))
        elif not line.startswith("      "):  # a description is indented further
            break
    return out


SUBCOMMANDS = _subcommands()
CASES = [pytest.param(name, cmd, id=f"{name}-{i}")
         for name, p in sorted(SUBCOMMANDS.items()) for i, cmd in enumerate(_examples(p.epilog))]


def test_the_parser_has_the_known_subcommands():
    # a guard for the iteration below: the subcommands of the design and of issue 29 are all there
    assert {"inspect", "compile", "simulate", "bench", "continue", "orbit", "export", "modes", "map",
            "stiffness", "lyapunov", "cache", "models", "init"} <= set(SUBCOMMANDS)


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_every_subcommand_help_ends_with_one_to_three_examples(name, capsys):
    cmds = _examples(SUBCOMMANDS[name].epilog)
    assert 1 <= len(cmds) <= 3, f"gearsym {name}: {len(cmds)} examples in its epilog"
    assert all(shlex.split(c)[1] == name for c in cmds), cmds
    with pytest.raises(SystemExit) as info:
        main([name, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    tail = out[out.rindex("Examples:"):]
    assert "options:" in out[: out.rindex("Examples:")]  # after the options: at the end of the help
    for c in cmds:  # each example on a line of its own, as written
        assert f"\n  {c}\n" in tail


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_every_epilog_is_clean_restructuredtext(name):
    docutils_core = pytest.importorskip("docutils.core")
    doc = docutils_core.publish_doctree(SUBCOMMANDS[name].epilog, settings_overrides={
        "report_level": 1, "halt_level": 5, "warning_stream": False})
    problems = [m.astext() for m in doc.findall(lambda n: n.tagname == "system_message")]
    assert problems == []


@pytest.mark.parametrize(("name", "command"), CASES)
def test_every_example_runs(name, command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    argv = shlex.split(command)
    assert argv[0] == "gearsym"
    code = main(argv[1:])
    out, err = capsys.readouterr()
    assert code == 0, f"{command}\nexit {code}\n{err[-2000:]}"
    if "--json" in argv:
        assert isinstance(json.loads(out), dict)
