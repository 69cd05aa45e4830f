"""Sphinx configuration of the gearsym documentation (``make docs``: warnings are errors).

The site is built from the numpydoc docstrings (autodoc + numpydoc), the Markdown chapters
of this folder (MyST), the argparse parser of the CLI (sphinx-argparse) and the guides
whose code runs during the build (sphinx-gallery: ``guides/*.py`` -> ``auto_guides/``).
The API page lists every name of ``gearsym.__all__``: it is written here, at build time.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
# the guides compile scenes: keep their builds inside the docs build, not in a shared cache
os.environ.setdefault("GEARSYM_GENERATED", str(HERE / "_build" / "gearsym-builds"))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import gearsym  # noqa: E402

project = "gearsym"
author = "the gearsym developers"
copyright = "the gearsym developers"
release = version = gearsym.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "gallery", "performance", "guides/GALLERY_HEADER.rst", "auto_guides/*.ipynb",
                    "auto_guides/*.py", "auto_guides/*.zip", "auto_guides/*.json"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]

html_theme = "furo"
html_title = f"gearsym {version}"

autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc sections carry the types
autodoc_default_options = {"members": True, "show-inheritance": True}
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_class_members_toctree = False

sphinx_gallery_conf = {
    "examples_dirs": ["guides"],
    "gallery_dirs": ["auto_guides"],
    "filename_pattern": r"guide_",       # run every guide
    "abort_on_example_error": True,      # a guide whose code fails fails the build
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "default_thumb_file": None,
    "show_memory": False,
    "plot_gallery": "True",
}


def _api_page(app, docname: str, source: list[str]) -> None:
    """Fill ``api.md``'s placeholder with one autodoc entry per name of ``gearsym.__all__``."""
    if docname != "api":
        return
    kinds = {"function": [], "class": [], "exception": []}
    for name in gearsym.__all__:
        if name == "__version__":
            continue
        obj = getattr(gearsym, name)
        if isinstance(obj, type) and issubclass(obj, BaseException):
            kinds["exception"].append(name)
        elif isinstance(obj, type):
            kinds["class"].append(name)
        else:
            kinds["function"].append(name)
    titles = {"function": "Functions", "class": "Classes", "exception": "Exceptions"}
    parts = []
    for kind, names in kinds.items():
        parts.append(f"## {titles[kind]}\n\n```{{eval-rst}}")
        for name in sorted(names, key=str.lower):
            directive = "autofunction" if kind == "function" else "autoclass"
            parts.append(f".. {directive}:: gearsym.{name}\n")
        parts.append("```\n")
    source[0] = source[0].replace("<!-- API -->", "\n".join(parts))


def setup(app):
    app.connect("source-read", _api_page)
