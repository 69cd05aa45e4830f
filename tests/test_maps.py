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
from gearsym.analysis.maps import save_map, stability_map
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
