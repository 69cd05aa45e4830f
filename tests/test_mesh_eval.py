"""Per-mesh deflections evaluated by the engine in C (gs_eval GS_EVAL_MESH) against the
CasADi function the same code was generated from, evaluated by CasADi's own virtual machine
on the same points and modes (an independent evaluator of the same expressions)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import gearsym

ROOT = Path(__file__).resolve().parents[1]


def test_mesh_deflections_in_c_match_casadi_on_a_two_mesh_train():
    system = gearsym.load_scene(ROOT / "scenes" / "two_stage_train.toml").compile()
    T = system.period()
    tr = system.simulate(t_end=3 * T, n_out=400)
    assert len(tr.events) > 0  # both sides of contact are exercised
    p = system.param_vector()
    t, Y = tr.t, tr.y
    got = system.mesh_deflections(t, Y, p)
    assert got.shape == (len(t), len(system.generated.meshes)) == (len(t), 2)
    m = system.modes(t, Y, p).T
    ref = np.asarray(system.generated.casadi_function("gs_mesh")(t[None, :], Y.T, np.tile(p[:, None], (1, len(t))),
                                                               m)).T
    scale = np.max(np.abs(ref))
    assert scale > 0
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * scale)


def test_model_without_meshes_gives_no_columns():
    system = gearsym.load_scene(ROOT / "scenes" / "mathieu.toml").compile()
    out = system.mesh_deflections([0.0, 0.1], np.zeros((2, system.generated.nx)))
    assert out.shape == (2, 0)
