"""Moving switching surfaces (a time-varying pressure angle and a dynamic backlash that
follows a bearing coordinate) and Floquet multipliers close to +1 and -1.

References: a hand-derived right-hand side integrated by the event-located DOP853 of
:mod:`tests.hard._ref`; the exact monodromy of the damped Meissner equation (a product of
two matrix exponentials, Vaishya & Singh 2001 eqs. 25-31).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

import gearsym

from ._ref import hybrid_solve

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"


# ------------------------------------------------------------------ moving surfaces
P = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.3, "Omega": 0.6, "b0": 1.0, "alpha0": 0.35, "alpha1": 0.05,
     "my": 2.0, "ky": 1.5, "cy": 0.1}


def _moving_rhs(p):
    """Hand derivation (element semantics: Q_i = -W d(delta)/d(q_i)): delta = x + y sin(alpha(t)),
    alpha = alpha0 + alpha1 sin(Omega t), dead zone of half width b(y) = b0 + y tan(alpha0),
    W = f(delta; b) + 2 zeta delta';  x'' = Fm + Fa Omega^2 cos(Omega t) - W,
    my y'' = -ky y - cy y' - W sin(alpha)."""
    zeta, Fm, Fa, Om, b0, a0, a1, my, ky, cy = (p[k] for k in ("zeta", "Fm", "Fa", "Omega", "b0", "alpha0",
                                                                "alpha1", "my", "ky", "cy"))

    def parts(t, y):
        x, yy = y[0], y[1]
        al = a0 + a1 * math.sin(Om * t)
        delta = x + yy * math.sin(al)
        b = b0 + yy * math.tan(a0)
        return al, delta, b

    def rhs(t, y, s):
        x, yy, v, w = y
        al, delta, b = parts(t, y)
        ddelta = v + w * math.sin(al) + yy * math.cos(al) * a1 * Om * math.cos(Om * t)
        f = (delta - b) if s[0] > 0 else (delta + b) if s[1] < 0 else 0.0
        W = f + 2 * zeta * ddelta
        return np.array([v, w, Fm + Fa * Om**2 * math.cos(Om * t) - W, (-ky * yy - cy * w - W * math.sin(al)) / my])

    def g(t, y):
        _, delta, b = parts(t, y)
        return np.array([delta - b, delta + b])

    return rhs, g


def test_time_varying_pressure_angle_and_dynamic_backlash_move_the_surfaces():
    scene = gearsym.load_scene(DATA / "moving_surfaces_scene.toml")
    m = scene.model
    t_sym = m.t
    # the surfaces really depend on time and on two states
    for s in m.switching:
        assert s.expr.has(t_sym) and {str(v) for v in s.expr.free_symbols} >= {"x", "y"}
    system = scene.compile()
    rhs, g = _moving_rhs(P)
    T = system.period()
    t = np.linspace(0, 12 * T, 12 * 64 + 1)
    x0 = [1.1, 0.0, 0.0, 0.0]
    y_ref, ev_ref = hybrid_solve(rhs, g, x0, t, rtol=1e-13, atol=1e-15, max_step=T / 32)
    assert len(ev_ref) > 20
    for method in ("adams", "bdf"):
        tr = system.simulate(t_end=t[-1], t_out=t, x0=x0, rtol=1e-11, atol=1e-13, method=method)
        assert len(tr.events) == len(ev_ref)
        assert [e.surface for e in tr.events] == [("mesh.drive", "mesh.back")[j] for _, j, _ in ev_ref]
        np.testing.assert_allclose([e.t for e in tr.events], [e[0] for e in ev_ref], rtol=0, atol=1e-8)
        assert np.max(np.abs(tr.y - y_ref)) < 1e-8
        # located exactly on the moving surface
        for e in tr.events[:10]:
            ye = system.simulate(t_end=e.t, x0=x0, rtol=1e-11, atol=1e-13, n_out=2, method=method).x_final
            j = ("mesh.drive", "mesh.back").index(e.surface)
            assert abs(g(e.t, ye)[j]) < 1e-8


# ------------------------------------------------------------------ multipliers
MEISSNER = {"zeta": 0.02, "w0": 1.0, "a": 0.3, "d": 0.5}


