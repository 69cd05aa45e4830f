"""System.flow, the flow map of the orbit solvers: the same numbers as System.simulate, and
per-component absolute tolerances (atol per state, variational entries scaled by the state
magnitudes) checked against central finite differences of the flow on an SI model whose
states differ by four orders of magnitude."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gearsym

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def spur():
    system = gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml").compile()
    T = system.period()
    x0 = system.simulate(periods=100, rtol=1e-10, atol=1e-16).x_final  # on the impacting orbit
    return system, T, x0


def test_flow_is_simulate(spur):
    system, T, x0 = spur
    f = system.flow(x0, 0.0, T, rtol=1e-10, atol=1e-16)
    tr = system.simulate(t_end=T, x0=x0, rtol=1e-10, atol=1e-16, n_out=2, monodromy=True)
    assert np.array_equal(f.x_final, tr.x_final)
    assert np.array_equal(f.monodromy, tr.monodromy)
    assert len(f.event_t) == tr.stats["n_events"] >= 2
    np.testing.assert_array_equal(f.event_t, [e.t for e in tr.events])
    # a vector of equal tolerances is the scalar tolerance, bit for bit
    g = system.flow(x0, 0.0, T, rtol=1e-10, atol=np.full(2, 1e-16))
    assert np.array_equal(g.monodromy, f.monodromy) and g.stats == f.stats


def test_scaled_variational_tolerance_vs_finite_differences(spur):
    system, T, x0 = spur
    tr = system.simulate(t_end=T, x0=x0, rtol=1e-10, atol=1e-16, n_out=512)
    scale = np.max(np.abs(tr.y), axis=0)
    assert scale[1] / scale[0] > 1e3  # m and m/s: the case the scaling is for
    flows = {"scalar": system.flow(x0, 0.0, T, rtol=1e-10, atol=1e-16),
             "scaled": system.flow(x0, 0.0, T, rtol=1e-10, atol=1e-16, scales=scale)}
    fd = np.empty((2, 2))
    for j in range(2):
        h = 1e-6 * scale[j]
        e = np.zeros(2)
        e[j] = h
        xp = system.flow(x0 + e, 0.0, T, rtol=1e-12, atol=1e-18, monodromy=False)
        xm = system.flow(x0 - e, 0.0, T, rtol=1e-12, atol=1e-18, monodromy=False)
        assert len(xp.event_t) == len(xm.event_t) == len(flows["scalar"].event_t)
        fd[:, j] = (xp.x_final - xm.x_final) / (2 * h)
    # compare in scaled coordinates (dimensionless monodromy S^-1 M S)
    S = np.diag(scale)
    fd_s = np.linalg.solve(S, fd @ S)
    for f in flows.values():
        err = np.max(np.abs(np.linalg.solve(S, f.monodromy @ S) - fd_s))
        assert err < 1e-5 * np.max(np.abs(fd_s)), err
    assert flows["scaled"].stats["n_steps"] <= flows["scalar"].stats["n_steps"]
