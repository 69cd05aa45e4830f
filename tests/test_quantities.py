"""Gear quantities (issue 29, item 1): every quantity against a hand computation from the trajectory
(numpy on its arrays and its event list, never gearsym.quantities), the dynamic factor and the
contact ratios against closed forms of linear oscillators, the planets' load sharing against the
mesh forces written out from the planetary model's equations.

* ``kahraman_singh`` (x'' + 2 zeta x' + (1 + eps cos Omega t) f(x) = Fm + Fa Omega^2 cos Omega t,
  f the dead zone of half width b): the mesh force is W = (1 + eps cos Omega t) f(x) + 2 zeta x',
  the static state x_s = Fm + b (the mean of the stiffness is 1), its force Fm.  With eps = 0 and
  a forcing below grazing the steady response is x = x_s + A cos(Omega t - phi),
  A = Fa Omega^2 / sqrt((1 - Omega^2)^2 + (2 zeta Omega)^2), so W = Fm + A sqrt(1 + (2 zeta Omega)^2)
  cos(...): dynamic factor 1 + A sqrt(1 + (2 zeta Omega)^2) / Fm, RMS factor
  sqrt(1 + A^2 (1 + (2 zeta Omega)^2) / (2 Fm^2)), DTE RMS A / sqrt(2), order-1 amplitude A, no
  contact loss.
* ``tests/data/flank_probe.toml``: the linear oscillator x'' + 2 zeta x' + x = Fm + F cos Omega t
  with a mesh of zero stiffness and damping: its flanks' surfaces (x - b, x + b) are located
  events that change nothing, so the response stays x = Fm + A cos(theta) through contact loss
  and back contact.  The drive flank is open while cos(theta) < (b - Fm)/A: a fraction
  1 - arccos((b - Fm)/A)/pi of the period; the back flank closed while cos(theta) < (-b - Fm)/A;
  the flanks close at the speed |x'| = A Omega sqrt(1 - c^2), c the level's cosine.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.cli import main
from gearsym.errors import ParameterError
from gearsym.static import static_equilibrium

ROOT = Path(__file__).resolve().parents[1]
KS = ROOT / "scenes" / "kahraman_singh.toml"
PROBE = ROOT / "tests" / "data" / "flank_probe_scene.toml"


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def probe():
    return gearsym.load_scene(PROBE).compile()


# ------------------------------------------------------------------ hand computations
def _window(traj, ts, te):
    """Window samples ``[ts, te)`` of an evenly sampled trajectory."""
    k0, k1 = int(np.argmin(np.abs(traj.t - ts))), int(np.argmin(np.abs(traj.t - te)))
    assert abs(traj.t[k0] - ts) < 1e-9 and abs(traj.t[k1] - te) < 1e-9
    return k0, k1


def _dft_amplitude(e, k):
    """|2/m sum_j e_j exp(-2 pi i j k / m)|, written out."""
    m = len(e)
    j = np.arange(m)
    return 2.0 / m * abs(np.sum(e * np.exp(-2j * np.pi * j * k / m)))


def _flank_times(traj, ts, te, surface, closed_at_start, closing_direction):
    """Time the flank of ``surface`` is closed in [ts, te), and its closing events (t, |speed|),
    from the event list."""
    closed, last, total, impacts = closed_at_start, ts, 0.0, []
    for e, v in zip(traj.events, traj.event_speed):
        if e.surface != surface or not ts <= e.t < te:
            continue
        if closed:
            total += e.t - last
        closed, last = e.direction == closing_direction, e.t
        if closed:
            impacts.append((e.t, abs(v)))
    if closed:
        total += te - last
    return total, impacts


def ks_by_hand(traj, ts, te, harmonics=3):
    """Every gear quantity of kahraman_singh's mesh over [ts, te), from the arrays and the events."""
    p = traj.params
    Fm, b, eps, zeta, Om = p["Fm"], p["b"], p["eps"], p["zeta"], p["Omega"]
    k0, k1 = _window(traj, ts, te)
    t, x, v = traj.t[k0:k1], traj["x"][k0:k1], traj["v"][k0:k1]
    f = np.where(x > b, x - b, np.where(x < -b, x + b, 0.0))
    W = (1 + eps * np.cos(Om * t)) * f + 2 * zeta * v
    xs, Ws = Fm + b, Fm
    e = x - xs
    K = round((te - ts) / (2 * np.pi / Om))
    drive_closed, drive_imp = _flank_times(traj, ts, te, "mesh.drive", x[0] - b > 0, +1)
    back_closed, back_imp = _flank_times(traj, ts, te, "mesh.back", x[0] + b < 0, -1)
    imp = sorted(drive_imp + back_imp)
    return {"static_deflection": xs, "static_force": Ws, "dte_mean": e.mean(), "dte_rms": np.sqrt(np.mean(e ** 2)),
            "dte_peak_to_peak": e.max() - e.min(), "force_mean": W.mean(), "force_rms": np.sqrt(np.mean(W ** 2)),
            "force_min": W.min(), "force_max": W.max(), "dynamic_factor": W.max() / Ws,
            "dynamic_factor_rms": np.sqrt(np.mean(W ** 2)) / Ws,
            "contact_loss_ratio": 1 - drive_closed / (te - ts), "back_contact_ratio": back_closed / (te - ts),
            "impact_count": len(imp), "impacts_per_period": len(imp) / ((te - ts) * Om / (2 * np.pi)),
            "impact_velocity_max": max((s for _, s in imp), default=0.0),
            **{f"dte_harmonic_{h}": _dft_amplitude(e, h * K) for h in range(1, harmonics + 1)},
            "_impacts": imp}


