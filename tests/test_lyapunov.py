"""Lyapunov exponents of the hybrid system (gearsym.analysis.sweeps.lyapunov_exponents, ``gearsym lyapunov``).

Independent references, none of them gearsym code:

* the trace of the benchmark oscillator's Jacobian, ``-2 zeta`` (the exponents' sum);
* the Floquet multipliers of a stable periodic orbit, ``log |mu| / T`` (found by shooting: a
  different algorithm on the same engine);
* a hand-written Benettin algorithm on the benchmark oscillator in scipy (:func:`scipy_stretches`):
  ``solve_ivp`` on the state and a 2 x 2 tangent block, terminal events at the contact
  surfaces ``x = +-b``, the saltation matrix applied to the tangent block at each event, QR at the
  end of each period;
* for an autonomous model (van der Pol), the limit cycle's exponents ``0`` and
  ``(1/T) int_0^T div f dt``, integrated by scipy.
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

import gearsym
from gearsym.analysis.sweeps import (
    LyapunovOptions,
    batch_errors,
    format_estimate,
    kaplan_yorke,
    lyapunov_exponents,
    weighted_average,
    window,
)
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"
CHAOS = {"Omega": 0.8, "Fa": 0.6}
ZETA = 0.05


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def ks_contact_damping():
    """Damping only in contact: the vector field jumps at x = +-b, the saltation matrix is not I."""
    return gearsym.load_scene(KS, effects={"contact_damping": True}).compile()


# ------------------------------------------------------------------ the scipy reference
def _ks_params(p: dict) -> dict:
    base = {"zeta": ZETA, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}
    base.update(p)
    return base


def _mode(x: float, v: float, b: float) -> int:
    if x > b or (x == b and v > 0):
        return 1
    if x < -b or (x == -b and v < 0):
        return -1
    return 0


def _accel(t: float, x: float, v: float, m: int, p: dict, contact_damping: bool) -> float:
    """x'' of the benchmark oscillator in contact mode m (+1 drive side, 0 gap, -1 back side)."""
    W = p["Omega"]
    k = 1.0 + p["eps"] * math.cos(W * t)
    f = x - p["b"] if m == 1 else (x + p["b"] if m == -1 else 0.0)
    c = 0.0 if (contact_damping and m == 0) else 2 * p["zeta"]
    return p["Fm"] + p["Fa"] * W * W * math.cos(W * t) - c * v - k * f


def scipy_stretches(p: dict, x0, scales, periods: int, contact_damping: bool = False,
                    saltation: bool = True) -> np.ndarray:
    """``log |R_ii|`` per forcing period, by a hand-written Benettin algorithm (scipy DOP853).

    The tangent block ``Y = diag(scales) Q`` (``Q`` orthonormal in states divided by ``scales``,
    the metric gearsym reports in ``info["tangent_scales"]``) is integrated with the state,
    ``Y' = A_m(t) Y``; at a crossing of ``x = +-b`` (a terminal event) the saltation matrix
    ``S = I + (f_new - f_old) n^T / (n^T f_old)``, ``n = (1, 0)``, multiplies ``Y`` and the mode
    changes; at the end of each period ``diag(1/scales) Y = Q R`` and ``Y <- diag(scales) Q``.
    """
    p = _ks_params(p)
    T = 2 * math.pi / p["Omega"]
    D = np.asarray(scales, float)
    b = p["b"]
    y = np.concatenate([np.asarray(x0, float), np.diag(D).ravel()])
    m = _mode(y[0], y[1], b)
    out = []

    def rhs(t, s, m):
        x, v = s[0], s[1]
        k = (1.0 + p["eps"] * math.cos(p["Omega"] * t)) if m != 0 else 0.0
        c = 0.0 if (contact_damping and m == 0) else 2 * p["zeta"]
        A = np.array([[0.0, 1.0], [-k, -c]])
        Y = s[2:].reshape(2, 2)
        return np.concatenate([[v, _accel(t, x, v, m, p, contact_damping)], (A @ Y).ravel()])

    def surface(sign, level):
        def g(t, s, m):
            return s[0] - level
        g.terminal = True
        g.direction = sign
        return g

    t = 0.0
    for n in range(periods):
        t_end = (n + 1) * T
        while True:
            events = {1: [surface(-1, b)], 0: [surface(1, b), surface(-1, -b)], -1: [surface(1, -b)]}[m]
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-14, events=events, args=(m,),
                            max_step=T / 16)
            hit = next((i for i, te in enumerate(sol.t_events) if len(te)), None)
            if hit is None:
                t, y = t_end, sol.y[:, -1]
                break
            t, y = float(sol.t_events[hit][0]), sol.y_events[hit][0].copy()
            x, v = y[0], y[1]
            new = 0 if m != 0 else (1 if x > 0 else -1)
            if saltation:
                a_old, a_new = _accel(t, x, v, m, p, contact_damping), _accel(t, x, v, new, p, contact_damping)
                S = np.array([[1.0, 0.0], [(a_new - a_old) / v, 1.0]])  # f_new - f_old = (0, a_new - a_old)
                y[2:] = (S @ y[2:].reshape(2, 2)).ravel()
            m = new
        Q, R = np.linalg.qr(y[2:].reshape(2, 2) / D[:, None])
        out.append(np.log(np.abs(np.diag(R))))
        y = np.concatenate([y[:2], (D[:, None] * Q).ravel()])
    return np.array(out)


# ------------------------------------------------------------------ the benchmark oscillator
def test_sum_of_exponents_is_the_trace_in_the_chaotic_regime(ks):
    """Omega 0.8, Fa 0.6 (chaotic: lambda_1 > 0 beyond its error): lambda_1 + lambda_2 = -2 zeta, the
    trace of the Jacobian (the backlash force is continuous: the saltation matrices have det 1).
    The sum is exact in every block up to the integration error, so 400 periods are plenty."""
    r = lyapunov_exponents(ks, CHAOS, periods=400, transient=100)
    assert r.exponents.shape == (2,)
    assert abs(r.exponent_sum + 2 * ZETA) < 1e-4
    assert abs(r.exponent_sum + 2 * ZETA) < 1e-7  # (measured: 5e-10)
    assert r.exponents[0] - r.errors[0] > 0.02  # chaotic
    # Kaplan-Yorke: 1 + lambda_1 / |lambda_2|
    assert r.kaplan_yorke == pytest.approx(1 + r.exponents[0] / abs(r.exponents[1]), rel=1e-12)
    assert 1 < r.kaplan_yorke < 2
    assert r.info["forced"] and r.trivial.shape == (0,)


@pytest.mark.parametrize("omega", [0.6, 0.9])
def test_periodic_orbit_exponents_equal_floquet(ks, omega):
    """A stable periodic orbit (Omega 0.6: no impact; 0.9: single-sided impacts): the exponents
    are log|mu_i| / T of its Floquet multipliers, to 1e-6 (measured: 2e-10 over 500 periods)."""
    prm = {"Omega": omega}
    orbit = ks.periodic_orbit(params=prm)
    assert orbit.stable
    ref = np.sort(np.log(np.abs(orbit.multipliers)) / orbit.period)[::-1]
    r = lyapunov_exponents(ks, prm, periods=500, transient=200)
    assert r.converged, r.reason
    assert np.abs(r.exponents - ref).max() < 1e-6
    assert np.all(r.errors < 1e-4)
    assert r.kaplan_yorke == 0.0


def test_periodic_orbit_with_real_multipliers_equals_floquet(ks):
    """Omega 0.9, Fa 0.2: a stable single-sided impact orbit with real multipliers (-0.995 and
    -0.500): two distinct exponents, each log|mu_i| / T, to 1e-6.  Started on the orbit (its
    slowest transient would decay like 0.995^n)."""
    prm = {"Omega": 0.9, "Fa": 0.2}
    orbit = ks.periodic_orbit(params=prm)
    assert orbit.stable and np.all(np.abs(orbit.multipliers.imag) == 0)
    ref = np.sort(np.log(np.abs(orbit.multipliers)) / orbit.period)[::-1]
    r = lyapunov_exponents(ks, prm, x0=orbit.x0, periods=500, transient=0)
    assert r.stats["n_events"] >= 500
    assert np.abs(r.exponents - ref).max() < 1e-6
    assert r.exponents[0] - r.exponents[1] > 0.05


def test_periodic_orbit_with_contact_damping_equals_floquet(ks_contact_damping):
    """Damping only in contact: the vector field jumps at the contact surfaces (saltation matrices
    that are not I) and the sum is no longer -2 zeta; the exponents are log|mu_i| / T."""
    sysc = ks_contact_damping
    prm = {"Omega": 0.9}
    orbit = sysc.periodic_orbit(params=prm)
    assert orbit.stable
    ref = np.sort(np.log(np.abs(orbit.multipliers)) / orbit.period)[::-1]
    r = lyapunov_exponents(sysc, prm, periods=500, transient=200)
    assert r.stats["n_events"] > 0
    assert np.abs(r.exponents - ref).max() < 1e-6
    assert r.exponent_sum > -2 * ZETA + 1e-3


@pytest.mark.parametrize("contact_damping", [False, True])
def test_finite_time_exponents_equal_a_hand_written_scipy_benettin(ks, ks_contact_damping, contact_damping):
    """In the chaotic regime (Omega 0.8, Fa 0.6; with contact damping, where that is periodic,
    Omega 0.9, Fa 0.6), from one state on the attractor and in the same tangent metric, the
    stretches of 10 periods (finite-time exponents) equal those of the scipy reference (event
    location, saltation at each event, QR per period) to 1e-6, far inside the two digits asked.
    (Longer is not comparable: the two integrations' 1e-12 differences grow about fivefold per
    period on the chaotic orbit: 6e-4 after 24 periods.)  With contact damping, the same reference
    without the saltation differs by 1e-2 and more: the comparison sees the saltation."""
    system = ks_contact_damping if contact_damping else ks
    prm = {"Omega": 0.9, "Fa": 0.6} if contact_damping else CHAOS
    start = system.simulate(periods=100, params=prm, n_out=2).x_final
    r = lyapunov_exponents(system, prm, x0=start, periods=10, transient=0, align=0, batches=2, rtol=1e-12)
    assert r.stretches.shape == (10, 2) and r.stats["n_events"] >= 10
    ref = scipy_stretches(prm, start, r.info["tangent_scales"], 10, contact_damping=contact_damping)
    T = 2 * math.pi / prm["Omega"]
    ftle, ftle_ref = r.stretches.sum(axis=0) / (10 * T), ref.sum(axis=0) / (10 * T)
    assert ftle[0] == pytest.approx(ftle_ref[0], rel=1e-6)
    assert np.abs(r.stretches - ref).max() < 1e-6
    if contact_damping:
        wrong = scipy_stretches(prm, start, r.info["tangent_scales"], 10, contact_damping=True, saltation=False)
        assert np.abs(wrong - ref).max() > 1e-2


def test_largest_exponent_only(ks):
    """exponents=1: one column, the same largest exponent's stretches as the full spectrum's
    (the first column of a QR does not depend on the others)."""
    full = lyapunov_exponents(ks, CHAOS, periods=40, transient=50, batches=2, align=4)
    one = lyapunov_exponents(ks, CHAOS, periods=40, transient=50, batches=2, align=4, exponents=1)
    assert one.exponents.shape == (1,)
    assert np.abs(one.stretches[:, 0] - full.stretches[:, 0]).max() < 1e-9
    assert math.isnan(one.kaplan_yorke)  # lambda_1 > 0 alone: more exponents are needed


def test_progress_bar_on_stderr(ks, capsys):
    pytest.importorskip("tqdm")
    lyapunov_exponents(ks, periods=32, transient=0, align=0, progress=True)
    assert "Lyapunov blocks" in capsys.readouterr().err


def test_not_converged_is_reported_not_hidden(ks):
    """A short chaotic run: converged False, a reason naming the exponents and their errors."""
    r = lyapunov_exponents(ks, CHAOS, periods=40, transient=50, batches=2, rel_tol=1e-3)
    assert not r.converged
    assert "not converged after 40 periods" in r.reason and "lambda_1" in r.reason
    d = r.as_dict()
    assert d["converged"] is False and d["reason"] == r.reason
    json.dumps(d, allow_nan=False)


# ------------------------------------------------------------------ free gear train, autonomous model
def test_rigid_body_directions_are_reported_apart():
    """two_stage_train keeps one rigid-body mode: two zero exponents reported apart; the six others
    are those of the orbit's non-trivial multipliers, log|mu|/T: their sum (exact in every block) to
    1e-8, the two real ones to 1e-7, the complex pairs within their reported errors (a pair rotating
    2.4 rad per period makes the stretches oscillate: 64 periods leave 2e-3 of it)."""
    s = gearsym.load_scene("two_stage_train").compile()
    orbit = s.periodic_orbit()
    ref = np.sort(np.log(np.abs(orbit.multipliers)) / orbit.period)[::-1]
    r = lyapunov_exponents(s, x0=orbit.x0, periods=64, transient=0)
    assert r.trivial.tolist() == [0.0, 0.0]
    assert r.info["dimension"] == 6 and "split off 2 rigid-body directions" in r.info["rigid_split"]
    assert r.exponent_sum == pytest.approx(float(ref.sum()), rel=1e-8)
    assert r.exponents[2:4] == pytest.approx(ref[2:4], rel=1e-7)
    assert np.all(np.abs(r.exponents - ref) <= r.errors)
    with pytest.raises(ParameterError, match="6 directions besides its 2 rigid-body ones"):
        lyapunov_exponents(s, periods=64, exponents=7)


VDP = """
[model]
name = "van_der_pol"
description = "van der Pol oscillator x'' - mu (1 - x^2) x' + x = 0 (autonomous)"
reference = "issue 28"
time_unit = "1"

