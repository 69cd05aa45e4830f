"""Two-parameter stability / response maps.

References: the hand-written exact Meissner monodromy (matrix exponentials, as
in test_floquet.py), direct single-point orbit solves, and the equality of the
serial, process-pool and Dask (LocalCluster) runs of the same tasks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import gearsym
from gearsym.analysis.sweeps import save_map, stability_map
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parent.parent
MEISSNER = ROOT / "scenes" / "meissner.toml"
KS = ROOT / "scenes" / "kahraman_singh.toml"
X_AX = ("T", 1.0, 9.0, 9)
Y_AX = ("a", 0.05, 0.75, 5)


def exact_max_multiplier(zeta, w0, a, d, T):
    Ap = np.array([[0.0, 1.0], [-w0**2 * (1 + a), -2 * zeta * w0]])
    Am = np.array([[0.0, 1.0], [-w0**2 * (1 - a), -2 * zeta * w0]])
    return np.max(np.abs(np.linalg.eigvals(expm(Am * (1 - d) * T) @ expm(Ap * d * T))))


@pytest.fixture(scope="module")
def meissner_scene():
    return gearsym.load_scene(MEISSNER)


@pytest.fixture(scope="module")
def exact_map(meissner_scene):
    return stability_map(meissner_scene, X_AX, Y_AX, method="exact")


def test_exact_map_vs_hand_written_reference(exact_map):
    ds = exact_map
    assert ds["max_multiplier"].dims == ("a", "T")
    ref = np.array([[exact_max_multiplier(0.02, 1.0, a, 0.5, T) for T in ds["T"].values] for a in ds["a"].values])
    assert np.max(np.abs(ds["max_multiplier"].values - ref) / ref) < 1e-12
    assert ds.attrs["methods_used"] == "exact"
    # both stable and unstable points (the first tongue at T ~ pi)
    assert 0 < int(ds["stable"].sum()) < ds["stable"].size
    assert np.array_equal(ds["stable"].values, (ref < 1).astype(np.int8))


def test_shooting_map_serial_and_processes_agree_with_exact(meissner_scene, exact_map):
    serial = stability_map(meissner_scene, X_AX, Y_AX, method="shooting", workers=1)
    pooled = stability_map(meissner_scene, X_AX, Y_AX, method="shooting", workers=2, rows_per_task=1)
    assert serial.attrs["runner"] == "serial" and pooled.attrs["runner"].startswith("processes")
    assert serial.attrs["methods_used"] == "shooting"
    ref = exact_map["max_multiplier"].values
    assert np.max(np.abs(serial["max_multiplier"].values - ref) / ref) < 1e-8
    assert np.array_equal(serial["max_multiplier"].values, pooled["max_multiplier"].values)
    assert np.array_equal(serial["stable"].values, exact_map["stable"].values)


def test_dask_local_cluster_same_code_path(meissner_scene):
    distributed = pytest.importorskip("distributed")
    serial = stability_map(meissner_scene, ("T", 2.5, 4.0, 4), ("a", 0.2, 0.6, 3), method="shooting",
                           workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True,
                                  dashboard_address=None) as cluster:
        ds = stability_map(meissner_scene, ("T", 2.5, 4.0, 4), ("a", 0.2, 0.6, 3), method="shooting",
                           dask=cluster.scheduler_address, rows_per_task=1)
    assert ds.attrs["runner"] == "dask"
    assert np.array_equal(ds["max_multiplier"].values, serial["max_multiplier"].values)


def test_netcdf_and_png_round_trip(exact_map, tmp_path):
    xr = pytest.importorskip("xarray")
    files = save_map(exact_map, tmp_path / "out")
    nc, png = files
    assert png.stat().st_size > 5000 and png.read_bytes()[:4] == b"\x89PNG"
    back = xr.open_dataset(nc)
    try:
        assert np.array_equal(back["max_multiplier"].values, exact_map["max_multiplier"].values)
        assert back.attrs["quantity"] == "max_multiplier"
        assert list(back["T"].values) == list(exact_map["T"].values)
    finally:
        back.close()


def test_response_map_of_backlash_model_matches_single_orbits():
    """Peak-to-peak and rattle state on a small (Omega, Fa) grid of the nonlinear
    benchmark (shooting, continuation along rows) against direct orbit solves."""
    scene = gearsym.load_scene(KS)
    ds = stability_map(scene, ("Omega", 0.8, 1.4, 4), ("Fa", 0.03, 0.06, 2), quantity="peak_to_peak",
                       workers=1)
    assert ds.attrs["methods_used"] == "shooting"
    assert int(ds["converged"].sum()) == ds["converged"].size
    system = scene.compile()
    for j, Fa in enumerate(ds["Fa"].values):
        for i, Om in enumerate(ds["Omega"].values):
            o = system.periodic_orbit(params={"Omega": float(Om), "Fa": float(Fa)}, transient=300)
            assert ds["max_multiplier"].values[j, i] == pytest.approx(o.max_multiplier, abs=1e-7)
            assert ds["rattle_state"].values[j, i] == o.rattle_state
            tr = o.trajectory(n_out=513)
            assert ds["peak_to_peak"].values[j, i] == pytest.approx(np.ptp(tr.y[:, 0]), rel=1e-6)
    assert set(np.unique(ds["rattle_state"].values)) >= {0, 1}


def test_bad_axis_is_a_parameter_error(meissner_scene):
    with pytest.raises(ParameterError, match="not a parameter"):
        stability_map(meissner_scene, ("nope", 0, 1, 3), Y_AX)
    with pytest.raises(ParameterError, match="run-time parameter"):
        stability_map(meissner_scene, ("F0", 0, 1, 3), Y_AX)  # effect excitation is off
    with pytest.raises(ParameterError, match="quantity"):
        stability_map(meissner_scene, X_AX, Y_AX, quantity="colour")


def test_cli_map(tmp_path, capsys):
    import json

    from gearsym.cli import main

    out = tmp_path / "m"
    rc = main(["map", str(MEISSNER), "--x", "T", "1", "9", "9", "--y", "a", "0.05", "0.75", "5", "--json",
               "--out", str(out)])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["methods_used"] == "exact" and info["n_points"] == 45 and info["n_failed"] == 0
    assert 0 < info["fraction_unstable"] < 1
    assert (out / "map.nc").exists() and (out / "map.png").exists()
    assert main(["map", str(MEISSNER), "--x", "T", "1", "x", "3", "--y", "a", "0", "1", "2", "--out",
                 str(out)]) == 2
    assert main(["map", str(MEISSNER), "--x", "bogus", "1", "2", "3", "--y", "a", "0", "1", "2", "--out",
                 str(out)]) == 2


# ------------------------------------------------------- Vaishya & Singh Fig. 5
VS_MODEL = ROOT / "models" / "vaishya_singh.toml"


def _vs_system(tmp_path, formulation):
    """Undamped V&S gear pair (Figs. 5-6: zeta = 0, mu0 = 0.1), friction formulation A
    (quasi-static load: rectangular coefficients) or B (dynamic load: sawtooth)."""
    scene = tmp_path / f"vs_{formulation}.toml"
    scene.write_text(f'[scene]\nname = "vs_fig5_{formulation}"\nmodel = "{VS_MODEL.as_posix()}"\n'
                     f'[effects]\nsliding_friction = "{formulation}"\nmesh_stiffness_variation = true\n'
                     f'static_transmission_error = true\n[parameters]\nzeta = 0.0\nmu0 = 0.1\n')
    sc = gearsym.load_scene(scene)
    sc.compile(generated_dir=ROOT / "generated")
    return sc


@pytest.mark.skipif(not VS_MODEL.exists(), reason="models/vaishya_singh.toml not present")
def test_vaishya_singh_fig5_tongues_and_fig6_statements(tmp_path):
    from scipy import ndimage

    scA = _vs_system(tmp_path, "A")
    scB = _vs_system(tmp_path, "B")
    # Fig. 5 / Fig. 6 statements, formulation B (sawtooth coefficients: numerical monodromy)
    sysB = scB.compile(generated_dir=ROOT / "generated")
    verdict = {}
    for G, W in ((1.24, 1500), (1.374, 1484), (1.453, 1484)):
        o = sysB.periodic_orbit(x0=[0.0, 0.0], params={"Gamma": G, "Omega_p": W})  # rpm, the declared unit
        verdict[(G, W)] = o.max_multiplier
    assert verdict[(1.24, 1500)] > 1.05  # Fig. 5: the zone containing 1500 rpm and Gamma = 1.24
    assert abs(verdict[(1.374, 1484)] - 1) < 1e-6  # Fig. 6(a): stable (undamped: on the unit circle)
    assert verdict[(1.453, 1484)] > 1.05  # Fig. 6(b): unstable
    # B has no exact path: its coefficients vary inside the segments
    small = stability_map(scB, ("Omega_p", 1480, 1520, 9), ("Gamma", 1.36, 1.44, 5))
    assert small.attrs["methods_used"] == "shooting" and small.attrs["n_failed"] == 0
    # Fig. 5: diagonally laid instability zones (exact path, formulation A)
    ds = stability_map(scA, ("Omega_p", 1400, 1600, 81), ("Gamma", 1.15, 1.55, 41))
    assert ds.attrs["methods_used"] == "exact"
    unstable = ds["stable"].values == 0
    assert 0.05 < unstable.mean() < 0.4
    labels, n = ndimage.label(unstable)
    W, G = np.meshgrid(ds["Omega_p"].values, ds["Gamma"].values)
    slopes = []
    for k in range(1, n + 1):
        m = labels == k
        if m.sum() >= 15 and len(np.unique(G[m])) >= 4:
            slopes.append(np.polyfit(G[m], W[m], 1)[0])  # rpm per unit contact ratio
    assert len(slopes) >= 4
    # every zone leans the same way: higher contact ratio, stiffer mesh, higher speed
    assert all(150 < s < 1500 for s in slopes), slopes
    # the same zones from the numerical monodromy of formulation A (shooting) on a sub-grid
    sub = stability_map(scA, ("Omega_p", 1400, 1600, 11), ("Gamma", 1.15, 1.55, 5), method="shooting",
                        workers=1)
    exact = stability_map(scA, ("Omega_p", 1400, 1600, 11), ("Gamma", 1.15, 1.55, 5))
    # (default atol 1e-13 m on a DTE of ~1e-5 m: ~1e-7 here; next to a zone edge the two multipliers
    # are a near-double eigenvalue whose error grows like the square root of the monodromy's:
    # 1.3e-6 at |mu| = 1.086 with the solid-disc inertias of models/vaishya_singh.toml)
    assert np.max(np.abs(sub["max_multiplier"].values - exact["max_multiplier"].values)) < 3e-6
    assert np.array_equal(sub["stable"].values, exact["stable"].values)
    assert 0 < int(exact["stable"].sum()) < exact["stable"].size
