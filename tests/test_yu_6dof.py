"""Yu et al. (2021) 6-DOF transverse-torsional spur pair with dynamic and fractal backlash.

References used here (all independent of the code under test):

* the fractal mean height (eq. 4) against an mpmath computation at 30 digits that
  finds the sign changes with ``mpmath.findroot`` on its own, finer grid and
  integrates ``z`` between them with ``mpmath.quad`` (no antiderivative);
* the reduced equations (DTE + four translations) against a sympy derivation from
  the UNREDUCED eqs. 12-16 (rotations and translations as functions of time, the DTE
  of eq. 15 differentiated twice), with eq. 10 in its literal signed form
  ``sign(da)*sqrt(da^2 - dp^2)`` and eq. 7 with ``beta = tan(alpha)``;
* ``bearing_flexibility`` off against a hand-written torsional backlash oscillator
  (``sympy.simplify(a - b) == 0``);
* a simulation against scipy (DOP853, event-restarted at every contact transition)
  of the unreduced 12-state system with a hand-written numpy right-hand side.
"""

from __future__ import annotations

import math
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import gearsym
from gearsym.errors import ParameterError
from gearsym.fractal import wm_mean_height, wm_mean_height_report, wm_mean_height_truncated
from gearsym.spec.model import parse_model
from gearsym.spec.scene import SceneSpec, resolve_scene
from gearsym.symbolic.model import SymbolicModel

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "yu_6dof.toml"
DYN = ROOT / "scenes" / "yu_dynamic_D14.toml"
CONST = ROOT / "scenes" / "yu_constant_backlash.toml"
WM = "wm_mean_height(D, G, lam, L_c, l_a)"
TORSIONAL = {"bearing_flexibility": False, "time_varying_pressure_angle": False, "dynamic_backlash": False}


# ----------------------------------------------------------------------------- fractal


def mp_mean_abs(D, G, lam, L, l_a, n_levels, dps=30, ppw=64):
    """Independent reference for eq. 4 truncated to ``n_levels`` levels (mpmath).

    The series is truncated to the same levels ``k_min + j``, ``j < n_levels``; the
    integral of ``|z|`` is split at the sign changes of ``z`` (bracketed on a grid of
    ``ppw`` points per shortest wavelength, refined with ``findroot``) and each
    root-free piece is integrated with ``mpmath.quad`` (tanh-sinh) at ``dps`` digits.
    """
    mp.mp.dps = dps
    D, G, lam, L, l_a = (mp.mpf(repr(float(v))) for v in (D, G, lam, L, l_a))
    f = [lam**j / l_a for j in range(n_levels)]
    a = [G ** (D - 1) * fj ** (D - 2) for fj in f]
    tp = 2 * mp.pi

    def z(pos):
        return mp.fsum(aj * mp.cos(tp * fj * pos) for aj, fj in zip(a, f))

    n = int(mp.ceil(L * f[-1] * ppw))
    grid = [L * i / n for i in range(n + 1)]
    zs = [z(pos) for pos in grid]
    roots = [mp.findroot(z, (grid[i], grid[i + 1]), solver="anderson")
             for i in range(n) if (zs[i] >= 0) != (zs[i + 1] >= 0)]
    pts = [mp.mpf(0), *roots, L]
    return mp.fsum(abs(mp.quad(z, [p0, p1])) for p0, p1 in zip(pts[:-1], pts[1:])) / L


@pytest.mark.parametrize("D,L", [(1.2, 1.5e-4), (1.45, 2.3e-4), (1.7, 1.5e-4)])
def test_fractal_mean_height_vs_mpmath(D, L):
    n = 9
    ref = mp_mean_abs(D, 1e-11, 1.5, L, 1e-4, n)
    val, n_roots = wm_mean_height_truncated(D, 1e-11, 1.5, L, 1e-4, n)
    assert n_roots > 5
    assert abs(val - float(ref)) <= 1e-13 * float(ref)


@pytest.mark.parametrize("D", [1.2, 1.8])
def test_fractal_series_truncation_is_converged(D):
    rep = wm_mean_height_report(D, 1e-11, 1.5, 1.5e-4, 1e-4)
    tol = max(1e-6 * rep.value, 1e-11)
    assert rep.tail_estimate <= tol and rep.grid_check <= tol
    # four more levels (a 5x shorter smallest wavelength) change it by less than claimed
    more, _ = wm_mean_height_truncated(D, 1e-11, 1.5, 1.5e-4, 1e-4, rep.levels + 4)
    assert abs(more - rep.value) <= tol
    assert abs(more - rep.value) <= rep.tail_bound  # rigorous first-order bound
    assert wm_mean_height(D, 1e-11, 1.5, 1.5e-4, 1e-4) == rep.value


def test_fractal_trends_of_yu_sec_2_1():
    """b_i falls with D and grows with G; b_s < 20 um for D = 1.2, ~b_0 for D = 1.8 (Fig. 4)."""
    b = [wm_mean_height(D, 1e-11, 1.5, 1.5e-4, 1e-4) for D in (1.2, 1.4, 1.6, 1.8)]
    assert all(x > y for x, y in zip(b, b[1:]))
    assert wm_mean_height(1.4, 1e-10, 1.5, 1.5e-4, 1e-4) > b[1] > wm_mean_height(1.4, 1e-12, 1.5, 1.5e-4, 1e-4)
    b0 = 20e-6
    assert b0 - 2 * b[0] < 20e-6 - 1e-6 and abs(2 * b[-1]) < 1e-4 * b0
    with pytest.raises(ParameterError, match="fractal dimension"):
        wm_mean_height(2.0, 1e-11, 1.5, 1.5e-4, 1e-4)


