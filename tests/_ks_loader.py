"""``tests/reference.py`` (the benchmark oscillator's hand-written references) as a module.

Loaded under its own name: ``tests/engine/reference.py`` is imported as ``reference`` by
the engine tests, and the two must never shadow each other.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

_NAME = "gearsym_tests_ks_reference"


def ks() -> ModuleType:
    """The module ``tests/reference.py`` (loaded once)."""
    if _NAME not in sys.modules:
        spec = importlib.util.spec_from_file_location(_NAME, Path(__file__).with_name("reference.py"))
        mod = importlib.util.module_from_spec(spec)
        sys.modules[_NAME] = mod
        spec.loader.exec_module(mod)
    return sys.modules[_NAME]
