"""The root finder of the continuation's detection (:func:`gearsym.analysis.continuation._bifurcation.bracket_root`).

References: exact roots of smooth functions, and a jump (a discontinuous test function,
which must be told from a root by its final bracket)."""

from __future__ import annotations

import math

import pytest

from gearsym.analysis.continuation._bifurcation import bracket_root


@pytest.mark.parametrize("root", [1e-4, 0.3, 0.77, 0.99999])
@pytest.mark.parametrize("fn", ["tanh", "cubic", "exp"])
def test_smooth_roots_to_xtol(root, fn):
    f = {"tanh": lambda x: math.tanh(5 * (x - root)),
         "cubic": lambda x: (x - root) * (1 + 3 * (x - root) ** 2),
         "exp": lambda x: math.exp(2 * (x - root)) - 1}[fn]
    calls = []

    def g(x):
        calls.append(x)
        return f(x)

    xtol = 1e-9
    x, a, fa, b, fb = bracket_root(g, 0.0, f(0.0), 1.0, f(1.0), xtol)
    assert abs(x - root) <= xtol
    assert min(a, b) - 1e-15 <= root <= max(a, b) + 1e-15 or abs(x - root) <= 0.5 * xtol
    assert len(calls) <= 30


def test_a_jump_is_bracketed_to_xtol_not_taken_for_a_root():
    jump = 0.4123

    def f(x):
        return 1.0 + x if x > jump else -1.0 - x

    xtol = 1e-9
    x, a, fa, b, fb = bracket_root(f, 0.0, f(0.0), 1.0, f(1.0), xtol)
    assert abs(b - a) <= xtol and min(a, b) <= jump <= max(a, b)
    assert min(abs(fa), abs(fb)) > 0.5  # the detection's 'nonsmooth' verdict follows from this
