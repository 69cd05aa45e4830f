"""Vaishya & Singh (JSV 2001): spur pair with rectangular mesh stiffness/damping and
Coulomb sliding friction (models/vaishya_singh.toml, scenes/vaishya_singh_*.toml).

References used here, all independent of gearsym's derivation:

* Table 1 and eqs. 1-4, 9, 12-20, 32-33 of the paper, evaluated by hand with the
  readings documented in the model file (k = k_max / k_min, the double-contact
  friction term with the sign that follows from eqs. 4 and 7-9, gear moment arms
  (R_p + R_g)*tan(phi) - zeta_p);
* the exact monodromy of the frictionless undamped model as a product of matrix
  exponentials over the segments;
* the variational equations of formulation B integrated with scipy at tight
  tolerance (the coefficients vary within the single-contact segments);
* a scipy solution of the combined scene with a hand-written right-hand side that
  stops at every breakpoint.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl
import sympy as sp
from scipy.integrate import solve_ivp

import gearsym
from gearsym.cli import main as cli_main

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
FIG3 = SCENES / "vaishya_singh_fig3.toml"
FRICTION = SCENES / "vaishya_singh_friction.toml"
PARAMETRIC = SCENES / "vaishya_singh_parametric.toml"
FIG6 = SCENES / "vaishya_singh_fig6.toml"

# ---------------------------------------------------------------- hand values
# Table 1 and the readings of the model file (pressure angle, inertias, t_b share)
PI_P, PI_G = 25, 31
A_C = 88.9e-3
PHI = math.radians(25.0)
R_P = A_C * PI_P / (PI_P + PI_G) * math.cos(PHI)
R_G = A_C * PI_G / (PI_P + PI_G) * math.cos(PHI)
J_P, J_G = 1.0807e-3, 2.5550e-3           # solid discs, J_g/J_p = (31/25)^4
J_T = J_P * R_G**2 + J_G * R_P**2            # eq. 15b
M_E = J_P * J_G / J_T                         # J_e/J_t, eqs. 9, 15a
K_MAX = 7.2e8
K_MIN = K_MAX / 1.667
T_IN = 226.0
N0 = T_IN / R_P                               # eq. 1
MU0 = 0.1
R_AP = 0.500698                               # t_b/(Gamma*t_c) = 1.148/(1.433*1.6)
P_B = 2 * math.pi * R_P / PI_P                # base pitch R_p*alpha_m
L_12 = (R_P + R_G) * math.tan(PHI)


def rpm(n: float) -> float:
    """rpm -> rad/s."""
    return n * 2 * math.pi / 60


def mesh_period(n_rpm: float) -> float:
    """Eq. 33: t_c = 60/(Omega_p*Pi_p)."""
    return 60.0 / (n_rpm * PI_P)


def friction_factor(phase: float, gamma: float, seg: int | None = None) -> float:
    """F_f/N of eq. 9 divided by J_t, per unit normal load (eqs. 1, 4, 12-14, 20).

    Double contact: +mu0*alpha_m*R_p*(J_p R_g - J_g R_p)/(2 J_t) (the sign derived from
    eqs. 4, 7-9; eq. 12 prints a minus); single contact: +-mu0*(R_p J_g zeta_p2 +
    R_g J_p zeta_g2)/J_t before/after the pitch point (eq. 13 prints zeta_p1 for the
    gear arm zeta_g2).  ``seg`` overrides the segment found from the phase (at the
    right end of a segment).
    """
    seg = segment(phase, gamma) if seg is None else seg
    z_p2 = R_P * math.tan(PHI) + P_B * (phase - R_AP * gamma)
    z_g2 = L_12 - z_p2
    if seg == 0:
        return MU0 * P_B * (J_P * R_G - J_G * R_P) / (2 * J_T)
    single = MU0 * (R_P * J_G * z_p2 + R_G * J_P * z_g2) / J_T
    return single if seg == 1 else -single


def segment(phase: float, gamma: float) -> int:
    """Segment of the mesh cycle: 0 double contact, 1/2 single before/after the pitch point."""
    return 0 if phase < gamma - 1 else (1 if phase < R_AP * gamma else 2)


def k_c(seg: int, zeta: float) -> tuple[float, float]:
    """Rectangular stiffness and damping of a segment (c = 2*zeta*sqrt(m_e*k))."""
    k = K_MAX if seg == 0 else K_MIN
    return k, 2 * zeta * math.sqrt(M_E * k)


def breaks(gamma: float, T: float, n: int) -> list[float]:
    """All breakpoints of n mesh cycles from t = 0."""
    out = []
    for i in range(n):
        out += [i * T, (i + gamma - 1) * T, (i + R_AP * gamma) * T]
    return out + [n * T]


# ----------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def parametric():
    return gearsym.load_scene(PARAMETRIC).compile()


@pytest.fixture(scope="module")
def fig6():
    return gearsym.load_scene(FIG6).compile()


def _values(path: Path) -> dict[str, float]:
    return gearsym.load_scene(path).resolved.values


# --------------------------------------------------------------- Table 1
def test_table1_breakpoints_and_inspect(capsys):
    """Breakpoint times of the mesh cycle at 1500 rpm (Table 1: 0.693, 1.148, 1.600 ms)
    from the symbolic schedule and from `gearsym inspect --json`."""
    scene = gearsym.load_scene(FIG3)
    vals = {sp.Symbol(k, real=True): v for k, v in scene.resolved.values.items()}
    (sched,) = scene.model.schedules
    T = float(sched.period.subs(vals))
    fr = [float(b.subs(vals)) for b in sched.breaks]
    assert T == pytest.approx(mesh_period(1500.0), rel=1e-14)
    assert T * 1e3 == pytest.approx(1.600, abs=1e-12)
    assert fr[0] == 0.0
    assert fr[1] * T * 1e3 == pytest.approx(0.693, abs=5e-4)        # t_a = (Gamma - 1)*t_c
    assert fr[1] * T == pytest.approx(0.433 * mesh_period(1500.0), rel=1e-12)
    assert fr[2] * T * 1e3 == pytest.approx(1.148, abs=1e-6)        # t_b, the pitch point
    assert cli_main(["inspect", str(FIG3), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    (bp,) = info["breakpoints"]
    assert bp["schedule"] == "mesh"
    env = {k: v for k, v in scene.resolved.values.items()}
    t_c = float(sp.sympify(bp["period"]).subs(env))
    times = [float(sp.sympify(b).subs(env)) * t_c * 1e3 for b in bp["breaks"]]
    assert t_c * 1e3 == pytest.approx(1.600, abs=1e-12)
    assert times == pytest.approx([0.0, 0.6928, 1.148], abs=1e-6)
    # k_mean by eq. 3 (5.567e8 N/m; Table 1 prints 5.68e8, see the model file)
    k_mean = K_MAX * 0.433 + K_MIN * 0.567
    assert k_mean == pytest.approx(5.5666e8, rel=1e-4)
    assert info["parameters"]["mu0"]["active"] and info["effects"]["sliding_friction"]["variant"] == "A"


# ----------------------------------------------------- piecewise coefficients
def test_piecewise_stiffness_and_damping(parametric):
    """k(t), c(t) of the generated system in each segment against k_max, k_min and
    c = 2*zeta*sqrt(m_e*k) (eqs. 2-3 read physically: k = k_max in double contact;
    the printed eq. 2 would give k_mean*k_max/k_min = 9.28e8 N/m there)."""
    zeta = _values(PARAMETRIC)["zeta"]
    T = mesh_period(1500.0)
    for phase, seg in ((0.2, 0), (0.6, 1), (0.9, 2)):
        J = parametric.jacobian(phase * T, [0.0, 0.0])
        k, c = k_c(seg, zeta)
        assert -J[1, 0] * M_E == pytest.approx(k, rel=1e-12)
        assert -J[1, 1] * M_E == pytest.approx(c, rel=1e-12)
    k_printed = (K_MAX * 0.433 + K_MIN * 0.567) * K_MAX / K_MIN
    assert abs(-parametric.jacobian(0.2 * T, [0.0, 0.0])[1, 0] * M_E - k_printed) > 0.2 * K_MAX
    # mean load: x'' = N0/m_e at x = v = 0
    assert parametric.rhs(0.2 * T, [0.0, 0.0])[1] * M_E == pytest.approx(N0, rel=1e-12)


def test_friction_forcing_formulation_a():
    """The friction excitation of formulation A (k, c at their means) over the mesh
    cycle against eqs. 12-14 evaluated by hand, and the friction power is dissipative
    (the check that fixes the sign of the double-contact term)."""
    system = gearsym.load_scene(FRICTION).compile()
    T = mesh_period(1500.0)
    for phase in (0.05, 0.3, 0.432, 0.44, 0.6, 0.7174, 0.7176, 0.8, 0.999):
        got = system.rhs(phase * T, [0.0, 0.0])[1] * M_E - N0
        want = N0 * friction_factor(phase, 1.433)
        assert got == pytest.approx(want, rel=1e-10, abs=1e-9 * N0)
    # the printed eq. 12 sign would be the opposite one in double contact
    printed_12 = -MU0 * N0 * (2 * math.pi / PI_P) * R_P * (J_P * R_G - J_G * R_P) / (2 * J_T)
    got0 = system.rhs(0.1 * T, [0.0, 0.0])[1] * M_E - N0
    assert got0 == pytest.approx(-printed_12, rel=1e-10) and abs(printed_12) > 1.0    # N; J_d != 0
    # power of the model's friction torques, T_fp*Omega_p - T_fg*Omega_g <= 0
    model = gearsym.load_scene(FRICTION).model
    ns = model.ns
    vals = {sp.Symbol(k, real=True): v for k, v in ns.rs.values.items()}
    n_mesh = ns.sched_n["mesh"]
    t_fp = ns.parse("T_fp").subs(vals).subs(n_mesh, 0)
    t_fg = ns.parse("T_fg").subs(vals).subs(n_mesh, 0)
    seg_sym = ns.sched_seg["mesh"]
    w_p = rpm(1500.0)
    w_g = w_p * R_P / R_G
    powers = []
    for phase in np.linspace(0.0, 0.999, 60):
        s = segment(phase, 1.433)
        sub = {model.t: phase * T, seg_sym: s}
        powers.append(float(t_fp.subs(sub)) * w_p - float(t_fg.subs(sub)) * w_g)
    assert max(powers) <= 1e-9 * N0 * R_P * w_p
    assert min(powers) < -0.01 * MU0 * N0 * P_B * w_p


# ------------------------------------------------------------- Meissner form
def test_friction_off_is_a_meissner_equation():
    """With sliding_friction (and backlash) off the derived equation is, segment by
    segment, x'' + c(t)/m x' + k(t)/m x = F/m + (k eps + c eps')/m with k, c piecewise
    constant (rectangular) over the mesh cycle."""
    scene = gearsym.load_scene(FIG3, effects={"sliding_friction": False})
    model = scene.model
    acc = model.rhs[1]
    x, v = model.states
    t = model.t
    s = {n: sp.Symbol(n, real=True) for n in scene.resolved.values}
    pos = {sym: sp.Symbol(n, positive=True) for n, sym in s.items()}
    P = {n: pos[sym] for n, sym in s.items()}
    cphi = sp.Symbol("cphi", positive=True)
    # the mapping written down by hand (eqs. 1, 2, 9, 15, 32-33; c = 2*zeta*sqrt(m*k))
    R_p = P["a_c"] * P["Pi_p"] / (P["Pi_p"] + P["Pi_g"]) * cphi
    R_g = P["a_c"] * P["Pi_g"] / (P["Pi_p"] + P["Pi_g"]) * cphi
    m = 1 / (R_p**2 / P["J_p"] + R_g**2 / P["J_g"])
    F = P["T_p"] / R_p
    w = P["Omega_p"] * P["Pi_p"]
    eps = sum(P[f"e_c{n}"] * sp.cos(n * w * t) + P[f"e_s{n}"] * sp.sin(n * w * t) for n in range(1, 9))
    k_seg = [P["k_max"], P["k_max"] / P["k_ratio"], P["k_max"] / P["k_ratio"]]
    seg = model.ns.sched_seg["mesh"]
    assert model.parameter_names and "mu0" not in model.parameter_names
    # single contact before and after the pitch point: the same k and c (segments 1, 2)
    assert acc.subs(seg, 2) == acc.subs(seg, 1)
    for i, k in enumerate(k_seg[:2]):
        c = 2 * P["zeta"] * sp.sqrt(m * k)
        want = F / m - c / m * v - k / m * x + (k * eps + c * sp.diff(eps, t)) / m
        got = acc.subs(seg, i).xreplace(pos).subs(sp.cos(P["phi"]), cphi)
        assert not got.has(seg)
        assert sp.simplify(got - want) == 0


# --------------------------------------------------------------- stability
# (Gamma, rpm, verdict with friction (formulation B, mu0 = 0.1), verdict without friction):
# Figs. 5, 6(a), 6(b); Fig. 8 is 6(a) without friction.  Gamma = 1.24 at 1500 rpm is inside
# the zone only with friction (friction moves the zone to higher speed, Fig. 9).
CASES = [(1.24, 1500.0, "unstable", "stable"), (1.374, 1484.0, "stable", "stable"),
         (1.453, 1484.0, "unstable", "unstable")]


def monodromy_frictionless(gamma: float, n_rpm: float) -> np.ndarray:
    """Exact: expm over the single-contact part after expm over the double-contact part."""
    T = mesh_period(n_rpm)
    Phi = np.eye(2)
    for k, dt in ((K_MAX, (gamma - 1) * T), (K_MIN, (2 - gamma) * T)):
        Phi = sl.expm(np.array([[0.0, 1.0], [-k / M_E, 0.0]]) * dt) @ Phi
    return Phi


def monodromy_b(gamma: float, n_rpm: float) -> np.ndarray:
    """Formulation B, undamped: m x'' + (1 - phi(t)) k(t) x = 0 with the friction factor
    phi of eqs. 17-19, variational equations with scipy stopping at each breakpoint."""
    T = mesh_period(n_rpm)

    def f(tt, y, seg):
        k, _ = k_c(seg, 0.0)
        g = 1.0 - friction_factor(tt / T, gamma, seg)
        Y = y.reshape(2, 2)
        return (np.array([[0.0, 1.0], [-g * k / M_E, 0.0]]) @ Y).ravel()

    y = np.eye(2).ravel()
    bps = breaks(gamma, T, 1)
    for seg, (a, b) in enumerate(zip(bps[:-1], bps[1:])):
        sol = solve_ivp(f, (a, b), y, method="DOP853", rtol=1e-13, atol=1e-14, args=(seg,))
        y = sol.y[:, -1]
    return y.reshape(2, 2)


def _rho(Phi: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(Phi))))


@pytest.mark.parametrize("gamma,n_rpm,verdict_b,verdict", CASES)
def test_stability_frictionless_undamped(parametric, gamma, n_rpm, verdict_b, verdict):
    """Figs. 5/6 without friction: exact expm monodromy vs gearsym's variational monodromy."""
    exact = monodromy_frictionless(gamma, n_rpm)
    pr = {"Gamma": gamma, "Omega_p": n_rpm, "zeta": 0.0}
    T = parametric.period(pr)
    assert T == pytest.approx(mesh_period(n_rpm), rel=1e-14)
    tr = parametric.simulate(t_end=T, x0=[1e-6, 0.0], params=pr, monodromy=True, rtol=1e-12, atol=1e-18)
    assert tr.stats["n_breaks"] == 2
    np.testing.assert_allclose(tr.monodromy, exact, rtol=0, atol=1e-7 * np.max(np.abs(exact)))
    rho = _rho(exact)
    assert abs(_rho(tr.monodromy) - rho) < 1e-7
    if verdict == "stable":
        assert abs(rho - 1.0) < 1e-9
    else:
        assert rho > 1.05
    expected = {1.24: 1.0, 1.374: 1.0, 1.453: 1.15638}[gamma]
    assert rho == pytest.approx(expected, abs=2e-5)


