"""Basins of attraction (issue 28 items 3 and 5): ``gearsym.basins`` and ``gearsym basins``.

The benchmark oscillator (Kahraman & Singh) at ``Omega = 0.87`` has two coexisting stable
period-1 orbits (one-parameter continuation: a fold at 0.8356, grazing at 0.8922): one in
permanent drive-side contact (rattle state 0) and one with contact loss (rattle state 1).
The reference here is written by hand with scipy: the piecewise-linear equation of motion,
``solve_ivp`` (DOP853) with terminal events at the backlash surfaces ``x = +-b`` and a restart in
the new contact mode, integrated until the Poincare point stays near one of the two orbits
(found by the same integration from two starts).  No gearsym code is used for the reference.
"""

from __future__ import annotations

import json
import math
import operator
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import gearsym
from gearsym.analysis.sweeps import FAILED, UNBOUNDED, UNRESOLVED, BasinOptions, basins, run_tasks
from gearsym.engine.batch import run_batch
from gearsym.engine.errors import EngineInputError
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[1]
KS = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.87}
T_KS = 2 * math.pi / KS["Omega"]
#: The box of the reference test: both attractors, bands of the two basins wide enough for a 24 x 24
#: grid (on the whole box -2 <= x <= 4, -2 <= v <= 2 of the benchmark's 400 x 400 map, filaments
#: thinner than such a grid's cells pass through blocks of 3 x 3 equal cells)
GRID_X = ("x", 0.5, 2.5, 24)
GRID_V = ("v", -0.5, 0.5, 24)


# ------------------------------------------------------------------ the hand-written reference
def _rhs(mode: int, p: dict[str, float]):
    """``(x', v')`` in contact mode +1 (drive side, x > b), 0 (gap), -1 (back side, x < -b)."""
    z2, Fm, A, eps, b, Om = 2 * p["zeta"], p["Fm"], p["Fa"] * p["Omega"] ** 2, p["eps"], p["b"], p["Omega"]
    shift = {1: b, -1: -b}.get(mode)

    def f(t, y):
        c = math.cos(Om * t)
        spring = 0.0 if shift is None else (1.0 + eps * c) * (y[0] - shift)
        return [y[1], Fm + A * c - z2 * y[1] - spring]
    return f


def _events(mode: int, b: float) -> list:
    """Terminal events leaving ``mode`` (only the crossing away from it is armed), with the next mode."""
    def surface(shift: float, direction: int, nxt: int):
        def g(t, y):
            return y[0] - shift
        g.terminal, g.direction = True, direction
        return g, nxt
    return {1: [surface(b, -1, 0)], -1: [surface(-b, 1, 0)], 0: [surface(b, 1, 1), surface(-b, -1, -1)]}[mode]


def reference_poincare(x0, p: dict[str, float], n_periods: int, stop=None, span: int = 5, rtol: float = 1e-9):
    """Poincare points ``x(n T)``, n = 1.., of the event-located scipy solution from ``x0`` at t = 0;
    ``stop(points)`` ends the integration early (checked every ``span`` periods or event)."""
    b, T = p["b"], 2 * math.pi / p["Omega"]
    rhs = {m: _rhs(m, p) for m in (-1, 0, 1)}
    evs = {m: _events(m, b) for m in (-1, 0, 1)}
    t, y = 0.0, np.array(x0, float)
    mode = 1 if y[0] > b else (-1 if y[0] < -b else 0)
    points: list[np.ndarray] = []
    while len(points) < n_periods:
        grid = T * np.arange(len(points) + 1, min(len(points) + span, n_periods) + 1)
        sol = solve_ivp(rhs[mode], (t, grid[-1]), y, method="DOP853", rtol=rtol, atol=rtol * 1e-2,
                        events=[e for e, _ in evs[mode]], t_eval=grid, max_step=T / 4)
        assert sol.status >= 0, sol.message
        points += list(np.asarray(sol.y, float).reshape(2, -1).T)
        if stop is not None and stop(points):
            break
        if sol.status == 1:
            j = next(i for i, te in enumerate(sol.t_events) if len(te))
            t, y, mode = sol.t_events[j][0], sol.y_events[j][0], evs[mode][j][1]
        else:
            t, y = sol.t[-1], sol.y[:, -1]
    return np.array(points)


