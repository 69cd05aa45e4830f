"""Run-ups (issue 29, item 2): a speed ramp that is exact in the engine, and its waterfall.

The model (tests/data/runup_pair.toml): the DTE of a spur pair at pinion speed ``n`` (rpm),
``z1 = 25`` teeth, a rectangular mesh stiffness on the schedule ``mesh`` (period
``2 pi / (z1 n)``, breaks at 0 and ``eps - 1``) and a transmission-error forcing
``m_e e_a w_m^2 cos(w_m t)``.  Under the ramp ``n(t) = n0 + a t`` the reference below writes
the same equations with the phase in closed form, ``theta(t) = z1 (n0 t + a t^2 / 2)``, the
amplitude at the instantaneous ``w_m(t) = z1 n(t)``, and the stiffness segment from the
fraction of ``theta / (2 pi)``; its breakpoints are the roots of the quadratic
``z1 (n0 t + a t^2/2) = 2 pi (j + c)``, found by ``numpy.roots``, and ``scipy``'s DOP853 is
restarted at each of them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gearsym
from gearsym.analysis.linear import modal_analysis
from gearsym.cli import main
from gearsym.engine.errors import EngineInputError
from gearsym.engine.ramp import SpeedRamp
from gearsym.errors import ParameterError, SpecError

DATA = Path(__file__).parent / "data"
SCENE = DATA / "runup_pair_scene.toml"
RPM = 2 * math.pi / 60


@pytest.fixture(scope="module")
def scene():
    return gearsym.load_scene(SCENE)


@pytest.fixture(scope="module")
def system(scene):
    return scene.compile()


@pytest.fixture(scope="module")
def steep(system):
    """5000 -> 11000 rpm in 0.05 s (a steep ramp: 330 breakpoints), tight tolerances."""
    return gearsym.runup(system, duration=0.05, settle=0, rtol=1e-10, atol=1e-16, modes=False, bins=8)


@pytest.fixture(scope="module")
def rig(scene):
    """The scene's [runup]: 5000 -> 11000 rpm in 0.5 s after 20 periods at 5000 rpm."""
    return gearsym.runup(scene)


def _constants(system):
    P = system.params
    c = {k: float(P[k]) for k in ("m_e", "k_hi", "k_lo", "eps", "zeta", "F_m", "e_a", "z1")}
    c["e_a"] *= 1e-6  # um -> m
    c["k_mean"] = c["k_lo"] + (c["k_hi"] - c["k_lo"]) * (c["eps"] - 1)
    c["c_m"] = 2 * c["zeta"] * math.sqrt(c["k_mean"] * c["m_e"])
    return c


def _reference_breaks(z1, n0, a, eps, D):
    """Times where z1 (n0 t + a t^2 / 2) / (2 pi) reaches j or j + eps - 1 (numpy.roots)."""
    u_end = z1 * (n0 * D + a * D * D / 2) / (2 * math.pi)
    out = []
    for j in range(int(u_end) + 2):
        for frac in (0.0, eps - 1):
            u = j + frac
            if u <= 0:
                continue
            roots = np.roots([z1 * a / 2, z1 * n0, -2 * math.pi * u])
            tb = float(np.max(roots.real))
            if tb < D:
                out.append(tb)
    return np.sort(out)


def _reference_run(system, D, times):
    """The run-up's equations with the phase in closed form, solve_ivp restarted at every break."""
    c = _constants(system)
    n0, a = 5000 * RPM, (11000 - 5000) * RPM / D
    z1 = c["z1"]
    breaks = _reference_breaks(z1, n0, a, c["eps"], D)

    def rhs(t, y, k):
        theta, wm = z1 * (n0 * t + a * t * t / 2), z1 * (n0 + a * t)
        return [y[1], (c["F_m"] - c["c_m"] * y[1] - k * y[0] + c["m_e"] * c["e_a"] * wm * wm * math.cos(theta))
                / c["m_e"]]

    y = np.asarray(system.x0, float)
    edges = np.concatenate([[0.0], breaks, [D]])
    out = np.full((len(times), 2), np.nan)
    for t0, t1 in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (t0 + t1)
        u = z1 * (n0 * mid + a * mid * mid / 2) / (2 * math.pi)
        k = c["k_hi"] if u - math.floor(u) < c["eps"] - 1 else c["k_lo"]
        sol = solve_ivp(rhs, (t0, t1), y, args=(k,), method="DOP853", rtol=1e-12, atol=1e-20, dense_output=True)
        inside = (times >= t0) & (times <= t1)
        out[inside] = sol.sol(times[inside]).T
        y = sol.y[:, -1]
    return breaks, out


