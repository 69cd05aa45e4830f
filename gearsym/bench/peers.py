"""The methods a work-precision run compares: gearsym itself and the peers a user would
otherwise write (scipy, scikit-sundae, CasADi), each an untimed ``setup`` and a timed ``run``."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError
from .events import _Deadline, _guarded, solve_with_events
from .model import PythonModel

__all__ = ["METHOD_NAMES", "Method", "RunOutput", "make_methods", "parse_methods"]


@dataclass
class RunOutput:
    """States on the grid and the counters a method reports."""

    y: np.ndarray
    stats: dict[str, int | None] = field(default_factory=dict)


class Method:
    """One way of integrating the scene: an untimed ``setup(rtol, atol)`` and a timed ``run()``.

    Attributes
    ----------
    name, description
        For tables, plots and JSON.
    events
        Whether it locates the switching events (``True``) or steps over the kinks.
    gearsym
        Whether it is gearsym itself (Pareto analysis).
    """

    name = "method"
    description = ""
    events = False
    gearsym = False

    def __init__(self, ctx: _Context):
        self.ctx = ctx
        self.rtol = 1e-8
        self.atol = 1e-10
        #: Wall-clock limit of one run of a Python right-hand side method (seconds).
        self.max_run_s = math.inf
        self._dl = _Deadline()

    def setup(self, rtol: float, atol: float) -> None:
        """Prepare for runs at these tolerances (not timed)."""
        self.rtol, self.atol = rtol, atol

    def run(self) -> RunOutput:
        """Integrate over the grid (timed)."""
        raise NotImplementedError


@dataclass
class _Context:
    system: Any
    pm: PythonModel | None
    x0: np.ndarray
    grid: np.ndarray
    params: dict[str, float] | None
    period: float | None


class GearsymMethod(Method):
    gearsym = True
    events = True

    def __init__(self, ctx: _Context, method: str = "adams"):
        super().__init__(ctx)
        self.method = method
        self.name = "gearsym" if method == "adams" else f"gearsym ({method})"
        self.description = (f"System.simulate(method='{method}'): generated C + SUNDIALS CVODE "
                            f"{'Adams' if method == 'adams' else 'BDF'}, located events and breakpoints, "
                            "one C call (compile excluded)")

    def run(self) -> RunOutput:
        c = self.ctx
        tr = c.system.simulate(t_end=float(c.grid[-1]), t0=float(c.grid[0]), x0=c.x0, rtol=self.rtol,
                               atol=self.atol, t_out=c.grid, method=self.method, params=c.params)
        s = tr.stats
        return RunOutput(np.asarray(tr.y), {"n_steps": int(s["n_steps"]), "n_rhs": int(s["n_rhs"]),
                                            "n_events": len(tr.events)})


class ScipyEventsMethod(Method):
    name = "scipy DOP853 + events"
    description = ("solve_ivp DOP853 on the modal right-hand side (lambdify), terminal events on every "
                   "switching surface, restarted in the new mode and at every breakpoint (in Python)")
    events = True

    def run(self) -> RunOutput:
        c = self.ctx
        assert c.pm is not None
        self._dl.start(self.max_run_s)
        sol = solve_with_events(c.pm, c.x0, c.grid, t0=float(c.grid[0]), rtol=self.rtol, atol=self.atol,
                                deadline=self._dl)
        return RunOutput(sol.y, {"n_steps": None, "n_rhs": sol.n_rhs, "n_events": int(sol.event_t.size)})


class ScipyMethod(Method):
    def __init__(self, ctx: _Context, method: str):
        super().__init__(ctx)
        self.method = method
        self.name = f"scipy {method}"
        self.description = (f"solve_ivp(method='{method}', t_eval=grid), Python right-hand side with the "
                            "dead zone as an if (lambdify), no events")

    def setup(self, rtol: float, atol: float) -> None:
        super().setup(rtol, atol)
        assert self.ctx.pm is not None
        self._f = _guarded(self.ctx.pm.rhs_function(), self._dl)

    def run(self) -> RunOutput:
        from scipy.integrate import solve_ivp

        c = self.ctx
        self._dl.start(self.max_run_s)
        sol = solve_ivp(self._f, (float(c.grid[0]), float(c.grid[-1])), c.x0, method=self.method,
                        t_eval=c.grid, rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise RuntimeError(f"{self.name}: {sol.message}")
        return RunOutput(sol.y.T.copy(), {"n_steps": None, "n_rhs": int(sol.nfev)})


class SksundaeMethod(Method):
    name = "sksundae CVODE"
    description = "scikit-sundae sksundae.cvode.CVODE (BDF, dense), Python right-hand side (lambdify), no events"

    def setup(self, rtol: float, atol: float) -> None:
        from sksundae.cvode import CVODE

        super().setup(rtol, atol)
        assert self.ctx.pm is not None
        f = _guarded(self.ctx.pm.rhs_function(), self._dl)

        def rhsfn(t, y, yp):
            yp[:] = f(t, y)

        self._solver = CVODE(rhsfn, method="BDF", rtol=rtol, atol=atol, max_num_steps=1_000_000)

    def run(self) -> RunOutput:
        c = self.ctx
        self._dl.start(self.max_run_s)
        soln = self._solver.solve(c.grid, c.x0)
        if not soln.success:
            raise RuntimeError(f"{self.name}: {soln.message}")
        return RunOutput(np.asarray(soln.y, dtype=float).reshape(-1, c.x0.size).copy(),
                         {"n_steps": None, "n_rhs": int(soln.nfev)})


class CasadiMethod(Method):
    name = "CasADi cvodes"
    description = ("casadi.integrator('cvodes') over the whole horizon with the output grid, the model's "
                   "equations as an SX graph with if_else (sides from the sign of g), no events")

    def setup(self, rtol: float, atol: float) -> None:
        import casadi as ca

        super().setup(rtol, atol)
        c = self.ctx
        gen = c.system.generated
        if gen.implicit:
            raise NotImplementedError("implicit models: no explicit right-hand side for cvodes")
        nx = gen.nx
        t = ca.SX.sym("t")
        x = ca.SX.sym("x", nx)
        p = ca.SX.sym("p", len(gen.param_names))
        m: list[Any] = []
        if gen.nsw:
            g = gen.casadi_function("gs_sw")(t, x, p)
            m += [ca.if_else(g[j] >= 0, 1, -1) for j in range(gen.nsw)]
        sched = gen.casadi_function("gs_sched")(p)
        i = 0
        for s in gen.schedules:
            P = sched[i]
            br = [sched[i + 1 + k] for k in range(s["n_breaks"])]
            i += 1 + s["n_breaks"]
            n = ca.floor(t / P)
            ph = t / P - n
            seg = sum(ca.if_else(ph >= b, 1, 0) for b in br[1:]) if len(br) > 1 else ca.SX(0)
            m += [n, seg]
        mv = ca.vertcat(*m) if m else ca.SX(0, 1)
        ode = gen.casadi_function("gs_rhs")(t, x, p, mv)
        opts = {"reltol": rtol, "abstol": atol, "max_num_steps": 10_000_000}
        self._F = ca.integrator("F", "cvodes", {"x": x, "t": t, "p": p, "ode": ode}, float(c.grid[0]),
                                [float(v) for v in c.grid[1:]], opts)
        self._pv = c.system.param_vector(c.params)

    def run(self) -> RunOutput:
        c = self.ctx
        res = self._F(x0=c.x0, p=self._pv)
        xf = np.asarray(res["xf"], dtype=float)
        y = np.vstack([c.x0, xf.T])
        st = self._F.stats()
        return RunOutput(y, {"n_steps": int(st["nsteps"]), "n_rhs": int(st["nfevals"])})


#: Names of all methods, in table order.
METHOD_NAMES: tuple[str, ...] = ("gearsym", "gearsym (bdf)", "scipy DOP853 + events", "scipy RK45",
                                 "scipy DOP853", "scipy LSODA", "scipy Radau", "sksundae CVODE",
                                 "CasADi cvodes")


def make_methods(ctx: _Context, names: Sequence[str] | None = None) -> list[Method]:
    """The methods to compare (all of :data:`METHOD_NAMES` by default)."""
    names = list(names or METHOD_NAMES)
    out: list[Method] = []
    for n in names:
        if n == "gearsym":
            out.append(GearsymMethod(ctx, "adams"))
        elif n == "gearsym (bdf)":
            out.append(GearsymMethod(ctx, "bdf"))
        elif n == "scipy DOP853 + events":
            out.append(ScipyEventsMethod(ctx))
        elif n.startswith("scipy "):
            out.append(ScipyMethod(ctx, n.split(" ", 1)[1]))
        elif n == "sksundae CVODE":
            out.append(SksundaeMethod(ctx))
        elif n == "CasADi cvodes":
            out.append(CasadiMethod(ctx))
        else:
            raise ParameterError(f"unknown benchmark method '{n}' (have: {', '.join(METHOD_NAMES)})")
    return out


def parse_methods(text: str) -> list[str]:
    """Comma-separated method names, checked against :data:`METHOD_NAMES`."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    for n in names:
        if n not in METHOD_NAMES:
            raise ParameterError(f"--methods: unknown method '{n}' (have: {', '.join(METHOD_NAMES)})")
    if not any(n.startswith("gearsym") for n in names):
        names.insert(0, "gearsym")
    return names