def reference_label(x0, refs: list[np.ndarray], p: dict[str, float], tol: float = 1e-2, need: int = 2,
                    max_periods: int = 400) -> int:
    """The reference orbit whose Poincare point the trajectory from ``x0`` stays within ``tol`` of for
    ``need`` consecutive periods (-1: none within ``max_periods``); integrated at ``rtol = 1e-6``.

    ``tol`` is a seventh of the distance from the no-impact orbit's Poincare point to the saddle
    orbit's between the two (about (1.199, 0.092) at Omega = 0.87, from ``gearsym continue``): a
    trajectory that close to a stable focus for two periods stays in its basin."""
    def near(P):
        d = [float(np.max(np.abs(P - r))) for r in refs]
        return int(np.argmin(d)) if min(d) < tol else -1

    def settled(points):
        labs = [near(P) for P in points[-need:]]
        return len(points) >= need and labs[0] >= 0 and labs.count(labs[0]) == need

    pts = reference_poincare(x0, p, max_periods, stop=settled, rtol=1e-6)
    return near(pts[-1]) if settled(list(pts)) else -1


@pytest.fixture(scope="module")
def reference_orbits() -> list[np.ndarray]:
    """The two stable orbits' Poincare points from 200 periods of the reference from two starts."""
    refs = [reference_poincare(x0, KS, 200)[-1] for x0 in ([3.0, 1.0], [1.15, 0.0])]
    assert np.max(np.abs(refs[0] - refs[1])) > 0.1  # two different attractors
    for r in refs:  # settled: one period maps the point onto itself
        assert np.max(np.abs(reference_poincare(r, KS, 1)[-1] - r)) < 1e-7
    return refs


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def system():
    return gearsym.load_scene("kahraman_singh", Omega=KS["Omega"]).compile()


@pytest.fixture(scope="module")
def result(system):
    return basins(system, GRID_X, GRID_V)


# ------------------------------------------------------------------ the batched C entry
def test_batch_equals_one_run_per_state(system):
    """gs_simulate_batch gives each state exactly what Engine.run gives it alone, also when the
    batch continues from the surface sides of a previous one."""
    p, eng = system.param_vector(), system.engine
    X = np.array([[3.0, 1.0], [-1.5, 0.3], [1.2, 0.0], [0.5, -1.8]])
    grid = np.arange(1, 4) * T_KS
    kw = {"method": "adams", "rtol": 1e-9, "atol": 1e-11, "max_step": T_KS / 8}
    b1 = run_batch(eng, X, p, 0.0, 3 * T_KS, grid, **kw)
    b2 = run_batch(eng, b1.x_final, p, 3 * T_KS, 6 * T_KS, grid + 3 * T_KS, sigma0s=b1.sigma_final, **kw)
    assert np.all(b1.status == 0) and np.all(b2.status == 0) and b1.message == ""
    for i, x in enumerate(X):
        r1 = eng.run(x, p, 0.0, 3 * T_KS, grid, **kw)
        r2 = eng.run(r1.x_final, p, 3 * T_KS, 6 * T_KS, grid + 3 * T_KS, sigma0=r1.sigma_final, **kw)
        np.testing.assert_allclose(b1.y[i], r1.y, rtol=0, atol=1e-13)
        np.testing.assert_allclose(b2.x_final[i], r2.x_final, rtol=0, atol=1e-13)
        np.testing.assert_array_equal(b1.sigma_final[i], r1.sigma_final)
        assert b1.n_events[i] == len(r1.events) and b1.n_steps[i] == r1.stats["n_steps"]


def test_batch_failed_state_does_not_stop_the_others(system):
    p, eng = system.param_vector(), system.engine
    X = np.array([[3.0, 1.0], [np.nan, 0.0], [1.2, 0.0]])
    b = run_batch(eng, X, p, 0.0, T_KS, [T_KS], max_step=T_KS / 8)
    assert b.status.tolist() == [0, -6, 0]  # GS_ERR_INPUT for the non-finite state only
    assert b.message.startswith("state 1:") and "not finite" in b.message
    r = eng.run(X[2], p, 0.0, T_KS, [T_KS], method="adams", rtol=1e-8, atol=1e-10, max_step=T_KS / 8)
    np.testing.assert_allclose(b.x_final[2], r.x_final, rtol=0, atol=1e-13)


def test_batch_refuses_wrong_shapes(system):
    p, eng = system.param_vector(), system.engine
    with pytest.raises(EngineInputError, match=r"x0s must have shape \(n, 2\)"):
        run_batch(eng, np.zeros((3, 3)), p, 0.0, 1.0)
    with pytest.raises(EngineInputError, match=r"sigma0s must have shape \(2, 2\)"):
        run_batch(eng, np.zeros((2, 2)), p, 0.0, 1.0, sigma0s=np.ones((2, 3)))
    with pytest.raises(EngineInputError, match="bad time span"):
        run_batch(eng, np.zeros((2, 2)), p, 1.0, 0.5)