def _assert_all(m, hand, rel=1e-9, absolute=1e-12):
    for name, want in hand.items():
        if name.startswith("_"):
            continue
        assert m.value(name) == pytest.approx(want, rel=rel, abs=absolute), name
    want = np.array(hand["_impacts"]).reshape(-1, 2)
    assert np.column_stack([m.impact_times, m.impact_velocities]) == pytest.approx(want, rel=1e-12)


# ------------------------------------------------------------------ against hand computations
@pytest.mark.parametrize("params,loss,back", [
    ({"Omega": 0.6}, False, False),                  # no impact
    ({"Omega": 0.9}, True, False),                   # single-sided impacts
    ({"Omega": 0.8, "Fa": 0.6}, True, True),         # double-sided impacts
], ids=["no_impact", "single_sided", "double_sided"])
def test_trajectory_quantities_equal_a_hand_computation(ks, params, loss, back):
    tr = ks.simulate(periods=40, params=params)
    gq = tr.gear_quantities()
    T = 2 * np.pi / params["Omega"]
    # the steady window: the second half, whole forcing periods ending at the last output time
    assert gq.t_end == tr.t[-1]
    assert gq.t_start == pytest.approx(tr.t[-1] - 20 * T, rel=1e-12)
    assert gq.periods == pytest.approx(20)
    m = gq["mesh"]
    hand = ks_by_hand(tr, gq.t_start, gq.t_end)
    _assert_all(m, hand)
    assert (m.contact_loss_ratio > 0) == loss and (m.back_contact_ratio > 0) == back
    assert (m.impact_count > 0) == loss
    assert set(m.impact_flanks) == ({"drive", "back"} if back else {"drive"} if loss else set())


def test_orbit_quantities_equal_a_hand_computation_and_the_impact_speed_is_the_closing_speed(ks):
    orbit = ks.periodic_orbit(params={"Omega": 0.9})
    gq = orbit.gear_quantities()
    tr = orbit.trajectory()
    assert (gq.t_start, gq.t_end) == pytest.approx((orbit.t0, orbit.t0 + orbit.period))
    hand = ks_by_hand(tr, orbit.t0, orbit.t0 + orbit.period)
    _assert_all(gq["mesh"], hand)
    assert gq["mesh"].impact_count == 1 and gq["mesh"].impacts_per_period == 1
    # the impact velocity is the relative velocity x' of the flanks when they close: integrate to
    # the event time itself and read v there
    (t_imp, speed), = hand["_impacts"]
    end = ks.simulate(t_end=t_imp, t0=orbit.t0, x0=orbit.x0, rtol=1e-12, atol=1e-14, n_out=2,
                      params=orbit.params).x_final
    assert end[0] == pytest.approx(orbit.params["b"], abs=1e-8)
    assert gq["mesh"].impact_velocity_max == pytest.approx(end[1], rel=1e-6)


