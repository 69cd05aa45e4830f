"""The integration methods are named in one place (``gearsym/integrators.py``), and the run
settings are frozen objects whose fields are also accepted as keywords.

* The registry agrees with the C driver's codes (``gs_driver.h``), and every list of methods
  (the scene's ``[simulate] method``, the command line's ``--method``, the engine's codes, the
  exported program's table) is read from it; no other module names a method.
* ``adams_fixedpoint`` (CVODE Adams with the fixed-point iteration) is one registry entry and
  no C of its own: it runs the simulation, the shooting Newton in C and the continuation
  corrector in C, against the hand-written scipy flow of the benchmark oscillator (with contact
  events and saltation, ``tests/test_shooting.py``) and against the Newton-iteration runs.
* An unknown keyword of ``System.simulate`` / ``System.flow`` / ``Engine.run`` is a
  ParameterError naming it and the closest field (it was a bare TypeError, or for
  ``Engine.run`` with a misspelt sensitivity keyword, nothing).
"""

from __future__ import annotations

import argparse
import ast
import re
from pathlib import Path

import numpy as np
import pytest
import test_shooting
from _corrector_spy import spy_on_c_corrector
from test_shooting import P0, ref_flow

import gearsym
from gearsym.errors import ParameterError, SpecError

try:  # (imported here so that the behaviour tests below also run, and fail one by one, without it)
    from gearsym.integrators import (
        INTEGRATION_METHODS,
        LINEAR_SOLVERS,
        NONLINEAR,
        check_method,
        get_method,
        method_names,
        supports_monodromy,
        supports_sensitivities,
    )
except ImportError:  # pragma: no cover
    INTEGRATION_METHODS = {}

ROOT = Path(__file__).resolve().parents[1]
ks = test_shooting.ks  # the benchmark scene (module fixture)

#: Modules that may name a method: the registry; the benchmark's peers (which methods the
#: work-precision benchmark compares, a choice, not a list of methods); Engine.run's default.
NAMING_ALLOWED = {"gearsym/integrators.py", "gearsym/bench/peers.py", "gearsym/engine/run_settings.py"}


# ------------------------------------------------------------------ one place


def test_registry_matches_the_driver_header():
    header = (ROOT / "gearsym" / "engine" / "gs_driver.h").read_text()
    defs = {k: int(v) for k, v in re.findall(r"#define GS_((?:METHOD|NONLIN|LINSOL)_\w+)\s+(\d+)", header)}
    methods = {v: k.split("_", 1)[1] for k, v in defs.items() if k.startswith("METHOD_")}
    kinds = {"BDF": ("CVODE", "BDF"), "ADAMS": ("CVODE", "Adams-Moulton"), "IDA": ("IDA", "BDF")}
    assert set(methods.values()) == set(kinds)
    for m in INTEGRATION_METHODS.values():
        assert (m.integrator, m.family) == kinds[methods[m.code]], m.name
        assert set(m.nonlinear) <= set(NONLINEAR) - {"auto"} and m.nonlinear
        assert set(m.linear_solvers) <= set(LINEAR_SOLVERS) - {"auto"}
    assert dict(NONLINEAR) == {k[7:].lower(): v for k, v in defs.items() if k.startswith("NONLIN_")}
    assert dict(LINEAR_SOLVERS) == {k[7:].lower(): v for k, v in defs.items() if k.startswith("LINSOL_")}


def test_every_list_of_methods_is_the_registry():
    from gearsym.cli.parser import build_parser
    from gearsym.engine import driver
    from gearsym.export import model_info
    from gearsym.spec.settings import SETTINGS

    names = method_names()
    assert names == ("adams", "bdf", "ida", "adams_fixedpoint")
    assert SETTINGS["simulate"]["method"].choices == names
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for command in ("simulate", "lyapunov"):
        option = next(a for a in sub.choices[command]._actions if "--method" in a.option_strings)
        assert tuple(option.choices) == names, command
    assert driver.METHODS == {n: m.code for n, m in INTEGRATION_METHODS.items()}
    table = model_info._method_table("bdf")
    assert f"#define GSX_NMETHODS {len(names)}\n" in table and "#define GSX_DEFAULT_METHOD 1\n" in table
    assert 'gsx_method_names[5] = {"adams", "bdf", "ida", "adams_fixedpoint", 0}' in table
    assert "gsx_method_code[5] = {1, 0, 2, 1, 0}" in table and "gsx_method_nonlinear[5] = {1, 1, 1, 2, 0}" in table
    # the analysis' predicates
    # (THE Newton iteration runs in C with every method: its evaluations are the driver's runs;
    # shooting needs the variational equations, the corrector's C evaluator the sensitivities)
    assert [n for n in names if supports_monodromy(n)] == list(names)
    assert [n for n in names if supports_sensitivities(n)] == list(names)
    assert not supports_monodromy("rk4") and not supports_sensitivities(None)