[coordinates.x]
unit = "1"
meaning = "displacement"
velocity = "v"

[parameters]
mu = { value = 1.0, meaning = "nonlinear damping" }

[elements.mass]
type = "inertia"
coordinate = "x"
value = "1"

[equations.x]
force = "mu*(1 - x**2)*v - x"

[initial]
x = 2.0
v = 0.0
"""


def test_autonomous_limit_cycle_has_a_zero_exponent(tmp_path):
    """van der Pol (no forcing period): block_time is required; the flow direction gives the
    exponent 0 and the other is (1/T) int div f dt = (1/T) int mu (1 - x^2) dt over the cycle."""
    (tmp_path / "vdp.toml").write_text(VDP)
    (tmp_path / "scene.toml").write_text('[scene]\nname = "vdp"\nmodel = "vdp.toml"\n')
    s = gearsym.load_scene(tmp_path / "scene.toml").compile()
    with pytest.raises(ParameterError, match="no forcing period: give block_time"):
        lyapunov_exponents(s, periods=64)
    # reference: the cycle by scipy (period from successive upward zero crossings of x)
    def f(t, y):
        return [y[1], (1 - y[0] ** 2) * y[1] - y[0], 1 - y[0] ** 2]
    up = lambda t, y: y[0]  # noqa: E731
    up.direction = 1
    sol = solve_ivp(f, (0, 200), [2.0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12, events=up,
                    dense_output=True)
    t1, t2 = sol.t_events[0][-2], sol.t_events[0][-1]
    div = (sol.sol(t2)[2] - sol.sol(t1)[2]) / (t2 - t1)
    r = lyapunov_exponents(s, periods=2000, transient=40, block_time=1.0)
    assert not r.info["forced"] and r.periods == 2000 and r.time == 2000.0
    assert abs(r.exponents[0]) < 5e-6 and abs(r.exponents[0]) <= r.errors[0]  # (measured: 6e-7 +- 1.2e-5)
    assert r.exponents[1] == pytest.approx(div, abs=5e-6)
    assert r.converged, r.reason
    assert r.kaplan_yorke == pytest.approx(1.0, abs=1e-5)
    # blocks of 17 time units: the directions separate by exp(1.06 * 17) > 1e6 in one, so the
    # automatic block length halves it to 8.5 (exp(9)).  (Not 20: halved to 10 = 1.5008 cycles, the
    # block stretches nearly repeat every two blocks and the windowed average is 6e-4 off after
    # 200 blocks, more than the batches' spread shows.)
    r2 = lyapunov_exponents(s, periods=100, transient=4, block_time=17.0)
    assert r2.block == 0.5 and r2.block_time == 8.5 and r2.periods == 100
    assert 8 < r2.stats["max_growth"] < math.log(1e6)
    assert r2.exponents[1] == pytest.approx(div, abs=1e-5)


# ------------------------------------------------------------------ statistics, options
def test_kaplan_yorke_dimension():
    assert kaplan_yorke([-0.1, -0.2]) == 0.0
    assert kaplan_yorke([0.5, 0.0, -1.0]) == pytest.approx(2.5)
    assert kaplan_yorke([0.1, -0.3]) == pytest.approx(1 + 1 / 3)
    assert kaplan_yorke([0.1, 0.05]) == 2.0
    assert math.isnan(kaplan_yorke([0.1, 0.05], complete=False))


def test_window_and_averages():
    w = window(1000)
    assert w.min() > 0 and w.max() == pytest.approx(1.0) and np.all(w[300:700] == 1.0)
    assert np.allclose(w, w[::-1])
    L = np.tile([[0.3, -0.7]], (64, 1))
    assert weighted_average(L, 2.0) == pytest.approx([0.15, -0.35])
    # a constant plus an oscillation of the block index: the window removes the oscillation to
    # far below the plain average's 1/N
    n = np.arange(400)
    osc = np.column_stack([0.5 + np.cos(0.7 * n), -0.5 - np.cos(0.7 * n)])
    assert np.abs(weighted_average(osc, 1.0) - [0.5, -0.5]).max() < 1e-6  # (5e-8)
    assert np.abs(osc.mean(axis=0) - [0.5, -0.5]).max() > 1e-4
    # independent noise: the 95 % half-width is about 1.96 sqrt(1.25) sigma / sqrt(N)
    rng = np.random.default_rng(3)
    e = batch_errors(rng.standard_normal((8000, 1)), 1.0, 8)
    assert 0.5 * 1.96 * math.sqrt(1.25 / 8000) < e[0] < 2.5 * 1.96 * math.sqrt(1.25 / 8000)


def test_format_estimate_shows_the_digits_the_error_allows():
    assert format_estimate(0.082115, 0.0048) == "0.0821 +- 0.0048"
    assert format_estimate(-0.05000000013, 1.4e-7) == "-0.05000000 +- 1.4e-07"


@pytest.mark.parametrize("kw, match", [
    ({"periods": 10}, "periods=10: the convergence estimate needs at least 32 blocks"),
    ({"periods": -1}, "periods must be finite"),
    ({"rtol": 2.0}, "rtol must be finite"),
    ({"exponents": 0}, "exponents must be an integer >= 1"),
    ({"batches": 1}, "batches must be an integer"),
    ({"block": 0.0}, "block must be finite"),
    ({"method": "rk4"}, "method must be"),
])
def test_bad_options(kw, match):
    with pytest.raises(ParameterError, match=match):
        LyapunovOptions(**kw)


def test_unknown_option_is_named(ks):
    with pytest.raises(ParameterError, match="unknown option"):
        lyapunov_exponents(ks, periods=64, period=3)


def test_block_time_refused_for_a_forced_model(ks):
    with pytest.raises(ParameterError, match="block_time=2: this model has a forcing period"):
        lyapunov_exponents(ks, periods=64, block_time=2.0)


# ------------------------------------------------------------------ command line
def _cli(capsys, *args: str) -> tuple[int, str, str]:
    """``gearsym lyapunov ARGS`` in this process (the console script's entry point)."""
    from gearsym.cli import main

    rc = main(["lyapunov", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli_converged_json_and_files(tmp_path, capsys):
    out = tmp_path / "ly"
    rc, stdout, stderr = _cli(capsys, str(KS), "--set", "Omega=0.6", "--periods", "200", "--transient", "200",
                              "--json", "--out", str(out))
    assert rc == 0, stderr
    d = json.loads(stdout)
    assert d["converged"] is True and d["exponents"] == pytest.approx([-0.05, -0.05], abs=1e-6)
    assert d["scene"] == "kahraman_singh" and d["periods"] == 200
    assert json.loads((out / "lyapunov.json").read_text())["exponents"] == d["exponents"]
    assert (out / "lyapunov.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_not_converged_exits_1_with_the_reason(capsys):
    rc, stdout, stderr = _cli(capsys, str(KS), "--set", "Omega=0.8", "--set", "Fa=0.6", "--periods", "64",
                              "--transient", "50", "--rel-tol", "0.001")
    assert rc == 1
    assert "NOT CONVERGED" in stdout and "lambda_1 = " in stdout
    assert "gearsym: error: not converged after 64 periods" in stderr


@pytest.mark.parametrize("args, match", [
    (["--periods", "10"], "--periods: periods=10"),
    (["--rtol", "2"], "--rtol: rtol must be"),
    (["--exponents", "3", "--periods", "64", "--transient", "0"], "--exponents: exponents=3: the system has 2"),
    (["--block-time", "2", "--periods", "64"], "--block-time: block_time=2"),
    (["--set", "nope=1"], "unknown parameter 'nope'"),
    (["--out", str(KS)], "--out: "),
    (["--periods", "1e8"], "--periods: periods=1e+08 with 2 exponents keeps more than"),
    (["--set", "Omega=0"], "the forcing period is not finite and positive at Omega = 0"),
])
def test_cli_bad_input_exits_2(capsys, args, match):
    rc, _, stderr = _cli(capsys, str(KS), *args)
    assert rc == 2, stderr
    assert match in stderr


def test_cli_runs_as_a_console_command():
    """The subcommand is registered in the installed entry point (a fresh process)."""
    p = subprocess.run([sys.executable, "-m", "gearsym", "lyapunov", "--help"], capture_output=True, text=True)
    assert p.returncode == 0 and "--exponents" in p.stdout and "--block-time" in p.stdout
