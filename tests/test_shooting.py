"""Shooting on the benchmark backlash oscillator (models/kahraman_singh.toml).

Independent reference: a hand-written scipy DOP853 integrator of

    x'' + c(x)*x' + (1 + eps*cos(Omega*t))*f(x) = Fm + Fa*Omega^2*cos(Omega*t)
    f(x) = x - b (x > b), 0 (|x| <= b), x + b (x < -b)
    c(x) = 2*zeta always, or only in contact (|x| > b) with contact_damping

restarted in the new contact mode at every located crossing of x = +-b, with
optionally the variational equations and the saltation matrices
S = I + (f+ - f-) n^T / (n . f-) at the crossings.  Central finite differences of
this flow map are the reference for the monodromy.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gearsym
from gearsym.errors import ConvergenceError

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "kahraman_singh.toml"
P0 = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}


# ------------------------------------------------------------------ reference
def _accel(p, t, x, v, mode, cd):
    f = x - p["b"] if mode == 1 else (x + p["b"] if mode == -1 else 0.0)
    c = 0.0 if (cd and mode == 0) else 2 * p["zeta"]
    W = p["Omega"]
    return -c * v - (1 + p["eps"] * np.cos(W * t)) * f + p["Fm"] + p["Fa"] * W**2 * np.cos(W * t)


def _jac(p, t, mode, cd):
    k = (1 + p["eps"] * np.cos(p["Omega"] * t)) if mode != 0 else 0.0
    c = 0.0 if (cd and mode == 0) else 2 * p["zeta"]
    return np.array([[0.0, 1.0], [-k, -c]])


def ref_flow(p, x0, t0, t1, cd=False, variational=False, saltation=True):
    """Flow map (and monodromy) of the hand-written hybrid system."""
    b = p["b"]
    y = np.concatenate([np.asarray(x0, float), np.eye(2).ravel()]) if variational else np.asarray(x0, float)
    x = y[0]
    mode = 1 if x > b else (-1 if x < -b else 0)
    t = t0
    n_ev = 0
    while t < t1:
        def rhs(tt, yy, mode=mode):
            a = _accel(p, tt, yy[0], yy[1], mode, cd)
            if not variational:
                return [yy[1], a]
            Phi = yy[2:].reshape(2, 2)
            return np.concatenate([[yy[1], a], (_jac(p, tt, mode, cd) @ Phi).ravel()])

        events = []
        if mode == 0:
            e1 = lambda tt, yy: yy[0] - b  # noqa: E731
            e1.terminal, e1.direction = True, 1
            e2 = lambda tt, yy: yy[0] + b  # noqa: E731
            e2.terminal, e2.direction = True, -1
            events = [e1, e2]
        else:
            e = (lambda tt, yy: yy[0] - b) if mode == 1 else (lambda tt, yy: yy[0] + b)
            e.terminal, e.direction = True, -mode
            events = [e]
        s = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=1e-13, atol=1e-15, events=events)
        y = s.y[:, -1].copy()
        t = s.t[-1]
        if s.status == 1:  # crossing: new mode
            n_ev += 1
            new = (1 if y[0] > 0 else -1) if mode == 0 else 0
            y[0] = b if y[0] > 0 else -b  # on the surface exactly
            if variational and saltation:
                fm = np.array([y[1], _accel(p, t, y[0], y[1], mode, cd)])
                fp = np.array([y[1], _accel(p, t, y[0], y[1], new, cd)])
                n = np.array([1.0, 0.0])
                S = np.eye(2) + np.outer(fp - fm, n) / (n @ fm)
                y[2:] = (S @ y[2:].reshape(2, 2)).ravel()
            mode = new
    if variational:
        return y[:2], y[2:].reshape(2, 2), n_ev
    return y, n_ev


def fd_monodromy(p, x0, T, cd, h=1e-5):
    cols = []
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        xp, np_ = ref_flow(p, x0 + e, 0.0, T, cd)
        xm, nm = ref_flow(p, x0 - e, 0.0, T, cd)
        assert np_ == nm  # no crossing appears or disappears
        cols.append((xp - xm) / (2 * h))
    return np.array(cols).T


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(SCENE).compile()


@pytest.fixture(scope="module")
def ks_cd():
    return gearsym.load_scene(SCENE, effects={"contact_damping": True}).compile()


# ---------------------------------------------------------------------- tests
@pytest.mark.parametrize("cd", [False, True], ids=["always_on_damping", "contact_damping"])
def test_impacting_orbit_monodromy_vs_fd_and_long_simulation(ks, ks_cd, cd):
    """Omega = 0.9 (impacting orbit): the shooting monodromy agrees with central
    finite differences of the reference flow map to 1e-6, the orbit closes under
    the reference flow and matches a long simulation's steady state to 1e-8."""
    system = ks_cd if cd else ks
    orbit = system.periodic_orbit()
    assert orbit.converged and orbit.residual < 1e-10
    assert orbit.rattle_state == 1 and len(orbit.events) == 2  # contact loss, single-sided
    T = 2 * np.pi / P0["Omega"]
    # the orbit closes under the independent flow
    xT, n_ev = ref_flow(P0, orbit.x0, 0.0, T, cd)
    assert n_ev == 2
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9
    # monodromy vs FD of the reference flow
    M_fd = fd_monodromy(P0, orbit.x0, T, cd)
    err = np.max(np.abs(orbit.monodromy - M_fd)) / np.max(np.abs(M_fd))
    assert err < 1e-6, err
    # the reference variational equations with saltation agree tightly; without
    # saltation they are wrong exactly when the vector field jumps (contact damping)
    _, M_salt, _ = ref_flow(P0, orbit.x0, 0.0, T, cd, variational=True)
    _, M_nosalt, _ = ref_flow(P0, orbit.x0, 0.0, T, cd, variational=True, saltation=False)
    assert np.max(np.abs(orbit.monodromy - M_salt)) / np.max(np.abs(M_salt)) < 1e-8
    miss = np.max(np.abs(M_nosalt - M_fd)) / np.max(np.abs(M_fd))
    if cd:
        assert miss > 1e-2
    else:
        assert miss < 1e-6  # continuous field: saltation = identity
    # a long simulation (2000 periods from the scene's initial state) settles on it
    tr = system.simulate(periods=2000, rtol=1e-12, atol=1e-14, n_out=2)
    assert np.max(np.abs(tr.x_final - orbit.x0)) < 1e-8
    # stable: |mu|^2 = det M = exp(-2*zeta*T) for the complex pair
    assert orbit.stable and orbit.max_multiplier < 1
    assert abs(np.prod(orbit.multipliers).real - np.linalg.det(M_fd)) < 1e-6