# ------------------------------------------------------------------ closed forms
def test_dynamic_factor_and_dte_of_the_linear_response_equal_the_closed_form(ks):
    Om, Fa = 0.6, 0.01
    orbit = ks.periodic_orbit(params={"eps": 0.0, "Fa": Fa, "Omega": Om})
    p = orbit.params
    zeta, Fm = p["zeta"], p["Fm"]
    A = Fa * Om ** 2 / math.sqrt((1 - Om ** 2) ** 2 + (2 * zeta * Om) ** 2)
    assert A < Fm  # below grazing: the teeth never separate
    m = orbit.gear_quantities()["mesh"]
    amp_W = A * math.sqrt(1 + (2 * zeta * Om) ** 2)  # the elastic and the damping force in quadrature
    assert m.static_deflection == pytest.approx(Fm + p["b"], rel=1e-12)
    assert m.static_force == pytest.approx(Fm, rel=1e-12)
    assert m.dynamic_factor == pytest.approx(1 + amp_W / Fm, rel=1e-6)
    assert m.dynamic_factor_rms == pytest.approx(math.sqrt(1 + amp_W ** 2 / (2 * Fm ** 2)), rel=1e-8)
    assert m.dte_rms == pytest.approx(A / math.sqrt(2), rel=1e-7)
    assert m.dte_mean == pytest.approx(0.0, abs=1e-9 * A)
    assert m.dte_harmonics[0] == pytest.approx(A, rel=1e-7)
    assert np.all(m.dte_harmonics[1:] < 1e-7 * A)
    assert m.contact_loss_ratio == 0.0 and m.back_contact_ratio == 0.0 and m.impact_count == 0


def test_contact_ratios_and_impact_speeds_through_contact_loss_equal_the_closed_form(probe):
    orbit = probe.periodic_orbit()
    p = orbit.params
    Om, zeta, Fm, F, b = p["Omega"], p["zeta"], p["Fm"], p["F"], p["b"]
    A = F / math.sqrt((1 - Om ** 2) ** 2 + (2 * zeta * Om) ** 2)
    c_drive, c_back = (b - Fm) / A, (-b - Fm) / A
    assert -1 < c_back < c_drive < 1  # the response opens the drive flank and closes the back flank
    gq = orbit.gear_quantities()
    m = gq["flank"]
    assert m.contact_loss_ratio == pytest.approx(1 - math.acos(c_drive) / math.pi, abs=1e-9)
    assert m.back_contact_ratio == pytest.approx(1 - math.acos(c_back) / math.pi, abs=1e-9)
    assert m.impact_count == 2 and sorted(m.impact_flanks) == ["back", "drive"]
    speeds = dict(zip(m.impact_flanks, m.impact_velocities))
    assert speeds["drive"] == pytest.approx(A * Om * math.sqrt(1 - c_drive ** 2), rel=1e-8)
    assert speeds["back"] == pytest.approx(A * Om * math.sqrt(1 - c_back ** 2), rel=1e-8)
    # a force-free mesh: no static force, so no dynamic factor (NaN, not a division by zero)
    assert m.static_force == 0.0 and math.isnan(m.dynamic_factor) and math.isnan(m.dynamic_factor_rms)


def test_a_long_simulation_gives_the_closed_form_contact_ratio(probe):
    """The same ratio from a simulation's steady window (whole periods, events exact)."""
    tr = probe.simulate(periods=120)
    p = tr.params
    A = p["F"] / math.sqrt((1 - p["Omega"] ** 2) ** 2 + (2 * p["zeta"] * p["Omega"]) ** 2)
    m = tr.gear_quantities()["flank"]
    assert m.contact_loss_ratio == pytest.approx(1 - math.acos((p["b"] - p["Fm"]) / A) / math.pi, abs=1e-7)
    assert m.impacts_per_period == 2


# ------------------------------------------------------------------ planets, mesh orders
@pytest.fixture(scope="module")
def planetary():
    return gearsym.load_scene(ROOT / "scenes" / "planetary_n3.toml").compile()


