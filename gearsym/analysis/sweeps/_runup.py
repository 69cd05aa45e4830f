r"""Run-ups: a simulation whose speed parameter ramps linearly in time, with order tracking.

:func:`runup` does what a gearbox test rig does: the speed runs from ``start`` to ``stop``
over ``duration`` (a run-up, or a run-down), one signal is recorded (the dynamic deflection
of a mesh, or a state), and its short-time spectra against speed give the waterfall and the
Campbell diagram, with the mesh orders (``speed x teeth x k``) and the natural frequencies of
:func:`gearsym.analysis.linear.modal_analysis` overlaid.

**The ramp is exact.**  A speed ``Omega`` enters a gear model through periodic time
functions of its phase -- ``cos(Omega t)``, a mesh schedule of period ``2 pi / (Z Omega)``,
a Fourier series in ``Z Omega t`` -- and, outside the phase, through amplitudes (the
``Fa Omega^2`` of a dimensionless transmission-error forcing).  Under a ramp the phase is
the integral of the speed, :math:`\theta(t) = \Omega_0 t_0 + \int_{t_0}^t \Omega`, not
``Omega(t) t``.  The engine therefore calls the generated functions at the time
:math:`s(t) = \theta(t)/\Omega(t)` with the speed parameter set to :math:`\Omega(t)`, so
that every time function :math:`h(\Omega t, \Omega)` of the model becomes
:math:`h(\theta(t), \Omega(t))`; for the linear profile :math:`\Omega(t) = \Omega_0 + a
(t - t_0)` the phase is :math:`\theta = \Omega_0 \tau(t)` with the *phase time*
:math:`\tau(t) = t + a (t - t_0)^2 / (2 \Omega_0)` in closed form.  A schedule of period
:math:`P(\Omega) = C / \Omega` runs on :math:`\tau`: its breakpoints are the roots of
:math:`\tau(t_b) = (n + c_i) P(\Omega_0)`, a quadratic the driver solves in closed form,
so the integrator still stops exactly there (``gearsym/engine/gs_ramp.c``).  The ramp's
settings are run-time inputs of the engine: a run-up needs no new build.

**Assumptions, checked before the run** (a model that breaks one is refused, naming it):

* the speed is a run-time parameter, not an argument of a bound function, and the system
  is dimensional (``[simulate] dimensionless`` off);
* the speed keeps its sign (a run-down ends above zero);
* the model has a forcing period, and it and every schedule period are proportional to
  ``1 / speed`` (``T(Omega) Omega`` constant over the range, checked at both ends and the
  middle) with schedule breaks that do not depend on the speed: the speed *is* the
  frequency scale of the model's time functions;
* every generated function (right-hand side or residual, switching functions, mesh
  deflections, outputs) is periodic in time with the forcing period at the start and the end
  speed (checked at sample points): a time function of fixed frequency, or a non-periodic one
  (a ramped torque), has no phase of the speed to run on.

The amplitude factors of the speed take its instantaneous value, and so does every time
derivative the model writes by hand at constant speed (``Fa Omega^2`` in
``models/kahraman_singh.toml``, ``e_s_dot`` in ``models/liu_nfg.toml``) or the symbolic layer
takes of a time function inside a ``[reduction]`` definition (the inertial term ``-m e''(t)``
of ``models/spur_pair_torsional.toml``): a second derivative of :math:`h(\theta(t))` is
:math:`\Omega^2 h'' + \dot\Omega h'`, of which the ramp keeps the first term; the second is
smaller by :math:`|\dot\Omega| / \Omega^2` (``|rate| / speed^2`` in the model's time unit, a
quantity the result's ``settings`` report as ``sweep_rate_ratio``; 1e-4 for a
test-rig run-up through a 3 kHz mesh resonance in half a second).  First derivatives (a
damper on a time-varying deflection) are exact.

**Sampling and spectra.**  The engine's output is requested on two grids at once: equal
time steps (``samples_per_period`` per period of the fastest mesh at the highest speed) for
the short-time spectra, and equal steps of the phase time (the same number per mesh period)
for order tracking in the angle domain, each sample at its exact time (no resampling);
:mod:`gearsym.analysis.sweeps._runup_spectra` defines the spectra and the order amplitudes.
Mesh order 1 of a mesh is its mesh frequency, from the period of the schedule named like
the mesh, else from the forcing period (:func:`gearsym.quantities.mesh_order_periods`;
``mesh_periods`` overrides it), proportional to the speed.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import check_output_grid, check_step_budget
from ...engine.ramp import SpeedRamp
from ...errors import GearsymError, ParameterError
from ...progress import progress_bar
from ...quantities import mesh_order_periods
from ...spec.settings import read_settings, resolve_settings
from .._inputs import as_system
from .._options import resolve_options
from ._runup_result import RunupResult
from ._runup_spectra import angle_windows, order_amplitudes, short_time_spectra, speed_bins

if TYPE_CHECKING:  # pragma: no cover
    from ...engine.driver import Engine, RunResult
    from ...system import CompiledSystem

__all__ = ["RunupOptions", "runup"]

#: RunupOptions field -> key of the scene's [runup] table (where they differ).
_TOML_KEYS = {"start": "from", "stop": "to"}
#: Relative tolerance of the checks that the forcing and schedule periods scale as 1 / speed.
_SCALING_TOL = 1e-9
#: Relative tolerance of the periodicity check of the generated functions.
_PERIODIC_TOL = 1e-7
#: Engine calls the ramp is integrated in (the steps of the progress bar; always this many, so
#: that a run with a bar and one without give the same numbers).
CHUNKS = 32


@dataclass(frozen=True)
class RunupOptions:
    """Settings of :func:`runup`; ``None``: the scene's ``[runup]`` value, else the default.

    Attributes
    ----------
    parameter : str
        The speed parameter (required, here or in the scene).
    start, stop : float
        Its values at the start and the end of the ramp, in its declared unit (the scene's
        ``from`` / ``to``); ``stop < start`` is a run-down.
    duration : float
        Length of the ramp (the model's time unit); or
    rate : float
        its slope ``|stop - start| / duration`` (declared unit per time unit).
    profile : str
        ``"linear"`` (default; the only profile).
    signal : str
        What is recorded: ``"mesh_deflection[NAME]"`` (the dynamic deflection of mesh
        ``NAME``, deflection minus error), ``"mesh_deflection"`` (the first mesh) or a state
        name; default: the first mesh's deflection, else the first state.
    settle : float
        Forcing periods at the start speed before the ramp (default 0), so that the ramp
        starts on the steady response, as on a rig.
    samples_per_period : int
        Output samples per period of the fastest mesh at the highest speed (default 16),
        and angle-domain samples per mesh period.
    bins : int
        Speed bins: short-time spectra along the run (default 60; half-overlapping windows).
    orders : int
        Mesh orders tracked and drawn, ``1 .. orders`` (default 3).
    modes : bool
        Natural frequencies from the modal analysis at the start, middle and end speed
        (default True).
    rtol, atol, method, max_steps
        Integration (default: the scene's ``[simulate]`` values, else 1e-8, 1e-10, the
        scene's method, 10,000,000).
    mesh_periods : mapping
        Mesh name -> the period of its order 1 at the start speed, overriding the rule
        (module docstring); Python only.
    """

    parameter: str | None = None
    start: float | None = None
    stop: float | None = None
    duration: float | None = None
    rate: float | None = None
    profile: str | None = None
    signal: str | None = None
    settle: float | None = None
    samples_per_period: int | None = None
    bins: int | None = None
    orders: int | None = None
    modes: bool | None = None
    rtol: float | None = None
    atol: float | None = None
    method: str | None = None
    max_steps: int | None = None
    mesh_periods: Mapping[str, float] | None = None

    def __post_init__(self) -> None:
        given = {_TOML_KEYS.get(f.name, f.name): getattr(self, f.name) for f in fields(self)
                 if f.name != "mesh_periods" and getattr(self, f.name) is not None}
        if isinstance(given.get("from"), int):  # (a TOML integer is a number too)
            given["from"] = float(given["from"])
        read_settings("runup", given, _option_error)

    def given(self) -> dict[str, Any]:
        """The settings, keyed as in the scene's ``[runup]`` table.

        Returns
        -------
        dict
            Every setting but ``mesh_periods`` (``None``: not given).
        """
        return {_TOML_KEYS.get(f.name, f.name): getattr(self, f.name) for f in fields(self)
                if f.name != "mesh_periods"}


def _option_error(where: str, message: str) -> ParameterError:
    key = where.split(".", 1)[-1]
    name = {v: k for k, v in _TOML_KEYS.items()}.get(key, key)
    return ParameterError(f"runup option '{name}': {message}")


@dataclass
class _Plan:
    """Everything a run-up needs before it integrates (resolved, checked)."""

    name: str
    index: int
    unit: str
    start: float
    stop: float
    duration: float
    ramp: SpeedRamp
    p0: np.ndarray
    params: dict[str, float]
    T0: float
    meshes: list[str]
    mesh_periods0: dict[str, float]
    cycles: list[int]
    signal: str
    grid: np.ndarray
    dtau: float
    q: int
    angle_t: np.ndarray
    settings: dict[str, Any]
    engine: Engine
    notes: list[str] = field(default_factory=list)


def runup(target: CompiledSystem | Any, options: RunupOptions | None = None, *,
          params: Mapping[str, float] | None = None, x0: Sequence[float] | None = None,
          progress: bool | None = False, **overrides: Any) -> RunupResult:
    """A run-up (or run-down) of a speed parameter with its waterfall (module docstring).

    Parameters
    ----------
    target
        A compiled system (``scene.compile()``) or a scene.
    options
        Settings (:class:`RunupOptions`); the scene's ``[runup]`` table fills what it leaves
        ``None``.
    params
        Parameter overrides (declared units) for the whole run, besides the speed.
    x0
        The state at the start (of the settling periods, else of the ramp); default: the
        scene's initial state.
    progress
        A progress bar of the integration (:func:`gearsym.progress.progress_bar`: ``tqdm.auto``;
        ``None``: where someone watches).
    **overrides
        Fields of :class:`RunupOptions` (``parameter="omega", start=1e4, stop=3e4,
        duration=0.5``), overriding ``options``.

    Returns
    -------
    RunupResult

    Raises
    ------
    ParameterError
        A missing or bad setting, or a model the ramp does not cover (module docstring:
        which assumption, naming the parameter and the function).
    SimulationError
        The integration failed.
    """
    system = as_system(target, "runup")
    time_unit = (getattr(system, "state_units", None) or {}).get("t") or None  # (a System has them)
    opts = resolve_options(options, RunupOptions, overrides, "runup")
    plan = _plan(system, opts, dict(params or {}))
    res, angle = _integrate(system, plan, x0, progress)
    return _result(system, plan, res, angle, time_unit)


# ------------------------------------------------------------------ planning
def _settings(system: CompiledSystem, opts: RunupOptions) -> dict[str, Any]:
    """The run-up's settings: the caller's, else the scene's ``[runup]``, else the defaults."""
    given = opts.given()
    if given["duration"] is not None and given["rate"] is not None:
        raise ParameterError("runup: give one of duration and rate (the ramp's length in time, or its slope)")
    scene = dict(system.settings.get("runup") or {})
    for mine, other in (("duration", "rate"), ("rate", "duration")):
        if given[mine] is not None:
            scene.pop(other, None)  # the caller's duration replaces the scene's rate, and vice versa
    s = resolve_settings("runup", scene, **given)
    sim = resolve_settings("simulate", system.defaults, rtol=s["rtol"], atol=s["atol"], method=s["method"])
    s["rtol"], s["atol"], s["method"] = float(sim["rtol"]), float(sim["atol"]), sim["method"]
    s["max_steps"] = int(s["max_steps"] or sim["max_steps"] or 0)
    missing = [k for k in ("parameter", "from", "to") if s[k] is None]
    if s["duration"] is None and s["rate"] is None:
        missing.append("duration or rate")
    if missing:
        raise ParameterError(f"runup needs the speed parameter, its start and stop values, and the ramp's duration "
                             f"or rate (missing: {', '.join(missing)}): parameter=, start=, stop=, duration= or "
                             "rate= of runup(); --param, --from, --to, --duration or --rate of `gearsym runup`; or "
                             "parameter, from, to, duration or rate in the scene's [runup] table")
    return s


def _plan(system: CompiledSystem, opts: RunupOptions, params: dict[str, float]) -> _Plan:
    """Resolve and check the run-up's settings and the model (module docstring)."""
    s = _settings(system, opts)
    name = str(s["parameter"])
    index, unit = _speed_parameter(system, name, params)
    start, stop = float(s["from"]), float(s["to"])
    if start == stop:
        raise ParameterError(f"runup: from and to are equal ({name} = {start:g}): nothing to ramp")
    duration = float(s["duration"]) if s["duration"] is not None else abs(stop - start) / float(s["rate"])
    p0 = system.param_vector({**params, name: start})
    p1 = system.param_vector({**params, name: stop})
    w0, w1 = float(p0[index]), float(p1[index])
    if not w0 * w1 > 0:
        raise ParameterError(f"runup: {name} runs from {start:g} to {stop:g} {unit}: the speed must keep its sign "
                             "(the phase time would turn back where it passes zero)")
    ramp = SpeedRamp(index=index, speed0=w0, rate=(w1 - w0) / duration, t0=0.0)
    pm = system.param_vector({**params, name: 0.5 * (start + stop)})
    T0 = _check_model(system, name, index, (p0, pm, p1))
    notes: list[str] = []
    meshes = list(getattr(system.generated, "meshes", []) or [])
    periods0 = mesh_order_periods(system, p0, meshes, T0, opts.mesh_periods) if meshes else {}
    cycles = _cycles(periods0, T0)
    _check_orders(int(s["orders"]), int(s["samples_per_period"]), cycles)
    signal = _signal_name(system, s["signal"], meshes)
    settings = {k: s[k] for k in ("rtol", "atol", "method", "max_steps", "settle", "samples_per_period", "bins",
                                  "orders", "modes", "profile")}
    settings["method"] = s["method"] or _default_method(system)
    settings["sweep_rate_ratio"] = abs(ramp.rate) / min(abs(w0), abs(w1)) ** 2
    plan = _Plan(name, index, unit, start, stop, duration, ramp, p0, params, T0, meshes, periods0, cycles, signal,
                 np.empty(0), math.nan, 0, np.empty(0), settings, _engine(system, index, notes), notes)
    _grids(system, plan)
    return plan


def _speed_parameter(system: CompiledSystem, name: str, params: Mapping[str, float]) -> tuple[int, str]:
    """``(index, declared unit)`` of the speed parameter, refused where the ramp cannot run it."""
    if name not in system.params:
        raise ParameterError(f"runup: '{name}' is not a run-time parameter of this system (have: "
                             f"{', '.join(system.params) or 'none'})")
    if name in params:
        raise ParameterError(f"runup: '{name}' is the ramped parameter; do not also set it in params")
    for fn, args in system.generated.bound.values():
        if name in args:
            raise ParameterError(f"runup: '{name}' is an argument of the bound function {fn}({', '.join(args)}), "
                                 "evaluated once per run in Python: it cannot follow a ramp")
    if system.generated.dimensionless:
        raise ParameterError("runup: the system simulates in dimensionless variables ([simulate] dimensionless = "
                             "true); run it on the dimensional build (compile(dimensionless=False))")
    return system.param_names.index(name), system.units.unit(name)


def _check_model(system: CompiledSystem, name: str, index: int, ps: tuple[np.ndarray, ...]) -> float:
    """The forcing period at the start speed, after the checks of the module docstring."""
    Ts = [system.period_of(p) for p in ps]
    if Ts[0] is None:
        raise ParameterError(f"runup: the model has no forcing period at {name} = {ps[0][index]:g} (SI): a run-up "
                             "ramps the frequency of periodic time functions; declare [forcing] period")
    at = ", ".join(f"{p[index]:.6g}" for p in ps)
    products = [None if T is None else T * p[index] for T, p in zip(Ts, ps)]
    if any(v is None for v in products) or _spread(products) > _SCALING_TOL:
        raise ParameterError(f"runup: the forcing period is not proportional to 1/{name} (T*{name} = "
                             f"{', '.join('none' if v is None else f'{v:.10g}' for v in products)} at {name} = "
                             f"{at} SI): '{name}' is not the speed of the model's periodic time functions")
    tables = [system.schedule_table(p) for p in ps]
    for k, sched in enumerate(system.generated.schedules):
        prods = [tab[k][0] * p[index] for tab, p in zip(tables, ps)]
        brk = [tab[k][1] for tab in tables]
        if _spread(prods) > _SCALING_TOL or any(np.max(np.abs(b - brk[0])) > 1e-12 for b in brk):
            raise ParameterError(f"runup: schedule '{sched['name']}' does not scale with 1/{name} (period*{name} = "
                                 f"{', '.join(f'{v:.10g}' for v in prods)}, or its breaks move with {name}): it "
                                 f"cannot run on the phase of '{name}'")
    _check_periodic(system, name, index, (ps[0], ps[-1]), (Ts[0], Ts[-1]))
    return float(Ts[0])


def _spread(values: Sequence[float]) -> float:
    v = np.asarray(values, float)
    return float(np.max(np.abs(v - v[0])) / max(abs(v[0]), 1e-300))


def _check_periodic(system: CompiledSystem, name: str, index: int, ps: tuple[np.ndarray, ...],
                    Ts: tuple[float, ...]) -> None:
    """Every generated function is periodic in time with the forcing period (sample points)."""
    gen = system.generated
    x0 = np.asarray(system.x0, float)
    X = np.vstack([x0, x0 + 0.05 * np.asarray(system.state_scales(), float)])
    fns = [("dae", "residual") if gen.implicit else ("rhs", "right-hand side"), ("sw", "switching functions")]
    if getattr(gen, "meshes", None):
        fns.append(("mesh", "mesh deflections"))
    if getattr(gen, "outputs", None):
        fns.append(("out", "outputs"))
    u = np.array([0.113, 0.377, 0.618, 0.891])
    for p, T in zip(ps, Ts):
        t = np.repeat(u * T, len(X))
        x = np.tile(X, (len(u), 1))
        sigma = np.where(system.engine.evaluate("sw", t, x, p) >= 0, 1.0, -1.0) if gen.nsw else None
        for fn, what in fns:
            if fn == "sw" and not gen.nsw:
                continue
            try:
                a = system.engine.evaluate(fn, t, x, p, sigma)
                b = system.engine.evaluate(fn, t + T, x, p, sigma)
            except GearsymError:  # (an implicit model whose derivatives cannot be solved for there)
                continue
            scale = np.max(np.abs(np.vstack([a, b])), axis=0) + 1e-300
            bad = np.abs(a - b) > _PERIODIC_TOL * scale
            if np.any(bad):
                j = int(np.argmax(np.any(bad, axis=0)))
                raise ParameterError(
                    f"runup: the model's {what} (entry {j}) are not periodic in time with the forcing period at "
                    f"{name} = {p[index]:.6g} (SI): a time function whose frequency is not proportional to "
                    f"'{name}' (a fixed-frequency excitation, a ramp in t) has no phase of '{name}' to run on")


def _check_orders(orders: int, spp: int, cycles: Sequence[int]) -> None:
    """Refuse mesh orders that no mesh's angle samples resolve: ``spp * max(cycles)`` samples a
    forcing period hold orders ``h < spp max(cycles) / (2 c)`` of a mesh of ``c`` cycles (Nyquist)."""
    if not cycles:
        return
    top = max(math.ceil(spp * max(cycles) / (2 * c)) - 1 for c in cycles)
    if orders > top:
        raise ParameterError(f"runup: orders={orders}: {spp} samples per period of the fastest mesh "
                             f"(samples_per_period, --samples-per-period) resolve mesh orders up to {top} (Nyquist): "
                             f"track at most {top} orders or raise samples_per_period to at least {2 * orders + 1}")


def _cycles(periods0: Mapping[str, float], T0: float) -> list[int]:
    """Mesh cycles per forcing period of every mesh (whole numbers)."""
    out = []
    for nm, Tm in periods0.items():
        c = T0 / Tm
        if abs(c - round(c)) > 1e-6 * max(1.0, c) or round(c) < 1:
            raise ParameterError(f"runup: mesh '{nm}' has {c:.8g} cycles per forcing period (not a whole number): "
                                 "give mesh_periods or a forcing period that is a common period of the meshes")
        out.append(int(round(c)))
    return out


def _signal_name(system: CompiledSystem, signal: str | None, meshes: list[str]) -> str:
    """The recorded signal, checked: ``mesh_deflection[NAME]`` or a state name."""
    if signal is None:
        return f"mesh_deflection[{meshes[0]}]" if meshes else system.state_names[0]
    m = re.fullmatch(r"mesh_deflection(?:\[(\w+)\])?", signal.strip())
    if m:
        if not meshes:
            raise ParameterError("runup signal: the model has no mesh elements (give a state name)")
        mesh = m.group(1) or meshes[0]
        if mesh not in meshes:
            raise ParameterError(f"runup signal: no mesh '{mesh}' (meshes: {', '.join(meshes)})")
        return f"mesh_deflection[{mesh}]"
    if signal not in system.state_names:
        choices = [f"mesh_deflection[{nm}]" for nm in meshes] + list(system.state_names)
        raise ParameterError(f"runup signal: '{signal}' is neither a mesh deflection nor a state (choose from "
                             f"{', '.join(choices)})")
    return signal


def _engine(system: CompiledSystem, index: int, notes: list[str]) -> Engine:
    """The engine: the system's, or the build with ``gs_swp`` when a switching function depends
    on the speed (its time derivative along the ramp needs it: gs_ramp.c ``eval_swdt``)."""
    gen = system.generated
    if not gen.nsw or "gs_swp" in gen.functions:
        return system.engine
    fn = gen.casadi_function("gs_sw")
    if not fn.which_depends("p", fn.name_out(), 1, False)[index]:
        return system.engine
    notes.append("the switching functions depend on the speed: the build with parameter derivatives is used "
                 "(their time derivative along the ramp)")
    return system.derivative_engine()


def _grids(system: CompiledSystem, plan: _Plan) -> None:
    """The output grids: equal time steps over the ramp, and equal phase-time steps."""
    r, D = plan.ramp, plan.duration
    spp = int(plan.settings["samples_per_period"])
    shortest0 = min(plan.mesh_periods0.values()) if plan.mesh_periods0 else plan.T0
    top = max(abs(r.speed0), abs(r.speed0 + r.rate * D))
    dt = shortest0 * abs(r.speed0) / top / spp
    n = int(math.floor(D / dt + 1e-9)) + 1
    check_output_grid(2 * n, system.generated.nx + 1, "use fewer samples_per_period or a shorter run")
    plan.grid = np.linspace(0.0, D, max(n, 2))
    plan.q = spp * (max(plan.cycles) if plan.cycles else 1)
    plan.dtau = plan.T0 / plan.q
    tau_end = float(r.phase_time(D))
    J = int(math.floor(tau_end / plan.dtau + 1e-9))
    plan.angle_t = np.minimum(r.time_at_phase(np.arange(J + 1) * plan.dtau), D)
    max_step = plan.T0 * abs(r.speed0) / top / 8
    check_step_budget(0.0, D + plan.settings["settle"] * plan.T0, max_step, plan.settings["max_steps"], False)
    plan.settings["max_step"] = max_step


# ------------------------------------------------------------------ running
def _integrate(system: CompiledSystem, plan: _Plan, x0: Sequence[float] | None,
               progress: bool | None) -> tuple[RunResult, RunResult]:
    """Settle (constant start speed), then the ramp with both grids, in :data:`CHUNKS` engine
    calls (the progress bar's steps; the state and the surface sides carried over); returns
    the ramp's run and a view of it on the angle grid."""
    s = plan.settings
    x = np.asarray(system.x0 if x0 is None else x0, float)
    if x.shape != (system.generated.nx,):
        raise ParameterError(f"x0 must have {system.generated.nx} entries ({', '.join(system.state_names)})")
    run_kw = {"method": s["method"], "rtol": s["rtol"], "atol": s["atol"],
              "max_steps": s["max_steps"], "max_step": s["max_step"]}
    sigma = None
    t_all = np.concatenate([plan.grid, plan.angle_t])
    order = np.argsort(t_all, kind="stable")
    t_sorted = t_all[order]
    edges = np.linspace(0.0, plan.duration, CHUNKS + 1)
    table = system.schedule_table(plan.p0)
    runs = []
    with progress_bar(progress, CHUNKS + (1 if s["settle"] else 0), f"run-up of {plan.name}", unit="chunk") as bar:
        if s["settle"]:
            pre = plan.engine.run(x, plan.p0, -float(s["settle"]) * plan.T0, 0.0, np.array([0.0]), **run_kw)
            x, sigma = pre.x_final, (pre.sigma_final if system.generated.nsw else None)
            bar()
        for k in range(CHUNKS):
            lo = 0 if k == 0 else int(np.searchsorted(t_sorted, edges[k], side="right"))
            hi = int(np.searchsorted(t_sorted, edges[k + 1], side="right")) if k < CHUNKS - 1 else len(t_sorted)
            span = float(plan.ramp.phase_time(edges[k + 1]) - plan.ramp.phase_time(edges[k]))
            n_breaks = sum((int(math.ceil(span / P)) + 2) * len(c) for P, c in table)
            res = plan.engine.run(x, plan.p0, float(edges[k]), float(edges[k + 1]), t_sorted[lo:hi], sigma0=sigma,
                                  ramp=plan.ramp, break_log=n_breaks, **run_kw)
            runs.append(res)
            x, sigma = res.x_final, (res.sigma_final if system.generated.nsw else None)
            bar()
    res = _joined(runs)
    y = np.empty_like(res.y)
    y[order] = res.y
    n = len(plan.grid)
    return replace(res, t=plan.grid, y=y[:n]), replace(res, t=plan.angle_t, y=y[n:])


def _joined(runs: list[RunResult]) -> RunResult:
    """One run of consecutive engine runs: outputs, events and breakpoints in order, counts summed."""
    ev = [r.events for r in runs]
    events = type(ev[0])(t=np.concatenate([e.t for e in ev]), surface=np.concatenate([e.surface for e in ev]),
                         direction=np.concatenate([e.direction for e in ev]),
                         speed=np.concatenate([e.speed for e in ev]))
    stats = {k: sum(int(r.stats.get(k, 0)) for r in runs) for k in runs[0].stats}
    brk = np.concatenate([r.break_times for r in runs if r.break_times is not None] or [np.empty(0)])
    return replace(runs[-1], t=np.concatenate([r.t for r in runs]), y=np.concatenate([r.y for r in runs]),
                   events=events, stats=stats, break_times=brk)


def _default_method(system: CompiledSystem) -> str:
    from ...integrators import default_method

    return default_method(system.generated.implicit, system.defaults.get("method"))


def _signal(system: CompiledSystem, plan: _Plan, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The recorded signal at the samples (mesh deflections at the ramp's time and speed)."""
    if plan.signal.startswith("mesh_deflection["):
        mesh = plan.signal[len("mesh_deflection["):-1]
        D = plan.engine.evaluate("mesh", t, y, plan.p0, ramp=plan.ramp)
        return D[:, plan.meshes.index(mesh)]
    return y[:, system.state_names.index(plan.signal)]


# ------------------------------------------------------------------ the result
def _result(system: CompiledSystem, plan: _Plan, res: RunResult, angle: RunResult,
            time_unit: str | None) -> RunupResult:
    """Spectra, order tracks and natural frequencies of the run (module docstring)."""
    s = plan.settings
    t = plan.grid
    x = _signal(system, plan, t, res.y)
    xa = _signal(system, plan, angle.t, angle.y)
    starts, L = speed_bins(len(t), int(s["bins"]))
    dt = float(t[1] - t[0])
    freqs, spectra = short_time_spectra(x, dt, starts, L)
    t_mid = t[starts] + 0.5 * (L - 1) * dt
    tau = plan.ramp.phase_time
    first, K = angle_windows(tau(t[starts]), tau(t[starts + L - 1]), plan.dtau, plan.q)
    orders = order_amplitudes(xa, first, K, plan.q, plan.cycles, int(s["orders"]))
    if plan.cycles and np.any(K < 1):
        plan.notes.append("some speed bins hold no whole forcing period: their order amplitudes are NaN (use fewer "
                          "bins or a longer run)")
    t_ord = (first + 0.5 * K * plan.q) * plan.dtau  # the angle windows' centres, in phase time
    speed_of = _declared_speed(plan)
    mode_speeds, natural = _natural_frequencies(system, plan) if s["modes"] else (np.empty(0), np.empty((0, 0)))
    events = res.events
    names = system.surface_names
    units = dict(getattr(system, "state_units", None) or {})
    params = {k: v for k, v in system.run_params(plan.params).items() if k != plan.name}
    return RunupResult(
        scene=system.name, parameter=plan.name, unit=plan.unit, start=plan.start, stop=plan.stop,
        duration=plan.duration, time_unit=time_unit, t=t, speed=speed_of(t), phase_time=np.asarray(tau(t)),
        states=res.y, state_names=list(system.state_names), state_units=units, signal=x, signal_name=plan.signal,
        signal_unit=units.get(plan.signal, "model units (SI)"),
        angle_phase_time=np.arange(len(xa)) * plan.dtau, angle_signal=xa, bin_time=t_mid, bin_speed=speed_of(t_mid),
        frequencies=freqs, spectra=spectra, window=L * dt, meshes=list(plan.meshes),
        mesh_frequency0=np.array([1.0 / plan.mesh_periods0[m] for m in plan.meshes]),
        order_amplitude=orders, order_speed=speed_of(np.asarray(plan.ramp.time_at_phase(t_ord))),
        mode_speeds=mode_speeds, natural_frequencies=natural, break_times=res.break_times,
        event_times=np.asarray(events.t), event_surfaces=[names[int(j)] for j in events.surface],
        event_directions=np.asarray(events.direction), event_speeds=np.asarray(events.speed), stats=dict(res.stats),
        settings=dict(s),
        params=params, param_units={k: system.units.unit(k) for k in params}, notes=list(plan.notes))


def _declared_speed(plan: _Plan):
    """Time -> the speed in its declared unit (linear: the unit conversion is a scale)."""
    w0, w1 = plan.ramp.speed0, plan.ramp.speed0 + plan.ramp.rate * plan.duration

    def speed(t: np.ndarray) -> np.ndarray:
        w = np.asarray(plan.ramp.speed(t), float)
        return plan.start + (plan.stop - plan.start) * (w - w0) / (w1 - w0)

    return speed


def _natural_frequencies(system: CompiledSystem, plan: _Plan) -> tuple[np.ndarray, np.ndarray]:
    """The natural frequencies (positive ones) at the start, middle and end speed; a failed
    modal analysis leaves NaN and a note."""
    from ..linear import modal_analysis

    speeds = np.array([plan.start, 0.5 * (plan.start + plan.stop), plan.stop])
    found: list[np.ndarray] = []
    failed: dict[str, list[str]] = {}
    for v in speeds:
        try:
            f = np.asarray(modal_analysis(system, {**plan.params, plan.name: float(v)}).frequencies_hz, float)
        except GearsymError as exc:
            failed.setdefault(str(exc), []).append(f"{v:g}")
            f = np.empty(0)
        found.append(f[np.isfinite(f) & (f > 0)])
    for why, at in failed.items():
        plan.notes.append(f"no natural frequencies at {plan.name} = {', '.join(at)}: {why}")
    n = max((len(f) for f in found), default=0)
    out = np.full((len(speeds), n), math.nan)
    for i, f in enumerate(found):
        out[i, :len(f)] = f
    return speeds, out