# ------------------------------------------------------------------ the attractors
def test_attractors_are_the_two_coexisting_orbits(result, reference_orbits):
    """Exactly the two stable period-1 orbits, their Poincare points equal to the reference's, their
    rattle states from the reference trajectory, max|mu| = exp(-zeta T) (a complex pair: |mu|^2 =
    det M = exp(-2 zeta T), the trace of the Jacobian being -2 zeta and the saltation the identity)."""
    atts = result.attractors
    assert len(atts) == 2 and all(a.kind == "periodic" and a.period == 1 for a in atts)
    for a in atts:
        d = [np.max(np.abs(a.x0 - r)) for r in reference_orbits]
        ref = reference_orbits[int(np.argmin(d))]
        np.testing.assert_allclose(a.x0, ref, rtol=0, atol=1e-6)
        # the reference's own rattle state: drive contact all along (x > b) or not, never back contact
        xs = _reference_path(ref)
        assert xs.min() > -KS["b"]
        assert a.rattle_state == (0 if xs.min() > KS["b"] else 1), (a, xs.min())
        assert a.max_multiplier == pytest.approx(math.exp(-KS["zeta"] * T_KS), abs=1e-7)
        assert a.stability == "asymptotically_stable"
        np.testing.assert_allclose(a.maximum[0], xs.max(), atol=2e-4)
        np.testing.assert_allclose(a.minimum[0], xs.min(), atol=2e-4)
    assert {a.rattle_state for a in atts} == {0, 1}


def _reference_path(x0, n: int = 2000) -> np.ndarray:
    """``x(t)`` over one period of the reference from ``x0`` (piecewise, event-located), densely sampled."""
    b, T = KS["b"], T_KS
    t, y = 0.0, np.array(x0, float)
    mode = 1 if y[0] > b else (-1 if y[0] < -b else 0)
    xs = []
    while t < T:
        evs = _events(mode, b)
        sol = solve_ivp(_rhs(mode, KS), (t, T), y, method="DOP853", rtol=1e-10, atol=1e-12,
                        events=[e for e, _ in evs], dense_output=True, max_step=T / 16)
        xs.append(sol.sol(np.linspace(t, sol.t[-1], n))[0])
        if sol.status != 1:
            break
        j = next(i for i, te in enumerate(sol.t_events) if len(te))
        t, y, mode = sol.t_events[j][0], sol.y_events[j][0], evs[j][1]
    return np.concatenate(xs)


def test_300_random_states_agree_with_the_reference(result, reference_orbits):
    """Done-when of issue 28 (basins): 300 random initial states in the grid's box, classified by
    the hand-written scipy integration, agree with the basin map except within one cell of a
    boundary (the nearest cell or one of its 8 neighbours has another label)."""
    lab = result.labels
    # reference orbit -> the map's attractor
    to_map = [int(np.argmin([np.max(np.abs(a.x0 - r)) for a in result.attractors])) for r in reference_orbits]
    assert sorted(to_map) == [0, 1]
    rng = np.random.default_rng(28)
    X = np.column_stack([rng.uniform(*GRID_X[1:3], 300), rng.uniform(*GRID_V[1:3], 300)])
    dx, dv = np.diff(result.x_values[:2])[0], np.diff(result.y_values[:2])[0]
    compared = agree = 0
    for x in X:
        j = int(np.clip(round((x[0] - result.x_values[0]) / dx), 0, lab.shape[1] - 1))
        i = int(np.clip(round((x[1] - result.y_values[0]) / dv), 0, lab.shape[0] - 1))
        block = lab[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2]
        if np.any(block != block.flat[0]):
            continue  # within one cell of a boundary
        k = reference_label(x, reference_orbits, KS)
        assert k >= 0, f"the reference did not settle from {x}"
        compared += 1
        agree += int(to_map[k] == lab[i, j])
        assert to_map[k] == lab[i, j], (x, k, lab[i, j])
    assert compared >= 100  # (128 of the 300 with this seed and grid)
    assert agree == compared


def test_every_cell_settles_early(result):
    """Early termination: no cell unresolved, failed or unbounded; most settle within 30 periods."""
    assert result.count(UNRESOLVED) == result.count(FAILED) == result.count(UNBOUNDED) == 0
    assert np.median(result.periods) <= 30
    st = result.stats
    assert st["periods_integrated"] >= result.periods.sum() and st["events"] > 0


