"""The analysis layer's public objects: options as frozen dataclasses, immutable results.

Cheap checks on the benchmark oscillator (one orbit solve each): an options object gives
the same orbit as the keywords it replaces, a keyword overrides it, and the results
cannot be modified in place.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis.periodic import shoot

ROOT = Path(__file__).resolve().parents[1]
KS = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}


@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()


@pytest.fixture(scope="module")
def ks_orbit(ks_system):
    return shoot(ks_system, params=KS, rtol=1e-11, atol=1e-13, tol=1e-10)


def test_shooting_options_equal_the_keywords(ks_system, ks_orbit):
    opts = gearsym.ShootingOptions(rtol=1e-11, atol=1e-13, tol=1e-10)
    o = shoot(ks_system, params=KS, x0=ks_orbit.x0 + 1e-4, options=opts)
    k = shoot(ks_system, params=KS, x0=ks_orbit.x0 + 1e-4, rtol=1e-11, atol=1e-13, tol=1e-10)
    assert np.array_equal(o.x0, k.x0) and o.info["rtol"] == 1e-11
    # a keyword not at its default overrides the options object
    s = shoot(ks_system, params=KS, x0=ks_orbit.x0 + 1e-4, options=opts, rtol=1e-9)
    assert s.info["rtol"] == 1e-9 and s.info["atol"] == 1e-13
    assert np.max(np.abs(s.x0 - o.x0)) < 1e-6  # the same orbit at a looser tolerance
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.rtol = 1.0  # type: ignore[misc]
    with pytest.raises(gearsym.ParameterError, match="ShootingOptions"):
        shoot(ks_system, params=KS, options=gearsym.ContinuationOptions())


def test_periodic_orbit_is_immutable(ks_orbit):
    with pytest.raises(dataclasses.FrozenInstanceError):
        ks_orbit.x0 = np.zeros(2)  # type: ignore[misc]
    tr = ks_orbit.trajectory()  # a cached derived value is still allowed
    assert tr is ks_orbit.trajectory()
    # the orbit closes: the cached trajectory ends where it starts
    assert np.max(np.abs(tr.y[-1] - tr.y[0])) < 1e-8


def test_branch_results_are_immutable_and_carry_no_solver_state(ks_system):
    opts = gearsym.ContinuationOptions(ds_max=0.2, detect=False, progress=False)
    br = gearsym.continuation(ks_system, "Omega", 1.3, 1.4, params={k: v for k, v in KS.items() if k != "Omega"},
                              options=opts)
    assert br.complete and br.values[-1] == pytest.approx(1.4)
    assert not any(hasattr(br, a) for a in ("_residual", "_continuer", "_nodes"))
    assert br.setup is not None and br.setup.param == "Omega" and br.setup.periods == 1
    with pytest.raises(dataclasses.FrozenInstanceError):
        br.points = []  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        br.points[0].value = 0.0  # type: ignore[misc]
    # every point is an orbit: one period from x0 returns to x0
    p = br.points[len(br.points) // 2]
    xT = ks_system.simulate(periods=1, x0=p.x0, params=br.params_at(p.value), rtol=1e-11, atol=1e-13,
                            n_out=2).x_final
    assert np.max(np.abs(xT - p.x0)) < 1e-7


def test_fourier_series_against_the_written_out_sum():
    from gearsym.analysis.periodic._fourier import coefficients, synthesize

    rng = np.random.default_rng(3)
    c = rng.standard_normal(5)
    n = 32
    th = 2 * np.pi * np.arange(n) / n
    ref = c[0] + c[1] * np.cos(th) + c[2] * np.sin(th) + c[3] * np.cos(2 * th) + c[4] * np.sin(2 * th)
    assert np.max(np.abs(synthesize(c, n) - ref)) < 1e-13
    C = rng.standard_normal((9, 3))
    assert np.max(np.abs(coefficients(synthesize(C, 64), 4) - C)) < 1e-13


@pytest.mark.parametrize("n", [2, 6, 30])
def test_multiplier_tolerances_match_scipy_left_right_eigenvectors(n):
    """The small-matrix path (numpy eig, left vectors from inv(V)) against scipy's left/right
    eigenvectors: the same eigenvalue condition numbers, hence the same tolerances."""
    import scipy.linalg

    from gearsym.analysis.periodic import multiplier_tolerances

    rng = np.random.default_rng(n)
    M = rng.standard_normal((n, n)) * 10.0 ** rng.uniform(-3, 3, (n, 1))
    mu, tol, delta = multiplier_tolerances(M, 1e-10)
    Mb = scipy.linalg.matrix_balance(M, permute=False)[0]
    ref, vl, vr = scipy.linalg.eig(Mb, left=True, right=True)
    kappa = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0) / np.abs(np.sum(np.conj(vl) * vr, axis=0))
    cap = np.sqrt(delta * max(1.0, np.linalg.norm(Mb, 2)))
    ref_tol = np.maximum(np.minimum(kappa * delta, cap), 16 * np.finfo(float).eps)
    for m, t in zip(mu, tol, strict=True):
        j = int(np.argmin(np.abs(ref - m)))
        assert abs(ref[j] - m) <= 1e-12 * np.max(np.abs(ref))
        assert t == pytest.approx(ref_tol[j], rel=1e-9)
