"""Pseudo-arclength continuation of periodic orbits in one run-time parameter.

The branch is the solution set of ``F(u, lambda) = 0`` with ``F`` the shooting
residual ``phi(t0 + P(lambda), t0, x0; lambda) - x0`` (or its multiple-shooting
form, or the harmonic-balance residual).  ``P(lambda)`` is ``periods`` forcing
periods *at the current parameter value*, so when the parameter is the forcing
frequency the orbit period follows it.  The method (Keller's pseudo-arclength,
in variables scaled by the state magnitudes and the parameter range):

* **predictor**: a step ``ds`` along the unit tangent ``t`` (the null vector of
  ``[F_u, F_lambda]``, oriented by the previous tangent);
* **corrector**: Newton on ``F = 0`` together with ``t . (w - w_pred) = 0``: the
  new point lies on the hyperplane through the prediction orthogonal to the
  tangent, so turning points (folds) are passed without special treatment.
  ``F_u`` is the monodromy minus the identity from the engine's variational
  equations (with saltation matrices), ``F_lambda`` a central difference;
* **step control**: the step grows after easy corrections (<= 3 Newton steps)
  and shrinks after hard ones; a step is rejected (and halved) when Newton
  fails, the integration fails, or the tangent turns by more than
  ``max_angle`` -- which keeps the steps small where the branch turns sharply,
  e.g. next to grazing points where the multipliers of a non-smooth system
  change like a square root;
* **parameter steps where no fold is possible**: when no Floquet multiplier is
  near +1 (none within 0.2 at the last point, none crossed +1 since the point
  before), the implicit function theorem makes the branch a graph over the
  parameter; if the orbit's state also moves fast with the parameter (a
  rattling orbit whose impacts appear and disappear), the predictor-corrector
  steps in the parameter itself (Newton at fixed parameter), and the tangent is
  oriented so that the parameter keeps its direction.  A step in which a real
  multiplier crosses +1 is redone with the arclength.

**The branch must advance**: the continuation ends with ``complete = False`` and the
reason in ``Branch.stop_reason`` when the step size falls below ``ds_min``, when
``max_points`` is reached before the range is left, or when the parameter stays within
``stall_tol`` of the range over ``stall_points`` consecutive points (the orbit grows
without bound while the parameter converges: an undamped system at resonance, where
the branch never reaches the other side).

Between two accepted points the test functions of
:mod:`gearsym.analysis.bifurcation` are compared; a sign change is *located*
by solving ``tau(sigma) = 0`` in the arclength ``sigma`` (each evaluation is a
corrected point on the hyperplane ``t_A . (w - w_A) = sigma``), and the located
point is inserted into the branch: folds (tangent's parameter component),
period doublings, Neimark-Sacker points, branch points, and grazings (the
extremum of a switching function over the orbit crosses zero).  If the number of
unstable multipliers changes between two points without any located special
point (a multiplier jumping at a non-smooth point), the change is located by
bisection and classified by the multiplier that crossed.

At a period doubling, :func:`switch_period_doubling` starts the branch of the
doubled orbit: at the located point the ``2k``-period map has the multiplier
``(-1)^2 = 1`` with the eigenvector ``v`` of ``-1``; the new branch leaves the old
one along ``(v, 0)``, so the first corrector runs on the hyperplane orthogonal
to that direction a small distance away, and the continuation proceeds from
there (until the parameter range is left or the doubled orbit merges back into
the period-``k`` branch).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ConvergenceError, GearsymError, ParameterError
from .bifurcation import (
    bracket_root,
    crossing_multiplier,
    tau_branch_point,
    tau_neimark_sacker,
    tau_period_doubling,
    unit_circle_pair,
)
from .branch import Bifurcation, Branch, BranchPoint
from .floquet import monodromy_product
from .meshes import mesh_point
from .orbit import PeriodicOrbit, rattle_states
from .stability import complex_sides, floquet, neutral_step_limit, rigid_state_basis
from .stall import QUICK_STALL, stalled_branch

if TYPE_CHECKING:  # pragma: no cover
    from ..facade import Scene
    from ..system import System

__all__ = ["continuation", "switch_period_doubling", "HBResidual", "ShootingResidual"]

_ALL_TYPES = ("fold", "period_doubling", "neimark_sacker", "grazing", "branch_point")


# =====================================================================================
# residuals
# =====================================================================================
@dataclass
class _Eval:
    """One evaluation of a residual: ``R``, ``F_u``, ``F_lambda`` and what the point needs."""

    R: np.ndarray
    Fu: np.ndarray | None
    Flam: np.ndarray | None
    monodromy: np.ndarray | None = None
    events: list = field(default_factory=list)


class _Residual:
    """Interface of a continuation residual ``F(u, lambda)``."""

    #: steps in the parameter itself where no multiplier is near +1 (see :func:`_run`)
    natural_steps = True

    system: System
    param: str
    periods: float
    t0: float
    n: int

    def params(self, lam: float) -> dict[str, float]:
        p = dict(self.base_params)
        p[self.param] = float(lam)
        return p

    def period(self, lam: float) -> float:
        cache = self.__dict__.setdefault("_period_cache", {})
        T = cache.get(lam)
        if T is None:
            T = self.system.period(self.params(lam))
            if not T:
                T = self.system.require_period(self.params(lam), "continuation of periodic orbits")
            if len(cache) > 64:
                cache.clear()
            cache[lam] = T
        return float(self.periods) * T

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True
                 ) -> _Eval:  # pragma: no cover
        raise NotImplementedError

    def x0_of(self, u: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        """``(t, Y)``: the orbit on ``n`` evenly spaced times of one period (end excluded)."""
        raise NotImplementedError  # pragma: no cover

    def rigid_basis(self, lam: float) -> np.ndarray | None:
        """The rigid-body subspace of the state at ``lambda`` (``None`` without rigid-body modes)."""
        return rigid_state_basis(self.system, self.params(lam))

    def anchor_rows(self, lam: float) -> np.ndarray | None:
        """Rows ``(k, n)`` that pin the rigid-body coordinates of the orbit (one per mode):
        without them ``F_u`` is singular along the rigid-body shift."""
        V = self.rigid_basis(lam)
        if V is None:
            return None
        k = V.shape[1] // 2
        Pq = V[:, :k] / np.linalg.norm(V[:, :k], axis=0)
        out = np.zeros((k, self.n))
        for j, i in enumerate(self._anchor_index()):
            out[:, i] = Pq[j]
        return out

    def _anchor_index(self) -> list[int]:
        """Index in the unknowns of the quantity of each state the anchor acts on."""
        raise NotImplementedError  # pragma: no cover

    def _fd_lambda(self, u: np.ndarray, lam: float, R: np.ndarray | None = None) -> np.ndarray:
        """``dF/dlambda`` by a forward difference from ``R = F(u, lambda)`` (central without it)."""
        h = self.fd_step
        Rp = self.evaluate(u, lam + h, jac=False).R
        if R is not None:
            return (Rp - R) / h
        Rm = self.evaluate(u, lam - h, jac=False).R
        return (Rp - Rm) / (2 * h)


class ShootingResidual(_Residual):
    """``F(X, lambda)``: the (multiple) shooting residual of ``periods`` forcing periods.

    Parameters
    ----------
    system
        The compiled system.
    param
        The continuation parameter (a run-time parameter of ``system``).
    periods
        Forcing periods per orbit.
    params
        Other parameter overrides (SI).
    segments
        Shooting segments (1: single shooting); the unknowns are the states at
        the segment starts.
    t0
        Phase of the orbit's reference state.
    rtol, atol
        Integrator tolerances.
    fd_step
        Step of the central difference ``F_lambda``.
    method
        Integrator.
    """

    def __init__(self, system: System, param: str, periods: float = 1, params: Mapping[str, float] | None = None,
                 segments: int = 1, t0: float = 0.0, rtol: float = 1e-10, atol: float = 1e-12,
                 fd_step: float = 1e-6, method: str | None = None):
        self.system = system
        self.param = param
        self.periods = float(periods)
        self.base_params = dict(params or {})
        self.segments = int(segments)
        if self.segments < 1:
            raise ParameterError(f"segments must be >= 1, got {segments}")
        self.t0 = float(t0)
        self.rtol, self.atol = float(rtol), float(atol)
        self.fd_step = float(fd_step)
        self.method = method
        self.nx = system.generated.nx
        self.n = self.segments * self.nx
        self.n_evals = 0
        self.n_integrations = 0

    def times(self, lam: float) -> np.ndarray:
        P = self.period(lam)
        s = self.t0 + P * np.arange(self.segments + 1) / self.segments
        s[-1] = self.t0 + P
        return s

    def x0_of(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(u[: self.nx], float)

    def _anchor_index(self) -> list[int]:
        return list(range(self.nx))  # the states of the first segment

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:
        return np.tile(state_scale, self.segments)

    def u_from_orbit(self, x0: np.ndarray, lam: float) -> np.ndarray:
        """Unknowns (segment start states) of the orbit through ``x0``."""
        if self.segments == 1:
            return np.asarray(x0, float).copy()
        s = self.times(lam)
        tr = self.system.simulate(t_end=s[-1], t0=s[0], x0=x0, rtol=self.rtol, atol=self.atol, t_out=s,
                                  params=self.params(lam), method=self.method)
        return np.asarray(tr.y[:-1], float).ravel()

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True) -> _Eval:
        N, nx = self.segments, self.nx
        X = np.asarray(u, float).reshape(N, nx)
        s = self.times(lam)
        p = self.params(lam)
        xs, Ms, evs = [], [], []
        for i in range(N):
            tr = self.system.simulate(t_end=s[i + 1], t0=s[i], x0=X[i], rtol=self.rtol, atol=self.atol,
                                      n_out=2, params=p, monodromy=jac, method=self.method)
            self.n_integrations += 1
            xs.append(tr.x_final)
            Ms.append(tr.monodromy)
            evs.extend(tr.events)
        R = np.concatenate([xs[i] - X[(i + 1) % N] for i in range(N)])
        self.n_evals += 1
        if not jac:
            return _Eval(R, None, None, events=evs)
        if any(M is None for M in Ms):
            raise GearsymError("the engine returned no monodromy (implicit models are not supported by "
                               "continuation yet)")
        J = np.zeros((N * nx, N * nx))
        for i in range(N):
            J[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = Ms[i]
            k = (i + 1) % N
            J[i * nx:(i + 1) * nx, k * nx:(k + 1) * nx] -= np.eye(nx)
        Flam = self._fd_lambda(u, lam, R) if dlam else None
        return _Eval(R, J, Flam, monodromy=monodromy_product(Ms), events=evs)

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        N, nx = self.segments, self.nx
        X = np.asarray(u, float).reshape(N, nx)
        s = self.times(lam)
        p = self.params(lam)
        n_seg = max(8, int(math.ceil(n_per_period * self.periods / N)))
        ts, ys = [], []
        for i in range(N):
            grid = np.linspace(s[i], s[i + 1], n_seg + 1)
            tr = self.system.simulate(t_end=s[i + 1], t0=s[i], x0=X[i], rtol=self.rtol, atol=self.atol,
                                      t_out=grid, params=p, method=self.method)
            self.n_integrations += 1
            ts.append(grid[:-1])
            ys.append(tr.y[:-1])
        return np.concatenate(ts), np.vstack(ys)


class HBResidual(_Residual):
    """``F(C, lambda)``: the harmonic-balance (AFT) residual with ``H`` harmonics.

    The unknowns are the Fourier coefficients of every state (state-major, as
    :class:`gearsym.analysis.hbm.HarmonicBalance`); the base frequency is
    ``2*pi/P(lambda)``.  The Floquet multipliers of each point come from one
    integration of the variational equations from the series' ``x(t0)``.

    No steps in the parameter itself and no orientation of the tangent by them: those
    multipliers belong to the integrated orbit, not to the truncated balance, whose own
    fold can lie where none of them is near +1.
    """

    natural_steps = False

    def __init__(self, system: System, param: str, harmonics: int, periods: float = 1,
                 params: Mapping[str, float] | None = None, t0: float = 0.0, samples: int | None = None,
                 rtol: float = 1e-10, atol: float = 1e-12, fd_step: float = 1e-6):
        self.system = system
        self.param = param
        self.periods = float(periods)
        self.base_params = dict(params or {})
        self.H = int(harmonics)
        self.samples = samples
        self.t0 = float(t0)
        self.rtol, self.atol = float(rtol), float(atol)
        self.fd_step = float(fd_step)
        self.nx = system.generated.nx
        self.nc = 2 * self.H + 1
        self.n = self.nx * self.nc
        self._cache: dict[float, Any] = {}
        self.n_evals = 0
        self.n_integrations = 0

    def _hb(self, lam: float):
        from .hbm import HarmonicBalance

        hb = self._cache.get(lam)
        if hb is None:
            if len(self._cache) > 8:
                self._cache.clear()
            hb = HarmonicBalance(self.system, self.period(lam), self.H, self.params(lam), self.t0, self.samples)
            self._cache[lam] = hb
        return hb

    def coefficients(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(u, float).reshape(self.nx, self.nc).T

    def _anchor_index(self) -> list[int]:
        return [i * self.nc for i in range(self.nx)]  # the mean (a0) of every state

    def x0_of(self, u: np.ndarray) -> np.ndarray:
        C = self.coefficients(u)
        return C[0] + sum(C[2 * k - 1] for k in range(1, self.H + 1)) if self.H else C[0].copy()

    def unknown_scale(self, state_scale: np.ndarray) -> np.ndarray:
        return np.repeat(state_scale, self.nc)

    def u_from_orbit(self, orbit: PeriodicOrbit | np.ndarray, lam: float) -> np.ndarray:
        if isinstance(orbit, PeriodicOrbit) and orbit.coefficients is not None and \
                orbit.coefficients.shape[0] == self.nc:
            return orbit.coefficients.T.ravel().copy()
        x0 = orbit.x0 if isinstance(orbit, PeriodicOrbit) else np.asarray(orbit, float)
        P = self.period(lam)
        n = max(64, 8 * self.H)
        tr = self.system.simulate(t_end=self.t0 + P, t0=self.t0, x0=x0, rtol=self.rtol, atol=self.atol,
                                  n_out=n + 1, params=self.params(lam))
        y = tr.y[:-1]
        Cf = np.fft.rfft(y, axis=0) / n
        C = np.zeros((self.nc, self.nx))
        C[0] = Cf[0].real
        for k in range(1, self.H + 1):
            C[2 * k - 1] = 2 * Cf[k].real
            C[2 * k] = -2 * Cf[k].imag
        return C.T.ravel()

    def evaluate(self, u: np.ndarray, lam: float, jac: bool = True, dlam: bool = True) -> _Eval:
        hb = self._hb(lam)
        C = self.coefficients(u)
        R = hb.residual(C).T.ravel()
        self.n_evals += 1
        if not jac:
            return _Eval(R, None, None)
        J = hb.jacobian(C)
        Flam = self._fd_lambda(u, lam, R) if dlam else None
        x0 = self.x0_of(u)
        mono, events = None, []
        try:
            tr = self.system.simulate(t_end=self.t0 + hb.P, t0=self.t0, x0=x0, rtol=self.rtol, atol=self.atol,
                                      n_out=2, params=self.params(lam), monodromy=True)
            self.n_integrations += 1
            mono, events = tr.monodromy, list(tr.events)
        except GearsymError:
            pass
        return _Eval(R, J, Flam, monodromy=mono, events=events)

    def dense(self, u: np.ndarray, lam: float, n_per_period: int) -> tuple[np.ndarray, np.ndarray]:
        P = self.period(lam)
        n = max(64, int(n_per_period * self.periods))
        th = 2 * np.pi * np.arange(n) / n
        C = self.coefficients(u)
        Y = np.tile(C[0], (n, 1))
        for k in range(1, self.H + 1):
            Y += np.outer(np.cos(k * th), C[2 * k - 1]) + np.outer(np.sin(k * th), C[2 * k])
        return self.t0 + th / (2 * np.pi) * P, Y


# =====================================================================================
# points
# =====================================================================================
def _periodic_extremum(y: np.ndarray, i: int, sign: float) -> float:
    """Parabolic refinement of a sample extremum of a periodic sequence."""
    n = len(y)
    a, b, c = y[(i - 1) % n], y[i], y[(i + 1) % n]
    den = a - 2 * b + c
    if den * sign < 0:
        return float(b - 0.125 * (c - a) ** 2 / den)
    return float(b)


@dataclass
class _Node:
    """A point of the branch with what the continuation needs."""

    z: np.ndarray          # (u, lambda), unscaled
    ev: _Eval
    point: BranchPoint
    t: np.ndarray          # unit tangent, scaled variables
    tau: dict[str, float]
    iterations: int = 0
    scale: np.ndarray | None = None
    graph: bool = False    # the branch is a graph over the parameter between the previous point and this


class _Continuer:
    """The predictor-corrector machinery on one residual."""

    def __init__(self, res: _Residual, *, lam_scale: float, tol: float, max_newton: int, state: int,
                 n_dense: int, detect: Sequence[str], state_weight: float = 1.0):
        self.res = res
        self.lam_scale = float(lam_scale)
        self.tol = float(tol)
        self.max_newton = int(max_newton)
        self.state = int(state)
        self.n_dense = int(n_dense)
        self.detect = tuple(detect)
        gen = res.system.generated
        self.surfaces = [s["name"] for s in gen.surfaces]
        self._sw_fn = gen.casadi_function("gs_sw") if gen.nsw else None
        self._sw_maps: dict[int, Any] = {}
        self.state_weight = float(state_weight)
        self.state_scale = np.ones(res.nx)
        self.Rs = np.ones(res.n)
        self.S = np.ones(res.n + 1)
        self.S[-1] = self.lam_scale

    # ------------------------------------------------------------ scaling
    def set_state_scale(self, state_scale: np.ndarray) -> None:
        """Scales: residual rows by the state magnitudes, unknowns by them over ``state_weight``.

        A magnitude is at least ``atol / tol`` (as in shooting's convergence test): the
        integration resolves no state better than ``atol``, so a state that vanishes on
        the orbit (e.g. by symmetry) must not demand a scaled residual below ``tol``
        from integration noise.  (With the default ``atol`` the floor is 1e-3 of the
        smallest magnitude and never binds.)
        """
        floor = float(getattr(self.res, "atol", 0.0)) / self.tol
        self.state_scale = np.maximum(np.asarray(state_scale, float), floor)
        self.Rs = self.res.unknown_scale(self.state_scale)
        self.S = np.concatenate([self.Rs / self.state_weight, [self.lam_scale]])
        self.__dict__.pop("_anchor_cache", None)

    def scaled_jacobian(self, ev: _Eval) -> np.ndarray:
        """``[F_u, F_lambda]`` in scaled variables, rows scaled by the state magnitudes."""
        J = np.hstack([ev.Fu, ev.Flam[:, None]]) * self.S[None, :]
        return J / self.Rs[:, None]

    def scaled_residual(self, ev: _Eval) -> np.ndarray:
        return ev.R / self.Rs

    def scaled_anchor(self, lam: float) -> np.ndarray | None:
        """Anchor rows of the residual in scaled variables (unit rows; ``None`` without)."""
        key = float(lam)
        cache = self.__dict__.setdefault("_anchor_cache", {})
        if key not in cache:
            if len(cache) > 32:
                cache.clear()
            rows = self.res.anchor_rows(key)
            if rows is not None:
                rows = np.hstack([rows * self.S[None, :-1], np.zeros((len(rows), 1))])
                rows = rows / np.linalg.norm(rows, axis=1)[:, None]
            cache[key] = rows
        return cache[key]

    # ------------------------------------------------------------ corrector
    def correct(self, z_guess: np.ndarray, row: np.ndarray, target: float, Flam: np.ndarray | None = None
                ) -> tuple[np.ndarray, _Eval, int]:
        """Newton on ``F(z) = 0``, ``row . (z / S) = target``.

        ``F_lambda`` (a finite difference, the costly column) is computed at the first
        iterate and kept (chord) until convergence, then recomputed at the solution
        for the tangent.  A residual at the integrator's noise floor (a Newton step
        below ``tol`` that no longer reduces it, up to ``100 * tol``) is accepted.

        Raises
        ------
        ConvergenceError, GearsymError
            No convergence (step to be rejected).
        """
        z = np.asarray(z_guess, float).copy()
        ev = self.res.evaluate(z[:-1], z[-1], dlam=Flam is None)
        if Flam is None:
            Flam = ev.Flam
        r = float(np.max(np.abs(self.scaled_residual(ev))))
        c = float(row @ (z / self.S) - target)
        it = 0
        r_prev = math.inf
        step = math.inf
        while True:
            if not math.isfinite(r):
                raise ConvergenceError("non-finite residual in the corrector")
            if (r <= self.tol or (step <= self.tol and r <= 100 * self.tol)) and abs(c) <= 1e-9:
                if ev.Flam is None:
                    ev.Flam = self.res._fd_lambda(z[:-1], float(z[-1]), ev.R)
                return z, ev, it
            if it >= self.max_newton:
                raise ConvergenceError(f"corrector: no convergence in {it} Newton steps (residual {r:.3g})")
            if it >= 2 and r > 0.9 * r_prev and r > 100 * self.tol:
                raise ConvergenceError(f"corrector: Newton diverges (residual {r_prev:.3g} -> {r:.3g})")
            if ev.Flam is None:
                ev.Flam = Flam
            anchor = self.scaled_anchor(z[-1])
            if anchor is None:
                A = np.vstack([self.scaled_jacobian(ev), row[None, :]])
                rhs = -np.concatenate([self.scaled_residual(ev), [c]])
                try:
                    dw = np.linalg.solve(A, rhs)
                except np.linalg.LinAlgError:
                    dw = np.linalg.lstsq(A, rhs, rcond=None)[0]
            else:  # rigid-body modes: keep their coordinates where they are (least squares)
                A = np.vstack([self.scaled_jacobian(ev), anchor, row[None, :]])
                rhs = -np.concatenate([self.scaled_residual(ev), np.zeros(len(anchor)), [c]])
                dw = np.linalg.lstsq(A, rhs, rcond=None)[0]
            if not np.all(np.isfinite(dw)):
                raise ConvergenceError("corrector: singular Newton matrix")
            step = float(np.max(np.abs(dw)))
            it += 1
            r_prev = r
            # damped step: halve it (up to 3 times) while the residual grows
            for k in range(4):
                zn = z + dw * self.S * 0.5 ** k
                try:
                    evn = self.res.evaluate(zn[:-1], zn[-1], dlam=False)
                    rn = float(np.max(np.abs(self.scaled_residual(evn))))
                except GearsymError:
                    if k == 3:
                        raise
                    continue
                if rn < r or k == 3 or rn <= self.tol:
                    break
            z, ev, r = zn, evn, rn
            c = float(row @ (z / self.S) - target)

    def tangent(self, ev: _Eval, t_ref: np.ndarray, lam: float | None = None) -> np.ndarray:
        """Unit null vector of the scaled ``[F_u, F_lambda]`` with ``t . t_ref > 0`` (and, with
        rigid-body modes, no component along their shift: anchor rows at ``lam``)."""
        anchor = self.scaled_anchor(lam) if lam is not None else None
        A = np.vstack([self.scaled_jacobian(ev)] + ([anchor] if anchor is not None else []) + [t_ref[None, :]])
        b = np.zeros(A.shape[0])
        b[-1] = 1.0
        if anchor is not None:
            t = np.linalg.lstsq(A, b, rcond=None)[0]
        else:
            try:
                t = np.linalg.solve(A, b)
            except np.linalg.LinAlgError:
                t = np.linalg.lstsq(A, b, rcond=None)[0]
        if not np.all(np.isfinite(t)) or not np.any(t):
            # fall back on the smallest right singular vector
            _, _, Vt = np.linalg.svd(self.scaled_jacobian(ev))
            t = Vt[-1]
        t = t / np.linalg.norm(t)
        if t @ t_ref < 0:
            t = -t
        return t

    # ------------------------------------------------------------ points
    def _sw_map(self, n: int):
        f = self._sw_maps.get(n)
        if f is None:
            f = self._sw_fn.map(n)
            self._sw_maps[n] = f
        return f

    def make_node(self, z: np.ndarray, ev: _Eval, t_ref: np.ndarray, iterations: int = 0,
                  ref: _Node | None = None) -> _Node:
        """Post-process a corrected point: multipliers, extrema, grazing tests, tangent.

        The tangent is oriented along ``t_ref``; but when neither this point nor
        ``ref`` (the previous point) has a multiplier near +1 and no real multiplier
        crossed +1 between them, the branch is locally a graph over the parameter
        (implicit function theorem: no turning point is possible), and the
        tangent is oriented so that the parameter keeps its direction -- a rattling
        orbit whose state moves fast and erratically with the parameter could
        otherwise flip it and send the continuation backwards.
        """
        res = self.res
        u, lam = z[:-1], float(z[-1])
        fq = floquet(ev.monodromy, res.rtol, res.rigid_basis(lam))
        mu = fq.multipliers
        t_dense, Y = res.dense(u, lam, self.n_dense)
        y = Y[:, self.state]
        i_max, i_min = int(np.argmax(y)), int(np.argmin(y))
        params = res.params(lam)
        ext: dict[str, tuple[float, float]] = {}
        if self._sw_fn is not None:
            p = res.system.param_vector(params)
            G = np.asarray(self._sw_map(len(t_dense))(t_dense[None, :], Y.T,
                                                      np.tile(p[:, None], (1, len(t_dense)))))
            for j, name in enumerate(self.surfaces):
                g = G[j]
                ext[name] = (_periodic_extremum(g, int(np.argmin(g)), +1.0),
                             _periodic_extremum(g, int(np.argmax(g)), -1.0))
        x0 = res.x0_of(u)
        try:
            rss = rattle_states(res.system, x0, res.t0, ev.events, params)
        except Exception:  # noqa: BLE001 - the classification is informative only
            rss = {}
        meshes = mesh_point(res.system, t_dense, Y, params, rss)
        t = self.tangent(ev, t_ref, lam)
        if res.natural_steps and ref is not None and _graph_like(mu, ref.point.multipliers) \
                and ref.t[-1] * t[-1] < 0:
            t = -t
        pt = BranchPoint(
            value=lam, x0=np.asarray(x0, float), period=res.period(lam), periods=res.periods, multipliers=mu,
            stable=fq.stable, n_unstable=fq.n_unstable,
            max=_periodic_extremum(y, i_max, -1.0), min=_periodic_extremum(y, i_min, +1.0),
            rms=float(np.sqrt(np.mean(y ** 2))), rattle_state=max(rss.values()) if rss else None,
            n_events=len(ev.events),
            surface_extrema=ext, tangent=t, residual=float(np.max(np.abs(self.scaled_residual(ev)))),
            iterations=iterations, u=np.asarray(u, float).copy(), monodromy=ev.monodromy,
            stability=fq.stability, trivial_multipliers=fq.trivial, multiplier_tolerances=fq.tolerances,
            meshes=meshes)
        tau: dict[str, float] = {"fold": float(t[-1])}
        if len(mu):
            tau["period_doubling"] = tau_period_doubling(mu)
            tau["neimark_sacker"] = tau_neimark_sacker(mu)
            tau["branch_point"] = tau_branch_point(mu)
        for name, (gmin, gmax) in ext.items():
            tau[f"grazing|{name}|min"] = gmin
            tau[f"grazing|{name}|max"] = gmax
        return _Node(z=np.asarray(z, float).copy(), ev=ev, point=pt, t=t, tau=tau, iterations=iterations,
                     scale=np.maximum(np.max(np.abs(Y), axis=0), np.ptp(Y, axis=0)))


# =====================================================================================
# the continuation loop
# =====================================================================================
class _Progress:
    def __init__(self, enabled: bool | None, start: float, stop: float, param: str):
        self.bar = None
        if enabled is None:
            enabled = bool(getattr(sys.stderr, "isatty", lambda: False)())
        if enabled:
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=1000, desc=f"continuation in {param}", file=sys.stderr, leave=False,
                                bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} [{elapsed}]")
            except ImportError:  # pragma: no cover
                self.bar = None
        self.start, self.stop = start, stop
        self.done = 0

    def update(self, lam: float, n_points: int, n_bif: int) -> None:
        if self.bar is None:
            return
        span = self.stop - self.start
        frac = 0.0 if span == 0 else min(max((lam - self.start) / span, 0.0), 1.0)
        k = int(1000 * frac)
        if k > self.done:
            self.bar.update(k - self.done)
            self.done = k
        self.bar.set_postfix_str(f"value={lam:.6g} points={n_points} bifurcations={n_bif}", refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _as_system(target: System | Scene) -> System:
    if hasattr(target, "simulate"):
        return target  # type: ignore[return-value]
    if hasattr(target, "compile"):
        return target.compile()  # type: ignore[union-attr]
    raise ParameterError("continuation needs a compiled System (scene.compile()) or a Scene")


def continuation(system: System | Scene, param: str, start: float, stop: float, *,
                 x0: Sequence[float] | None = None, orbit: PeriodicOrbit | None = None, periods: float = 1,
                 method: str = "shooting", params: Mapping[str, float] | None = None, segments: int = 1,
                 harmonics: int | None = None, t0: float = 0.0, ds: float = 0.005, ds_min: float = 1e-7,
                 ds_max: float = 0.02, max_angle: float = 0.3, max_points: int = 5000, tol: float = 1e-9,
                 rtol: float = 1e-10, atol: float | None = None, max_newton: int = 7,
                 detect: Sequence[str] | bool = True, locate: bool = True, state: int | str = 0,
                 n_dense: int | None = None, switch: int = 0, progress: bool | None = None,
                 transient: float | None = None, state_weight: float = 1.0, stall_points: int = 50,
                 stall_tol: float = 1e-5, display: tuple[float, str] | None = None,
                 defect_tol: float = 1e-5) -> Branch:
    """Continue a periodic orbit in one parameter from ``start`` to ``stop``.

    Parameters
    ----------
    system
        Compiled system (or a scene, compiled here).
    param
        Name of the run-time parameter to vary (SI units).  When the forcing
        period depends on it, the orbit period follows it.
    start, stop
        Parameter range: the branch starts at ``start`` and ends when it leaves
        the range (through ``stop``, after any number of turning points, or back
        through ``start``).
    x0
        Initial guess of the orbit's state at ``t0`` for ``param = start``
        (default: the scene's initial state after a transient).
    orbit
        A periodic orbit at ``param = start`` to start from (instead of solving).
    periods
        Forcing periods per orbit (``k`` for period-``k`` orbits).
    method
        ``"shooting"`` (single / multiple shooting, ``segments``) or ``"hbm"``
        (harmonic balance with ``harmonics`` harmonics).
    params
        Other parameter overrides (SI).
    segments
        Shooting segments.
    harmonics
        Harmonics of the harmonic-balance residual.  Default: those with which the
        starting harmonic balance meets ``defect_tol`` (its harmonics grown until one
        period integrated from the balanced state closes to ``defect_tol`` of the orbit's
        size): a margin for the orbit's growth along the branch.
    t0
        Phase of ``x0`` (a multiple of the forcing period).
    ds, ds_min, ds_max
        Initial, smallest and largest arclength step in scaled variables (the
        parameter scaled by ``|stop - start|``, every state by its magnitude on
        the branch): ``ds_max = 0.02`` gives at least 50 points over the range.
    max_angle
        Largest angle (rad) between consecutive tangents before a step is refused.
    max_points
        Limit on the number of points.
    tol
        Corrector tolerance on the residual scaled by the state magnitudes.
    rtol, atol
        Integrator tolerances.  ``atol`` default: ``rtol * 1e-2 *`` the smallest state
        magnitude on the first orbit; a state that is identically zero there (the
        trivial orbit ``x = 0``) takes its magnitude from the scene instead: the
        largest entry of its initial state, else the magnitude its ``[simulate]``
        tolerances imply (``atol / (1e-2 * rtol)``), else 1.
    max_newton
        Newton steps per correction.
    detect
        Bifurcation types to detect (``True``: all of ``fold``,
        ``period_doubling``, ``neimark_sacker``, ``grazing``, ``branch_point``;
        ``False``: none).
    locate
        Locate detected points (else only flag the point after the change).
    state
        The observed state for ``max``, ``min``, ``rms`` (index or name).
    n_dense
        Samples per forcing period for extrema, RMS and grazing tests (default:
        ``max(1024, 8 * points_per_period of the scene)``).
    switch
        Depth of automatic branch switching at period doublings (0: none; 1: the
        doubled branches; 2: also their doublings, ...).
    progress
        Show a progress bar on stderr (default: when stderr is a terminal).
    state_weight
        Weight of the states against the parameter in the arclength (1: a step
        of one state magnitude counts as much as a step of the whole parameter
        range).  Smaller values take larger parameter steps where the orbit
        changes quickly (rattling orbits with many impacts).
    transient
        Forcing periods integrated before the first Newton solve when no ``x0``
        or ``orbit`` is given.
    stall_points, stall_tol
        The branch does not advance (``complete = False``) when the parameter stays
        within ``stall_tol * |stop - start|`` over ``stall_points`` consecutive points.
        Measured on a forced linear oscillator: with damping ratios down to 1e-4 the
        smallest spread over 50 points through the resonance peak is 1.9e-4 of the range;
        undamped, the parameter converges to the resonance and the branch stalls.
    defect_tol
        Time-domain defect of the starting harmonic balance (``method="hbm"``, see
        ``harmonics``).
    display
        ``(SI value of one display unit, unit name)`` for the parameter values in
        ``stop_reason`` (the CLI passes the model's declared unit); default SI.

    Returns
    -------
    Branch

    Raises
    ------
    ParameterError
        Unknown parameter, empty range, bad options.
    ConvergenceError
        No periodic orbit at ``start``.

    Notes
    -----
    A branch that stops early is returned, not raised: check ``branch.complete``.
    """
    system = _as_system(system)
    wall = time.perf_counter()
    if param not in system.params:
        raise ParameterError(f"'{param}' is not a run-time parameter of this system (have: "
                             f"{', '.join(system.params) or 'none'})")
    start, stop = float(start), float(stop)
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise ParameterError(f"the parameter range must be two different finite values, got {start} .. {stop}")
    if method not in ("shooting", "hbm"):
        raise ParameterError(f"method must be 'shooting' or 'hbm', got '{method}'")
    if system.generated.implicit:
        raise ParameterError("continuation needs an explicit model (variational equations for the monodromy)")
    types = _detect_types(detect)
    if method == "hbm" and detect is True:
        # the multipliers of a harmonic-balance point come from integrating its truncated
        # orbit, so +1 is crossed slightly away from the balance's own fold: no branch points
        types = tuple(t for t in types if t != "branch_point")
    if isinstance(state, str):
        if state not in system.state_names:
            raise ParameterError(f"state '{state}' is not a state of this system (have: "
                                 f"{', '.join(system.state_names)})")
        state_idx = system.state_names.index(state)
    else:
        state_idx = int(state)
        if not 0 <= state_idx < system.generated.nx:
            raise ParameterError(f"state index {state} out of range (0..{system.generated.nx - 1})")
    if not (0 < ds_min <= ds <= ds_max) or max_points < 2 or tol <= 0 or periods <= 0 or switch < 0 \
            or not 0 < state_weight or not 0 < max_angle or stall_points < 2 or not 0 <= stall_tol < 1:
        raise ParameterError("need 0 < ds_min <= ds <= ds_max, max_points >= 2, tol > 0, periods > 0, "
                             "switch >= 0, state_weight > 0, max_angle > 0, stall_points >= 2, "
                             "0 <= stall_tol < 1")
    from .shooting import _check_tolerances

    _check_tolerances(tol=tol, rtol=rtol, **({"atol": atol} if atol is not None else {}))
    base = dict(params or {})
    base.pop(param, None)
    p_start = dict(base)
    p_start[param] = start
    system.require_period(p_start, "continuation of periodic orbits")
    fmt = _formatter(display)

    # ------------------------------------------------------------- first orbit
    if n_dense is None:
        n_dense = max(1024, 8 * int(system.defaults.get("points_per_period", 64)))
    if method == "shooting":
        x_start, state_scale = _first_orbit_shooting(system, param, start, p_start, base, periods, x0, orbit,
                                                     segments, t0, rtol, atol, tol, transient)
        if atol is None:
            atol = _default_atol(rtol, state_scale)
        res: _Residual = ShootingResidual(system, param, periods, base, segments, t0, rtol, atol,
                                          fd_step=_fd_step(start, stop, rtol))
        u0 = res.u_from_orbit(x_start, start)  # type: ignore[attr-defined]
    else:
        if orbit is None:
            from .hbm import harmonic_balance

            orbit = harmonic_balance(system, periods=periods, x0=x0, params=p_start, t0=t0, harmonics=harmonics,
                                     rtol=rtol, atol=atol or 1e-12, defect_tol=defect_tol)
        state_scale = _state_scale(system, orbit.x0, t0, float(orbit.period), p_start, rtol, atol or 1e-12)
        if atol is None:
            atol = _default_atol(rtol, state_scale)
        H = int(harmonics or orbit.harmonics or 16)
        res = HBResidual(system, param, H, periods, base, t0, rtol=rtol, atol=atol, fd_step=_fd_step(start, stop, rtol))
        u0 = res.u_from_orbit(orbit, start)  # type: ignore[attr-defined]
    branch = _run(res, u0, start, stop, state_scale=state_scale, ds=ds, ds_min=ds_min, ds_max=ds_max,
                  max_angle=max_angle, max_points=max_points, tol=tol, max_newton=max_newton, types=types,
                  locate=locate, state=state_idx, n_dense=n_dense, progress=progress, method=method,
                  state_weight=state_weight, stall_points=stall_points, stall_tol=stall_tol, fmt=fmt)
    branch.info.update({"rtol": rtol, "atol": atol, "tol": tol, "segments": segments if method == "shooting"
                        else None, "harmonics": getattr(res, "H", None), "start": start, "stop": stop,
                        "params": {k: float(v) for k, v in res.params(start).items() if k != param},
                        "t0": t0})
    if switch > 0:
        _switch_all(branch, switch, stop=stop, start=start, ds=ds, ds_min=ds_min, ds_max=ds_max,
                    max_angle=max_angle, max_points=max_points, tol=tol, max_newton=max_newton, types=types,
                    locate=locate, n_dense=n_dense, progress=progress, stall_points=stall_points,
                    stall_tol=stall_tol, fmt=fmt)
    branch.info["wall_s"] = time.perf_counter() - wall
    return branch


def _state_scale(system: System, x0: np.ndarray, t0: float, period: float, params: Mapping[str, float],
                 rtol: float, atol: float) -> np.ndarray:
    """Magnitude of each state over one period from ``x0`` (max of |x| and peak-to-peak).

    An orbit that is identically zero (``x = 0``) gets :func:`_zero_orbit_scale` for every state.
    """
    tr = system.simulate(t_end=t0 + period, t0=t0, x0=x0, rtol=rtol, atol=atol, n_out=257, params=params)
    sc = np.maximum(np.max(np.abs(tr.y), axis=0), np.ptp(tr.y, axis=0))
    top = float(np.max(sc))
    if not (math.isfinite(top) and top > 1e-280):
        return np.full(len(sc), _zero_orbit_scale(system))
    return np.maximum(sc, 1e-12 * top)


def _zero_orbit_scale(system: System) -> float:
    """A state magnitude for the trivial orbit ``x = 0``, from the scene.

    The largest entry of the scene's initial state; else the magnitude that the scene's
    ``[simulate]`` tolerances imply (``atol / (1e-2 * rtol)``, the convention of the
    continuation's default ``atol``); else 1.
    """
    x0 = np.abs(np.asarray(system.x0, float))
    if x0.size and np.all(np.isfinite(x0)) and float(np.max(x0)) > 0:
        return float(np.max(x0))
    d = system.defaults
    try:
        a, r = float(d["atol"]), float(d["rtol"])
        if a > 0 and r > 0 and math.isfinite(a / r):
            return a / (1e-2 * r)
    except (KeyError, TypeError, ValueError):
        pass
    return 1.0


def _default_atol(rtol: float, state_scale: np.ndarray) -> float:
    """``rtol * 1e-2 *`` the smallest state magnitude (positive by construction of the scales)."""
    return float(rtol * 1e-2 * np.min(state_scale))


def _formatter(display: tuple[float, str] | None):
    """Format a parameter value (SI) for messages: in the display unit, unit ``1`` omitted."""
    if display is None:
        return lambda v: f"{v:.10g}"
    scale, unit = float(display[0]), str(display[1] or "")
    suffix = "" if unit in ("", "1") else f" {unit}"
    return lambda v: f"{v / scale:.10g}{suffix}"


def _first_orbit_shooting(system: System, param: str, start: float, p_start: dict[str, float],
                          base: dict[str, float], periods: float, x0: Sequence[float] | None,
                          orbit: PeriodicOrbit | None, segments: int, t0: float, rtol: float,
                          atol: float | None, tol: float, transient: float | None
                          ) -> tuple[np.ndarray, np.ndarray]:
    """The state at ``t0`` of a periodic orbit at ``param = start`` and the state scales.

    A transient from the guess, then Newton at fixed parameter (the continuation's
    own corrector); if that fails, :func:`gearsym.analysis.shooting.shoot` with its
    relaxation by integration.
    """
    P = float(periods) * float(system.period(p_start))
    if orbit is not None:
        guess = np.asarray(orbit.x0, float)
    else:
        guess = np.asarray(system.x0 if x0 is None else x0, float)
        if guess.shape != (system.generated.nx,):
            raise ParameterError(f"x0 must have {system.generated.nx} entries "
                                 f"({', '.join(system.state_names)}), got shape {guess.shape}")
        n_tr = transient if transient is not None else (
            0 if x0 is not None else float(system.defaults.get("transient_periods", 20)))
        if n_tr and n_tr > 0:
            T = float(system.period(p_start))
            n = max(1, int(math.ceil(n_tr)))
            guess = system.simulate(t_end=t0, t0=t0 - n * T, x0=guess, rtol=max(rtol, 1e-9),
                                    atol=max(atol or 1e-12, 1e-14), n_out=2, params=p_start).x_final
    scale = _state_scale(system, guess, t0, P, p_start, max(rtol, 1e-9), atol or 1e-12)
    a_tol = atol if atol is not None else _default_atol(rtol, scale)
    res = ShootingResidual(system, param, periods, base, segments, t0, rtol, a_tol, fd_step=1e-6)
    C = _Continuer(res, lam_scale=1.0, tol=tol, max_newton=25, state=0, n_dense=64, detect=())
    C.set_state_scale(scale)
    row = np.zeros(res.n + 1)
    row[-1] = 1.0
    try:
        z, _, _ = C.correct(np.concatenate([res.u_from_orbit(guess, start), [start]]), row, start)
        x_start = res.x0_of(z[:-1])
    except GearsymError:
        from .shooting import shoot

        o = shoot(system, periods=periods, x0=guess, params=p_start, segments=segments, t0=t0, transient=0,
                  rtol=rtol, atol=a_tol, tol=min(tol, 1e-9))
        x_start = np.asarray(o.x0, float)
    return x_start, _state_scale(system, x_start, t0, P, p_start, rtol, a_tol)


def _fd_step(start: float, stop: float, rtol: float = 1e-10) -> float:
    """Step of the forward difference ``F_lambda``: ``sqrt(rtol)`` of the parameter range
    (at least 1e-6), the usual balance of the integration noise (~ rtol) divided by the
    step against the truncation error (~ the step).  Measured on the benchmark orbit
    against a central difference at rtol 1e-13: relative error 1e-2 at rtol 1e-5, 5e-5 at
    1e-10 (a fixed 1e-6 step gave 34 and 6e-4: at loose tolerances ``F_lambda`` was all
    noise and the corrector rejected step after step)."""
    return max(1e-6, math.sqrt(rtol)) * max(abs(stop - start), 1e-3 * max(abs(start), abs(stop)))


def _detect_types(detect: Sequence[str] | bool) -> tuple[str, ...]:
    if detect is True:
        return _ALL_TYPES
    if detect is False:
        return ()
    out = tuple(detect)
    for d in out:
        if d not in _ALL_TYPES:
            raise ParameterError(f"unknown bifurcation type '{d}' (have: {', '.join(_ALL_TYPES)})")
    return out


def _run(res: _Residual, u0: np.ndarray, start: float, stop: float, *, state_scale: np.ndarray, ds: float,
         ds_min: float, ds_max: float, max_angle: float, max_points: int, tol: float, max_newton: int,
         types: tuple[str, ...], locate: bool, state: int, n_dense: int, progress: bool | None,
         method: str, first: tuple[np.ndarray, np.ndarray] | None = None, parent: Bifurcation | None = None,
         stop_on_merge: bool = False, state_weight: float = 1.0, stall_points: int = 50, stall_tol: float = 1e-5,
         fmt=None) -> Branch:
    """The predictor-corrector loop (shared by :func:`continuation` and branch switching)."""
    fmt = fmt or _formatter(None)
    lo, hi = min(start, stop), max(start, stop)
    lam_scale = abs(stop - start)
    C = _Continuer(res, lam_scale=lam_scale, tol=tol, max_newton=max_newton, state=state, n_dense=n_dense,
                   detect=types, state_weight=state_weight)
    C.set_state_scale(state_scale)
    n = res.n
    if first is None:
        # correct at fixed lambda = start, tangent oriented towards stop
        row = np.zeros(n + 1)
        row[-1] = 1.0
        z0 = np.concatenate([u0, [start]])
        z, ev, it = C.correct(z0, row, start / C.S[-1])
        t_ref = np.zeros(n + 1)
        t_ref[-1] = 1.0 if stop > start else -1.0
        node = C.make_node(z, ev, t_ref, it)
    else:
        z_first, t_first = first
        z, ev, it = C.correct(z_first, t_first, float(t_first @ (z_first / C.S)))
        node = C.make_node(z, ev, t_first, it)
    # scale from the first orbit, then re-express the tangent
    C, node = _rescale(C, node, force=True)
    nodes: list[_Node] = [node]
    specials: list[tuple[int, str, dict[str, Any]]] = []  # (node index, type, info)
    prog = _Progress(progress, start, stop, res.param)
    stop_reason = ""
    complete = False
    h = h_arc = h_nat = float(ds)
    force_arc = False
    n_rejected = 0
    merge_ref = None
    try:
        while True:
            A = nodes[-1]
            if len(nodes) >= max_points:
                stop_reason = (f"max_points={max_points} reached at {res.param} = {fmt(float(A.z[-1]))} before the "
                               f"end of the range ({fmt(stop)}): raise max_points or ds_max")
                break
            wA = A.z / C.S
            # where no turning point is possible (no multiplier near +1) and the state moves fast
            # with the parameter, step in the parameter itself (natural parameter): Newton on a
            # contracting map at fixed parameter is robust even when the branch is kinked by
            # many grazing impacts
            natural = (res.natural_steps and A.graph and abs(A.t[-1]) < 0.7 and not force_arc
                       and np.min(np.abs(A.point.multipliers - 1.0)) > 0.2)
            h = h_nat if natural else h_arc
            try:
                if natural:
                    row = np.zeros(n + 1)
                    row[-1] = 1.0
                    dl = math.copysign(h, A.t[-1])
                    w_pred = wA.copy()
                    w_pred[-1] += dl
                    z, ev, it = C.correct(w_pred * C.S, row, float(wA[-1]) + dl)
                else:
                    row = A.t
                    z, ev, it = C.correct((wA + h * A.t) * C.S, A.t, float(A.t @ wA) + h)
                B = C.make_node(z, ev, A.t, it, ref=A)
                B.graph = res.natural_steps and _graph_like(B.point.multipliers, A.point.multipliers)
                if natural and (tau_branch_point(B.point.multipliers) > 0) != (tau_branch_point(
                        A.point.multipliers) > 0):
                    force_arc = True  # a real multiplier crossed +1: a fold may be near, use the arclength
                    raise ConvergenceError("a multiplier crossed +1 in a parameter step")
                cosang = float(B.t @ A.t)
                if B.graph:
                    cosang = abs(cosang)
                if not natural and cosang < math.cos(max_angle) and h > 4 * ds_min:
                    raise ConvergenceError(f"tangent turned by {math.degrees(math.acos(max(-1, cosang))):.1f} deg")
            except GearsymError as exc:
                n_rejected += 1
                h *= 0.5
                if natural:
                    h_nat = h
                else:
                    h_arc = h
                if h < ds_min:
                    stop_reason = (f"the branch cannot advance: step size below ds_min={ds_min:g} at {res.param} = "
                                   f"{fmt(float(A.z[-1]))} before the end of the range ({fmt(stop)}); last "
                                   f"rejection: {exc}")
                    break
                continue
            lamB = float(B.z[-1])
            leaving = lamB > hi or lamB < lo
            if leaving:
                bound = hi if lamB > hi else lo
                try:
                    B = _boundary_node(C, A, B, bound)
                except GearsymError:
                    pass
                stop_reason = (f"reached {res.param} = {fmt(bound)}" if bound == (hi if stop > start else lo)
                               else f"left the range at {res.param} = {fmt(bound)}")
                complete = True
            new_specials = _detect_between(C, A, B, types, locate, row) if types else []
            for nd, kind, info in new_specials:
                nodes.append(nd)
                specials.append((len(nodes) - 1, kind, info))
            nodes.append(B)
            prog.update(float(B.z[-1]), len(nodes), len(specials))
            if leaving:
                break
            if stop_on_merge:
                d = _period_defect(res, B)
                if merge_ref is None:
                    merge_ref = d
                elif d < 1e-4 * max(merge_ref, 1e-300) or d < 1e3 * tol:
                    stop_reason = "merged back into the branch of the base period (period doubling)"
                    complete = True
                    break
                merge_ref = max(merge_ref, d)
            stalled = stalled_branch([(float(nd.z[-1]), nd.scale, nd.point.multipliers) for nd in
                                      nodes[-max(stall_points, QUICK_STALL[0]) - 1:]], stall_points,
                                     stall_tol * lam_scale, lam_scale, getattr(res, "rtol", 1e-10))
            if stalled:
                k_st, lo_st, hi_st, s0_st, s1_st = stalled
                stop_reason = (f"the branch does not advance: {res.param} stayed within {fmt(lo_st)} .. "
                               f"{fmt(hi_st)} over the last {k_st} points while the orbit's magnitude went "
                               f"from {s0_st:.3g} to {s1_st:.3g} (a resonance of an undamped system: no "
                               f"periodic orbit beyond it; or a multiplier at +1 along the branch)")
                break
            # step control
            force_arc = False
            h_used = h
            if it <= 1:
                h = min(2.0 * h, ds_max)
            elif it <= 3:
                h = min(1.5 * h, ds_max)
            elif it >= 5:
                h = max(0.6 * h, ds_min)
            cosang = abs(float(B.t @ A.t)) if B.graph else float(B.t @ A.t)
            if not natural and cosang < math.cos(0.5 * max_angle):
                h = max(0.7 * h, ds_min)
            h = neutral_step_limit(A.point, B.point, h, h_used, ds_min)
            if natural:
                h_nat = h
            else:
                h_arc = h
            C, nodes[-1] = _rescale(C, nodes[-1])
    finally:
        prog.close()
    points = [nd.point for nd in nodes]
    bifs: list[Bifurcation] = []
    for idx, kind, info in specials:
        nodes[idx].point.bifurcation = kind
        bifs.append(Bifurcation(type=kind, value=float(nodes[idx].z[-1]), point=nodes[idx].point, index=idx,
                                info=info))
    br = Branch(param=res.param, points=points, bifurcations=bifs, periods=res.periods, method=method,
                state=res.system.state_names[state], state_names=res.system.state_names, stop_reason=stop_reason,
                complete=complete, stop_value=float(nodes[-1].z[-1]), parent=parent, system=res.system,
                info={"n_rejected_steps": n_rejected, "n_residual_evaluations": res.n_evals,
                      "n_integrations": res.n_integrations})
    br._residual = res  # type: ignore[attr-defined]
    br._continuer = C  # type: ignore[attr-defined]
    br._nodes = nodes  # type: ignore[attr-defined]
    return br


def _graph_like(mu_b: np.ndarray, mu_a: np.ndarray, margin: float = 0.05) -> bool:
    """No multiplier within ``margin`` of +1 at either point and none crossed +1 in between."""
    if len(mu_a) == 0 or len(mu_b) == 0:
        return False
    if np.min(np.abs(mu_a - 1.0)) <= margin or np.min(np.abs(mu_b - 1.0)) <= margin:
        return False
    return (tau_branch_point(mu_a) > 0) == (tau_branch_point(mu_b) > 0)


def _period_defect(res: _Residual, node: _Node) -> float:
    """``max |x(t0 + P/2) - x(t0)|`` (scaled): zero when a period-2k orbit is a period-k orbit."""
    if res.periods < 2 or int(round(res.periods)) % 2:
        return math.inf
    lam = float(node.z[-1])
    x0 = node.point.x0
    half = res.period(lam) / 2
    tr = res.system.simulate(t_end=res.t0 + half, t0=res.t0, x0=x0, rtol=res.rtol, atol=res.atol, n_out=2,
                             params=res.params(lam))
    scale = np.maximum(np.abs(x0), 1e-300)
    return float(np.max(np.abs(tr.x_final - x0) / np.maximum(scale, np.max(scale) * 1e-6)))


def _rescale(C: _Continuer, node: _Node, force: bool = False) -> tuple[_Continuer, _Node]:
    """Grow the state scales when the orbit outgrows them; re-express the tangent."""
    old = C.S.copy()
    cur = C.state_scale
    new_scale = np.asarray(node.scale, float)
    grow = new_scale > 2 * cur
    if not force and not np.any(grow):
        return C, node
    target = np.where(grow, new_scale, cur) if not force else np.maximum(new_scale, 1e-12 * max(1e-300, new_scale.max()))
    C.set_state_scale(target)
    t = node.t * old / C.S
    node.t = t / np.linalg.norm(t)
    node.point.tangent = node.t
    node.tau["fold"] = float(node.t[-1])
    return C, node


def _boundary_node(C: _Continuer, A: _Node, B: _Node, bound: float) -> _Node:
    """The point on the branch between A and B where the parameter equals ``bound``."""
    lamA, lamB = float(A.z[-1]), float(B.z[-1])
    f = (bound - lamA) / (lamB - lamA)
    z_guess = A.z + f * (B.z - A.z)
    z_guess[-1] = bound
    row = np.zeros(len(A.z))
    row[-1] = 1.0
    z, ev, it = C.correct(z_guess, row, bound / C.S[-1])
    return C.make_node(z, ev, A.t, it, ref=A)


def _node_at(C: _Continuer, A: _Node, B: _Node, sigma: float, sigma_B: float, cache: dict[float, _Node],
             row: np.ndarray) -> _Node:
    """The branch point with ``row . (w - w_A) = sigma`` between A and B (corrected)."""
    nd = cache.get(sigma)
    if nd is not None:
        return nd
    f = sigma / sigma_B if sigma_B else 0.0
    z_guess = A.z + f * (B.z - A.z)
    z, ev, it = C.correct(z_guess, row, float(row @ (A.z / C.S)) + sigma)
    nd = C.make_node(z, ev, A.t, it, ref=A)
    cache[sigma] = nd
    return nd


def _sign_change(a: float, b: float) -> bool:
    return math.isfinite(a) and math.isfinite(b) and (a > 0) != (b > 0) and a != 0 and b != 0


def _detect_between(C: _Continuer, A: _Node, B: _Node, types: tuple[str, ...], locate: bool,
                    row: np.ndarray | None = None) -> list[tuple[_Node, str, dict[str, Any]]]:
    """Locate the special points between two neighbouring branch points.

    The points in between are parametrised by ``sigma = row . (w - w_A)`` (``row``:
    A's tangent for an arclength step, the parameter axis for a natural step).
    """
    if row is None:
        row = A.t
    wA = A.z / C.S
    sigma_B = float(row @ (B.z / C.S - wA))
    cache: dict[float, _Node] = {0.0: A, sigma_B: B}
    found: list[tuple[float, _Node, str, dict[str, Any]]] = []
    keys = []
    fold_flip = _sign_change(A.tau.get("fold", math.nan), B.tau.get("fold", math.nan))
    for key in A.tau:
        kind = key.split("|")[0]
        if kind not in types or key not in B.tau:
            continue
        if kind == "branch_point" and fold_flip:
            continue  # a fold also changes the sign of det(M - I)
        if kind == "neimark_sacker" and complex_sides(A.point) == complex_sides(B.point):
            # no complex pair left or entered the circle beyond the tolerances: pairs sitting on
            # the unit circle (a conservative branch) flip the sign of the test function by noise
            continue
        if _sign_change(A.tau[key], B.tau[key]):
            keys.append(key)
    for key in keys:
        kind = key.split("|")[0]
        info: dict[str, Any] = {}
        if kind == "grazing":
            _, surf, side = key.split("|")
            info = {"surface": surf, "side": side}
        if not locate or sigma_B == 0:
            found.append((sigma_B, B, kind, dict(info, located=False)))
            continue

        def f(s: float, key: str = key) -> float:
            try:
                return _node_at(C, A, B, s, sigma_B, cache, row).tau.get(key, math.nan)
            except GearsymError:
                return math.nan

        xtol = max(1e-12, 1e-7 * abs(sigma_B))
        s_root, a, fa, b, fb = bracket_root(f, 0.0, A.tau[key], sigma_B, B.tau[key], xtol)
        try:
            nd = _node_at(C, A, B, s_root, sigma_B, cache, row)
        except GearsymError:
            continue
        scale = max(abs(A.tau[key]), abs(B.tau[key]))
        nonsmooth = abs(b - a) <= 10 * xtol and min(abs(fa), abs(fb)) > 1e-3 * scale
        info["test_function"] = float(nd.tau.get(key, math.nan))
        if nonsmooth:
            info["nonsmooth"] = True
        left = cache.get(a if abs(a) < abs(b) else b)
        right = cache.get(b if abs(a) < abs(b) else a)
        if left is not None and right is not None:
            info["n_unstable_before"] = int(left.point.n_unstable)
            info["n_unstable_after"] = int(right.point.n_unstable)
            if left.point.n_unstable == right.point.n_unstable and A.point.n_unstable != B.point.n_unstable:
                # the crossing multiplier is within its tolerance of the circle at the bracket
                # (as close to the root as that): count on the neighbouring branch points
                info["n_unstable_before"] = int(A.point.n_unstable)
                info["n_unstable_after"] = int(B.point.n_unstable)
        if kind == "neimark_sacker":
            m = unit_circle_pair(nd.point.multipliers, tol=1e-2 if not nonsmooth else 0.5)
            if m is None:
                continue  # a neutral saddle (real pair with product 1): not a bifurcation
            info["frequency_ratio"] = float(abs(np.angle(m)) / (2 * np.pi))
        if kind == "period_doubling":
            mu = nd.point.multipliers
            info["multiplier"] = complex(mu[np.argmin(np.abs(mu + 1.0))])
        if kind in ("fold", "branch_point"):
            mu = nd.point.multipliers
            if len(mu):
                m1 = complex(mu[np.argmin(np.abs(mu - 1.0))])
                if abs(m1 - 1.0) > 0.05 and not nonsmooth and kind == "fold":
                    continue  # no multiplier at +1: a numerical flip of the tangent, not a fold
                info["multiplier"] = m1
        found.append((s_root, nd, kind, info))
    # an unexplained change of the number of unstable multipliers (a jump at a non-smooth point)
    if locate and A.point.n_unstable != B.point.n_unstable and not any(
            k in ("fold", "period_doubling", "neimark_sacker", "branch_point", "grazing") for _, _, k, _ in found):
        nd_info = _locate_jump(C, A, B, sigma_B, cache, row)
        if nd_info is not None and nd_info[2] in types:
            found.append(nd_info)
    found.sort(key=lambda x: abs(x[0]))
    return [(nd, kind, info) for _, nd, kind, info in found]


def _locate_jump(C: _Continuer, A: _Node, B: _Node, sigma_B: float, cache: dict[float, _Node],
                 row: np.ndarray):
    """Bisection on the number of unstable multipliers; classification by the crossing multiplier."""
    a, b = 0.0, sigma_B
    na = A.point.n_unstable
    left, right = A, B
    for _ in range(40):
        if abs(b - a) <= max(1e-12, 1e-8 * abs(sigma_B)):
            break
        c = 0.5 * (a + b)
        try:
            nd = _node_at(C, A, B, c, sigma_B, cache, row)
        except GearsymError:
            return None
        if nd.point.n_unstable == na:
            a, left = c, nd
        else:
            b, right = c, nd
    cross = crossing_multiplier(left.point.multipliers, right.point.multipliers)
    kind = {"+1": "fold" if (left.t[-1] > 0) != (right.t[-1] > 0) else "branch_point", "-1": "period_doubling",
            "complex": "neimark_sacker"}.get(cross.get("kind") or "", None)
    if kind is None:
        return None
    info = {"nonsmooth": True, "n_unstable_before": cross["n_unstable_before"],
            "n_unstable_after": cross["n_unstable_after"], "multiplier": cross.get("multiplier")}
    return (b, right, kind, info)


# =====================================================================================
# branch switching at period doubling
# =====================================================================================
def switch_period_doubling(branch: Branch, bifurcation: Bifurcation | int | None = None, *,
                           stop: float | None = None, amplitude: float = 2e-3, **options: Any) -> Branch:
    """Continue the period-doubled branch born at a located period doubling.

    Parameters
    ----------
    branch
        A branch from :func:`continuation` (shooting).
    bifurcation
        The period-doubling point (or its index in ``branch.bifurcations``;
        default: the first period doubling).
    stop
        End of the parameter range of the new branch (default: the parent's
        ``stop``); its other end is the parent's ``start``.
    amplitude
        Distance (scaled arclength) from the period-doubling point along the
        critical eigenvector at which the first doubled orbit is sought.
    **options
        ``ds``, ``ds_max``, ``tol``, ... as for :func:`continuation`.

    Returns
    -------
    Branch
        With ``periods`` twice the parent's; appended to ``branch.children``.
    """
    if bifurcation is None:
        pds = branch.of_type("period_doubling")
        if not pds:
            raise ParameterError("the branch has no located period doubling")
        bifurcation = pds[0]
    elif isinstance(bifurcation, int):
        bifurcation = branch.bifurcations[bifurcation]
    if bifurcation.type != "period_doubling":
        raise ParameterError(f"branch switching needs a period doubling, got a {bifurcation.type}")
    res0 = getattr(branch, "_residual", None)
    C0 = getattr(branch, "_continuer", None)
    if res0 is None or C0 is None or not isinstance(res0, ShootingResidual):
        raise ParameterError("branch switching needs a shooting branch computed in this session")
    system = res0.system
    start = float(branch.info.get("start", branch.points[0].value))
    stop = float(branch.info.get("stop", branch.points[-1].value)) if stop is None else float(stop)
    pt = bifurcation.point
    lam = float(bifurcation.value)
    M = pt.monodromy
    if M is None:
        raise ParameterError("the period-doubling point has no monodromy")
    w, V = np.linalg.eig(M)
    k = int(np.argmin(np.abs(w + 1.0)))
    v = np.real(V[:, k])
    v = v / np.linalg.norm(v)
    res = ShootingResidual(system, res0.param, 2 * res0.periods, res0.base_params, res0.segments * (
        2 if res0.segments > 1 else 1), res0.t0, res0.rtol, res0.atol, res0.fd_step, res0.method)
    # state scale of the parent (at this point), the tangent (v, 0) in scaled variables
    nx = res.nx
    state_scale = C0.state_scale.copy()
    x_star = pt.x0
    vs = v / state_scale
    vs = vs / np.linalg.norm(vs)
    step = amplitude
    x_guess = x_star + step * vs * state_scale * math.sqrt(nx)
    u_guess = res.u_from_orbit(x_guess, lam)
    u_star = res.u_from_orbit(x_star, lam)
    S = np.concatenate([res.unknown_scale(state_scale) / C0.state_weight, [abs(stop - start)]])
    t_dir = np.concatenate([(u_guess - u_star), [0.0]]) / S
    t_dir = t_dir / np.linalg.norm(t_dir)
    z_first = np.concatenate([u_guess, [lam]])
    opts = {k: options[k] for k in ("ds", "ds_min", "ds_max", "max_angle", "max_points", "tol", "max_newton",
                                    "locate", "n_dense", "progress", "stall_points", "stall_tol", "fmt")
            if k in options}
    types = _detect_types(options.get("detect", True))
    kw = dict(ds=opts.get("ds", 0.005), ds_min=opts.get("ds_min", 1e-7), ds_max=opts.get("ds_max", 0.02),
              max_angle=opts.get("max_angle", 0.3), max_points=opts.get("max_points", 5000),
              tol=opts.get("tol", float(branch.info.get("tol", 1e-9))), max_newton=opts.get("max_newton", 7),
              types=types, locate=opts.get("locate", True), state=C0.state,
              n_dense=opts.get("n_dense", C0.n_dense), progress=opts.get("progress"),
              stall_points=opts.get("stall_points", 50), stall_tol=opts.get("stall_tol", 1e-5), fmt=opts.get("fmt"))
    # direction: towards the side where the doubled orbit exists is found by the corrector; the
    # continuation range keeps the parent's orientation
    lo, hi = min(start, stop), max(start, stop)
    child = _run(res, u_guess, lo if stop >= start else hi, hi if stop >= start else lo, state_scale=state_scale,
                 method="shooting", first=(z_first, t_dir), parent=bifurcation, stop_on_merge=True,
                 state_weight=C0.state_weight, **kw)
    # the corrector on the hyperplane orthogonal to (v, 0) lands on the doubled branch; check it
    p0 = child.points[0]
    if abs(p0.value - lam) > 0.5 * abs(hi - lo) or _period_defect(res, child._nodes[0]) < 1e2 * kw["tol"]:
        raise ConvergenceError(f"branch switching at the period doubling at {res0.param} = {lam:.8g} fell back "
                               f"onto the period-{res0.periods:g} orbit; try a larger amplitude=")
    child.info.update({"start": lo, "stop": hi, "rtol": res.rtol, "atol": res.atol, "tol": kw["tol"],
                       "params": dict(branch.info.get("params", {})), "t0": res.t0,
                       "switched_at": lam})
    branch.children.append(child)
    return child


def _switch_all(branch: Branch, depth: int, **kw: Any) -> None:
    for b in list(branch.of_type("period_doubling")):
        try:
            child = switch_period_doubling(branch, b, stop=kw.get("stop"),
                                           **{k: v for k, v in kw.items() if k not in ("stop", "start", "types")},
                                           detect=kw.get("types", True))
        except GearsymError as exc:
            branch.info.setdefault("switch_failures", []).append(
                {"value": b.value, "error": str(exc)})
            continue
        if depth > 1:
            _switch_all(child, depth - 1, **kw)
