"""Budgets for symbolic work (gearsym issue 25, item 6): expression sizes measured without
walking shared trees, a deadline for the derivation and the code generation, and a bounded
W-M series in the fractal bound function.

The hostile spec files themselves (a 256-argument ``Max``, power towers and product chains
spread over ``[derived]``, ``floor`` of a state, ...) are cases of
``tests/bad_input/test_hostile_input.py``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

import gearsym
from gearsym.bound_functions import evaluate
from gearsym.errors import ParameterError, SpecError
from gearsym.fractal import wm_mean_height, wm_mean_height_report

# (the budget module is imported by the tests that use it: the others run on a gearsym without it)

ROOT = Path(__file__).resolve().parents[1]
#: the folder of the gearsym being tested (the subprocesses import the same one)
PACKAGE_ROOT = Path(gearsym.__file__).resolve().parents[1]
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"
x, v, b, t = sp.symbols("x v b t", real=True)


def _chain(k: int) -> sp.Expr:
    """``d_j = sin(d_(j-1)) + cos(d_(j-1))``: a tree of 2**k leaves, k + 1 distinct levels."""
    d = x
    for _ in range(k):
        d = sp.sin(d) + sp.cos(d)
    return d


def test_measure_counts_the_tree_of_a_shared_expression():
    """The counts equal sympy's own walk of the tree (small case), and a tree of 2**60 nodes
    built from 60 shared levels is refused by its count, without walking it."""
    from gearsym.symbolic import budget
    from gearsym.symbolic.budget import ExpressionTooLarge, measure

    e = _chain(10)
    m = measure(e)

    def depth(node: sp.Basic) -> int:
        return 1 + max((depth(a) for a in node.args), default=0)
    assert m.nodes == sum(1 for _ in sp.preorder_traversal(e)) == 4093
    assert m.depth == depth(e) == 21
    with pytest.raises(ExpressionTooLarge, match=f"more than {budget.MAX_TREE_NODES} nodes"):
        measure(_chain(60))


@pytest.mark.parametrize("expr", [
    (x + 1) ** 64,
    sp.Mul(*[x + v + i for i in range(1, 11)]),
    sp.Mul(*[x + b * i for i in range(1, 9)]) * (x - v) ** 3,
    (x + v) ** 5 / (1 + x ** 2) ** 2,
])
def test_measure_bounds_the_expansion(expr):
    """``terms`` bounds the number of terms of ``sp.expand`` (the reference) and ``degree``
    is the total degree of the numerator."""
    from gearsym.symbolic.budget import measure

    m = measure(expr)
    num = sp.fraction(sp.together(expr))[0]
    assert m.terms >= len(sp.Add.make_args(sp.expand(expr)))
    assert m.degree >= sp.Poly(num, x, v, b).total_degree()


def test_measure_bounds_the_expansion_with_blocks():
    """Expanded in the states with every static part one symbol (the derivation's canonical form
    of a switching function), ``(x + v + t + 1)*(x + v + t + 2)*...`` has a distinct block per
    factor: 60 factors are refused, 3 are counted (the reference: the expansion itself)."""
    from gearsym.symbolic.budget import ExpressionTooLarge, measure

    states = frozenset({x, v})
    blocks = sp.symbols("c1:4")
    small = sp.Mul(*[x + v + c for c in blocks])
    assert measure(sp.Mul(*[x + v + t + i for i in range(1, 4)]), states).terms >= \
        len(sp.Add.make_args(sp.expand(small)))
    with pytest.raises(ExpressionTooLarge, match="expansion of more than"):
        measure(sp.Mul(*[x + v + t + i for i in range(1, 61)]), states)
    measure(sp.Mul(*[x + v + t + i for i in range(1, 61)]))  # fully expanded: a polynomial in x, v, t


@pytest.mark.parametrize("expr,message", [
    (x ** 4096, "polynomial degree of 4096"),
    (sp.Integer(2) ** 4096 * x, "number out of range"),
    (sp.Rational(1, 2 ** 1100) * x, "number out of range"),
    (sp.Float("1e400") * x, "number out of range"),
])
def test_measure_refuses(expr, message):
    from gearsym.symbolic.budget import ExpressionTooLarge, measure

    with pytest.raises(ExpressionTooLarge, match=message):
        measure(expr)


def test_the_derivation_has_a_deadline(monkeypatch):
    """``GEARSYM_SYMBOLIC_SECONDS=0``: the derivation stops at its first check, naming the field."""
    scene = gearsym.load_scene(KS_SCENE)
    monkeypatch.setenv("GEARSYM_SYMBOLIC_SECONDS", "0")
    with pytest.raises(SpecError, match="deriving the equations of model 'kahraman_singh' took longer than its "
                                        "budget of 0 s") as info:
        _ = scene.model
    assert info.value.field is not None and info.value.file.endswith("kahraman_singh.toml")


def test_the_code_generation_has_a_deadline(monkeypatch):
    """The sympy -> CasADi walk checks the deadline of the code generation (its own budget:
    the model was derived before)."""
    from gearsym.codegen.generate import build_functions

    model = gearsym.load_scene(KS_SCENE).model
    assert build_functions(model)  # within the default budget
    monkeypatch.setenv("GEARSYM_SYMBOLIC_SECONDS", "0")
    with pytest.raises(SpecError, match="generating the functions of model 'kahraman_singh' took longer"):
        build_functions(model)


@pytest.mark.parametrize("value", ["abc", "-1", "nan"])
def test_a_bad_budget_is_refused(monkeypatch, value):
    monkeypatch.setenv("GEARSYM_SYMBOLIC_SECONDS", value)
    with pytest.raises(SpecError, match="GEARSYM_SYMBOLIC_SECONDS must be a number of seconds"):
        _ = gearsym.load_scene(KS_SCENE).model


# --------------------------------------------------------------- the fractal bound function

ARGS = (1.4, 1e-11, 1.5, 1.5e-4, 1e-4)  # D, G, lam, L, l_a of models/yu_6dof.toml (SI)


def test_wm_series_refuses_lam_close_to_one():
    """``lam = 1.000001``: the series needs about 1e7 levels; refused before any work, naming lam
    (before: an evaluation that did not end)."""
    with pytest.raises(ParameterError, match=r"lam = 1\.000001 .* needs about 8\.\d+e\+06 levels"):
        wm_mean_height_report(1.4, 1e-11, 1.000001, 1.5e-4, 1e-4)
    with pytest.raises(ParameterError, match=r"^wm_mean_height\(D, G, lam, L_c, l_a\): the W-M series with the "
                                             r"frequency density lam = 1\.000001"):
        evaluate("wm_mean_height", [1.4, 1e-11, 1.000001, 1.5e-4, 1e-4], ["D", "G", "lam", "L_c", "l_a"])


def test_wm_series_refuses_a_sampling_length_of_millions_of_asperities():
    with pytest.raises(ParameterError, match="spans 1.5e\\+06 times the largest asperity"):
        wm_mean_height(1.4, 1e-11, 1.5, 150.0, 1e-4)


def test_wm_series_unchanged_within_the_limits():
    """The limits do not change a value the series reaches: the value and the number of levels
    gearsym computed before them (commit cbf81b9), bit for bit."""
    rep = wm_mean_height_report(*ARGS)
    assert (rep.value, rep.levels) == (1.267601178731335e-07, 20)
    assert wm_mean_height(*ARGS) == rep.value


WM_MODEL = """
[model]
name = "wm"