# ------------------------------------------------------------------ symbolic structure


_SCENES: dict = {}


def _model(effects=None, scene=DYN, **over) -> gearsym.Scene:
    """Load a scene (cached: the symbolic derivation takes about a second)."""
    key = (str(scene), tuple(sorted((effects or {}).items())), tuple(sorted(over.items())))
    if key not in _SCENES:
        _SCENES[key] = gearsym.load_scene(scene, effects=effects, **over)
    return _SCENES[key]


def test_bearing_flexibility_off_is_the_torsional_backlash_oscillator():
    sc = _model(TORSIONAL)
    m = sc.model
    assert m.state_names == ["x", "v"]
    assert sc.initial_state() == [24e-6, 0.0]
    assert not ({"k_px", "c_py", "m_p", "m_g"} & set(m.parameter_names))
    # hand-written:  m_e x'' + c_m x' + k(t) f(x) = F_0 + m_e*omega_h^2*e_r*cos(omega_h t + phi0)
    S = {n: sp.Symbol(n, real=True) for n in ("I_p I_g R_p R_g k_m T_p T_g xi T_ah b_n alpha0 Omega eps "
                                               "phi0 b_0 x v").split()}
    t = sp.Symbol("t", real=True)
    W = sp.Symbol(WM, real=True)
    me = 1 / ((S["R_p"] * sp.cos(S["alpha0"])) ** 2 / S["I_p"] + (S["R_g"] * sp.cos(S["alpha0"])) ** 2 / S["I_g"])
    wh = S["Omega"] * sp.sqrt(S["k_m"] / me)
    k = S["k_m"] * (1 + S["eps"] * sp.sin(wh * t + S["phi0"]))
    c = 2 * S["xi"] * sp.sqrt(S["k_m"] * me)
    F0 = me * (S["R_p"] * sp.cos(S["alpha0"]) * S["T_p"] / S["I_p"]
               + S["R_g"] * sp.cos(S["alpha0"]) * S["T_g"] / S["I_g"])
    B = S["b_0"] - 2 * W
    x = S["x"]
    f = sp.Piecewise((x - B, x > B), (x + B, x < -B), (0, True))
    hand = (F0 + me * wh**2 * S["T_ah"] * S["b_n"] * sp.cos(wh * t + S["phi0"]) - c * S["v"] - k * f) / me
    assert sp.simplify(m.accelerations[0] - hand) == 0
    assert [g.name for g in m.switching] == ["mesh.drive", "mesh.back"]
    assert sp.simplify(m.switching[0].expr - (x - B)) == 0
    assert sp.simplify(m.switching[1].expr - (x + B)) == 0
    # parameters used only by the switched-off effect are not inputs
    with pytest.raises(ParameterError, match="switched-off"):
        _model(TORSIONAL, k_px=2e8)


def test_dynamic_backlash_off_gives_a_constant_backlash():
    sc = _model(scene=CONST)
    m = sc.model
    assert len(m.state_names) == 10
    states = set(m.states)
    drive = next(g for g in m.switching if g.name == "mesh.drive")
    x = sp.Symbol("x", real=True)
    B = x - drive.expr
    assert not (B.free_symbols & states)
    assert sp.simplify(B - (sp.Symbol("b_0", real=True) - 2 * sp.Symbol(WM, real=True))) == 0
    # only the two contact surfaces: no guard of eq. 10
    assert [g.name for g in m.switching] == ["mesh.drive", "mesh.back"]
    # and with fractal_backlash off as well, B = b_0
    m2 = _model({"dynamic_backlash": False, "fractal_backlash": False}, scene=CONST).model
    d2 = next(g for g in m2.switching if g.name == "mesh.drive")
    assert sp.simplify(x - d2.expr - sp.Symbol("b_0", real=True)) == 0
    assert "wm_mean_height(D, G, lam, L_c, l_a)" not in m2.parameter_names