def test_multiple_shooting_same_orbit_and_multipliers(ks_cd):
    single = ks_cd.periodic_orbit()
    multi = ks_cd.periodic_orbit(segments=5)
    assert multi.segments == 5 and len(multi.segment_monodromies) == 5
    assert np.max(np.abs(multi.x0 - single.x0)) < 1e-8
    assert np.max(np.abs(multi.monodromy - single.monodromy)) < 1e-7
    assert np.max(np.abs(np.sort_complex(multi.multipliers) - np.sort_complex(single.multipliers))) < 1e-7
    # every segment start lies on the orbit
    tr = ks_cd.simulate(t_end=single.period, x0=single.x0, t_out=np.linspace(0, single.period, 6),
                        rtol=1e-12, atol=1e-14)
    assert np.max(np.abs(multi.segment_states - tr.y[:-1])) < 1e-8


@pytest.mark.parametrize("x0", [[10.0, 0.0], [0.0, 0.0], [-3.0, 2.0]])
def test_convergence_from_poor_initial_guess(ks, x0):
    ref = ks.periodic_orbit()
    orbit = ks.periodic_orbit(x0=x0, transient=0)
    assert orbit.converged
    assert np.max(np.abs(orbit.x0 - ref.x0)) < 1e-8
    assert orbit.history[0]["residual"] > 1e-2  # it really started far away
    assert orbit.iterations > 3