# ------------------------------------------------------------------ non-periodic and unbounded
def test_chaotic_attractor_is_not_shown_as_a_periodic_orbit():
    """Omega 0.8, Fa 0.6: a chaotic attractor (largest exponent > 0) beside a stable period-1 orbit
    (double-sided impacts).  The chaotic one's Poincare section repeats with no period <= 12 (a
    check on its cloud in numpy), and every cell's label is the one a long run without early
    termination (600 periods) ends on."""
    s = gearsym.load_scene("kahraman_singh", Omega=0.8, Fa=0.6).compile()
    r = basins(s, ("x", -2, 4, 4), ("v", -2, 2, 4), seeds=4, lyapunov_periods=200, cloud=200)
    kinds = sorted(a.kind for a in r.attractors)
    assert kinds == ["chaotic", "periodic"]
    chaos = next(a for a in r.attractors if a.kind == "chaotic")
    orbit = next(a for a in r.attractors if a.kind == "periodic")
    assert chaos.period is None and math.isnan(chaos.max_multiplier)
    assert chaos.lyapunov > 3 * chaos.lyapunov_error > 0
    C = chaos.points
    span = np.ptp(C, axis=0)
    for k in range(1, 13):
        assert np.median(np.max(np.abs(C[k:] - C[:-k]) / span, axis=1)) > 0.01
    assert orbit.period == 1 and orbit.rattle_state == 2
    # long runs from every cell: on the periodic orbit at the end, or not (both happen)
    T = s.period()
    X = np.array([[x, v] for v in r.y_values for x in r.x_values])
    b = run_batch(s.engine, X, s.param_vector(), 0.0, 600 * T, np.arange(590, 601) * T, max_step=T / 8)
    on_orbit = np.max(np.abs(b.y - orbit.x0), axis=(1, 2)) < 1e-4
    assert np.array_equal(r.labels.ravel() == orbit.index, on_orbit)
    assert np.all(r.labels.ravel()[~on_orbit] == chaos.index)
    assert 0 < np.count_nonzero(on_orbit) < on_orbit.size


def test_unbounded_cells():
    """The Mathieu equation in its first instability tongue (a = 1.5, q = 1, |mu| = 2.77): every
    start except the equilibrium grows without bound."""
    s = gearsym.load_scene("mathieu", a=1.5).compile()
    r = basins(s, ("x", 0.5, 1.5, 3), ("v", 0.5, 1.5, 3), seeds=2, periods_max=100)
    assert r.attractors == ()
    assert np.all(r.labels == UNBOUNDED)
    assert np.all(r.periods < 20)


# ------------------------------------------------------------------ options, parallel runs, output
def test_bad_input_names_the_option(system):
    with pytest.raises(ParameterError, match="'w' is not a state"):
        basins(system, ("w", 0, 1, 4), GRID_V)
    with pytest.raises(ParameterError, match="x and y must be different states"):
        basins(system, GRID_V, GRID_V)
    with pytest.raises(ParameterError, match="need finite LO < HI"):
        basins(system, ("x", 1, 0, 4), GRID_V)
    with pytest.raises(ParameterError, match=r"phase must be in \[0, 1\)"):
        BasinOptions(phase=1.0)
    with pytest.raises(ParameterError, match="unknown option"):
        basins(system, GRID_X, GRID_V, periods=3)
    with pytest.raises(ParameterError, match="base must be 2 finite numbers"):
        basins(system, GRID_X, GRID_V, base=[1.0])


def test_phase_moves_the_section(system, result):
    """At phase 0.25 the attractors' Poincare points are the orbits' states a quarter period later."""
    r = basins(system, ("x", -2, 4, 6), ("v", -2, 2, 5), phase=0.25, seeds=9)
    assert len(r.attractors) == 2
    for a in r.attractors:
        shifted = [system.flow(b.x0, 0.0, 0.25 * T_KS, rtol=1e-10, atol=1e-12, monodromy=False).x_final
                   for b in result.attractors]
        assert min(np.max(np.abs(a.x0 - s)) for s in shifted) < 1e-6


def test_run_tasks_reports_each_result():
    """The progress hook of the process pool and of Dask: every task's (index, result), once."""
    seen: list[tuple[int, int]] = []
    out, runner = run_tasks(operator.add, 10, [1, 2, 3, 4], workers=2, on_result=lambda i, r: seen.append((i, r)))
    assert out == [11, 12, 13, 14] and runner == "processes(2)"
    assert sorted(seen) == [(0, 11), (1, 12), (2, 13), (3, 14)]
    seen.clear()
    distributed = pytest.importorskip("distributed")
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        out, runner = run_tasks(operator.add, 10, [1, 2, 3], dask=client, on_result=lambda i, r: seen.append((i, r)))
    assert out == [11, 12, 13] and runner == "dask"
    assert sorted(seen) == [(0, 11), (1, 12), (2, 13)]