def _unreduced_derivation():
    """x'' and the translational accelerations from eqs. 12-16 (unreduced), by sympy."""
    P = {n: sp.Symbol(n, real=True) for n in ("I_p I_g R_p R_g k_m T_p T_g xi T_ah b_n alpha0 Omega eps phi0 "
                                               "b_0 m_p m_g k_px k_py k_gx k_gy c_px c_py c_gx c_gy").split()}
    W = sp.Symbol(WM, real=True)
    t = sp.Symbol("t", real=True)
    X = {n: sp.Symbol(n, real=True) for n in "x v xp yp xg yg xp_dot yp_dot xg_dot yg_dot".split()}
    th_p, th_g, xp, yp, xg, yg = (sp.Function(n, real=True)(t) for n in ("th_p", "th_g", "Xp", "Yp", "Xg", "Yg"))
    c0, s0 = sp.cos(P["alpha0"]), sp.sin(P["alpha0"])
    Rpb, Rgb = P["R_p"] * c0, P["R_g"] * c0
    a0, ab = P["R_p"] + P["R_g"], Rpb + Rgb
    me = 1 / (Rpb**2 / P["I_p"] + Rgb**2 / P["I_g"])
    wh = P["Omega"] * sp.sqrt(P["k_m"] / me)
    a = sp.sqrt((a0 - (xp - xg)) ** 2 + (yp - yg) ** 2)          # eq. 8 (sign as in the model notes)
    alpha = sp.acos(ab / a)                                        # eq. 16 with base radii
    e = P["T_ah"] * P["b_n"] * sp.cos(wh * t + P["phi0"])
    delta = Rpb * th_p - Rgb * th_g + (xp - xg) * sp.sin(alpha) + (yp - yg) * sp.cos(alpha) - e  # eq. 15
    Fm = sp.Symbol("F_m")
    d2 = {th_p.diff(t, 2): (P["T_p"] - Rpb * Fm) / P["I_p"],       # eq. 12
          th_g.diff(t, 2): (-P["T_g"] + Rgb * Fm) / P["I_g"],
          xp.diff(t, 2): (-P["c_px"] * xp.diff(t) - P["k_px"] * xp - Fm * sp.sin(alpha)) / P["m_p"],
          yp.diff(t, 2): (-P["c_py"] * yp.diff(t) - P["k_py"] * yp - Fm * sp.cos(alpha)) / P["m_p"],
          xg.diff(t, 2): (-P["c_gx"] * xg.diff(t) - P["k_gx"] * xg + Fm * sp.sin(alpha)) / P["m_g"],
          yg.diff(t, 2): (-P["c_gy"] * yg.diff(t) - P["k_gy"] * yg + Fm * sp.cos(alpha)) / P["m_g"]}
    dd = delta.diff(t, 2).subs(d2)
    trans = [d2[q.diff(t, 2)] for q in (xp, yp, xg, yg)]
    to_state = {q.diff(t): X[n + "_dot"] for q, n in zip((xp, yp, xg, yg), ("xp", "yp", "xg", "yg"))}
    to_state.update({q: X[n] for q, n in zip((xp, yp, xg, yg), ("xp", "yp", "xg", "yg"))})
    dd = dd.subs(to_state)
    trans = [e_.subs(to_state) for e_ in trans]
    alpha_s = alpha.subs(to_state)
    a_s = a.subs(to_state)
    # eqs. 1, 5, 6, 7, 9, 10: signed reading, literal form
    da = a_s - a0
    dp = Rpb / 2 * (sp.tan(alpha_s) ** 2 - sp.tan(P["alpha0"]) ** 2)
    B = P["b_0"] - 2 * W + sp.sign(da) * sp.sqrt(da**2 - dp**2)
    k = P["k_m"] * (1 + P["eps"] * sp.sin(wh * t + P["phi0"]))
    c = 2 * P["xi"] * sp.sqrt(P["k_m"] * me)
    f = sp.Piecewise((X["x"] - B, X["x"] > B), (X["x"] + B, X["x"] < -B), (0, True))   # eq. 14
    Fm_val = k * f + c * X["v"]                                                          # eq. 13
    assert not dd.has(th_p) and not dd.has(th_g)
    return P, W, t, X, [e_.subs(Fm, Fm_val) for e_ in (dd, *trans)], B, s0


def test_reduction_matches_the_unreduced_derivation():
    m = _model().model
    P, W, t, X, ref, B, _ = _unreduced_derivation()
    acc = list(m.accelerations)
    assert [str(q) for q in m.coordinates] == ["x", "xp", "yp", "xg", "yg"]
    syms = [t, W, *P.values(), *X.values()]
    f_model = sp.lambdify(syms, acc, modules="mpmath")
    f_ref = sp.lambdify(syms, ref, modules="mpmath")
    f_B = sp.lambdify(syms, B, modules="mpmath")
    rng = np.random.default_rng(7)
    base = dict(I_p=1.15e-3, I_g=2.3e-3, R_p=0.094, R_g=0.12, k_m=3e8, T_p=107.8, T_g=137.6, xi=0.1,
                T_ah=0.019, b_n=1e-3, alpha0=math.radians(20), Omega=0.9, eps=0.2, phi0=0.3, b_0=20e-6,
                m_p=0.26, m_g=0.4, k_px=1e8, k_py=1.3e8, k_gx=0.8e8, k_gy=1.1e8, c_px=510, c_py=400,
                c_gx=600, c_gy=450)
    mp.mp.dps = 40
    checked = 0
    for trial in range(3):
        pv = [mp.mpf(repr(base[n] * (1 + 0.1 * rng.uniform(-1, 1)))) for n in P]
        tv = mp.mpf(repr(rng.uniform(0, 1e-3)))
        xs = {n: mp.mpf(repr(rng.uniform(-6e-6, 6e-6))) for n in ("xp", "yp", "xg", "yg")}
        xs.update({n: mp.mpf(repr(rng.uniform(-0.2, 0.2))) for n in ("v", "xp_dot", "yp_dot", "xg_dot",
                                                                      "yg_dot")})
        wv = mp.mpf("2.8e-6")
        xs["x"] = mp.mpf(0)
        def args(tv=tv, wv=wv, pv=pv, xs=xs):
            return [tv, wv, *pv, *[xs[n] for n in X]]

        Bv = f_B(*args())
        assert Bv > 0
        for region in (1.3, 0.5, -1.4):  # drive contact, separation, back contact
            xs["x"] = region * Bv
            am, ar = f_model(*args()), f_ref(*args())
            for u, w in zip(am, ar):
                assert abs(u - w) <= mp.mpf("1e-25") * (1 + abs(w)), (trial, region, u, w)
            checked += 1
    assert checked == 9