def _exact_monodromy(T: float, p=MEISSNER) -> np.ndarray:
    def A(sign):
        return np.array([[0.0, 1.0], [-p["w0"] ** 2 * (1 + sign * p["a"]), -2 * p["zeta"] * p["w0"]]])
    return expm(A(-1) * (1 - p["d"]) * T) @ expm(A(+1) * p["d"] * T)


def _boundary(sign: int, lo: float, hi: float) -> float:
    """Period T at which a multiplier is exactly sign*1: tr(Phi) = sign*(1 + det(Phi))."""
    def h(T):
        Phi = _exact_monodromy(T)
        return np.trace(Phi) - sign * (1 + np.linalg.det(Phi))
    Ts = np.linspace(lo, hi, 400)
    hs = [h(T) for T in Ts]
    k = next(i for i in range(len(Ts) - 1) if hs[i] * hs[i + 1] < 0)
    return brentq(h, Ts[k], Ts[k + 1], xtol=1e-15)


@pytest.fixture(scope="module")
def meissner():
    return gearsym.load_scene(ROOT / "scenes" / "meissner.toml").compile()


@pytest.mark.parametrize("sign,window", [(-1, (2.4, 3.2)), (+1, (5.2, 6.3))],
                         ids=["period-doubling (mu=-1)", "fold (mu=+1)"])
def test_multipliers_near_plus_and_minus_one(meissner, sign, window):
    """At the edge of an instability tongue of the damped Meissner equation one multiplier
    crosses sign*1.  Just inside and outside it (|mu| = 1 -+ ~1e-6) the multipliers of the
    variational monodromy match the exact ones to 1e-9 and classify stability correctly."""
    T_star = _boundary(sign, *window)
    dT = 1e-5 * T_star
    mus = []
    for T in (T_star - dT, T_star + dT):
        exact = np.linalg.eigvals(_exact_monodromy(T))
        tr = meissner.simulate(t_end=T, params={**MEISSNER, "T": T}, x0=[0.3, -0.2], rtol=1e-12, atol=1e-14,
                               monodromy=True)
        mu = np.linalg.eigvals(tr.monodromy)
        key = np.argsort(np.abs(exact))
        exact, mu = exact[key], mu[np.argsort(np.abs(mu))]
        np.testing.assert_allclose(mu, exact, rtol=0, atol=1e-9)
        dom = exact[-1]
        assert abs(dom.imag) < 1e-12 and np.sign(dom.real) == sign   # real, near sign*1
        assert 0 < abs(abs(dom) - 1) < 1e-3
        assert (np.max(np.abs(mu)) < 1) == (np.max(np.abs(exact)) < 1)
        mus.append(np.max(np.abs(mu)))
    assert (mus[0] < 1) != (mus[1] < 1)          # the two sides of the boundary differ


# ------------------------------------------- nonlinear orbits at a fold and a period doubling
def _fd_monodromy(params, x0, T, h=1e-6):
    """Central finite differences of the hand-written event-located DOP853 flow over one period."""
    from ._ref import ks

    R = ks()
    cols = []
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        yp = R.reference_solution(params, np.asarray(x0) + e, [0.0, T], rtol=1e-13, atol=1e-15)[0][-1]
        ym = R.reference_solution(params, np.asarray(x0) - e, [0.0, T], rtol=1e-13, atol=1e-15)[0][-1]
        cols.append((yp - ym) / (2 * h))
    y0 = R.reference_solution(params, x0, [0.0, T], rtol=1e-13, atol=1e-15)[0][-1]
    return np.array(cols).T, y0


@pytest.mark.parametrize("kind,window,extra", [("fold", (0.6, 1.4), {}),
                                               ("period_doubling", (0.58, 0.64), {"Fa": 0.4})])
