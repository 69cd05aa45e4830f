"""Diagnostics through :mod:`logging` (issue 29, item 5): a ``gearsym`` logger hierarchy, no
handler installed by the library, no debug ``print``, log lines where a user wants to know what
happened, and the CLI's ``-v`` / ``-vv`` / ``-q`` / ``--debug``.

Each log test checks the message against the value the code returned (the branch's stop
reason, the equilibrium's contact state, the build's folder) or against the cause the test
made (a tampered file, a planted object), not merely that something was logged.
"""

from __future__ import annotations

import ast
import hashlib
import json
import logging
import math
import re
from pathlib import Path

import pytest

import gearsym
from gearsym.cli import main
from gearsym.engine import build as engine_build

ROOT = Path(__file__).resolve().parents[1]
PKG = Path(gearsym.__file__).resolve().parent  # the package under test (the scans read its files)
KS = ROOT / "scenes" / "kahraman_singh.toml"


def _messages(caplog, name: str, level: int = logging.INFO) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == name and r.levelno == level]


# ------------------------------------------------------------------ the library's side
def test_the_package_logger_has_only_a_null_handler():
    logger = logging.getLogger("gearsym")
    assert [type(h) for h in logger.handlers] == [logging.NullHandler]


def _calls(tree: ast.AST) -> list[ast.Call]:
    return [n for n in ast.walk(tree) if isinstance(n, ast.Call)]


def _name(call: ast.Call) -> str:
    f = call.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def test_no_module_configures_logging_or_prints_diagnostics():
    # only the CLI adds a handler (gearsym/cli/verbosity.py) and the package root its NullHandler;
    # print is the output of the CLI and of the reports it prints (gearsym/inspection.py), never a
    # diagnostic of the library; no debug flag such as dimensionless.py's former _DEBUG
    configures, prints, flags = [], [], []
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG.parent).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for call in _calls(tree):
            if _name(call) in ("basicConfig", "addHandler", "dictConfig", "fileConfig") and rel not in (
                    "gearsym/__init__.py", "gearsym/cli/verbosity.py"):
                configures.append(f"{rel}:{call.lineno}")
            if _name(call) == "print" and not rel.startswith("gearsym/cli/") and rel != "gearsym/inspection.py":
                prints.append(f"{rel}:{call.lineno}")
        for node in tree.body:
            targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
            for t in targets:
                if isinstance(t, ast.Name) and re.fullmatch(r"_*(DEBUG|VERBOSE|TRACE)\w*", t.id):
                    flags.append(f"{rel}:{node.lineno} {t.id}")
    assert (configures, prints, flags) == ([], [], [])


def test_modules_log_under_their_own_name():
    # logging.getLogger(__name__) everywhere: never a logger outside the gearsym hierarchy
    bad = []
    for path in sorted(PKG.rglob("*.py")):
        for call in _calls(ast.parse(path.read_text(encoding="utf-8"))):
            if _name(call) == "getLogger" and not (
                    len(call.args) == 1 and isinstance(call.args[0], ast.Name) and call.args[0].id == "__name__"
                    or path == PKG / "cli" / "verbosity.py"):
                bad.append(f"{path.relative_to(PKG.parent)}:{call.lineno}")
    assert bad == []


def test_dimensionless_blocks_are_debug_log_records(caplog):
    # before: a print gated by a module flag (_DEBUG = False); now each checked block is a DEBUG record
    model = gearsym.load_scene(KS).model
    with caplog.at_level(logging.DEBUG, logger="gearsym"):
        form = model.dimensionless()
    blocks = _messages(caplog, "gearsym.symbolic.dimensionless", logging.DEBUG)
    assert blocks and all(m.startswith("dimensionless block ") for m in blocks)
    for m in blocks:  # "... : A (dimensional) vs C (groups)": the two numbers of the check agree
        a, c = map(float, re.search(r": (\S+) \(dimensional\) vs (\S+) \(groups\)$", m).groups())
        assert math.isclose(a, c, rel_tol=10 * max(form.check, 1e-15), abs_tol=1e-300)


# ------------------------------------------------------------------ build cache and driver object
def test_build_cache_miss_build_hit_and_rebuild_say_why(tmp_path, caplog):
    cache = tmp_path / "cache"
    with caplog.at_level(logging.INFO, logger="gearsym"):
        first = gearsym.load_scene(KS).generate(generated_dir=cache)
        assert not first.cached
        second = gearsym.load_scene(KS).generate(generated_dir=cache)
        assert second.cached
        (Path(first.directory) / "gs_model.c").write_text("/* edited */\n")  # not the signed source
        third = gearsym.load_scene(KS).generate(generated_dir=cache)
        assert not third.cached
    msgs = _messages(caplog, "gearsym.facade")
    d = first.directory
    assert msgs[0] == f"scene kahraman_singh: build cache miss (no build cache folder {cache} yet): building"
    built = re.fullmatch(r"scene kahraman_singh: built in (\S+) s \(equations and CasADi functions (\S+) s, "
                         r"C sources and compiler (\S+) s\) -> (.*)", msgs[1])
    assert built and built.group(4) == d and float(built.group(3)) == pytest.approx(first.compile_seconds, abs=6e-3)
    assert float(built.group(1)) >= float(built.group(3))
    assert msgs[2] == f"scene kahraman_singh: build cache hit, verified build {d}"
    assert msgs[3] == (f"scene kahraman_singh: build cache miss (a file of {d} is missing or does not have the "
                       "SHA-256 it was signed with (damaged or edited)): building")
    assert msgs[4].startswith("scene kahraman_singh: built in ") and msgs[4].endswith(f"-> {d}")
    assert len(msgs) == 5


