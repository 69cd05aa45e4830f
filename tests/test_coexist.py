"""Maps that show every coexisting stable response, and never an unstable orbit as one (issue 28 item 2).

Before: a map point kept one orbit, the one its row sweep followed: coexisting responses (the jump
phenomenon of a softening mesh) were hidden, and a non-periodic response was not classified.  Now
the coexistence search (:mod:`gearsym.analysis.sweeps._coexist`) continues every attractor along
the rows and columns both ways and lands from starting states; every stable orbit found is listed
along the ``attractor`` dimension (verified, stable, deduplicated, with its rattle state, period
and amplitude), ``n_stable`` counts them, and a non-periodic attractor is classified by its largest
Lyapunov exponent and its Poincare section, never as a periodic orbit.

References, all independent of gearsym: the geared rotor's equations written here by hand and
integrated with scipy from two initial states, each landing on one of the two coexisting orbits,
then our own shooting (``scipy.optimize.fsolve`` on one period); the benchmark oscillator's
event-located scipy reference (``tests/reference.py``) the same way; the exponent of a stable
orbit of the benchmark oscillator, whose multipliers are a complex pair, is ``-zeta`` (they share
the determinant ``exp(-2 zeta T)``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks as ks_reference
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import gearsym
from gearsym.analysis.sweeps import ATTRACTOR_KINDS, closed_curve, run_tasks, stability_map
from gearsym.cli import main

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"
MEISSNER = ROOT / "scenes" / "meissner.toml"
ROTOR = ROOT / "tests" / "data" / "rotor_transverse_torsional_scene.toml"


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


# ------------------------------------------------------------------ the geared rotor, by hand
#: The rotor scene's parameters in SI (b_m = 50 um, e_a = 2.5 um).
ROTOR_P = {"J1": 2e-3, "J2": 4e-3, "m1": 1.5, "m2": 2.5, "rb1": 0.04, "rb2": 0.05, "k_m": 3e8, "k_a": 6e7,
           "c_m": 1451.0, "b": 50e-6, "e": 2.5e-6, "k_b1": 4e8, "k_b2": 6e8, "c_b1": 800.0, "c_b2": 900.0,
           "T1": 20.0, "T2": 25.0}
ROTOR_SCALE = np.array([5e-5] * 3 + [0.05] * 3)


def rotor_rhs(t: float, x: np.ndarray, w: float) -> list[float]:
    """The reduced transverse-torsional pair: p = rb1 th1 - rb2 th2, bearing translations y1, y2;
    mesh force k(t) f(delta) + c_m delta' with the backlash dead zone f."""
    P = ROTOR_P
    p, y1, y2, pv, u1, u2 = x
    d = p + y1 - y2 - P["e"] * math.cos(w * t)
    f = d - P["b"] if d > P["b"] else (d + P["b"] if d < -P["b"] else 0.0)
    F = (P["k_m"] + P["k_a"] * math.cos(w * t)) * f + P["c_m"] * (pv + u1 - u2 + P["e"] * w * math.sin(w * t))
    a = P["rb1"] ** 2 / P["J1"] + P["rb2"] ** 2 / P["J2"]
    return [pv, u1, u2, P["rb1"] * P["T1"] / P["J1"] + P["rb2"] * P["T2"] / P["J2"] - a * F,
            (-P["c_b1"] * u1 - P["k_b1"] * y1 - F) / P["m1"], (-P["c_b2"] * u2 - P["k_b2"] * y2 + F) / P["m2"]]


def rotor_flow(x: np.ndarray, w: float, periods: int) -> np.ndarray:
    """The states at the ends of ``periods`` forcing periods (scipy DOP853)."""
    T = 2 * math.pi / w
    sol = solve_ivp(rotor_rhs, (0.0, periods * T), x, args=(w,), method="DOP853", rtol=1e-12,
                    atol=list(1e-12 * ROTOR_SCALE), t_eval=T * np.arange(1, periods + 1))
    return sol.y.T


def rotor_orbit_from(x0: list[float], w: float) -> np.ndarray:
    """Where 150 periods from ``x0`` land, polished by our own shooting."""
    x = rotor_flow(np.asarray(x0, float), w, 150)[-1]
    z = fsolve(lambda z: (rotor_flow(z * ROTOR_SCALE, w, 1)[-1] - z * ROTOR_SCALE) / ROTOR_SCALE,
               x / ROTOR_SCALE, xtol=1e-13)
    return z * ROTOR_SCALE


@pytest.fixture(scope="module")
def rotor_map():
    return stability_map(gearsym.load_scene(ROTOR), ("omega", 21500, 22500, 3), ("T1", 20, 25, 2), workers=1)


