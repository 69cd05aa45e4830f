"""Package layout that pyproject.toml alone cannot say.

The shipped models and scenes stay in the repository's top-level ``models/`` and
``scenes/`` folders (scenes name their model as ``../models/NAME.toml``); the wheel and
the sdist carry them as package data under ``gearsym/data/models`` and
``gearsym/data/scenes``, where :mod:`gearsym.catalog` finds them by name.  Folders of
data inside the package (templates) are listed as packages too, as setuptools wants.
Every other setting is in pyproject.toml.
"""

from setuptools import find_packages, setup

#: package -> folder of the repository (the shipped models and scenes)
SHIPPED = {"gearsym.data.models": "models", "gearsym.data.scenes": "scenes"}
#: package -> its data files
DATA = {
    "gearsym": ["py.typed"],  # PEP 561: the package's type hints are for type checkers too
    "gearsym.engine": ["*.c", "*.h"],
    "gearsym.templates": ["*.toml"],
    "gearsym.export.templates": ["*.c", "*.h", "*.sh", "*.in"],
    "gearsym.export.templates.fmi2": ["*.h"],
    "gearsym.export.templates.sundials": ["LICENSE", "NOTICE"],
    **{pkg: ["*.toml", "*.csv"] for pkg in SHIPPED},  # models read their tables (CSV) from beside them
}

packages = find_packages(include=["gearsym", "gearsym.*"])
setup(
    packages=[*packages, *(p for p in DATA if p not in packages)],
    package_dir=SHIPPED,
    package_data=DATA,
)