def test_unstable_orbit_found_and_reported_unstable(ks):
    """Omega = 0.85: a stable non-impacting orbit, a stable impacting one and,
    between them, a saddle (real multiplier > 1), found by Newton from a nearby
    guess without relaxation and checked with the reference flow."""
    p = {"Omega": 0.85}
    orbit = ks.periodic_orbit(x0=[1.075, 0.13], transient=0, relax_periods=0, params=p)
    assert orbit.converged and not orbit.stable
    mu = orbit.multipliers
    assert abs(mu[0].imag) < 1e-12 and mu[0].real > 1.2  # a real multiplier outside the circle
    assert abs(mu[1]) < 1
    P = dict(P0, Omega=0.85)
    T = 2 * np.pi / 0.85
    xT, _ = ref_flow(P, orbit.x0, 0.0, T)
    assert np.max(np.abs(xT - orbit.x0)) < 1e-9
    M_fd = fd_monodromy(P, orbit.x0, T, cd=False)
    mu_fd = np.sort(np.linalg.eigvals(M_fd).real)[::-1]
    assert np.max(np.abs(np.sort(mu.real)[::-1] - mu_fd)) < 1e-6
    # the stable orbits coexisting with it are different orbits
    lo = ks.periodic_orbit(x0=[1.15, 0.015], transient=0, params=p)
    hi = ks.periodic_orbit(x0=[1.02, 0.19], transient=0, params=p)
    assert lo.stable and hi.stable
    assert lo.rattle_state == 0 and hi.rattle_state == 1
    assert min(np.max(np.abs(orbit.x0 - lo.x0)), np.max(np.abs(orbit.x0 - hi.x0))) > 1e-2


def test_no_convergence_gives_a_clear_report(ks):
    with pytest.raises(ConvergenceError) as exc:
        ks.periodic_orbit(x0=[10.0, 0.0], transient=0, relax_periods=0, max_iter=3)
    msg = str(exc.value)
    assert "did not converge" in msg and "Residual history" in msg and "last x0" in msg
    orbit = ks.periodic_orbit(x0=[10.0, 0.0], transient=0, relax_periods=0, max_iter=3,
                              raise_on_failure=False)
    assert not orbit.converged and orbit.info["failure"]


def test_period_two_orbit_and_rattle_states(ks):
    """A period-2 orbit request on a period-1 attractor returns the same orbit
    (its monodromy is the square); back-side contact gives rattle state 2."""
    one = ks.periodic_orbit()
    two = ks.periodic_orbit(periods=2, x0=one.x0)
    assert two.period == pytest.approx(2 * one.period)
    assert np.max(np.abs(two.x0 - one.x0)) < 1e-9
    assert np.max(np.abs(two.monodromy - one.monodromy @ one.monodromy)) < 1e-7
    # light load, large transmission error: impacts on both flanks
    both = ks.periodic_orbit(params={"Fm": 0.1, "Fa": 1.5, "Omega": 1.2}, transient=300)
    assert both.stable and both.rattle_state == 2
    lo, hi = both.extrema()
    assert lo < -1 < 1 < hi  # beyond both flanks (b = 1)
    # the orbit's classification (initial sides + events of one period) agrees with the
    # trajectory classifier of gearsym.analysis.periodic._rattle on the integrated period
    from gearsym.analysis.periodic import _rattle as rattle

    for o in (one, both):
        assert rattle.rattle_state(o.trajectory(), system=ks, t_start=o.t0) == o.rattle_state


def test_system_api_and_json(ks):
    orbit = ks.periodic_orbit(method="shooting")
    d = orbit.to_dict()
    for key in ("x0", "period", "multipliers", "monodromy", "stable", "iterations", "residual",
                "rattle_state", "max", "min"):
        assert key in d
    assert all(len(m) == 2 for m in d["multipliers"])
    assert d["max"] > d["min"]
    tr = orbit.trajectory()
    assert d["max"] == pytest.approx(tr.y[:, 0].max(), abs=1e-5)


