"""Package layout that pyproject.toml alone cannot say.

The shipped models and scenes stay in the repository's top-level ``models/`` and
``scenes/`` folders (scenes name their model as ``../models/NAME.toml``); the wheel and
the sdist carry them as package data under ``gearsym/data/models`` and
``gearsym/data/scenes``, where :mod:`gearsym.catalog` finds them by name.  Every other
setting is in pyproject.toml.
"""

from setuptools import find_packages, setup

DATA = {"gearsym.data.models": "models", "gearsym.data.scenes": "scenes"}

setup(
    packages=[*find_packages(include=["gearsym", "gearsym.*"]), *DATA],
    package_dir=DATA,
    package_data={
        "gearsym": ["templates/*.toml"],
        "gearsym.engine": ["*.c", "*.h"],
        "gearsym.export": ["templates/*.c", "templates/*.sh", "templates/*.in", "templates/fmi2/*.h"],
        **{pkg: ["*.toml"] for pkg in DATA},
    },
)