def test_fixed_pressure_angle_reduction_is_linear():
    """time_varying_pressure_angle off: s'' = sin(alpha0) u'' + cos(alpha0) w'' exactly, so in
    contact d(x'')/dx = -k(t)*(1/m_e + (sin^2 + cos^2)*(1/m_p + 1/m_g)) and x'' is linear
    in the velocities (no alpha' terms)."""
    m = _model({"time_varying_pressure_angle": False, "dynamic_backlash": False}).model
    x_acc = m.accelerations[0]
    names = {str(s_): s_ for s_ in x_acc.free_symbols}
    vals = {"I_p": 1.15e-3, "I_g": 2e-3, "R_p": 0.094, "R_g": 0.11, "alpha0": 0.35, "k_m": 3e8,
            "eps": 0.2, "Omega": 0.9, "phi0": 0.1, "m_p": 0.26, "m_g": 0.4, "t": 1.3e-5, "b_0": 2e-5,
            WM: 1e-6, "x": 3e-5}
    sub = {names[k]: v for k, v in vals.items() if k in names}
    me = float(m.mass_matrix[0, 0].subs(sub))
    k_t = 3e8 * (1 + 0.2 * math.sin(0.9 * math.sqrt(3e8 / me) * 1.3e-5 + 0.1))
    slope = float(sp.diff(x_acc, names["x"]).subs(sub).subs({s_: 0 for s_ in x_acc.free_symbols}))
    assert slope == pytest.approx(-k_t * (1 / me + 1 / 0.26 + 1 / 0.4), rel=1e-12)
    for v in ("xp_dot", "yp_dot", "xg_dot", "yg_dot"):
        assert sp.diff(x_acc, names[v], 2) == 0


# ------------------------------------------------------- derived from elements (issue 12)

PAPER = ROOT / "tests" / "data" / "yu_6dof_paper_equations.toml"


def _paper_scene(scene: Path, **over) -> gearsym.Scene:
    """The scene on the hand-typed reduced equations of the paper (with the documented corrections)."""
    import tempfile

    text = scene.read_text().replace('model = "../models/yu_6dof.toml"', f'model = "{PAPER.as_posix()}"')
    path = Path(tempfile.mkdtemp(prefix="gearsym-yu-")) / scene.name
    path.write_text(text)
    return gearsym.load_scene(path, **over)


def test_model_has_no_hand_typed_equation_of_motion():
    spec = gearsym.load_scene(DYN).model_spec
    assert not spec.equations
    assert {e.type for e in spec.elements.values()} == {"inertia", "force", "bearing", "gear_mesh"}
    assert spec.reduction is not None and spec.reduction.keep == ("xp", "yp", "xg", "yg")
    assert not ({"s_dd", "u_dd", "w_dd", "Fxp", "al_dd", "a_dd"} & set(spec.derived))


