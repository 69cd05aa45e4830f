"""The noncircular face gear model (models/liu_nfg.toml; Liu, Lv, Zhao, Mech. Sci. 2021).

* The derived equation against a hand derivation from the paper's physical
  statements (eq. 5 with q1 = 0, eq. 1 + eq. 18 for the base radius and the rigid
  angle, eq. 19 for k_m and e, q = q2 + e/rb2), written here with sympy independently
  of the model file.  Mapping for the exact comparison: every parameter positive,
  eps = u/(1 + u) with u > 0 (0 < eps < 1), and the trigonometric functions of time
  replaced by symbols C = cos(omega_c*t), S = sin(omega_c*t), SE/CE, SM/CM of
  omega_e*t + phi_e / phi_m; the numerator of (model - hand) reduces to 0 modulo
  S^2 + C^2 - 1.
* The pieces of the reading: theta2'' from eq. 18 (and eq. 20 as printed differs),
  rb2 = rb1*i12 = L*(1 + beta*cos(omega_c*t)), mean(rb2^2) = L^2*(1 + beta^2/2) (eq. 10),
  the eq. 9 coefficients F(tau) and zeta, the switching surfaces rb2*q -+ b
  (eq. 12's backlash b/rb2(t)) with the drive side q < -b/rb2.
* The compiled model against scipy DOP853 with event location on the hand-derived
  right-hand side (bilateral rattle at 180 rad/s, half an instantaneous-center cycle).
* The rattle sequence of Figs. 8-10: state 0, 1, 2 at omega1 = 140, 160, 180 rad/s,
  with the jump of the peak-to-peak value at the onset of bilateral rattle.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import gearsym
from gearsym.analysis.periodic._rattle import BILATERAL, NO_RATTLE, UNILATERAL, peak_to_peak, rattle_summary

ROOT = Path(__file__).resolve().parents[1]
SCENES = {w: ROOT / "scenes" / f"liu_nfg_{w}.toml" for w in (140, 160, 180)}
NAMES = ["omega1", "Z1", "Z2", "eps", "rb1", "I2", "k0", "kr", "phi_m", "zeta", "e0", "er", "phi_e",
         "b", "T2"]


# --------------------------------------------------------------- hand derivation


class Hand:
    """Eq. 5 of Liu et al. with q1 = 0, derived here by hand (sympy), in q = q2 + e/rb2."""

    def __init__(self, t: sp.Symbol, q: sp.Symbol, v: sp.Symbol):
        self.t, self.q, self.v = t, q, v
        P = {n: sp.Symbol(n, real=True) for n in NAMES}
        self.P = P
        omega1, Z1, Z2, eps, rb1 = P["omega1"], P["Z1"], P["Z2"], P["eps"], P["rb1"]
        ij = Z2 / Z1
        self.omega_c = omega1 / ij                 # f1 = omega1/(2*pi*ij)
        self.omega_e = Z1 * omega1                 # f2 = omega1*Z1/(2*pi)
        i12 = ij * (1 + 2 * eps * sp.cos(self.omega_c * t) + eps**2) / (1 - eps**2)   # eq. 18
        self.i12 = i12
        self.rb2 = rb1 * i12                       # eq. 1: r2 = r1*i12 (base radii: times cos(alpha))
        self.theta2_dd = sp.diff(omega1 / i12, t)  # rigid angle: theta2' = omega1/i12
        self.km = P["k0"] + P["kr"] * sp.sin(self.omega_e * t + P["phi_m"])     # eq. 19
        self.e = P["e0"] + P["er"] * sp.sin(self.omega_e * t + P["phi_e"])       # eq. 19
        x = sp.Symbol("x", real=True)
        # mean of rb2^2 over one instantaneous-center cycle (the x = omega_c*t average)
        self.mean_rb2sq = (rb1 * ij / (1 - eps**2))**2 * sp.integrate(
            sp.expand((1 + eps**2 + 2 * eps * sp.cos(x))**2), (x, 0, 2 * sp.pi)) / (2 * sp.pi)
        self.omega_n = sp.sqrt(P["k0"] * self.mean_rb2sq / P["I2"])             # eq. 10
        self.c_m = 2 * P["zeta"] * P["I2"] * self.omega_n / self.mean_rb2sq      # eq. 9's zeta

    def acceleration(self, branch: str) -> sp.Expr:
        """q'' in one contact mode: f(x) = x + b (drive), 0 (separation), x - b (back)."""
        P, t = self.P, self.t
        fb = {"drive": lambda x: x + P["b"], "sep": lambda x: 0, "back": lambda x: x - P["b"]}[branch]
        q2 = sp.Function("q2")(t)
        x = self.rb2 * q2 + self.e
        q2dd = (-P["T2"] - P["I2"] * self.theta2_dd
                - self.rb2 * self.c_m * (self.rb2 * sp.diff(q2, t) + sp.diff(self.e, t))
                - self.rb2 * self.km * fb(x)) / P["I2"]                           # eq. 5
        qdd = q2dd + sp.diff(self.e / self.rb2, t, 2)                             # q = q2 + e/rb2
        qf = sp.Function("qf")(t)
        qdd = qdd.subs(q2, qf - self.e / self.rb2).doit()
        return qdd.subs(sp.Derivative(qf, t), self.v).subs(qf, self.q)


@pytest.fixture(scope="module")
def model():
    return gearsym.load_scene(SCENES[160]).model


@pytest.fixture(scope="module")
def hand(model):
    q, v = model.states
    return Hand(model.t, q, v)


def _canon(expr: sp.Expr, hand: Hand) -> tuple[sp.Expr, tuple[sp.Symbol, sp.Symbol]]:
    """The mapping of the module docstring (positive parameters, eps = u/(1+u), trig -> symbols)."""
    P, t = hand.P, hand.t
    pos = {s: sp.Symbol(str(s), positive=True) for n, s in P.items() if n != "eps"}
    u = sp.Symbol("u", positive=True)
    C, S, SE, CE, SM, CM = sp.symbols("C S SE CE SM CM", real=True)
    e = expr.xreplace(pos).xreplace({P["eps"]: u / (1 + u)})
    wc = (hand.omega_c * t).xreplace(pos)
    we = (hand.omega_e * t).xreplace(pos)
    e = e.subs({sp.cos(wc): C, sp.sin(wc): S})
    e = e.subs({sp.sin(we + pos[P["phi_e"]]): SE, sp.cos(we + pos[P["phi_e"]]): CE,
                sp.sin(we + pos[P["phi_m"]]): SM, sp.cos(we + pos[P["phi_m"]]): CM})
    assert not e.has(t), f"time left after the mapping: {e.atoms(sp.Function)}"
    return e, (S, C)


def _identical(a: sp.Expr, b: sp.Expr, hand: Hand) -> bool:
    ca, (S, C) = _canon(a, hand)
    cb, _ = _canon(b, hand)
    num = sp.expand(sp.numer(sp.cancel(sp.together(ca - cb))))
    if num == 0:
        return True
    _, rem = sp.reduced(num, [S**2 + C**2 - 1], S, C)
    return sp.expand(rem) == 0


def _branches(model) -> dict[str, sp.Expr]:
    """The model's q'' per contact mode, identified by the condition at q = +-1 rad."""
    acc = model.accelerations[0]
    assert isinstance(acc, sp.Piecewise) and len(acc.args) == 3
    q = model.states[0]
    point = {sp.Symbol(n, real=True): sp.Integer(1) for n in NAMES}
    point[sp.Symbol("eps", real=True)] = sp.Rational(1, 10)
    point[model.t] = sp.Integer(0)
    out = {}
    for expr, cond in acc.args:
        if cond == sp.true:
            out["sep"] = expr
        elif bool(cond.xreplace({**point, q: sp.Integer(1)})):
            out["back"] = expr
        else:
            assert bool(cond.xreplace({**point, q: sp.Integer(-1)}))
            out["drive"] = expr
    assert set(out) == {"drive", "sep", "back"}
    return out