def _no_unstable_response(ds) -> None:
    """Every listed periodic attractor and every 2-D response is a stable orbit."""
    kinds = ds["attractor_kind"].values
    per = kinds == 0
    assert np.all(ds["attractor_max_multiplier"].values[per] < 1 + 1e-6)
    assert np.all(np.isin(ds["attractor_stability"].values[per], (0, 1)))
    assert np.all(np.isnan(ds["attractor_max_multiplier"].values[~per]))  # nothing else shows a multiplier
    assert np.all(ds["attractor_rattle_state"].values[~per] == -1)
    resp = ds["response"].values == 1
    assert np.all(ds["max_multiplier"].values[resp] < 1 + 1e-6)


def test_geared_rotor_map_shows_both_coexisting_orbits(rotor_map):
    """Inside the fold of the rotor's frequency response (omega = 22 500 rad/s, T1 = 20 N m) the map lists
    two stable responses, one in permanent contact and one losing contact, each equal to the orbit our
    own scipy integration lands on from a different initial state."""
    ds = rotor_map
    pt = ds.sel(omega=22500.0, T1=20.0)
    assert int(pt["n_stable"]) == 2
    per = pt["attractor_kind"].values == 0
    assert sorted(pt["attractor_rattle_state"].values[per].tolist()) == [0, 1]
    assert pt["attractor_periods"].values[per].tolist() == [1, 1]
    x_map = {int(r): x for r, x in zip(pt["attractor_rattle_state"].values[per], pt["attractor_x0"].values[per],
                                       strict=True)}
    ptp = dict(zip(pt["attractor_rattle_state"].values[per].tolist(), pt["attractor_peak_to_peak"].values[per],
                   strict=True))
    # p = 55 um at rest (just in contact) stays in contact; every state at rest starts inside the backlash
    for x0, rattle in (([55e-6, 0, 0, 0, 0, 0], 0), ([0.0] * 6, 1)):
        x = rotor_orbit_from(x0, 22500.0)
        assert np.max(np.abs(x - x_map[rattle]) / ROTOR_SCALE) < 1e-8
        T = 2 * math.pi / 22500.0
        dense = solve_ivp(rotor_rhs, (0.0, T), x, args=(22500.0,), method="DOP853", rtol=1e-12,
                          atol=list(1e-12 * ROTOR_SCALE), t_eval=np.linspace(0.0, T, 4001)).y[0]
        assert ptp[rattle] == pytest.approx(np.ptp(dense), rel=1e-5)


def test_geared_rotor_map_shows_no_unstable_orbit(rotor_map):
    _no_unstable_response(rotor_map)
    assert rotor_map.attrs["n_coexisting"] >= 1 and rotor_map.attrs["coexist_search"] == "rows,columns,starts"
    # the per-mesh layers (one mesh here) agree with the worst-mesh rattle state
    mr = rotor_map["attractor_mesh_rattle_state"].sel(mesh="mesh").values
    assert np.array_equal(mr, rotor_map["attractor_rattle_state"].values)


# ------------------------------------------------------------------ the benchmark oscillator
def ks_orbit_from(x0: list[float], params: dict[str, float], periods: int = 200) -> np.ndarray:
    """Where ``periods`` forcing periods of the scipy reference from ``x0`` land, polished by our own shooting."""
    ref = ks_reference()
    T = 2 * math.pi / params["Omega"]
    y, *_ = ref.reference_solution(params, x0, [0.0, periods * T], rtol=1e-11, atol=1e-13)

    def period_map(x: np.ndarray) -> np.ndarray:
        return ref.reference_solution(params, x, [0.0, T], rtol=1e-12, atol=1e-14)[0][-1]

    return fsolve(lambda x: period_map(x) - x, y[-1], xtol=1e-13)


def test_benchmark_coexistence_region_lists_both_stable_orbits(ks):
    ds = stability_map(ks, ("Omega", 0.86, 0.88, 3), ("Fa", 0.05, 0.06, 2), quantity="rattle_state",
                       method="shooting", workers=1)
    _no_unstable_response(ds)
    pt = ds.sel(Omega=0.87, Fa=0.05)
    assert int(pt["n_stable"]) == 2
    per = pt["attractor_kind"].values == 0
    rattle = pt["attractor_rattle_state"].values[per].tolist()
    assert sorted(rattle) == [0, 1]
    x_map = dict(zip(rattle, pt["attractor_x0"].values[per], strict=True))
    for x0, r in (([1.1, 0.0], 0), ([0.0, 0.0], 1)):  # the static state stays in contact; the rest state rattles
        x = ks_orbit_from(x0, {"Omega": 0.87, "Fa": 0.05})
        assert np.max(np.abs(x - x_map[r])) < 1e-7
    # the exponent of a stable orbit with a complex pair of multipliers is -zeta
    lam = pt["attractor_lyapunov"].values[per]
    assert np.allclose(lam, -0.05, atol=1e-8)


