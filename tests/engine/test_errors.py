"""Error paths: every failure is a Python exception with a message; the
process survives and the engine stays usable."""

from __future__ import annotations

import numpy as np
import pytest

from gearsym.engine.errors import (
    EngineError,
    EngineInputError,
    EventStormError,
    MaxEventsError,
    NonFiniteError,
    TooMuchWorkError,
)
from gearsym.errors import GearsymError, ParameterError, SimulationError

P = [0.05, 0.2, 0.8, 0.1, 1.0, 1.0]


def test_hierarchy():
    for cls in (EngineInputError, EventStormError, MaxEventsError, NonFiniteError, TooMuchWorkError):
        assert issubclass(cls, EngineError)
        assert issubclass(cls, SimulationError)
        assert issubclass(cls, GearsymError)
    assert issubclass(EngineInputError, ParameterError)


def test_nan_parameter(backlash_engine):
    p = list(P)
    p[3] = np.nan
    with pytest.raises(EngineInputError, match=r"parameter p\[3\] is not finite") as ei:
        backlash_engine.run([1.1, 0.0], p, 0.0, 10.0)
    assert ei.value.status == -6


def test_nan_initial_state(backlash_engine):
    with pytest.raises(EngineInputError, match=r"x0\[1\]"):
        backlash_engine.run([1.1, np.inf], P, 0.0, 10.0)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(t0=1.0, t_end=1.0), "time span"),
        (dict(t_out=[0.5, 0.2]), "ascending"),
        (dict(t_out=[20.0]), "outside"),
        (dict(rtol=0.0), "tolerances"),
        (dict(method="rk4"), "unknown method"),
    ],
)
def test_bad_arguments(backlash_engine, kw, match):
    args = dict(x0=[1.1, 0.0], p=P, t0=0.0, t_end=10.0)
    args.update(kw)
    with pytest.raises(EngineInputError, match=match):
        backlash_engine.run(**args)


def test_too_much_work(backlash_engine):
    with pytest.raises(TooMuchWorkError, match="max_steps=20") as ei:
        backlash_engine.run([1.1, 0.0], P, 0.0, 100.0, max_steps=20)
    assert 0.0 < ei.value.t_reached < 100.0
    # the budget is total, across events and re-initialisations
    r = backlash_engine.run([1.1, 0.0], P, 0.0, 100.0)
    with pytest.raises(TooMuchWorkError):
        backlash_engine.run([1.1, 0.0], P, 0.0, 100.0, max_steps=r.stats["n_steps"] // 2)
    backlash_engine.run([1.1, 0.0], P, 0.0, 100.0, max_steps=r.stats["n_steps"] + 10)


@pytest.mark.parametrize("method", ["bdf", "adams", "ida"])
def test_nonfinite_rhs(nan_engine, method):
    with pytest.raises(NonFiniteError, match=r"non-finite value in the right-hand side.*t=1\.") as ei:
        nan_engine.run([1.0], [1.0], 0.0, 3.0, [0.5, 2.0], method=method)
    assert ei.value.t_reached == pytest.approx(1.0, abs=1e-3)
    # before the bad time everything is fine
    r = nan_engine.run([1.0], [1.0], 0.0, 0.9, [0.5], method=method, rtol=1e-10, atol=1e-12)
    assert r.y[0, 0] == pytest.approx(np.exp(-0.5), rel=1e-8)


@pytest.mark.parametrize("method", ["bdf", "adams", "ida"])
def test_event_storm(chatter_engine, method):
    with pytest.raises(EventStormError, match=r"surface 0 at t=1\.") as ei:
        chatter_engine.run([1.0], [1.0], 0.0, 3.0, method=method)
    assert "event storm" in str(ei.value)


def test_max_events(backlash_engine):
    with pytest.raises(MaxEventsError, match="max_events=5"):
        backlash_engine.run([1.1, 0.0], P, 0.0, 200.0, max_events=5)


def test_engine_usable_after_errors(backlash_engine, nan_engine, chatter_engine):
    for _ in range(3):
        with pytest.raises(EngineError):
            nan_engine.run([1.0], [1.0], 0.0, 3.0)
        with pytest.raises(EngineError):
            chatter_engine.run([1.0], [1.0], 0.0, 3.0)
    r = backlash_engine.run([1.1, 0.0], P, 0.0, 10.0, [10.0])
    assert np.all(np.isfinite(r.y))


@pytest.mark.parametrize("sigma0", [None, [1.0], [-1.0]])
def test_event_storm_starting_on_the_surface(chatter_engine, sigma0):
    """x0 exactly on a surface that attracts from both sides: the storm is
    detected at t0 instead of silently integrating on the wrong side."""
    with pytest.raises(EventStormError, match="t=0"):
        chatter_engine.run([0.0], [1.0], 0.0, 3.0, sigma0=sigma0)