@pytest.mark.parametrize("branch", ["drive", "sep", "back"])
def test_equation_of_motion_matches_hand_derivation(model, hand, branch):
    assert _identical(_branches(model)[branch], hand.acceleration(branch), hand)


def test_rigid_angle_acceleration_eq18_and_misprinted_eq20(model, hand):
    alpha2 = model.ns.parse("alpha2")
    assert _identical(alpha2, hand.theta2_dd, hand)
    # eq. 20 as printed (in tau = omega_n*t, Omega_c = omega_c/omega_n) does not follow
    P, t = hand.P, hand.t
    eps = P["eps"]
    Oc = hand.omega_c / hand.omega_n
    tau = hand.omega_n * t
    printed = 2 * Oc * eps * (1 - eps**2) * sp.sin(Oc * tau) / (1 + 2 * eps * sp.cos(Oc * tau) + eps**2)
    derived = hand.theta2_dd / hand.omega_n**2
    vals = {P["omega1"]: 160, P["Z1"]: 16, P["Z2"]: 64, eps: sp.Rational(12, 100), P["rb1"]: sp.Rational(2255, 100000),
            P["k0"]: 2 * 10**8, P["I2"]: sp.Rational(3, 100), t: sp.Rational(1, 100)}
    assert abs(float((printed - derived).xreplace(vals))) > 10 * abs(float(derived.xreplace(vals)))
    # the mean of theta2' is omega_c = omega1/ij (one instantaneous-center cycle per NFG turn)
    x = sp.Symbol("x")
    mean = sp.integrate((P["omega1"] / hand.i12).subs(hand.omega_c * t, x).subs(vals | {x: x}), (x, 0, 2 * sp.pi))
    assert float(mean / (2 * sp.pi)) == pytest.approx(160 / 4, rel=1e-12)


