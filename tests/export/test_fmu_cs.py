"""The FMU for Co-Simulation, and the mesh outputs of the FMU (issue 29 item 5).

Before: the FMU was Model Exchange only (``fmi2Instantiate`` refused ``fmi2CoSimulation``,
``fmi2DoStep`` reported an error) and had no outputs but the model's ``[outputs]``.  Now
``fmi2DoStep`` integrates each communication step with gearsym's driver (events and
scheduled breakpoints inside the step, as ``System.simulate``), and every mesh gives its
dynamic deflection and its force as outputs.

Checked with an independent FMI client (fmpy: ``validate_fmu``, ``simulate_fmu`` with
``fmi_type="CoSimulation"``) against ``System.simulate`` on the same output grid, the mesh
deflections against :func:`gearsym.analysis.periodic.mesh_deflections` of the reference
trajectory, and the mesh force of the benchmark oscillator against its formula written here.
"""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from gearsym.analysis.periodic import mesh_deflections

fmpy = pytest.importorskip("fmpy")
from fmpy import extract, read_model_description, simulate_fmu  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402


def _outputs(ex) -> list[str]:
    md = read_model_description(str(ex.fmu))
    return [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]


def _cs_and_reference(ex, params, periods, ppp, rtol):
    """fmpy's Co-Simulation run and System.simulate on the same grid, at the same tolerances."""
    T = ex.system.period(params)
    res = simulate_fmu(str(ex.fmu), fmi_type="CoSimulation", start_values=params, stop_time=periods * T,
                       output_interval=T / ppp, relative_tolerance=rtol,
                       output=ex.system.state_names + _outputs(ex) + ["n_events"])
    ratio = ex.system.defaults["atol"] / ex.system.defaults["rtol"]  # the FMU's nominals: atol = rtol * ratio
    ref = ex.system.simulate(periods=periods, n_out=periods * ppp + 1, rtol=rtol, atol=rtol * ratio, params=params)
    assert len(res) == len(ref.t)
    np.testing.assert_allclose(res["time"], ref.t, rtol=1e-13, atol=1e-15)
    return res, ref


def _rel_err(a, b) -> float:
    """max |a - b| relative to the range of b."""
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.ptp(b))


def _ks_mesh_force(p, t, x, v):
    """The benchmark's mesh force written from its model file: stiffness 1 + eps*cos(Omega*t),
    damping 2*zeta, dead zone of half width b."""
    f = np.where(x > p["b"], x - p["b"], np.where(x < -p["b"], x + p["b"], 0.0))
    return (1 + p["eps"] * np.cos(p["Omega"] * t)) * f + 2 * p["zeta"] * v


@pytest.mark.parametrize("name", ["ks", "ts"])
def test_cs_fmu_passes_fmpy_validation(request, name):
    ex = request.getfixturevalue(name)
    assert validate_fmu(str(ex.fmu)) == []
    md = read_model_description(str(ex.fmu))
    assert md.coSimulation is not None and md.modelExchange is not None
    assert md.coSimulation.modelIdentifier == md.modelExchange.modelIdentifier
    assert md.coSimulation.canHandleVariableCommunicationStepSize


def test_ks_impacting_regime_cs_equals_simulate(ks):
    # Omega = 0.9: single-sided impacts (contact loss and re-contact every forcing period)
    params = {"Omega": 0.9}
    res, ref = _cs_and_reference(ks, params, periods=100, ppp=16, rtol=1e-10)
    assert len(ref.events) > 150
    for i, s in enumerate(ks.system.state_names):
        assert _rel_err(res[s], ref.y[:, i]) < 1e-7, s
    d = mesh_deflections(ks.system, ref.t, ref.y, params)["mesh"]
    assert _rel_err(res["mesh_deflection[mesh]"], d) < 1e-7
    p = {**ks.system.params, **params}
    w = _ks_mesh_force(p, ref.t, ref.y[:, 0], ref.y[:, 1])
    assert _rel_err(res["mesh_force[mesh]"], w) < 1e-7
    # the outputs are those of the FMU's own states, to round-off
    w_own = _ks_mesh_force(p, res["time"], res["x"], res["v"])
    assert np.abs(res["mesh_force[mesh]"] - w_own).max() < 1e-12 * np.abs(w_own).max()
    # the same events: the count at every sample
    ev_t = np.array([e.t for e in ref.events])
    np.testing.assert_array_equal(res["n_events"], np.searchsorted(ev_t, ref.t, side="right"))


