"""Continuation of periodic orbits against independent references.

* Brute-force up and down sweeps of the benchmark scene (integrate to steady state
  at each parameter value, starting from the previous value's final state): the
  stable parts of the continued branch coincide with them (peak-to-peak to 1e-4)
  and their jumps happen at the located folds / grazings (to 0.005 in Omega).
* Grazing points of the non-impacting orbit: the periodic solution of the linear
  (drive-side contact) equation written by hand and solved with scipy; the grazing
  frequency is the root of ``min_t x(t) = b``.
* A period doubling located where the brute-force Poincare sequence doubles, and
  the switched-on period-2 branch equal to the brute-force period-2 attractor.
* Neimark-Sacker points of a 2-DOF gear pair (spur pair on a flexible output
  shaft, written here) against the Floquet multipliers of its linearised contact
  equations computed with scipy (variational equations by hand).
* The number of unstable multipliers changes exactly at the located bifurcations.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import gearsym
from gearsym.analysis.continuation import switch_period_doubling

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "scenes" / "kahraman_singh.toml"
KS = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0}


@pytest.fixture(scope="module")
def ks_system():
    return gearsym.load_scene(SCENE).compile()


@pytest.fixture(scope="module")
def ks_branch(ks_system):
    return gearsym.continuation(ks_system, "Omega", 0.6, 1.4, progress=False)


# ------------------------------------------------------------------ brute force
def returns_to_orbit(system, point, periods=300, offset=1e-4):
    """Whether integration from the branch point's state plus ``offset`` (every state) comes
    back to it: after ``periods`` forcing periods the Poincare point is within 1e-6."""
    T = system.period({"Omega": point.value})
    tr = system.simulate(t_end=periods * T, x0=np.asarray(point.x0) + offset, params={"Omega": point.value},
                         n_out=2, rtol=1e-10, atol=1e-12)
    return bool(np.max(np.abs(tr.x_final - point.x0)) < 1e-6)


def steady_state(system, params, x, block=100, max_periods=4000, tol=1e-10):
    """Integrate blocks of forcing periods until the Poincare point repeats (period 1)
    or ``max_periods`` are spent; then one dense period.  Returns (x, max, min, poincare)."""
    n = 0
    while n < max_periods:
        tr = system.simulate(periods=block, x0=x, params=params, rtol=1e-10, atol=1e-12, n_out=block + 1)
        x = tr.x_final
        n += block
        if np.max(np.abs(tr.y[-1] - tr.y[-2])) < tol and np.max(np.abs(tr.y[-1] - tr.y[-block // 2])) < tol:
            break
    tr = system.simulate(periods=1, x0=x, params=params, rtol=1e-10, atol=1e-12, n_out=4097)
    y = tr.y[:, 0]
    return tr.x_final, float(y.max()), float(y.min())


def sweep(system, values, x0):
    x = np.asarray(x0, float)
    out = []
    for w in values:
        x, hi, lo = steady_state(system, {"Omega": float(w)}, x)
        out.append((float(w), hi, lo, x.copy()))
    return out


def jumps(result, threshold=0.05):
    """Consecutive sweep values across which the peak-to-peak jumps."""
    return [(a, b) for a, b in zip(result[:-1], result[1:]) if abs((b[1] - b[2]) - (a[1] - a[2])) > threshold]


def refine_jump(system, a, b, step=5e-4):
    """Sweep finely from the state at ``a`` towards ``b``; the jump's bracket."""
    vals = np.arange(a[0], b[0], step if b[0] > a[0] else -step)[1:]
    prev = a
    x = a[3]
    for w in vals:
        x, hi, lo = steady_state(system, {"Omega": float(w)}, x)
        cur = (float(w), hi, lo, x)
        if abs((hi - lo) - (prev[1] - prev[2])) > 0.05:
            return prev[0], cur[0]
        prev = cur
    return prev[0], b[0]