def test_base_radius_and_natural_frequency(model, hand):
    rb2 = model.ns.parse("rb2")
    assert _identical(rb2, hand.rb2, hand)  # eq. 8 with beta, L from eqs. 1 and 18
    L, beta = model.ns.parse("L"), model.ns.parse("beta")
    assert _identical(hand.mean_rb2sq, L**2 * (1 + beta**2 / 2), hand)   # eq. 10
    assert _identical(model.ns.parse("omega_n")**2, hand.omega_n**2, hand)
    assert _identical(model.ns.parse("e_s_dot"), sp.diff(model.ns.parse("e_s"), hand.t), hand)


def test_eq9_coefficients(model, hand):
    """Drive contact: q'' = -omega_n^2*F(tau)*(q + b/rb2) - 2*zeta*omega_n*(rb2^2/mean)*q' + ..."""
    q, v = model.states
    drive = _branches(model)["drive"]
    P = hand.P
    beta = 2 * P["eps"] / (1 + P["eps"]**2)
    shape = (1 + beta * sp.cos(hand.omega_c * hand.t))**2 / (1 + beta**2 / 2)
    F = hand.km / P["k0"] * shape                                                # F(tau) of eq. 9
    assert _identical(sp.diff(drive, q), -hand.omega_n**2 * F, hand)
    assert _identical(sp.diff(drive, v), -2 * P["zeta"] * hand.omega_n * shape, hand)


def test_switching_surfaces_time_varying_backlash(model, hand):
    q = model.states[0]
    by_name = {g.name: g for g in model.switching}
    assert set(by_name) == {"mesh.drive", "mesh.back"}
    drive, back = by_name["mesh.drive"], by_name["mesh.back"]
    assert (drive.kind, drive.contact_sign) == ("drive", -1)   # drive contact: rb2*q + b < 0
    assert (back.kind, back.contact_sign) == ("back", +1)      # back contact: rb2*q - b > 0
    b = hand.P["b"]
    assert _identical(drive.expr, hand.rb2 * q + b, hand)
    assert _identical(back.expr, hand.rb2 * q - b, hand)


# -------------------------------------------------------- numerical reference


def _hand_rhs(hand: Hand, values: dict[str, float]):
    """Hand-derived right-hand side per mode, lambdified (no gearsym code)."""
    subs = {hand.P[n]: values[n] for n in NAMES}
    fns = {}
    for br in ("drive", "sep", "back"):
        fns[br] = sp.lambdify((hand.t, hand.q, hand.v), hand.acceleration(br).xreplace(subs), "numpy")
    rb2 = sp.lambdify(hand.t, hand.rb2.xreplace(subs), "numpy")
    return fns, rb2


def _reference(hand: Hand, values: dict[str, float], x0, t_eval: np.ndarray):
    """DOP853 on one contact mode at a time, with direction-armed terminal events on
    g = rb2*q + b (drive flank, contact g < 0) and g = rb2*q - b (back flank, contact g > 0),
    restarted in the next mode at each crossing."""
    fns, rb2 = _hand_rhs(hand, values)
    b = values["b"]
    # mode -> [(surface, sign of b in g, crossing direction, next mode)]
    arms = {
        "drive": [("mesh.drive", +1, +1, "sep")],
        "sep": [("mesh.drive", +1, -1, "drive"), ("mesh.back", -1, +1, "back")],
        "back": [("mesh.back", -1, -1, "sep")],
    }
    t, y = float(t_eval[0]), np.array(x0, float)
    g = rb2(t) * y[0]
    mode = "drive" if g + b < 0 else ("back" if g - b > 0 else "sep")
    out = np.empty((t_eval.size, 2))
    events: list[tuple[float, str]] = []
    while True:
        def rhs(tt, yy, f=fns[mode]):
            return [yy[1], f(tt, yy[0], yy[1])]

        evs = []
        for _name, sb, direction, _nxt in arms[mode]:
            def ev(tt, yy, sb=sb):
                return rb2(tt) * yy[0] + sb * b
            ev.terminal = True
            ev.direction = direction
            evs.append(ev)
        sol = solve_ivp(rhs, (t, float(t_eval[-1])), y, method="DOP853", rtol=1e-11, atol=1e-16,
                        events=evs, dense_output=True)
        hit = [(te[0], i) for i, te in enumerate(sol.t_events) if te.size]
        mask = t_eval >= t
        if not hit:
            if mask.any():
                out[mask] = sol.sol(t_eval[mask]).T
            return out, events
        te, i = min(hit)
        seg = mask & (t_eval <= te)
        if seg.any():
            out[seg] = sol.sol(t_eval[seg]).T
        name, _sb, _d, nxt = arms[mode][i]
        events.append((te, name))
        t, y, mode = te, sol.sol(te), nxt


