"""The wheel, installed into a fresh virtual environment outside the repository.

``python -m build`` makes the sdist and, from it, the wheel (so the sdist is checked to be
complete too).  The wheel is installed with pip into a new venv whose only other packages
are gearsym's *core* dependencies, the closure of the wheel's own ``Requires-Dist`` taken
from this environment (linked in through a ``.pth`` file, so nothing is downloaded):
``pip install --no-index`` then fails if the wheel declares a dependency the core set
does not have, and the extras (matplotlib, xarray, dask, distributed) are absent, as for a
user's plain ``pip install gearsym``.

One build and one install for the module (about 20 s); marked ``wheel`` so that
``-m "not wheel"`` leaves it out while iterating.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from email.parser import Parser
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks
from packaging.markers import default_environment
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

pytestmark = pytest.mark.wheel
REPO = Path(__file__).resolve().parents[1]


def _closure(requirements: list[str]) -> list[metadata.Distribution]:
    """The installed distributions that satisfy ``requirements`` (no extras), transitively."""
    env = {**default_environment(), "extra": ""}
    seen: dict[str, metadata.Distribution] = {}
    todo = [Requirement(r) for r in requirements]
    while todo:
        req = todo.pop()
        if req.marker is not None and not req.marker.evaluate(env):
            continue
        key = canonicalize_name(req.name)
        if key in seen:
            continue
        dist = metadata.distribution(req.name)  # PackageNotFoundError: the test env lacks a core dep
        assert req.specifier.contains(dist.version, prereleases=True), (req, dist.version)
        seen[key] = dist
        todo += [Requirement(r) for r in dist.requires or []]
    return list(seen.values())


def _link_site(dists: list[metadata.Distribution], site: Path) -> None:
    """A folder with links to the top-level files of ``dists`` (packages, ``.libs``, dist-info)."""
    site.mkdir()
    for dist in dists:
        base = Path(dist.locate_file(""))
        tops = {Path(f).parts[0] for f in dist.files or [] if not str(f).startswith("..")}
        tops.add(Path(dist._path).name)  # the .dist-info folder itself
        for top in tops:
            if (base / top).exists() and not (site / top).exists():
                (site / top).symlink_to(base / top)


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> dict:
    tmp = tmp_path_factory.mktemp("wheel")
    dist = tmp / "dist"
    # without PYTHONPATH: with the repository on it, the gearsym.egg-info that the build writes
    # there looks like an installed gearsym to pip, which then skips the install
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(dist), str(REPO)],
                   check=True, capture_output=True, text=True, cwd=tmp, env=clean)
    wheel = next(dist.glob("gearsym-*.whl"))
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        name = next(n for n in names if n.endswith(".dist-info/METADATA"))
        meta = Parser().parsestr(zf.read(name).decode())
    requires = meta.get_all("Requires-Dist") or []
    core = [r for r in requires if "extra ==" not in r]
    site = tmp / "core-site"
    _link_site(_closure(core), site)
    env_dir = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True)
    py = env_dir / "bin" / "python"
    purelib = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    Path(purelib, "gearsym_core_deps.pth").write_text(str(site) + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "--no-index", "--quiet",
                    str(wheel)], check=True, capture_output=True, text=True, cwd=tmp, env=clean)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env.update(GEARSYM_GENERATED=str(tmp / "builds"), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    work = tmp / "work"
    work.mkdir()
    return {"bin": env_dir / "bin", "env": env, "cwd": work, "requires": requires, "core": core, "meta": meta,
            "names": names}


def _run(venv: dict, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(venv["bin"] / "gearsym"), *args], capture_output=True, text=True,
                          env=venv["env"], cwd=venv["cwd"], timeout=600)


def test_wheel_declares_the_core_and_the_extras(venv):
    core = sorted(canonicalize_name(Requirement(r).name) for r in venv["core"])
    assert core == ["casadi", "numpy", "platformdirs", "scikit-sundae", "scipy", "sympy"]
    extras = {}
    for r in venv["requires"]:
        req = Requirement(r)
        for extra in ("plots", "maps", "all"):
            if req.marker is not None and req.marker.evaluate({**default_environment(), "extra": extra}) \
                    and "extra ==" in r:
                extras.setdefault(extra, set()).add(canonicalize_name(req.name))
    assert extras["plots"] == {"matplotlib"}
    assert {"xarray", "dask", "distributed"} <= extras["maps"]


def test_wheel_metadata_is_complete_and_ships_py_typed(venv):
    # issue 29: project URLs, classifiers (Linux only), keywords and the PEP 561 marker in the wheel
    meta = venv["meta"]
    urls = dict(u.split(", ", 1) for u in meta.get_all("Project-URL") or [])
    assert set(urls) == {"Homepage", "Documentation", "Source", "Issues"}
    assert all(u.startswith("https://") for u in urls.values())
    classifiers = set(meta.get_all("Classifier") or [])
    assert {"Operating System :: POSIX :: Linux", "Intended Audience :: Science/Research",
            "Topic :: Scientific/Engineering", "Typing :: Typed"} <= classifiers
    assert meta["License-Expression"] == "MIT" and meta["Requires-Python"] == ">=3.11"
    assert meta["Author"] and "gear dynamics" in meta["Keywords"].split(",")
    assert "gearsym/py.typed" in venv["names"]


def test_installed_wheel_runs_a_shipped_scene_by_name(venv):
    py = venv["bin"] / "python"
    where = subprocess.run([py, "-c", "import gearsym, gearsym.catalog as c; print(gearsym.__file__); "
                            "print(c.data_root())"], capture_output=True, text=True, env=venv["env"],
                           cwd=venv["cwd"], check=True).stdout.split()
    assert Path(where[0]).is_relative_to(venv["bin"].parent)  # the installed copy, not the checkout
    assert Path(where[1]) == Path(where[0]).parent / "data"

    res = _run(venv, "simulate", "kahraman_singh", "--json", "--periods", "20", "--rtol", "1e-10",
               "--atol", "1e-12")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["scene"] == "kahraman_singh" and info["state_names"] == ["x", "v"]
    # against the event-located DOP853 reference at rtol 1e-13 (tests/reference.py)
    T = 2 * np.pi / 0.9
    y, *_ = ks().reference_solution(dict(zeta=0.05, Fm=0.1, Fa=0.05, eps=0.2, b=1.0, Omega=0.9), [1.1, 0.0],
                                    [0.0, 20 * T])
    assert info["t_end"] == pytest.approx(20 * T, rel=1e-14)
    assert np.allclose(info["final_state"], y[-1], atol=1e-7)

    res = _run(venv, "models", "--json")
    assert res.returncode == 0, res.stderr
    models = {m["name"]: m for m in json.loads(res.stdout)["models"]}
    assert {"kahraman_singh", "spur_pair_torsional", "vaishya_singh", "yu_6dof", "liu_nfg", "meissner"} <= set(models)
    assert "Kahraman" in models["kahraman_singh"]["reference"]


def test_installed_wheel_names_the_missing_extras(venv):
    res = _run(venv, "map", "meissner", "--x", "a", "0", "0.5", "3", "--y", "T", "1", "2", "3", "--out", "m")
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [
        "gearsym: error: gearsym map needs the optional dependencies of gearsym[maps] (missing: xarray, "
        "dask, distributed, matplotlib); install them with: pip install 'gearsym[maps]'"]
    res = _run(venv, "simulate", "kahraman_singh", "--periods", "2", "--out", "figs")
    assert res.returncode == 2 and "pip install 'gearsym[plots]'" in res.stderr
    assert not (venv["cwd"] / "figs").exists() and not (venv["cwd"] / "m").exists()


def test_installed_init_writes_a_scene_that_runs(venv):
    res = _run(venv, "init", "mygear")
    assert res.returncode == 0, res.stderr
    # the template is in the wheel and valid (tests/test_static_start.py compiles and runs it)
    res = _run(venv, "inspect", "scenes/mygear.toml", "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["model"] == "mygear" and info["states"] == ["x", "v"]
    assert [s["name"] for s in info["switching_functions"]] == ["mesh.drive", "mesh.back"]
    res = _run(venv, "init", "mygear")
    assert res.returncode == 2 and "not overwriting" in res.stderr