@pytest.mark.parametrize("gamma,n_rpm,verdict,verdict_frictionless", CASES)
def test_stability_formulation_b_undamped(fig6, gamma, n_rpm, verdict, verdict_frictionless):
    """Fig. 5 (Gamma = 1.24 at 1500 rpm unstable) and Fig. 6 (1.374 stable, 1.453
    unstable at 1484 rpm), formulation B, mu0 = 0.1, no damping: scipy variational
    equations vs gearsym's monodromy."""
    ref = monodromy_b(gamma, n_rpm)
    pr = {"Gamma": gamma, "Omega_p": n_rpm, "zeta": 0.0, "mu0": MU0}
    T = fig6.period(pr)
    tr = fig6.simulate(t_end=T, x0=[1e-6, 0.0], params=pr, monodromy=True, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(tr.monodromy, ref, rtol=0, atol=1e-7 * np.max(np.abs(ref)))
    rho = _rho(ref)
    assert abs(_rho(tr.monodromy) - rho) < 1e-7
    assert abs(np.linalg.det(ref) - 1.0) < 1e-9        # undamped: trace of A is zero
    if verdict == "stable":
        assert abs(rho - 1.0) < 1e-9
    else:
        assert rho > 1.05
    expected = {1.24: 1.11051, 1.374: 1.0, 1.453: 1.08437}[gamma]
    assert rho == pytest.approx(expected, abs=2e-5)


def _zone_edge(system, gamma: float, mu: float, J: tuple[float, float] | None, stable: float,
               unstable: float) -> float:
    """Speed (rpm) between a stable and an unstable speed where |trace(monodromy)| = 2
    (undamped: det = 1, so that is where the multipliers leave the unit circle); the
    model's inertias unless ``J`` is given."""
    pr = {"Gamma": gamma, "zeta": 0.0, "mu0": mu} | ({"J_p": J[0], "J_g": J[1]} if J else {})

    def unstable_at(n_rpm: float) -> bool:
        p = pr | {"Omega_p": n_rpm}
        M = system.simulate(t_end=system.period(p), x0=[1e-6, 0.0], params=p, monodromy=True, rtol=1e-11,
                            atol=1e-18, n_out=2).monodromy
        return abs(M[0, 0] + M[1, 1]) > 2

    assert unstable_at(unstable) and not unstable_at(stable)
    for _ in range(16):                    # 14 rpm / 2^16: 2e-4 rpm
        mid = 0.5 * (stable + unstable)
        if unstable_at(mid):
            unstable = mid
        else:
            stable = mid
    return 0.5 * (stable + unstable)


def test_friction_moves_the_zone_to_higher_speed(fig6):
    """Fig. 9: friction (formulation B) shifts the instability zone "a little towards the
    higher speed side".  The shift has the sign of J_d = J_g R_p - J_p R_g (eqs. 17, 29):
    friction stiffens the mesh on average when J_g/J_p > R_g/R_p, as for solid discs
    (the model's inertias); with equal inertias (J_d < 0) it moves the zone lower."""
    lo = [_zone_edge(fig6, 1.24, mu, None, 1478.0, 1492.0) for mu in (0.0, MU0)]    # the model's inertias
    hi = [_zone_edge(fig6, 1.24, mu, None, 1506.0, 1492.0) for mu in (0.0, MU0)]
    assert lo[1] > lo[0] and hi[1] > hi[0]
    assert lo[1] - lo[0] == pytest.approx(0.678, abs=0.01)      # measured +0.678 rpm
    assert hi[1] - hi[0] == pytest.approx(1.677, abs=0.01)      # measured +1.677 rpm
    assert lo[0] < 1500.0 - 1 and hi[0] < 1500.0 < hi[1]     # 1500 rpm is in the zone only with friction
    assert (fig6.params["J_p"], fig6.params["J_g"]) == pytest.approx((J_P, J_G), rel=1e-12)
    # the same m_e with J_p = J_g (J_d < 0): both edges move to lower speed
    assert J_G * R_P - J_P * R_G > 0
    Jeq = (M_E * (R_P**2 + R_G**2),) * 2
    lo_eq = _zone_edge(fig6, 1.24, MU0, Jeq, 1478.0, 1492.0)
    hi_eq = _zone_edge(fig6, 1.24, MU0, Jeq, 1506.0, 1492.0)
    assert lo_eq - lo[0] < -1.0 and hi_eq - hi[0] < -0.2


# ---------------------------------------------------- combined simulation
def test_combined_scene_against_scipy():
    """Fig. 3(a) scene (k(t), c(t), STE, friction A, zeta = 5 %) over 12 mesh cycles
    against scipy with a hand-written right-hand side that stops at every breakpoint."""
    scene = gearsym.load_scene(FIG3)
    V = scene.resolved.values
    zeta = V["zeta"]
    T = mesh_period(1500.0)
    w = rpm(1500.0) * PI_P
    ec = [V[f"e_c{n}"] for n in range(1, 9)]
    es = [V[f"e_s{n}"] for n in range(1, 9)]

    def eps(tt):
        return sum(ec[n - 1] * math.cos(n * w * tt) + es[n - 1] * math.sin(n * w * tt) for n in range(1, 9))

    def deps(tt):
        return sum(n * w * (-ec[n - 1] * math.sin(n * w * tt) + es[n - 1] * math.cos(n * w * tt))
                   for n in range(1, 9))

    def rhs(tt, y, seg, cycle):
        k, c = k_c(seg, zeta)
        ff = N0 * friction_factor(tt / T - cycle, 1.433, seg)
        x, v = y
        return [v, (N0 + ff - k * (x - eps(tt)) - c * (v - deps(tt))) / M_E]

    n_cyc = 12
    grid = np.linspace(0.0, n_cyc * T, 12 * 64 + 1)
    x0 = [11.3e-6, 0.0]
    bps = breaks(1.433, T, n_cyc)
    y = np.array(x0)
    ref = np.empty((grid.size, 2))
    ref[0] = y
    for i, (a, b) in enumerate(zip(bps[:-1], bps[1:])):
        if b - a <= 0:
            continue
        seg, cycle = i % 3, i // 3
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-12, atol=1e-18, dense_output=True,
                        args=(seg, cycle))
        inside = (grid > a) & (grid <= b)
        ref[inside] = sol.sol(grid[inside]).T
        y = sol.y[:, -1]
    system = scene.compile()
    tr = system.simulate(t_end=n_cyc * T, n_out=grid.size, x0=x0, rtol=1e-11, atol=1e-17)
    np.testing.assert_allclose(tr.t, grid, rtol=1e-15, atol=0)
    assert tr.stats["n_breaks"] == 3 * n_cyc - 1          # every interior breakpoint, no event
    scale = np.max(np.abs(ref - ref[:, :].mean(axis=0)), axis=0)
    err = np.max(np.abs(tr.y - ref), axis=0)
    print(f"max |x - x_ref| = {err[0]:.3e} m, |v - v_ref| = {err[1]:.3e} m/s, scale {scale}")
    assert err[0] < 1e-8 * scale[0] and err[1] < 1e-8 * scale[1]     # seen: 5e-10 of the ranges
    # the response is not trivial: the DTE varies by more than 0.1 um over the last cycles
    last = ref[grid > (n_cyc - 2) * T, 0]
    assert last.max() - last.min() > 1e-7