def test_backlash_orbit_multiplier_at_a_fold_and_a_period_doubling(kind, window, extra):
    """The benchmark oscillator's period-1 orbit at a located fold (multiplier +1) and period
    doubling (-1): the orbit is a fixed point of the hand-written reference flow, and the
    variational monodromy's multipliers match finite differences of that flow; shooting
    next to the point (ill-conditioned Newton) converges and reports the multiplier near +-1."""
    from ._ref import ks

    R = ks()
    system = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()
    br = gearsym.continuation(system, "Omega", *window, params=extra, progress=False)
    # (the fold at Omega ~ 0.894 sits next to a grazing; take the smooth one at ~ 0.836)
    pts = [b for b in br.of_type(kind) if kind != "fold" or b.value < 0.87]
    assert len(pts) == 1
    b = pts[0]
    sign = 1.0 if kind == "fold" else -1.0
    params = dict(R.DEFAULTS, **extra, Omega=b.value)
    T = 2 * math.pi / b.value
    M_fd, y_T = _fd_monodromy(params, b.point.x0, T)
    assert np.max(np.abs(y_T - b.point.x0)) < 1e-8                  # a periodic orbit of the reference flow
    mu_fd = np.linalg.eigvals(M_fd)
    mu_gs = np.asarray(b.point.multipliers)
    assert np.min(np.abs(mu_gs - sign)) < 1e-6
    np.testing.assert_allclose(np.sort_complex(mu_gs), np.sort_complex(mu_fd), rtol=0, atol=1e-5)
    # shooting from a neighbouring branch point (slightly perturbed) converges back to it
    # (the branch point of this bifurcation, not the first of its kind: there may be two folds)
    k = (b.index if 0 <= b.index < len(br.points)
         else min(range(len(br.points)), key=lambda i: abs(br.points[i].value - b.value)))
    nb = br.points[k - 1] if k > 0 else br.points[k + 1]
    orb = system.periodic_orbit(x0=nb.x0 * (1 + 1e-4), params={**extra, "Omega": nb.value}, rtol=1e-11,
                                atol=1e-13, tol=1e-10, relax_periods=0)
    assert orb.converged
    near = orb.multipliers[np.argmin(np.abs(orb.multipliers - sign))]
    # against the fixed point of the independent reference flow (Newton on that flow with its
    # finite-difference monodromy), as far as the conditioning allows: a residual r moves the
    # fixed point by ~ r / |mu - sign| along the critical direction.  The shooting solve
    # (tol 1e-10) must be close; the branch point (continuation tolerance) less so.
    pr = dict(R.DEFAULTS, **extra, Omega=nb.value)
    x_ref = orb.x0.copy()
    for _ in range(3):
        M_ref, y_T = _fd_monodromy(pr, x_ref, 2 * math.pi / nb.value)
        x_ref = x_ref - np.linalg.solve(M_ref - np.eye(2), y_T - x_ref)
    cond = 1.0 / abs(near - sign)
    assert np.max(np.abs(orb.x0 - x_ref)) < 1e-9 * cond
    assert np.max(np.abs(nb.x0 - x_ref)) < 1e-8 * cond
    assert abs(near - sign) < 0.1 and abs(near - sign) < 10 * abs(nb.value - b.value) ** 0.5 + 1e-3


def test_six_dof_pressure_angle_and_dynamic_backlash_against_a_python_reference():
    """Yu et al.'s 6-DOF pair (scene yu_dynamic_D14, time-varying pressure angle and dynamic
    backlash on, load lowered to 20 N m so that the teeth rattle): the contact surfaces move
    with the bearing coordinates.  Checked against the same equations integrated in
    Python (sympy.lambdify + the event-located scipy DOP853 of tests/hard/_ref.py at rtol 1e-12,
    tests/hard/_lambdified.py), which shares only the symbolic derivation with the generated C
    and the engine."""
    from ._lambdified import lambdified_solve

    scene = gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml", T_p=20.0, T_g=20.0)
    eff = scene.resolved.effects
    assert eff["time_varying_pressure_angle"] and eff["dynamic_backlash"]
    system = scene.compile()
    for s in system.generated.surfaces:
        if s["kind"] in ("drive", "back"):
            assert all(name in s["expr"] for name in ("xp", "yp", "xg", "yg"))   # surfaces move with the centres
    T = system.period()
    t = np.linspace(0, 8 * T, 8 * 32 + 1)
    tr = system.simulate(t_end=t[-1], t_out=t, rtol=1e-11, atol=1e-17)
    scale = np.max(np.abs(tr.y), axis=0)
    ref = lambdified_solve(scene.model, system.param_vector(), system.x0, t, rtol=1e-12, atol=1e-14 * scale)
    assert len(ref.event_t) > 20 and len(tr.events) == len(ref.event_t)
    assert [system.surface_names.index(e.surface) for e in tr.events] == list(ref.event_surface)
    np.testing.assert_allclose([e.t for e in tr.events], ref.event_t, rtol=0, atol=1e-8 * T)
    assert np.max(np.abs(tr.y - ref.y) / scale) < 1e-7