# ------------------------------------------------------------------ exactness of the ramp
def test_breakpoints_are_the_roots_of_the_quadratic(system, steep):
    c = _constants(system)
    expected = _reference_breaks(c["z1"], 5000 * RPM, 6000 * RPM / 0.05, c["eps"], 0.05)
    assert steep.break_times is not None and len(steep.break_times) == len(expected) > 300
    assert steep.stats["n_breaks"] == len(expected)
    np.testing.assert_allclose(steep.break_times, expected, rtol=1e-12, atol=0)


def test_the_run_up_equals_solve_ivp_with_the_phase_in_closed_form(system, steep):
    _, ref = _reference_run(system, 0.05, steep.t)
    for j in range(2):
        err = np.max(np.abs(steep.states[:, j] - ref[:, j]))
        assert err <= 1e-8 * np.ptp(ref[:, j]), (j, err / np.ptp(ref[:, j]))
    # the speed and the phase time reported are the closed forms
    np.testing.assert_allclose(steep.speed, 5000 + 6000 * steep.t / 0.05, rtol=1e-14)
    n0, a = 5000 * RPM, 6000 * RPM / 0.05
    np.testing.assert_allclose(steep.phase_time, (n0 * steep.t + a * steep.t ** 2 / 2) / n0, rtol=1e-13)


def test_the_signal_is_the_mesh_deflection_at_the_ramp_time(steep):
    # the mesh's deflection is x (no error term): the signal is the first state, evaluated through gs_eval_ramp
    assert steep.signal_name == "mesh_deflection[mesh]"
    np.testing.assert_array_equal(steep.signal, steep.states[:, 0])


def test_a_ramp_of_rate_zero_runs_as_the_constant_speed(system):
    p = system.param_vector({"n": 7000.0})
    i = system.param_names.index("n")
    grid = np.linspace(0.0, 2e-3, 41)
    kw = {"method": "bdf", "rtol": 1e-10, "atol": 1e-16}
    plain = system.engine.run(system.x0, p, 0.0, 2e-3, grid, **kw)
    ramped = system.engine.run(system.x0, p, 0.0, 2e-3, grid, ramp=SpeedRamp(i, float(p[i]), 0.0), break_log=100,
                               **kw)
    assert np.all(np.max(np.abs(ramped.y - plain.y), axis=0) <= 1e-9 * np.max(np.abs(plain.y), axis=0))
    assert ramped.stats["n_breaks"] == plain.stats["n_breaks"] == len(ramped.break_times)


def test_the_engine_refuses_a_ramp_with_variational_equations_or_through_zero_speed(system):
    p = system.param_vector()
    i = system.param_names.index("n")
    with pytest.raises(EngineInputError, match="variational"):
        system.engine.run(system.x0, p, 0.0, 1e-3, ramp=SpeedRamp(i, 500.0, 1.0), want_monodromy=True)
    with pytest.raises(EngineInputError, match="keep the sign"):
        system.engine.run(system.x0, p, 0.0, 1.0, ramp=SpeedRamp(i, 500.0, -1000.0))


# ------------------------------------------------------------------ the waterfall (done-when)
def test_the_waterfall_shows_mesh_order_one_at_speed_times_teeth(system, rig):
    z1 = _constants(system)["z1"]
    assert rig.mesh_frequency0[0] == pytest.approx(z1 * 5000 / 60, rel=1e-12)  # speed x teeth, in Hz
    df = rig.resolution
    for speed, spec in zip(rig.bin_speed, rig.spectra):
        f1 = z1 * speed / 60
        k = int(round(f1 / df))
        near = slice(max(k - 3, 1), k + 4)
        j = near.start + int(np.argmax(spec[near]))
        assert abs(rig.frequencies[j] - f1) <= df, (speed, rig.frequencies[j], f1)
        assert spec[j] > 100 * np.median(spec), speed  # a line, not noise