def test_unreduced_equations_are_eq_12():
    """Virtual work over the elements gives Yu's eq. 12 (with base radii and the corrected
    centre distance, see the model notes), symbolically: rotations driven by -/+R*F_m,
    centres by the bearings and -/+F_m*(sin, cos)(alpha) along the line of action."""
    m = _model().model
    P = {n: sp.Symbol(n, real=True) for n in ("I_p I_g R_p R_g k_m T_p T_g xi T_ah b_n alpha0 Omega eps phi0 b_0 "
                                               "m_p m_g k_px k_py k_gx k_gy c_px c_py c_gx c_gy").split()}
    t = sp.Symbol("t", real=True)
    q = {n: sp.Symbol(n, real=True) for n in "th_p th_g xp yp xg yg w_p w_g xp_dot yp_dot xg_dot yg_dot".split()}
    c0 = sp.cos(P["alpha0"])
    Rpb, Rgb = P["R_p"] * c0, P["R_g"] * c0
    a0, ab = P["R_p"] + P["R_g"], Rpb + Rgb
    a = sp.sqrt((a0 - (q["xp"] - q["xg"])) ** 2 + (q["yp"] - q["yg"]) ** 2)       # eq. 8 (corrected sign)
    sa, ca = sp.sqrt(1 - (ab / a) ** 2), ab / a                                       # eq. 16, base radii
    M = sp.diag(P["I_p"], P["I_g"], P["m_p"], P["m_p"], P["m_g"], P["m_g"])
    assert m.unreduced_mass_matrix == M
    Fm = sp.Symbol("F_m")
    hand = [P["T_p"] - Rpb * Fm, -P["T_g"] + Rgb * Fm,
            -P["c_px"] * q["xp_dot"] - P["k_px"] * q["xp"] - Fm * sa,
            -P["c_py"] * q["yp_dot"] - P["k_py"] * q["yp"] - Fm * ca,
            -P["c_gx"] * q["xg_dot"] - P["k_gx"] * q["xg"] + Fm * sa,
            -P["c_gy"] * q["yg_dot"] - P["k_gy"] * q["yg"] + Fm * ca]
    # the mesh force of the model: read it off the pinion row, Q_thp = T_p - R_pb*F_m
    F_model = (P["T_p"] - m.unreduced_forces[0]) / Rpb
    for got, want in zip(m.unreduced_forces, hand):
        assert sp.simplify(got - want.subs(Fm, F_model)) == 0
    # and F_m is eq. 13 with the dead zone of eq. 14 and c_m*delta' (the damping reading)
    me = 1 / (Rpb ** 2 / P["I_p"] + Rgb ** 2 / P["I_g"])
    wh = P["Omega"] * sp.sqrt(P["k_m"] / me)
    e = P["T_ah"] * P["b_n"] * sp.cos(wh * t + P["phi0"])
    delta = Rpb * q["th_p"] - Rgb * q["th_g"] + (q["xp"] - q["xg"]) * sa + (q["yp"] - q["yg"]) * ca - e
    ddelta = sp.diff(delta, t) + sum(sp.diff(delta, q[k]) * q[v] for k, v in
                                     (("th_p", "w_p"), ("th_g", "w_g"), ("xp", "xp_dot"), ("yp", "yp_dot"),
                                      ("xg", "xg_dot"), ("yg", "yg_dot")))
    W = sp.Symbol(WM, real=True)
    da = a - a0
    kappa = Rpb * (a + a0) / (2 * ab ** 2)
    B = P["b_0"] - 2 * W + da * sp.sqrt(sp.Max(0, 1 - kappa ** 2))
    k = P["k_m"] * (1 + P["eps"] * sp.sin(wh * t + P["phi0"]))
    c = 2 * P["xi"] * sp.sqrt(P["k_m"] * me)
    branches = sp.piecewise_fold(F_model).args
    assert len(branches) == 3 and branches[-1][1] == sp.true
    for (got, _), want in zip(branches, (k * (delta - B) + c * ddelta, k * (delta + B) + c * ddelta, c * ddelta)):
        assert sp.simplify(got - want) == 0
    cond = branches[0][1]  # drive contact: delta - B > 0, in either orientation
    gap = cond.lhs - cond.rhs if isinstance(cond, sp.StrictGreaterThan) else cond.rhs - cond.lhs
    assert isinstance(cond, (sp.StrictGreaterThan, sp.StrictLessThan))
    assert sp.simplify(gap - (delta - B)) == 0


def test_reduced_equations_are_the_hand_typed_ones_exactly():
    """The reduction of the element model equals the equations that were hand-typed in the
    model (tests/data/yu_6dof_paper_equations.toml, eqs. 12-19 after the documented
    corrections) as an identity of rational functions: every parameter an exact rational,
    the states symbolic, the centre distance and the pressure angle parametrised rationally
    (a = A, sin(alpha) = 2n/(1 + n^2), cos(alpha) = (1 - n^2)/(1 + n^2)) so that every square
    root is rational, and the difference of each right-hand side cancelled to zero (drive
    contact, the mode with every term)."""
    import random

    new = _model(scene=CONST).model
    old = _paper_scene(CONST).model
    assert new.state_names == old.state_names
    assert [g.name for g in new.switching] == [g.name for g in old.switching] == ["mesh.drive", "mesh.back"]
    S = lambda n: sp.Symbol(n, real=True)  # noqa: E731
    A, mm, nn = sp.symbols("A m n", positive=True)
    R_p, R_g = S("R_p"), S("R_g")
    a0 = R_p + R_g
    u = a0 - A * (1 - mm ** 2) / (1 + mm ** 2)
    w = 2 * A * mm / (1 + mm ** 2)
    rng = random.Random(5)
    rat = {p_: sp.Rational(rng.randint(2, 30), rng.randint(2, 30)) for p_ in new.parameters
           if str(p_) not in ("R_p", "R_g", "alpha0", "Omega", "phi0")}
    rat.update({R_p: sp.Rational(9, 100), R_g: sp.Rational(11, 100), S("Omega"): sp.Rational(1, 5), S("phi0"): 0})
    c0 = A * (1 - nn ** 2) / ((1 + nn ** 2) * a0)

    def prep(e: sp.Expr, sigma) -> sp.Expr:
        e = e.xreplace({s_: sp.Integer(1) for s_ in sigma})
        e = e.replace(lambda x: x.is_Pow and x.exp.is_Float, lambda x: sp.Pow(x.base, sp.Rational(str(x.exp))))
        e = e.xreplace({sp.cos(S("alpha0")): c0}).xreplace({S("xp"): S("xg") + u, S("yp"): S("yg") + w})
        e = e.xreplace(rat)
        return e.replace(lambda x: x.is_Pow and x.exp.is_Rational and x.exp.q == 2,
                         lambda x: sp.Pow(sp.factor(sp.cancel(x.base)), x.exp))

    for i in range(5):
        a_new = prep(new.modal.rhs[5 + i], new.modal.sigma)
        a_old = prep(old.modal.rhs[5 + i], old.modal.sigma)
        assert not any(p_.exp.is_Rational and p_.exp.q == 2 and p_.base.free_symbols
                       for p_ in (a_new - a_old).atoms(sp.Pow)), "a square root of the states is left"
        assert sp.cancel(sp.together(a_new - a_old)) == 0, new.state_names[5 + i]