def test_two_workers_give_the_same_map(system, result):
    r2 = basins(system, GRID_X, GRID_V, workers=2)
    assert r2.stats["runner"] == "processes(2)"
    np.testing.assert_array_equal(r2.labels, result.labels)
    np.testing.assert_array_equal(r2.periods, result.periods)


def test_save_writes_netcdf_json_and_figure(result, tmp_path):
    xr = pytest.importorskip("xarray")
    files = result.save(tmp_path)
    assert [f.name for f in files] == ["basins.nc", "basins.json", "basins.png"]
    ds = xr.open_dataset(files[0], engine="scipy")
    np.testing.assert_array_equal(ds["label"].values, result.labels)
    assert ds["label"].dims == ("v", "x")
    np.testing.assert_allclose(ds["poincare"].values[:, 0, :], [a.x0 for a in result.attractors])
    assert ds["attractor_period"].values.tolist() == [1, 1]
    assert sorted(ds["rattle_state"].values.tolist()) == [0, 1]
    np.testing.assert_allclose(ds["fraction"].values.sum(), 1.0)
    ds.close()
    info = json.loads(files[1].read_text())
    assert len(info["attractors"]) == 2 and info["n_failed"] == 0
    assert files[2].stat().st_size > 10_000


def _cli(capsys, *args: str) -> tuple[int, str, str]:
    """``gearsym basins ARGS`` in this process (the console script's entry point)."""
    from gearsym.cli import main

    rc = main(["basins", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli(tmp_path, capsys):
    rc, out, err = _cli(capsys, "kahraman_singh", "--set", "Omega=0.87", "--x", "x,-2,4,6", "--y", "v,-2,2,5",
                        "--workers", "1", "--seeds", "9", "--json", "--out", str(tmp_path / "o"))
    assert rc == 0, err
    info = json.loads(out)
    assert sorted(a["rattle_state"] for a in info["attractors"]) == [0, 1]
    assert sorted(Path(f).name for f in info["files"]) == ["basins.json", "basins.nc", "basins.png"]
    assert info["n_failed"] == info["n_unresolved"] == 0
    for args, msg in ((["--x", "w,0,1,4", "--y", "v,-2,2,5"], "--x: 'w' is not a state"),
                      (["--x", "x,0,1", "--y", "v,-2,2,5"], "--x expects STATE,LO,HI,N"),
                      (["--x", "x,0,1,1", "--y", "v,-2,2,5"], r"--x: N must be in \[2,"),
                      (["--x", "x,1,0,4", "--y", "v,-2,2,5"], "--x: need LO < HI"),
                      (["--x", "x,0,1,4", "--y", "x,-2,2,5"], "--x and --y must be different states"),
                      (["--x", "x,0,1,4", "--y", "v,-2,2,5", "--phase", "1.5"], r"--phase: phase must be in"),
                      (["--x", "x,0,1,4", "--y", "v,-2,2,5", "--periods-max", "0"], "--periods-max: periods_max"),
                      (["--x", "x,0,1,4", "--y", "v,-2,2,5", "--base", "1"], "--base: base must be 2 finite"),
                      (["--x", "x,0,1,4", "--y", "v,-2,2,5", "--workers", "0"], "--workers must be in")):
        rc, out, err = _cli(capsys, "kahraman_singh", *args)
        assert rc == 2, (args, err)
        assert out == "" and err.count("\n") == 1 and re.search(msg, err), err


def test_cli_exit_1_when_no_attractor_is_found(capsys, monkeypatch):
    """A run that found no attractor for cells that stayed bounded failed: exit 1 with the reason
    (here the identification is switched off, so nothing can settle)."""
    import gearsym.analysis.sweeps._basins as mod

    monkeypatch.setattr(mod, "identify", lambda *a, **k: None)
    rc, out, err = _cli(capsys, "kahraman_singh", "--set", "Omega=0.87", "--x", "x,0,1,2", "--y", "v,0,1,2",
                        "--seeds", "1", "--transient", "5", "--periods-max", "3", "--workers", "1")
    assert rc == 1 and out == ""
    assert "no attractor found: 4 cells did not settle within 3 forcing periods, 0 failed" in err