def test_two_stage_train_rattling_cs_equals_simulate(ts):
    # a light load: both meshes lose contact and hit their back flanks; the rectangular mesh
    # stiffness switches at scheduled breakpoints inside the steps
    params = {"T_in": 5.0}
    res, ref = _cs_and_reference(ts, params, periods=10, ppp=16, rtol=1e-11)
    P1 = float(np.asarray(ts.system.generated.casadi_function("gs_sched")(ts.system.param_vector(params)))[0, 0])
    assert np.any(np.abs(ref.t / P1 - np.round(ref.t / P1)) < 1e-9)  # samples at mesh-1 breakpoints
    surfaces = {e.surface for e in ref.events}
    assert {"mesh1.back", "mesh2.back", "mesh1.drive", "mesh2.drive"} <= surfaces
    assert ref.stats["n_breaks"] > 20
    for i, s in enumerate(ts.system.state_names):
        assert _rel_err(res[s], ref.y[:, i]) < 1e-7, s
    defl = mesh_deflections(ts.system, ref.t, ref.y, params)
    assert set(defl) == {"mesh1", "mesh2"}
    for name, d in defl.items():
        assert _rel_err(res[f"mesh_deflection[{name}]"], d) < 1e-7, name
    # the mesh forces: the model's generated gs_mesh_force on the reference trajectory
    # (the output grid meets the mesh-1 stiffness breakpoints, t = (k + 1/8) T: there the FMU gives the
    # segment that starts at the breakpoint, the one the integration goes on with; System.modes at t
    # gives either side, as t / P rounds, so the segments are taken just after each sample)
    f = ts.system.generated.casadi_function("gs_mesh_force")
    p = ts.system.param_vector(params)
    T = ts.system.period(params)
    modes = ts.system.modes(ref.t + 1e-9 * T, ref.y, p)
    W = np.array([np.asarray(f(t, y, p, m)).ravel() for t, y, m in zip(ref.t, ref.y, modes)])
    for k, name in enumerate(["mesh1", "mesh2"]):
        assert _rel_err(res[f"mesh_force[{name}]"], W[:, k]) < 1e-7, name
    # mean load: the mesh force swings about T_in / r_b1 (N), the units say so
    rb1 = 1.5e-3 * 40 * np.cos(np.radians(20.0)) / 2
    assert 0.5 * 5.0 / rb1 < np.mean(res["mesh_force[mesh1]"]) < 2.0 * 5.0 / rb1
    assert res["n_events"][-1] == len(ref.events)


def test_mesh_outputs_units(ks, ts):
    v = {x.name: x for x in read_model_description(str(ts.fmu)).modelVariables}
    assert (v["mesh_deflection[mesh1]"].unit, v["mesh_force[mesh2]"].unit) == ("m", "kg*m*s^-2")
    assert v["mesh_force[mesh1]"].causality == "output" and v["mesh_force[mesh1]"].variability == "continuous"
    k = {x.name: x for x in read_model_description(str(ks.fmu)).modelVariables}
    assert k["mesh_deflection[mesh]"].unit is None and k["mesh_force[mesh]"].unit is None  # dimensionless model