def test_reduced_dynamic_backlash_equations_match_the_hand_typed_ones_numerically():
    """With the dynamic backlash (a Max inside the contact surfaces): every right-hand side and
    switching function at random states, 60 digits, all three contact modes."""
    new = _model().model
    old = _paper_scene(DYN).model
    assert [g.name for g in new.switching] == [g.name for g in old.switching]
    syms = sorted(set().union(*[e.free_symbols for e in (*new.modal.rhs, *old.modal.rhs)]) - set(new.modal.sigma)
                  - set(old.modal.sigma), key=str)
    mp.mp.dps = 60
    rng = np.random.default_rng(11)
    base = dict(I_p=1.15e-3, I_g=2.3e-3, R_p=0.094, R_g=0.12, k_m=3e8, T_p=107.8, T_g=137.6, xi=0.1,
                T_ah=0.019, b_n=1e-3, alpha0=math.radians(20), Omega=0.9, eps=0.2, phi0=0.3, b_0=20e-6,
                m_p=0.26, m_g=0.4, k_px=1e8, k_py=1.3e8, k_gx=0.8e8, k_gy=1.1e8, c_px=510, c_py=400,
                c_gx=600, c_gy=450, t=2e-4, **{WM: 2.8e-6})
    for trial in range(3):
        vals = {}
        for s_ in syms:
            n = str(s_)
            if n in base:
                vals[s_] = mp.mpf(repr(base[n] * (1 + 0.1 * rng.uniform(-1, 1))))
            elif n in ("xp", "yp", "xg", "yg"):
                vals[s_] = mp.mpf(repr(rng.uniform(-6e-6, 6e-6)))
            elif n == "x":
                vals[s_] = mp.mpf(repr(rng.uniform(-4e-5, 4e-5)))
            else:
                vals[s_] = mp.mpf(repr(rng.uniform(-0.2, 0.2)))
        f_new = sp.lambdify(syms + list(new.modal.sigma), list(new.modal.rhs) + [g.expr for g in new.switching],
                            modules="mpmath")
        f_old = sp.lambdify(syms + list(old.modal.sigma), list(old.modal.rhs) + [g.expr for g in old.switching],
                            modules="mpmath")
        for sides in ((1, 1, 1), (1, -1, 1), (1, -1, -1), (-1, 1, 1)):
            a = f_new(*[vals[s_] for s_ in syms], *sides)
            b = f_old(*[vals[s_] for s_ in syms], *sides)
            for u_, w_ in zip(a, b):
                assert abs(u_ - w_) <= mp.mpf("1e-50") * (1 + abs(w_)), (trial, sides)


# ---------------------------------------------------------------- core change: gating


def test_gated_coordinate_disappears_with_its_effect():
    doc = {
        "model": {"name": "gated"},
        "coordinates": {"q": {"unit": "m", "velocity": "qd"},
                        "r": {"unit": "m", "velocity": "rd", "effect": "extra"}},
        "parameters": {"m": {"value": 1.0, "unit": "kg"}, "k": {"value": 4.0, "unit": "N/m"},
                       "kr": {"value": 9.0, "unit": "N/m"}},
        "effects": {"extra": {"meaning": "second mass"}},
        "elements": {"mq": {"type": "inertia", "coordinate": "q", "value": "m"},
                     "mr": {"type": "inertia", "coordinate": "r", "value": "m"},
                     "s": {"type": "spring", "deflection": "q - r", "stiffness": "k"},
                     "sr": {"type": "spring", "deflection": "r", "stiffness": "kr"}},
    }
    spec = parse_model(doc, "<gated>")
    scene = SceneSpec("<scene>", "g", "", "<gated>", {}, {}, {}, {})
    on = SymbolicModel(resolve_scene(scene, spec))
    off = SymbolicModel(resolve_scene(scene, spec, effects={"extra": False}))
    q, r = sp.symbols("q r", real=True)
    k, kr, m = sp.symbols("k kr m", real=True)
    assert on.state_names == ["q", "r", "qd", "rd"] and off.state_names == ["q", "qd"]
    assert sp.simplify(on.accelerations[1] - (k * (q - r) - kr * r) / m) == 0
    assert sp.simplify(off.accelerations[0] + k * q / m) == 0
    assert off.parameter_names == ["m", "k"]
    with pytest.raises(ParameterError, match="switched-off"):
        resolve_scene(scene, spec, effects={"extra": False}, overrides={"kr": 1.0})


@pytest.mark.parametrize("expr,message", [
    ("wm_mean_height(D, G, lam, q, l_a)", "must be the name of a parameter"),
    ("wm_mean_height(D, G, lam, 2*l_a, l_a)", "must be the name of a parameter"),
    ("wm_mean_height(D, lam, lam, l_a, l_a)", "argument 2 of wm_mean_height"),
    ("wm_mean_height(D, G, lam, l_a)", "takes 5 arguments"),
])
def test_bound_function_spec_errors(expr, message):
    doc = {
        "model": {"name": "bad"},
        "coordinates": {"q": {"unit": "m", "velocity": "qd"}},
        "parameters": {"m": {"value": 1.0, "unit": "kg"}, "D": 1.4, "lam": 1.5,
                       "G": {"value": 1e-11, "unit": "m"}, "l_a": {"value": 1e-4, "unit": "m"}},
        "derived": {"h": {"value": expr, "unit": "m"}},
        "elements": {"mq": {"type": "inertia", "coordinate": "q", "value": "m"}},
    }
    with pytest.raises(gearsym.errors.SpecError, match=message) as info:
        parse_model(doc, "<bad>")
    assert info.value.field == "derived.h.value"