def test_the_resonance_is_where_order_one_crosses_the_natural_frequency(system, rig):
    fn = float(modal_analysis(system).frequencies_hz[0])
    assert fn == pytest.approx(math.sqrt(_constants(system)["k_mean"] / 0.7) / (2 * math.pi), rel=1e-9)
    # the waterfall: the largest order-1 line over the speed bins is at the natural frequency (one bin)
    z1, df = _constants(system)["z1"], rig.resolution
    line = [np.max(s[max(int(round(z1 * v / 60 / df)) - 1, 1):int(round(z1 * v / 60 / df)) + 2])
            for v, s in zip(rig.bin_speed, rig.spectra)]
    peak_bin = int(np.argmax(line))
    assert abs(z1 * rig.bin_speed[peak_bin] / 60 - fn) <= df
    # the order track (angle domain) and the crossing the result predicts agree
    (pk,) = [p for p in rig.peaks() if p["order"] == 1]
    assert abs(pk["frequency"] - fn) <= df
    (cross,) = [c for c in rig.crossings() if c["order"] == 1]
    assert cross["speed"] == pytest.approx(fn * 60 / z1, rel=1e-12)
    assert rig.natural_frequencies[0, 0] == pytest.approx(fn, rel=1e-12)


def test_order_amplitudes_are_the_dft_of_whole_periods_in_the_angle_domain(rig):
    # order 1 in the bin at the top speed, recomputed from the angle samples with numpy's FFT
    q = rig.settings["samples_per_period"]
    j = -1
    tau_a = rig.phase_time[np.searchsorted(rig.t, rig.bin_time[j] - 0.5 * rig.window)]
    dtau = rig.angle_phase_time[1]
    first = int(math.ceil(tau_a / dtau - 1e-9))
    assert first > 0
    amp = rig.order_amplitude[0, 0, j]
    K = round(len(rig.angle_signal[first:]) / q)  # at most this many whole periods remain
    for k in range(K, 0, -1):
        seg = rig.angle_signal[first:first + k * q]
        if abs(2 * abs(np.fft.rfft(seg)[k]) / len(seg) - amp) <= 1e-12 * amp:
            break
    else:
        pytest.fail("no whole-period window of the angle samples gives the order amplitude")


# ------------------------------------------------------------------ refusals
@pytest.mark.parametrize(("overrides", "match"), [
    ({"parameter": "m_e"}, "not proportional to 1/m_e"),
    ({"parameter": "F_m", "start": 400.0, "stop": 600.0}, "not proportional to 1/F_m"),
    ({"stop": -5000.0}, "period of schedule 'mesh' .* must be positive"),
    ({"stop": 5000.0}, "equal"),
    ({"parameter": "nope"}, "'nope' is not a run-time parameter"),
    ({"signal": "mesh_deflection[gear]"}, "no mesh 'gear'"),
    ({"signal": "w"}, "neither a mesh deflection nor a state"),
    ({"duration": 0.5, "rate": 1000.0}, "one of duration and rate"),
    ({"bins": 0}, "bins"),
])
def test_bad_run_ups_are_refused_naming_what(system, overrides, match):
    with pytest.raises(ParameterError, match=match):
        gearsym.runup(system, **overrides)


def test_a_run_up_needs_its_settings(system, monkeypatch):
    monkeypatch.setitem(system.settings, "runup", {})
    with pytest.raises(ParameterError, match=r"missing: parameter, from, to, duration or rate"):
        gearsym.runup(system)


def test_a_fixed_frequency_excitation_is_refused(tmp_path):
    # an excitation at a frequency of its own has no phase of the speed to run on
    model = (DATA / "runup_pair.toml").read_text().replace(
        'value = ["F_m", "m_e*e_a*w_m**2*cos(w_m*t)"]',
        'value = ["F_m", "m_e*e_a*w_m**2*cos(w_m*t)", "F_m*cos(w_r*t)"]').replace(
        "[parameters]", '[parameters]\nw_r = { value = 6000.0, unit = "rad/s", meaning = "a rig resonance" }')
    (tmp_path / "m.toml").write_text(model)
    (tmp_path / "s.toml").write_text('[scene]\nmodel = "m.toml"\n[simulate]\natol = 1e-14\n')
    with pytest.raises(ParameterError, match="right-hand side .* not periodic in time with the forcing period"):
        gearsym.runup(gearsym.load_scene(tmp_path / "s.toml"), parameter="n", start=5000, stop=6000, duration=0.01)


