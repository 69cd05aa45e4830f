"""Bifurcation curves in two parameters (gearsym.analysis.continuation.continue_bifurcation, issue 28).

Independent references:

* **Mathieu** ``x'' + (a - 2 q cos 2t) x = 0``: the branch-point (multiplier +1, ``m`` even) and
  period-doubling (-1, ``m`` odd) curves of the orbit ``x = 0`` in the ``(q, a)`` plane are the
  characteristic values ``a_m(q)``, ``b_m(q)`` of ``scipy.special.mathieu_a`` / ``mathieu_b``;
* **grazing**: the benchmark oscillator with ``eps = 0`` is linear while in contact, so the
  no-impact orbit is ``x = b + Fm + A cos(Omega t - phi)``, ``A = Fa Omega^2 / sqrt((1 - Omega^2)^2
  + (2 zeta Omega)^2)``, and it touches the drive flank (``g = x - b``, min 0) when ``Fm = A``;
* **fold**: the folds of the benchmark oscillator's frequency response at fixed ``Fa`` from a
  shooting written here with scipy (DOP853 on the state and its variational equations, the
  contact events located, the vector field continuous so no saltation jump) and a bracketed
  root of ``det(M - I)`` along a sweep of one state;
* **Neimark-Sacker**: the damped Mathieu equation ``x'' + c x' + (a - 2 q cos 2t) x = 0`` has a
  complex pair on the unit circle exactly at ``c = 0`` inside the stability intervals, with
  ``cos(omega) = tr(M) / 2`` (M from scipy here), and the pair meets at -1 at ``a_1(q)`` and at +1
  at ``b_2(q)``: the 1:2 and 1:1 resonances that end the curve.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

import gearsym
from gearsym.analysis.continuation import CODIM2_TYPES, CurveStart, continue_bifurcation
from gearsym.analysis.continuation._augmented import bordered
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]
KS = dict(zeta=0.05, Fm=0.1, Fa=0.05, eps=0.2, b=1.0, Omega=0.9)


@pytest.fixture(scope="module")
def mathieu():
    system = gearsym.load_scene(ROOT / "scenes" / "mathieu.toml").compile()
    branch = gearsym.continuation(system, "a", -1.0, 10.0, x0=[0.0, 0.0], params={"q": 1.0}, atol=1e-12,
                                  progress=False)
    return system, branch


@pytest.fixture(scope="module")
def ks():
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    branch = gearsym.continuation(system, "Omega", 0.6, 1.3, params={"Fa": 0.05}, progress=False)
    return system, branch


# ------------------------------------------------------------------ Mathieu
def _characteristic(kind: str, value: float, q: float = 1.0) -> tuple[object, int]:
    """The characteristic-value function and order of a special point of the branch in a at q."""
    best = None
    for m in range(5):
        for fn in ((mathieu_a,) if m == 0 else (mathieu_a, mathieu_b)):
            d = abs(float(fn(m, q)) - value)
            if best is None or d < best[0]:
                best = (d, fn, m)
    assert best[0] < 1e-6
    return best[1], best[2]


def test_mathieu_curves_are_the_characteristic_values(mathieu):
    """Every a_m(q), b_m(q) for m <= 3 from q = 0.5 to 10, continued from the special points of
    the branch in a at q = 1: even m as branch points (a fold asked for at an orbit that persists
    through +1), odd m as period doublings, each to 1e-7 over the whole curve."""
    system, branch = mathieu
    assert len(branch.bifurcations) == 7
    worst = 0.0
    for i, b in enumerate(branch.bifurcations):
        fn, m = _characteristic(b.type, b.value)
        follow = "fold" if b.type == "branch_point" else None
        curve = continue_bifurcation(system, follow, "q", "a", 0.5, 10.0, start_from=(branch, i), bounds2=(-20, 20),
                                     ds=0.05, ds_max=0.1)
        assert curve.complete, curve.stop_reasons
        assert curve.type == ("branch_point" if m % 2 == 0 else "period_doubling")
        q, a = curve.value, curve.value2
        assert q.min() == pytest.approx(0.5, abs=1e-9) and q.max() == pytest.approx(10.0, abs=1e-9)
        assert len(curve) >= 10
        err = float(np.max(np.abs(a - fn(m, q))))
        worst = max(worst, err)
        assert err < 1e-7, (fn.__name__, m, err)
        mu = curve.points[len(curve) // 2].multipliers
        # a double multiplier (Jordan block): the eigenvalues move like the square root of M's error
        assert np.max(np.abs(mu - (1.0 if m % 2 == 0 else -1.0))) < 5e-3
    assert worst > 0  # (compared at all)


# ------------------------------------------------------------------ grazing
def test_grazing_curve_is_the_linear_response_touching_the_flank():
    """eps = 0: the grazing curve of the drive flank in (Omega, Fm) is Fm = A(Omega) to 1e-8."""
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", eps=0.0).compile()
    branch = gearsym.continuation(system, "Omega", 0.6, 1.3, params={"Fa": 0.05}, progress=False)
    i = next(k for k, b in enumerate(branch.bifurcations) if b.type == "grazing")
    curve = continue_bifurcation(system, None, "Omega", "Fm", 0.5, 1.3, start_from=(branch, i), bounds2=(0.0, 1.0))
    assert curve.complete, curve.stop_reasons
    assert curve.type == "grazing" and "mesh.drive" in curve.info["formulation"]
    W, Fm = curve.value, curve.value2
    zeta, Fa = KS["zeta"], 0.05
    closed = Fa * W ** 2 / np.sqrt((1 - W ** 2) ** 2 + (2 * zeta * W) ** 2)
    assert float(np.max(np.abs(Fm - closed))) < 1e-8
    assert W.min() == pytest.approx(0.5) and W.max() == pytest.approx(1.3)
    assert np.max(Fm) > 0.45  # through the resonance peak Fa / (2 zeta) = 0.5
    # the touch: the orbit's minimum of x - b is zero (sampled at 512 points per period: to 1e-4)
    assert max(abs(p.surface_extrema["mesh.drive"][0]) for p in curve.points) < 1e-4


def _linear_flip_test(om: float, eps: float, zeta: float) -> float:
    """det(M + I) of x'' + 2 zeta x' + (1 + eps cos(Omega t)) x = 0 over one forcing period (scipy):
    the variational equation of every orbit that keeps the drive contact."""
    def rhs(t, y):
        k = 1.0 + eps * math.cos(om * t)
        return [y[1], -k * y[0] - 2 * zeta * y[1], y[3], -k * y[2] - 2 * zeta * y[3]]
    y = solve_ivp(rhs, (0, 2 * math.pi / om), [1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-12, atol=1e-13).y[:, -1]
    return float(np.linalg.det(np.array([[y[0], y[2]], [y[1], y[3]]]) + np.eye(2)))


def test_grazing_curve_crosses_the_flip_tongue_where_the_linear_orbit_doubles():
    """eps = 0.4: along the grazing curve the orbit keeps contact, so its multipliers are those of the
    linear parametric equation (independent of Fm): the curve meets period-doubling curves where that
    equation has a multiplier -1 -- the two edges of the principal tongue near Omega = 2 (scipy)."""
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", eps=0.4).compile()
    branch = gearsym.continuation(system, "Omega", 0.6, 1.3, params={"Fa": 0.05}, progress=False)
    i = next(k for k, b in enumerate(branch.bifurcations) if b.type == "grazing")
    curve = continue_bifurcation(system, None, "Omega", "Fm", 0.5, 2.5, start_from=(branch, i), bounds2=(0.0, 1.0))
    assert curve.complete, curve.stop_reasons
    found = sorted(s.value for s in curve.of_type("period_doubling_grazing"))
    assert [s.info["located"] for s in curve.special_points] == [True] * len(curve.special_points)
    ref = [brentq(_linear_flip_test, lo, hi, args=(0.4, KS["zeta"]), xtol=1e-13) for lo, hi in ((1.7, 1.95),
                                                                                               (2.05, 2.3))]
    assert len(found) == 2
    # (measured 3e-7 and 2e-11: at the touch the integration may cross the flank and back by its own
    # error, a free flight of ~sqrt(rtol) that moves the multipliers of the touching orbit)
    assert np.max(np.abs(np.array(found) - ref)) < 2e-6, (found, ref)


# ------------------------------------------------------------------ fold: scipy reference
def _period_map(x0: np.ndarray, p: dict, t0: float) -> tuple[np.ndarray, np.ndarray]:
    """``(x(t0 + T), M)`` of the benchmark oscillator by DOP853 on the state and its variational
    equations, restarted at each contact event (only the crossing out of the current mode armed)."""
    zeta, Fm, Fa, eps, b, Om = (p[k] for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega"))
    T = 2 * math.pi / Om

    def rhs(t, y, mode):
        c = math.cos(Om * t)
        k = 1.0 + eps * c
        f, df = (y[0] - b, 1.0) if mode > 0 else (y[0] + b, 1.0) if mode < 0 else (0.0, 0.0)
        J = np.array([[0.0, 1.0], [-k * df, -2 * zeta]])
        return np.concatenate([[y[1], Fm + Fa * Om * Om * c - 2 * zeta * y[1] - k * f],
                               (J @ y[2:].reshape(2, 2)).ravel()])

    armed = {1: [(b, -1)], 0: [(b, 1), (-b, -1)], -1: [(-b, 1)]}
    after = {(b, -1): 0, (b, 1): 1, (-b, -1): -1, (-b, 1): 0}
    y = np.concatenate([x0, np.eye(2).ravel()])
    mode = 1 if y[0] > b else -1 if y[0] < -b else 0
    t, t_end = t0, t0 + T
    while t < t_end:
        events = []
        for s, d in armed[mode]:
            def e(tt, yy, s=s):
                return yy[0] - s
            e.terminal, e.direction = True, d
            events.append(e)
        sol = solve_ivp(lambda tt, yy, m=mode: rhs(tt, yy, m), (t, t_end), y, method="DOP853", rtol=1e-12,
                        atol=1e-13, events=events, max_step=T / 16)
        y, t = sol.y[:, -1], sol.t[-1]
        if sol.status == 1:
            mode = after[armed[mode][next(k for k, te in enumerate(sol.t_events) if len(te))]]
    return y[:2], y[2:].reshape(2, 2)


def _orbit_with(s: float, i: int, z: np.ndarray, p: dict, t0: float) -> tuple[np.ndarray, float]:
    """The periodic orbit whose state ``i`` at ``t0`` is ``s``: Newton on (the other state, Omega);
    ``(z, det(M - I))``."""
    j = 1 - i
    for _ in range(8):
        x0 = np.empty(2)
        x0[i], x0[j] = s, z[0]
        xe, M = _period_map(x0, dict(p, Omega=z[1]), t0)
        h = 1e-6
        dOm = (_period_map(x0, dict(p, Omega=z[1] + h), t0)[0] - _period_map(x0, dict(p, Omega=z[1] - h), t0)[0]) / (2 * h)
        dz = np.linalg.solve(np.column_stack([M[:, j] - np.eye(2)[:, j], dOm]), x0 - xe)
        z = z + dz
        if np.max(np.abs(dz)) < 1e-11:
            break
    x0 = np.empty(2)
    x0[i], x0[j] = s, z[0]
    return z, float(np.linalg.det(_period_map(x0, dict(p, Omega=z[1]), t0)[1] - np.eye(2)))


def _scipy_fold(p: dict, x_near: np.ndarray, om_near: float, t0: float, delta: float = 2e-3) -> float:
    """The fold's Omega near a point: det(M - I) changes sign along a sweep of the state that
    parametrises the branch through the fold; its root by brentq, each value a shooting solve."""
    M = _period_map(x_near, dict(p, Omega=om_near), t0)[1]
    i = int(np.argmax(np.abs(np.linalg.svd(M - np.eye(2))[2][-1])))
    last = {"z": np.array([x_near[1 - i], om_near])}

    def tau(s: float) -> float:
        z, d = _orbit_with(s, i, last["z"], p, t0)
        last["z"], last[s] = z, z
        return d

    lo, hi = x_near[i] - delta, x_near[i] + delta
    assert tau(lo) * tau(hi) < 0
    root = brentq(tau, lo, hi, xtol=1e-12)
    return float(last[root][1] if root in last else _orbit_with(root, i, last["z"], p, t0)[0][1])


def test_fold_curve_matches_scipy_folds_and_has_the_cusp(ks):
    """The fold curve of the impacting response in (Omega, Fa) equals, at six values of Fa, the
    folds of one-parameter problems solved here with scipy (to 1e-7); its two folds meet in a
    cusp, and a one-parameter continuation just above the cusp's Fa has two folds, just below none."""
    system, branch = ks
    i = min((k for k, b in enumerate(branch.bifurcations) if b.type == "fold"),
            key=lambda k: branch.bifurcations[k].value)  # the jump-up fold near Omega 0.84
    curve = continue_bifurcation(system, "fold", "Omega", "Fa", 0.5, 1.3, start_from=(branch, i),
                                 bounds2=(0.0, 0.2))
    assert curve.complete, curve.stop_reasons
    assert curve.info["formulation"] == "bordered M - I"
    cusps = curve.of_type("cusp")
    assert len(cusps) == 1 and cusps[0].info["located"]
    fa_cusp, om_cusp = cusps[0].value2, cusps[0].value
    # three points on each of the two folds, away from the cusp (where the fold is degenerate:
    # det(M - I) has a double root along the branch, no sign change to bracket)
    sides = [[k for k in range(2, len(curve) - 2) if (k < cusps[0].index) == left
              and curve.points[k].value2 > fa_cusp + 0.01] for left in (True, False)]
    picks = [side[j] for side in sides for j in np.linspace(0, len(side) - 1, 3).astype(int)]
    for k in picks:
        pt = curve.points[k]
        ref = _scipy_fold(dict(KS, Fa=pt.value2), pt.x0, pt.value, pt.t0)
        assert abs(pt.value - ref) < 1e-7, (pt.value2, pt.value, ref)
    assert len({round(curve.points[k].value2, 3) for k in picks}) >= 5
    for dfa, n_folds in ((+0.003, 2), (-0.003, 0)):
        br = gearsym.continuation(system, "Omega", om_cusp - 0.1, om_cusp + 0.1, params={"Fa": fa_cusp + dfa},
                                  progress=False, detect=["fold"])
        assert len(br.of_type("fold")) == n_folds, (dfa, [b.value for b in br.bifurcations])