# ----------------------------------------------------------------------- simulation


@pytest.fixture(scope="module")
def dyn_system(tmp_path_factory):
    return _model().compile(generated_dir=tmp_path_factory.mktemp("yu"))


def test_bound_fractal_height_is_recomputed_at_bind_time(dyn_system):
    s = dyn_system
    assert WM in s.param_names and WM not in s.params and "D" in s.params
    si = s.units.to_si(s.params)  # L_c, l_a are declared in um; the bound function takes SI
    args = [si[n] for n in ("G", "lam", "L_c", "l_a")]
    assert args == pytest.approx([1e-11, 1.5, 150e-6, 100e-6], rel=1e-15)
    p = dict(zip(s.param_names, s.param_vector()))
    assert p[WM] == wm_mean_height(1.4, *args)
    p12 = dict(zip(s.param_names, s.param_vector({"D": 1.2})))
    assert p12[WM] == wm_mean_height(1.2, *args) > p[WM]
    with pytest.raises(ParameterError):
        s.param_vector({WM: 1e-6})


def _ref_rhs(p: dict, b_i: float):
    """Unreduced eqs. 12-16 (12 states), hand-written in numpy."""
    c0 = math.cos(p["alpha0"])
    Rpb, Rgb = p["R_p"] * c0, p["R_g"] * c0
    a0, ab = p["R_p"] + p["R_g"], Rpb + Rgb
    me = 1 / (Rpb**2 / p["I_p"] + Rgb**2 / p["I_g"])
    wh = p["Omega"] * math.sqrt(p["k_m"] / me)
    cm = 2 * p["xi"] * math.sqrt(p["k_m"] * me)
    er = p["T_ah"] * p["b_n"]
    bs = p["b_0"] - 2 * b_i

    def geometry(t, y):
        thp, thg, xp, yp, xg, yg, wp, wg, vxp, vyp, vxg, vyg = y
        u, w, ud, wd = xp - xg, yp - yg, vxp - vxg, vyp - vyg
        a = math.hypot(a0 - u, w)
        al = math.acos(ab / a)
        sa, ca = math.sin(al), math.cos(al)
        ad = (-(a0 - u) * ud + w * wd) / a
        ald = ab / (a * math.sqrt(a * a - ab * ab)) * ad
        e = er * math.cos(wh * t + p["phi0"])
        ed = -er * wh * math.sin(wh * t + p["phi0"])
        delta = Rpb * thp - Rgb * thg + u * sa + w * ca - e
        ddelta = Rpb * wp - Rgb * wg + ud * sa + wd * ca + (u * ca - w * sa) * ald - ed
        da = a - a0
        dp = Rpb / 2 * (math.tan(al) ** 2 - math.tan(p["alpha0"]) ** 2)
        B = bs + math.copysign(math.sqrt(max(da * da - dp * dp, 0.0)), da)
        return delta, ddelta, B, sa, ca

    def rhs(t, y, mode):
        delta, ddelta, B, sa, ca = geometry(t, y)
        f = delta - B if mode == 1 else (delta + B if mode == -1 else 0.0)
        Fm = p["k_m"] * (1 + p["eps"] * math.sin(wh * t + p["phi0"])) * f + cm * ddelta
        xp, yp, xg, yg, wp, wg, vxp, vyp, vxg, vyg = y[2:]
        return [wp, wg, vxp, vyp, vxg, vyg,
                (p["T_p"] - Rpb * Fm) / p["I_p"], (-p["T_g"] + Rgb * Fm) / p["I_g"],
                (-p["c_px"] * vxp - p["k_px"] * xp - Fm * sa) / p["m_p"],
                (-p["c_py"] * vyp - p["k_py"] * yp - Fm * ca) / p["m_p"],
                (-p["c_gx"] * vxg - p["k_gx"] * xg + Fm * sa) / p["m_g"],
                (-p["c_gy"] * vyg - p["k_gy"] * yg + Fm * ca) / p["m_g"]]

    return rhs, geometry, (Rpb, Rgb, a0, ab, wh, er)


