"""Scheduled breakpoints (test model 2) against the exact matrix-exponential
solution of the piecewise-constant linear system."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MEISSNER_P, meissner_exact

PV = [MEISSNER_P[k] for k in ("w", "a", "P", "d", "c")]
P, D = MEISSNER_P["P"], MEISSNER_P["d"]


def breakpoints(t0, t1):
    out = []
    for n in range(int(np.floor(t0 / P)) - 1, int(np.ceil(t1 / P)) + 2):
        for c in (0.0, D):
            tb = (n + c) * P
            if t0 < tb < t1:
                out.append(tb)
    return np.array(sorted(out))


@pytest.mark.parametrize("method", ["bdf", "adams"])
@pytest.mark.parametrize("t0,t_end", [(0.0, 7.3 * P), (-1.234, 5.0 * P), (0.35 * P, 6.0 * P + 0.1)])
def test_schedule_vs_expm(meissner_engine, method, t0, t_end):
    x0 = [0.7, -0.2]
    bps = breakpoints(t0, t_end)
    # outputs: a grid plus every breakpoint plus t0 and t_end exactly
    t_out = np.unique(np.concatenate([[t0, t_end], np.linspace(t0, t_end, 57), bps]))
    r = meissner_engine.run(
        x0, PV, t0, t_end, t_out, method=method, rtol=1e-11, atol=1e-13, want_monodromy=True
    )
    y_ex, Phi_ex = meissner_exact(MEISSNER_P, x0, t0, t_out)
    assert np.max(np.abs(r.y - y_ex)) < 1e-8
    np.testing.assert_array_equal(r.y[0], x0)
    assert np.max(np.abs(r.monodromy - Phi_ex)) < 1e-8
    assert r.stats["n_breaks"] == len(bps)
    assert r.stats["n_reinit"] == len(bps)  # no events (|x| < c)
    assert len(r.events) == 0


def test_schedule_needs_breakpoints(meissner_engine):
    """Without stopping at the breakpoints the error would be large: compare
    with the smooth system that never switches (sanity of the test itself)."""
    x0 = [0.7, -0.2]
    t_end = 7.3 * P
    r = meissner_engine.run(x0, PV, 0.0, t_end, [t_end], rtol=1e-11, atol=1e-13)
    y_ex, _ = meissner_exact(MEISSNER_P, x0, 0.0, [t_end])
    y_wrong, _ = meissner_exact(dict(MEISSNER_P, d=0.3), x0, 0.0, [t_end])
    assert np.max(np.abs(r.y - y_ex)) < 1e-8
    assert np.max(np.abs(y_wrong - y_ex)) > 1e-2


def test_event_at_breakpoint(meissner_engine):
    """A switching surface crossed exactly at a breakpoint, with an output
    time there too: both are handled, nothing is lost or doubled."""
    x0 = [0.7, -0.2]
    t_end = 3.0 * P
    tb = (1 + D) * P  # a breakpoint
    y_tb, _ = meissner_exact(MEISSNER_P, x0, 0.0, [tb])
    c = float(y_tb[0, 0])  # the surface g = x - c is crossed at tb
    pv = PV[:4] + [c]
    t_out = np.array([0.0, tb, t_end])
    r = meissner_engine.run(x0, pv, 0.0, t_end, t_out, rtol=1e-11, atol=1e-13)
    y_ex, _ = meissner_exact(MEISSNER_P, x0, 0.0, t_out)
    assert np.max(np.abs(r.y - y_ex)) < 1e-8
    near = np.abs(r.events.t - tb) < 1e-6
    assert near.sum() == 1, r.events.t
    assert r.stats["n_breaks"] == len(breakpoints(0.0, t_end))


def test_breakpoint_at_t_end_and_output_grid_on_breaks(meissner_engine):
    x0 = [0.1, 0.5]
    t_end = 4 * P  # a breakpoint (up to round-off)
    t_out = np.array([k * P for k in range(5)] + [(k + D) * P for k in range(4)])
    t_out.sort()
    r = meissner_engine.run(x0, PV, 0.0, t_end, t_out, rtol=1e-11, atol=1e-13)
    y_ex, _ = meissner_exact(MEISSNER_P, x0, 0.0, t_out)
    assert np.max(np.abs(r.y - y_ex)) < 1e-8
    assert r.stats["n_breaks"] == 7  # 3 cycle starts + 4 at d, not t_end
    np.testing.assert_array_equal(r.y[-1], r.x_final)
