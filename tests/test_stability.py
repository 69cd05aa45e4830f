"""The stability rule (gearsym.analysis.periodic._stability): trivial multipliers, the neutral band,
verdicts, and bifurcation detection along a conservative branch.

Independent references: scipy.special.mathieu_a / mathieu_b (the characteristic values
of the Mathieu equation bound its stability intervals: x = 0 is stable for
a_m(q) < a < b_{m+1}(q), unstable elsewhere); matrices built with a known spectrum.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.special as ss

import gearsym
from gearsym.analysis.periodic import floquet, multiplier_tolerances

ROOT = Path(__file__).resolve().parents[1]
MATHIEU = ROOT / "scenes" / "mathieu.toml"
QS = (0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0)


def _truth(a: float, q: float) -> str:
    """'stable' inside a_m(q) < a < b_{m+1}(q), else 'unstable' (DLMF 28.17)."""
    return "stable" if any(ss.mathieu_a(m, q) < a < ss.mathieu_b(m + 1, q) for m in range(12)) else "unstable"


@pytest.fixture(scope="module")
def mathieu():
    return gearsym.load_scene(MATHIEU).compile()


def test_jordan_block_of_a_rigid_body_mode_is_split_off():
    """M = Q [[J, X], [0, N]] Q^T with J the rigid-body Jordan block [[1, T], [0, 1]]."""
    rng = np.random.default_rng(1)
    n, T = 6, 0.7
    N = np.diag([0.9, -0.5, 0.3, 0.1]) + np.triu(rng.normal(size=(4, 4)) * 0.1, 1)
    N[0, 1], N[1, 0] = 0.2, -0.2  # a complex pair
    B = np.zeros((n, n))
    B[:2, :2] = [[1.0, T], [0.0, 1.0]]
    B[:2, 2:] = rng.normal(size=(2, 4))
    B[2:, 2:] = N
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    M = Q @ B @ Q.T
    V = Q[:, :2] @ np.diag([3.0, 0.5])  # any basis of the subspace
    M_noisy = M + 1e-13 * rng.normal(size=(n, n))
    plain = np.linalg.eigvals(M_noisy)
    assert np.max(np.abs(plain[np.argsort(np.abs(plain - 1))[:2]] - 1)) > 1e-8  # the smear
    fq = floquet(M_noisy, 1e-12, V)
    assert fq.info["rigid_split"] == "ok" and fq.invariance_defect < 1e-11
    assert np.allclose(np.sort_complex(fq.multipliers), np.sort_complex(np.linalg.eigvals(N)), atol=1e-11)
    assert np.max(np.abs(fq.trivial - 1)) < 1e-5
    assert fq.stability == "asymptotically_stable"
    # without the basis the Jordan pair is judged (neutral at best)
    assert floquet(M_noisy, 1e-12).stability in ("neutral", "unstable")


def test_verdict_does_not_depend_on_the_units_of_the_states():
    rng = np.random.default_rng(2)
    M = rng.normal(size=(4, 4)) * 0.4
    D = np.diag([1e-6, 1.0, 1e-3, 10.0])
    a = floquet(M, 1e-10)
    b = floquet(np.linalg.inv(D) @ M @ D, 1e-10)
    assert a.stability == b.stability
    assert np.allclose(a.multipliers, b.multipliers, rtol=1e-10)
    assert np.allclose(a.tolerances, b.tolerances, rtol=1e-6)


def test_eigenvalue_condition_numbers_match_the_left_right_vector_definition():
    """``kappa_i = |y_i| |x_i| / |y_i^H x_i|`` from scipy's left and right eigenvectors (the
    definition) against the one-``dgeev`` computation of the rule, on matrices with real
    eigenvalues and complex pairs, n = 1 .. 40; and a Jordan block's tolerance is the cap."""
    import scipy.linalg

    from gearsym.analysis.periodic._stability import ERROR_FACTOR, _eig_kappa

    rng = np.random.default_rng(7)
    n_pairs = 0
    for n in (1, 2, 3, 6, 13, 40):
        for _ in range(10):
            M = rng.standard_normal((n, n)) * np.exp(rng.uniform(-3, 3, n))[None, :]
            mu, kappa = _eig_kappa(M)
            w, vl, vr = scipy.linalg.eig(M, left=True, right=True)
            ref = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0) / np.abs(np.sum(np.conj(vl) * vr, axis=0))
            n_pairs += int(np.sum(np.abs(w.imag) > 0))
            for m, k in zip(mu, kappa, strict=True):
                j = int(np.argmin(np.abs(w - m)))
                assert abs(w[j] - m) <= 1e-12 * max(1.0, abs(m))
                assert k == pytest.approx(ref[j], rel=1e-8)
    assert n_pairs > 50
    J = np.array([[1.0, 1.0], [0.0, 1.0]])
    mu, tol, delta = multiplier_tolerances(J, 1e-10)
    assert np.allclose(mu, 1.0, atol=1e-7)
    assert tol == pytest.approx(np.full(2, math.sqrt(delta * max(1.0, np.linalg.norm(J, 2)))), rel=1e-12)
    assert delta == pytest.approx(ERROR_FACTOR * 1e-10 * np.linalg.norm(J, 2), rel=1e-12)


