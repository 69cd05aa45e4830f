"""Long runs: a chaotic regime over 1e4 forcing periods (statistics stable when the
tolerance is tightened, no drift of the forcing phase) and a periodic impacting regime
over 1e5 forcing periods (the orbit is never lost).

References: the hand-written event-located DOP853 of ``tests/reference.py`` (fixed point
of the periodic orbit; the chaotic motion over its first periods), the time-shift symmetry
of a T-periodic system, and the statistics of the same run at a 100x tighter tolerance.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import gearsym

from ._ref import ks

ROOT = Path(__file__).resolve().parents[2]
KS = ROOT / "scenes" / "kahraman_singh.toml"
R = ks()
CHAOS = {"Omega": 0.8, "Fa": 0.6}      # double-sided impacts, chaotic (tests/test_benchmark_accuracy.py)


@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(KS).compile()


def _stats(tr, T: float, skip: int) -> dict[str, float]:
    x = tr.y[skip:, 0]
    ev = np.array([e.t for e in tr.events])
    ev = ev[ev > tr.t[skip]]
    back = sum(1 for e in tr.events if e.t > tr.t[skip] and e.surface == "mesh.back")
    n_per = (tr.t[-1] - tr.t[skip]) / T
    return {"mean": float(x.mean()), "rms": float(np.sqrt(np.mean(x**2))), "impacts": len(ev) / n_per,
            "back": back / n_per, "phases": np.sort((ev % T) / T)}


@pytest.fixture(scope="module")
def chaos_runs(ks_system):
    T = ks_system.period(CHAOS)
    n = 10_000
    out = {}
    for rtol in (1e-7, 1e-9):
        tr = ks_system.simulate(periods=n, params=CHAOS, rtol=rtol, atol=rtol * 1e-2, n_out=8 * n + 1,
                                max_steps=30_000_000)
        out[rtol] = tr
    return T, out


def test_chaotic_regime_is_chaotic_and_accurate_before_divergence(ks_system):
    """Two hand-written references 10x apart in tolerance part within 50 periods (chaos);
    gearsym follows them over the first 5 periods."""
    T = ks_system.period(CHAOS)
    p = dict(R.DEFAULTS, **CHAOS)
    t = np.linspace(0, 50 * T, 50 * 8 + 1)
    y13, *_ = R.reference_solution(p, [1.1, 0.0], t)
    y12, *_ = R.reference_solution(p, [1.1, 0.0], t, rtol=1e-12, atol=1e-14)
    assert np.max(np.abs(y13[-40:] - y12[-40:])) > 1e-3            # diverged by 50 periods
    tr = ks_system.simulate(t_end=t[-1], t_out=t, params=CHAOS, rtol=1e-10, atol=1e-12)
    early = t <= 5 * T
    assert np.max(np.abs(tr.y[early] - y13[early])) < 1e-6


def test_chaotic_statistics_stable_under_tolerance(chaos_runs):
    T, runs = chaos_runs
    skip = 8 * 100
    a, b = (_stats(runs[r], T, skip) for r in (1e-7, 1e-9))
    for s in (a, b):
        assert np.all(np.isfinite(runs[1e-7].y)) and np.max(np.abs(runs[1e-7].y[:, 0])) < 10
        assert 2.0 < s["impacts"] < 5.0 and s["back"] > 0.2        # double-sided impacts throughout
    assert abs(a["mean"] - b["mean"]) < 0.02 * b["rms"]
    assert abs(a["rms"] - b["rms"]) < 0.02 * b["rms"]
    assert abs(a["impacts"] - b["impacts"]) < 0.03 * b["impacts"]
    assert abs(a["back"] - b["back"]) < 0.05 * b["back"]


def test_no_drift_of_the_forcing_phase(ks_system, chaos_runs):
    """(1) The system is T-periodic: starting the same state at t0 = 1e4 T gives the same
    motion as at t0 = 0 (the forcing phase at large t is exact).  (2) Over the 1e4-period
    run, impacts happen at the same forcing phases early and late (same distribution)."""
    T, runs = chaos_runs
    x0 = runs[1e-9].y[8 * 137]              # some state on the attractor
    t_rel = np.linspace(0, 3 * T, 3 * 64 + 1)
    t_shift = 10_000 * T
    a = ks_system.simulate(t_end=t_rel[-1], t_out=t_rel, x0=x0, params=CHAOS, rtol=1e-11, atol=1e-13)
    b = ks_system.simulate(t0=t_shift, t_end=t_shift + t_rel[-1], t_out=t_shift + t_rel, x0=x0, params=CHAOS,
                           rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(a.y - b.y)) < 1e-8
    ev = np.array([e.t for e in runs[1e-9].events])
    first = (ev[ev < 4000 * T] % T) / T
    last = (ev[ev > 6000 * T] % T) / T
    grid = np.linspace(0, 1, 201)
    cdf = [np.searchsorted(np.sort(x), grid) / x.size for x in (first, last)]
    assert np.max(np.abs(cdf[0] - cdf[1])) < 0.05      # two-sample Kolmogorov-Smirnov distance


def test_periodic_orbit_kept_for_1e5_periods(ks_system):
    """Single-sided impact regime (the scene): a stable period-1 orbit with two contact
    changes per period.  After 1e5 periods every Poincare point is still on the orbit."""
    T = ks_system.period()
    p = dict(R.DEFAULTS)
    t = np.linspace(0, 200 * T, 201)
    y_ref, *_ = R.reference_solution(p, [1.1, 0.0], t)
    x_star = y_ref[-1]
    assert np.max(np.abs(y_ref[-20:] - x_star)) < 1e-10       # converged fixed point
    n = 100_000
    tr = ks_system.simulate(periods=n, rtol=1e-6, atol=1e-8, n_out=n + 1, max_steps=30_000_000)
    P = tr.y[100:]
    assert np.all(np.isfinite(P))
    assert np.max(np.abs(P - x_star)) < 1e-4
    assert np.max(np.abs(P - P[-1])) < 1e-8            # not drifting along the run
    counts = np.bincount(np.floor(np.array([e.t for e in tr.events]) / T).astype(int), minlength=n)
    assert np.all(counts[100:n] == 2)
    assert abs(tr.t[-1] - n * T) < 1e-9 * n * T
    assert math.isclose(tr.x_final[0], tr.y[-1, 0], rel_tol=0, abs_tol=1e-12)