def test_chaotic_regime_is_classified_never_shown_as_an_orbit(ks):
    """Omega 0.8, Fa 0.6: the attractor the scene's initial state lands on is chaotic (positive largest
    exponent beyond its error) and is listed as such, with no multiplier, rattle state or period; any
    periodic attractor listed beside it is a stable orbit (checked with the scipy reference)."""
    ds = stability_map(ks, ("Omega", 0.8, 0.8, 1), ("Fa", 0.6, 0.6, 1), quantity="lyapunov", method="shooting",
                       workers=1)
    _no_unstable_response(ds)
    pt = ds.isel(Omega=0, Fa=0)
    kinds = pt["attractor_kind"].values
    assert 2 in kinds.tolist()
    q = int(np.nonzero(kinds == 2)[0][0])
    lam, err = float(pt["attractor_lyapunov"].values[q]), float(pt["attractor_lyapunov_error"].values[q])
    assert lam > 2 * err and lam * 2 * math.pi / 0.8 > 0.1
    assert int(pt["attractor_periods"].values[q]) == 0 and int(pt["attractor_rattle_state"].values[q]) == -1
    assert math.isnan(float(pt["attractor_max_multiplier"].values[q]))
    assert int(pt["response_kind"]) == 2 and float(pt["lyapunov"]) == pytest.approx(lam)
    # the scipy reference from the scene's initial state does not settle on a cycle of up to 8 periods
    T = 2 * math.pi / 0.8
    y, *_ = ks_reference().reference_solution({"Omega": 0.8, "Fa": 0.6}, [1.1, 0.0], T * np.arange(401), rtol=1e-10,
                                              atol=1e-12)
    P = y[-100:]
    assert min(np.max(np.abs(P[k:] - P[:-k])) for k in range(1, 9)) > 1e-2
    for q in np.nonzero(kinds == 0)[0]:  # a periodic attractor beside it: a stable orbit of the reference
        k = int(pt["attractor_periods"].values[q])
        x0 = pt["attractor_x0"].values[q]
        y, *_ = ks_reference().reference_solution({"Omega": 0.8, "Fa": 0.6}, x0 + [1e-4, 0.0], [0.0, 120 * k * T],
                                                  rtol=1e-11, atol=1e-13)
        assert np.max(np.abs(y[-1] - x0)) < 1e-6


def test_lyapunov_quantity_without_the_search(ks):
    one = stability_map(ks, ("Omega", 0.87, 0.87, 1), ("Fa", 0.05, 0.05, 1), quantity="lyapunov",
                        method="shooting", workers=1, search="none")
    assert "attractor_kind" not in one and one.attrs["coexist_search"] == "none"
    assert float(one["lyapunov"].values[0, 0]) == pytest.approx(-0.05, abs=1e-8)
    assert int(one["response_kind"].values[0, 0]) == 0
    chaos = stability_map(ks, ("Omega", 0.8, 0.8, 1), ("Fa", 0.6, 0.6, 1), quantity="lyapunov", method="shooting",
                          workers=1, search="none")
    assert int(chaos["response"].values[0, 0]) == 0  # no stable periodic response: never an orbit's values
    assert int(chaos["response_kind"].values[0, 0]) == 2 and float(chaos["lyapunov"].values[0, 0]) > 0


def test_exact_path_lyapunov_is_log_multiplier_over_period():
    ds = stability_map(gearsym.load_scene(MEISSNER), ("T", 1.0, 9.0, 5), ("a", 0.05, 0.75, 3), quantity="lyapunov",
                       method="exact")
    T = ds["T"].values[None, :]
    assert np.allclose(ds["lyapunov"].values, np.log(ds["max_multiplier"].values) / T, rtol=1e-12, atol=0)


def test_search_defaults_and_choices(ks):
    from gearsym.analysis.sweeps._coexist import COEXIST_DEFAULT_POINTS, resolve_search

    assert resolve_search("auto", COEXIST_DEFAULT_POINTS, False).search == ("rows", "columns", "starts")
    assert resolve_search("auto", COEXIST_DEFAULT_POINTS + 1, False) is None
    assert resolve_search("auto", 4, True) is None  # a linear model has one orbit
    assert resolve_search("starts,rows", 10**6, False).search == ("rows", "starts")
    assert resolve_search("none", 4, False) is None
    with pytest.raises(gearsym.errors.ParameterError, match="search: unknown 'diagonal'"):
        stability_map(ks, ("Omega", 0.86, 0.88, 2), ("Fa", 0.05, 0.06, 1), method="shooting", workers=1,
                      search="rows,diagonal")


