"""Results in notebooks and data tools: short reprs, HTML, LaTeX, xarray / pandas with units,
netCDF round trips, the progress bar, and the names that say what they are (issue 29, item 3).

The numbers of every conversion are compared with the result's own arrays (exactly), the units
with the model files, the natural frequency of the spur pair with the hand formula
``sqrt(k_m / m_e) / (2 pi)``, ``m_e = 1 / (rb1^2/J1 + rb2^2/J2)``.
"""

from __future__ import annotations

import math
import multiprocessing
import pickle
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import gearsym

xr = pytest.importorskip("xarray")
pd = pytest.importorskip("pandas")

ROOT = Path(__file__).resolve().parents[1]
MAX_REPR = 500


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()


@pytest.fixture(scope="module")
def spur():
    return gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml").compile()


@pytest.fixture(scope="module")
def branch(ks):
    # over the fold at Omega = 0.894 and back (tests/test_map_truth.py): two folds, a grazing
    return gearsym.continuation(ks, "Omega", 0.85, 0.95, progress=False)


@pytest.fixture(scope="module")
def spur_orbit(spur):
    return spur.periodic_orbit()


def _one_line(text: str) -> None:
    assert len(text) <= MAX_REPR and "\n" not in text and "object at 0x" not in text, text


# ------------------------------------------------------------------ reprs and HTML
def test_reprs_are_one_short_line_with_the_facts(ks, branch):
    scene = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml")
    r = repr(scene)
    _one_line(r)
    assert "kahraman_singh" in r and "backlash" in r and "x, v" in r
    assert "model" not in scene.__dict__  # the repr (and the HTML) never derive the equations
    scene._repr_html_()
    assert "model" not in scene.__dict__
    _one_line(repr(scene.model))
    r = repr(ks)
    _one_line(r)
    assert f"forcing period {ks.period():.6g}" in r and "2 switching surfaces" in r
    traj = ks.simulate(periods=20)
    r = repr(traj)
    _one_line(r)
    assert f"({len(traj.t)} points)" in r and f"{len(traj.events)} events" in r
    orbit = ks.periodic_orbit()
    r = repr(orbit)
    _one_line(r)
    assert f"max|mu| {orbit.max_multiplier:.4g}" in r and "stable" in r
    r = repr(branch)
    _one_line(r)  # was 81,502 characters for a 108-point branch
    assert f"{len(branch.points)} points ({int(np.sum(branch.stable))} stable)" in r
    assert f"{len(branch.bifurcations)} bifurcations" in r and "fold at 0.894" in r
    for obj in (branch.points[0], branch.bifurcations[0], ks.natural_modes()):
        _one_line(repr(obj))


def test_html_of_every_result(ks, branch, spur):
    pages = {"Scene": gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml")._repr_html_(),
             "System": spur._repr_html_(), "Trajectory": spur.simulate(periods=5)._repr_html_(),
             "PeriodicOrbit": ks.periodic_orbit()._repr_html_(), "Branch": branch._repr_html_(),
             "BranchPoint": branch.points[0]._repr_html_(), "Bifurcation": branch.bifurcations[0]._repr_html_(),
             "ModalAnalysis": spur.natural_modes()._repr_html_()}
    for title, page in pages.items():
        assert page.startswith('<div class="gearsym-repr"><b>' + title + "</b>"), title
        assert len(page) < 20_000, title
    assert "um" in pages["Scene"] and "half backlash" in pages["Scene"]  # declared units and meanings
    assert "m/s" in pages["System"] and "N/m" in pages["System"]  # state (SI) and parameter units
    for b in branch.bifurcations:
        assert b.type in pages["Branch"]


def test_latex_of_the_equations_and_the_groups(spur):
    scene = gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml")
    tex = scene.model._repr_latex_()
    assert tex.startswith("$$\\begin{aligned}") and tex.endswith("\\end{aligned}$$")
    assert "\\ddot{x} &= \\begin{cases}" in tex  # Piecewise as cases, aligned at =
    assert "g_{\\mathrm{mesh.drive}} &= - b_{m} + x" in tex and "g_{\\mathrm{mesh.back}} &= b_{m} + x" in tex
    form = scene.model.dimensionless()
    tex = form._repr_latex_()
    assert "\\zeta &= \\frac{c_{m}}{2 \\sqrt{k_{m} m_{e}}} = " in tex
    # the value shown is zeta = c_m / (2 sqrt(k_m m_e)) at the scene's values
    p = spur.params
    m_e = 1.0 / (p["rb1"] ** 2 / p["J1"] + p["rb2"] ** 2 / p["J2"])
    zeta = p["c_m"] / (2 * math.sqrt(p["k_m"] * m_e))
    assert f"\\zeta &= \\frac{{c_{{m}}}}{{2 \\sqrt{{k_{{m}} m_{{e}}}}}} = {zeta:.6g}" in tex
    _one_line(repr(form))