[coordinates.x]
unit = "m"
velocity = "v"

[parameters]
m = { value = 1.0, unit = "kg" }
k = { value = 1e6, unit = "N/m" }
c = { value = 10.0, unit = "N*s/m" }
F = { value = 1.0, unit = "N" }
D = { value = 1.4 }
G = { value = 1e-11, unit = "m" }
lam = { value = 1.5 }
L_c = { value = 150.0, unit = "um" }
l_a = { value = 100.0, unit = "um" }

[derived]
h = { value = "wm_mean_height(D, G, lam, L_c, l_a)", unit = "m" }

[elements.mass]
type = "inertia"
coordinate = "x"
value = "m"

[elements.spring]
type = "spring"
deflection = "x"
stiffness = "k"

[elements.damper]
type = "damper"
deflection = "x"
coefficient = "c"

[elements.load]
type = "force"
coordinate = "x"
value = "F + k*h"

[initial]
x = 0.0
v = 0.0
"""


def test_cli_refuses_lam_close_to_one(tmp_path):
    """``gearsym simulate --set lam=1.000001`` on a model with the fractal bound function: exit 2,
    one line naming the call and lam (before: it did not end)."""
    (tmp_path / "wm.toml").write_text(WM_MODEL)
    (tmp_path / "s.toml").write_text('[scene]\nname = "wm"\nmodel = "wm.toml"\n')
    env = dict(os.environ, GEARSYM_GENERATED=str(tmp_path / "gen"), PYTHONPATH=str(PACKAGE_ROOT))
    r = subprocess.run([sys.executable, "-m", "gearsym.cli", "simulate", "s.toml", "--set", "lam=1.000001",
                        "--t-end", "0.001"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gearsym: error: "), r.stderr
    assert "wm_mean_height(D, G, lam, L_c, l_a)" in r.stderr and "lam = 1.000001" in r.stderr


def test_a_long_chain_of_derived_quantities_written_backwards(tmp_path):
    """1 500 derived quantities, each defined by the next one (the file written bottom-up): the
    spec layer's cycle check was a recursion (RecursionError, exit 1) and the namespace took one
    pass over the table per level of the chain; now one walk each."""
    ks = (ROOT / "models" / "kahraman_singh.toml").read_text()
    n = 1500
    table = "[derived]\n" + "\n".join(f'e{k} = "e{k + 1} + b"' for k in range(n)) + f'\ne{n} = "b"\n\n[forcing]'
    model = ks.replace("[forcing]", table, 1).replace('value = ["Fm",', 'value = ["Fm*e0/(1501*b)",', 1)
    (tmp_path / "m.toml").write_text(model)
    (tmp_path / "s.toml").write_text('[scene]\nname = "chain"\nmodel = "m.toml"\n')
    m = gearsym.load_scene(tmp_path / "s.toml").model
    assert m.ns._local["e0"] == (n + 1) * sp.Symbol("b", real=True)
