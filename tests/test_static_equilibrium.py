"""The static equilibrium of multi-coordinate models against hand-written equations.

Every reference below is written from the physics of the model (free-body balances of
the wheels, the bearings and the clearances, the mean of each time-varying term taken
by hand) and solved with :func:`scipy.optimize.root`; none uses gearsym's generated
functions.  The models (tests/data):

* ``rotor_transverse_torsional.toml``: a 4-DOF transverse-torsional spur pair (pinion
  and gear on bearings, their centres y1, y2 along the line of action), reduced to the
  rotational deflection ``p = rb1 th1 - rb2 th2`` with y1, y2 kept (``[reduction]
  keep``), and the same model with three named reduced coordinates; a varying stiffness
  times a transmission error of the same frequency, whose mean product counts.
* ``clutch_gear_pair.toml``: a spur pair behind a clutch with clearance, with a pump on a
  spline with clearance: three clearances, loaded, reversed, and one under no mean load
  (which rests in the centre of its clearance).
* ``models/two_stage_train_deflections.toml``: the shipped two-stage train.
* the ``gearsym init`` template with a 2e13 N/m contact.

``gearsym modes`` on them is checked against the eigenvalues of a hand linearisation.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import root

import gearsym
from gearsym import static
from gearsym.analysis.linear import modal_analysis
from gearsym.cli import main
from gearsym.cli.catalog import init_files
from gearsym.errors import SpecError

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"
ROTOR = DATA / "rotor_transverse_torsional.toml"
CLUTCH = DATA / "clutch_gear_pair.toml"

#: the rotor reduced with three named coordinates instead of `keep` (the issue's form)
ROTOR_COORDINATES = """[reduction.coordinates.p]
definition = "rb1*th1 - rb2*th2"
unit = "m"
velocity = "pv"
[reduction.coordinates.z1]
definition = "y1"
unit = "m"
velocity = "z1v"
[reduction.coordinates.z2]
definition = "y2"
unit = "m"
velocity = "z2v"

