"""Compiled systems: a generated model bound to the C engine and parameter values."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from .bound_functions import evaluate as evaluate_bound
from .budget import DEFAULT_MAX_STEPS, MAX_OUTPUT_VALUES, check_output_grid  # noqa: F401 (the constants: re-exported)
from .budget import check_step_budget as _check_step_budget
from .codegen.artifact import GeneratedModel
from .engine.driver import Engine, load_engine
from .errors import GearsymError, ParameterError
from .evaluation import Evaluations
from .integrators import check_method, default_method, method_names, supports_sensitivities
from .options import cached_options, merge_options
from .results import Event, Flow, Trajectory
from .sensitivity import SensitivityMethods
from .simulation_options import FlowOptions, SimulateOptions
from .spec.rules import ParameterRules
from .spec.settings import resolve_settings
from .spec.units import ParameterUnits

# the largest output grid (points x (states + 1)) and the step budget: gearsym.budget


class CompiledSystem(Evaluations, SensitivityMethods):
    """A compiled scene at the engine level: simulate it, its flow map, point evaluations.

    The base of :class:`gearsym.System`, which :meth:`gearsym.Scene.compile` returns and
    which adds the analysis conveniences (:meth:`gearsym.System.periodic_orbit`); the
    analysis layer works on this class and never imports the facade (:mod:`gearsym.facade`).

    **Units.** Every parameter *mapping* a System takes or gives (``params=`` of every
    method, :attr:`params`, the ``params`` of its trajectories and orbits) is in the units
    the model declares (``b_m`` in um if the model says ``unit = "um"``), as
    :func:`gearsym.load_scene` and ``--set`` take them; :attr:`units` converts them to SI
    once, in :meth:`param_vector`.  Parameter *vectors* (:meth:`param_vector`,
    ``flow(p=...)``, :meth:`period_of`) are what the engine runs on: SI.

    A System pickles (for process pools and Dask): the copy reloads the same build from
    the build cache by its key (verified, never recompiled); the build must be in that
    cache on the machine that unpickles it.

    Parameters
    ----------
    generated
        The compiled model (:meth:`gearsym.Scene.generate`).
    params
        Values of the run-time parameters (SI units: what the spec layer resolved).
    x0
        The initial state.
    defaults
        The scene's ``[simulate]`` table (``periods``, ``rtol``, ``method``, ...).
    scene_name
        The scene's name (default: the build's).
    units
        The declared units of the parameters (default: every parameter SI).
    rules
        The physical ranges of the parameter values (:mod:`gearsym.spec.rules`), checked
        for every override in :meth:`param_vector` (default: none).
    settings
        The scene's other settings tables: ``{"orbit": {...}, "continue": {...}, "map": {...}}``
        (:mod:`gearsym.spec.settings`), the defaults of :meth:`gearsym.System.periodic_orbit`,
        :func:`gearsym.continuation` and :func:`gearsym.analysis.sweeps.stability_map`.
    state_units
        The (coherent SI) unit of time ``"t"`` and of every state (``"m"``, ``"rad/s"``, ``"1"``),
        as :meth:`units_table` reports them (default: unknown, ``""``).

    Attributes
    ----------
    generated : GeneratedModel
        Sources, shared object, state and parameter names, operation counts.
    units : ParameterUnits
        Declared unit of every parameter and the conversion to and from SI.
    x0 : ndarray
        The scene's initial state.
    """

    def __init__(self, generated: GeneratedModel, params: Mapping[str, float], x0: Sequence[float],
                 defaults: Mapping[str, object] | None = None, scene_name: str = "",
                 units: ParameterUnits | None = None, rules: ParameterRules | None = None,
                 settings: Mapping[str, Mapping[str, Any]] | None = None,
                 state_units: Mapping[str, str] | None = None):
        self.generated = generated
        self.engine: Engine = load_engine(generated.so_path, sha256=generated.so_sha256 or None,
                                          build_key=generated.build_key or None)
        self.units = units if units is not None else ParameterUnits()
        self.rules = rules if rules is not None else ParameterRules()
        # run-time inputs: the generated parameters, except the bound ones (numeric
        # functions of other parameters), which param_vector() evaluates from theirs
        self._si = {name: float(params[name]) for name in generated.input_names}
        self._params_view = MappingProxyType(self.units.to_declared(self._si))
        self.x0 = np.asarray(x0, dtype=float)
        if generated.dimensionless:  # the scene's initial state is dimensional: scale it
            self.x0 = self.x0 / self.state_scales()
        self.defaults = dict(defaults or {})
        self.settings = {k: dict(v) for k, v in (settings or {}).items()}
        self.name = scene_name or generated.scene
        self.state_units = dict(state_units or {})
        #: makes the build with the parameter derivatives of the sensitivities on the first
        #: sensitivity request (set by :meth:`gearsym.Scene.compile`; None: not available)
        self.derivative_build = None
        self._derivative_engine: Engine | None = None

    # ------------------------------------------------------------ pickling

    def __getstate__(self) -> dict[str, object]:
        gen = self.generated
        if not gen.build_key:
            raise GearsymError(f"system '{self.name}' has no build key: it cannot be reloaded from a build cache")
        return {"cache": str(Path(gen.directory).parent), "scene": gen.scene, "build_key": gen.build_key,
                "params": dict(self._si), "x0": self.x0.tolist(), "defaults": dict(self.defaults),
                "name": self.name, "units": self.units, "rules": self.rules, "settings": self.settings,
                "state_units": self.state_units}

    def __setstate__(self, state: dict[str, object]) -> None:
        from .codegen.cache import BuildCache

        cache = BuildCache(str(state["cache"]))
        key = str(state["build_key"])
        gen = cache.lookup(cache.entry(str(state["scene"]), key), key)
        if gen is None:
            raise GearsymError(f"the build {key[:16]} of scene '{state['scene']}' is not in the build cache "
                               f"{cache.root} on this machine (compile the scene here first)")
        self.__init__(gen, state["params"], state["x0"], state["defaults"], str(state["name"]),  # type: ignore[misc]
                      state["units"], state.get("rules"), state.get("settings"), state.get("state_units"))

    # ------------------------------------------------------------------ info

    @property
    def params(self) -> Mapping[str, float]:
        """Current values of the run-time parameters, in the model's declared units (read-only)."""
        return self._params_view

    def units_table(self) -> dict[str, str]:
        """The unit of every value a result of this system holds.

        Time ``"t"`` and the states in coherent SI units (``"s"``, ``"m"``, ``"rad/s"``; ``"1"``
        for dimensionless variables, e.g. a system compiled with ``dimensionless=True``), the
        run-time parameters in the units the model declares (``"um"``; ``""`` where none is
        declared): what ``attrs["units"]`` of :meth:`gearsym.Trajectory.to_xarray` says.

        Returns
        -------
        dict
            Name -> unit text (a new dict).
        """
        if self.generated.dimensionless:
            out = {"t": "1", **{n: "1" for n in self.generated.state_names}}
        else:
            out = {"t": self.state_units.get("t", ""), **{n: self.state_units.get(n, "") for n in self.generated.state_names}}
        out.update({k: self.units.unit(k) for k in self.params})
        return out

    def param_dict(self, p: Sequence[float]) -> dict[str, float]:
        """A parameter vector as a mapping in declared units (bound parameters: SI).

        Parameters
        ----------
        p
            Parameter vector (as :meth:`param_vector` returns).

        Returns
        -------
        dict
            Name -> value for every entry of :attr:`param_names`.
        """
        return self.units.to_declared(dict(zip(self.param_names, (float(v) for v in p), strict=True)))

    # ------------------------------------------------------------------ info

    @property
    def state_names(self) -> list[str]:
        """Names of the states, in the order of ``x``."""
        return list(self.generated.state_names)

    @property
    def differential_states(self) -> int:
        """Number of differential states: all but the algebraic variables (the last states)."""
        return self.generated.nx - len(self.generated.algebraic)

    @property
    def param_names(self) -> list[str]:
        """Names of the run-time parameters, in the order of ``p``."""
        return list(self.generated.param_names)

    @property
    def surface_names(self) -> list[str]:
        """Names of the switching functions."""
        return [s["name"] for s in self.generated.surfaces]

    def state_scales(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """Reference of each state: ``x_dimensional = state_scales() * x``.

        Ones unless the system simulates in dimensionless variables; then time is
        ``t_ref * tau``, see :meth:`time_scale`.

        Parameters
        ----------
        params
            Parameter overrides (declared units, as every ``params=``).

        Returns
        -------
        ndarray
            One scale per state (coordinates, then velocities: coordinate scale / ``t_ref``).
        """
        if not self.generated.dimensionless:
            return np.ones(self.generated.nx)
        s = self._reference_scales(params)
        T, q = s[0], s[1:]
        return np.concatenate([q, q / T])

    def time_scale(self, params: Mapping[str, float] | None = None) -> float:
        """``t_ref``: dimensional time per unit of this system's time.

        Parameters
        ----------
        params
            Parameter overrides (declared units, as every ``params=``).

        Returns
        -------
        float
            1 unless the system simulates in dimensionless variables.
        """
        if not self.generated.dimensionless:
            return 1.0
        return float(self._reference_scales(params)[0])

    def _reference_scales(self, params: Mapping[str, float] | None) -> np.ndarray:
        """``[t_ref, q_ref...]`` of a dimensionless system (the generated ``gs_scales``)."""
        return np.asarray(self.generated.casadi_function("gs_scales")(self.param_vector(params))).ravel()

    def param_vector(self, params: Mapping[str, float] | None = None) -> np.ndarray:
        """The engine's parameter vector (SI), with ``params`` overriding the current values.

        The one place a System converts parameter values from declared units to SI.

        Parameters
        ----------
        params
            Overrides by name (declared units).

        Returns
        -------
        ndarray
            SI values in the order of :attr:`param_names`, bound parameters evaluated.

        Raises
        ------
        ParameterError
            An unknown or non-finite override, or one outside the physical range of the field
            that uses it (a negative backlash, a non-positive inertia, a schedule break outside
            (0, 1), a declared ``min`` / ``max``: :mod:`gearsym.spec.rules`), naming the
            parameter and its unit.
        """
        if not params:
            return self._at_own_values("param_vector", self._param_vector).copy()
        return self._param_vector(params)

    def _at_own_values(self, what: str, compute: Callable[[dict], Any]) -> Any:
        """``compute({})``, made once: the system's own parameter values never change (its
        parameter vector, run parameters and forcing period sit on hot paths)."""
        cache = self.__dict__.setdefault("_own_values", {})
        if what not in cache:
            cache[what] = compute({})
        return cache[what]

    def _param_vector(self, params: Mapping[str, float]) -> np.ndarray:
        values = dict(self._si)
        for k, v in params.items():
            if k not in values:
                raise ParameterError(
                    f"'{k}' is not a run-time parameter of this system (have: "
                    f"{', '.join(values) or 'none'}); parameters of switched-off effects are "
                    f"not inputs")
            if not math.isfinite(float(v)):
                raise ParameterError(f"parameter '{k}': non-finite value {v}")
        values.update(self.units.to_si(params))
        broken = self.rules.violation(values, changed=params.keys()) if self.rules.rules else None
        if broken is not None:  # the values every analysis runs on: maps, continuation, params=
            raise ParameterError(self.rules.message(*broken, values, self.units))
        for name, (fn, args) in self.generated.bound.items():
            values[name] = evaluate_bound(fn, [values[a] for a in args], args)
        return np.array([values[k] for k in self.generated.param_names], dtype=float)

    def run_params(self, params: Mapping[str, float] | None = None) -> dict[str, float]:
        """The run-time parameter values of a run with these overrides, keyed like :attr:`params`
        (declared units; bound parameters excluded): what a result records as its ``params``.

        Parameters
        ----------
        params
            Overrides by name (declared units).

        Returns
        -------
        dict
            A new dict.
        """
        if not params:
            return dict(self._at_own_values("run_params", self._run_params))
        return self._run_params(params)

    def _run_params(self, params: Mapping[str, float]) -> dict[str, float]:
        used, inputs = self.param_dict(self.param_vector(params)), self.params
        return {k: v for k, v in used.items() if k in inputs}

    @property
    def forcing_period(self) -> float | None:
        """The forcing period at the system's own parameter values (time unit: ``units_table()["t"]``,
        seconds for a dimensional model), or ``None`` without one; :meth:`period` evaluates it at
        other values."""
        return self.period()

    def period(self, params: Mapping[str, float] | None = None) -> float | None:
        """The forcing period at these parameters (in the model's time unit, seconds for a dimensional model).

        A method because it takes parameter overrides; at the system's own values the property
        :attr:`forcing_period` reads better.  Evaluated by the generated C (``gs_period``)
        through the engine: about a microsecond.

        Parameters
        ----------
        params
            Parameter overrides (declared units).

        Returns
        -------
        float or None
            ``None`` if the scene has none, or if it is not finite and positive at these
            values (:meth:`require_period` says which).
        """
        if not params:
            T = self._at_own_values("period", lambda _: self.engine.period(self.param_vector()))
        else:
            T = self.engine.period(self.param_vector(params))
        return T if math.isfinite(T) and T > 0 else None

    def period_of(self, p: np.ndarray) -> float | None:
        """:meth:`period` for a parameter *vector*.

        Parameters
        ----------
        p
            Parameter vector (as :meth:`param_vector` returns).

        Returns
        -------
        float or None
        """
        T = self.engine.period(p)
        return T if math.isfinite(T) and T > 0 else None

    @property
    def has_forcing_period(self) -> bool:
        """Whether the model declares a forcing period (``[forcing] period``)."""
        fn = self.generated.casadi_function("gs_period")
        return any(fn.which_depends("p", ["T"], 1, False)) or not math.isnan(float(fn(self.param_vector())))

    def require_period(self, params: Mapping[str, float] | None = None, what: str = "this") -> float:
        """The forcing period, or a :class:`ParameterError` saying why there is none.

        Parameters
        ----------
        params
            Parameter overrides (declared units).
        what
            What needs the period (for the message), e.g. ``"periods="``.

        Returns
        -------
        float
            The forcing period.

        Raises
        ------
        ParameterError
            The model declares no forcing period, or it is not finite and positive at these
            parameter values (e.g. ``Omega = 0`` in ``period = "2*pi/Omega"``).
        """
        p = self.param_vector(params)
        T = self.engine.period(p)
        if math.isfinite(T) and T > 0:
            return T
        fn = self.generated.casadi_function("gs_period")  # which parameters T depends on, for the message
        deps = [f"{n} = {v:g}" for n, v, d in zip(self.param_names, p, fn.which_depends("p", ["T"], 1, False),
                                                   strict=True) if d]
        if not deps and math.isnan(T):
            raise ParameterError(f"{what} needs a scene with a forcing period ([forcing] period); give t_end")
        at = f" at {', '.join(deps)}" if deps else ""
        raise ParameterError(f"the forcing period is not finite and positive{at} (T = {T:g}); {what} needs a "
                             f"forcing period")

    def simulate(self, t_end: float | None = None, periods: float | None = None,
                 x0: Sequence[float] | None = None, rtol: float | None = None, atol: float | None = None,
                 n_out: int | None = None, params: Mapping[str, float] | None = None, *,
                 options: SimulateOptions | None = None, **keywords: Any) -> Trajectory:
        """Integrate the system with the C engine (one call into C).

        Parameters
        ----------
        t_end
            Final time. Give this or ``periods``.
        periods
            Number of forcing periods (``t_end = t0 + periods * T``).  Without ``t_end``,
            ``periods`` and ``t_out``: the scene's ``[simulate]`` ``periods`` or ``t_end``,
            else 100 forcing periods (a time of 100 without a forcing period).
        x0
            Initial state; the scene's when ``None``.
        rtol, atol
            Integrator tolerances (default: the scene's ``[simulate]`` ``rtol`` / ``atol``,
            else 1e-8 / 1e-10).
        n_out
            Number of evenly spaced output points from ``t0`` to ``t_end`` (both
            included); by default the scene's ``points_per_period`` (else 64) per forcing
            period (or 1001).
        params
            Parameter overrides for this call only (declared units).
        options
            The other settings (:class:`~gearsym.simulation_options.SimulateOptions`, each with
            its default): ``t0``, ``method``, ``max_step``, ``monodromy``, ``sigma0``,
            ``max_steps``, ``t_out``, ``nonlinear``, ``linear_solver``, ``sensitivities``.
            ``rtol``, ``atol`` and ``n_out`` given here override the object's.
        **keywords
            The fields of :class:`~gearsym.simulation_options.SimulateOptions` as keywords
            (``method="bdf", monodromy=True, ...``), overriding those of ``options``.  Notably:
            ``method`` (``"adams"``, ``"bdf"``, ``"adams_fixedpoint"``; ``"ida"`` for implicit
            models); ``monodromy``: also integrate the variational equations and return ``d
            x(t_end)/d x0`` (with saltation matrices at the events; on IDA with algebraic
            variables, the last states, their columns are 0 and the top-left block of the
            differential states is the monodromy of the underlying ODE, whose eigenvalues are the
            Floquet multipliers: :attr:`differential_states`); ``max_steps``: a run that needs
            more than this many steps of ``max_step`` is refused before it starts; ``t_out``:
            without ``t_end`` and ``periods`` the integration ends at ``t_out[-1]``;
            ``sensitivities``: run-time parameters (e.g. ``["omega"]``) whose exact sensitivities
            ``d x(t) / d p`` to return along the trajectory (at the fixed output times) in
            :attr:`Trajectory.sensitivities`: the parameter variational equations are integrated
            with the state, with the event-time terms at contact events and the breakpoint-time
            terms at scheduled breakpoints (explicit models; ``x0`` is held fixed).

        Returns
        -------
        Trajectory
            With :attr:`Trajectory.settings`, the settings the run used; time and states in SI
            (``"1"`` for dimensionless variables), parameters in their declared units, each unit
            in :attr:`Trajectory.units` (:meth:`units_table`).

        Notes
        -----
        The scene's settings are resolved in one place for the command line and this method
        (:func:`gearsym.spec.settings.resolve_settings`): ``gearsym simulate`` passes only the
        options the user typed, so one scene gives one answer both ways.

        Raises
        ------
        SimulationError
            Too much work, event storm, non-finite state, solver failure.
        ParameterError
            Unknown or non-finite parameter override; an unknown keyword (named, with the
            closest one); a method not offered for the model's form; an output grid above
            :data:`MAX_OUTPUT_VALUES` numbers; a horizon that needs more than ``max_steps`` steps.
        """
        wall = time.perf_counter()
        for k, v in (("rtol", rtol), ("atol", atol), ("n_out", n_out)):
            if v is not None:
                keywords[k] = v
        o = cached_options(SimulateOptions, keywords, "System.simulate") if options is None else \
            merge_options(SimulateOptions, options, keywords, "System.simulate")
        p = self.param_vector(params)
        plan = self._plan(p, params, t_end, periods, o)
        x0v = self.x0 if x0 is None else np.asarray(x0, dtype=float)
        if x0v.shape != (self.generated.nx,):
            raise ParameterError(f"x0 must have {self.generated.nx} entries "
                                 f"({', '.join(self.state_names)}), got shape {x0v.shape}")
        sensitivities = o.sensitivities
        sens_kw: dict = {}
        if sensitivities is not None:
            sens_kw = self._sensitivity_args(list(sensitivities), p, np.full(self.generated.nx, plan.atol),
                                             o.monodromy, plan.atol, inputs=params)
            if not supports_sensitivities(plan.method):
                raise ParameterError(f"method '{plan.method}' does not integrate parameter sensitivities; use one "
                                     f"of {', '.join(n for n in method_names() if supports_sensitivities(n))}")
            sens_kw["sens_out"] = True
        engine = self.engine if sensitivities is None else self.derivative_engine()
        res = engine.run(x0v, p, o.t0, plan.t_end, plan.grid, method=plan.method, rtol=plan.rtol, atol=plan.atol,
                         sigma0=o.sigma0, want_monodromy=o.monodromy, max_steps=plan.max_steps,
                         max_step=plan.max_step, nonlinear=o.nonlinear, linear_solver=o.linear_solver, **sens_kw)
        return self._trajectory(res, plan, p, sensitivities, wall, params)

    def _plan(self, p: np.ndarray, params: Mapping[str, float] | None, t_end: float | None,
              periods: float | None, o: SimulateOptions) -> _Plan:
        """The settings of one :meth:`simulate` run: the caller's, else the scene's, else the defaults
        (:func:`~gearsym.spec.settings.resolve_settings`), checked before any work."""
        t0, rtol, atol, n_out, method, max_step, max_steps, t_out = (o.t0, o.rtol, o.atol, o.n_out, o.method,
                                                                      o.max_step, o.max_steps, o.t_out)
        T = self.period(params)
        grid = _explicit_grid(t_out)
        given_horizon = t_end is not None or periods is not None
        s = resolve_settings("simulate", self.defaults, rtol=rtol, atol=atol, method=method,
                             max_steps=max_steps or None,
                             **({"t_end": t_end, "periods": periods} if given_horizon else {}))
        if not given_horizon and grid is not None:
            t_end = float(grid[-1])  # integrate to the last output time, not the scene's horizon
        elif given_horizon:
            t_end = None if t_end is None else float(t_end)
        elif s["periods"] is None and s["t_end"] is not None:
            t_end = float(s["t_end"])
        elif s["periods"] is None and not T and not self.has_forcing_period:
            t_end = 100.0
        if t_end is None:
            periods = s["periods"] if s["periods"] is not None else 100
            if not T:
                T = self.require_period(params, "periods=")  # says why there is none
            if not (math.isfinite(float(periods)) and float(periods) > 0):
                raise ParameterError(f"periods must be positive and finite, got {periods}")
            t_end = t0 + float(periods) * T
        _check_tolerances(t0, t_end, s["rtol"], s["atol"])
        grid = self._output_grid(grid, t0, t_end, T, n_out, int(s["points_per_period"]))
        method = default_method(self.generated.implicit and method is None, s["method"])
        check_method(method, self.generated.implicit)
        if max_step is None:
            max_step = T / 8 if T else 0.0
        steps = int(s["max_steps"] or 0)
        if steps < 0:
            raise ParameterError(f"max_steps must be positive (0: the default), got {steps}")
        _check_step_budget(t0, t_end, max_step, steps, bool(T and max_step == T / 8))
        settings = {"t0": t0, "t_end": t_end, "rtol": float(s["rtol"]), "atol": float(s["atol"]), "method": method,
                    "n_out": int(grid.size), "max_step": max_step, "max_steps": steps,
                    "transient_periods": s["transient_periods"]}
        return _Plan(T, t_end, grid, float(s["rtol"]), float(s["atol"]), method, max_step, steps, settings)

    def _output_grid(self, grid: np.ndarray | None, t0: float, t_end: float, T: float | None, n_out: int | None,
                     points_per_period: int) -> np.ndarray:
        """The output times: ``t_out``, else ``n_out`` (or ``points_per_period`` per forcing period) evenly
        spaced from ``t0`` to ``t_end``; refused above :data:`MAX_OUTPUT_VALUES` numbers."""
        if grid is not None:
            if grid[0] < t0 or grid[-1] > t_end:
                raise ParameterError(f"t_out must lie in [t0, t_end] = [{t0:g}, {t_end:g}], got "
                                     f"[{grid[0]:g}, {grid[-1]:g}]")
            n_points = grid.size
        else:
            if n_out is None:
                n_out = int(round((t_end - t0) / T * points_per_period)) + 1 if T else 1001
            n_points = max(int(n_out), 2)
        check_output_grid(n_points, self.generated.nx + 1,
                          "use fewer periods, a smaller points_per_period or n_out / t_out")
        if grid is None:
            grid = np.linspace(t0, t_end, n_points)
            grid[-1] = t_end
        return grid

    def _trajectory(self, res: Any, plan: _Plan, p: np.ndarray, sensitivities: Sequence[str] | None,
                    wall: float, inputs: Mapping[str, float] | None = None) -> Trajectory:
        """The :class:`Trajectory` of an engine run."""
        sens = None
        if sensitivities is not None:
            sens = {name: res.sensitivity_out[:, :, s].copy() for s, name in enumerate(sensitivities)}
        names = self.surface_names
        events = [Event(float(tt), names[int(j)], int(d))
                  for tt, j, d in zip(res.events.t, res.events.surface, res.events.direction)]
        stats = dict(res.stats)
        stats["n_events"] = int(stats.get("n_events", len(events)))
        stats["wall_s"] = time.perf_counter() - wall
        return Trajectory(t=plan.grid, y=res.y, state_names=self.state_names, events=events, stats=stats,
                          period=plan.period, params=self.param_dict(p),
                          x_final=res.x_final, monodromy=res.monodromy,
                          event_speed=np.asarray(res.events.speed), sensitivities=sens, settings=plan.settings,
                          system=self, units=self.units_table(),
                          inputs=dict(inputs or {}))

    def flow(self, x0: Sequence[float], t0: float, t1: float, p: np.ndarray | None = None,
             options: FlowOptions | None = None, *, sigma0: Sequence[float] | None = None,
             scales: np.ndarray | None = None, sensitivities: Sequence[str] | None = None,
             span_derivative: tuple[Sequence[float] | float, Sequence[float] | float] | None = None,
             inputs: Mapping[str, float] | None = None, **keywords: Any) -> Flow:
        """The flow map ``phi(t1, t0, x0)`` and its Jacobian: the cheap path of the orbit solvers.

        One C call with a reused engine workspace; no output grid beyond ``n_samples``
        points, no trajectory object, the forcing period from the generated C.

        Parameters
        ----------
        x0
            Initial state.
        t0, t1
            Time span, ``t1 > t0``.
        p
            Parameter vector (:meth:`param_vector`); the current values when ``None``.
        options
            How to integrate (:class:`~gearsym.simulation_options.FlowOptions`, each with its
            default): ``rtol``, ``atol`` (a number or one per state), ``monodromy`` (integrate
            the variational equations: CVODE, or IDA for implicit models; with algebraic
            variables their columns are 0, see :meth:`simulate`), ``method`` (default: the
            scene's, else Adams; IDA for implicit models), ``max_step`` (default: an eighth of
            the forcing period), ``n_samples`` (evenly spaced samples from ``t0`` to ``t1``:
            :attr:`Flow.samples`, :attr:`Flow.amplitude`), ``max_steps`` (0: the scene's, else
            ten million).
        sigma0
            Side of each switching surface at ``t0`` (default: from the state).
        scales
            Magnitude of each state (e.g. its largest value on the orbit).  With it the
            variational entry ``Phi_ij = d x_i / d x0_j`` gets the absolute tolerance
            ``atol_i / scales_j`` (its error, times a perturbation of size ``scales_j``,
            is then an error ``atol_i`` in ``x_i``) instead of ``atol_i``: in SI units the
            states and their ratios differ by orders of magnitude, and one ``atol`` for
            all made the variational equations take 7-26x the steps of the state.
        sensitivities
            Run-time parameters whose exact derivatives ``d phi / d p`` to return in
            :attr:`Flow.sensitivity` (CVODE, or IDA for implicit models and DAEs): parameter variational equations
            with event-time and breakpoint-time terms, in the same integration as the
            monodromy.
        span_derivative
            ``(d t0 / d p_s, d t1 / d p_s)`` for each of ``sensitivities`` when the span
            moves with the parameter; :attr:`Flow.sensitivity` is then the total
            derivative, e.g. for the period map ``x0 -> phi(T(p), 0, x0; p)`` give
            ``(0, dT/dp)`` (:meth:`period_gradient`): the sensitivity at ``T-`` plus ``f(T-) dT/dp``.
        inputs
            The parameter overrides ``p`` was made with (:meth:`param_vector`), needed for the
            derivative of a bound parameter whose arguments ``p`` does not hold; default: the
            current values.
        **keywords
            The fields of :class:`~gearsym.simulation_options.FlowOptions` as keywords
            (``rtol=1e-10, monodromy=False, ...``), overriding those of ``options``.

        Returns
        -------
        Flow

        Raises
        ------
        ParameterError
            An unknown keyword (named, with the closest one), an output grid or a horizon
            beyond the work budget.
        SimulationError
            The integration failed.
        """
        if keywords:
            o = cached_options(FlowOptions, keywords, "System.flow") if options is None else \
                merge_options(FlowOptions, options, keywords, "System.flow")
        else:
            o = merge_options(FlowOptions, options, keywords, "System.flow")
        pv = self.param_vector() if p is None else p
        method = o.method if o.method is not None else default_method(self.generated.implicit,
                                                                         self.defaults.get("method"))
        max_step = o.max_step
        if max_step is None:
            T = self.engine.period(pv)
            max_step = T / 8 if math.isfinite(T) and T > 0 else 0.0
        check_output_grid(o.n_samples, self.generated.nx, "use fewer n_samples")
        grid = np.linspace(t0, t1, max(int(o.n_samples), 2))
        grid[-1] = t1
        max_steps = o.max_steps or int(self.defaults.get("max_steps", 0))
        _check_step_budget(t0, t1, max_step, max_steps, False)
        mono = bool(o.monodromy)
        atol, atol_vec = self._flow_tolerances(o.atol, mono, scales)
        sens_kw: dict = {}
        if sensitivities is not None:
            nx = self.generated.nx
            ax = np.broadcast_to(np.asarray(atol if atol_vec is None else atol_vec[:nx], float), (nx,))
            sens_kw = self._sensitivity_args(list(sensitivities), pv, np.array(ax), mono, ax, scales, inputs)
            if span_derivative is not None:
                sens_kw["sens_dt0"], sens_kw["sens_dt1"] = span_derivative
            atol_vec = sens_kw.pop("atol_vec")
        engine = self.engine if sensitivities is None else self.derivative_engine()
        res = engine.run(x0, pv, t0, t1, grid, method=method, rtol=o.rtol, atol=atol, sigma0=sigma0,
                         atol_vec=atol_vec, want_monodromy=mono, max_steps=max_steps, max_step=max_step, **sens_kw)
        ev = res.events
        return Flow(x_final=res.x_final, monodromy=res.monodromy, event_t=ev.t, event_surface=ev.surface,
                    event_direction=ev.direction, event_speed=ev.speed, sigma_final=res.sigma_final,
                    amplitude=np.max(np.abs(res.y), axis=0), stats=res.stats, sensitivity=res.sensitivity,
                    samples=res.y)

    def _flow_tolerances(self, atol: Any, mono: bool, scales: np.ndarray | None) -> tuple[Any, np.ndarray | None]:
        """``(atol, atol_vec)`` of a :meth:`flow` run: the scalar ``atol``, or per state (and, with the
        monodromy, per variational entry ``atol_i / scales_j``, column-major) with the smallest as scalar."""
        if not (np.ndim(atol) or scales is not None):
            return atol, None
        nx = self.generated.nx
        nd = nx - len(self.generated.algebraic)  # variational columns: the differential states
        ax = np.broadcast_to(np.asarray(atol, float), (nx,))
        if mono:
            sc = np.ones(nx) if scales is None else np.maximum(np.asarray(scales, float), np.finfo(float).tiny)
            atol_vec = np.concatenate([ax, (ax[:, None] / sc[None, :nd]).T.ravel()])  # Phi column-major
        else:
            atol_vec = np.array(ax)
        return float(np.min(ax)), atol_vec


@dataclass(frozen=True)
class _Plan:
    """The resolved settings of one :meth:`System.simulate` run."""

    period: float | None
    t_end: float
    grid: np.ndarray
    rtol: float
    atol: float
    method: str
    max_step: float
    max_steps: int
    settings: dict[str, Any]


def _explicit_grid(t_out: Sequence[float] | None) -> np.ndarray | None:
    if t_out is None:
        return None
    grid = np.asarray(t_out, dtype=float).reshape(-1)
    if grid.size == 0 or not np.all(np.isfinite(grid)) or np.any(np.diff(grid) < 0):
        raise ParameterError("t_out must be a non-empty ascending sequence of finite times")
    return grid


def _check_tolerances(t0: float, t_end: float, rtol: float, atol: float) -> None:
    if not (math.isfinite(t_end) and t_end > t0):
        raise ParameterError(f"t_end must be finite and greater than t0={t0}, got {t_end}")
    if not (rtol > 0 and atol > 0 and math.isfinite(rtol) and math.isfinite(atol)):
        raise ParameterError(f"tolerances must be positive and finite (rtol={rtol}, atol={atol})")
    if rtol < 1e-15:
        raise ParameterError(f"rtol={rtol} is below what double precision can deliver (1e-15)")
    if rtol >= 1:
        raise ParameterError(f"rtol={rtol} asks for no accuracy at all (need rtol < 1)")