def _driver_name() -> str:
    """The file name driver_object() gives the driver (its formula, as in gearsym.engine.build)."""
    tc = engine_build.toolchain_identity()
    h = hashlib.sha256(json.dumps([tc["driver"], tc["compiler"], tc["compiler_version"],
                                   list(engine_build.DRIVER_CFLAGS)]).encode())
    return f"gs_driver-{h.hexdigest()[:16]}.o"


def test_driver_object_rebuild_says_why(tmp_path, caplog):
    folder = tmp_path / "driver"
    folder.mkdir(mode=0o700)
    planted = folder / _driver_name()
    planted.write_bytes(b"\x7fELF not really")  # no signature: never used
    with caplog.at_level(logging.DEBUG, logger="gearsym.engine"):
        obj = engine_build.driver_object(folder)
        again = engine_build.driver_object(folder)
    assert obj == again == folder.resolve() / planted.name and obj.read_bytes()[:4] == b"\x7fELF"
    info = _messages(caplog, "gearsym.engine.build")
    assert info[0] == (f"driver object {obj}: compiling it (the object there does not verify: damaged, truncated, "
                       "unsigned or not made by this user's gearsym)")
    assert re.fullmatch(rf"driver object {re.escape(str(obj))}: compiled in \d+\.\d\d s", info[1])
    assert _messages(caplog, "gearsym.engine.build", logging.DEBUG) == [f"driver object {obj}: verified, reused"]


# ------------------------------------------------------------------ analyses
@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(KS).compile()


def test_static_equilibrium_logs_its_contact_state(caplog):
    from gearsym.static import static_equilibrium

    system = gearsym.load_scene("spur_pair_torsional").compile()
    with caplog.at_level(logging.INFO, logger="gearsym.static"):
        eq = static_equilibrium(system)
    (msg,) = _messages(caplog, "gearsym.static")
    state = ", ".join(f"{m}: {s}" for m, s in eq.contact.items())
    assert eq.contact and msg.startswith(f"static equilibrium of {system.name}: contact state {state} (")
    assert f"contact states tried {eq.info['states_tried']}," in msg


def test_continuation_logs_why_it_stopped(ks_system, caplog):
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        branch = gearsym.continuation(ks_system, "Omega", 0.5, 0.6)
    (msg,) = _messages(caplog, "gearsym.analysis.continuation._arclength")
    assert branch.stop_reason and msg == (f"continuation in Omega: {len(branch.points)} points, no special point; "
                                          f"stopped: {branch.stop_reason}")


def test_periodic_orbit_logs_its_result(ks_system, caplog):
    with caplog.at_level(logging.INFO, logger="gearsym.analysis"):
        orbit = ks_system.periodic_orbit(params={"Omega": 0.6})
    (msg,) = _messages(caplog, "gearsym.analysis.periodic._solve")
    assert msg.startswith(f"periodic orbit (shooting, period {orbit.period:.6g}): {orbit.iterations} iterations")
    assert msg.endswith(f"max |multiplier| {orbit.max_multiplier:.6g}, {orbit.stability}")


# ------------------------------------------------------------------ the CLI
def _cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_is_silent_by_default_and_verbose_with_v(capsys, ks_system):
    code, _, err = _cli(capsys, "compile", "kahraman_singh")
    assert code == 0 and err == ""
    for argv in (["-v", "compile", "kahraman_singh"], ["compile", "kahraman_singh", "--verbose"]):
        code, _, err = _cli(capsys, *argv)
        lines = err.splitlines()
        assert code == 0 and len(lines) == 1, err
        assert re.fullmatch(r"gearsym\.facade: INFO: scene kahraman_singh: build cache hit, verified build .+", lines[0])


def test_cli_vv_shows_debug_and_q_hides_info(capsys):
    code, _, err = _cli(capsys, "inspect", "kahraman_singh", "-vv")
    assert code == 0 and "gearsym.symbolic.dimensionless: DEBUG: dimensionless block " in err
    code, _, err2 = _cli(capsys, "-v", "inspect", "kahraman_singh", "-v")  # counts add up: -vv
    assert code == 0 and err2 == err
    code, _, err = _cli(capsys, "-q", "modes", "spur_pair_torsional")
    assert code == 0 and err == ""
    code, _, err = _cli(capsys, "modes", "spur_pair_torsional", "-v")
    assert code == 0 and "gearsym.static: INFO: static equilibrium of spur_pair_torsional: contact state " in err


def test_cli_v_and_q_exclude_each_other(capsys):
    code, _, err = _cli(capsys, "compile", "kahraman_singh", "-v", "-q")
    assert code == 2 and "not allowed with argument" in err


def test_cli_leaves_the_logger_as_it_found_it(capsys):
    logger = logging.getLogger("gearsym")
    before = (logger.level, list(logger.handlers))
    assert _cli(capsys, "-vv", "models")[0] == 0
    assert (logger.level, list(logger.handlers)) == before


def test_debug_still_prints_the_traceback_of_an_internal_error(capsys, monkeypatch):
    from gearsym.cli import catalog

    def boom(args):
        raise RuntimeError("planted internal error")

    monkeypatch.setattr(catalog, "cmd_models", boom)
    code, _, err = _cli(capsys, "models")
    assert code == 1 and "Traceback" not in err
    assert err.strip() == ("gearsym: internal error: RuntimeError: planted internal error (rerun with --debug for "
                           "the traceback)")
    code, _, err = _cli(capsys, "--debug", "models")
    assert code == 1 and "Traceback (most recent call last)" in err and "planted internal error" in err
