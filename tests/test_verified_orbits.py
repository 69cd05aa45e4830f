"""A periodic orbit is a state that returns after a whole number of forcing periods (issue 24 item 2).

``--periods 0.5`` was solved and reported ``converged``, ``asymptotically_stable``, exit 0, for
a state that does not return after a forcing period (a fixed point of the half-period map), and
``continue --periods 0.5`` returned a "complete" branch of 53 points.  Now ``periods`` must be a
positive whole number for a forced system (exit 2 / ``ParameterError``), and every converged
orbit is verified by one more integration over its period before it is reported.

The verdicts are checked against the hand-written event-located scipy reference of the
benchmark oscillator (``tests/reference.py``): a state that is reported does return, a state
that is refused does not.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks as ks_reference

import gearsym
from gearsym.analysis.continuation import continuation
from gearsym.analysis.continuation._corrector import Continuer
from gearsym.analysis.periodic import _shooting as shooting
from gearsym.analysis.periodic import harmonic_balance
from gearsym.analysis.sweeps import stability_map
from gearsym.cli import main
from gearsym.errors import ConvergenceError, ParameterError

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"
AXES = ["--x", "Omega", "0.8", "0.9", "2", "--y", "Fa", "0.05", "0.06", "2"]


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


def _return_defect(x0, period: float, params: dict | None = None) -> np.ndarray:
    """``|x(t0 + period) - x0|`` by the independent reference (scipy DOP853, event-located)."""
    y, *_ = ks_reference().reference_solution(params, x0, [0.0, period])
    return np.abs(y[-1] - np.asarray(x0, float))


# ------------------------------------------------------------------ whole periods
@pytest.mark.parametrize("args", [
    ["orbit", str(KS), "--periods", "0.5"],
    ["orbit", str(KS), "--periods", "0.5", "--method", "hbm"],
    ["orbit", str(KS), "--periods", "2.5"],
    ["continue", str(KS), "--param", "Omega", "--from", "0.6", "--to", "0.7", "--periods", "0.5", "--no-progress"],
    ["map", str(KS), *AXES, "--periods", "1.5", "--workers", "1"],
], ids=["orbit", "orbit-hbm", "orbit-2.5", "continue", "map"])
def test_fractional_periods_exit_2(args, capsys, tmp_path):
    if args[0] == "map":
        args = [*args, "--out", str(tmp_path / "m")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "--periods" in err and "whole number of forcing periods" in err
    assert not (tmp_path / "m").exists()


def test_fractional_periods_are_refused_by_the_api(ks):
    T = ks.period()
    for method in ("shooting", "hbm"):
        with pytest.raises(ParameterError, match="whole number"):
            ks.periodic_orbit(periods=0.5, method=method)
        with pytest.raises(ParameterError, match="0.5 forcing periods"):
            ks.periodic_orbit(period=0.5 * T, method=method)
    with pytest.raises(ParameterError, match="whole number"):
        continuation(ks, "Omega", 0.6, 0.7, periods=0.5, progress=False)
    with pytest.raises(ParameterError, match="whole number"):
        stability_map(ks, ("Omega", 0.8, 0.9, 2), ("Fa", 0.05, 0.06, 2), periods=1.5, workers=1)


def test_a_whole_number_of_periods_is_an_orbit_that_returns(ks):
    T = ks.period()
    o = ks.periodic_orbit(period=2 * T)  # two forcing periods, given as a period
    assert o.converged and o.periods == 2.0
    assert o.info["verification"]["ok"]
    assert np.max(_return_defect(o.x0, 2 * T)) < 1e-8  # the reference: it returns
    assert np.max(_return_defect(o.x0, T)) < 1e-8  # (the period-one orbit: also after one period)


# ------------------------------------------------------------------ verification of a converged orbit
def test_a_reported_orbit_closes_under_the_reference(ks):
    o = ks.periodic_orbit()
    v = o.info["verification"]
    assert v["ok"] and v["relative"] <= 1.0
    ref = np.max(_return_defect(o.x0, o.period))
    assert ref < 1e-8 and v["residual"] < 1e-8


def test_a_converged_state_that_does_not_return_is_not_reported(ks, monkeypatch):
    """A Newton iteration that reports convergence at a state 1e-4 off the orbit (a solver that
    lies): the verification integration finds that the state does not return."""
    real = shooting.ShootingProblem.solve

    def lying(self, X):
        run = real(self, X)
        return dataclasses.replace(run, X=run.X + np.array([1e-4, 0.0])) if run.converged else run

    monkeypatch.setattr(shooting.ShootingProblem, "solve", lying)
    with pytest.raises(ConvergenceError, match="does not return"):
        ks.periodic_orbit()
    o = ks.periodic_orbit(raise_on_failure=False)
    assert not o.converged and not o.info["verification"]["ok"]
    assert np.max(_return_defect(o.x0, o.period)) > 1e-5  # the reference agrees: no orbit


@pytest.mark.parametrize("segments", [1, 3])
def test_the_verification_integration_runs_in_the_solves_c_call(ks, monkeypatch, segments):
    """The verification integration of a shooting orbit (issue 24) is made in the C call that
    solved it (issue 26: no second driver call per solve), and it is the integration
    ``segment_closure`` makes through ``System.flow``: the same closure; the orbit closes under
    the scipy reference."""
    from gearsym.analysis.periodic._verification import segment_closure

    x0 = ks.periodic_orbit().x0
    calls: list[str] = []
    lib = ks.engine._lib

    class Spy:
        def __getattr__(self, name):
            fn = getattr(lib, name)
            if not name.startswith(("gs_simulate", "gs_shoot", "gs_correct")):
                return fn

            def spied(*args):
                calls.append(name)
                return fn(*args)

            return spied

    monkeypatch.setattr(ks.engine, "_lib", Spy())
    o = ks.periodic_orbit(x0=x0, transient=0, segments=segments)
    monkeypatch.undo()
    assert o.converged and calls.count("gs_shoot_ws") == 1 and calls[-1] == "gs_shoot_ws"
    v = o.info["verification"]
    times = o.t0 + o.period * np.arange(segments + 1) / segments
    c = segment_closure(ks, o.segment_states, times, ks.param_vector(), rtol=o.info["rtol"], atol=o.info["atol"],
                        tol=o.info["tol"], amplification=o.max_multiplier,
                        amplitude=np.asarray(o.info["state_scales"]))
    assert v["ok"] and c.ok and v["state"] == c.state
    assert v["residual"] == pytest.approx(c.residual, rel=1e-9, abs=0.0)
    assert v["relative"] == pytest.approx(c.relative, rel=1e-9, abs=0.0)
    assert np.max(_return_defect(o.x0, o.period)) < 1e-8


def test_a_failed_verification_run_is_reported_as_a_failed_verification():
    """A verification run that failed (its error, made in the solve's C call) is a failed
    verification naming the error, as a failed ``System.flow`` is."""
    from gearsym.analysis.periodic._verification import runs_closure

    c = runs_closure(np.zeros((1, 2)), None, "too much work at t=1.5", np.ones(2), rtol=1e-9, atol=1e-12, tol=1e-8)
    assert not c.ok and c.relative == math.inf and c.error == "too much work at t=1.5"
    assert c.message() == "the verification integration over one period failed: too much work at t=1.5"
    ok = runs_closure(np.array([[1.0, 2.0]]), np.array([[1.0 + 1e-12, 2.0]]), "", np.array([1.0, 2.0]), rtol=1e-9,
                      atol=1e-12, tol=1e-8)
    assert ok.ok and ok.residual == pytest.approx(1e-12, rel=1e-3) and ok.state == 0


def test_fixed_harmonics_that_do_not_close_are_no_orbit(ks):
    """Harmonic balance with one harmonic at Omega = 0.5: the balance converges, but one period
    integrated from its x(t0) misses it by about half the orbit's size (was: converged, exit 0).
    With four harmonics the series is an orbit (the defect is small)."""
    p = {"Omega": 0.5}
    with pytest.raises(ConvergenceError, match="does not return"):
        harmonic_balance(ks, harmonics=1, params=p, initial_guess="simulation")
    bad = harmonic_balance(ks, harmonics=1, params=p, initial_guess="simulation", raise_on_failure=False)
    assert not bad.converged and not bad.info["verification"]["ok"]
    T = 2 * math.pi / 0.5
    shot = ks.periodic_orbit(params=p)
    ptp = np.ptp(ks_reference().reference_solution(p, shot.x0, np.linspace(0, T, 513))[0], axis=0)
    assert np.max(_return_defect(bad.x0, T, p) / ptp) > 0.1  # the reference: it does not return
    good = harmonic_balance(ks, harmonics=4, params=p, initial_guess="simulation")
    assert good.converged and good.info["verification"]["ok"]
    assert np.max(_return_defect(good.x0, T, p) / ptp) < 0.1


# ------------------------------------------------------------------ continuation
def test_branch_points_are_verified(ks):
    br = continuation(ks, "Omega", 0.6, 0.7, progress=False)
    assert br.complete
    c = np.array([p.closure for p in br.points])
    assert np.all(np.isfinite(c)) and np.all(c <= 1.0)
    for p in br.points[:: max(1, len(br.points) // 3)]:
        assert np.max(_return_defect(p.x0, p.period, {"Omega": p.value})) < 1e-7


def test_a_corrector_that_returns_a_state_that_does_not_return_stops_the_branch(ks, monkeypatch):
    """The corrector in C returns a point 1e-4 off the orbit it integrated beyond Omega = 0.65:
    the point's verification (the plain run of its samples) rejects it and the branch ends
    incomplete instead of reporting it."""
    real = Continuer.correct

    def lying(self, z, row, target, Flam=None, t_ref=None):
        out = real(self, z, row, target, Flam, t_ref)
        if out[0][-1] > 0.65:
            zz = out[0].copy()
            zz[0] += 1e-4
            return zz, out[1], out[2]
        return out

    monkeypatch.setattr(Continuer, "correct", lying)
    br = continuation(ks, "Omega", 0.6, 0.7, progress=False)
    assert not br.complete and "does not return" in br.stop_reason
    assert br.values.max() <= 0.65 + 1e-12