"""


def write_scene(folder: Path, model: Path, name: str, body: str = "") -> Path:
    path = folder / f"{name}.toml"
    path.write_text(f'[scene]\nname = "{name}"\nmodel = {json.dumps(str(model))}\n{body}')
    return path


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    return tmp_path_factory.mktemp("static_builds")


@pytest.fixture(scope="module")
def rotor(builds):
    scene = gearsym.load_scene(write_scene(builds, ROTOR, "rotor_tt"))
    return scene, scene.compile(generated_dir=builds)


@pytest.fixture(scope="module")
def rotor_coordinates(builds):
    text = ROTOR.read_text()
    i, j = text.index("\n[reduction]\n") + 1, text.index("\n[initial]\n") + 1
    model = builds / "model_rotor_tt_coordinates.toml"
    model.write_text(text[:i].replace('name = "rotor_transverse_torsional"', 'name = "rotor_tt_coordinates"')
                     + ROTOR_COORDINATES + text[j:])
    scene = gearsym.load_scene(write_scene(builds, model, "rotor_tt_coordinates"))
    return scene, scene.compile(generated_dir=builds)


@pytest.fixture(scope="module")
def clutch(builds):
    scene = gearsym.load_scene(write_scene(builds, CLUTCH, "clutch_gear_pair"))
    return scene, scene.compile(generated_dir=builds)


# ------------------------------------------------------------------ hand references
def rotor_by_hand(v: dict[str, float]) -> np.ndarray:
    """(p, y1, y2) at rest: the mean mesh force W balances the torques through the reduced
    pair and pushes the centres apart against the bearings.  In drive-side contact the
    mesh force is k(t) (delta - b - e(t)) with k = k_m + k_a cos(w t), e = e_a cos(w t):
    its mean is k_m (delta - b) - k_a e_a / 2."""
    def mean_force(d):  # d = delta - b, the deflection past the drive flank
        return v["k_m"] * d - v["k_a"] * v["e_a"] / 2

    m_e = 1 / (v["rb1"] ** 2 / v["J1"] + v["rb2"] ** 2 / v["J2"])

    def residual(z):  # unknowns in N and um, equations in N
        W, y1, y2, d = z[0] * 1e3, z[1] * 1e-6, z[2] * 1e-6, z[3] * 1e-6
        return [m_e * (v["rb1"] * (v["T1"] - v["rb1"] * W) / v["J1"] - v["rb2"] * (v["rb2"] * W - v["T2"]) / v["J2"]),
                -W - v["k_b1"] * y1, W - v["k_b2"] * y2, W - mean_force(d)]

    sol = root(residual, [1.0, 0.0, 0.0, 0.0], method="hybr", options={"xtol": 1e-14})
    W, y1, y2, d = sol.x * [1e3, 1e-6, 1e-6, 1e-6]
    assert np.abs(residual(sol.x)).max() <= 1e-12 * abs(W)
    assert W > 0  # drive-side contact, as assumed
    return np.array([v["b_m"] + d - y1 + y2, y1, y2])  # p = delta - y1 + y2


def rotor_linearisation(v: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``M``, ``K``, ``C`` of the rotor in (p, y1, y2) about a drive-side contact, mean stiffness.

    p'' = rb1 th1'' - rb2 th2'' = (rb1 T1/J1 + rb2 T2/J2) - W/m_e,   m1 y1'' = -W - k_b1 y1 - c_b1 y1',
    m2 y2'' = W - k_b2 y2 - c_b2 y2',   W = k_m (p + y1 - y2 - b) + c_m (p' + y1' - y2') + ...
    """
    m_e = 1 / (v["rb1"] ** 2 / v["J1"] + v["rb2"] ** 2 / v["J2"])
    g = np.array([1.0, 1.0, -1.0])  # d(delta)/d(p, y1, y2)
    M = np.diag([m_e, v["m1"], v["m2"]])
    K = v["k_m"] * np.outer(g, g) + np.diag([0.0, v["k_b1"], v["k_b2"]])
    C = v["c_m"] * np.outer(g, g) + np.diag([0.0, v["c_b1"], v["c_b2"]])
    return M, K, C


