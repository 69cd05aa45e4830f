"""Shipped scenes by name, ``gearsym models`` / ``init``, optional extras, a light ``--version``.

The missing extras are simulated in-process: ``sys.modules[name] = None`` makes
``import name`` fail exactly as for a package that is not installed (the installed-wheel
test, ``tests/test_wheel.py``, checks the same messages with the packages really absent).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import gearsym
from gearsym import catalog
from gearsym.cli import main
from gearsym.errors import SpecError
from gearsym.extras import MissingExtraError

REPO = Path(__file__).resolve().parents[1]


def cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------ shipped files by name
def test_every_shipped_scene_is_addressable_by_its_file_name():
    scenes = catalog.shipped_scenes()
    assert set(scenes) == {p.stem for p in (REPO / "scenes").glob("*.toml")}
    for name, s in scenes.items():
        assert catalog.find_scene(name) == REPO / "scenes" / f"{name}.toml"
        assert (s.path.parent / f"../models/{s.model}.toml").resolve().is_file()
        assert tomllib.loads(s.path.read_text())["scene"].get("name", name) == name


def test_find_scene_keeps_paths_and_rejects_unknown_names(tmp_path):
    assert catalog.find_scene("scenes/kahraman_singh.toml") == Path("scenes/kahraman_singh.toml")
    assert catalog.find_scene("nowhere.toml") == Path("nowhere.toml")  # the reader names the missing file
    with pytest.raises(SpecError, match="no shipped scene of that name.*kahraman_singh"):
        catalog.find_scene("kahraman")
    assert catalog.find_spec_file("yu_6dof") == REPO / "models" / "yu_6dof.toml"


def test_load_scene_by_name_equals_load_by_path():
    by_name = gearsym.load_scene("kahraman_singh", Omega=0.8)
    by_path = gearsym.load_scene(REPO / "scenes" / "kahraman_singh.toml", Omega=0.8)
    assert by_name.path == by_path.path and by_name.resolved.values == by_path.resolved.values


def test_models_lists_each_model_with_its_reference_and_scenes(capsys):
    code, out, _ = cli(capsys, "models", "--json")
    assert code == 0
    data = json.loads(out)
    models = {m["name"]: m for m in data["models"]}
    for path in (REPO / "models").glob("*.toml"):
        meta = tomllib.loads(path.read_text())["model"]
        assert models[path.stem]["reference"] == " ".join(meta.get("reference", "").split())
    assert models["vaishya_singh"]["scenes"] == ["vaishya_singh_fig3", "vaishya_singh_fig6", "vaishya_singh_friction",
                                                 "vaishya_singh_parametric", "vaishya_singh_ste"]
    code, out, _ = cli(capsys, "models")
    assert code == 0 and "reference: A. Kahraman, R. Singh" in out and "scene yu_dynamic_D12" in out


def test_init_from_a_shipped_scene_equals_the_shipped_scene(tmp_path, capsys):
    code, out, _ = cli(capsys, "init", "myks", "--dir", str(tmp_path), "--from", "kahraman_singh", "--json")
    assert code == 0
    files = json.loads(out)
    mine = gearsym.load_scene(files["scene"])
    ref = gearsym.load_scene("kahraman_singh")
    assert mine.name == "myks" and mine.model_spec.name == "myks"
    assert Path(mine.model_spec.path) == (tmp_path / "models" / "myks.toml").resolve()
    assert mine.resolved.values == ref.resolved.values and mine.resolved.effects == ref.resolved.effects
    assert mine.resolved.initial == ref.resolved.initial
    assert "Kahraman & Singh" in Path(files["model"]).read_text()  # the comments come along


def test_init_never_overwrites(tmp_path, capsys):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "g.toml").write_text("keep me")
    code, _, err = cli(capsys, "init", "g", "--dir", str(tmp_path))
    assert code == 2 and "exists already; not overwriting" in err
    assert (tmp_path / "scenes" / "g.toml").read_text() == "keep me"
    assert not (tmp_path / "models" / "g.toml").exists()  # nothing written when one file is in the way
    code, _, err = cli(capsys, "init", "../evil", "--dir", str(tmp_path))
    assert code == 2 and "not a valid model name" in err
    code, _, err = cli(capsys, "init", "h", "--dir", str(tmp_path), "--from", "nosuch")
    assert code == 2 and "not a shipped scene" in err


# ------------------------------------------------------------------ optional extras
@pytest.fixture
def without(monkeypatch):
    def hide(*modules: str) -> None:
        for m in modules:
            monkeypatch.setitem(sys.modules, m, None)  # `import m` now raises ImportError
    return hide


def test_map_without_the_maps_extra_says_which_to_install(without, capsys, tmp_path):
    without("xarray", "distributed")
    code, out, err = cli(capsys, "map", "meissner", "--x", "a", "0", "0.5", "3", "--y", "T", "1", "2", "3",
                         "--out", str(tmp_path / "m"))
    assert code == 2 and out == ""
    assert err.strip() == ("gearsym: error: gearsym map needs the optional dependencies of gearsym[maps] "
                           "(missing: xarray, distributed); install them with: pip install 'gearsym[maps]'")
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("command", [["simulate", "kahraman_singh"], ["orbit", "kahraman_singh"],
                                     ["continue", "kahraman_singh", "--param", "Omega", "--from", "0.8",
                                      "--to", "0.9"]])
def test_figures_without_the_plots_extra_say_which_to_install(without, capsys, tmp_path, command):
    without("matplotlib")
    code, _, err = cli(capsys, *command, "--out", str(tmp_path / "o"))
    assert code == 2 and "pip install 'gearsym[plots]'" in err and "(missing: matplotlib)" in err
    assert not (tmp_path / "o").exists()


def test_plots_module_without_matplotlib_raises_the_extra_error(without, monkeypatch):
    without("matplotlib")
    monkeypatch.delitem(sys.modules, "gearsym.plots", raising=False)
    with pytest.raises(MissingExtraError, match=r"gearsym\[plots\]"):
        import gearsym.plots  # noqa: F401


def test_simulate_without_out_needs_no_extra(without, capsys):
    without("matplotlib", "xarray", "dask", "distributed", "tqdm")
    code, out, err = cli(capsys, "simulate", "kahraman_singh", "--periods", "2", "--json")
    assert code == 0, err
    assert json.loads(out)["scene"] == "kahraman_singh"


def test_version_imports_no_numerical_library():
    code = ("import sys\nfrom gearsym.cli import main\ntry:\n    main(['--version'])\nexcept SystemExit:\n"
            "    pass\nprint(sorted(m for m in ('numpy', 'sympy', 'casadi', 'scipy', 'matplotlib') "
            "if m in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.splitlines() == [f"gearsym {gearsym.__version__}", "[]"]


def test_simulate_does_not_import_the_benchmark_harness(tmp_path):
    """Issue 14: the CLI imports :mod:`gearsym.bench` (scipy peers, lambdify, timing) only for
    ``gearsym bench``; ``simulate`` runs without it (and ``bench --help`` still lists it)."""
    code = ("import sys\nfrom gearsym.cli import main\ncode = main(['simulate', 'kahraman_singh', '--periods', "
            "'1', '--json'])\nprint(code, sorted(m for m in sys.modules if m == 'gearsym.bench' or "
            "m.startswith('gearsym.bench.')))")
    env = dict(os.environ, GEARSYM_GENERATED=str(tmp_path))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert res.stdout.splitlines()[-1] == "0 []"
    code_b = "import sys\nimport gearsym.cli.benchmark\nprint('gearsym.bench' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code_b], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "False"   # registering the command does not import the harness either


def test_time_history_shows_every_state_or_the_chosen_ones(tmp_path, capsys, monkeypatch):
    import numpy as np

    import gearsym.plots as plots

    traj = gearsym.load_scene("kahraman_singh").compile().simulate(periods=3)
    drawn = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path, **kw: drawn.append(
        [(ax.get_ylabel(), np.asarray(ax.lines[0].get_ydata())) for ax in fig.axes]))
    plots.plot_time_history(traj, tmp_path / "a.png")
    plots.plot_time_history(traj, tmp_path / "b.png", states=["v"])
    assert [name for name, _ in drawn[0]] == ["x", "v"] and [name for name, _ in drawn[1]] == ["v"]
    assert np.array_equal(drawn[0][1][1], traj.y[:, 1]) and np.array_equal(drawn[1][0][1], traj.y[:, 1])

    code, out, err = cli(capsys, "simulate", "kahraman_singh", "--periods", "4", "--out", str(tmp_path),
                         "--plot-states", "v", "--json")
    assert code == 0, err
    assert drawn[2][0][0] == "v" and len(drawn[2]) == 1
    code, _, err = cli(capsys, "simulate", "kahraman_singh", "--out", str(tmp_path), "--plot-states", "x,w")
    assert code == 2 and "--plot-states: 'w' is not a state (states: x, v)" in err


# ------------------------------------------------------------------ package metadata (issue 29)
def _metadata() -> str:
    """The core metadata (PKG-INFO) setuptools makes from pyproject.toml, without building anything."""
    import io

    from setuptools.config.pyprojecttoml import apply_configuration
    from setuptools.dist import Distribution

    buf = io.StringIO()
    apply_configuration(Distribution(), REPO / "pyproject.toml").metadata.write_pkg_file(buf)
    return buf.getvalue()


def test_metadata_has_urls_classifiers_keywords_and_authors():
    from email.parser import Parser

    meta = Parser().parsestr(_metadata())
    urls = dict(u.split(", ", 1) for u in meta.get_all("Project-URL") or [])
    assert set(urls) == {"Homepage", "Documentation", "Source", "Issues"}
    assert all(u.startswith("https://") for u in urls.values()) and urls["Issues"].startswith(urls["Source"])
    classifiers = meta.get_all("Classifier") or []
    assert len(classifiers) == len(set(classifiers))
    for required in ("Development Status :: ", "Intended Audience :: Science/Research",
                     "Operating System :: POSIX :: Linux", "Programming Language :: Python :: 3 :: Only",
                     "Programming Language :: Python :: 3.11", "Topic :: Scientific/Engineering", "Typing :: Typed"):
        assert any(c.startswith(required) for c in classifiers), required
    # Linux only (docs/install.md, "Supported platforms"): no other operating system is claimed
    assert [c for c in classifiers if c.startswith("Operating System")] == ["Operating System :: POSIX :: Linux"]
    # the licence is the SPDX expression (PEP 639: setuptools refuses a "License ::" classifier beside it)
    assert meta["License-Expression"] == "MIT" and not any(c.startswith("License ::") for c in classifiers)
    assert meta["Author"] == "the gearsym developers" and meta["Requires-Python"] == ">=3.11"
    keywords = meta["Keywords"].split(",")
    assert {"gear dynamics", "backlash", "Floquet multipliers", "continuation", "SUNDIALS"} <= set(keywords)


def test_metadata_declares_platformdirs_as_a_core_dependency():
    from email.parser import Parser

    from packaging.requirements import Requirement

    requires = [Requirement(r) for r in Parser().parsestr(_metadata()).get_all("Requires-Dist") or []]
    core = {r.name: r for r in requires if r.marker is None}
    # 4.11.8: the first platformdirs that ignores a relative XDG_CACHE_HOME (gearsym.engine.trust.user_cache_dir)
    assert "platformdirs" in core and core["platformdirs"].specifier.contains("4.11.8")
    assert not core["platformdirs"].specifier.contains("4.11.7")


def test_py_typed_is_package_data():
    import runpy

    import setuptools

    captured: dict = {}
    monkey = pytest.MonkeyPatch()
    monkey.setattr(setuptools, "setup", lambda **kw: captured.update(kw))
    try:
        runpy.run_path(str(REPO / "setup.py"), run_name="__main__")
    finally:
        monkey.undo()
    assert "py.typed" in captured["package_data"]["gearsym"]
    assert (Path(gearsym.__file__).parent / "py.typed").is_file()


def test_supported_platforms_are_stated():
    install = (REPO / "docs" / "install.md").read_text(encoding="utf-8")
    section = install[install.index("## Supported platforms"):]
    section = section[: section.index("\n## ", 3)]
    for fact in ("fcntl.flock", "O_NOFOLLOW", "PR_SET_PDEATHSIG", "ELF", "Windows is not supported"):
        assert fact in section, fact
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert "Supported platforms: Linux only" in readme


def test_the_licence_named_in_the_metadata_is_shipped():
    """``license = "MIT"`` names a licence; its text is in the repository and in the wheel's metadata."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    text = (root / "LICENSE").read_text()
    assert text.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in text