def test_tolerance_of_a_defective_pair_is_the_square_root_bound():
    # a Jordan block at -1: kappa is infinite, the bound is sqrt(delta * ||M||)
    M = np.array([[-1.0, 1.0], [0.0, -1.0]])
    mu, tol, delta = multiplier_tolerances(M, 1e-10)
    assert np.all(tol == pytest.approx(math.sqrt(delta * np.linalg.norm(M, 2)), rel=1e-9))
    # a normal matrix: kappa = 1, the tolerance is delta
    mu, tol, delta = multiplier_tolerances(np.diag([0.5, -0.2]), 1e-10)
    assert np.all(tol == pytest.approx(delta, rel=1e-12))


def test_mathieu_verdicts_on_both_sides_of_every_characteristic_value(mathieu):
    """Issue 11 done-when: a = a_m(q) +- 0.01 and b_m(q) +- 0.01, q = 0.5 .. 10, m = 0 .. 3:
    orbit (shooting, default tolerances) says neutral on the stable side and unstable on the
    other (before: 18 of 70 stable cases were called unstable)."""
    n = {"stable": 0, "unstable": 0}
    for q in QS:
        for m in range(4):
            for fn in ((ss.mathieu_a,) if m == 0 else (ss.mathieu_a, ss.mathieu_b)):
                for da in (-0.01, 0.01):
                    a = float(fn(m, q)) + da
                    want = _truth(a, q)
                    o = mathieu.periodic_orbit(x0=[0.0, 0.0], params={"a": a, "q": q}, atol=1e-14)
                    assert o.converged and np.all(o.x0 == 0.0)
                    got = "stable" if o.stable else "unstable"
                    assert got == want, (m, q, da, o.multipliers, o.multiplier_tolerances)
                    assert o.stability == ("neutral" if want == "stable" else "unstable")
                    n[want] += 1
    assert n["stable"] >= 40 and n["unstable"] >= 40, n


@pytest.mark.parametrize("q, lo, hi", [(1.0, -1.0, 10.0), (5.0, -6.0, 26.0)])
def test_mathieu_continuation_locates_every_characteristic_value(mathieu, q, lo, hi):
    """Continuation of x = 0 in a: every a_m, b_m in the range once, to 1e-6, as a branch
    point (m even: multipliers meet at +1) or period doubling (m odd: at -1); no
    Neimark-Sacker point inside the stable intervals (before: 12 spurious ones).  atol is
    given explicitly: the default absolute tolerance of a zero orbit is another branch's work."""
    br = gearsym.continuation(mathieu, "a", lo, hi, x0=[0.0, 0.0], params={"q": q}, atol=1e-12, progress=False)
    assert br.stop_reason.startswith("reached")
    want = sorted([(float(ss.mathieu_a(m, q)), "branch_point" if m % 2 == 0 else "period_doubling")
                   for m in range(12) if lo < ss.mathieu_a(m, q) < hi]
                  + [(float(ss.mathieu_b(m, q)), "branch_point" if m % 2 == 0 else "period_doubling")
                     for m in range(1, 12) if lo < ss.mathieu_b(m, q) < hi])
    got = sorted((b.value, b.type) for b in br.bifurcations)
    assert len(want) >= 7
    assert [k for _, k in got] == [k for _, k in want], got
    assert np.max(np.abs(np.array([v for v, _ in got]) - [v for v, _ in want])) < 1e-6
    for p in br.points:
        if p.bifurcation is None:
            assert p.stability == ("neutral" if _truth(p.value, q) == "stable" else "unstable")


def test_mathieu_map_uses_the_same_rule(mathieu):
    from gearsym.analysis.sweeps import stability_map

    ds = stability_map(mathieu, ("a", -1.0, 9.0, 11), ("q", 0.5, 4.5, 3), method="shooting", workers=1,
                       orbit_options={"atol": 1e-14})
    for j, q in enumerate(ds["q"].values):
        for i, a in enumerate(ds["a"].values):
            stable = _truth(float(a), float(q)) == "stable"
            assert ds["stable"].values[j, i] == int(stable)
            assert ds["stability"].values[j, i] == (1 if stable else 2)