# ------------------------------------------------------------------ units
def test_units_table_of_states_and_parameters(spur):
    u = spur.units_table()
    assert (u["t"], u["x"], u["v"]) == ("s", "m", "m/s")  # the reduced coordinate's unit
    assert (u["b_m"], u["k_m"], u["omega"]) == ("um", "N/m", "rad/s")  # declared units
    train = gearsym.load_scene(ROOT / "scenes" / "two_stage_train.toml")
    from gearsym.facade import state_units

    su = state_units(train.model_spec)
    assert (su["th1"], su["w1"]) == ("rad", "rad/s")
    assert pickle.loads(pickle.dumps(spur)).units_table() == u  # workers keep the units
    assert spur.simulate(periods=2).units == u


def test_dimensionless_systems_say_so():
    system = gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml").compile(dimensionless=True)
    u = system.units_table()
    assert (u["t"], u["x"], u["v"], u["b_m"]) == ("1", "1", "1", "um")


# ------------------------------------------------------------------ conversions
def _round_trip(ds, tmp_path: Path, engine: str):
    path = tmp_path / f"{engine}.nc"
    ds.to_netcdf(path, engine=engine)
    with xr.open_dataset(path, engine=engine) as back:
        back = back.load()
    xr.testing.assert_identical(ds, back)
    return back


@pytest.mark.parametrize("engine", ["scipy", "default"])
def test_trajectory_to_xarray_round_trips_through_netcdf(spur, tmp_path, engine):
    from gearsym.display import netcdf_engine

    traj = spur.simulate(periods=10)
    ds = traj.to_xarray()
    back = _round_trip(ds, tmp_path, "scipy" if engine == "scipy" else netcdf_engine())
    np.testing.assert_array_equal(back["t"].values, traj.t)
    for i, name in enumerate(traj.state_names):
        np.testing.assert_array_equal(back[name].values, traj.y[:, i])
    assert (back["t"].attrs["units"], back["x"].attrs["units"], back["v"].attrs["units"]) == ("s", "m", "m/s")
    assert back.attrs["param_b_m"] == traj.params["b_m"] == 50.0 and back.attrs["param_b_m_units"] == "um"
    assert back.attrs["period"] == traj.period
    np.testing.assert_array_equal(back["event_t"].values, [e.t for e in traj.events])
    assert list(back["event_surface"].values) == [e.surface for e in traj.events]
    assert "SI" in back.attrs["units_convention"] and "declared" in back.attrs["units_convention"]


def test_trajectory_to_dataframe(spur):
    traj = spur.simulate(periods=3)
    df = traj.to_dataframe()
    np.testing.assert_array_equal(df.index.values, traj.t)
    np.testing.assert_array_equal(df.to_numpy(), traj.y)
    assert df.attrs["units"] == {"t": "s", "x": "m", "v": "m/s"} and df.attrs["param_units"]["b_m"] == "um"


def test_orbit_to_xarray_is_its_sampled_period(spur_orbit, tmp_path):
    o = spur_orbit
    ds = o.to_xarray()
    tr = o.trajectory()
    np.testing.assert_array_equal(ds["x"].values, tr.y[:, 0])
    np.testing.assert_array_equal(ds["x0"].values, o.x0)
    np.testing.assert_array_equal(ds["multiplier_real"].values + 1j * ds["multiplier_imag"].values, o.multipliers)
    assert ds.attrs["period"] == o.period and ds.attrs["stability"] == o.stability and ds.attrs["stable"] == 1
    assert ds["t"].values[-1] - ds["t"].values[0] == pytest.approx(o.period, rel=1e-12)
    _round_trip(ds, tmp_path, "scipy")
    df = o.to_dataframe(n_out=65)
    assert len(df) == 65 and df.attrs["max_multiplier"] == o.max_multiplier


def test_harmonic_balance_orbit_without_a_system_converts_from_its_series(ks):
    import dataclasses

    hb = ks.periodic_orbit(method="hbm")
    detached = dataclasses.replace(hb, system=None)
    ds = detached.to_xarray(n_out=257)
    # the series at t0 is the balanced state x0 (to the balance's own accuracy)
    np.testing.assert_allclose([ds[n].values[0] for n in hb.state_names], hb.x0, atol=1e-9)
    np.testing.assert_allclose([ds[n].values[-1] for n in hb.state_names], hb.x0, atol=1e-9)


