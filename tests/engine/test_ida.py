"""Implicit (residual-form) model with IDA against CVODE."""

from __future__ import annotations

import numpy as np
import pytest

from gearsym.engine.errors import EngineInputError

P = [0.05, 0.2, 0.8, 0.1, 1.0, 1.0]  # double-sided regular impacts


def test_ida_residual_model_matches_cvode(backlash_engine, backlash_ida_engine):
    assert backlash_ida_engine.implicit and not backlash_engine.implicit
    T = 2 * np.pi / P[2]
    t_out = np.linspace(0, 20 * T, 401)
    cv = backlash_engine.run([1.1, 0.0], P, 0.0, 20 * T, t_out, method="bdf", rtol=1e-10, atol=1e-12)
    ida = backlash_ida_engine.run([1.1, 0.0], P, 0.0, 20 * T, t_out, method="ida", rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(ida.y - cv.y)) < 1e-6
    assert len(ida.events) == len(cv.events) > 10
    np.testing.assert_allclose(ida.events.t, cv.events.t, atol=1e-6)
    np.testing.assert_array_equal(ida.events.surface, cv.events.surface)
    np.testing.assert_array_equal(ida.events.direction, cv.events.direction)
    np.testing.assert_allclose(ida.events.speed, cv.events.speed, atol=1e-5)
    np.testing.assert_array_equal(ida.sigma_final, cv.sigma_final)
    assert ida.stats["n_steps"] > 0 and ida.stats["n_jac"] > 0


def test_explicit_model_through_ida(backlash_engine):
    """An explicit model may also be run with IDA (residual xdot - f)."""
    T = 2 * np.pi / P[2]
    t_out = np.linspace(0, 10 * T, 101)
    cv = backlash_engine.run([1.1, 0.0], P, 0.0, 10 * T, t_out, rtol=1e-10, atol=1e-12)
    ida = backlash_engine.run([1.1, 0.0], P, 0.0, 10 * T, t_out, method="ida", rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(ida.y - cv.y)) < 1e-6
    assert len(ida.events) == len(cv.events)


def test_implicit_model_rejects_cvode(backlash_ida_engine):
    with pytest.raises(EngineInputError, match="implicit"):
        backlash_ida_engine.run([1.1, 0.0], P, 0.0, 1.0, method="bdf")
