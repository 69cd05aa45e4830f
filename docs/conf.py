"""Sphinx configuration of the gearsym documentation (``make docs``: ``-n -W``, every warning,
including a cross-reference that does not resolve, fails the build).

The site is built from the numpydoc docstrings (autodoc + numpydoc), the Markdown chapters
of this folder (MyST), the argparse parser of the CLI (sphinx-argparse), the guides whose
code runs during the build (sphinx-gallery: ``guides/*.py`` -> ``auto_guides/``) and the
notebook tour, executed during the build (myst-nb: ``examples/notebooks/tour.ipynb``, copied
to ``notebooks/``).  The API pages (``api/*.md``) are filled in at build time by
``_ext/gearsym_docs.py``.  No step reads the network: the intersphinx inventories are files of
``_inventories/`` (README.md there says where each comes from) and MathJax is the copy in
``_static/mathjax/``.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE / "_ext"))
# the guides and the notebook compile scenes: keep their builds inside the docs build, not in a shared cache
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
    "sphinx.ext.intersphinx",
    "numpydoc",
    "myst_nb",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
    "gearsym_docs",
]
root_doc = "index"
exclude_patterns = ["_build", "_inventories", "_ext", "_static", "gallery", "performance", "guides/GALLERY_HEADER.rst",
                    "auto_guides/*.ipynb", "auto_guides/*.py", "auto_guides/*.zip", "auto_guides/*.json",
                    "**.ipynb_checkpoints"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath", "amsmath"]
nitpicky = True
smartquotes_action = "qe"   # quotes and ellipses only: "--option" stays two hyphens (the CLI examples)
nitpick_ignore = [
    ("py:class", "tqdm.tqdm"),   # tqdm's documentation is not built with Sphinx: there is no inventory to link to
]

html_theme = "furo"
html_title = f"gearsym {version}"
html_static_path = ["_static"]

# ---------------------------------------------------------------- mathematics (offline MathJax 3)
# MathJax 3.2.2 (Apache-2.0, _static/mathjax/LICENSE): the combined TeX -> CommonHTML component
# with every TeX extension, and its fonts; no network is read by the build or by the pages.
mathjax_path = "mathjax/tex-chtml-full.js"
mathjax3_config = {"options": {"processHtmlClass": "tex2jax_process|mathjax_process|math|output_area"}}

# ---------------------------------------------------------------- intersphinx (local inventories)
# Each inventory is a file of _inventories/ (no download); the addresses are the projects'
# public documentation, where the links point.
intersphinx_mapping = {
    "python": ("https://docs.python.org/3/", str(HERE / "_inventories" / "python.inv")),
    "numpy": ("https://numpy.org/doc/stable/", str(HERE / "_inventories" / "numpy.inv")),
    "scipy": ("https://docs.scipy.org/doc/scipy/", str(HERE / "_inventories" / "scipy.inv")),
    "xarray": ("https://docs.xarray.dev/en/stable/", str(HERE / "_inventories" / "xarray.inv")),
    "pandas": ("https://pandas.pydata.org/docs/", str(HERE / "_inventories" / "pandas.inv")),
    "sympy": ("https://docs.sympy.org/latest/", str(HERE / "_inventories" / "sympy.inv")),
}

# ---------------------------------------------------------------- autodoc and numpydoc
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the numpydoc sections carry the types
autodoc_default_options = {}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# the types of the Parameters / Returns sections: the names below link, every other word stays text
numpydoc_xref_param_type = True
numpydoc_xref_ignore = "all"
numpydoc_xref_aliases = {
    "bool": ":class:`python:bool`",   # numpydoc's default links a label of the Python docs' prose
    "ndarray": "numpy.ndarray",
    "array_like": ":term:`numpy:array_like`",
    "array-like": ":term:`numpy:array_like`",
    "Dataset": "xarray.Dataset",
    "xarray.Dataset": "xarray.Dataset",
    "DataArray": "xarray.DataArray",
    "xarray.DataArray": "xarray.DataArray",
    "DataFrame": "pandas.DataFrame",
    "pandas.DataFrame": "pandas.DataFrame",
    "Path": "pathlib.Path",
    "pathlib.Path": "pathlib.Path",
    "Expr": "sympy.core.expr.Expr",
    "sympy.Expr": "sympy.core.expr.Expr",
    "Symbol": "sympy.core.symbol.Symbol",
    "sympy.Symbol": "sympy.core.symbol.Symbol",
}
# the public classes of gearsym, by their short name
for _name in gearsym.__all__:
    if _name[:1].isupper():
        numpydoc_xref_aliases[_name] = f"gearsym.{_name}"

# ---------------------------------------------------------------- the notebook tour (myst-nb)
NOTEBOOKS = HERE / "notebooks"
NOTEBOOKS.mkdir(exist_ok=True)
shutil.copyfile(ROOT / "examples" / "notebooks" / "tour.ipynb", NOTEBOOKS / "tour.ipynb")
nb_execution_mode = "force"           # run on every build: what the page shows is what this version computes
nb_execution_raise_on_error = True    # a cell that fails fails the build
nb_execution_timeout = 900
nb_execution_excludepatterns = ["auto_guides/*"]
nb_output_stderr = "remove"           # the text progress bars (stderr) of a kernel without widgets
# the progress widgets need the ipywidgets JavaScript of a CDN: their text form is shown instead
nb_mime_priority_overrides = [("html", "application/vnd.jupyter.widget-view+json", None)]
nb_ipywidgets_js = {}

# ---------------------------------------------------------------- the guides (sphinx-gallery)
sphinx_gallery_conf = {
    "examples_dirs": ["guides"],
    "gallery_dirs": ["auto_guides"],
    "filename_pattern": r"guide_",       # run every guide
    "abort_on_example_error": True,      # a guide whose code fails fails the build
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    # figures, and the _repr_latex_ of a block's last expression (derived equations) as mathematics
    "image_scrapers": ("matplotlib", "gearsym_docs.latex_scraper"),
    "default_thumb_file": None,
    "show_memory": False,
    "plot_gallery": "True",
}