def test_branch_to_dataframe_one_row_per_point(branch, tmp_path):
    df = branch.to_dataframe()
    assert len(df) == len(branch.points)
    np.testing.assert_array_equal(df["Omega"].values, branch.values)
    np.testing.assert_array_equal(df["stable"].values, branch.stable)
    np.testing.assert_array_equal(df["max_multiplier"].values, [np.max(np.abs(p.multipliers)) for p in branch.points])
    np.testing.assert_array_equal(df["peak_to_peak"].values, branch.peak_to_peak)
    np.testing.assert_array_equal(df["x0_v"].values, [p.x0[1] for p in branch.points])
    located = {b.index: b.type for b in branch.bifurcations}
    assert {i: t for i, t in enumerate(df["bifurcation"]) if t} == located
    assert df.attrs["units"]["Omega"] == "1" and df.attrs["param"] == "Omega"
    ds = branch.to_xarray()
    back = _round_trip(ds, tmp_path, "scipy")
    np.testing.assert_array_equal(back["Omega"].values, branch.values)
    mu = back["multiplier_real"].values + 1j * back["multiplier_imag"].values
    for i, p in enumerate(branch.points):
        np.testing.assert_array_equal(mu[i, :len(p.multipliers)], p.multipliers)


def test_natural_modes_against_the_hand_formula(spur, tmp_path):
    m = spur.natural_modes()
    p = spur.params
    m_e = 1.0 / (p["rb1"] ** 2 / p["J1"] + p["rb2"] ** 2 / p["J2"])
    f = math.sqrt(p["k_m"] / m_e) / (2 * math.pi)
    assert m.frequencies_hz[0] == pytest.approx(f, rel=1e-9)
    ref = gearsym.modal_analysis(spur)
    np.testing.assert_array_equal(m.frequencies_hz, ref.frequencies_hz)
    df = m.to_dataframe()
    assert df["frequency_hz"].iloc[0] == m.frequencies_hz[0] and df.attrs["units"]["frequency_hz"] == "Hz"
    ds = _round_trip(m.to_xarray(), tmp_path, "scipy")
    assert ds["frequency_hz"].attrs["units"] == "Hz" and list(ds["coordinate"].values) == ["x"]


def test_lyapunov_result_converts(ks):
    r = gearsym.lyapunov_exponents(ks, periods=32, transient=0, align=0)
    _one_line(repr(r))
    df = r.to_dataframe()
    np.testing.assert_array_equal(df["exponent"].values, r.exponents)
    np.testing.assert_array_equal(r.to_xarray()["error"].values, r.errors)


def test_map_dataset_round_trips(ks, tmp_path):
    ds = gearsym.stability_map(ks, ("Omega", 0.8, 0.9, 2), ("zeta", 0.04, 0.06, 2), workers=1)
    _round_trip(ds, tmp_path, "scipy")


def test_netcdf_attrs_are_safe():
    from gearsym.display import netcdf_attrs

    a = netcdf_attrs({"b": True, "n": None, "d": {"x": 1}, "c": 1 + 2j, "i": np.int64(3), "f": np.float32(0.5),
                      "a": np.array([1.0, 2.0]), "l": [1, 2]})
    assert a["b"] == 1 and a["n"] == "" and a["d"] == '{"x": 1}' and a["l"] == "[1, 2]"
    assert a["i"] == 3 and type(a["i"]) is int and a["f"] == 0.5 and a["c"] == "1+2j"


# ------------------------------------------------------------------ names
def test_names_that_say_what_they_are(ks, branch):
    assert ks.forcing_period == ks.period() == pytest.approx(2 * math.pi / 0.9, rel=1e-14)
    assert ks.period({"Omega": 1.0}) == pytest.approx(2 * math.pi, rel=1e-14)  # the method stays
    t = np.linspace(0, 3, 4)
    x = np.tile(ks.x0, (4, 1))
    np.testing.assert_array_equal(ks.contact_modes(t, x), ks.modes(t, x))
    for b in branch.bifurcations:
        np.testing.assert_array_equal(b.x0, b.to_dict()["x0"])
        assert b.period == b.to_dict()["period"]
    from gearsym.analysis import linear, periodic, sweeps

    assert gearsym.mesh_deflections is periodic.mesh_deflections
    assert gearsym.harmonic_balance is periodic.harmonic_balance
    assert gearsym.stability_map is sweeps.stability_map
    assert gearsym.modal_analysis is linear.modal_analysis
    assert gearsym.analysis.mesh_deflections is periodic.mesh_deflections


# ------------------------------------------------------------------ progress
class _Stream:
    def __init__(self, tty: bool):
        self.tty, self.text = tty, []

    def isatty(self) -> bool:
        return self.tty

    def write(self, s: str) -> int:
        self.text.append(s)
        return len(s)

    def flush(self) -> None:
        pass


