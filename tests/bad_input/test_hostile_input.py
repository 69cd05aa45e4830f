"""Hostile spec files: expressions and names written by an attacker (or an unlucky user).

Every case is a model or scene file that tries to run code (each payload would create a
marker file), to inject C through a name, to escape the build folder, to hang sympy or to
blow the stack.  Each one must be rejected up front by ``inspect``, ``compile`` and
``simulate``: exit 2, one line naming the file and the field, no traceback, nothing
written, and the marker file never appears.

Each case runs in-process through :func:`gearsym.cli.main` for all three commands (cheap)
and once as a real ``python -m gearsym.cli`` subprocess (the command rotates through the
three), with the checks of :func:`._helpers.check_case`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from gearsym import cli

from ._helpers import KS_MODEL, SPUR_MODEL, Case, check_case, sub

M = "m.toml"
S = "s.toml"
LOAD = 'value = ["Fm",'   # first term of the load force of the KS model: elements.load.value[0]
LOAD_FIELD = "elements.load.value[0]"


def _sh(marker: str) -> str:
    return f"touch {marker}"


def _toml(text: str) -> str:
    """A TOML basic string holding ``text`` (JSON escapes are valid TOML escapes)."""
    return json.dumps(text)


@dataclass
class Hostile:
    """A hostile input: the files to write (``{SH}`` becomes a shell command creating the
    marker file) and what the one-line message must name besides ``file``."""

    id: str
    model: str | None               # model file text (None: not written)
    needles: tuple[str, ...]
    file: str = M                   # the file the message must name
    scene_name: str = '"s"'         # TOML value of [scene] name
    model_ref: str = M              # the scene's model path
    setup: Callable[[Path], object] | None = None  # run in the working folder first


def expr_case(id_: str, expr: str, *needles: str) -> Hostile:
    """The KS model with ``expr`` as the first term of the load force."""
    return Hostile(id_, sub(KS_MODEL, LOAD, "value = [" + _toml(expr) + ","), (LOAD_FIELD, *needles))


def name_case(id_: str, old: str, new: str, field: str, *needles: str, model: str = KS_MODEL) -> Hostile:
    """A shipped model with one declaration replaced."""
    return Hostile(id_, sub(model, old, new), (field, *needles))


def derived_case(id_: str, derived: list[str], expr: str, *needles: str) -> Hostile:
    """The KS model with a ``[derived]`` table (``name = "expression"`` lines) and ``expr`` as
    the first term of the load force."""
    table = "[derived]\n" + "\n".join(f"{line.split('=', 1)[0].strip()} = {_toml(line.split('=', 1)[1].strip())}"
                                       for line in derived) + "\n\n[forcing]"
    return Hostile(id_, sub(sub(KS_MODEL, LOAD, "value = [" + _toml(expr) + ","), "[forcing]", table), needles)


def term_case(id_: str, table: str, *needles: str) -> Hostile:
    """The KS model with the TOML ``table`` as the first term of the load force."""
    return Hostile(id_, sub(KS_MODEL, LOAD, "value = [" + table + ","), needles)


#: the issue's symbolic hangs (gearsym issue 25, item 6) and more of their kind: each used to
#: run for minutes or hours in sympy (or end in an internal error) and must now be refused at once
BUDGETS = [
    expr_case("Max of 256 state-dependent arguments",
              "Max(" + ", ".join(f"{i + 1}*x - {i}*v" for i in range(256)) + ")",
              "Max() of the states with 256 arguments"),
    derived_case("power tower of integers over derived", ["c1 = 2**64"] + [f"c{k} = c{k - 1}**64" for k in range(2, 7)],
                 "Fm*c6/c6", "derived.c2.value", "number out of range"),
    derived_case("power tower of a state over derived", ["c1 = x**64"] + [f"c{k} = c{k - 1}**64" for k in range(2, 7)],
                 "Fm*c6", "derived.c2.value", "polynomial degree of 4096"),
    derived_case("24-step derived chain of products of a state",
                 ["d0 = x"] + [f"d{k} = (d{k - 1} + b)*(d{k - 1} + 2*b)" for k in range(1, 25)],
                 "Fm*d24", "derived.d9.value", "too large for the symbolic layer"),
    derived_case("24-step derived chain of products of a parameter",
                 ["d0 = b"] + [f"d{k} = (d{k - 1} + b)*(d{k - 1} + 2*b)" for k in range(1, 25)],
                 "Fm*d24", "derived.d9.value", "too large for the symbolic layer"),
    expr_case("floor of a state", "Fm*floor(x)", "floor() of the states"),
    expr_case("floor of time", "Fm*floor(Omega*t)", "floor() of time", "[schedules]"),
    derived_case("200-step derived chain of sin", ["d0 = x"] + [f"d{k} = sin(d{k - 1})" for k in range(1, 201)],
                 "Fm*d200", "derived.d150.value", "nested more than 150 levels"),
    derived_case("float overflow over derived", ["c1 = 1e200", "c2 = c1*c1"], "Fm*c2/c2", "derived.c2.value",
                 "number out of range"),
    derived_case("rational underflow over derived", ["c1 = 2**-64", "c2 = c1**64", "c3 = c2**64"], "Fm + c3",
                 "derived.c2.value", "number out of range"),
    expr_case("Piecewise with 100 state conditions",
              "Piecewise(" + ", ".join(f"({i}, x > {i})" for i in range(1, 101)) + ", (0, True))",
              "Piecewise with 100 conditions on the states"),
    expr_case("600 switching surfaces", " + ".join(f"Max(x, {i})" for i in range(1, 600)),
              "more than 256 switching surfaces"),
    expr_case("product of 60 sums of states and time in a condition",
              "Piecewise((Fm, " + "*".join(f"(x + v + t + {i})" for i in range(1, 61)) + " > 0), (0, True))",
              "an expansion of more than 100000 terms"),
    term_case("more surface names than surfaces",
              '{ expr = "Piecewise((Fm, x > 2*b), (0, True))", surface = ["stop", "end"] }',
              "elements.load.value[0].surface", "2 surface names for 1 switching surface of the states ('x>2*b')"),
    term_case("surface name that is not a name", '{ expr = "Piecewise((Fm, x > 2*b), (0, True))", surface = "a b" }',
              "elements.load.value[0].surface", "not a valid symbol name"),
    Hostile("one surface name for two surfaces",
            sub(KS_MODEL, LOAD, 'value = [{ expr = "Piecewise((Fm, x > 2*b), (0, True))", surface = "stop" }, '
                                '{ expr = "Piecewise((Fm, x > 3*b), (0, True))", surface = "stop" },'),
            ("elements.load.value[1].surface", "'load.stop' is given to two different switching surfaces")),
]

DEEP = "(" * 1000 + "Fm" + ")" * 1000
HOSTILE = [
    # ---- the cases
    expr_case("keyword argument with a shell command",
              """Fm*Heaviside(Fm, H0='__import__("os").system("{SH}")*0 + 1/2')""", "keyword argument"),
    expr_case("not Fm", "not Fm", "'not' is not allowed"),
    expr_case("evaluate keyword", "sqrt(Fm, evaluate=False)", "keyword argument"),
    expr_case("sqrt()", "sqrt()", "sqrt() takes 1 argument, got 0"),
    expr_case("Max()", "Max()", "Max() takes at least 2 arguments"),
    expr_case("abs()", "abs()", "abs() takes 1 argument"),
    expr_case("~Fm", "~Fm", "'~' is not allowed"),
    expr_case("Fm & x", "Fm & x", "'&' is not allowed"),
    Hostile("string in dimensionless.coordinates",
            sub(SPUR_MODEL, 'coordinates = { x = "b_m" }',
                'coordinates = { x = "\'__import__(\\"os\\").system(\\"{SH}\\")\'" }'),
            ("dimensionless.coordinates.x", "strings are not allowed")),
    expr_case("10**10**10", "Fm*10**10**10", "exponent", "too large"),
    # ---- code execution attempts
    expr_case("__import__", '__import__("os").system("{SH}")', "names starting with '_'"),
    expr_case("dunder attribute chain", "Fm.__class__.__base__.__subclasses__()", "attribute access"),
    expr_case("eval", 'eval("__import__(\'os\').system(\'{SH}\')")', "unknown function 'eval'"),
    expr_case("exec", 'exec("import os; os.system(\'{SH}\')")', "unknown function 'exec'"),
    expr_case("getattr", 'getattr(Fm, "__class__")', "unknown function 'getattr'"),
    expr_case("lambda", 'Fm*(lambda: __import__("os").system("{SH}"))()', "lambda is not allowed"),
    expr_case("list comprehension", '[__import__("os").system("{SH}") for k in (1,)]', "lists ('[') are not allowed"),
    expr_case("generator in a call", 'Max(__import__("os").system("{SH}") for k in x)', "names starting with '_'"),
    expr_case("comprehension over names", "Max(k for k in x)", "comprehensions ('for') are not allowed"),
    expr_case("f-string", 'f"{__import__(\'os\').system(\'{SH}\')}"', "strings are not allowed"),
    expr_case("bytes literal", "b'\\x00'*Fm", "strings are not allowed"),
    expr_case("walrus", "(z := Fm)", "':='"),
    expr_case("starred argument", "Max(*x)", "unpacking is not allowed"),
    expr_case("subscript", "x[0]", "subscripts"),
    expr_case("conditional expression", "Fm if x > 0 else 0", "'if'"),
    expr_case("semicolon", 'Fm; __import__("os").system("{SH}")', "';' is not allowed"),
    expr_case("line continuation", "Fm \\\n + 1", "'\\' is not allowed"),
    expr_case("comment", "Fm # comment", "comments"),
    expr_case("null byte", "Fm\x00", "is not allowed"),
    expr_case("unicode look-alike of Fm", "\uff26m", "non-ASCII character"),
    # ---- operators and conditions
    expr_case("floor division", "Fm // 2", "'//' is not allowed"),
    expr_case("modulo", "Fm % 2", "'%' is not allowed"),
    expr_case("matrix product", "Fm @ x", "'@' is not allowed"),
    expr_case("bitwise or", "Piecewise((Fm, (x > 0) | (x < -1)), (0, True))", "'|' is not allowed"),
    expr_case("equality condition", "Piecewise((Fm, x == 0), (0, True))", "'==' is not allowed"),
    expr_case("chained comparison", "Piecewise((Fm, 0 < x < 1), (0, True))", "chained comparison"),
    expr_case("condition as a value", "Fm*(x > 0)", "is a condition, not a value"),
    expr_case("value as a condition", "Piecewise((Fm, x), (0, True))", "is not a condition"),
    expr_case("tuple", "(Fm, x)", "unexpected tuple"),
    # ---- limits
    expr_case("huge literal", "Fm*1e400", "number out of range"),
    expr_case("literal with 50 digits", "Fm*" + "7" * 50, "more than 30 digits"),
    expr_case("power of a huge base", "Fm*99999**99", "exponent 99 is too large"),
    expr_case("nested powers", "((x**8)**8)**2", "exponents above 64"),
    expr_case("exp overflow", "Fm*exp(exp(exp(10.0)))", "constant value too large"),
    expr_case("complex constant", "Fm*sqrt(-1)", "outside the domain of sqrt()"),
    expr_case("division by zero", "Fm/0", "division by zero"),
    expr_case("zero minus itself in a denominator", "Fm/(x - x)", "infinite, undefined or complex"),
    expr_case("1000 nested parentheses", DEEP, "nested too deeply"),
    expr_case("100 nested calls", "sin(" * 100 + "Fm" + ")" * 100, "nested too deeply"),
    expr_case("100 000-term sum", " + ".join(["Fm"] * 100_000), "expression too long"),
    expr_case("300 arguments of Max", "Max(" + ", ".join(["Fm"] * 300) + ")", "more than 256 arguments"),
    # ---- names that reach C, paths or symbol tables
    Hostile("model name closing the C comment",
            sub(KS_MODEL, 'name = "kahraman_singh"',
                'name = "x */ __attribute__((constructor)) static void f(void){system(\\"{SH}\\");} /*"'),
            ("model.name", "not a valid model name")),
    Hostile("scene name with ../", KS_MODEL, ("scene.name", "not a valid scene name"), S, '"../../../x"'),
    Hostile("absolute scene name", KS_MODEL, ("scene.name", "not a valid scene name"), S, '"/abs"'),
    Hostile("scene name closing the C comment", KS_MODEL, ("scene.name", "not a valid scene name"), S,
            '"a*/b"'),
    name_case("element name closing the C comment", "[elements.mesh]",
              '[elements."m */ __attribute__((constructor)) static void f(void){system(\\"{SH}\\");} /*"]',
              "elements.m */", "not a valid symbol name"),
    name_case("C keyword as a coordinate", "[coordinates.x]", "[coordinates.int]", "coordinates.int",
              "C keyword"),
    name_case("Python keyword as a velocity", 'velocity = "v"', 'velocity = "class"', "coordinates.x.velocity",
              "Python keyword"),
    name_case("internal residual name", 'velocity = "v"', 'velocity = "__xd0"', "coordinates.x.velocity",
              "not a valid symbol name"),
    name_case("internal side name with (t)", "zeta  = {", '"sigma_0(t)" = {', "parameters.sigma_0(t)",
              "not a valid symbol name"),
    name_case("dunder parameter", "zeta  = {", "__import__ = {", "parameters.__import__",
              "not a valid symbol name"),
    name_case("unicode look-alike parameter", "zeta  = {", '"\uff26m" = {', "parameters.",
              "not a valid symbol name"),
    name_case("path in a parameter name", "zeta  = {", '"../zeta" = {', "parameters.../zeta",
              "not a valid symbol name"),
    name_case("newline in a parameter name", "zeta  = {", '"ze\\nta" = {', "parameters.ze\\nta",
              "not a valid symbol name"),
    name_case("65-character parameter name", "zeta  = {", "z" * 65 + " = {", "parameters.zzz",
              "longer than 64"),
    name_case("reserved function name", "zeta  = {", "sin = {", "parameters.sin", "reserved"),
    name_case("effect name with */", "[effects.backlash]", '[effects."b*/"]', "effects.b*/",
              "not a valid symbol name"),
    name_case("variant with a path", "[effects.contact_damping]",
              '[effects.contact_damping]\nvariants = ["../v"]', "effects.contact_damping.variants[0]",
              "not a valid symbol name"),
    name_case("derived quantity named t", "[forcing]", '[derived]\nt = "Fm"\n\n[forcing]', "derived.t",
              "reserved"),
    name_case("tau in a model with a dimensionless form", "omega = { value", "tau = { value = 1.0 }\nomega = { value",
              "parameters.tau", "'tau' is the time of the [dimensionless] form", model=SPUR_MODEL),
    name_case("group named like a parameter", "Fa    = { definition", "k_m   = { definition",
              "dimensionless.groups.k_m", "duplicate name 'k_m'", model=SPUR_MODEL),
    # ---- spec files and paths
    Hostile("model is /dev/urandom", None, ("not a regular file",), "/dev/urandom", model_ref="/dev/urandom"),
    Hostile("model is a FIFO", None, ("not a regular file",), "fifo.toml", model_ref="fifo.toml",
            setup=lambda w: os.mkfifo(w / "fifo.toml")),
    Hostile("model file over 1 MB", KS_MODEL + "#" * 1_100_000 + "\n", (M, "too large")),
    Hostile("TOML nested 100 000 deep", "a = " + "[" * 100_000 + "]" * 100_000 + "\n", (M, "TOML syntax error")),
    Hostile("unit of 10 000 factors", sub(KS_MODEL, 'zeta  = { value = 0.05,',
                                          'zeta  = { value = 0.05, unit = "' + "*".join(["m"] * 10_000) + '",'),
            ("parameters.zeta.unit", "cannot parse unit")),
    *BUDGETS,
]


def _write(case: Hostile, work: Path) -> Path:
    marker = str(work.parent / "PWNED")
    if case.setup is not None:
        case.setup(work)
    if case.model is not None:
        (work / M).write_text(case.model.replace("{SH}", _sh(marker)), encoding="utf-8")
    (work / S).write_text(f"[scene]\nname = {case.scene_name}\nmodel = {_toml(case.model_ref)}\n",
                          encoding="utf-8")
    return work / S


COMMANDS = ("inspect", "compile", "simulate")


def _argv(command: str, case: Hostile, work: Path) -> list[str]:
    # inspect reads the model file itself when there is one (the name checks of the scene
    # need the scene); compile and simulate take the scene
    target = work / M if (command == "inspect" and case.model is not None and case.scene_name == '"s"'
                          and case.model_ref == M) else work / S
    argv = [command, str(target)]
    if command == "simulate":
        argv += ["--periods", "2", "--out", str(work / "out")]
    return argv


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("gen")


def test_at_least_forty_hostile_cases():
    assert len(HOSTILE) >= 40
    assert len({c.id for c in HOSTILE}) == len(HOSTILE)


@pytest.mark.parametrize("case", HOSTILE, ids=[c.id for c in HOSTILE])
def test_hostile_input_in_process(case: Hostile, tmp_path: Path, gen: Path, capsys, monkeypatch):
    """inspect, compile and simulate: exit 2, one line naming file and field, no code runs."""
    monkeypatch.setenv("GEARSYM_GENERATED", str(gen))
    work = tmp_path / "work"
    work.mkdir()
    _write(case, work)
    for command in COMMANDS:
        argv = _argv(command, case, work)
        code = cli.main(argv)
        out, err = capsys.readouterr()
        assert code == 2, f"{command}: exit {code}: {err}"
        assert out == ""
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("gearsym: error: "), err
        for needle in (case.file, *case.needles):
            assert needle in err, f"{command}: {needle!r} not in {err}"
        assert not (tmp_path / "PWNED").exists(), "the payload ran"
        assert not (work / "out").exists()
    assert not any(gen.iterdir()), "a hostile spec left a build behind"


#: The cases also run as a real subprocess (each costs a Python start): the issue's ten and every
#: fourth of the others, the command rotating through inspect, compile and simulate.
SUBPROCESS = [(i, c) for i, c in enumerate(HOSTILE) if i < 10 or i % 4 == 0]


@pytest.mark.parametrize("i,case", SUBPROCESS, ids=[c.id for _, c in SUBPROCESS])
def test_hostile_input_cli(i: int, case: Hostile, tmp_path: Path, gen: Path):
    """The real command line (one command per case, in turn): see ``check_case``."""
    command = COMMANDS[i % 3]
    check_case(Case(case.id, lambda w: (_write(case, w), _argv(command, case, w))[1],
                    [case.file, *case.needles]), tmp_path, gen)
    assert not (tmp_path / "PWNED").exists(), "the payload ran"
