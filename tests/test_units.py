"""One unit convention at every public entry point (issue 14): on ``spur_pair_torsional``, whose
half backlash ``b_m`` is declared in um, the value ``60`` means 60 um everywhere -- in
``load_scene``, ``System.simulate/periodic_orbit(params=...)``, ``System.params`` and the
``params`` of results, ``continuation`` (range and branch values), ``stability_map`` (grid) and
the command line (``--set``, ``--from``, ``--to``) -- and the same value gives the same numbers.

Before, ``simulate(params={"b_m": 60})`` meant 60 m (the model's switching surface
``x - b_m`` then sits at 60 m instead of 6e-5 m), while ``load_scene(b_m=60)`` meant 60 um.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import gearsym
from gearsym.cli import main

B = 60.0          # um, the declared unit of b_m
B_SI = 60.0e-6    # m


@pytest.fixture(scope="module")
def systems():
    base = gearsym.load_scene("spur_pair_torsional").compile()
    at_b = gearsym.load_scene("spur_pair_torsional", b_m=B).compile()
    return base, at_b


def test_declared_values_read_back_and_reach_the_model_in_si(systems):
    base, at_b = systems
    assert base.params["b_m"] == 50.0 and at_b.params["b_m"] == B      # declared, exactly
    assert base.units.unit("b_m") == "um"
    drive = base.surface_names.index("mesh.drive")
    # the drive-side surface g = x - b_m vanishes at x = 60e-6 m: independent of gearsym's conversion
    for g in (base.switching(0.0, [B_SI, 0.0], params={"b_m": B}), at_b.switching(0.0, [B_SI, 0.0])):
        assert abs(g[drive]) < 1e-20
    assert np.array_equal(base.param_vector({"b_m": B}), at_b.param_vector())


def test_load_scene_simulate_orbit_continuation_map_and_cli_agree(systems, capsys):
    base, at_b = systems
    tr_a = at_b.simulate(periods=5)
    tr_b = base.simulate(periods=5, params={"b_m": B})
    assert np.array_equal(tr_a.y, tr_b.y) and len(tr_a.events) == len(tr_b.events) > 0
    assert tr_a.params["b_m"] == tr_b.params["b_m"] == B

    orb = base.periodic_orbit(params={"b_m": B})
    orb_scene = at_b.periodic_orbit()
    assert np.array_equal(orb.x0, orb_scene.x0) and orb.params["b_m"] == orb_scene.params["b_m"] == B
    assert orb.converged and 0.5 * B_SI < orb.x0[0] < 2 * B_SI    # the orbit lives on the scale of b_m = 60 um

    # the command line: --set in the declared unit gives the same orbit
    assert main(["orbit", "spur_pair_torsional", "--set", f"b_m={B:g}", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert np.array_equal(np.array(cli["x0"]), orb.x0) and cli["params"]["b_m"] == B

    # continuation: range and branch values in um; the point at b_m = 60 is the orbit above
    br = gearsym.continuation(base, "b_m", 58.0, B, progress=False)
    data = br.to_dict()
    assert br.complete and data["start"] == 58.0 and data["stop"] == B
    assert 58.0 <= br.values.min() and br.values.max() <= B + 1e-9
    end = br.points[int(np.argmin(np.abs(br.values - B)))]
    assert abs(end.value - B) < 1e-9
    assert np.max(np.abs(end.x0 - orb.x0) / np.abs(orb.x0)) < 1e-6
    assert main(["continue", "spur_pair_torsional", "--param", "b_m", "--from", "58", "--to", f"{B:g}",
                 "--no-progress", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    assert cli["unit"] == "um" and cli["start"] == 58.0 and cli["stop"] == B
    assert [p["value"] for p in cli["points"]] == [p["value"] for p in data["points"]]

    # a map over b_m: grid in um, SI alongside, the point at 60 um is the orbit above
    from gearsym.analysis.sweeps import stability_map

    ds = stability_map(base, ("b_m", 50.0, B, 2), ("e_a", 2.5, 2.5, 1), method="shooting", workers=1)
    assert list(ds["b_m"].values) == [50.0, B] and ds["b_m"].attrs["units"] == "um"
    np.testing.assert_allclose(ds["b_m_si"].values, [50e-6, B_SI], rtol=1e-15)
    assert abs(float(ds["max_multiplier"].values[0, 1]) - orb.max_multiplier) < 1e-6