def test_the_scene_table_is_checked(tmp_path):
    (tmp_path / "m.toml").write_text((DATA / "runup_pair.toml").read_text())
    for table, match in (('[runup]\nspeed = "n"\n', "runup.speed"), ("[runup]\nduration = 1\nrate = 2\n", "runup.rate"),
                         ('[runup]\nprofile = "cubic"\n', "runup.profile")):
        (tmp_path / "s.toml").write_text(f'[scene]\nmodel = "m.toml"\n{table}')
        with pytest.raises(SpecError, match=match):
            gearsym.load_scene(tmp_path / "s.toml")


# ------------------------------------------------------------------ results, files, command line
def test_the_dataset_round_trips_through_netcdf(steep, tmp_path):
    xr = pytest.importorskip("xarray")
    files = steep.save(tmp_path)
    assert sorted(f.name for f in files) == ["campbell.png", "orders.png", "runup.nc", "waterfall.png"]
    with xr.open_dataset(tmp_path / "runup.nc") as ds:
        np.testing.assert_array_equal(ds["spectrum"].values, steep.spectra)
        np.testing.assert_array_equal(ds["states"].values, steep.states)
        np.testing.assert_array_equal(ds["break_time"].values, steep.break_times)
        np.testing.assert_array_equal(ds["order_amplitude"].values, steep.order_amplitude)
        assert ds.attrs["parameter"] == "n" and ds.attrs["unit"] == "rpm" and ds["frequency"].attrs["units"] == "Hz"
        assert ds["bin_speed"].attrs["units"] == "rpm"
        assert list(ds["state_unit"].values) == ["m", "m/s"] and ds["signal"].attrs["units"] == "model units (SI)"
        assert ds.attrs["param_F_m_units"] == "N" and "param_n" not in ds.attrs  # the ramped speed is no constant


def test_displays(steep):
    pytest.importorskip("pandas")
    df = steep.to_dataframe()
    assert list(df.columns) == ["time", "speed", "mesh_order1", "mesh_order2", "mesh_order3"] and len(df) == 8
    np.testing.assert_array_equal(df["mesh_order1"].values, steep.order_amplitude[0, 0])
    assert df.attrs["units"]["speed"] == "rpm"
    page = steep._repr_html_()
    assert page.startswith('<div class="gearsym-repr"><b>RunupResult</b>') and "n 5000 -&gt; 11000 rpm" in page
    assert repr(steep) == ("RunupResult(runup_pair: n 5000 -> 11000 rpm in 0.05 s, 3667 samples, 8 speed bins, "
                           "signal mesh_deflection[mesh])")


def test_cli_runup_json_and_files(tmp_path, capsys):
    rc = main(["runup", str(SCENE), "--duration", "0.05", "--bins", "8", "--no-modes", "--json", "--out",
               str(tmp_path / "o")])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["parameter"] == "n" and info["from"] == 5000 and info["to"] == 11000 and info["duration"] == 0.05
    assert info["n_breaks"] == 333 and info["frequency_unit"] == "Hz"
    assert info["meshes"]["mesh"]["order1_frequency_per_speed"] == pytest.approx(25 / 60, rel=1e-12)
    assert {Path(f).name for f in info["files"]} == {"runup.nc", "campbell.png", "waterfall.png", "orders.png"}


def test_cli_runup_takes_speeds_with_units(tmp_path, capsys):
    rc = main(["runup", str(SCENE), "--from", "500 rad/s", "--duration", "0.02", "--bins", "4", "--no-modes",
               "--json"])
    assert rc == 0
    assert json.loads(capsys.readouterr().out)["from"] == pytest.approx(500 / RPM, rel=1e-12)


@pytest.mark.parametrize(("argv", "match"), [
    (["--param", "m_e"], "not proportional to 1/m_e"),
    (["--duration", "-1"], "--duration"),
    (["--duration", "1", "--rate", "2"], "--duration and --rate"),
    (["--from", "fast"], "--from"),
])
def test_cli_runup_bad_input_exits_2(argv, match, capsys):
    assert main(["runup", str(SCENE), *argv]) == 2
    assert match in capsys.readouterr().err


# ------------------------------------------------------------------ IDA, event speeds
@pytest.fixture(scope="module")
def coupled():
    """The DAE pair with a rigidly coupled load (IDA) and its ODE twin (CVODE), one ramp each."""
    kw = {"parameter": "omega", "start": 16000.0, "stop": 22000.0, "duration": 0.01, "bins": 6, "modes": False,
          "rtol": 1e-10, "atol": 1e-15}
    dae = gearsym.load_scene("spur_pair_coupled_load").compile()
    ode = gearsym.load_scene(DATA / "spur_pair_coupled_load_ode_scene.toml").compile()
    return ode, gearsym.runup(dae, **kw), gearsym.runup(ode, **kw)


