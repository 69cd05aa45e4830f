"""Tables in the equations against independent references (issue 27).

A 1-DOF mesh ``m x'' + c x' + s_k k(phase) f(x) = F`` with backlash (contact loss: events),
its stiffness a table over the mesh phase (linear, cubic, fourier) or over (mesh phase, load),
and a spring whose force is a table over the deflection.  Each is compared with a right-hand
side written here from numpy / scipy (``np.interp``, ``CubicSpline(bc_type="periodic")``, a
trigonometric interpolant solved as a linear system) integrated by ``solve_ivp`` (DOP853) with
event location at the contact surfaces and the knots of a table over a state, and restarts at
the knots of a table over the phase (so the reference never steps across a kink either):

* the trajectory over 200 periods to 1e-8 of its range, the same number of events;
* the Floquet multipliers of the periodic orbit to 1e-8, against a monodromy from the
  reference's own variational equations (the vector field is continuous across every surface
  here, so the saltation matrices are the identity);
* the sensitivity to the table's scale parameter against the reference's forward sensitivity.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

import gearsym

PERIODS = 200
T_M = 4.4e-4
M, C, F, B = 0.5, 700.0, 500.0, 10e-6
N = 8
XK = np.arange(N) / N
K0 = 1e8
VALS = K0 * (1 + 0.3 * np.cos(2 * np.pi * XK) + 0.1 * np.sin(4 * np.pi * XK) + 0.05 * (XK > 0.5))
LOADS = np.array([200.0, 600.0, 1000.0])
GRID = np.outer(VALS, 1 + 0.2 * LOADS / 1000)  # k(phase_i, load_j)

# a periodic load over time (the last knot closes the period, 0.55 ms) and a ramp held after 2 ms
TIME_X = np.array([0.0, 0.1, 0.25, 0.3, 0.55]) * 1e-3
TIME_V = np.array([-800.0, 1800.0, -600.0, 1200.0, -800.0])
RAMP_X = np.array([0.0, 1.0, 2.0]) * 1e-3
RAMP_V = np.array([0.0, 300.0, 200.0])

FORCE_X = np.array([-20.0, -10.0, 0.0, 5.0, 10.0, 20.0, 30.0, 40.0]) * 1e-6   # a measured force law
FORCE_V = np.array([-3000.0, -1200.0, 0.0, 250.0, 700.0, 2200.0, 4200.0, 7000.0])


def _floats(v) -> str:
    return "[" + ", ".join(repr(float(a)) for a in np.ravel(v)) + "]"


def _model(kind: str) -> str:
    head = f'''[model]
name = "table_pair_{kind}"
[coordinates.x]
unit = "m"
velocity = "v"
[parameters]
m = {{ value = {M}, unit = "kg" }}
c = {{ value = {C}, unit = "N*s/m" }}
F = {{ value = {F}, unit = "N" }}
b = {{ value = {B * 1e6}, unit = "um" }}
s_k = {{ value = 1.0 }}
T_m = {{ value = {T_M}, unit = "s" }}
F_a = {{ value = 800.0, unit = "N" }}
k_c = {{ value = 1e8, unit = "N/m" }}
[schedules.mesh]
period = "T_m"
[forcing]
period = "T_m"
[elements.mass]
type = "inertia"
coordinate = "x"
value = "m"
[initial]
x = 1.5e-5
'''
    if kind == "force_law":
        return head + f'''
[tables.Fs]
unit = "N"
domain = "um"
x = {_floats(FORCE_X * 1e6)}
values = {_floats(FORCE_V)}
outside = "extend"
[equations.x]
force = "-s_k*Fs(x) - c*v + F + F_a*cos(2*pi*t/T_m)"
'''
    load = "F_per(t) + F_ramp(t)" if kind == "time" else "F"
    mesh = f'''
[elements.load]
type = "force"
coordinate = "x"
value = "{load}"
[elements.mesh]
type = "mesh"
deflection = "x"
damping = "c"
backlash = "b"
'''
    if kind == "grid":
        rows = ", ".join(_floats(r) for r in GRID)
        return head + mesh + f'''stiffness = "s_k*k(mesh_phase, F)"
[tables.k]
unit = "N/m"
domain = ["phase", "N"]
x = {_floats(XK)}
y = {_floats(LOADS)}
values = [{rows}]
'''
    if kind == "time":
        return head + mesh + f'''stiffness = "s_k*k_c"
[tables.F_per]
unit = "N"
domain = "ms"
x = {_floats(TIME_X * 1e3)}
values = {_floats(TIME_V)}
periodic = true
[tables.F_ramp]
unit = "N"
domain = "ms"
x = {_floats(RAMP_X * 1e3)}
values = {_floats(RAMP_V)}
'''
    tol = "\ntolerance = 0.0" if kind == "fourier" else ""
    return head + mesh + f'''stiffness = "s_k*k(mesh_phase)"
[tables.k]
unit = "N/m"
domain = "phase"
x = {_floats(XK)}
values = {_floats(VALS)}
interpolation = "{kind}"{tol}
'''


# ------------------------------------------------------------------ the references


def _trig_interpolant(x: np.ndarray, y: np.ndarray):
    """The trigonometric interpolant of N (even) equally spaced samples on [0, 1), from a linear solve."""
    n = len(x)
    cols = [np.ones(n)]
    for k in range(1, n // 2):
        cols += [np.cos(2 * np.pi * k * x), np.sin(2 * np.pi * k * x)]
    cols.append(np.cos(np.pi * n * x))
    coef = np.linalg.solve(np.stack(cols, axis=1), y)

    def f(p):
        out = coef[0] + coef[-1] * np.cos(np.pi * n * p)
        for k in range(1, n // 2):
            out = out + coef[2 * k - 1] * np.cos(2 * np.pi * k * p) + coef[2 * k] * np.sin(2 * np.pi * k * p)
        return out
    return f


def _stiffness(kind: str):
    """k(t) of the reference (SI)."""
    phase = lambda t: np.mod(t / T_M, 1.0)  # noqa: E731
    if kind == "linear":
        return lambda t: np.interp(phase(t), XK, VALS, period=1.0)
    if kind == "cubic":
        cs = CubicSpline(np.append(XK, 1.0), np.append(VALS, VALS[0]), bc_type="periodic")
        return lambda t: cs(phase(t))
    if kind == "fourier":
        f = _trig_interpolant(XK, VALS)
        return lambda t: f(t / T_M)
    if kind == "grid":  # bilinear: across the loads first (at the fixed load F), then along the phase
        at_load = np.array([np.interp(F, LOADS, row) for row in GRID])
        return lambda t: np.interp(phase(t), XK, at_load, period=1.0)
    raise AssertionError(kind)


def _force_law(x: float, j: int) -> tuple[float, float]:
    """Piece ``j`` of the force law (linear interpolation, end pieces extended) and its slope."""
    s = (FORCE_V[j + 1] - FORCE_V[j]) / (FORCE_X[j + 1] - FORCE_X[j])
    return FORCE_V[j] + s * (x - FORCE_X[j]), s


class Reference:
    """The model's right-hand side written by hand, integrated with events and restarts.

    ``mode`` holds the side (+1/-1) of every surface between events; the augmented state
    ``[x, v, Phi (2x2), dx/ds_k]`` carries the variational and sensitivity equations.
    """

    def __init__(self, kind: str, s_k: float = 1.0):
        self.kind = kind
        self.s_k = s_k
        self.knot_times: list[float] = []
        if kind == "force_law":
            self.surfaces = [float(a) for a in FORCE_X[1:-1]]      # the interior knots (extended ends)
            self.knot_phases: list[float] = []
        elif kind == "time":
            self.k = lambda t: 1e8
            self.surfaces = [B, -B]
            self.knot_phases = []
            P = TIME_X[-1]
            self.knot_times = sorted({n * P + x for n in range(int(PERIODS * T_M / P) + 2) for x in TIME_X[:-1]}
                                     | set(RAMP_X))
        else:
            self.k = _stiffness(kind)
            self.surfaces = [B, -B]                                  # drive and back flanks
            self.knot_phases = [] if kind == "fourier" else list(XK)

    def field(self, t: float, y: np.ndarray, mode: tuple[int, ...]) -> np.ndarray:
        x, v = y[0], y[1]
        if self.kind == "force_law":
            fs, slope = _force_law(x, sum(1 for m in mode if m > 0))  # the piece the mode holds
            force = -self.s_k * fs - C * v + F + 800.0 * np.cos(2 * np.pi * t / T_M)
            dfdx, dfds = -self.s_k * slope, -fs
        else:
            k = float(self.k(t))
            if mode[0] > 0:
                f, df = x - B, 1.0
            elif mode[1] < 0:
                f, df = x + B, 1.0
            else:
                f, df = 0.0, 0.0
            force = self._load(t) - C * v - self.s_k * k * f
            dfdx, dfds = -self.s_k * k * df, -k * f
        A = np.array([[0.0, 1.0], [dfdx / M, -C / M]])
        phi = y[2:6].reshape(2, 2)
        sens = y[6:8]
        return np.concatenate([[v, force / M], (A @ phi).ravel(), A @ sens + np.array([0.0, dfds / M])])

    def state_field(self, t: float, y: np.ndarray, mode: tuple[int, ...]) -> list[float]:
        """The right-hand side alone (the state, without the variational equations)."""
        x, v = y
        if self.kind == "force_law":
            fs, _ = _force_law(x, sum(1 for m in mode if m > 0))
            return [v, (-self.s_k * fs - C * v + F + 800.0 * np.cos(2 * np.pi * t / T_M)) / M]
        f = x - B if mode[0] > 0 else (x + B if mode[1] < 0 else 0.0)
        return [v, (self._load(t) - C * v - self.s_k * float(self.k(t)) * f) / M]

    def _load(self, t: float) -> float:
        if self.kind != "time":
            return F
        return float(np.interp(np.mod(t, TIME_X[-1]), TIME_X, TIME_V) + np.interp(t, RAMP_X, RAMP_V))

    def run(self, x0, t_end: float, t_eval: np.ndarray | None = None, rtol: float = 1e-12,
            variational: bool = True):
        """Integrate from ``x0`` to ``t_end``: final (augmented) state, events, output samples."""
        field = self.field if variational else self.state_field
        y = np.concatenate([x0, np.eye(2).ravel(), np.zeros(2)]) if variational else np.asarray(x0, float)
        t = 0.0
        mode = tuple(1 if y[0] - s > 0 else -1 for s in self.surfaces)
        n_cycles = int(np.ceil(t_end / T_M)) + 1
        stops = sorted({(n + p) * T_M for n in range(n_cycles) for p in self.knot_phases} | {t_end}
                       | set(self.knot_times))
        stops = [s for s in stops if 0 < s <= t_end]
        events, out_t, out_y = 0, [], []
        for tb in stops:
            while t < tb:
                evs = []
                for j, s in enumerate(self.surfaces):
                    def ev(_t, yy, s=s):
                        return yy[0] - s
                    ev.terminal, ev.direction = True, -mode[j]
                    evs.append(ev)
                sol = solve_ivp(lambda tt, yy, mode=mode: field(tt, yy, mode), (t, tb), y, method="DOP853", rtol=rtol,
                                atol=1e-20, events=evs, dense_output=t_eval is not None)
                hit = [i for i, e in enumerate(sol.t_events) if len(e)]
                t_next, y_next = (sol.t_events[hit[0]][0], sol.y_events[hit[0]][0]) if hit else (sol.t[-1], sol.y[:, -1])
                if t_eval is not None:
                    for te in t_eval[(t_eval >= t) & (t_eval <= t_next)]:
                        if not out_t or te > out_t[-1]:
                            out_t.append(te)
                            out_y.append(sol.sol(te)[:2])
                t, y = t_next, y_next
                if hit:
                    mode = tuple(-m if i == hit[0] else m for i, m in enumerate(mode))
                    events += 1
        return y, events, np.array(out_t), np.array(out_y)


# ------------------------------------------------------------------ the tests

KINDS = ["linear", "cubic", "fourier", "grid", "force_law", "time"]


@pytest.fixture(scope="module")
def systems(tmp_path_factory):
    """One compiled system per kind of table (built once for the module)."""
    folder = tmp_path_factory.mktemp("tables")
    out = {}
    for kind in KINDS:
        (folder / f"{kind}.toml").write_text(_model(kind))
        (folder / f"{kind}_scene.toml").write_text(f'[scene]\nmodel = "{kind}.toml"\n')
        out[kind] = gearsym.load_scene(folder / f"{kind}_scene.toml").compile()
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_table_trajectory_and_events_equal_the_reference(systems, kind):
    system = systems[kind]
    x0 = np.array([1.5e-5, 0.0])
    tr = system.simulate(periods=PERIODS, x0=x0, rtol=1e-11, atol=1e-18, n_out=PERIODS * 8 + 1)
    ref = Reference(kind)
    _, events, t_ref, y_ref = ref.run(x0, PERIODS * T_M, t_eval=tr.t, variational=False)
    assert len(t_ref) == len(tr.t)
    assert np.allclose(t_ref, tr.t, rtol=0, atol=1e-15)
    Y = np.stack([tr["x"], tr["v"]], axis=1)
    err = np.max(np.abs(Y - y_ref), axis=0) / np.ptp(y_ref, axis=0)
    assert np.all(err < 1e-8), err
    assert tr.stats["n_events"] == events
    assert events > 100  # the orbit loses contact (or crosses the knots of the force law) every period
    if kind in ("linear", "cubic", "grid"):  # the integrator stopped at every knot of the table
        assert tr.stats["n_breaks"] >= PERIODS * N - 1
    if kind == "time":  # every knot of the periodic load (4 a period) and the two of the ramp
        assert tr.stats["n_breaks"] >= int(PERIODS * T_M / TIME_X[-1]) * 4 + 2


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "time"])   # (the loads over time are not T_m-periodic)
def test_table_floquet_multipliers_equal_the_reference(systems, kind):
    system = systems[kind]
    tr = system.simulate(periods=60, x0=[1.5e-5, 0.0], rtol=1e-11, atol=1e-18)
    orbit = system.periodic_orbit(x0=tr.final_state, rtol=1e-12, atol=1e-18, tol=1e-12)
    y, _, _, _ = Reference(kind).run(orbit.x0, T_M)
    assert np.allclose(y[:2], orbit.x0, rtol=0, atol=1e-9 * np.abs(orbit.x0).max())
    mono = y[2:6].reshape(2, 2)
    ref = np.sort_complex(np.linalg.eigvals(mono))
    got = np.sort_complex(np.asarray(orbit.multipliers))
    assert np.max(np.abs(got - ref)) < 1e-8, (got, ref)


def test_table_scale_sensitivity_equals_the_reference(systems):
    """d x(t)/d s_k (the table's scale parameter) against the reference's forward sensitivity."""
    system = systems["linear"]
    x0 = np.array([1.5e-5, 0.0])
    tr = system.simulate(periods=5, x0=x0, rtol=1e-11, atol=1e-18, sensitivities=["s_k"])
    y, _, _, _ = Reference("linear").run(x0, 5 * T_M)
    got = tr.sensitivities["s_k"][-1]
    assert np.allclose(got, y[6:8], rtol=1e-7, atol=1e-9 * np.abs(y[6:8]).max()), (got, y[6:8])


@pytest.mark.parametrize("kind", ["linear", "cubic", "fourier", "grid"])
def test_generated_c_evaluates_the_reference_interpolant(systems, kind):
    """The stiffness the generated C evaluates (read back from its right-hand side in contact) equals
    the reference's k(t) to round-off, also thousands of periods on (the same wrap)."""
    system = systems[kind]
    k_ref = _stiffness(kind)
    rng = np.random.default_rng(7)
    ts = np.concatenate([rng.uniform(0, 3, 200), rng.uniform(0, 5000, 200)]) * T_M
    ts = np.concatenate([ts, (np.arange(40) + XK[np.arange(40) % N] + 1e-9) * T_M])  # just past knots
    dx = 1e-5
    got = np.array([(F - M * system.rhs(t, [B + dx, 0.0])[1]) / dx for t in ts])
    want = np.array([float(k_ref(t)) for t in ts])
    assert np.max(np.abs(got - want) / want) < 1e-11
