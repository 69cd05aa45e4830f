"""The dimensional spur pair reduces to the benchmark equation (symbolically and numerically).

Hand derivation (independent of gearsym): with x = rb1*th1 - rb2*th2 - e(t),
J1*th1'' = T1 - rb1*W, J2*th2'' = -T2 + rb2*W, W = k(t)*f(x) + c_m*x':

    m_e*x'' + c_m*x' + k(t)*f(x) = m_e*(rb1*T1/J1 + rb2*T2/J2) - m_e*e''(t),
    m_e = 1/(rb1^2/J1 + rb2^2/J2).

With tau = omega_n*t, omega_n = sqrt(k_m/m_e), X = x/b_m this is the benchmark with
zeta = c_m/(2*sqrt(k_m*m_e)), eps = k_a/k_m, Omega = omega/omega_n,
Fm = m_e*(rb1*T1/J1 + rb2*T2/J2)/(k_m*b_m), Fa = e_a/b_m, b = 1.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gearsym

ROOT = Path(__file__).resolve().parents[1]


def _mapping(v: dict[str, float]) -> dict[str, float]:
    m_e = 1.0 / (v["rb1"] ** 2 / v["J1"] + v["rb2"] ** 2 / v["J2"])
    wn = math.sqrt(v["k_m"] / m_e)
    return {
        "m_e": m_e, "omega_n": wn,
        "zeta": v["c_m"] / (2 * math.sqrt(v["k_m"] * m_e)),
        "eps": v["k_a"] / v["k_m"],
        "Omega": v["omega"] / wn,
        "Fm": m_e * (v["rb1"] * v["T1"] / v["J1"] + v["rb2"] * v["T2"] / v["J2"]) / (v["k_m"] * v["b_m"]),
        "Fa": v["e_a"] / v["b_m"],
        "b": 1.0,
    }


@pytest.fixture(scope="module")
def scenes():
    dim = gearsym.load_scene(ROOT / "scenes" / "spur_pair_torsional.toml")
    ks = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml")
    return dim, ks


def test_reduced_equation_matches_hand_derivation(scenes):
    dim, _ = scenes
    m = dim.model
    J1, J2, rb1, rb2, k_m, k_a, c_m, b_m, T1, T2, e_a, w = sp.symbols(
        "J1 J2 rb1 rb2 k_m k_a c_m b_m T1 T2 e_a omega", real=True)
    t, x, v = sp.symbols("t x v", real=True)
    m_e = 1 / (rb1**2 / J1 + rb2**2 / J2)
    k = k_m + k_a * sp.cos(w * t)
    e = e_a * sp.cos(w * t)
    F = m_e * (rb1 * T1 / J1 + rb2 * T2 / J2) - m_e * sp.diff(e, t, 2)
    hand = {  # acceleration in each mode: drive contact, back contact, separation
        "drive": (F - c_m * v - k * (x - b_m)) / m_e,
        "back": (F - c_m * v - k * (x + b_m)) / m_e,
        "free": (F - c_m * v) / m_e,
    }
    acc = m.modal.rhs[1]
    assert isinstance(acc, sp.Piecewise)
    sigma = m.modal.sigma
    (a_drive, c_drive), (a_back, c_back), (a_free, c_free) = acc.args
    assert c_drive == (sigma[0] > 0) and c_back == (sigma[1] < 0) and c_free == sp.true
    for got, want in ((a_drive, hand["drive"]), (a_back, hand["back"]), (a_free, hand["free"])):
        assert sp.simplify(got - want) == 0
    assert [sp.simplify(s.expr - want) for s, want in zip(m.switching, (x - b_m, x + b_m))] == [0, 0]
    assert sp.simplify(m.reduced_mass - m_e) == 0


def test_dimensionless_form_is_the_benchmark_equation(scenes):
    dim, ks = scenes
    d = dim.model.dimensionless()
    assert d.leftover == []
    ksm = ks.model
    tau = d.time
    sub = {ksm.t: tau, sp.Symbol("b", real=True): 1}
    ks_acc = ksm.modal.rhs[1].xreplace(sub)
    ours = d.accelerations[0]
    # same symbols (states x, v; groups zeta, eps, Omega, Fm, Fa; surface sides sigma_j):
    # compare in every mode (drive contact, separation, back contact)
    s0, s1 = ksm.modal.sigma
    for sides in ((1, 1), (-1, 1), (-1, -1)):
        mode = {s0: sides[0], s1: sides[1]}
        assert sp.simplify(ours.xreplace(mode) - ks_acc.xreplace(mode)) == 0, sides
    assert [sp.simplify(g) for g in d.switching] == [sp.Symbol("x", real=True) - 1,
                                                     sp.Symbol("x", real=True) + 1]
    # the printed group definitions are the hand ones
    vals = {p: dim.resolved.values[p] for p in dim.model.parameter_names}
    hand = _mapping(vals)
    subs = {sp.Symbol(k, real=True): v for k, v in vals.items()}
    for name in ("zeta", "eps", "Omega", "Fm", "Fa"):
        assert float(d.groups[name].xreplace(subs)) == pytest.approx(hand[name], rel=1e-12)


def test_dimensional_and_benchmark_trajectories_agree_after_scaling(scenes):
    dim, _ = scenes
    sd = dim.compile()
    vals = sd.units.to_si(sd.params)  # SI values: the test scales the physics itself
    mp = _mapping(vals)
    ks = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml",
                            **{k: mp[k] for k in ("zeta", "eps", "Omega", "Fm", "Fa", "b")})
    sk = ks.compile()
    wn, b_m = mp["omega_n"], vals["b_m"]
    periods = 60
    T_ks = 2 * math.pi / mp["Omega"]
    tau = np.linspace(0, periods * T_ks, 60 * 32 + 1)
    X0 = np.array([1.1, 0.05])
    tr_ks = sk.simulate(t_out=tau, t_end=tau[-1], x0=X0, rtol=1e-11, atol=1e-13)
    tr_d = sd.simulate(t_out=tau / wn, t_end=tau[-1] / wn, x0=X0 * [b_m, b_m * wn], rtol=1e-11,
                       atol=1e-18)
    X = tr_d.y[:, 0] / b_m
    V = tr_d.y[:, 1] / (b_m * wn)
    assert np.max(np.abs(X - tr_ks.y[:, 0])) < 1e-6
    assert np.max(np.abs(V - tr_ks.y[:, 1])) < 1e-6
    assert len(tr_d.events) == len(tr_ks.events) > 10
    ev_d = np.array([e.t for e in tr_d.events]) * wn
    ev_k = np.array([e.t for e in tr_ks.events])
    assert np.max(np.abs(ev_d - ev_k)) < 1e-6