def test_long_period_multipliers_need_segment_products():
    """NFG (liu_nfg_160): the orbit spans Z2 = 64 mesh cycles and the multipliers are
    ~1e-21 and ~1e-32.  Their product must equal Liouville's determinant
    exp(int trace J dt) (trace of the generated Jacobian along the orbit, trapezoid
    rule; the saltation determinants are 1 for the continuous backlash force).  The
    product of segment monodromies (multiple shooting) gets it to ~1e-7; one
    monodromy over the whole period does not (its entries sit far below atol)."""
    from scipy.integrate import trapezoid

    system = gearsym.load_scene(ROOT / "scenes" / "liu_nfg_160.toml").compile()
    single = system.periodic_orbit(transient=10, rtol=1e-10, atol=1e-14)
    n = 4001  # the trace is smooth and periodic: the trapezoid rule converges fast
    tr = system.simulate(t_end=single.period, x0=single.x0, rtol=1e-12, atol=1e-16, n_out=n)
    p = np.tile(system.param_vector()[:, None], (1, n))
    g = np.asarray(system.generated.casadi_function("gs_sw").map(n)(tr.t[None, :], tr.y.T, p))
    J = np.asarray(system.generated.casadi_function("gs_jac").map(n)(tr.t[None, :], tr.y.T, p,
                                                                     np.where(g >= 0, 1.0, -1.0)))
    J = J.reshape(2, n, 2)
    log_det = trapezoid(J[0, :, 0] + J[1, :, 1], tr.t)
    multi = system.periodic_orbit(segments=8, x0=single.x0, transient=0, rtol=1e-10, atol=1e-14)
    assert np.max(np.abs(multi.x0 - single.x0)) < 1e-9
    log_det_multi = float(np.sum(np.log(np.abs(multi.multipliers))))
    log_det_single = float(np.sum(np.log(np.abs(single.multipliers))))
    assert abs(log_det_multi - log_det) < 1e-4 * abs(log_det)
    assert abs(log_det_multi - log_det) < 1e-4
    assert abs(log_det_single - log_det) > 1e-2  # single shooting loses the small multiplier
    # the dominant multiplier: segment products agree with each other, the single
    # monodromy (entries ~1e-21, far below atol) only roughly
    multi16 = system.periodic_orbit(segments=16, x0=multi.x0, transient=0, rtol=1e-10, atol=1e-14)
    mu8, mu16 = multi.multipliers[0], multi16.multipliers[0]
    assert abs(mu8 - mu16) < 1e-5 * abs(mu16)
    assert abs(single.multipliers[0] - mu16) < 1e-2 * abs(mu16)
    assert multi.stable and multi.rattle_state == 1


def test_cli_orbit(tmp_path, capsys):
    import json

    from gearsym.cli import main

    rc = main(["orbit", str(SCENE), "--effect", "contact_damping", "--json", "--out", str(tmp_path / "o")])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    for key in ("x0", "period", "multipliers", "monodromy", "stable", "iterations", "residual",
                "rattle_state", "max", "min"):
        assert key in info
    assert info["rattle_state"] == 1 and info["stable"] is True
    assert all(isinstance(m, list) and len(m) == 2 for m in info["multipliers"])
    for name in ("orbit.json", "orbit_phase.png", "orbit_multipliers.png"):
        assert (tmp_path / "o" / name).stat().st_size > 0
    rc = main(["orbit", str(SCENE), "--method", "hbm", "--harmonics", "16", "--set", "Omega=1.4"])
    assert rc == 0 and "stable" in capsys.readouterr().out
    assert main(["orbit", str(SCENE), "--periods", "0"]) == 2
    assert main(["orbit", str(SCENE), "--x0", "1,a"]) == 2
    assert main(["orbit", str(SCENE), "--set", "nope=1"]) == 2
