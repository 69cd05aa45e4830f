"""Bounded work everywhere (issue 24 item 14): every count a user gives is checked against a
memory / time budget (:mod:`gearsym.budget`) before any work, by the command line and by the
library alike, with a :class:`~gearsym.errors.ParameterError` (exit 2) naming the option and
the limit.

Before: ``gearsym modes --samples 1000000000`` allocated 7.7 GB and died with a MemoryError
(exit 1); the API took ``segments=10**6``, ``max_points=10**9`` or a map axis of 10**12 points
and failed late (a MemoryError) or not at all.  The values below that reach an allocation on
the old code are chosen so that the allocation fails at once (10**12 samples: 8 TB) rather than
filling this machine's memory.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from bad_input._helpers import KS_SCENE, Case, check_case

import gearsym
from gearsym.errors import ParameterError

KS = str(KS_SCENE)


# ---------------------------------------------------------------- the rules
def test_the_modes_samples_of_the_issue_are_above_the_budget():
    from gearsym.budget import LIMITS, check_count

    assert LIMITS["samples"].high == 100_000
    check_count("--samples", 100_000)
    with pytest.raises(ParameterError, match=r"^--samples must be an integer in \[1, 100,000\], got 1000000000 "
                                             r"\(the limit on samples per forcing period"):
        check_count("--samples", 1_000_000_000)
    for bad in (0, 2.5, "32", True, float("nan"), float("inf")):
        with pytest.raises(ParameterError, match=r"^--samples must be an integer in \[1, 100,000\]"):
            check_count("--samples", bad)


def test_matrix_and_branch_budgets():
    from gearsym.budget import check_branch, check_shooting

    check_shooting(1000, 16)  # 16000**2 = 2.56e8 entries: within 2**28
    with pytest.raises(ParameterError, match=r"with 2 states and 10000 segments, the multiple-shooting Jacobian "
                                             r"would have 20000 x 20000 = 4e\+08 entries .*use fewer segments"):
        check_shooting(10_000, 2)
    check_branch(5000, 200)  # the default max_points up to 200 states
    with pytest.raises(ParameterError, match=r"a branch of up to 1,000,000 points, each with its 20 x 20 monodromy"
                                             r".*use a smaller max_points"):
        check_branch(1_000_000, 20)


# ---------------------------------------------------------------- the command line
CLI = [
    Case("modes: --samples 1e12", lambda w: ["modes", KS, "--samples", str(10 ** 12)],
         ["--samples", "[1, 100,000]", "got 1000000000000"]),
    Case("modes: --samples 0", lambda w: ["modes", KS, "--samples", "0"], ["--samples", "got 0"]),
]


@pytest.mark.parametrize("case", CLI, ids=[c.id for c in CLI])
def test_cli_counts_refused_before_loading(case: Case, tmp_path: Path):
    gen = tmp_path / "gen"
    gen.mkdir()
    check_case(case, tmp_path, gen)  # exit 2, one line naming the option, nothing compiled or written


# ---------------------------------------------------------------- the library
@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(KS_SCENE).compile()


def test_modal_analysis_samples(ks_system):
    from gearsym.analysis.linear import modal_analysis, static_equilibrium

    for fn in (modal_analysis, static_equilibrium):
        with pytest.raises(ParameterError, match=r"^samples must be an integer in \[1, 100,000\], got 10{12}"):
            fn(ks_system, samples=10 ** 12)


def test_flow_samples(ks_system):
    with pytest.raises(ParameterError, match=r"output grid has 1e\+12 points x 2 values .*use fewer n_samples"):
        ks_system.flow(ks_system.x0, 0.0, 1.0, n_samples=10 ** 12)


def test_harmonic_balance_counts(ks_system):
    from gearsym.analysis.periodic import harmonic_balance

    with pytest.raises(ParameterError, match=r"^harmonics must be an integer in \[0, 4,096\], got 10{12}"):
        harmonic_balance(ks_system, harmonics=10 ** 12)
    with pytest.raises(ParameterError, match=r"^a harmonic number of harmonics must be an integer in "
                                             r"\[0, 4,096\], got 1000000000"):
        harmonic_balance(ks_system, harmonics=[1, 10 ** 9])
    with pytest.raises(ParameterError, match=r"^samples must be an integer in \[1, 1,048,576\], got 10{12}"):
        harmonic_balance(ks_system, harmonics=4, samples=10 ** 12)


@pytest.mark.parametrize("cls, kw, needle", [
    ("ShootingOptions", {"segments": 10 ** 6}, r"^segments must be an integer in \[1, 10,000\]"),
    ("ShootingOptions", {"max_iter": 10 ** 9}, r"^max_iter must be an integer in \[0, 100,000\]"),
    ("ShootingOptions", {"transient": 1e12}, r"^transient must be a number in \[0, 1,000,000\]"),
    ("ShootingOptions", {"relax_periods": float("inf")}, r"^relax_periods must be a number"),
    ("ContinuationOptions", {"max_points": 10 ** 9}, r"^max_points must be an integer in \[2, 1,000,000\]"),
    ("ContinuationOptions", {"switch": 40}, r"^switch must be an integer in \[0, 8\]"),
    ("ContinuationOptions", {"n_dense": 10 ** 9}, r"^n_dense must be an integer in \[2, 1,048,576\]"),
])
def test_options_objects_are_bounded(cls, kw, needle):
    with pytest.raises(ParameterError, match=needle):
        getattr(gearsym, cls)(**kw)


def test_shooting_and_continuation_keywords(ks_system):
    from gearsym.analysis.periodic import shoot

    with pytest.raises(ParameterError, match=r"^segments must be an integer in \[1, 10,000\], got 1000000"):
        shoot(ks_system, segments=10 ** 6)
    with pytest.raises(ParameterError, match=r"^max_points must be an integer in \[2, 1,000,000\], got 10{9}"):
        gearsym.continuation(ks_system, "Omega", 0.5, 1.0, max_points=10 ** 9)
    with pytest.raises(ParameterError, match=r"^segments must be an integer in \[1, 10,000\], got 1000000"):
        gearsym.continuation(ks_system, "Omega", 0.5, 1.0, segments=10 ** 6)


def test_map_axes_and_workers():
    from gearsym.analysis.sweeps import stability_map

    scene = gearsym.load_scene(KS_SCENE)  # refused before it is compiled
    with pytest.raises(ParameterError, match=r"^x N must be an integer in \[1, 1,000,000\], got 10{12}"):
        stability_map(scene, ("Omega", 0.5, 1.0, 10 ** 12), ("zeta", 0.02, 0.05, 1))
    # options passed to every point's solver: refused once, before the scene is compiled (the old
    # code failed every point with the same message and returned a map of failed points)
    with pytest.raises(ParameterError, match=r"^segments must be an integer in \[1, 10,000\], got 1000000"):
        stability_map(scene, ("Omega", 0.5, 1.0, 2), ("zeta", 0.02, 0.05, 1), method="shooting",
                      orbit_options={"segments": 10 ** 6})
    # (the unknown quantity: the old code refused it before it started 10**6 processes)
    with pytest.raises(ParameterError, match=r"^workers must be an integer in \[1, 1,024\], got 1000000"):
        stability_map(scene, ("Omega", 0.5, 1.0, 2), ("zeta", 0.02, 0.05, 2), "bogus", workers=10 ** 6)


def test_the_engine_refuses_a_dense_newton_matrix_above_the_budget(ks_system):
    """nA = 2 (1 + 2 + 8998) = 18002: an 18002**2 = 3.2e8-entry dense matrix (2.4 GiB) fits the
    32-bit index but not the budget.  (The index limit itself: tests/engine/test_index_limits.py;
    the old code refused this call only because this engine has no parameter derivatives.)"""
    import numpy as np

    with pytest.raises(ParameterError, match=r"2 states with 9000 variational columns .*limit is 2\.68e\+08 "
                                             r"values .*blockdiag"):
        ks_system.engine.run(ks_system.x0, ks_system.param_vector(), 0.0, 1.0, want_monodromy=True,
                             linear_solver="dense", sens_dir=np.zeros((ks_system.engine.np, 8998)))


def test_the_cli_and_the_library_share_the_limits():
    from gearsym.budget import LIMITS
    from gearsym.cli import checks

    assert checks.LIMITS is LIMITS