def _string_constants(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_no_module_names_a_method_outside_the_registry():
    assert {"adams", "bdf", "ida"} <= set(INTEGRATION_METHODS)
    found = []
    for path in sorted((ROOT / "gearsym").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel not in NAMING_ALLOWED:
            found += [f"{rel}:{line} {value!r}" for line, value in _string_constants(path) if value in INTEGRATION_METHODS]
    assert found == []


def test_registry_checks_name_what_is_wrong():
    with pytest.raises(ParameterError, match=r"unknown method 'adam'; did you mean 'adams'\?"):
        get_method("adam")
    with pytest.raises(ParameterError, match=r"this model is in implicit \(mass-matrix\) form: use method='ida'"):
        check_method("bdf", implicit=True)
    with pytest.raises(ParameterError, match=r"method='ida' needs a model in implicit form"):
        check_method("ida", implicit=False)
    with pytest.raises(ParameterError, match=r"method 'adams_fixedpoint' has no 'newton' nonlinear iteration"):
        get_method("adams_fixedpoint").nonlinear_code("newton")
    with pytest.raises(ParameterError, match=r"method 'ida' has no 'fixedpoint' nonlinear iteration"):
        get_method("ida").nonlinear_code("fixedpoint")


def test_scene_method_is_checked_against_the_registry(tmp_path):
    scene = _scene(tmp_path, "rk45")
    with pytest.raises(SpecError, match=r"field 'simulate.method': must be one of adams, bdf, ida, "
                                        r"adams_fixedpoint, got 'rk45'"):
        gearsym.load_scene(scene)


# ------------------------------------------------------------------ options objects and keywords


def test_unknown_keywords_are_named(ks):
    with pytest.raises(ParameterError, match=r"System.simulate\(\) got an unknown keyword 'rtl'; did you mean "
                                             r"'rtol'\?"):
        ks.simulate(periods=1, rtl=1e-9)
    with pytest.raises(ParameterError, match=r"System.flow\(\) got an unknown keyword 'monodromi'; did you mean "
                                             r"'monodromy'\?"):
        ks.flow(ks.x0, 0.0, 1.0, monodromi=False)
    with pytest.raises(ParameterError, match=r"Engine.run\(\) got an unknown keyword 'want_monodromi'; did you "
                                             r"mean 'want_monodromy'\?"):
        ks.engine.run(ks.x0, ks.param_vector(), 0.0, 1.0, want_monodromi=True)


def test_options_objects_and_keywords_make_the_same_run(ks):
    from gearsym.engine.run_settings import RunSettings
    from gearsym.simulation_options import FlowOptions

    kw = dict(method="bdf", rtol=1e-9, atol=1e-11, monodromy=True)
    a = ks.simulate(periods=3, **kw)
    b = ks.simulate(periods=3, options=gearsym.SimulateOptions(**kw))
    # keywords (and rtol/atol/n_out) override the object's fields
    c = ks.simulate(3 * ks.period(), None, None, 1e-9, options=gearsym.SimulateOptions(
        method="adams", rtol=1e-5, atol=1e-11, monodromy=True), method="bdf")
    for t in (b, c):
        np.testing.assert_array_equal(t.y, a.y)
        np.testing.assert_array_equal(t.monodromy, a.monodromy)
        assert t.settings == a.settings and t.settings["method"] == "bdf" and t.settings["rtol"] == 1e-9
    T, p = ks.period(), ks.param_vector()
    f1 = ks.flow(ks.x0, 0.0, T, p, rtol=1e-9, method="bdf", n_samples=5)
    f2 = ks.flow(ks.x0, 0.0, T, p, FlowOptions(rtol=1e-9, method="bdf", n_samples=5))
    np.testing.assert_array_equal(f1.samples, f2.samples)
    np.testing.assert_array_equal(f1.monodromy, f2.monodromy)
    r1 = ks.engine.run(ks.x0, p, 0.0, T, None, method="bdf", rtol=1e-9, want_monodromy=True)
    r2 = ks.engine.run(ks.x0, p, 0.0, T, None, RunSettings(method="bdf", rtol=1e-9, want_monodromy=True))
    np.testing.assert_array_equal(r1.monodromy, r2.monodromy)


# ------------------------------------------------------------------ the example: adams_fixedpoint


def _scene(tmp_path: Path, method: str) -> Path:
    text = (ROOT / "scenes" / "kahraman_singh.toml").read_text()
    text = text.replace('model = "../models/kahraman_singh.toml"',
                        f'model = "{(ROOT / "models" / "kahraman_singh.toml").as_posix()}"')
    path = tmp_path / "ks_method.toml"
    path.write_text(text.replace("[simulate]\n", f'[simulate]\nmethod = "{method}"\n'))
    return path


def test_fixedpoint_flow_and_monodromy_against_scipy(ks):
    """Five forcing periods with the monodromy, against the hand-written scipy flow with contact
    events and saltation; no Jacobian is evaluated (the fixed-point iteration), while Adams with
    Newton evaluates it."""
    T = 2 * np.pi / P0["Omega"]
    x0 = np.array([1.1, 0.0])
    fp = ks.flow(x0, 0.0, 5 * T, rtol=1e-12, atol=1e-14, method="adams_fixedpoint")
    xT, M_ref, n_ev = ref_flow(P0, x0, 0.0, 5 * T, variational=True)
    assert n_ev == len(fp.event_t) >= 6
    assert np.max(np.abs(fp.x_final - xT)) < 1e-9
    assert np.max(np.abs(fp.monodromy - M_ref)) < 1e-7 * max(1.0, np.abs(M_ref).max())
    newton = ks.flow(x0, 0.0, 5 * T, rtol=1e-12, atol=1e-14, method="adams")
    assert fp.stats["n_jac"] == 0 < newton.stats["n_jac"]
    tr = ks.simulate(periods=5, rtol=1e-12, atol=1e-14, method="adams_fixedpoint")
    assert tr.settings["method"] == "adams_fixedpoint" and tr.stats["n_jac"] == 0
    assert np.max(np.abs(tr.x_final - xT)) < 1e-9


def test_fixedpoint_orbit_by_the_shooting_newton_in_c(ks):
    ref = ks.periodic_orbit()
    guess = ref.x0 + np.array([2e-3, -1e-3])
    orbit = ks.periodic_orbit(x0=guess, transient=0, options=gearsym.ShootingOptions(method="adams_fixedpoint"))
    assert orbit.history[-1].get("engine") == "C" and orbit.converged
    xT, M_ref, n_ev = ref_flow(P0, orbit.x0, 0.0, 2 * np.pi / P0["Omega"], variational=True)
    assert n_ev == len(orbit.events) == 2
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9
    assert np.max(np.abs(orbit.monodromy - M_ref)) < 1e-7 * max(1.0, np.abs(M_ref).max())
    mu_ref = np.sort_complex(np.linalg.eigvals(M_ref))
    assert np.max(np.abs(np.sort_complex(orbit.multipliers) - mu_ref)) < 1e-7


def test_fixedpoint_scene_continues_with_the_corrector_in_c(tmp_path, ks, monkeypatch):
    """A scene whose ``[simulate] method`` is ``adams_fixedpoint``: the continuation's corrector runs
    in C with it and finds the grazing and the fold of the Newton-iteration branch."""
    fp = gearsym.load_scene(_scene(tmp_path, "adams_fixedpoint")).compile()
    assert fp.simulate(periods=2).settings["method"] == "adams_fixedpoint"
    calls = spy_on_c_corrector(monkeypatch)
    br = gearsym.continuation(fp, "Omega", 0.85, 0.95, progress=False)
    assert len(calls) > 20 and all(calls)  # every point corrected in C
    ref = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)
    kinds = lambda b: [x.type for x in sorted(b.bifurcations, key=lambda x: x.value)]  # noqa: E731
    assert kinds(br) == kinds(ref) == ["grazing", "fold"]
    for a, b in zip(sorted(br.bifurcations, key=lambda x: x.value), sorted(ref.bifurcations, key=lambda x: x.value),
                    strict=True):
        assert abs(a.value - b.value) < 1e-7


def test_cli_simulates_with_a_registry_method(tmp_path):
    import json
    import subprocess
    import sys

    run = lambda *a: subprocess.run([sys.executable, "-m", "gearsym.cli", "simulate", *a, "--periods", "3",  # noqa: E731
                                     "--json"], capture_output=True, text=True, cwd=ROOT, timeout=300)
    r = run(str(ROOT / "scenes" / "kahraman_singh.toml"), "--method", "adams_fixedpoint")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["method"] == "adams_fixedpoint"
    r = run(str(_scene(tmp_path, "adams_fixedpoint")))  # the scene's method
    assert r.returncode == 0 and json.loads(r.stdout)["method"] == "adams_fixedpoint", r.stderr
    r = run(str(ROOT / "scenes" / "kahraman_singh.toml"), "--method", "rk4")
    assert r.returncode == 2 and "invalid choice: 'rk4'" in r.stderr
