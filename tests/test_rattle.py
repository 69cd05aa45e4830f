"""The rattle-state classifier and the peak-to-peak value (gearsym.analysis.periodic._rattle).

* synthetic signals with a known answer (sinusoids against fixed and time-varying
  flanks, both drive-side conventions, transients excluded by the steady window);
* the benchmark oscillator (scenes/kahraman_singh.toml) in its three known regimes:
  Omega = 0.6 no impact -> 0, Omega = 0.9 single-sided -> 1, Fa = 0.6 at Omega = 0.8
  double-sided -> 2, classified from the engine's events and checked against the
  independent event-located DOP853 reference of tests/reference.py classified from
  its samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks

import gearsym
from gearsym.analysis.periodic._rattle import (
    BILATERAL,
    NO_RATTLE,
    UNILATERAL,
    peak_to_peak,
    rattle_state,
    rattle_summary,
    steady_window,
)

ROOT = Path(__file__).resolve().parents[1]
KS = ROOT / "scenes" / "kahraman_singh.toml"


# ------------------------------------------------------------- synthetic signals

T = 2 * np.pi
t_syn = np.linspace(0.0, 20 * T, 20 * 400 + 1)


@pytest.mark.parametrize("offset, amp, expected", [
    (2.0, 0.5, NO_RATTLE),      # 1.5 .. 2.5: always above the drive flank x = 1
    (1.2, 0.5, UNILATERAL),     # 0.7 .. 1.7: leaves contact, never below -1
    (0.5, 2.0, BILATERAL),      # -1.5 .. 2.5: reaches the back flank
    (-2.0, 0.5, BILATERAL),     # resting on the back flank
    (0.0, 0.5, UNILATERAL),     # floating in the backlash, no contact at all
])
def test_synthetic_positive_drive(offset, amp, expected):
    x = offset + amp * np.sin(t_syn)
    assert rattle_state((t_syn, x), -1.0, 1.0, drive_side="positive") == expected
    # the mirrored signal with the mirrored convention gives the same state
    assert rattle_state((t_syn, -x), -1.0, 1.0, drive_side="negative") == expected


def test_synthetic_time_varying_flanks():
    # flanks -+ b/r(t) with r(t) = 1 + 0.3*cos(t/8) (as in the NFG model)
    def r(t):
        return 1.0 + 0.3 * np.cos(t / 8)

    lower = lambda t: -0.5 / r(t)  # noqa: E731
    upper = lambda t: 0.5 / r(t)   # noqa: E731
    # drive side negative: follows the moving drive flank 0.01 inside contact -> 0
    x0 = lower(t_syn) - 0.01
    assert rattle_state((t_syn, x0), lower, upper, drive_side="negative") == NO_RATTLE
    # a fixed position x = -0.45 is in contact only while -0.5/r(t) > -0.45 (r > 1.11)
    x1 = np.full_like(t_syn, -0.45)
    s = rattle_summary((t_syn, x1), lower, upper, drive_side="negative", steady_fraction=1.0)
    assert s.state == UNILATERAL
    frac_out = s.n_drive / t_syn.size
    frac_exact = np.mean(r(t_syn) <= 0.5 / 0.45)
    assert frac_out == pytest.approx(frac_exact, abs=1e-12)
    # the same flanks given as arrays
    assert rattle_state((t_syn, x1), lower(t_syn), upper(t_syn), drive_side="negative") == UNILATERAL


def test_steady_window_excludes_transient():
    # a decaying transient that hits the back flank early, then steady drive contact
    x = 2.0 + 0.3 * np.sin(t_syn) - 5.0 * np.exp(-t_syn / 3.0)
    assert rattle_state((t_syn, x), -1.0, 1.0, steady_fraction=1.0) == BILATERAL
    assert rattle_state((t_syn, x), -1.0, 1.0, steady_fraction=0.5) == NO_RATTLE
    assert rattle_state((t_syn, x), -1.0, 1.0, t_start=10 * T) == NO_RATTLE
    # ppv of the steady part: 2*0.3 (the transient has decayed by e^-20)
    assert peak_to_peak((t_syn, x), steady_fraction=0.5) == pytest.approx(0.6, abs=1e-8)
    assert peak_to_peak((t_syn, x), steady_fraction=1.0) == pytest.approx(
        np.max(x) - np.min(x), rel=1e-15)


def test_steady_window_whole_periods():
    t = np.linspace(0.0, 10.0, 1001)
    assert steady_window(t, 0.5) == (5.0, 10.0)
    ts, te = steady_window(t, 0.5, period=1.5)     # 5.0/1.5 -> 3 whole periods
    assert te == 10.0 and ts == pytest.approx(10.0 - 4.5)
    assert steady_window(t, 0.1, period=1.5) == (9.0, 10.0)   # shorter than a period: as asked
    with pytest.raises(ValueError):
        steady_window(t, 0.0)
    with pytest.raises(ValueError):
        steady_window(t, 0.5, t_start=11.0)


def test_peak_to_peak_arrays():
    x = 3.0 + 2.0 * np.sin(np.linspace(0, 2 * np.pi, 401))
    assert peak_to_peak(x, steady_fraction=1.0) == pytest.approx(4.0, abs=1e-12)


def test_bad_input():
    with pytest.raises(ValueError, match="lower"):
        rattle_state((t_syn, np.sin(t_syn)))
    with pytest.raises(ValueError, match="drive_side"):
        rattle_state((t_syn, np.sin(t_syn)), -1, 1, drive_side="left")
    with pytest.raises(ValueError, match="lower must not exceed upper"):
        rattle_state((t_syn, np.sin(t_syn)), 1, -1)


# ------------------------------------------------------ benchmark oscillator regimes

REGIMES = [
    ({"Omega": 0.6}, NO_RATTLE),
    ({"Omega": 0.9}, UNILATERAL),
    ({"Omega": 0.8, "Fa": 0.6}, BILATERAL),
]
PERIODS = 100


@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(KS).compile()


@pytest.mark.parametrize("params, expected", REGIMES)
def test_kahraman_singh_regimes(ks_system, params, expected):
    traj = ks_system.simulate(periods=PERIODS, x0=[1.1, 0.0], rtol=1e-10, atol=1e-12, params=params)
    s = rattle_summary(traj, system=ks_system, steady_fraction=0.5)
    assert s.method == "events"
    assert s.state == expected
    if expected == NO_RATTLE:
        assert s.n_drive == s.n_back == 0 and s.start_mode == "drive"
    if expected == UNILATERAL:
        assert s.n_drive > 0 and s.n_back == 0
    if expected == BILATERAL:
        assert s.n_back > 0
    # sample-based on the same trajectory (x against the flanks -b, +b; b = 1)
    assert rattle_state(traj, -1.0, 1.0, state="x", drive_side="positive") == expected
    # independent reference: event-located DOP853 on the hand-written oscillator
    ref = ks()
    y, ev_t, ev_s, _ev_d = ref.reference_solution(params, [1.1, 0.0], traj.t, rtol=1e-10, atol=1e-12)
    assert rattle_state((traj.t, y[:, 0]), -1.0, 1.0, drive_side="positive") == expected
    ts = s.t_start
    n_back_ref = sum(1 for tt, ss in zip(ev_t, ev_s) if tt >= ts and ss == "mesh.back")
    n_drive_ref = sum(1 for tt, ss in zip(ev_t, ev_s) if tt >= ts and ss == "mesh.drive")
    assert (n_back_ref > 0) == (s.n_back > 0)
    assert (n_drive_ref > 0) == (s.n_drive > 0)
    if expected != BILATERAL:  # periodic regimes: same peak-to-peak value as the reference
        ppv_ref = peak_to_peak((traj.t, y[:, 0]), t_start=ts)
        assert peak_to_peak(traj, "x", t_start=ts) == pytest.approx(ppv_ref, rel=1e-6, abs=1e-9)


def test_trajectory_needs_system_or_bounds(ks_system):
    traj = ks_system.simulate(periods=4)
    with pytest.raises(ValueError, match="system="):
        rattle_state(traj)
    with pytest.raises(ValueError, match="no backlash element"):
        rattle_state(traj, system=ks_system, element="gear")