def _planet_forces(system, tr, k0, k1):
    """Mesh forces of planetary_n3 written out from its model: W = k(t) f(delta) + c delta'."""
    p = system.units.to_si(dict(tr.params))
    t = tr.t[k0:k1]
    s = {n: tr[n][k0:k1] for n in tr.state_names}
    a = p["alpha"]
    out = {}
    for n in (1, 2, 3):
        psi = p[f"psi_{n}"]
        for mesh, side in (("sp", +1), ("rp", -1)):
            M = "s" if side > 0 else "r"
            ang = psi - a if side > 0 else psi + a

            def geo(v, M=M, ang=ang, n=n, side=side):
                return (-s[f"x_{M}{v}"] * np.sin(ang) + s[f"y_{M}{v}"] * np.cos(ang) + s[f"u_{M}{v}"]
                        - side * s[f"zeta_{n}{v}"] * np.sin(a) - s[f"eta_{n}{v}"] * np.cos(a) + side * s[f"u_{n}{v}"])

            d, dd = geo(""), geo("_dot")  # the deflection along the line of action and its rate
            if side > 0:
                k = p["k_sp"] * (1 + p["eps_s"] * np.cos(2 * np.pi * p["f_m"] * t - p["Z_s"] * psi))
                c = 2 * p["zeta_m"] * np.sqrt(p["k_sp"] / (1 / p["mu_s"] + 1 / p["mu_p"]))
                bl = p["b_s"]
            else:
                k = p["k_rp"] * (1 + p["eps_r"] * np.cos(2 * np.pi * (p["f_m"] * t - p["gamma_rs"]) + p["Z_r"] * psi))
                c = 2 * p["zeta_m"] * np.sqrt(p["k_rp"] / (1 / p["mu_r"] + 1 / p["mu_p"]))
                bl = p["b_r"]
            f = np.where(d > bl, d - bl, np.where(d < -bl, d + bl, 0.0))
            out[f"{mesh}{n}"] = k * f + c * dd
    return out


def test_load_sharing_of_unequally_spaced_planets_equals_a_hand_computation(planetary):
    tr = planetary.simulate(periods=20, params={"psi_2": 115.0, "T_s": 100.0})
    gq = tr.gear_quantities()
    assert gq.planet_sets == {"sp": ["sp1", "sp2", "sp3"], "rp": ["rp1", "rp2", "rp3"]}
    k0, k1 = _window(tr, gq.t_start, gq.t_end)
    W = _planet_forces(planetary, tr, k0, k1)
    for prefix in ("sp", "rp"):
        mean_of_means = np.mean([W[f"{prefix}{n}"].mean() for n in (1, 2, 3)])
        for n in (1, 2, 3):
            m = gq[f"{prefix}{n}"]
            assert m.planet_set == prefix
            assert m.force_mean == pytest.approx(W[f"{prefix}{n}"].mean(), rel=1e-9)
            assert m.force_max == pytest.approx(W[f"{prefix}{n}"].max(), rel=1e-9)
            assert m.load_sharing_factor == pytest.approx(W[f"{prefix}{n}"].max() / mean_of_means, rel=1e-9)
    # unequal spacing shares the load unequally: the planets' mean forces differ by percents
    means = [gq[f"sp{n}"].force_mean for n in (1, 2, 3)]
    assert (max(means) - min(means)) / np.mean(means) > 0.03


def test_planet_sets_by_name():
    from gearsym.quantities import planet_sets_of

    assert planet_sets_of(["sp1", "rp1", "sp2", "rp2", "sp3", "rp3"]) == {"sp": ["sp1", "sp2", "sp3"],
                                                                          "rp": ["rp1", "rp2", "rp3"]}
    assert planet_sets_of(["mesh1", "mesh2"]) == {}  # a two-stage train: meshes in series
    assert planet_sets_of(["mesh"]) == {}


def test_mesh_order_from_the_mesh_schedule():
    """two_stage_train: the forcing period is 8 mesh-1 cycles = 5 mesh-2 cycles; each mesh's order 1
    is its own schedule's frequency, its amplitude the DFT bin of that order."""
    system = gearsym.load_scene(ROOT / "scenes" / "two_stage_train.toml").compile()
    tr = system.simulate(periods=4)
    gq = tr.gear_quantities()
    p = system.units.to_si(dict(tr.params))
    Tf = tr.period
    k0, k1 = _window(tr, gq.t_start, gq.t_end)
    pv = system.param_vector(tr.params)
    D = system.mesh_deflections(tr.t[k0:k1], tr.y[k0:k1], pv)
    xs = static_equilibrium(system, tr.params, rigid="keep").state
    Ds = system.mesh_deflections(tr.t[k0:k1], np.tile(xs, (k1 - k0, 1)), pv)
    for i, (name, cycles) in enumerate((("mesh1", 8), ("mesh2", 5))):
        m = gq[name]
        w_m = p["z1"] * p["n_in"] * (1 if i == 0 else p["z3"] / p["z2"])  # the model's w_m1, w_m2
        assert m.mesh_period == pytest.approx(2 * np.pi / w_m, rel=1e-12)
        assert m.mesh_period * cycles == pytest.approx(Tf, rel=1e-12)
        K = cycles * round(gq.periods)
        e = D[:, i] - Ds[:, i]
        assert m.dte_harmonics[0] == pytest.approx(_dft_amplitude(e, K), rel=1e-9)
        assert m.dte_harmonics[1] == pytest.approx(_dft_amplitude(e, 2 * K), rel=1e-9)
    # an explicit mesh period is taken as given (order 1 = the forcing frequency here)
    g2 = tr.gear_quantities(mesh_periods={"mesh1": Tf})
    e = D[:, 0] - Ds[:, 0]
    assert g2["mesh1"].dte_harmonics[0] == pytest.approx(_dft_amplitude(e, round(gq.periods)), rel=1e-9)


