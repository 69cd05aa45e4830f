"""Maps tell the truth at every point: an unstable orbit is never shown as the response (issue 24 item 3).

Before: ``map --quantity rattle_state`` showed the rattle state of whatever orbit Newton
converged to, stable or not (rattle 1 for an orbit with ``|mu| = 1.47`` where the attractor was
another orbit), and unstable points were not marked.  Now an unstable orbit goes to the
``unstable_*`` variables, the stable response is searched for, and a point without one is
marked (``response = 0``) and hatched.

The benchmark oscillator past its period doubling (Fa = 0.38..0.42, Omega 0.58..0.64: the
period-one orbit is unstable, the attractor is a period-two orbit, checked here by brute force
with the hand-written scipy reference), and in its coexistence region (Omega = 0.868: a stable
orbit in contact, a stable impacting one and the unstable one between them).  The linear
Meissner equation (exact path): one orbit, unstable inside the tongues.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks as ks_reference

import gearsym
from gearsym.analysis.sweeps import _maps as maps
from gearsym.analysis.sweeps import save_map, stability_map
from gearsym.cli import main

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"
MEISSNER = ROOT / "scenes" / "meissner.toml"
PD_X, PD_Y = ("Omega", 0.58, 0.64, 4), ("Fa", 0.38, 0.42, 2)


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def pd_map(ks):
    return stability_map(ks, PD_X, PD_Y, quantity="peak_to_peak", method="shooting", workers=1)


def test_past_the_period_doubling_no_unstable_orbit_is_the_response(pd_map):
    ds = pd_map
    mm = ds["max_multiplier"].values
    unstable = ds["stability"].values == 2
    assert unstable.any() and (~unstable).any()
    assert np.all(mm[unstable] > 1) and np.all(mm[~unstable] < 1)
    # no response where the only period-one orbit is unstable: its rattle state and amplitude are not shown
    assert np.all(ds["rattle_state"].values[unstable] == -1)
    assert np.all(np.isnan(ds["peak_to_peak"].values[unstable]))
    resp = ds["response"].values
    assert np.all(resp[unstable] == 0) and np.all(resp[~unstable] == 1)
    assert np.all(np.isfinite(ds["peak_to_peak"].values[~unstable]))
    # the unstable orbit is recorded apart
    assert np.array_equal(ds["unstable_max_multiplier"].values[unstable], mm[unstable])
    assert np.all(ds["unstable_rattle_state"].values[unstable] >= 0)
    assert np.all(np.isnan(ds["unstable_max_multiplier"].values[~unstable]))
    assert ds.attrs["n_no_stable_response"] == int(unstable.sum()) and ds.attrs["n_failed"] == 0


def test_the_unmarked_point_has_no_period_one_attractor(pd_map):
    """Brute force with the scipy reference at the last point (Omega 0.64, Fa 0.42): the
    Poincare sequence from the scene's initial state settles on a period-two cycle."""
    assert pd_map["response"].values[-1, -1] == 0
    p = {"Omega": 0.64, "Fa": 0.42}
    T = 2 * math.pi / 0.64
    y, *_ = ks_reference().reference_solution(p, [1.1, 0.0], T * np.arange(301), rtol=1e-10, atol=1e-12)
    P = y[-20:]
    assert np.max(np.abs(P[2:] - P[:-2])) < 1e-6  # period two
    assert np.max(np.abs(P[1:] - P[:-1])) > 1e-2  # not period one


def test_an_unstable_start_finds_the_stable_response(ks):
    """Omega = 0.868, the shooting started on the unstable orbit between the two stable ones
    (|mu| = 1.57, contact loss: what the old map showed): the response is a stable orbit, the
    unstable one is recorded apart.  The response is one of the two stable orbits at that
    Omega, found here by integrating 100 periods from either side of the unstable orbit."""
    br = gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)  # over the fold at 0.894, back
    p = next(q for q in br.points if not q.stable and 0.866 < q.value < 0.870)
    Om = float(p.value)
    ds = stability_map(ks, ("Omega", Om, Om, 1), ("Fa", 0.05, 0.05, 1), quantity="rattle_state", method="shooting",
                       workers=1, x0=p.x0)
    assert ds["response"].values[0, 0] == 1 and ds["response_search"].values[0, 0] == 2
    assert ds["stability"].values[0, 0] == 0 and ds["max_multiplier"].values[0, 0] < 1
    assert ds["unstable_max_multiplier"].values[0, 0] == pytest.approx(np.max(np.abs(p.multipliers)), rel=1e-6)
    assert ds["unstable_rattle_state"].values[0, 0] == p.rattle_state == 1
    T = 2 * math.pi / Om
    stable = []
    for sign in (+1, -1):
        y, *_ = ks_reference().reference_solution({"Omega": Om}, p.x0 + sign * np.array([1e-3, 0.0]),
                                                  [0.0, 100 * T], rtol=1e-10, atol=1e-12)
        o = ks.periodic_orbit(params={"Omega": Om}, x0=y[-1], transient=0)
        stable.append((o.rattle_state, o.max_multiplier))
    assert {s[0] for s in stable} == {0, 1}  # both stable orbits: in contact, and impacting
    assert any(ds["rattle_state"].values[0, 0] == r and ds["max_multiplier"].values[0, 0] == pytest.approx(m, rel=1e-6)
               for r, m in stable)


def test_exact_path_marks_the_tongues_as_no_response():
    ds = stability_map(gearsym.load_scene(MEISSNER), ("T", 1.0, 9.0, 9), ("a", 0.05, 0.75, 5), method="exact")
    unstable = ds["stable"].values == 0
    assert unstable.any() and (~unstable).any()
    assert np.array_equal(ds["response"].values, np.where(unstable, 0, 1))
    assert np.array_equal(np.isfinite(ds["unstable_max_multiplier"].values), unstable)


def test_the_figure_hatches_the_points_without_a_response(pd_map, tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    kept = []
    monkeypatch.setattr(plt, "close", lambda fig=None: kept.append(fig))
    save_map(pd_map, tmp_path, quantity="rattle_state")
    ax = kept[-1].axes[0]
    hatched = [c for c in ax.collections if c.get_hatch() == "//"]
    assert len(hatched) == 1
    assert int(np.ma.count(hatched[0].get_array())) == int((pd_map["response"].values == 0).sum())
    assert "no stable periodic response" in [t.get_text() for t in ax.get_legend().get_texts()]
    mesh = ax.collections[0]  # the colour of the response: none at the hatched points
    assert int(np.ma.count(mesh.get_array())) == int((pd_map["response"].values == 1).sum())


def test_cli_map_reports_the_points_without_a_response(tmp_path, capsys):
    rc = main(["map", str(KS), "--x", *map(str, PD_X), "--y", *map(str, PD_Y), "--quantity", "rattle_state",
               "--method", "shooting", "--workers", "1", "--json", "--out", str(tmp_path / "m")])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["n_no_stable_response"] > 0 and info["n_failed"] == 0
    assert info["min"] >= 0  # the rattle states shown are those of responses (no -1 of a missing one)
    assert maps.RESPONSE[0].startswith("no stable periodic response")
