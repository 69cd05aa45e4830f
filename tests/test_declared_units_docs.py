"""Parameter values cross the public API in the model's declared units, and the docstrings say so
(issue 24, item 7: about 15 docstrings said "SI" where the code takes declared units, e.g. the
``start`` / ``stop`` / ``params`` of ``continuation``: a user who followed them was off by the
unit factor, 1e6 for um)."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import numpy as np
import pytest
from numpydoc.docscrape import NumpyDocString

import gearsym
from gearsym.analysis import continuation, periodic
from gearsym.analysis import continuation as branch
from gearsym.analysis import continuation as points
from gearsym.analysis import linear as modes
from gearsym.analysis import periodic as floquet
from gearsym.analysis import periodic as hbm
from gearsym.analysis import periodic as orbit
from gearsym.analysis import periodic as problems
from gearsym.analysis import periodic as shooting
from gearsym.facade import System
from gearsym.results import Trajectory

ROOT = Path(__file__).resolve().parents[1]
SPUR_SCENE = ROOT / "scenes" / "spur_pair_torsional.toml"
SPUR_MODEL = (ROOT / "models" / "spur_pair_torsional.toml").read_text()

#: (object, section, entries): the documented parameter values of the public API
DOCUMENTED = [
    (System.simulate, "Parameters", ("params",)),
    (System.periodic_orbit, "Parameters", ("params",)),
    (System.state_scales, "Parameters", ("params",)),
    (System.time_scale, "Parameters", ("params",)),
    (continuation.continuation, "Parameters", ("param", "start", "params")),
    (periodic.periodic_orbit, "Parameters", ("params",)),
    (shooting.shoot, "Parameters", ("params",)),
    (hbm.harmonic_balance, "Parameters", ("params",)),
    (hbm.HarmonicBalance, "Parameters", ("params",)),
    (modes.static_equilibrium, "Parameters", ("params",)),
    (modes.modal_analysis, "Parameters", ("params",)),
    (modes.ModalAnalysis, "Attributes", ("params",)),
    (floquet.exact_multipliers, "Parameters", ("params_list",)),
    (floquet.PiecewiseLTV.from_system, "Parameters", ("params",)),
    (problems.ShootingResidual, "Parameters", ("params",)),
    (orbit.PeriodicOrbit, "Attributes", ("params",)),
    (branch.Branch, "Attributes", ("stop_value",)),
    (branch.Branch.params_at, "Parameters", ("value",)),
    (points.BranchPoint, "Attributes", ("value",)),
    (points.ContinuationSetup, "Attributes", ("params",)),
    (Trajectory, "Attributes", ("params",)),
]


@pytest.mark.parametrize("obj,section,names", DOCUMENTED, ids=[d[0].__qualname__ for d in DOCUMENTED])
def test_docstrings_do_not_claim_si_for_declared_values(obj, section, names):
    doc = NumpyDocString(inspect.getdoc(obj))
    entries = {n.strip(): " ".join(e.desc) for e in doc[section] for n in e.name.split(":")[0].split(",")}
    for name in names:
        assert name in entries, f"{obj.__qualname__}: no {section} entry '{name}' (have {sorted(entries)})"
        text = entries[name].replace("bound parameters: SI", "")  # computed from the others, SI by design
        assert not re.search(r"\bSI\b", text), f"{obj.__qualname__}.{name}: {entries[name]!r}"


# ------------------------------------------------------- the documented unit gives the right answer
@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The spur pair as shipped (b_m in um) and the same model with b_m declared in m."""
    d = tmp_path_factory.mktemp("si")
    text = SPUR_MODEL.replace('b_m   = { value = 50.0,    unit = "um",', 'b_m   = { value = 5.0e-5,  unit = "m", ')
    assert text != SPUR_MODEL
    (d / "spur_si.toml").write_text(text)
    (d / "s.toml").write_text(SPUR_SCENE.read_text().replace('"../models/spur_pair_torsional.toml"', '"spur_si.toml"')
                              .replace('name = "spur_pair_torsional"', 'name = "spur_si"'))
    return gearsym.load_scene(SPUR_SCENE).compile(), gearsym.load_scene(d / "s.toml").compile()


def test_params_in_the_declared_unit(pair):
    um, si = pair
    assert um.units.unit("b_m") == "um" and si.units.unit("b_m") == "m"
    a = um.simulate(periods=3, params={"b_m": 45.0})
    b = si.simulate(periods=3, params={"b_m": 45e-6})
    assert a.params["b_m"] == 45.0 and b.params["b_m"] == 45e-6  # reported in the declared unit
    for j in range(b.y.shape[1]):
        np.testing.assert_allclose(a.y[:, j], b.y[:, j], rtol=1e-5, atol=1e-5 * np.max(np.abs(b.y[:, j])))  # a unit slip is 1e6
    oa = um.periodic_orbit(params={"b_m": 45.0})
    ob = si.periodic_orbit(params={"b_m": 45e-6})
    assert oa.params["b_m"] == 45.0
    for j in range(len(ob.x0)):
        assert oa.x0[j] == pytest.approx(ob.x0[j], rel=1e-8, abs=1e-8 * np.max(np.abs(ob.x0)))


def test_continuation_range_in_the_declared_unit(pair):
    um, si = pair
    ba = continuation.continuation(um, "b_m", 45.0, 46.0, max_points=4, progress=False)
    bb = continuation.continuation(si, "b_m", 45e-6, 46e-6, max_points=4, progress=False)
    va = np.array([p.value for p in ba.points])
    vb = np.array([p.value for p in bb.points])
    assert va[0] == 45.0 and vb[0] == 45e-6 and len(va) == len(vb) == 4
    np.testing.assert_allclose(va * 1e-6, vb, rtol=1e-7)
    xa, xb = np.array([p.x0 for p in ba.points]), np.array([p.x0 for p in bb.points])
    for j in range(xb.shape[1]):
        np.testing.assert_allclose(xa[:, j], xb[:, j], rtol=1e-6, atol=1e-8 * np.max(np.abs(xb[:, j])))
