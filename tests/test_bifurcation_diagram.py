"""Brute-force bifurcation diagrams: a library function and ``gearsym sweep`` (issue 28 items 4 and 5).

Before: only ``examples/period_doubling.py`` had a brute-force sweep (a loop of ``simulate``
calls, forward only, no Lyapunov exponent).  Now :func:`gearsym.analysis.sweeps.bifurcation_diagram`
sweeps one parameter forward and backward, keeps the Poincare points after a transient, the
period of the section and the largest Lyapunov exponent per value, on two processes (or Dask),
and ``gearsym sweep`` writes it as netCDF, JSON and a figure.

References: the event-located scipy reference of the benchmark oscillator (``tests/reference.py``)
from the same start over the same transient; the exponent of a stable orbit with a complex pair of
multipliers is ``-zeta`` (the estimate of one exponent over a few blocks is within its stated error).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _ks_loader import ks as ks_reference

import gearsym
from gearsym.analysis.sweeps import bifurcation_diagram
from gearsym.cli import main
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parent.parent
KS = ROOT / "scenes" / "kahraman_singh.toml"


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(KS).compile()


@pytest.fixture(scope="module")
def diagram(ks):
    # Fa = 0.4: period one at Omega 0.55, period two at 0.64 (past the period doubling at 0.60)
    return bifurcation_diagram(ks, "Omega", 0.55, 0.64, 2, params={"Fa": 0.4}, transient=150, samples=20,
                               lyapunov_periods=64, workers=1, rtol=1e-10, atol=1e-12)


def test_periods_and_exponents(diagram):
    ds = diagram
    assert ds["direction"].values.tolist() == ["forward", "backward"]
    assert ds["period"].values.tolist() == [[1, 2], [1, 2]]
    assert np.all(ds["kind"].values == 0)
    # a complex pair of multipliers: -zeta, within the error the estimate reports (one exponent over 64 periods)
    dev = np.abs(ds["lyapunov"].values[:, 0] + 0.05)
    assert np.all(dev <= ds["lyapunov_error"].values[:, 0]) and np.all(dev < 5e-4)
    assert ds.attrs["n_failed"] == 0 and ds.attrs["values_per_second"] > 0


def test_poincare_points_match_the_reference(diagram):
    """At Omega 0.55 the forward sweep starts from the scene's initial state: the scipy reference from the
    same state over the same periods gives the same section points (a stable orbit: on it to 1e-8)."""
    T = 2 * math.pi / 0.55
    y, *_ = ks_reference().reference_solution({"Omega": 0.55, "Fa": 0.4}, [1.1, 0.0], T * np.arange(150, 171),
                                              rtol=1e-11, atol=1e-13)
    got = diagram["poincare"].sel(direction="forward", Omega=0.55).values
    assert np.max(np.abs(got - y[1:])) < 1e-8
    # the backward sweep arrives from the period-two response at 0.64 and lands on the same orbit
    back = diagram["poincare"].sel(direction="backward", Omega=0.55).values
    assert np.max(np.abs(back - y[-1])) < 1e-8
    # period two at 0.64: the points alternate between two distinct states
    P = diagram["poincare"].sel(direction="forward", Omega=0.64).values
    assert np.max(np.abs(P[2:] - P[:-2])) < 1e-6 < np.max(np.abs(P[1:] - P[:-1]))


def test_bad_options_are_named(ks):
    with pytest.raises(ParameterError, match="samples=5"):
        bifurcation_diagram(ks, "Omega", 0.55, 0.64, 2, samples=5)
    with pytest.raises(ParameterError, match="'nope' is not a run-time parameter"):
        bifurcation_diagram(ks, "nope", 0.55, 0.64, 2)
    with pytest.raises(ParameterError, match="directions"):
        bifurcation_diagram(ks, "Omega", 0.55, 0.64, 2, directions=("sideways",))


def test_cli_sweep(tmp_path, capsys):
    out = tmp_path / "s"
    rc = main(["sweep", str(KS), "--set", "Fa=0.4", "--param", "Omega", "--from", "0.55", "--to", "0.64", "--n", "2",
               "--transient", "100", "--samples", "20", "--lyapunov-periods", "32", "--workers", "1", "--json",
               "--out", str(out)])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["values"] == pytest.approx([0.55, 0.64])
    assert info["forward"]["period"] == [1, 2] and info["backward"]["period"] == [1, 2]
    assert abs(info["forward"]["lyapunov"][0] + 0.05) <= info["forward"]["lyapunov_error"][0]
    assert {Path(f).name for f in info["files"]} == {"sweep.nc", "sweep.json", "sweep.png"}
    assert json.loads((out / "sweep.json").read_text())["forward"]["period"] == [1, 2]


def test_cli_sweep_bad_input(tmp_path, capsys):
    base = ["sweep", str(KS), "--param", "Omega", "--from", "0.55", "--to", "0.64", "--out", str(tmp_path / "s")]
    assert main([*base, "--n", "0"]) == 2
    assert "--n" in capsys.readouterr().err
    assert main([*base, "--n", "2", "--samples", "3"]) == 2
    assert "--samples" in capsys.readouterr().err
    assert main([*base[:3], "nope", *base[4:], "--n", "2"]) == 2
    assert "'nope' is not a run-time parameter" in capsys.readouterr().err