# ---------------------------------------------------- effects and parameters
def test_parameters_drop_with_friction_off(capsys):
    """`compile --json`: parameters used only by a switched-off effect are not inputs."""
    assert cli_main(["compile", str(FRICTION), "--json"]) == 0
    on = json.loads(capsys.readouterr().out)
    assert cli_main(["compile", str(FRICTION), "--no-effect", "sliding_friction", "--json"]) == 0
    off = json.loads(capsys.readouterr().out)
    assert "mu0" in on["params"] and "r_ap" in on["params"] and on["n_schedules"] == 1
    assert "mu0" not in off["params"] and "r_ap" not in off["params"] and off["n_schedules"] == 0
    assert off["n_params"] < on["n_params"]
    assert set(off["params"]) < set(on["params"])
    for name in ("e_c1", "b_h"):
        assert name not in on["params"]


def test_backlash_surfaces():
    """Optional backlash: two contact surfaces x - eps(t) -+ b_h, and no stiffness force
    inside the dead zone (separation mode)."""
    model = gearsym.load_scene(FIG3, effects={"backlash": True}).model
    x, v = model.states
    t = model.t
    S = {n: sp.Symbol(n, real=True) for n in ("b_h", "Omega_p", "Pi_p")}
    w = S["Omega_p"] * S["Pi_p"]
    eps = sum(sp.Symbol(f"e_c{n}", real=True) * sp.cos(n * w * t)
              + sp.Symbol(f"e_s{n}", real=True) * sp.sin(n * w * t) for n in range(1, 9))
    g = {s.kind: s.expr for s in model.switching}
    assert set(g) == {"drive", "back"}
    assert sp.expand(g["drive"] - (x - eps - S["b_h"])) == 0
    assert sp.expand(g["back"] - (x - eps + S["b_h"])) == 0
    sig = dict(zip([s.kind for s in model.switching], model.modal.sigma))
    acc = model.modal.rhs[1]
    separated = acc.subs({sig["drive"]: -1, sig["back"]: 1})
    contact = acc.subs({sig["drive"]: 1, sig["back"]: 1})
    for i in range(3):
        seg = model.ns.sched_seg["mesh"]
        assert sp.diff(separated.subs(seg, i), x) == 0
        assert sp.diff(contact.subs(seg, i), x) != 0