# ------------------------------------------------------------------ branches and maps
def test_branch_points_carry_the_gear_quantities_of_their_orbits(ks):
    branch = gearsym.continuation(ks, "Omega", 0.85, 0.9, progress=False, ds_max=0.05)
    df = branch.quantity("dynamic_factor")
    loss = branch.quantity("contact_loss_ratio[mesh]")
    assert df.shape == loss.shape == (len(branch.points),)
    for j in (0, len(branch.points) // 2, len(branch.points) - 1):
        pt = branch.points[j]
        tr = ks.simulate(t_end=pt.period, t0=0.0, x0=pt.x0, rtol=1e-10, atol=1e-12, n_out=2049,
                         params=branch.params_at(pt.value))
        hand = ks_by_hand(tr, 0.0, pt.period)
        assert df[j] == pytest.approx(hand["dynamic_factor"], rel=1e-9)
        assert loss[j] == pytest.approx(hand["contact_loss_ratio"], abs=1e-8)  # (the branch's own tolerances)
    assert np.any(loss > 0) and np.any(loss == 0)  # the branch passes the grazing
    import matplotlib

    matplotlib.use("Agg")
    ax = branch.plot(quantity="dynamic_factor")  # located points marked on the quantity's curve
    assert ax.get_ylabel() == "dynamic factor"
    with pytest.raises(ParameterError, match="unknown gear quantity 'bogus'"):
        branch.quantity("bogus")


def test_map_of_the_dynamic_factor_is_that_of_each_points_orbit(ks):
    from gearsym.analysis.sweeps import stability_map

    ds = stability_map(ks, ("Omega", 0.6, 0.9, 2), ("Fa", 0.05, 0.05, 1), quantity="dynamic_factor", workers=1)
    assert ds.attrs["quantity"] == "dynamic_factor"
    for i, Om in enumerate((0.6, 0.9)):
        orbit = ks.periodic_orbit(params={"Omega": Om, "Fa": 0.05})
        hand = ks_by_hand(orbit.trajectory(), orbit.t0, orbit.t0 + orbit.period)
        assert float(ds["dynamic_factor"].values[0, i]) == pytest.approx(hand["dynamic_factor"], rel=1e-6)


def test_map_on_the_exact_path_gives_the_quantity_of_the_periodic_state():
    """A piecewise-constant LTV model (matrix exponentials, no orbit solve): the gear quantity of its
    periodic state equals that of the shooting orbit there; a model without meshes is refused."""
    from gearsym.analysis.sweeps import stability_map

    system = gearsym.load_scene("vaishya_singh_parametric").compile()
    ds = stability_map(system, ("Omega_p", 1000, 1000, 1), ("zeta", 0.05, 0.05, 1), quantity="dte_rms",
                       method="exact", workers=1)
    assert ds.attrs["methods_used"] == "exact"
    orbit = system.periodic_orbit(params={"Omega_p": 1000.0, "zeta": 0.05})
    assert float(ds["dte_rms"].values[0, 0]) == pytest.approx(orbit.gear_quantities()["mesh"].dte_rms, rel=1e-6)
    meissner = gearsym.load_scene("meissner").compile()
    with pytest.raises(ParameterError, match="'dynamic_factor': model 'meissner' has no mesh elements"):
        stability_map(meissner, ("a", 0.0, 0.5, 2), ("T", 1.0, 2.0, 1), quantity="dynamic_factor", workers=1)


def test_the_map_quantities_are_the_gear_quantities():
    from gearsym.quantities import QUANTITIES, map_quantities, parse_quantity
    from gearsym.spec.settings import MAP_QUANTITIES

    gear = [q for q in MAP_QUANTITIES if q not in ("max_multiplier", "peak_to_peak", "rattle_state", "lyapunov")]
    assert set(QUANTITIES) <= set(gear)
    assert list(map_quantities()) == gear
    for q in gear:
        assert parse_quantity(q) == (q, None)


# ------------------------------------------------------------------ bad input
def test_bad_requests_are_clear_errors(ks):
    from gearsym.quantities import gear_quantities, parse_quantity

    tr = ks.simulate(t_end=33.3, n_out=500)
    with pytest.raises(ParameterError, match="does not start and end on output samples"):
        tr.gear_quantities()
    tr = ks.simulate(periods=4)
    with pytest.raises(ParameterError, match="mesh_periods: no mesh 'nope'"):
        tr.gear_quantities(mesh_periods={"nope": 1.0})
    with pytest.raises(ParameterError, match="not a whole number of its mesh period"):
        tr.gear_quantities(mesh_periods={"mesh": 3.0})
    with pytest.raises(ParameterError, match="no whole forcing period"):
        ks.simulate(periods=1.5).gear_quantities()
    with pytest.raises(ParameterError, match="unknown gear quantity 'dynamic'"):
        parse_quantity("dynamic")
    assert parse_quantity("dte_harmonic_2[mesh]") == ("dte_harmonic_2", "mesh")
    from dataclasses import replace

    with pytest.raises(ParameterError, match="not attached to a system"):
        replace(tr, system=None).gear_quantities()
    assert gear_quantities(ks, replace(tr, system=None)).meshes.keys() == {"mesh"}
    mathieu = gearsym.load_scene(ROOT / "scenes" / "mathieu.toml").compile()
    with pytest.raises(ParameterError, match="has no mesh elements"):
        mathieu.simulate(periods=4).gear_quantities()


# ------------------------------------------------------------------ command line
def _json_of(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    assert code == 0, out.err
    return json.loads(out.out)


def test_cli_simulate_and_orbit_report_the_gear_quantities(ks, capsys):
    d = _json_of(capsys, "simulate", str(KS), "--set", "Omega=0.9", "--periods", "40", "--json",
                 "--gear-quantities", "--quantity", "dynamic_factor,contact_loss_ratio[mesh]")
    tr = ks.simulate(periods=40, params={"Omega": 0.9})
    hand = ks_by_hand(tr, tr.t[-1] - 20 * tr.period, tr.t[-1])
    g = d["gear_quantities"]["meshes"]["mesh"]
    assert g["dynamic_factor"] == pytest.approx(hand["dynamic_factor"], rel=1e-9)
    assert g["impact_count"] == hand["impact_count"] and len(g["impact_times"]) == hand["impact_count"]
    assert d["quantities"] == {"dynamic_factor": {"mesh": pytest.approx(hand["dynamic_factor"], rel=1e-9)},
                               "contact_loss_ratio[mesh]": {"mesh": pytest.approx(hand["contact_loss_ratio"],
                                                                                  abs=1e-12)}}
    d = _json_of(capsys, "orbit", str(KS), "--set", "Omega=0.9", "--json")
    assert d["gear_quantities"]["meshes"]["mesh"]["impact_count"] == 1
    assert main(["orbit", str(KS), "--set", "Omega=0.9", "--quantity", "dte_rms"]) == 0
    assert "dte_rms: mesh" in capsys.readouterr().out
    assert main(["simulate", str(KS), "--periods", "4", "--quantity", "bogus"]) == 2
    assert "--quantity: unknown gear quantity 'bogus'" in capsys.readouterr().err


def test_cli_continue_and_map_take_a_gear_quantity(ks, capsys, tmp_path):
    d = _json_of(capsys, "continue", str(KS), "--param", "Omega", "--from", "0.6", "--to", "0.62", "--json",
                 "--no-progress", "--quantity", "dynamic_factor")
    assert d["quantity"] == "dynamic_factor"
    pt = d["points"][0]
    assert pt["quantity_value"] == pt["gear_quantities"]["mesh"]["dynamic_factor"] > 1
    d = _json_of(capsys, "map", str(KS), "--x", "Omega", "0.6", "0.7", "2", "--y", "Fa", "0.05", "0.05", "1",
                 "--quantity", "contact_loss_ratio", "--workers", "1", "--out", str(tmp_path), "--json")
    assert d["quantity"] == "contact_loss_ratio" and d["min"] == d["max"] == 0.0
    import xarray as xr

    with xr.open_dataset(tmp_path / "map.nc") as ds:
        assert ds["contact_loss_ratio"].shape == (1, 2)