# ------------------------------------------------------------------ the closed-curve test
def test_closed_curve_tells_a_curve_from_a_cloud():
    n = np.arange(300)
    theta = 2 * math.pi * n * (math.sqrt(5) - 1) / 2  # an irrational rotation: a quasi-periodic section
    curve = np.c_[np.cos(theta) * (1 + 0.3 * np.cos(3 * theta)), np.sin(theta), 0.1 * np.sin(2 * theta)]
    assert closed_curve(curve)
    assert closed_curve(np.c_[np.cos(theta[:100]), np.sin(theta[:100])])  # fewer, unevenly spaced points
    rng = np.random.default_rng(0)
    assert not closed_curve(rng.uniform(size=(300, 2)))  # a cloud
    x = np.zeros((300, 2))
    x[0] = 0.1, 0.1
    for i in range(1, 300):  # the Henon map's chaotic attractor (layers of a folded curve)
        x[i] = 1 - 1.4 * x[i - 1, 0] ** 2 + x[i - 1, 1], 0.3 * x[i - 1, 0]
    assert not closed_curve(x[50:])
    assert not closed_curve(np.tile(curve[:5], (40, 1)))  # five points: an orbit of five periods


# ------------------------------------------------------------------ progress
def _count_task(shared, task):  # module level: picklable for the worker processes
    from gearsym.analysis.sweeps import report

    for _ in range(task):
        report(1)
    return shared * task


@pytest.mark.parametrize("workers", [1, 2])
def test_task_progress_reaches_the_parent(workers):
    got = []
    res, runner = run_tasks(_count_task, 10, [3, 4, 5], workers=workers, progress=got.append, weights=[3, 4, 5])
    assert res == [30, 40, 50] and sum(got) == 12
    assert len(got) == 12  # one report per unit, as they happen (not one per task)


def test_task_progress_on_dask():
    distributed = pytest.importorskip("distributed")
    got = []
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        res, runner = run_tasks(_count_task, 2, [1, 2], dask=client, progress=got.append, weights=[1, 2])
    assert res == [2, 4] and runner == "dask" and sum(got) == 3


def test_map_progress_bar(ks, capsys):
    pytest.importorskip("tqdm")
    stability_map(ks, ("Omega", 0.86, 0.88, 2), ("Fa", 0.05, 0.05, 1), method="shooting", workers=1,
                  search="none", progress=True)
    assert "map Omega x Fa" in capsys.readouterr().err


# ------------------------------------------------------------------ the command line
def test_cli_map_lists_the_coexisting_responses(tmp_path, capsys):
    rc = main(["map", str(KS), "--x", "Omega", "0.86", "0.88", "3", "--y", "Fa", "0.05", "0.06", "2", "--quantity",
               "rattle_state", "--method", "shooting", "--workers", "1", "--json", "--out", str(tmp_path / "m")])
    assert rc == 0
    out = capsys.readouterr()
    assert "%|" not in out.err  # no progress bar when stderr is not a terminal
    info = json.loads(out.out)
    assert info["search"] == "rows,columns,starts" and info["n_coexisting"] >= 1
    pt = next(p for p in info["coexisting"] if p["Omega"] == pytest.approx(0.87) and p["Fa"] == pytest.approx(0.05))
    assert sorted(pt["rattle_states"]) == [0, 1] and max(pt["max_multipliers"]) < 1
    import xarray as xr

    with xr.open_dataset(tmp_path / "m" / "map.nc") as ds:
        assert int(ds["n_stable"].sel(Omega=0.87, Fa=0.05)) == 2
    assert (tmp_path / "m" / "map.png").stat().st_size > 0


def test_cli_map_search_choices(tmp_path, capsys):
    assert main(["map", str(KS), "--x", "Omega", "0.86", "0.88", "2", "--y", "Fa", "0.05", "0.06", "1", "--search",
                 "rows,bogus", "--out", str(tmp_path / "m")]) == 2
    assert "--search: 'bogus' is not a search" in capsys.readouterr().err
    assert main(["map", str(KS), "--x", "Omega", "0.86", "0.88", "2", "--y", "Fa", "0.05", "0.06", "1", "--method",
                 "shooting", "--workers", "1", "--no-coexist", "--json", "--out", str(tmp_path / "m")]) == 0
    assert json.loads(capsys.readouterr().out)["search"] == "none"


def test_kinds_are_documented():
    assert set(ATTRACTOR_KINDS) == {0, 1, 2, 3} and "chaotic" in ATTRACTOR_KINDS[2] and "quasi-periodic" in ATTRACTOR_KINDS[1]