# ------------------------------------------------------------------ benchmark scene
def test_branch_covers_range_and_jumps_at_located_points(ks_system, ks_branch):
    br = ks_branch
    assert br.stop_reason.startswith("reached")
    assert br.values[0] == pytest.approx(0.6) and br.values[-1] == pytest.approx(1.4)
    folds = [b.value for b in br.of_type("fold")]
    grazings = [b.value for b in br.of_type("grazing")]
    assert len(folds) == 2 and len(grazings) == 2
    special = np.array(folds + grazings)

    stable_vals = br.values[br.stable][::3]
    grid = np.unique(np.round(np.concatenate([np.arange(0.6, 1.4001, 0.02), stable_vals]), 12))
    up = sweep(ks_system, grid, ks_system.x0)
    down = sweep(ks_system, grid[::-1], up[-1][3])

    # jumps of the sweeps at the located folds / grazings
    located_jumps = []
    for res in (up, down):
        js = jumps(res)
        assert len(js) == 1, f"expected one jump per sweep, got {[(a[0], b[0]) for a, b in js]}"
        lo, hi = refine_jump(ks_system, *js[0])
        mid = 0.5 * (lo + hi)
        located_jumps.append(mid)
        assert np.min(np.abs(special - mid)) < 0.005, (mid, special)
    assert located_jumps[0] > located_jumps[1] + 0.03  # hysteresis: up jump above down jump

    # every stable branch point is on one of the sweeps' attractors (peak-to-peak to 1e-4)
    ptp_up = {round(w, 12): hi - lo for w, hi, lo, _ in up}
    ptp_down = {round(w, 12): hi - lo for w, hi, lo, _ in down}
    # (or, where a sweep steps across a narrow stable segment -- between the grazing at 0.8922 and
    # the fold at 0.8941 -- and lands on the other attractor, an attractor of its own: integration
    # from a perturbed state comes back to the orbit)
    worst = 0.0
    unvisited = []
    for p in br.points:
        key = round(p.value, 12)
        if not p.stable or key not in ptp_up:
            continue
        err = min(abs(p.peak_to_peak - ptp_up[key]), abs(p.peak_to_peak - ptp_down[key]))
        if err >= 1e-4 and returns_to_orbit(ks_system, p):
            unvisited.append(p.value)
            continue
        worst = max(worst, err)
    assert worst < 1e-4, worst
    assert all(0.8922 < w < 0.8942 for w in unvisited), unvisited
    # ... and every sweep point lies on a stable part of the branch (at a branch point of the
    # same parameter value, else between the two ends of a stable segment around it)
    for w, hi, lo, _ in up + down:
        ok = any(p.stable and abs(p.value - w) < 1e-12 and abs(p.peak_to_peak - (hi - lo)) < 1e-4
                 for p in br.points)
        for a, b in zip(br.points[:-1], br.points[1:]):
            if ok:
                break
            if a.stable and b.stable and min(a.value, b.value) <= w <= max(a.value, b.value) and a.value != b.value:
                lo_p, hi_p = sorted((a.peak_to_peak, b.peak_to_peak))
                ok = lo_p - 1e-4 <= hi - lo <= hi_p + 1e-4  # within the stable segment's range
        assert ok, (w, hi - lo)