# ------------------------------------------------------------------ Neimark-Sacker
DAMPED_MATHIEU = """
[model]
name = "damped_mathieu"
description = "damped Mathieu equation x'' + c x' + (a - 2 q cos 2t) x = 0 (c of either sign)"
time_unit = "1"

[coordinates.x]
unit = "1"
velocity = "v"

[parameters]
a = { value = 2.9, meaning = "a" }
q = { value = 1.0, meaning = "q" }
c = { value = 0.0, meaning = "damping (a force -c v: either sign)" }

[forcing]
period = "pi"

[elements.mass]
type = "inertia"
coordinate = "x"
value = "1"

[elements.spring]
type = "spring"
deflection = "x"
stiffness = "a - 2*q*cos(2*t)"

[elements.friction]
type = "force"
coordinate = "x"
value = "-c*v"

[initial]
x = 1.0
v = 0.0
"""


def _mathieu_trace(a: float, q: float) -> float:
    """tr M of the undamped Mathieu equation over pi, by scipy."""
    def rhs(t, y):
        k = a - 2 * q * math.cos(2 * t)
        return [y[1], -k * y[0], y[3], -k * y[2]]
    y = solve_ivp(rhs, (0, math.pi), [1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-12, atol=1e-13).y[:, -1]
    return y[0] + y[3]


def test_neimark_sacker_curve_of_the_damped_mathieu_equation(tmp_path):
    """From a guess inside the stability interval (a_1, b_2) at q = 1: the curve is c = 0, its
    omega is arccos(tr M / 2), and it ends at the 1:2 resonance a_1(1) and the 1:1 resonance b_2(1)."""
    (tmp_path / "dm.toml").write_text(DAMPED_MATHIEU)
    (tmp_path / "dm_scene.toml").write_text('[scene]\nname = "dm"\nmodel = "dm.toml"\n')
    system = gearsym.load_scene(tmp_path / "dm_scene.toml").compile()
    curve = continue_bifurcation(system, "neimark_sacker", "a", "c", 1.0, 5.0,
                                 start_from=CurveStart.guess({"a": 2.9, "c": 0.001}, [0.0, 0.0]), bounds2=(-1, 1))
    assert curve.complete, curve.stop_reasons
    assert all("resonance" in r for r in curve.stop_reasons)
    inner = [p for p in curve.points if 0.1 < p.extras["omega"] < math.pi - 0.1]
    assert len(inner) >= 10
    assert max(abs(p.value2) for p in inner) < 1e-8
    for p in inner[::3]:
        assert math.cos(p.extras["omega"]) == pytest.approx(_mathieu_trace(p.value, 1.0) / 2, abs=1e-7)
    r12, r11 = curve.of_type("resonance_1_2"), curve.of_type("resonance_1_1")
    assert len(r12) == 1 and len(r11) == 1
    assert abs(r12[0].value - mathieu_a(1, 1.0)) < 1e-6
    assert abs(r11[0].value - mathieu_b(2, 1.0)) < 1e-6


# ------------------------------------------------------------------ bad input
def test_bad_input_is_refused_with_the_name(mathieu, ks):
    system, branch = mathieu
    pd = next(k for k, b in enumerate(branch.bifurcations) if b.type == "period_doubling")
    with pytest.raises(ParameterError, match="period_doubling.*a fold curve starts from fold or branch_point"):
        continue_bifurcation(system, "fold", "q", "a", 0.5, 10.0, start_from=(branch, pd))
    with pytest.raises(ParameterError, match="param2 'nope' is not a run-time parameter"):
        continue_bifurcation(system, None, "q", "nope", 0.5, 10.0, start_from=(branch, pd))
    with pytest.raises(ParameterError, match="two different parameters"):
        continue_bifurcation(system, None, "a", "a", 0.5, 10.0, start_from=(branch, pd))
    with pytest.raises(ParameterError, match="the start's q = 1 lies outside its range 2 .. 10"):
        continue_bifurcation(system, None, "q", "a", 2.0, 10.0, start_from=(branch, pd))
    with pytest.raises(ParameterError, match="index 9 out of range: the branch has 7"):
        continue_bifurcation(system, None, "q", "a", 0.5, 10.0, start_from=(branch, 9))
    with pytest.raises(ParameterError, match="the type of the curve is needed"):
        continue_bifurcation(system, None, "q", "a", 0.5, 10.0, start_from=CurveStart.guess({"q": 1, "a": 1}))
    with pytest.raises(ParameterError, match="unknown curve type 'hopf'"):
        continue_bifurcation(system, "hopf", "q", "a", 0.5, 10.0, start_from=(branch, pd))
    ks_system, ks_branch = ks
    g = next(k for k, b in enumerate(ks_branch.bifurcations) if b.type == "grazing")
    with pytest.raises(ParameterError, match="surface 'mesh.side' is not a switching surface.*mesh.drive"):
        continue_bifurcation(ks_system, None, "Omega", "Fm", 0.5, 1.3, start_from=(ks_branch, g), surface="mesh.side")
    with pytest.raises(ParameterError, match="direction must be one of"):
        continue_bifurcation(ks_system, None, "Omega", "Fm", 0.5, 1.3, start_from=(ks_branch, g), direction="up")


def test_codim2_types_are_documented():
    for name in ("cusp", "fold_flip", "resonance_1_1", "resonance_1_2", "fold_grazing"):
        assert name in CODIM2_TYPES


# ------------------------------------------------------------------ the bordered test function
def test_bordered_test_function_vanishes_at_singularity_and_has_the_adjoint_derivative():
    """g of [[A, b], [c^T, 0]] is zero exactly where A is singular, and dg = -w^T dA v (compared with a
    central difference of g); the same for a complex A and the extended (n x n+1) form."""
    rng = np.random.default_rng(3)
    U, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    A0 = U @ np.diag([2.0, 1.0, 0.5, 0.0]) @ U.T
    b, c = rng.normal(size=4), rng.normal(size=4)
    assert abs(bordered(A0, b, c)[1][0, 0]) < 1e-13
    for A in (A0 + 0.1 * rng.normal(size=(4, 4)), A0 + 0.1j * rng.normal(size=(4, 4))):
        dA = rng.normal(size=(4, 4))
        V, G, w = bordered(A, b.astype(A.dtype), c.astype(A.dtype))
        h = 1e-6
        fd = (bordered(A + h * dA, b, c)[1][0, 0] - bordered(A - h * dA, b, c)[1][0, 0]) / (2 * h)
        assert abs(fd - (-(w.conj() @ dA @ V[:, 0]))) < 1e-7 * max(1.0, abs(fd))
    E = np.hstack([A0, rng.normal(size=(4, 1))])
    C = rng.normal(size=(5, 2))
    V, G, w = bordered(E, b, C)
    dE = rng.normal(size=(4, 5))
    h = 1e-6
    fd = (bordered(E + h * dE, b, C)[1] - bordered(E - h * dE, b, C)[1]) / (2 * h)
    assert np.allclose(fd[0], -(w @ dE @ V), atol=1e-7)
