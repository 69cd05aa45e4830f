"""The import graph of gearsym: no cycles, and no module imports a higher layer.

Every module of the package is read with :mod:`ast` (not imported); every ``import`` /
``from ... import`` of a gearsym module counts, at module level or inside a function
(a lazy import is still a dependency), except under ``if TYPE_CHECKING:`` (annotations
only).  ``from pkg import name`` counts as an import of ``pkg.name`` when that is a
module, else of ``pkg``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "gearsym"

#: The layers, lowest first, as the code has them (data flows one way, upwards):
#:
#: * base: errors, the version, file helpers, optional extras, bound (fractal) functions, the work budget,
#:   signals; the gear-geometry mesh stiffness (numpy only); frozen options objects; the registry of
#:   integration methods (data: the scene's settings check method names against it); the progress bar
#:   and the display mixins of the result classes (reprs, HTML, LaTeX, xarray / pandas; duck-typed);
#: * spec: TOML parsing/validation (no sympy); the catalogue of shipped models and scenes;
#: * symbolic: sympy equations of motion, modes, switching surfaces;
#: * engine: the generic C driver over SUNDIALS and its build; it knows no model, so it sits
#:   *below* codegen, which generates a model's C and links it against the driver;
#: * codegen: sympy -> CasADi -> C, the build cache, the GeneratedModel artefact;
#: * system: the engine-level compiled system (gearsym.system.CompiledSystem), result objects,
#:   the static equilibrium, evaluations and sensitivities, the gear quantities of a result;
#: * analysis: periodic orbits, Floquet, continuation, maps, modes (by kind: ANALYSIS_KINDS);
#: * facade: Scene, load_scene and the user-facing System with its analysis conveniences
#:   (System.periodic_orbit): above the analysis it calls;
#: * presentation: plots, inspection, export (C project, FMU);
#: * top: the CLI, the benchmark harness and the package root (its lazy public namespace).
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("base", ("gearsym._version", "gearsym.errors", "gearsym.files", "gearsym.extras", "gearsym.fractal",
              "gearsym.bound_functions", "gearsym.budget", "gearsym.signals", "gearsym.gears", "gearsym.options",
              "gearsym.integrators", "gearsym.progress", "gearsym.display")),
    ("spec", ("gearsym.spec", "gearsym.catalog")),
    ("symbolic", ("gearsym.symbolic",)),
    ("engine", ("gearsym.engine",)),
    ("codegen", ("gearsym.codegen",)),
    ("system", ("gearsym.system", "gearsym.results", "gearsym.static", "gearsym.evaluation", "gearsym.sensitivity",
                "gearsym.simulation_options", "gearsym.quantities")),
    ("analysis", ("gearsym.analysis",)),
    ("facade", ("gearsym.facade",)),
    ("presentation", ("gearsym.plots", "gearsym.inspection", "gearsym.export")),
    ("top", ("gearsym.cli", "gearsym.cli_cache", "gearsym.cli_catalog", "gearsym.cli_checks", "gearsym.bench",
             "gearsym.__main__", "gearsym")),
]

#: The kinds of analysis (subpackages of gearsym.analysis) and the other kinds each may import.
#: Continuation drives the periodic-orbit problems; sweeps run periodic-orbit solves and linear
#: analyses over grids; the periodic-orbit and the linear analysis import no other kind.
ANALYSIS_KINDS: dict[str, frozenset[str]] = {
    "periodic": frozenset(),
    "linear": frozenset(),
    "continuation": frozenset({"periodic"}),
    "sweeps": frozenset({"periodic", "linear"}),
}
#: Modules of gearsym.analysis outside the kinds: the package's face (its __init__, which imports
#: the kinds lazily) and what every kind shares (the options objects, the inputs), which imports no kind.
ANALYSIS_COMMON = ("gearsym.analysis", "gearsym.analysis._inputs", "gearsym.analysis._options")


def _modules() -> dict[str, Path]:
    mods = {}
    for f in ROOT.rglob("*.py"):
        parts = list(f.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = f
    return mods


MODULES = _modules()


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(mod: str, path: Path) -> list[tuple[str, str]]:
    """``(imported module, enclosing function or "")`` of every gearsym import of a module."""
    package = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
    out: list[tuple[str, str]] = []

    def visit(node: ast.AST, func: str) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.orelse:
                visit(child, func)
            return
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            func = node.name
        if isinstance(node, ast.Import):
            out.extend((a.name, func) for a in node.names if a.name.split(".")[0] == "gearsym")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            if name.split(".")[0] == "gearsym":
                for a in node.names:
                    full = f"{name}.{a.name}"
                    out.append((full if full in MODULES else name, func))
        for child in ast.iter_child_nodes(node):
            visit(child, func)

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return [(m, fn) for m, fn in out if m != mod]


GRAPH = {mod: _imports(mod, path) for mod, path in MODULES.items()}


def _layer(mod: str) -> int:
    best, rank = -1, -1
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (mod == p or mod.startswith(p + ".")) and len(p) > best:
                best, rank = len(p), i
    return rank


def test_every_module_has_a_layer():
    assert [m for m in MODULES if _layer(m) < 0] == []


def test_imports_resolve_to_modules_of_the_package():
    # a typo in an import (or a moved module) would otherwise drop an edge silently
    missing = sorted({(mod, dep) for mod, deps in GRAPH.items() for dep, _ in deps if dep not in MODULES})
    assert missing == []


def test_no_upward_imports():
    bad = []
    for mod, deps in GRAPH.items():
        for dep, func in deps:
            if _layer(dep) > _layer(mod):
                bad.append(f"{mod} ({LAYERS[_layer(mod)][0]}) imports {dep} ({LAYERS[_layer(dep)][0]})"
                           + (f" in {func}()" if func else ""))
    assert bad == []


def _kind(mod: str) -> str | None:
    """The kind of analysis of a module (``None``: not in a kind)."""
    parts = mod.split(".")
    if parts[:2] != ["gearsym", "analysis"] or len(parts) < 3:
        return None
    return parts[2] if parts[2] in ANALYSIS_KINDS else None


def test_every_analysis_module_belongs_to_a_kind():
    analysis = [m for m in MODULES if m == "gearsym.analysis" or m.startswith("gearsym.analysis.")]
    assert sorted(m for m in analysis if _kind(m) is None and m not in ANALYSIS_COMMON) == []
    assert {k for k in ANALYSIS_KINDS if f"gearsym.analysis.{k}" in MODULES} == set(ANALYSIS_KINDS)


def test_analysis_kinds_import_only_the_kinds_they_may():
    bad = []
    for mod, deps in GRAPH.items():
        src = _kind(mod)
        for dep, func in deps:
            dst = _kind(dep)
            if dst is None or dst == src:
                continue
            if src is None and mod in ANALYSIS_COMMON and mod != "gearsym.analysis":
                bad.append(f"{mod} (shared by every kind) imports {dep} (kind '{dst}')")
            elif src is not None and dst not in ANALYSIS_KINDS[src]:
                bad.append(f"{mod} (kind '{src}') imports {dep} (kind '{dst}', not in "
                           f"{sorted(ANALYSIS_KINDS[src]) or 'none'})" + (f" in {func}()" if func else ""))
    assert bad == []


def test_private_modules_of_a_kind_are_imported_only_within_it():
    # across kinds, and from outside the analysis, only a kind's public face (its __init__)
    bad = []
    for mod, deps in GRAPH.items():
        for dep, func in deps:
            dst = _kind(dep)
            if dst is None or dep == f"gearsym.analysis.{dst}" or _kind(mod) == dst:
                continue
            bad.append(f"{mod} imports the private module {dep}" + (f" in {func}()" if func else ""))
    assert bad == []


def test_no_import_cycles():
    edges = {mod: sorted({d for d, _ in deps if d in MODULES}) for mod, deps in GRAPH.items()}
    cycles = []
    state: dict[str, int] = {}
    stack: list[str] = []

    def dfs(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for d in edges[m]:
            if state.get(d) == 1:
                cycles.append(" -> ".join(stack[stack.index(d):] + [d]))
            elif d not in state:
                dfs(d)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            dfs(m)
    assert cycles == []


@pytest.mark.parametrize("mod", ["gearsym.spec.model", "gearsym.spec.scene", "gearsym.spec.expressions"])
def test_the_spec_layer_never_imports_sympy(mod):
    tree = ast.parse(MODULES[mod].read_text(encoding="utf-8"))
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    names += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    assert not [n for n in names if n.split(".")[0] == "sympy"]


def test_one_kind_of_analysis_does_not_load_the_others():
    """The package face imports the kinds on first use: the periodic-orbit and the linear
    analysis load neither continuation nor the sweeps (nor their process pool), and the facade
    loads no analysis until an analysis is asked for (``gearsym simulate`` does not pay for it)."""
    import subprocess
    import sys

    code = ("import sys\nimport gearsym.facade\nprint(sorted(m for m in sys.modules if m.startswith('gearsym.analysis')))\n"
            "import gearsym.analysis.periodic, gearsym.analysis.linear\n"
            "print(sorted({m.split('.')[2] for m in sys.modules if m.startswith('gearsym.analysis.')}))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.splitlines() == ["[]", "['_options', 'linear', 'periodic']"]


@pytest.mark.parametrize("face", ["gearsym.analysis", *(f"gearsym.analysis.{k}" for k in ANALYSIS_KINDS)])
def test_every_name_of_an_analysis_face_resolves(face):
    import importlib

    mod = importlib.import_module(face)
    assert [n for n in mod.__all__ if not hasattr(mod, n)] == []
    # the face's __all__ names what it defines or re-exports (no private name, no module)
    assert [n for n in mod.__all__ if n.startswith("_") or type(getattr(mod, n)).__name__ == "module"] == []