def frequencies(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Undamped natural frequencies in Hz (ascending) from det(K - w^2 M) = 0."""
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    return np.sqrt(np.clip(w2, 0.0, None)) / (2 * math.pi)


def clutch_by_hand(v: dict[str, float]) -> tuple[np.ndarray, dict[str, str]]:
    """(x_clutch, x_mesh, x_spline) at rest and the contact states.

    Free bodies: Jm thm'' = T_m - Tc, J1 th1'' = Tc - rb1 W, J2 th2'' = rb2 W - Ts - T2,
    Ja tha'' = Ts - T_a; at rest the deflection accelerations vanish (the train may turn
    as a whole: unbalanced torques accelerate it and the pump's inertia then loads the
    spline).  Each clearance rests at F/k + b (F > 0), F/k - b (F < 0), or in its centre
    under no mean load; x_mesh is the dynamic deflection (deflection - error), so its
    mean force is k_m (x_mesh - b_m) in contact."""
    def residual(F):
        Tc, W, Ts = F[0] * 10, F[1] * 1e3, F[2]
        a_m, a_1 = (v["T_m"] - Tc) / v["Jm"], (Tc - v["rb1"] * W) / v["J1"]
        a_2, a_a = (v["rb2"] * W - Ts - v["T2"]) / v["J2"], (Ts - v["T_a"]) / v["Ja"]
        return [(a_m - a_1) / 1e4, (v["rb1"] * a_1 - v["rb2"] * a_2) / 1e2, (a_2 - a_a) / 1e4]

    sol = root(residual, [v["T_m"] / 10, v["T_m"] / v["rb1"] / 1e3, 0.0], method="hybr", options={"xtol": 1e-14})
    assert np.abs(residual(sol.x)).max() <= 1e-12 * abs(v["T_m"])
    Tc, W, Ts = sol.x * [10, 1e3, 1]
    x, contact = [], {}
    for name, F, k, b, scale in (("clutch", Tc, v["k_c"], v["b_c"], abs(Tc) + abs(v["T_m"])),
                                 ("mesh", W, v["k_m"], v["b_m"], abs(W) + abs(v["T_m"]) / v["rb1"]),
                                 ("spline", Ts, v["k_s"], v["b_s"], abs(v["T_m"]))):
        if abs(F) <= 1e-9 * scale:
            x.append(0.0)
            contact[name] = "separated"
        else:
            x.append(F / k + math.copysign(b, F))
            contact[name] = "drive" if F > 0 else "back"
    return np.array(x), contact


def clutch_linearisation(v: dict[str, float], contact: dict[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """``M^-1 K`` of the clutch model in (x_clutch, x_mesh, x_spline): the deflection
    accelerations of the free bodies above with Tc = k_c x_c, W = k_m x_m, Ts = k_s x_s
    (a separated clearance: no stiffness)."""
    kc = v["k_c"] if contact["clutch"] != "separated" else 0.0
    ks = v["k_s"] if contact["spline"] != "separated" else 0.0
    km = v["k_m"]
    A = np.array([
        [kc * (1 / v["Jm"] + 1 / v["J1"]), -v["rb1"] * km / v["J1"], 0.0],
        [-v["rb1"] * kc / v["J1"], km * (v["rb1"] ** 2 / v["J1"] + v["rb2"] ** 2 / v["J2"]), -v["rb2"] * ks / v["J2"]],
        [0.0, -v["rb2"] * km / v["J2"], ks * (1 / v["J2"] + 1 / v["Ja"])]])
    return np.eye(3), A


# ------------------------------------------------------------------ the rotor
@pytest.mark.parametrize("which", ["rotor", "rotor_coordinates"])
def test_rotor_static_state_is_the_hand_equilibrium(which, request):
    scene, system = request.getfixturevalue(which)
    q = rotor_by_hand(scene.resolved.values)
    assert system.x0[:3] == pytest.approx(q, rel=1e-10, abs=0)
    assert np.all(system.x0[3:] == 0.0)
    assert q[0] > 5.6e-5 and q[1] < -1e-6 < 1e-6 < q[2]  # not the first coordinate alone


def test_rotor_static_state_follows_overrides_and_reversal(rotor):
    scene, system = rotor
    for override in ({"T1": 30.0, "T2": 37.5, "k_b1": 2e8}, {"T1": -60.0, "T2": -75.0}):
        v = dict(scene.resolved.values, **override)
        eq = static.static_equilibrium(system, override)
        if override["T1"] > 0:
            assert eq.q == pytest.approx(rotor_by_hand(v), rel=1e-10, abs=0)
            assert eq.contact == {"mesh": "drive"}
        else:  # back flank: mean force k_m (delta + b) - k_a e_a/2 = -F
            assert eq.contact == {"mesh": "back"}
            m_e = 1 / (v["rb1"] ** 2 / v["J1"] + v["rb2"] ** 2 / v["J2"])
            W = m_e * (v["rb1"] * v["T1"] / v["J1"] + v["rb2"] * v["T2"] / v["J2"])
            y1, y2 = -W / v["k_b1"], W / v["k_b2"]
            delta = (W + v["k_a"] * v["e_a"] / 2) / v["k_m"] - v["b_m"]
            assert eq.q == pytest.approx([delta - y1 + y2, y1, y2], rel=1e-10, abs=0)


def test_rotor_mesh_deflection_is_the_hand_one(rotor):
    """`keep` with a `mesh` element (compiled with "symbol 'th1' has no value" before): the
    per-mesh deflection is p + y1 - y2 - e(t)."""
    scene, system = rotor
    v = scene.resolved.values
    t = np.linspace(0.0, 2 * math.pi / v["omega"], 7)
    X = np.tile([6.1e-5, -2e-6, 3e-6, 0.1, 0.2, -0.3], (len(t), 1))
    got = system.mesh_deflections(t, X)[:, 0]
    assert got == pytest.approx(6.1e-5 - 2e-6 - 3e-6 - v["e_a"] * np.cos(v["omega"] * t), rel=1e-13)


def test_rotor_modes_are_the_hand_eigenvalues(rotor):
    scene, system = rotor
    v = scene.resolved.values
    res = modal_analysis(system)
    assert res.equilibrium == pytest.approx(rotor_by_hand(v), rel=1e-10, abs=0)
    M, K, C = rotor_linearisation(v)
    assert res.frequencies_hz == pytest.approx(frequencies(M, K), rel=1e-10)
    # modal damping ratios phi^T C phi / (2 w phi^T M phi) of the same M, K, C
    import scipy.linalg as sla

    w2, V = sla.eigh(K, M)
    zeta = np.einsum("ik,ij,jk->k", V, C, V) / (2 * np.sqrt(w2) * np.einsum("ik,ij,jk->k", V, M, V))
    assert res.damping_ratios == pytest.approx(zeta, rel=1e-9)
    assert res.contact == {"mesh": "drive"}


def test_cli_modes_on_the_rotor(rotor, builds, monkeypatch, capsys):
    scene, _ = rotor
    monkeypatch.setenv("GEARSYM_GENERATED", str(builds))
    assert main(["modes", str(scene.path), "--json", "--set", "k_b2=5e8"]) == 0
    d = json.loads(capsys.readouterr().out)
    v = dict(scene.resolved.values, k_b2=5e8)
    assert [d["equilibrium"][k] for k in ("p", "y1", "y2")] == pytest.approx(rotor_by_hand(v), rel=1e-10, abs=0)
    assert d["frequencies_hz"] == pytest.approx(frequencies(*rotor_linearisation(v)[:2]), rel=1e-10)


def test_static_start_refuses_a_moving_kept_coordinate(builds):
    path = write_scene(builds, ROTOR, "rotor_tt_moving", "[initial]\nu1 = 0.1\n")
    with pytest.raises(SpecError, match=r"initial\.u1.*starts at rest"):
        gearsym.load_scene(path)


# ------------------------------------------------------------------ three clearances
@pytest.mark.parametrize("override", [
    {},                                   # balanced torques: the pump's spline carries nothing
    {"T_m": -60.0, "T2": -75.0},          # reversed: back flanks, spline still unloaded
    {"T_a": 3.0},                         # pump drag: the spline closes on its drive flank
    {"T2": 80.0},                         # unbalanced: the train decelerates, the pump's inertia loads the spline
])
def test_clutch_pair_static_state_is_the_hand_equilibrium(override, clutch):
    scene, system = clutch
    v = dict(scene.resolved.values, **override)
    want, contact = clutch_by_hand(v)
    eq = static.static_equilibrium(system, override)
    assert eq.contact == contact
    assert eq.q == pytest.approx(want, rel=1e-10, abs=1e-15 * v["b_s"])
    if not override:
        assert system.x0[:3] == pytest.approx(want, rel=1e-10, abs=1e-15 * v["b_s"])
        assert contact == {"clutch": "drive", "mesh": "drive", "spline": "separated"}


@pytest.mark.parametrize("override", [{}, {"T_a": 3.0}])
def test_clutch_pair_modes_are_the_hand_eigenvalues(override, clutch):
    scene, system = clutch
    v = dict(scene.resolved.values, **override)
    want, contact = clutch_by_hand(v)
    res = modal_analysis(system, override)
    assert res.contact == contact
    assert res.equilibrium == pytest.approx(want, rel=1e-10, abs=1e-15 * v["b_s"])
    f = frequencies(*clutch_linearisation(v, contact))
    assert res.frequencies_hz == pytest.approx(f, rel=1e-10, abs=1e-6)
    assert (res.frequencies_hz[0] == 0.0) == (contact["spline"] == "separated")  # the free pump


# ------------------------------------------------------------------ two-stage train, stiff contact
def test_two_stage_train_static_state_is_the_hand_equilibrium(tmp_path):
    path = write_scene(tmp_path, REPO / "models" / "two_stage_train_deflections.toml",
                       "two_stage_train_deflections", "[initial]\nstatic = true\n")
    scene = gearsym.load_scene(path)
    system = scene.compile()  # the shipped scene's build (same name, model and effects)
    v = scene.resolved.values
    rb = [v["m_n"] * v[f"z{i}"] * math.cos(v["alpha"]) / 2 for i in range(1, 5)]
    disc = [math.pi * v["rho"] * b * (v["m_n"] * v[z] / 2) ** 4 / 2 for b, z in
            ((v["b1"], "z1"), (v["b1"], "z2"), (v["b2"], "z3"), (v["b2"], "z4"))]
    J = [disc[0] + v["J_mot"], disc[1], disc[2], disc[3] + v["J_load"]]
    T_out = v["T_in"] * rb[1] / rb[0] * rb[3] / rb[2]
    # mean of a rectangular stiffness: r_k k_min over eps - 1 of the cycle, k_min over 2 - eps
    k1 = v["c_s1"] * v["b1"] * (v["r_k"] * (v["eps1"] - 1) + 2 - v["eps1"])
    k2 = v["c_s1"] * v["b2"] * (v["r_k"] * (v["eps2"] - 1) + 2 - v["eps2"])
    k_s = v["G_s"] * math.pi * v["d_s"] ** 4 / (32 * v["L_s"])

    def residual(F):  # wheel accelerations; the deflection accelerations vanish
        W1, Ts, W2 = F[0] * 1e3, F[1] * 1e2, F[2] * 1e3
        a = [(v["T_in"] - rb[0] * W1) / J[0], (rb[1] * W1 - Ts) / J[1], (Ts - rb[2] * W2) / J[2],
             (rb[3] * W2 - T_out) / J[3]]
        return [rb[0] * a[0] - rb[1] * a[1], a[1] - a[2], rb[2] * a[2] - rb[3] * a[3]]

    sol = root(residual, [1.0, 1.0, 1.0], method="hybr", options={"xtol": 1e-14})
    assert np.abs(residual(sol.x)).max() <= 1e-12 * v["T_in"] / J[0]
    W1, Ts, W2 = sol.x * [1e3, 1e2, 1e3]
    want = [v["bh1"] + W1 / k1, Ts / k_s, v["bh2"] + W2 / k2]
    assert system.state_names[:3] == ["x_mesh1", "x_shaft", "x_mesh2"]
    assert system.x0[:3] == pytest.approx(want, rel=1e-10, abs=0)


def test_stiff_contact_static_state(tmp_path):
    """A 2e13 N/m contact (the template's pair): x_s = b + (F + k_a e_a/2)/k to the round-off of
    the state (the static solve stopped "not making good progress" before)."""
    model_text, scene_text = init_files("stiff")
    (tmp_path / "models").mkdir()
    (tmp_path / "scenes").mkdir()
    (tmp_path / "models" / "stiff.toml").write_text(model_text)
    (tmp_path / "scenes" / "stiff.toml").write_text(scene_text)
    for k in (2e13, 2e15):
        scene = gearsym.load_scene(tmp_path / "scenes" / "stiff.toml", k_m=k)
        system = scene.compile(generated_dir=tmp_path / "builds")
        v = scene.resolved.values
        assert system.x0[0] == pytest.approx(v["b_m"] + (v["F_m"] + v["k_a"] * v["e_a"] / 2) / k, rel=1e-14)
        eq = static.static_equilibrium(system, {"k_m": k, "F_m": -v["F_m"]})  # reversed: the back flank
        assert eq.contact == {"mesh": "back"}
        assert eq.q[0] == pytest.approx(-v["b_m"] + (-v["F_m"] + v["k_a"] * v["e_a"] / 2) / k, rel=1e-14)
    # no mean load: the pair rests in the centre of its backlash (mean deflection x - e = 0); with
    # no backlash either it touches where the mean force k_m x - k_a e_a/2 vanishes
    eq = static.static_equilibrium(system, {"F_m": 0.0})
    assert eq.contact == {"mesh": "separated"} and abs(eq.q[0]) < 1e-15 * v["b_m"]
    eq = static.static_equilibrium(system, {"F_m": 0.0, "b_m": 0.0})
    assert eq.contact["mesh"] in ("drive", "back")
    assert eq.q[0] == pytest.approx(v["k_a"] * v["e_a"] / 2 / v["k_m"], rel=1e-12)


def test_stiff_contacts_of_the_rotor(rotor):
    scene, system = rotor
    override = {"k_m": 2e13, "k_b1": 2e13, "k_b2": 4e12}
    eq = static.static_equilibrium(system, override)
    assert eq.q == pytest.approx(rotor_by_hand(dict(scene.resolved.values, **override)), rel=1e-10, abs=0)


# ------------------------------------------------------------------ reductions: compile failures name the field
PROBE = """
[elements.probe]
type = "mesh"
meaning = "a mesh the reduction does not describe (no stiffness, so the equations still close)"
deflection = "{deflection}"
stiffness = "0*k_m"
"""


@pytest.mark.parametrize("model, deflection", [(REPO / "models" / "spur_pair_torsional.toml", "rb1*th1"),
                                               (ROTOR, "rb1*th1 + y1")])
def test_a_deflection_the_reduction_does_not_describe_names_its_field(model, deflection, tmp_path):
    """Was the internal 'symbol ... has no value in the generated function' (exit 1, no field)."""
    text = model.read_text()
    i = text.index("\n[reduction]\n")
    changed = tmp_path / "model_probe.toml"
    changed.write_text(text[:i] + PROBE.format(deflection=deflection) + text[i:])
    scene = gearsym.load_scene(write_scene(tmp_path, changed, "probe", "[initial]\nstatic = false\n"))
    with pytest.raises(SpecError, match=r"field 'elements\.probe\.deflection'.*still depends on th2"):
        scene.compile(generated_dir=tmp_path / "builds")


def test_modes_average_a_mesh_harmonic_of_a_long_forcing_period():
    """Liu et al.'s noncircular face gear: the forcing period (the instantaneous-centre cycle)
    holds Z2 = 64 mesh cycles.  The mean over it of k(t) rb2(t)^2, with k = k0 + kr sin(Z2 w_c t + .)
    and rb2 = L (1 + beta cos(w_c t)), is k0 L^2 (1 + beta^2/2); of k rb2 it is k0 L.  So in
    drive-side contact (rb2 q < -b) the mean torque balance k0 (L^2 (1 + beta^2/2) q + L b) = -T2
    and w^2 = k0 L^2 (1 + beta^2/2) / I2, damping ratio zeta.  (32 equally spaced samples alias
    the mesh harmonic to k0 + kr; the earlier default took them, and the contact per sample.)"""
    scene = gearsym.load_scene(REPO / "scenes" / "liu_nfg_140.toml")
    system = scene.compile()
    v = scene.resolved.values
    beta = 2 * v["eps"] / (1 + v["eps"] ** 2)
    L = v["rb1"] * v["Z2"] / v["Z1"] * (1 + v["eps"] ** 2) / (1 - v["eps"] ** 2)
    m2 = L ** 2 * (1 + beta ** 2 / 2)
    res = modal_analysis(system)
    assert res.equilibrium == pytest.approx([-(v["T2"] / v["k0"] + v["b"] * L) / m2], rel=1e-10)
    assert res.frequencies_hz == pytest.approx([math.sqrt(v["k0"] * m2 / v["I2"]) / (2 * math.pi)], rel=1e-10)
    assert res.damping_ratios == pytest.approx([v["zeta"]], rel=1e-10)
    assert res.contact == {"mesh": "drive"}
