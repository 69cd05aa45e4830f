"""Backlash oscillator (test model 1) against an independent scipy reference."""

from __future__ import annotations

import numpy as np
import pytest
from reference import backlash_reference

from gearsym.engine.errors import EngineInputError

ZETA, EPS, FM, B = 0.05, 0.2, 0.1, 1.0


def params(Om, Fa, zeta=ZETA):
    return [zeta, EPS, Om, FM, Fa, B]


@pytest.mark.parametrize(
    "Om,Fa,method,periods,rtol",
    [
        (0.9, 0.05, "bdf", 50, 1e-10),
        (0.9, 0.05, "adams", 50, 1e-10),
        # regular (periodic) double-sided impacts
        (0.8, 1.0, "bdf", 50, 1e-10),
        (0.8, 1.0, "adams", 50, 1e-10),
        # Om=0.8, Fa=0.6 is CHAOTIC (two DOP853 references at rtol 1e-13 and
        # 1e-11 differ by O(1) after 30 periods, errors grow ~10x per 5 periods),
        # so it can only be compared over a short horizon
        (0.8, 0.6, "bdf", 8, 1e-12),
        (0.8, 0.6, "adams", 8, 1e-12),
    ],
    ids=[
        "single-sided-bdf",
        "single-sided-adams",
        "double-sided-bdf",
        "double-sided-adams",
        "chaotic-double-sided-bdf",
        "chaotic-double-sided-adams",
    ],
)
def test_backlash_vs_reference(backlash_engine, Om, Fa, method, periods, rtol):
    p = params(Om, Fa)
    T = 2 * np.pi / Om
    t_end = periods * T
    t_out = np.linspace(0.0, t_end, 20 * periods + 1)
    r = backlash_engine.run([1.1, 0.0], p, 0.0, t_end, t_out, method=method, rtol=rtol, atol=rtol * 1e-2)
    y_ref, ev_ref, x_end_ref, _ = backlash_reference(p, [1.1, 0.0], t_end, t_out)
    err = np.max(np.abs(r.y - y_ref))
    assert err < 1e-7, err
    assert len(r.events) == len(ev_ref)
    np.testing.assert_allclose(r.events.t, ev_ref, atol=1e-7)
    np.testing.assert_allclose(r.x_final, x_end_ref, atol=1e-7)
    assert r.t_reached == t_end
    # output at t0 is the initial state, exactly
    np.testing.assert_array_equal(r.y[0], [1.1, 0.0])
    np.testing.assert_array_equal(r.y[-1], r.x_final)
    # event bookkeeping: surfaces, directions and speeds are consistent
    assert set(np.unique(r.events.surface)) <= {0, 1}
    assert np.all(np.sign(r.events.speed) == r.events.direction)
    if Fa > 0.5:
        assert {0, 1} <= set(r.events.surface.tolist()), "double-sided impacts expected"
    st = r.stats
    assert st["n_events"] == len(ev_ref)
    assert st["n_reinit"] >= st["n_events"]
    assert st["n_steps"] > 0 and st["n_rhs"] >= st["n_steps"] and st["n_jac"] > 0 and st["n_root_evals"] > 0


def test_sides_and_sigma(backlash_engine):
    p = params(0.8, 0.6)
    # sigma from the sign of g at t0: x0 = 1.1 -> g0 > 0, g1 > 0
    r = backlash_engine.run([1.1, 0.0], p, 0.0, 1.0, [1.0])
    assert r.sigma_final.tolist() == [1.0, 1.0]
    assert len(r.events) == 0
    # explicit sigma0 consistent with the state gives the same result
    r2 = backlash_engine.run([1.1, 0.0], p, 0.0, 1.0, [1.0], sigma0=[1, 1])
    np.testing.assert_array_equal(r.y, r2.y)
    with pytest.raises(EngineInputError, match="sigma0"):
        backlash_engine.run([1.1, 0.0], p, 0.0, 1.0, [1.0], sigma0=[0.5, 1])


def test_outputs_at_event_times_and_repeats(backlash_engine):
    """Output times coinciding with events (and repeated times) are filled."""
    p = params(0.8, 0.6)
    t_end = 40.0
    r0 = backlash_engine.run([1.1, 0.0], p, 0.0, t_end, rtol=1e-10, atol=1e-12)
    te = r0.events.t[:5]
    t_out = np.sort(np.concatenate([[0.0, 0.0], te, te, np.linspace(0, t_end, 7), [t_end]]))
    r = backlash_engine.run([1.1, 0.0], p, 0.0, t_end, t_out, rtol=1e-10, atol=1e-12)
    assert np.all(np.isfinite(r.y))
    assert len(r.events) == len(r0.events)
    idx = np.searchsorted(t_out, te)
    # at an event time x = +-b
    np.testing.assert_allclose(np.abs(r.y[idx, 0]), B, atol=1e-9)
    y_ref, _, _, _ = backlash_reference(p, [1.1, 0.0], t_end, t_out)
    assert np.max(np.abs(r.y - y_ref)) < 1e-7


def test_event_log_capacity_regrows(backlash_engine):
    p = params(0.8, 0.6)
    r_small = backlash_engine.run([1.1, 0.0], p, 0.0, 200.0, max_events_out=3)
    r_big = backlash_engine.run([1.1, 0.0], p, 0.0, 200.0, max_events_out=100000)
    assert len(r_small.events) == len(r_big.events) > 3
    np.testing.assert_array_equal(r_small.events.t, r_big.events.t)


def test_repeatable_and_independent_runs(backlash_engine):
    p = params(0.9, 0.05)
    a = backlash_engine.run([1.1, 0.0], p, 0.0, 100.0, [50.0, 100.0])
    b = backlash_engine.run([1.1, 0.0], p, 0.0, 100.0, [50.0, 100.0])
    np.testing.assert_array_equal(a.y, b.y)
    assert a.stats == b.stats


@pytest.mark.parametrize("v0", [0.3, -0.3])
@pytest.mark.parametrize("method", ["bdf", "ida"])
def test_start_exactly_on_a_surface(backlash_engine, v0, method):
    """x0 = b exactly: the side is chosen from the flow (into contact for
    v0 > 0, free flight for v0 < 0), no spurious event, trajectory exact."""
    p = params(0.8, 1.0)
    t_end = 3 * 2 * np.pi / 0.8
    t_out = np.linspace(0, t_end, 61)
    r = backlash_engine.run([B, v0], p, 0.0, t_end, t_out, method=method, rtol=1e-10, atol=1e-12)
    y_ref, ev_ref, _, _ = backlash_reference(p, [B, v0], t_end, t_out)
    assert np.max(np.abs(r.y - y_ref)) < (1e-7 if method == "bdf" else 1e-6)
    assert len(r.events) == len(ev_ref)
    assert r.events.t[0] > 1e-3
