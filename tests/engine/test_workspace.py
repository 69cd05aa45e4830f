"""Reused C workspaces (gs_simulate_ws): a call that reuses the integrator memory of an
earlier call (CVodeReInit / IDAReInit) gives bitwise the same result as a fresh
integrator, whatever ran before (other methods, the monodromy, failures, other
threads); and the evaluation entry points (gs_eval, gs_eval_period) agree with
CasADi's own evaluation of the generated functions."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from conftest import MEISSNER_P

from gearsym.engine.errors import EngineError

P_KS = [0.05, 0.2, 0.9, 0.1, 0.05, 1.0]  # zeta, eps, Om, Fm, Fa, b
X0 = np.array([1.1, 0.0])
T = 2 * np.pi / 0.9


def _run(engine, **kw):
    base = {"rtol": 1e-9, "atol": 1e-11, "method": "adams", "t_out": np.linspace(0, 20 * T, 41)}
    base.update(kw)
    return engine.run(X0, P_KS, 0.0, 20 * T, **base)


def _same(r1, r2):
    assert np.array_equal(r1.y, r2.y)
    assert np.array_equal(r1.x_final, r2.x_final)
    assert np.array_equal(r1.events.t, r2.events.t)
    assert r1.stats == r2.stats
    if r1.monodromy is not None:
        assert np.array_equal(r1.monodromy, r2.monodromy)


CONFIGS = [
    {"method": "adams"},
    {"method": "bdf"},
    {"method": "adams", "want_monodromy": True},
    {"method": "bdf", "want_monodromy": True, "linear_solver": "dense"},
    {"method": "adams", "nonlinear": "fixedpoint"},
    {"method": "adams", "max_step": T / 8, "init_step": 1e-4},
    {"method": "adams", "rtol": 1e-6, "atol": 1e-8},
]


def test_reused_workspace_is_bitwise_a_fresh_one(backlash_engine, tmp_path_factory):
    # references: every configuration on a fresh workspace (a new thread has none)
    refs = []
    for cfg in CONFIGS:
        box = {}
        th = threading.Thread(target=lambda c=cfg, b=box: b.setdefault("r", _run(backlash_engine, **c)))
        th.start()
        th.join()
        refs.append(box["r"])
    assert refs[0].stats["n_events"] > 10
    # now all of them in a row, twice, on this thread's one workspace, with failures between
    for _ in range(2):
        for cfg, ref in zip(CONFIGS, refs):
            _same(_run(backlash_engine, **cfg), ref)
            with pytest.raises(EngineError):
                _run(backlash_engine, max_steps=20, **{k: v for k, v in cfg.items() if k != "max_steps"})


def test_threads_use_their_own_workspaces(backlash_engine):
    ref = _run(backlash_engine, want_monodromy=True)
    out: list = [None] * 4
    errs: list = []

    def work(i):
        try:
            for _ in range(5):
                out[i] = _run(backlash_engine, want_monodromy=True)
        except Exception as exc:  # pragma: no cover - reported below
            errs.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errs
    for r in out:
        _same(r, ref)


def test_ida_workspace_reused(backlash_ida_engine):
    kw = {"rtol": 1e-9, "atol": 1e-11, "method": "ida", "t_out": np.linspace(0, 5 * T, 11)}
    r1 = backlash_ida_engine.run(X0, P_KS, 0.0, 5 * T, **kw)
    backlash_ida_engine.run(X0 + 0.3, P_KS, 0.0, 2 * T, method="ida", rtol=1e-6, atol=1e-8)
    r2 = backlash_ida_engine.run(X0, P_KS, 0.0, 5 * T, **kw)
    _same(r1, r2)


def test_evaluate_matches_the_model(backlash_engine, meissner_engine):
    rng = np.random.default_rng(3)
    t = rng.uniform(0, 10, 7)
    x = rng.normal(0, 2, (7, 2))
    g = backlash_engine.evaluate("sw", t, x, P_KS)
    np.testing.assert_array_equal(g, np.column_stack([x[:, 0] - 1.0, x[:, 0] + 1.0]))
    sigma = np.where(g >= 0, 1.0, -1.0)
    np.testing.assert_array_equal(backlash_engine.evaluate("mode", t, x, P_KS), sigma)
    f = backlash_engine.evaluate("rhs", t, x, P_KS)
    zeta, eps, Om, Fm, Fa, b = P_KS
    dz = np.where(x[:, 0] > b, x[:, 0] - b, np.where(x[:, 0] < -b, x[:, 0] + b, 0.0))
    acc = -2 * zeta * x[:, 1] - (1 + eps * np.cos(Om * t)) * dz + Fm + Fa * Om**2 * np.cos(Om * t)
    np.testing.assert_allclose(f, np.column_stack([x[:, 1], acc]), rtol=1e-15, atol=1e-15)
    J = backlash_engine.evaluate("jac", t, x, P_KS)
    h = 1e-7
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        fd = (backlash_engine.evaluate("rhs", t, x + e, P_KS, sigma) - backlash_engine.evaluate("rhs", t, x - e,
                                                                                                  P_KS, sigma)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, rtol=1e-6, atol=1e-7)
    # schedule part of the mode: cycle index and segment from t (Meissner: P, breaks 0 and d)
    pm = np.array([MEISSNER_P[k] for k in ("w", "a", "P", "d", "c")])
    tm = np.array([0.0, 0.3 * 2.1, 0.5 * 2.1, 2.1 * 3.9])
    mode = meissner_engine.evaluate("mode", tm, np.zeros((4, 2)), pm)
    np.testing.assert_array_equal(mode[:, 1:], [[0, 0], [0, 0], [0, 1], [3, 1]])
    assert np.isnan(backlash_engine.period(np.asarray(P_KS)))  # hand-written test models have no gs_period
