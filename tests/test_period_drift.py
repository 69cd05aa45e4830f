"""The period rule does not call a slowly converging transient a cycle.

Found by probing: ``gearsym sweep kahraman_singh --set Fa=0.4 --param Omega --from 0.6 --to 0.61
--n 3 --transient 400`` reported period 2 at Omega = 0.605, where the period-1 orbit is stable
(multiplier -0.9974; period 2 appears at 0.6056..0.61).  Its Poincare points still alternate
with an amplitude decaying by 0.9974 a period: consecutive double periods agree to 1e-4 of the
range, but the points drift by more over the compared half.  Now such a response has no period
yet (0, unclassified), and a long enough transient gives period 1.
"""

from __future__ import annotations

import numpy as np
import pytest

import gearsym
from gearsym.analysis.sweeps._attractor_id import PERIODIC, UNCLASSIFIED, cycle_period


def test_a_decaying_flip_is_no_cycle_while_it_drifts():
    n = np.arange(129)
    settled = np.c_[0.3 + 1e-6 * (-1.0) ** n, np.zeros(len(n))]   # a period-1 point with noise below tol
    flip = np.c_[0.3 + 0.01 * (-0.9974) ** n, np.zeros(len(n))]   # still converging at -0.9974 a period
    two = np.c_[0.3 + 0.01 * (-1.0) ** n, np.zeros(len(n))]       # a true period-2 cycle
    scale = np.array([1.0, 1.0])
    assert cycle_period(settled, scale, 8, 1e-4) == 1
    assert cycle_period(two, scale, 8, 1e-4) == 2
    # double periods agree to 0.01 (1 - 0.9974^2) 0.9974^n < 1e-4 over the second half, but the points
    # move by about 32 times that between the start and the end of it: no period
    assert np.max(np.abs(flip[66:, 0] - flip[64:-2, 0])) < 1e-4
    assert abs(flip[64, 0] - flip[128, 0]) > 1e-4
    assert cycle_period(flip, scale, 8, 1e-4) == 0


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene("kahraman_singh").compile()


def test_a_sweep_near_a_period_doubling_reports_no_period_before_it_settles(ks):
    kw = {"params": {"Fa": 0.4}, "lyapunov": False, "directions": ("forward",), "workers": 1, "progress": False}
    short = gearsym.bifurcation_diagram(ks, "Omega", 0.605, 0.605, 1, transient=400, **kw)
    assert int(short["period"].values.ravel()[0]) == 0 and int(short["kind"].values.ravel()[0]) == UNCLASSIFIED
    long = gearsym.bifurcation_diagram(ks, "Omega", 0.605, 0.605, 1, transient=6000, **kw)
    assert int(long["period"].values.ravel()[0]) == 1 and int(long["kind"].values.ravel()[0]) == PERIODIC