def test_a_ramp_on_ida_equals_the_ramp_on_cvode_of_the_ode_twin(coupled):
    ode, a, b = coupled
    assert len(a.event_times) == len(b.event_times) > 20  # contact loss once per mesh cycle
    np.testing.assert_allclose(a.event_times, b.event_times, rtol=0, atol=1e-11)
    for j in range(len(ode.state_names)):
        assert np.max(np.abs(a.states[:, j] - b.states[:, j])) <= 1e-7 * np.ptp(b.states[:, j])


def test_event_speeds_are_the_time_derivative_of_g_along_the_ramp(coupled):
    # the switching functions depend on the speed through the phase of e(t): the engine's event
    # speed (gs_ramp.c eval_swdt) against a central difference of g(t, x(t)) along the run
    ode, _, b = coupled
    i = ode.param_names.index("omega")
    ramp = SpeedRamp(i, 16000.0, 6000.0 / 0.01)
    h = 1e-9
    te = b.event_times[:6]
    t_out = np.sort(np.concatenate([te - h, te + h]))
    p = ode.param_vector({"omega": 16000.0})
    eng = ode.derivative_engine()
    run = eng.run(ode.x0, p, 0.0, 0.01, t_out, method="bdf", rtol=1e-10, atol=1e-15,
                  max_step=b.settings["max_step"], ramp=ramp)
    g = eng.evaluate("sw", t_out, run.y, p, ramp=ramp)
    surfaces = ode.surface_names
    for k, t in enumerate(te):
        j = surfaces.index(b.event_surfaces[k])
        fd = (g[2 * k + 1, j] - g[2 * k, j]) / (2 * h)
        assert b.event_speeds[k] == pytest.approx(fd, rel=1e-4), (t, b.event_speeds[k], fd)


def test_event_speeds_include_the_speed_dependence_outside_the_phase(tmp_path):
    # a clearance whose size follows the speed (g = x - b(t) with b = b_m (1 + cos(w_m t)/5) n/n_ref):
    # dg/dt = v - db/dt has a part a * dg/dn at fixed phase, which the engine takes from gs_swp
    model = (DATA / "runup_pair.toml").read_text().replace(
        'backlash = { expr = "b_m", effect = "backlash" }',
        'backlash = { expr = "b_m*(1 + cos(w_m*t)/5)*n/n_ref", effect = "backlash" }').replace(
        "[parameters]", '[parameters]\nn_ref = { value = 5000.0, unit = "rpm", meaning = "reference speed" }')
    (tmp_path / "m.toml").write_text(model)
    (tmp_path / "s.toml").write_text('[scene]\nmodel = "m.toml"\n[effects]\nbacklash = true\n'
                                     '[parameters]\nF_m = 50.0\ne_a = 20.0\n[simulate]\natol = 1e-16\n')
    system = gearsym.load_scene(tmp_path / "s.toml").compile()
    D = 0.02
    res = gearsym.runup(system, parameter="n", start=5000.0, stop=9000.0, duration=D, bins=4, modes=False,
                        rtol=1e-10, atol=1e-16)
    assert any("build with parameter derivatives" in n for n in res.notes)
    assert len(res.event_times) >= 4
    i = system.param_names.index("n")
    ramp = SpeedRamp(i, 5000.0 * RPM, 4000.0 * RPM / D)
    h = 1e-9
    te = res.event_times[:4]
    t_out = np.sort(np.concatenate([te - h, te + h]))
    p = system.param_vector({"n": 5000.0})
    eng = system.derivative_engine()
    run = eng.run(system.x0, p, 0.0, D, t_out, method=res.settings["method"], rtol=1e-10, atol=1e-16,
                  max_step=res.settings["max_step"], ramp=ramp)
    g = eng.evaluate("sw", t_out, run.y, p, ramp=ramp)
    for k in range(len(te)):
        j = system.surface_names.index(res.event_surfaces[k])
        fd = (g[2 * k + 1, j] - g[2 * k, j]) / (2 * h)
        assert res.event_speeds[k] == pytest.approx(fd, rel=1e-4), (k, res.event_speeds[k], fd)
