"""Peer integrators for the benchmark backlash oscillator, written the way users write them.

The oscillator (models/kahraman_singh.toml)::

    x'' + 2*zeta*x' + (1 + eps*cos(Omega*t)) * f(x) = Fm + Fa*Omega**2*cos(Omega*t)
    f(x) = x - b (x > b),  0 (|x| <= b),  x + b (x < -b)

Every peer integrates the whole horizon with a single right-hand side containing the
dead zone as an ``if`` / ``if_else`` -- no event location, no mode switching: what a
MATLAB ``ode45`` or ``scipy.solve_ivp`` user gets.  Each peer is a small object with
an untimed :meth:`Peer.setup` (building the integrator object, if the tool has one)
and a timed :meth:`Peer.run` returning the states on an output grid and the solver
statistics the tool reports.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["PEERS", "CasadiCvodes", "Peer", "PeerRun", "ScipyDOP853", "ScipyLSODA", "SksundaeCVODE"]


@dataclass
class PeerRun:
    """Output of one peer run.

    Attributes
    ----------
    y : ndarray, shape (n_grid, 2)
        States at the output grid.
    stats : dict
        Whatever counters the tool reports (``n_steps``, ``n_rhs``, ``n_jac``, ...);
        ``None`` where the tool does not report one.
    """

    y: np.ndarray
    stats: dict[str, int | None] = field(default_factory=dict)


class Peer:
    """Base class: one integrator of the benchmark oscillator.

    Parameters
    ----------
    params
        ``zeta, Fm, Fa, eps, b, Omega``.
    x0
        Initial state ``(x, v)`` at ``t = grid[0]``.
    grid
        Output times (increasing, ``grid[0]`` the start time).
    """

    #: Short name used in tables and JSON.
    name = "peer"
    #: One-line description of how it integrates.
    description = ""

    def __init__(self, params: Mapping[str, float], x0: Sequence[float], grid: Sequence[float]):
        self.p = {k: float(params[k]) for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega")}
        self.x0 = np.asarray(x0, dtype=float)
        self.grid = np.asarray(grid, dtype=float)
        self.rtol = 1e-8
        self.atol = 1e-10

    def setup(self, rtol: float, atol: float) -> None:
        """Prepare for runs at these tolerances (not timed)."""
        self.rtol, self.atol = rtol, atol

    def run(self) -> PeerRun:
        """Integrate over the grid (timed)."""
        raise NotImplementedError


def python_rhs(params: Mapping[str, float]):
    """``f(t, y)`` of the oscillator as a user writes it (numpy, an ``if`` for the dead zone)."""
    zeta, Fm, Fa, eps, b, Om = (float(params[k]) for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega"))

    def rhs(t, y):
        x, v = y
        if x > b:
            f = x - b
        elif x < -b:
            f = x + b
        else:
            f = 0.0
        c = np.cos(Om * t)
        return np.array([v, Fm + Fa * Om**2 * c - 2 * zeta * v - (1 + eps * c) * f])

    return rhs


class _Scipy(Peer):
    method = ""

    def run(self) -> PeerRun:
        from scipy.integrate import solve_ivp

        sol = solve_ivp(python_rhs(self.p), (self.grid[0], self.grid[-1]), self.x0, method=self.method,
                        t_eval=self.grid, rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise RuntimeError(f"{self.name}: {sol.message}")
        return PeerRun(sol.y.T.copy(), {"n_steps": None, "n_rhs": int(sol.nfev), "n_jac": int(sol.njev)})


class ScipyDOP853(_Scipy):
    name = "scipy DOP853"
    description = "scipy.integrate.solve_ivp(method='DOP853'), Python RHS, no events, t_eval grid"
    method = "DOP853"


class ScipyLSODA(_Scipy):
    name = "scipy LSODA"
    description = "scipy.integrate.solve_ivp(method='LSODA'), Python RHS, no events, t_eval grid"
    method = "LSODA"


class SksundaeCVODE(Peer):
    name = "sksundae CVODE"
    description = "scikit-sundae sksundae.cvode.CVODE (BDF, dense), Python RHS, no events, output grid"

    def setup(self, rtol: float, atol: float) -> None:
        from sksundae.cvode import CVODE

        super().setup(rtol, atol)
        f = python_rhs(self.p)

        def rhsfn(t, y, yp):
            yp[:] = f(t, y)

        self._solver = CVODE(rhsfn, method="BDF", rtol=rtol, atol=atol, max_num_steps=1_000_000)

    def run(self) -> PeerRun:
        soln = self._solver.solve(self.grid, self.x0)
        if not soln.success:
            raise RuntimeError(f"{self.name}: {soln.message}")
        return PeerRun(np.asarray(soln.y, dtype=float).reshape(-1, 2).copy(),
                       {"n_steps": None, "n_rhs": int(soln.nfev), "n_jac": int(soln.njev)})


class CasadiCvodes(Peer):
    name = "CasADi cvodes"
    description = ("casadi.integrator('cvodes') over the whole horizon with the output grid, "
                   "if_else for the dead zone (one call)")

    def setup(self, rtol: float, atol: float) -> None:
        import casadi as ca

        super().setup(rtol, atol)
        x = ca.SX.sym("x", 2)
        t = ca.SX.sym("t")
        p = ca.SX.sym("p", 6)
        zeta, Fm, Fa, eps, b, Om = (p[i] for i in range(6))
        f = ca.if_else(x[0] > b, x[0] - b, ca.if_else(x[0] < -b, x[0] + b, 0))
        c = ca.cos(Om * t)
        ode = ca.vertcat(x[1], Fm + Fa * Om**2 * c - 2 * zeta * x[1] - (1 + eps * c) * f)
        opts = {"reltol": rtol, "abstol": atol, "max_num_steps": 10_000_000}
        self._F = ca.integrator("F", "cvodes", {"x": x, "t": t, "p": p, "ode": ode},
                                float(self.grid[0]), [float(v) for v in self.grid[1:]], opts)
        self._pv = [self.p[k] for k in ("zeta", "Fm", "Fa", "eps", "b", "Omega")]

    def run(self) -> PeerRun:
        res = self._F(x0=self.x0, p=self._pv)
        xf = np.asarray(res["xf"], dtype=float)  # (2, n_grid - 1)
        y = np.vstack([self.x0, xf.T])
        st = self._F.stats()
        return PeerRun(y, {"n_steps": int(st["nsteps"]), "n_rhs": int(st["nfevals"]),
                           "n_jac": int(st["n_call_jacF"])})


#: All peers, in table order.
PEERS: list[type[Peer]] = [ScipyDOP853, ScipyLSODA, SksundaeCVODE, CasadiCvodes]


def _selfcheck() -> None:  # pragma: no cover - manual use
    p = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}
    grid = 2 * math.pi / 0.9 * np.arange(11)
    for cls in PEERS:
        peer = cls(p, [1.1, 0.0], grid)
        peer.setup(1e-8, 1e-10)
        r = peer.run()
        print(f"{cls.name:16s} {r.y[-1]} {r.stats}")


if __name__ == "__main__":  # pragma: no cover
    _selfcheck()