def _linear_orbit_min(Om: float, b: float = 1.0) -> float:
    """min_t x(t) - b of the periodic solution of the drive-side contact equation (scipy)."""
    z, Fm, Fa, eps = KS["zeta"], KS["Fm"], KS["Fa"], KS["eps"]

    def f(t, y):
        x, v, *phi = y
        k = 1 + eps * math.cos(Om * t)
        dx = [v, -2 * z * v - k * (x - b) + Fm + Fa * Om ** 2 * math.cos(Om * t)]
        P = np.array(phi).reshape(2, 2)
        A = np.array([[0.0, 1.0], [-k, -2 * z]])
        return dx + list((A @ P).ravel())

    T = 2 * math.pi / Om
    s = solve_ivp(f, (0, T), [0.0, 0.0, 1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-12, atol=1e-14)
    Phi = s.y[2:, -1].reshape(2, 2)
    x0 = np.linalg.solve(np.eye(2) - Phi, s.y[:2, -1])
    s = solve_ivp(lambda t, y: f(t, list(y) + [1, 0, 0, 1])[:2], (0, T), x0, method="DOP853", rtol=1e-12,
                  atol=1e-14, dense_output=True)
    t = np.linspace(0, T, 4001)
    x = s.sol(t)[0]
    i = int(np.argmin(x))
    from scipy.optimize import minimize_scalar

    r = minimize_scalar(lambda tt: s.sol(tt)[0], bracket=(t[max(i - 1, 0)], t[i], t[min(i + 1, 4000)]),
                        tol=1e-12)
    return float(r.fun) - b


def test_grazing_points_against_linear_periodic_solution(ks_branch):
    ref = [brentq(_linear_orbit_min, 0.85, 0.9, xtol=1e-12), brentq(_linear_orbit_min, 1.15, 1.3, xtol=1e-12)]
    got = sorted(b.value for b in ks_branch.of_type("grazing"))
    assert got == pytest.approx(ref, abs=2e-6)
    for b in ks_branch.of_type("grazing"):
        assert b.info["surface"] == "mesh.drive" and b.info["side"] == "min"
        assert b.point.min == pytest.approx(1.0, abs=1e-6)


def test_unstable_count_changes_exactly_at_located_bifurcations(ks_branch):
    _check_unstable_count(ks_branch)
    for b in ks_branch.of_type("fold"):
        mu = b.point.multipliers
        assert np.min(np.abs(mu - 1.0)) < 1e-5  # a real multiplier at +1
        assert abs(b.info["n_unstable_before"] - b.info["n_unstable_after"]) == 1


def _check_unstable_count(br):
    """Between two consecutive located special points the number of unstable
    multipliers is constant; across each fold / period doubling / Neimark-Sacker
    point it changes."""
    regular = [i for i, p in enumerate(br.points) if p.bifurcation is None]
    special_idx = [b.index for b in br.bifurcations]
    for i, j in zip(regular[:-1], regular[1:]):
        if br.points[i].n_unstable != br.points[j].n_unstable:
            assert any(i < k < j for k in special_idx), (br.points[i].value, br.points[j].value)
    for b in br.bifurcations:
        if b.type in ("fold", "period_doubling", "neimark_sacker"):
            before = max(i for i in regular if i < b.index)
            after = min(i for i in regular if i > b.index)
            assert br.points[before].n_unstable != br.points[after].n_unstable, b


def test_json_object_and_plots(ks_branch, tmp_path):
    d = json.loads(json.dumps(ks_branch.to_dict()))
    assert d["param"] == "Omega"
    p = d["points"][0]
    for key in ("value", "stable", "max", "min", "rms", "rattle_state", "x0", "period", "multipliers"):
        assert key in p
    assert p["period"] == pytest.approx(2 * math.pi / 0.6)
    assert {b["type"] for b in d["bifurcations"]} == {"fold", "grazing"}
    # the rattle state changes at the grazings: no contact loss <-> contact loss
    rs = [q["rattle_state"] for q in d["points"]]
    assert rs[0] == 0 and rs[-1] == 0 and 1 in rs
    import matplotlib

    matplotlib.use("Agg")
    fig = ks_branch.plot_figure(tmp_path / "b.png", quantity=["max", "min"])
    assert (tmp_path / "b.png").stat().st_size > 10_000
    del fig


# ------------------------------------------------------------------ period doubling
def poincare_defect(system, Om, x, n=1500):
    """Brute force: |P_{k+1} - P_k| of the steady Poincare sequence (0 for period 1)."""
    p = {"Omega": Om, "Fa": 0.4}
    tr = system.simulate(periods=n, x0=x, params=p, rtol=1e-10, atol=1e-12, n_out=n + 1)
    P = tr.y[-40:, 0]
    return float(np.max(np.abs(np.diff(P)))), tr.x_final, P


def test_period_doubling_located_and_switched(ks_system):
    br = gearsym.continuation(ks_system, "Omega", 0.58, 0.64, params={"Fa": 0.4}, progress=False)
    pds = br.of_type("period_doubling")
    assert len(pds) == 1
    pd = pds[0]
    mu = pd.point.multipliers
    assert np.min(np.abs(mu + 1.0)) < 1e-5
    _check_unstable_count(br)
    # brute force: the Poincare sequence doubles between a and b
    x = ks_system.x0
    d, x, _ = poincare_defect(ks_system, pd.value - 0.004, x, 3000)
    assert d < 1e-6
    d, x, _ = poincare_defect(ks_system, pd.value + 0.004, x, 3000)
    assert d > 1e-3
    lo, hi = pd.value - 0.004, pd.value + 0.004
    x_lo = x
    for _ in range(3):  # bisection to 1e-3
        mid = 0.5 * (lo + hi)
        d, xm, _ = poincare_defect(ks_system, mid, x_lo, 3000)
        if d > 2e-4:
            hi = mid
        else:
            lo, x_lo = mid, xm
    assert lo - 2e-4 <= pd.value <= hi + 1e-3

    # switch onto the doubled orbit and continue it; compare with the brute-force attractor
    child = switch_period_doubling(br, pd, ds_max=0.05)
    assert child.periods == 2
    assert child in br.children
    Om = 0.625
    pts = [p for p in child.points if p.stable]
    assert pts, "the doubled branch must be stable past a supercritical period doubling"
    p_near = min(pts, key=lambda p: abs(p.value - Om))
    Om = p_near.value
    _, _, P = poincare_defect(ks_system, Om, p_near.x0 + 1e-3, 2000)
    brute = np.sort(np.unique(np.round(P, 7)))
    assert len(brute) == 2
    # the orbit's two Poincare points: x0 and x(T)
    xT = ks_system.simulate(periods=1, x0=p_near.x0, params={"Omega": Om, "Fa": 0.4}, rtol=1e-11,
                            atol=1e-13, n_out=2).x_final
    assert np.sort([p_near.x0[0], xT[0]]) == pytest.approx(brute, abs=1e-6)
    assert child.points[0].value == pytest.approx(pd.value, abs=2e-3)


# ------------------------------------------------------------------ Neimark-Sacker (2 DOF)
TWO_DOF = """
[model]
name = "spur_shaft_2dof"
description = "Spur pair with backlash on a flexible output shaft (2 DOF), parametric mesh stiffness"
time_unit = "1"

[coordinates.th1]
unit = "1"
velocity = "w1"
[coordinates.th2]
unit = "1"
velocity = "w2"

[parameters]
mu = { value = 1.0 }
ks = { value = 1.0 }
zeta = { value = 0.01 }
eps = { value = 0.3 }
b = { value = 1.0 }
Fm = { value = 0.5 }
Omega = { value = 2.0 }

[effects.backlash]
meaning = "dead zone"

[forcing]
period = "2*pi/Omega"

[elements.pinion]
type = "inertia"
coordinate = "th1"
value = "1"
[elements.gear]
type = "inertia"
coordinate = "th2"
value = "mu"
[elements.mesh]
type = "mesh"
deflection = "th1 - th2"
stiffness = "1 + eps*cos(Omega*t)"
damping = "2*zeta"
backlash = { expr = "b", effect = "backlash" }
drive_side = "positive"
[elements.shaft]
type = "spring"
deflection = "th2"
stiffness = "ks"
[elements.shaft_damper]
type = "damper"
deflection = "th2"
coefficient = "2*zeta*sqrt(ks*mu)"
[elements.load]
type = "force"
coordinate = "th1"
value = "Fm"

[initial]
th1 = 2.0
th2 = 0.5
"""


def _two_dof_max_complex(Om: float, zeta=0.01, eps=0.3, ks=1.0, mu=1.0) -> float:
    """max |mu| of the complex Floquet multipliers of the contact-mode linearisation (scipy)."""
    Minv = np.diag([1.0, 1.0 / mu])
    D = np.array([[1.0, -1.0], [-1.0, 1.0]])

    def f(t, y):
        k = 1 + eps * math.cos(Om * t)
        K = k * D + np.diag([0.0, ks])
        C = 2 * zeta * D + np.diag([0.0, 2 * zeta * math.sqrt(ks * mu)])
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
        return (A @ y.reshape(4, 4)).ravel()

    s = solve_ivp(f, (0, 2 * math.pi / Om), np.eye(4).ravel(), method="DOP853", rtol=1e-12, atol=1e-14)
    m = np.linalg.eigvals(s.y[:, -1].reshape(4, 4))
    c = m[np.abs(m.imag) > 1e-9]
    return float(np.max(np.abs(c))) - 1.0


def test_neimark_sacker_on_two_dof_model(tmp_path):
    (tmp_path / "two_dof.toml").write_text(TWO_DOF)
    (tmp_path / "scene.toml").write_text('[scene]\nname = "spur_shaft_2dof"\nmodel = "two_dof.toml"\n')
    system = gearsym.load_scene(tmp_path / "scene.toml").compile(generated_dir=tmp_path / "gen")
    br = gearsym.continuation(system, "Omega", 2.0, 2.45, progress=False)
    ns = br.of_type("neimark_sacker")
    assert len(ns) == 2
    ref = [brentq(_two_dof_max_complex, 2.05, 2.2, xtol=1e-12), brentq(_two_dof_max_complex, 2.25, 2.4, xtol=1e-12)]
    assert sorted(b.value for b in ns) == pytest.approx(ref, abs=1e-6)
    for b in ns:
        mu = b.point.multipliers
        pair = mu[np.abs(mu.imag) > 1e-6]
        assert np.min(np.abs(np.abs(pair) - 1.0)) < 1e-6
        assert abs(b.info["n_unstable_before"] - b.info["n_unstable_after"]) == 2
    _check_unstable_count(br)
    assert not br.of_type("grazing")  # the orbit stays in drive-side contact


# ------------------------------------------------------------------ harmonic balance, CLI
def test_hbm_branch_agrees_with_shooting(ks_system):
    from gearsym.analysis.periodic import shoot

    hb = gearsym.continuation(ks_system, "Omega", 0.6, 0.8, progress=False, ds_max=0.05, method="hbm",
                              harmonics=12)
    assert hb.method == "hbm" and hb.stop_reason.startswith("reached")
    assert hb.values[-1] == pytest.approx(0.8)
    for p in hb.points[:: max(1, len(hb.points) // 6)] + [hb.points[-1]]:
        o = shoot(ks_system, params={"Omega": p.value}, x0=p.x0, rtol=1e-12, atol=1e-14)
        lo, hi = o.extrema(0)
        assert p.max == pytest.approx(hi, abs=1e-6) and p.min == pytest.approx(lo, abs=1e-6)
        assert p.x0 == pytest.approx(o.x0, abs=1e-6)
        assert np.sort(np.abs(p.multipliers)) == pytest.approx(np.sort(np.abs(o.multipliers)), rel=1e-6)


def test_cli_continue_json(tmp_path):
    cmd = [sys.executable, "-m", "gearsym.cli", "continue", str(SCENE), "--param", "Omega", "--from", "0.6",
           "--to", "0.7", "--json", "--no-progress", "--out", str(tmp_path)]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["param"] == "Omega" and d["points"][0]["value"] == pytest.approx(0.6)
    assert d["points"][-1]["value"] == pytest.approx(0.7)
    assert all(p["stable"] and p["rattle_state"] == 0 for p in d["points"])
    assert isinstance(d["points"][0]["multipliers"][0], list) and len(d["points"][0]["x0"]) == 2
    assert (tmp_path / "response.png").exists() and (tmp_path / "branch.json").exists()
    r = subprocess.run(cmd[:5] + ["--param", "nope", "--from", "0.6", "--to", "0.7"], capture_output=True,
                       text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 2 and "nope" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("kind", ["exact", "fd"])
@pytest.mark.parametrize("rtol", [1e-5, 1e-7, 1e-10])
def test_parameter_derivative_of_the_residual_at_loose_tolerances(ks_system, rtol, kind):
    """F_lambda (exact from the parameter sensitivities, or the forward-difference fallback)
    at a loose integrator tolerance agrees with a central difference of the residual at rtol
    1e-13 to 2 % (with the old fixed 1e-6 step the difference was off by 34x at rtol 1e-5:
    the integration noise (~ rtol) over the step, and the corrector rejected step after
    step); the exact one to 1e-4."""
    from gearsym.analysis.continuation._api import ShootingResidual, _fd_step

    orb = ks_system.periodic_orbit(params={"Omega": 1.2}, rtol=1e-12, atol=1e-14, tol=1e-11)
    x = orb.x0
    tight = ShootingResidual(ks_system, "Omega", rtol=1e-13, atol=1e-15)
    h = 1e-4
    ref = (tight.evaluate(x, 1.2 + h, jac=False).R - tight.evaluate(x, 1.2 - h, jac=False).R) / (2 * h)
    loose = ShootingResidual(ks_system, "Omega", rtol=rtol, atol=rtol * 1e-2, fd_step=_fd_step(0.6, 1.4, rtol),
                             f_lambda="finite_difference" if kind == "fd" else "exact")
    got = loose.evaluate(x, 1.2, jac=True, dlam=True).Flam
    assert np.max(np.abs(got - ref)) < (2e-2 if kind == "fd" else 1e-4) * np.max(np.abs(ref))