def _slave(ex, tolerance=1e-10):
    md = read_model_description(str(ex.fmu))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(ex.fmu)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cs")
    fmu.instantiate()
    fmu.setupExperiment(tolerance=tolerance, startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return md, fmu


def test_cs_tunable_parameter_between_steps(ks):
    md, fmu = _slave(ks)
    v = {x.name: x.valueReference for x in md.modelVariables}
    T = ks.system.period({"Omega": 0.9})
    t, h = 0.0, T / 8
    for _ in range(80):  # 10 periods at Omega = 0.9
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    x1 = fmu.getReal([v["x"], v["v"]])
    sides = fmu.getInteger([v["sigma[mesh.drive]"], v["sigma[mesh.back]"]])
    fmu.setReal([v["Omega"]], [1.1])
    for _ in range(40):
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    x2 = fmu.getReal([v["x"], v["v"]])
    assert fmu.getRealStatus(2) == pytest.approx(t, rel=1e-15)  # fmi2LastSuccessfulTime
    fmu.terminate()
    fmu.freeInstance()
    ratio = ks.system.defaults["atol"] / ks.system.defaults["rtol"]
    a = ks.system.simulate(t_end=10 * T, n_out=2, rtol=1e-10, atol=1e-10 * ratio, params={"Omega": 0.9})
    np.testing.assert_allclose(x1, a.y[-1], rtol=0, atol=1e-7 * np.abs(a.y).max())
    b = ks.system.simulate(t0=10 * T, t_end=t, x0=x1, sigma0=[float(s) for s in sides], n_out=2, rtol=1e-10,
                           atol=1e-10 * ratio, params={"Omega": 1.1})
    np.testing.assert_allclose(x2, b.y[-1], rtol=0, atol=1e-7 * max(np.abs(b.y).max(), 1.0))


def test_cs_refuses_misuse(ks):
    md, fmu = _slave(ks)
    with pytest.raises(FMICallException):  # the communication point is not the time reached
        fmu.doStep(currentCommunicationPoint=1.0, communicationStepSize=0.1)
    md, fmu = _slave(ks)
    fn = fmu.dll.fmi2SetTime  # a Model Exchange call on a Co-Simulation instance: fmi2Error (3)
    fn.argtypes, fn.restype = [ctypes.c_void_p, ctypes.c_double], ctypes.c_int
    assert fn(fmu.component, 1.0) == 3
    v = {x.name: x.valueReference for x in md.modelVariables}
    with pytest.raises(FMICallException):  # a state is not set after initialisation
        fmu.setReal([v["x"]], [0.5])
    fmu.setReal([v["Omega"]], [0.8])  # a tunable parameter is
    with pytest.raises(FMICallException):
        fmu.setReal([v["b"]], [float("nan")])


def test_cs_fmu_runs_without_gearsym_or_its_environment(ks, tmp_path):
    # a process that imports only fmpy, with no library path: the binary finds the SUNDIALS
    # libraries shipped beside it (run path $ORIGIN), not the exporting environment's
    d = tmp_path / "unzipped"
    extract(str(ks.fmu), str(d))
    binary = next((d / "binaries" / "linux64").glob("kahraman_singh.so"))
    if shutil.which("ldd"):
        env = {k: val for k, val in os.environ.items() if k != "LD_LIBRARY_PATH"}
        out = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, env=env).stdout
        for name, path in re.findall(r"^\s*(\S+) => (.+?) \(0x[0-9a-f]+\)$", out, flags=re.M):
            if "sundials" in name:
                assert path.startswith(str(binary.parent) + "/"), (name, path)
    code = ("import sys\nfrom fmpy import simulate_fmu\n"
            "r = simulate_fmu(sys.argv[1], fmi_type='CoSimulation', stop_time=10*6.981317007977318, "
            "output_interval=6.981317007977318/8, start_values={'Omega': 0.9}, output=['x', 'n_events'])\n"
            "assert 'gearsym' not in sys.modules and 'sksundae' not in sys.modules\n"
            "print(repr(float(r['x'][-1])), int(r['n_events'][-1]))\n")
    env = {k: val for k, val in os.environ.items() if k != "LD_LIBRARY_PATH" and k != "PYTHONPATH"}
    run = subprocess.run([sys.executable, "-c", code, str(ks.fmu)], capture_output=True, text=True, env=env,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    x_end, n_ev = run.stdout.split()
    ratio = ks.system.defaults["atol"] / ks.system.defaults["rtol"]
    ref = ks.system.simulate(periods=10, n_out=2, rtol=1e-8, atol=1e-8 * ratio, params={"Omega": 0.9})
    assert abs(float(x_end) - ref.y[-1, 0]) < 1e-6 and int(n_ev) == len(ref.events)


def test_mesh_output_directional_derivatives(ks):
    # in drive-side contact (x > b) the benchmark's mesh force is (1 + eps cos(Omega t)) (x - b) + 2 zeta v:
    # its derivatives by x and v are the stiffness and the damping; the deflection's are 1 and 0
    from fmpy.fmi2 import FMU2Model

    md = read_model_description(str(ks.fmu))
    v = {x.name: x.valueReference for x in md.modelVariables}
    m = FMU2Model(guid=md.guid, unzipDirectory=extract(str(ks.fmu)),
                  modelIdentifier=md.modelExchange.modelIdentifier, instanceName="me")
    m.instantiate()
    m.setupExperiment(startTime=0.0)
    m.setReal([v["x"], v["v"]], [1.7, 0.3])
    m.enterInitializationMode()
    m.exitInitializationMode()
    m.newDiscreteStates()
    m.enterContinuousTimeMode()
    t = 2.0
    m.setTime(t)
    p = ks.system.params
    unknown = [v["mesh_force[mesh]"], v["mesh_deflection[mesh]"]]
    dx = m.getDirectionalDerivative(unknown, [v["x"]], [1.0])
    dv = m.getDirectionalDerivative(unknown, [v["v"]], [1.0])
    k = 1 + p["eps"] * np.cos(p["Omega"] * t)
    np.testing.assert_allclose(dx, [k, 1.0], rtol=1e-14)
    np.testing.assert_allclose(dv, [2 * p["zeta"], 0.0], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(m.getReal(unknown), [k * (1.7 - p["b"]) + 2 * p["zeta"] * 0.3, 1.7], rtol=1e-14)
    m.terminate()
    m.freeInstance()


def test_mesh_force_of_a_reduced_model():
    # spur_pair_torsional is reduced to its DTE x = rb1 th1 - rb2 th2 - e_s: the mesh force in the
    # reduced state is (k_m + k_a cos(omega t)) f(x) + c_m v, f the dead zone of half width b_m
    import gearsym

    from .conftest import scene_path

    system = gearsym.load_scene(scene_path("spur_pair_torsional")).compile()
    assert system.state_names == ["x", "v"]
    f = system.generated.casadi_function("gs_mesh_force")
    p = {**system.params, **system.units.to_si(system.params)}
    pv = system.param_vector()
    b = p["b_m"]
    for t, x, v in [(1e-4, 2.5 * b, 0.3), (3e-4, 0.2 * b, -0.1), (7e-4, -1.7 * b, 0.05)]:
        m = system.modes(np.array([t]), np.array([[x, v]]), pv)[0]
        fx = x - b if x > b else (x + b if x < -b else 0.0)
        ref = (p["k_m"] + p["k_a"] * np.cos(p["omega"] * t)) * fx + p["c_m"] * v
        assert float(f(t, [x, v], pv, m)) == pytest.approx(ref, rel=1e-13, abs=1e-12 * p["k_m"] * b)