def _reference(p, b_i, x0, t_end, t_out):
    """Event-restarted DOP853 on the unreduced system; returns DTE and translations at t_out."""
    rhs, geometry, (Rpb, Rgb, a0, ab, wh, er) = _ref_rhs(p, b_i)
    x, xp, yp, xg, yg, v, vxp, vyp, vxg, vyg = x0
    # unreduced initial state with th_g = 0, w_g = 0 and the same DTE and DTE rate
    y0 = np.array([0.0, 0.0, xp, yp, xg, yg, 0.0, 0.0, vxp, vyp, vxg, vyg])
    d0, dd0, *_ = geometry(0.0, y0)
    y0[0] = (x - d0) / Rpb
    y0[6] = (v - dd0) / Rpb

    def mode_of(t, y):
        d, _, B, _, _ = geometry(t, y)
        return 1 if d > B else (-1 if d < -B else 0)

    def ev_drive(t, y, mode):
        d, _, B, _, _ = geometry(t, y)
        return d - B

    def ev_back(t, y, mode):
        d, _, B, _, _ = geometry(t, y)
        return d + B

    ev_drive.terminal = ev_back.terminal = True
    t, y, mode = 0.0, y0, mode_of(0.0, y0)
    ts, ys, events = [], [], []
    atol = np.array([1e-17] * 6 + [1e-12] * 6)
    while t < t_end:
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=atol, args=(mode,),
                        events=(ev_drive, ev_back), dense_output=True)
        t_stop = sol.t[-1]
        sel = (t_out >= t) & (t_out <= t_stop)
        if sel.any():
            ts.append(t_out[sel])
            ys.append(sol.sol(t_out[sel]).T)
        if sol.status == 1:
            which = 0 if sol.t_events[0].size else 1
            events.append((t_stop, which))
            y = sol.y[:, -1]
            # step to the other side of the surface along the flow to read the new mode
            mode = mode_of(t_stop + 1e-12, y + 1e-12 * np.asarray(rhs(t_stop, y, mode)))
            # leave the surface in the new mode (solve_ivp would re-detect g = 0 at t0)
            h = 1e-9 * (t_end - t_stop) if t_end > t_stop else 0.0
            if h > 0:
                y = solve_ivp(rhs, (t_stop, t_stop + h), y, method="DOP853", rtol=1e-13, atol=atol,
                              args=(mode,)).y[:, -1]
                t_stop += h
        t = t_stop
    T = np.concatenate(ts)
    Y = np.concatenate(ys)
    _, idx = np.unique(T, return_index=True)
    Y = Y[idx]
    dte = np.array([geometry(tt, yy)[0] for tt, yy in zip(T[idx], Y)])
    return dte, Y[:, 2:6], events


def test_simulation_vs_unreduced_scipy_reference(dyn_system):
    s = dyn_system
    Om = 0.9  # rattling regime: double-sided impacts
    T = 2 * math.pi / (Om * math.sqrt(3e8 * 2 * (0.094 * math.cos(math.radians(20))) ** 2 / 1.15e-3))
    t_end = 4 * T
    t_out = np.linspace(0.0, t_end, 161)
    tr = s.simulate(t_end=t_end, params={"Omega": Om}, rtol=1e-11, atol=1e-18, t_out=t_out)
    assert abs(tr.period - T) < 1e-12 * T
    # all inputs (D, G, ... of the bound function included) and the values of this run (Omega), in SI
    p = s.units.to_si({**s.params, **tr.params})
    b_i = tr.params[WM]
    dte, trans, events = _reference(p, b_i, s.x0, t_end, t_out)
    err = np.max(np.abs(tr["x"] - dte))
    assert err < 2e-11, err      # DTE ~ 2e-5 m
    err_t = np.max(np.abs(tr.y[:, 1:5] - trans))
    assert err_t < 2e-11, err_t
    names = ["mesh.drive", "mesh.back"]
    mine = [(e.t, e.surface) for e in tr.events if e.surface in names]
    assert len(mine) == len(events) >= 3
    for (te, se), (tr_, wr) in zip(mine, events):
        assert se == names[wr] and abs(te - tr_) < 1e-9 * T


def test_long_run_is_finite_and_events_are_consistent(dyn_system):
    s = dyn_system
    tr = s.simulate(periods=40, params={"Omega": 1.0}, rtol=1e-9, atol=1e-16)
    assert np.all(np.isfinite(tr.y))
    ev = [e for e in tr.events if e.surface.startswith("mesh.")]
    assert len(ev) > 40 and {e.surface for e in ev} == {"mesh.drive", "mesh.back"}
    # the guard of eq. 10 never acts: no crossing of its surface
    assert all(e.surface.startswith("mesh.") for e in tr.events)
    # per surface the crossings alternate in direction
    for name in ("mesh.drive", "mesh.back"):
        d = [e.direction for e in ev if e.surface == name]
        assert all(a == -b for a, b in zip(d, d[1:]))
    # at every event the state is on its surface; the sides agree with the directions
    te = np.array([e.t for e in ev])
    tr2 = s.simulate(periods=40, params={"Omega": 1.0}, rtol=1e-9, atol=1e-16, t_out=te)
    gfun = s.generated.casadi_function("gs_sw")
    pv = s.param_vector({"Omega": 1.0})
    names = s.surface_names
    for e, x in zip(ev, tr2.y):
        g = np.asarray(gfun(e.t, x, pv)).ravel()
        assert abs(g[names.index(e.surface)]) < 1e-11, (e, g)  # b ~ 2e-5 m, rtol 1e-9
    # the half backlash stays positive and is b_s + (a - a_0)*sqrt(1 - kappa^2)
    c0 = math.cos(math.radians(20))
    a0, ab, Rpb = 0.188, 0.188 * c0, 0.094 * c0
    u, w = tr["xp"] - tr["xg"], tr["yp"] - tr["yg"]
    a = np.hypot(a0 - u, w)
    B = 20e-6 - 2 * tr.params[WM] + (a - a0) * np.sqrt(1 - (Rpb * (a + a0) / (2 * ab**2)) ** 2)
    assert B.min() > 0
    # the static load pushes the centres apart: the dynamic backlash exceeds the constant one
    assert np.mean(a[len(a) // 2:] - a0) > 0
