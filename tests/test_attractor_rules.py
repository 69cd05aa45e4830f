"""One set of attractor rules for basins, maps and brute-force diagrams (issue 26: one implementation of
each rule; issue 28 items 2-4).

Before, the three sweeps that recognise attractors each had their own rules: the basins compared
the Poincare points over the second half of a landing and called a zero exponent quasi-periodic
without looking at the section; the maps and the diagram compared the last ``k`` points only and
called an exponent positive only beyond twice its error.  The same response then had different
periods and kinds depending on the entry point.

Here a stub system produces the *same* synthetic response through every entry point -- the
landing of a basin (``_attractors.identify``), a start of a map's coexistence search
(``PointSearch.start``) and one value of a brute-force diagram (``_bifurcation_diagram._value``)
-- with the Lyapunov exponent and the orbit solver replaced by stubs that return what the scenario
prescribes.  Every entry point must give the expected period and kind: the criteria written in
``gearsym.analysis.sweeps._attractor_id`` (chaotic: exponent positive beyond its error; quasi-periodic:
zero within its error and the Poincare points on one closed curve; otherwise not classified).
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from gearsym.analysis import sweeps
from gearsym.analysis.sweeps import DiagramOptions, SearchOptions
from gearsym.errors import ConvergenceError

T = 2 * math.pi
#: The same lengths everywhere: a basin's landing is 2 max_period + 8 = 64 periods, a map's block and a
#: diagram's samples 64 periods, each non-periodic section 64 points.
MAX_K = 28
N = 64
#: A harmonic motion within each period on top of the Poincare point (its extremes at the half period,
#: a sample of every entry point's grid): the range of each state is the same however densely sampled.
B = np.array([0.5, 0.5])


def _henon(n: int) -> np.ndarray:
    x, y, out = 0.1, 0.1, []
    for _ in range(n + 100):
        x, y = 1.0 - 1.4 * x * x + y, 0.3 * x
        out.append((x, y))
    return np.array(out[100:])


_RNG = np.random.default_rng(7)
_RNG_CLOUD = _RNG.uniform(-1.0, 1.0, size=(4000, 2))
#: Six far-apart clumps visited in no order: a section that is certainly not one curve.
_CLUMPS = np.array([[0, 0], [3, 0], [0, 3], [3, 3], [6, 0], [0, 6]], float)[_RNG.integers(0, 6, 4000)] \
    + _RNG.uniform(-0.05, 0.05, size=(4000, 2))
_HENON = _henon(4000)
_GOLDEN = (math.sqrt(5) - 1) / 2


@dataclass
class Scenario:
    """A response: its Poincare point after ``n`` periods, the period of its limit (0: none), its largest
    exponent and the expected (period, kind code)."""

    name: str
    point: Any
    limit_period: int
    lam: float
    err: float
    expected: tuple[int, int]
    limit: Any = None


SCENARIOS = [
    Scenario("period two", lambda n: np.array([1.0, 0.0]) if n % 2 == 0 else np.array([-1.0, 0.5]), 2,
             math.log(0.5) / (2 * T), 1e-9, (2, 0)),
    # converging at 0.9 per period: settled to 1e-3 of the range over the last period, not over the
    # second half of the landing -- the same "no period yet" everywhere
    Scenario("converging", lambda n: np.array([1.0, 2.0]) + 0.5 * 0.9 ** n * np.array([1.0, 0.0]), 1,
             -0.05, 1e-3, (0, 3), limit=lambda n: np.array([1.0, 2.0])),
    Scenario("quasi-periodic circle", lambda n: np.array([math.cos(2 * math.pi * _GOLDEN * n),
                                                          math.sin(2 * math.pi * _GOLDEN * n)]), 0,
             0.0, 1e-5, (0, 1)),
    Scenario("chaotic Henon", lambda n: _HENON[n], 0, 0.1, 0.01, (0, 2)),
    # a zero exponent but a section in clumps, not one closed curve: not quasi-periodic
    Scenario("zero exponent, not a curve", lambda n: _CLUMPS[n], 0, 0.0, 1e-4, (0, 3)),
    # positive beyond its error (not beyond twice it): chaotic
    Scenario("positive beyond its error", lambda n: _RNG_CLOUD[n], 0, 0.05, 0.03, (0, 2)),
]


def _response(point, t: np.ndarray) -> np.ndarray:
    """The state at times ``t``: the Poincare point of the period plus the harmonic motion ``B (1 - cos)``."""
    n = np.floor(np.asarray(t, float) / T + 1e-9).astype(int)
    P = np.array([point(int(k)) for k in n]).reshape(len(n), 2)
    return P + B[None, :] * (1.0 - np.cos(2 * math.pi * np.asarray(t, float) / T))[:, None]


class StubSystem:
    """What the three entry points ask of a compiled system, producing the scenario's response (from the
    start of every integration: a stationary response whatever the state given)."""

    def __init__(self, sc: Scenario) -> None:
        self.sc = sc
        self.generated = SimpleNamespace(nx=2, nsw=0, implicit=False, contact_surfaces=[], meshes=[], functions={},
                                         rigid_modes=[])
        self.engine = SimpleNamespace(run=self._engine_run)
        self.x0 = np.zeros(2)
        self.params: dict[str, float] = {}
        self.state_names = ["x", "v"]
        self.name = "stub"

    def require_period(self, params: Any = None, what: str = "") -> float:
        return T

    def period(self, params: Any = None) -> float:
        return T

    def param_vector(self, params: Any = None) -> np.ndarray:
        return np.zeros(1)

    def _run(self, t: np.ndarray, point=None) -> Any:
        y = _response(point or self.sc.point, t)
        return SimpleNamespace(t=t, y=y, x_final=y[-1].copy())

    def simulate(self, t_end: float | None = None, periods: float | None = None, x0: Any = None, rtol: Any = None,
                 atol: Any = None, n_out: int | None = None, params: Any = None, **kw: Any) -> Any:
        t0 = float(kw.get("t0", 0.0))
        t = np.asarray(kw["t_out"], float) if kw.get("t_out") is not None else np.linspace(t0, t_end, n_out)
        return self._run(t - t0)

    def _engine_run(self, x: Any, p: Any, t0: float, t1: float, grid: Any, **kw: Any) -> Any:
        return self._run(np.asarray(grid, float) - t0)


@dataclass
class StubOrbit:
    """A periodic orbit on the scenario's limit cycle through the state Newton starts from."""

    system: StubSystem
    periods: int
    x0: np.ndarray
    shift: int
    t0: float = 0.0
    stability: str = "asymptotically_stable"
    rattle_state: Any = None
    rattle_states: dict = field(default_factory=dict)
    iterations: int = 3
    residual: float = 1e-13
    info: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    method: str = "shooting"

    @property
    def period(self) -> float:
        return self.periods * T

    @property
    def multipliers(self) -> np.ndarray:
        return np.array([0.5 ** (self.periods / max(1, self.system.sc.limit_period)) + 0j])

    @property
    def max_multiplier(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    @property
    def multiplier_tolerances(self) -> np.ndarray:
        return np.array([1e-9])

    def trajectory(self, n_out: int | None = None, **kw: Any) -> Any:
        n = n_out or max(2048, 1024 * self.periods + 1)
        limit = self.system.sc.limit or self.system.sc.point
        return self.system._run(np.linspace(0.0, self.period, n), point=lambda k: limit(k + self.shift))

    def extrema(self, i: int) -> tuple[float, float]:
        y = self.trajectory().y[:, i]
        return float(y.min()), float(y.max())

    def meshes(self) -> dict:
        return {}


def _stub_orbit(system: StubSystem, periods: float = 1, x0: Any = None, **kw: Any) -> StubOrbit:
    sc = system.sc
    k = int(round(periods))
    if sc.limit_period == 0 or k % sc.limit_period:
        raise ConvergenceError(f"no orbit of {k} period(s) (stub)")
    limit = sc.limit or sc.point
    shift = int(np.argmin([np.max(np.abs(limit(j) - np.asarray(x0, float))) for j in range(sc.limit_period)]))
    return StubOrbit(system, k, limit(shift).copy(), shift)


def _stub_lyapunov(sc: Scenario):
    def fake(system: Any, params: Any = None, options: Any = None, **kw: Any) -> Any:
        return SimpleNamespace(exponents=np.array([sc.lam]), errors=np.array([sc.err]), converged=True)
    return fake


@pytest.fixture
def stubbed(monkeypatch, request):
    sc: Scenario = request.param
    for name in ("_attractor_id", "_attractors", "_map_attractors", "_bifurcation_diagram", "_lyapunov"):
        try:
            mod = importlib.import_module(f"gearsym.analysis.sweeps.{name}")
        except ImportError:
            continue
        if hasattr(mod, "lyapunov_exponents"):
            monkeypatch.setattr(mod, "lyapunov_exponents", _stub_lyapunov(sc))
        if hasattr(mod, "periodic_orbit"):
            monkeypatch.setattr(mod, "periodic_orbit", _stub_orbit)
    return sc, StubSystem(sc)


def _basin(system: StubSystem) -> tuple[int, int]:
    from gearsym.analysis.sweeps import _attractors

    ctx = _attractors.Context(system=system, params={}, p=np.zeros(1), t0=0.0, T=T, rtol=1e-9, atol=np.full(2, 1e-11),
                              method="bdf", max_period=MAX_K, radius=0.05, cloud=N, lyapunov_periods=float(N))
    a = _attractors.identify(ctx, np.zeros(2), None, 0, 0, [], 3)
    return (a.period or 0), list(sweeps.KINDS).index(a.kind)


def _map(system: StubSystem) -> tuple[int, int]:
    from gearsym.analysis.sweeps._map_attractors import PointSearch

    opts = SearchOptions(search=("starts",), land_periods=N, block=N, max_k=MAX_K, settle_tol=1e-3, section_points=N,
                         lyapunov_periods=N)
    a = PointSearch(system, {}, "shooting", {}, opts).start(np.zeros(2), 5)
    return a.periods, a.kind


def _diagram(system: StubSystem) -> tuple[int, int]:
    from gearsym.analysis.sweeps import _bifurcation_diagram

    opts = DiagramOptions(transient=0, samples=N, lyapunov_periods=N, max_k=MAX_K, settle_tol=1e-3)
    r = _bifurcation_diagram._value(system, {}, np.zeros(2), opts, {})
    return r["period"], r["kind"]


@pytest.mark.parametrize("stubbed", SCENARIOS, ids=[s.name for s in SCENARIOS], indirect=True)
def test_basins_maps_and_diagrams_agree(stubbed):
    """The same response gets the same period and kind through the three entry points, and it is the one
    the documented criteria give."""
    sc, system = stubbed
    got = {"basins": _basin(system), "map": _map(system), "diagram": _diagram(system)}
    assert got == dict.fromkeys(got, sc.expected), sc.name


def test_one_table_of_kinds():
    """The basins' kind names and the maps' / diagrams' codes are the same four kinds, in the same order."""
    assert list(sweeps.ATTRACTOR_KINDS) == [0, 1, 2, 3]
    assert list(sweeps.KINDS) == ["periodic", "quasi-periodic", "chaotic", "unclassified"]
    for code, name in enumerate(sweeps.KINDS):
        assert sweeps.KINDS[name] == sweeps.ATTRACTOR_KINDS[code]


def test_period_rule_is_relative_to_each_states_range():
    """Dense samples whose first state swings over 10 within every period (the same at each Poincare point)
    and whose second alternates by 2e-3 from one period to the next: period two, because each state is
    measured in its own range (in the first state's range the alternation would be 2e-4, below the
    tolerance 1e-3, and the response would pass for period one)."""
    from gearsym.analysis.sweeps._attractor_id import cycle_period, settled_period

    per, periods = 8, 40
    t = np.arange(per * periods + 1) / per  # in forcing periods
    Y = np.c_[5.0 * (1.0 - np.cos(2 * math.pi * t)), 1e-3 * (-1.0) ** np.floor(t + 1e-9)]
    assert settled_period(Y, per, 8, 1e-3) == 2
    assert cycle_period(Y[::per], np.array([10.0, 10.0]), 8, 1e-3) == 1  # one unit for both: period one
