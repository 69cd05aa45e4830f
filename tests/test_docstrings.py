"""Every public name has a numpydoc docstring with Parameters and Returns where they apply.

Public names are ``gearsym.__all__`` and the public methods and properties of its classes
(their own and those they inherit from gearsym classes).
Functions and methods are checked with numpydoc's own validator (``numpydoc.validate``):
no docstring (GL08), parameters not documented (PR01) or documented but absent (PR02),
a function that returns something without a Returns section (RT01).  A class must describe
every argument of its constructor under Parameters or, for result objects that users
receive rather than build, Attributes.  No name is exempt.
"""

from __future__ import annotations

import inspect

import pytest
from numpydoc.docscrape import NumpyDocString
from numpydoc.validate import validate

import gearsym

CHECKS = {"GL08", "PR01", "PR02", "RT01"}


def _problems(name: str) -> list[str]:
    obj = getattr(gearsym, name)
    out = []
    if not inspect.getdoc(obj):
        return [f"{name}: no docstring"]
    if inspect.isclass(obj):
        doc = NumpyDocString(inspect.getdoc(obj))
        documented = {p.name.split(":")[0].strip().lstrip("*") for p in doc["Parameters"] + doc["Attributes"]}
        documented = {n for item in documented for n in item.replace(" ", "").split(",")}
        try:
            sig = inspect.signature(obj)
        except (TypeError, ValueError):
            sig = None
        for p in (sig.parameters.values() if sig else []):
            if p.name.lstrip("_") not in documented and p.name not in documented:
                out.append(f"{name}: constructor argument '{p.name}' is in neither Parameters nor Attributes")
        # the class's own members and those it inherits from gearsym classes (gearsym.System is
        # the facade's class over gearsym.system.CompiledSystem and its mixins)
        members = {}
        for klass in reversed([k for k in obj.__mro__ if k.__module__.split(".")[0] == "gearsym"]):
            members.update({attr: (klass, value) for attr, value in vars(klass).items()})
        for attr, (klass, value) in members.items():
            if attr.startswith("_"):
                continue
            if isinstance(value, (property, staticmethod, classmethod)) or inspect.isfunction(value):
                qual = f"{klass.__module__}.{klass.__qualname__}.{attr}"
                if isinstance(value, property):
                    if not (value.__doc__ or "").strip():
                        out.append(f"{qual}: property without a docstring")
                    continue
                out += [f"{qual}: {code} {msg}" for code, msg in validate(qual)["errors"] if code in CHECKS]
    elif callable(obj):
        qual = f"{obj.__module__}.{obj.__qualname__}"
        out += [f"{qual}: {code} {msg}" for code, msg in validate(qual)["errors"] if code in CHECKS]
    return out


PUBLIC = [n for n in gearsym.__all__ if n != "__version__"]


def test_all_lists_every_export():
    assert set(gearsym.__all__) == set(gearsym._EXPORTS) | {"__version__"}


@pytest.mark.parametrize("name", PUBLIC)
def test_public_name_has_a_complete_docstring(name):
    assert _problems(name) == []
