"""The documentation site leaves nothing public out, and builds without a warning (issue 29, item 4).

Cheap checks (no Sphinx needed): the API pages (``docs/api/*.md``, filled in at build time by
``docs/_ext/gearsym_docs.py``) cover the modules a user is pointed to -- the top-level package,
the analysis faces, gear quantities, gears, tables, display and progress, integrators, export,
plots -- and every name of their ``__all__`` is documented somewhere: at its home, or as an
alias of an object documented at another name; every figure of ``docs/gallery`` is on a page;
the offline assets (MathJax, the intersphinx inventories) are where ``docs/conf.py`` says.

The build itself (``sphinx -n -W``, as ``make docs``; about a minute, it runs the guides and the
notebook) runs when the documentation tools are installed (``pip install -e .[docs]``); it
then also checks that every public name of those modules is in the built ``objects.inv``.
"""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

import gearsym

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

import gearsym_docs  # noqa: E402

#: the modules the reference must cover (issue 29 item 4: maps, modes, export, plots, harmonic
#: balance, the gear quantities, gears, tables, Lyapunov exponents, basins, integrators, display)
REQUIRED = ["gearsym", "gearsym.analysis", "gearsym.analysis.periodic", "gearsym.analysis.continuation",
            "gearsym.analysis.linear", "gearsym.analysis.sweeps", "gearsym.quantities", "gearsym.gears",
            "gearsym.spec.tables", "gearsym.display", "gearsym.progress", "gearsym.integrators",
            "gearsym.export", "gearsym.plots", "gearsym.results", "gearsym.static"]


@pytest.fixture(scope="module")
def plan() -> gearsym_docs.ApiPlan:
    return gearsym_docs.api_plan(DOCS)


def test_api_pages_cover_the_public_modules(plan):
    missing = [m for m in REQUIRED if m not in plan.modules]
    assert missing == []


@pytest.mark.parametrize("module", REQUIRED)
def test_every_public_name_is_documented_once(plan, module):
    mod = importlib.import_module(module)
    names = gearsym_docs.public_names(mod)
    assert names, module
    entry = plan.modules[module]
    assert sorted(entry.own + list(entry.aliases)) == sorted(names)
    for name, home in entry.aliases.items():
        # an alias names the very object documented at its home, which is another module's own name
        home_module, _, home_name = home.rpartition(".")
        assert home_module != module
        assert home_name in plan.modules[home_module].own
        assert getattr(importlib.import_module(home_module), home_name) is getattr(mod, name)


def test_top_level_names_are_documented_at_the_top(plan):
    top = plan.modules["gearsym"]
    assert sorted(top.own) == sorted(n for n in gearsym.__all__ if n != "__version__")
    assert "__version__" not in top.own
    # e.g. the continuation face re-exports Branch: documented (and linked) as gearsym.Branch
    assert plan.modules["gearsym.analysis.continuation"].aliases["Branch"] == "gearsym.Branch"
    # gearsym.analysis gathers its kinds' names: they are documented in the kind
    assert plan.modules["gearsym.analysis"].aliases["shoot"] == "gearsym.analysis.periodic.shoot"
    assert plan.modules["gearsym.analysis"].own == ["KINDS"]


def test_gallery_figures_are_on_the_site():
    readme = (ROOT / "README.md").read_text()
    gallery = readme[readme.index("## Gallery"):readme.index("## Shipped models")]   # docs/figures.md includes it
    shown = set(re.findall(r"docs/gallery/([\w.-]+\.png)", gallery))
    shown |= set(re.findall(r"gallery/([\w.-]+\.png)", (DOCS / "figures.md").read_text()))
    shown |= {png for items in gearsym_docs.PAPER_FIGURES.values() for png, _ in items}   # reproduction.md
    on_disk = {p.name for p in (DOCS / "gallery").glob("*.png")}
    assert on_disk - shown == set()
    assert shown - on_disk == set()


def test_reproduction_figures_follow_their_paper():
    text = "# R\n\n## Kahraman & Singh, JSV\n\n| a |\n\n## Someone else\n\nx\n"
    out = gearsym_docs.reproduction_figures(text, {"Kahraman & Singh": [("a.png", "A.")], "Missing": [("b.png", "B.")]})
    assert out.index("gallery/a.png") > out.index("## Kahraman") and out.index("gallery/a.png") < out.index("## Someone")
    assert out.index("gallery/b.png") > out.index("## Figures")   # a paper whose heading is gone: at the end


def test_offline_assets_exist():
    assert (DOCS / "_static" / "mathjax" / "tex-chtml-full.js").stat().st_size > 1_000_000
    assert len(list((DOCS / "_static" / "mathjax" / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))) > 20
    assert "Apache License" in (DOCS / "_static" / "mathjax" / "LICENSE").read_text()
    for name in ("python", "numpy", "scipy", "xarray", "pandas", "sympy"):
        raw = (DOCS / "_inventories" / f"{name}.inv").read_bytes()
        head = raw.split(b"\n", 4)
        assert head[0] == b"# Sphinx inventory version 2"
        assert len(zlib.decompress(head[4]).decode().splitlines()) > 100


# ------------------------------------------------------------------------------ the build


def _inventory(path: Path) -> set[str]:
    head = path.read_bytes().split(b"\n", 4)
    return {line.split(" ")[0] for line in zlib.decompress(head[4]).decode().splitlines()}


@pytest.mark.docs
def test_docs_build_without_warnings_and_inventory_has_every_public_name(tmp_path):
    for module in ("sphinx", "myst_nb", "sphinx_gallery", "sphinxarg", "numpydoc", "furo"):
        pytest.importorskip(module)
    out = tmp_path / "html"
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-E", "-n", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(tmp_path / "doctrees"), str(DOCS), str(out)],
                          capture_output=True, text=True, cwd=ROOT)
    warnings = [ln for ln in proc.stderr.splitlines() if "WARNING" in ln and "[IPKernelApp]" not in ln]
    assert proc.returncode == 0 and warnings == [], proc.stderr[-3000:]
    inventory = _inventory(out / "objects.inv")
    for module in REQUIRED:
        names = gearsym_docs.public_names(importlib.import_module(module))
        assert [n for n in names if f"{module}.{n}" not in inventory] == [], module
