"""Write the intersphinx inventories of ``docs/_inventories/`` (the docs build reads no network).

Two sources, one per library (docs/_inventories/README.md says which is which):

* ``--debian DIR``: the ``objects.inv`` that the projects' own Sphinx builds wrote, as Debian ships
  them in its documentation packages (``apt-get download python3.11-doc python-scipy-doc
  python-pandas-doc python-sympy-doc``, then ``dpkg-deb -x PACKAGE.deb DIR``); only the Python
  domain and the glossary terms are kept (the labels and documents of their prose are not
  referenced from here), the lines themselves unchanged.
* generated: numpy and xarray, whose documentation is one autosummary page per public name
  (``reference/generated/numpy.NAME.html``, ``generated/xarray.NAME.html``), from the names of the
  installed packages; the numpy glossary terms are listed by hand.

Run it from the repository root: ``python docs/_inventories/make_inventories.py [--debian DIR]``.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: Debian documentation package folder -> (inventory file, project)
DEBIAN = {
    "python3.11": ("python.inv", "Python"),
    "python-scipy-doc": ("scipy.inv", "SciPy"),
    "python-pandas-doc": ("pandas.inv", "pandas"),
    "python-sympy-doc": ("sympy.inv", "SymPy"),
}
KEEP = ("py:", "std:term")
NUMPY_TERMS = ("array_like", "array", "ndarray", "dtype", "broadcast", "scalar", "view", "vectorization")


def _header(project: str, version: str) -> bytes:
    return (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: {version}\n"
            "# The remainder of this file is compressed using zlib.\n").encode()


def write(path: Path, project: str, version: str, lines: list[str]) -> None:
    """Write an objects.inv (format 2) with these entry lines."""
    body = "\n".join(sorted(set(lines))) + "\n"
    path.write_bytes(_header(project, version) + zlib.compress(body.encode(), 9))
    print(f"{path.name}: {len(set(lines))} entries, {path.stat().st_size} bytes")


def from_debian(root: Path) -> None:
    """Filter the Debian packages' inventories (the Python domain and glossary terms)."""
    for folder, (name, project) in DEBIAN.items():
        found = sorted(root.glob(f"usr/share/doc/{folder}/html/objects.inv"))
        if not found:
            print(f"{folder}: no objects.inv under {root}")
            continue
        raw = found[0].read_bytes()
        head = raw.split(b"\n", 4)
        version = head[2].decode().split(":", 1)[1].strip()
        lines = [ln for ln in zlib.decompress(head[4]).decode().splitlines()
                 if len(ln.split(" ")) > 4 and ln.split(" ")[1].startswith(KEEP)]
        write(HERE / name, project, version, lines)


def _role(obj: object) -> str:
    if inspect.isclass(obj):
        return "py:exception" if issubclass(obj, BaseException) else "py:class"
    if inspect.ismodule(obj):
        return "py:module"
    return "py:function" if callable(obj) else "py:data"


def _members(prefix: str, owner: object) -> list[tuple[str, str]]:
    """(name, role) of the public members of a module or class."""
    out = []
    for attr in dir(owner):
        if attr.startswith("_"):
            continue
        try:
            value = getattr(owner, attr)
        except Exception:
            continue
        if inspect.isclass(owner):
            role = "py:method" if callable(value) else "py:attribute"
        else:
            if inspect.ismodule(value) and not value.__name__.startswith(prefix):
                continue
            role = _role(value)
        out.append((f"{prefix}.{attr}", role))
    return out


def _generated(package: str, modules: tuple[str, ...], classes: tuple[str, ...], page: str) -> list[str]:
    names = [(package, "py:module")]
    for mod in modules:
        names += [(mod, "py:module")] if mod != package else []
        names += _members(mod, importlib.import_module(mod))
    for cls in classes:
        mod, _, attr = cls.rpartition(".")
        names += _members(cls, getattr(importlib.import_module(mod), attr))
    return [f"{n} {role} 1 {page.format(name=n) if role != 'py:module' else page.format(name=n)} -"
            for n, role in names]


def generated() -> None:
    """numpy and xarray: one autosummary page per public name."""
    import numpy
    import xarray

    lines = _generated("numpy", ("numpy", "numpy.linalg", "numpy.fft", "numpy.random"),
                       ("numpy.ndarray", "numpy.random.Generator"), "reference/generated/{name}.html#$")
    lines = [ln for ln in lines if " py:module " not in ln]
    lines += ["numpy py:module 1 reference/index.html#module-$ -"]
    lines += [f"{t} std:term -1 glossary.html#term-{t.replace(' ', '-')} -" for t in NUMPY_TERMS]
    write(HERE / "numpy.inv", "NumPy", numpy.__version__, lines)
    lines = _generated("xarray", ("xarray",), ("xarray.Dataset", "xarray.DataArray"), "generated/{name}.html#$")
    lines = [ln for ln in lines if " py:module " not in ln] + ["xarray py:module 1 api.html#module-$ -"]
    write(HERE / "xarray.inv", "xarray", xarray.__version__, lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--debian", type=Path, help="folder the Debian documentation packages were extracted to")
    args = parser.parse_args()
    if args.debian:
        from_debian(args.debian)
    generated()


if __name__ == "__main__":
    main()