@pytest.fixture(scope="module")
def system():
    return gearsym.load_scene(SCENES[160]).compile()


def test_engine_against_hand_reference_bilateral(system, hand):
    """180 rad/s (bilateral rattle) over the rattling part of the first instantaneous-center
    cycle, [0.45, 0.9]*T: drive-side separations, back-flank impacts, back to drive contact.
    Both start from the engine's state at 0.45*T (reached in smooth drive contact)."""
    scene = gearsym.load_scene(SCENES[180])
    values = {n: scene.resolved.values[n] for n in NAMES}
    T = 2 * np.pi / (values["omega1"] * values["Z1"] / values["Z2"])
    prm = {"omega1": values["omega1"]}
    start = system.simulate(t_end=0.45 * T, x0=scene.initial_state(), rtol=1e-11, atol=1e-16,
                            params=prm)
    assert not start.events
    t_eval = np.linspace(0.45 * T, 0.9 * T, 2001)
    x0 = start.x_final
    traj = system.simulate(t0=t_eval[0], t_out=t_eval, t_end=t_eval[-1], x0=x0, rtol=1e-11,
                           atol=1e-16, params=prm)
    y_ref, ev_ref = _reference(hand, values, x0, t_eval)
    names = [e.surface for e in traj.events]
    assert names == [n for _, n in ev_ref]
    assert "mesh.back" in names                                   # it does reach the back flank
    assert np.allclose([e.t for e in traj.events], [t for t, _ in ev_ref], rtol=0, atol=5e-10)
    scale = np.max(np.abs(y_ref), axis=0)
    assert np.max(np.abs(traj.y - y_ref) / scale) < 3e-7


# ------------------------------------------------------------ rattle sequence


def test_scenes_differ_only_in_speed():
    base = gearsym.load_scene(SCENES[160]).resolved
    for w, path in SCENES.items():
        rs = gearsym.load_scene(path).resolved
        assert rs.effects == base.effects
        diff = {k for k in base.values if rs.values[k] != base.values[k]}
        assert diff <= {"omega1"} and rs.values["omega1"] == float(w)


def test_rattle_sequence_figs_8_to_10(system):
    """rsv = 0, 1, 2 at 140, 160, 180 rad/s (paper: unilateral from 150 to 170 rad/s)."""
    states, ppv = {}, {}
    for w, path in SCENES.items():
        scene = gearsym.load_scene(path)
        sim = scene.spec.simulate
        periods, transient = sim["periods"], sim["transient_periods"]
        traj = system.simulate(periods=periods, x0=scene.initial_state(), rtol=sim["rtol"],
                               atol=sim["atol"], params={"omega1": scene.resolved.values["omega1"]})
        s = rattle_summary(traj, system=system, steady_fraction=(periods - transient) / periods)
        assert s.t_start == pytest.approx(transient * traj.period, rel=1e-9)
        states[w] = s.state
        ppv[w] = peak_to_peak(traj, "q", t_start=s.t_start)
        if s.state == NO_RATTLE:
            # in drive contact throughout: q stays below the moving drive flank -b/rb2(t)
            rb2 = sp.lambdify(sp.Symbol("t", real=True), scene.model.ns.parse("rb2").xreplace(
                {sp.Symbol(n, real=True): scene.resolved.values[n] for n in NAMES}), "numpy")
            on = traj.t >= s.t_start
            assert np.all(traj["q"][on] < -scene.resolved.values["b"] / rb2(traj.t[on]))
    assert states == {140: NO_RATTLE, 160: UNILATERAL, 180: BILATERAL}
    # ppv grows slowly without / with unilateral rattle and jumps at bilateral rattle (Fig. 11b)
    assert ppv[140] < ppv[160] < 1.1 * ppv[140]
    assert ppv[180] > 3 * ppv[160]