def test_progress_wanted_in_terminals_and_notebooks(monkeypatch):
    from gearsym import progress

    monkeypatch.setattr(sys, "stderr", _Stream(False))
    assert not progress.in_notebook() and not progress.wanted(None)
    assert progress.wanted(True) and not progress.wanted(False)
    monkeypatch.setattr(sys, "stderr", _Stream(True))
    assert progress.wanted(None)
    # a Jupyter kernel: stderr is no terminal, the bar is wanted all the same
    monkeypatch.setattr(sys, "stderr", _Stream(False))
    shell = types.SimpleNamespace(config={"IPKernelApp": {}})
    monkeypatch.setitem(sys.modules, "ipykernel", types.ModuleType("ipykernel"))
    monkeypatch.setitem(sys.modules, "IPython", types.SimpleNamespace(get_ipython=lambda: shell))
    assert progress.in_notebook() and progress.wanted(None)


def _wanted_in_child(queue) -> None:
    from gearsym import progress

    sys.stderr = _Stream(True)
    queue.put(progress.wanted(None))


def test_no_progress_bar_in_worker_processes():
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_wanted_in_child, args=(queue,))
    proc.start()
    proc.join(60)
    assert queue.get(timeout=5) is False


def test_progress_bar_draws_and_stays_silent(monkeypatch):
    pytest.importorskip("tqdm")
    from gearsym.progress import progress_bar

    stream = _Stream(True)
    monkeypatch.setattr(sys, "stderr", stream)
    with progress_bar(None, 10, "points") as bar:
        bar(4)
        bar.postfix("value=1")
    assert "points" in "".join(stream.text)
    quiet = _Stream(False)
    monkeypatch.setattr(sys, "stderr", quiet)
    with progress_bar(None, 10, "points") as bar:
        bar(10)
    assert bar.bar is None and quiet.text == []


def test_continuation_draws_its_progress_through_the_helper(ks, monkeypatch):
    pytest.importorskip("tqdm")
    stream = _Stream(True)
    monkeypatch.setattr(sys, "stderr", stream)  # a terminal: progress=None draws
    gearsym.continuation(ks, "Omega", 0.6, 0.62, ds_max=0.5, detect=False)
    assert "continuation in Omega" in "".join(stream.text)
    stream.text.clear()
    gearsym.continuation(ks, "Omega", 0.6, 0.62, ds_max=0.5, detect=False, progress=False)
    assert stream.text == []


def test_basin_result_shows_and_converts(tmp_path, monkeypatch):
    pytest.importorskip("tqdm")
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", Omega=0.87).compile()
    stream = _Stream(True)
    monkeypatch.setattr(sys, "stderr", stream)
    r = gearsym.basins(system, ("x", -2, 4, 5), ("v", -2, 2, 4), workers=1, progress=None)
    assert "basin cells settled" in "".join(stream.text)  # the progress helper, in a terminal
    page = r._repr_html_()
    assert page.startswith('<div class="gearsym-repr"><b>BasinResult</b>')
    for a in r.attractors:
        assert r.label_name(a.index) in page
    df = r.to_dataframe()
    assert list(df.index) == [a.index for a in r.attractors]
    np.testing.assert_array_equal(df["fraction"].values, [np.mean(r.labels == a.index) for a in r.attractors])
    back = _round_trip(r.to_xarray(), tmp_path, "scipy")
    np.testing.assert_array_equal(back["label"].values, r.labels)
    assert back.attrs["param_Omega"] == 0.87


def test_gear_quantities_show_and_convert(spur, tmp_path):
    g = spur.simulate(periods=60).gear_quantities()
    _one_line(repr(g))
    _one_line(repr(g["mesh"]))
    assert f"dynamic_factor {g.value('dynamic_factor'):.4g}" in repr(g)
    assert g._repr_html_().startswith('<div class="gearsym-repr"><b>GearQuantities</b>')
    df = g.to_dataframe()
    assert list(df.index) == list(g.meshes)
    for k in ("dte_rms", "dynamic_factor", "contact_loss_ratio", "impact_count"):
        assert df.loc["mesh", k] == g.value(k, "mesh")
    assert df.attrs["units"]["dte_rms"] == "m" and df.attrs["units"]["static_force"] == "N"
    back = _round_trip(g.to_xarray(), tmp_path, "scipy")
    np.testing.assert_array_equal(back["dte_harmonic"].values[0, :len(g["mesh"].dte_harmonics)],
                                  g["mesh"].dte_harmonics)
    assert back["force_max"].attrs["units"] == "N"
