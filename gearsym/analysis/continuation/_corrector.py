"""The corrector of the continuation: scaling, bordered Newton, tangents and branch points.

:class:`Continuer` holds the scaled variables of one periodic-orbit problem
(unknowns by the state magnitudes, the parameter by its range), corrects a
predicted point onto the branch with Newton on ``F = 0`` plus one linear
constraint (the pseudo-arclength hyperplane, or a fixed parameter), computes
unit tangents and turns a corrected point into a :class:`~gearsym.analysis.continuation.BranchPoint`
with its test functions.

Where each rule lives (``docs/contributing.md``, "Where each numerical rule lives"): the
corrector's Newton iteration -- the bordered step in the scaled variables, its damping,
divergence and convergence tests, the chord ``F_lambda``, the anchor rows' least squares, the
point's unit tangent -- is THE iteration of ``gearsym/engine/gs_newton.c``
(:class:`gearsym.engine.shoot.Corrector`), for every problem.  Here are the scales
(:meth:`Continuer.set_state_scale`), the anchor rows (:meth:`Continuer.scaled_anchor`) and the
choice of who evaluates the residual: the C evaluator of the shooting residual
(``gs_correct_ws``: single and multiple shooting, ODEs and DAEs, exact ``F_lambda``) where it
applies, else the problem's own :meth:`~gearsym.analysis.periodic.PeriodicOrbitProblem.evaluate`
(harmonic balance, a parameter that is no plain entry of the parameter vector, the
finite-difference ``F_lambda``).  That choice, and every evaluation the C evaluator hands back
(an integration with the parameter sensitivity that fails at a grazing contact), is reported in
the branch's ``info["corrector"]`` and logged.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ...engine.newton import DIVERGED, MAX_ITER, NONFINITE, SINGULAR
from ...engine.shoot import Corrector, CorrectorFlow, CorrectOutcome
from ...errors import ConvergenceError, GearsymError
from ...integrators import default_method, supports_monodromy, supports_sensitivities
from ...sensitivity import directions
from ..periodic import (
    Evaluation,
    PeriodicOrbitProblem,
    floquet,
    log_events,
    mesh_point,
    mesh_rattle_states,
    monodromy_product,
    verdict,
)
from ._bifurcation import tau_branch_point, tau_neimark_sacker, tau_period_doubling
from ._branch import BranchPoint

__all__ = ["Continuer", "Node", "distance_to_one", "graph_like", "rescale"]

_log = logging.getLogger(__name__)


def _periodic_extremum(y: np.ndarray, i: int, sign: float) -> float:
    """Parabolic refinement of a sample extremum of a periodic sequence."""
    n = len(y)
    a, b, c = y[(i - 1) % n], y[i], y[(i + 1) % n]
    den = a - 2 * b + c
    if den * sign < 0:
        return float(b - 0.125 * (c - a) ** 2 / den)
    return float(b)


@dataclass
class Node:
    """A point of the branch with what the continuation needs."""

    z: np.ndarray          # (u, lambda), unscaled
    ev: Evaluation
    point: BranchPoint
    t: np.ndarray          # unit tangent, scaled variables
    tau: dict[str, float]
    iterations: int = 0
    scale: np.ndarray | None = None
    size: float = float("nan")  # max of scale (the stall test reads it at every step)
    graph: bool = False    # the branch is a graph over the parameter between the previous point and this


class Continuer:
    """The predictor-corrector machinery on one residual."""

    def __init__(self, res: PeriodicOrbitProblem, *, lam_scale: float, tol: float, max_newton: int, state: int,
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
        self.state_weight = float(state_weight)
        self.state_scale = np.ones(gen.nx)  # every state's magnitude (the unknowns' scales: res.unknown_scale)
        #: who evaluates the residuals of THE Newton iteration (which always runs in C): ``"C"``, or
        #: ``"C, residuals in Python: <why>"`` (decided on the first correction)
        self.corrector_engine: str | None = None
        #: residuals the C evaluator handed back to the problem's own evaluation, and why (the first)
        self.n_python_evaluations = 0
        self.handback_reason = ""
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

    def scaled_jacobian(self, ev: Evaluation) -> np.ndarray:
        """``[F_u, F_lambda]`` in scaled variables, rows scaled by the state magnitudes."""
        J = np.hstack([ev.Fu, ev.Flam[:, None]]) * self.S[None, :]
        return J / self.Rs[:, None]

    def scaled_residual(self, ev: Evaluation) -> np.ndarray:
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
    def correct(self, z_guess: np.ndarray, row: np.ndarray, target: float, Flam: np.ndarray | None = None,
                t_ref: np.ndarray | None = None) -> tuple[np.ndarray, Evaluation, int]:
        """Newton on ``F(z) = 0``, ``row . (z / S) = target``: THE iteration of
        ``gs_newton.c`` (:class:`gearsym.engine.shoot.Corrector`), its residuals evaluated in C
        where the C evaluator applies (:meth:`_flow_setup`), else by the problem.

        ``t_ref``: the reference direction :meth:`make_node` will orient the point's tangent
        along (the iteration computes it at the corrected point).

        ``F_lambda``: where the problem's evaluation does not give it with the residual (the
        finite difference: the costly column) it is computed at the first iterate and kept
        (chord; ``Flam``: that first one, if known), then recomputed at the solution; where the
        residual's integration gives it (the exact parameter sensitivity) it is taken at every
        iterate.  A residual at the integrator's noise floor (a Newton step below ``tol``, the
        residual up to ``100 * tol``) is accepted.

        Raises
        ------
        ConvergenceError, GearsymError
            No convergence (step to be rejected).
        """
        z = np.asarray(z_guess, float).copy()
        res = self.res
        corrector = self._corrector(float(z[-1]))
        anchored = self.__dict__["_n_anchor"] > 0
        last: list[Evaluation] = []
        every: list[bool] = []  # (decided at the first evaluation in Python: it costs a period gradient)

        def evaluate(zz: np.ndarray, first: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, Any]:
            lam = float(zz[-1])
            if not every:
                every.append(bool(getattr(res, "flam_with_residual", lambda lam: False)(float(z[-1]))))
            ev = res.evaluate(zz[:-1], lam, dlam=every[0] or (first and Flam is None))
            last[:] = [ev]
            flam = ev.Flam if ev.Flam is not None else (Flam if first else None)
            return ev.R, ev.Fu, flam, self.scaled_anchor(lam) if anchored else None

        flow = self.__dict__["_flow"]
        out = corrector(z, row, target, self.S, self.Rs, t_ref=t_ref,
                        anchor=self.scaled_anchor(float(z[-1])) if anchored else None,
                        zalg=getattr(res, "_z", None) if flow is not None else None, evaluate=evaluate)
        self._count(out, flow is not None)
        if not out.converged:
            raise ConvergenceError(_failure(out))
        if out.by_python:
            ev = last[0]
            if ev.Flam is None:
                ev.Flam = res._fd_lambda(out.z[:-1], float(out.z[-1]), ev.R)
        else:
            ev = Evaluation(out.R, out.F_u, out.f_lambda, monodromy=monodromy_product(out.monodromies),
                            events=log_events(res.system, out.events.t, out.events.surface, out.events.direction),
                            samples=out.samples, period=out.period if math.isfinite(out.period) else None,
                            multipliers=out.multipliers)
        if out.tangent is not None:
            ev.tangent = (t_ref, out.tangent)
        return out.z, ev, out.iterations

    def _count(self, out: CorrectOutcome, flow: bool) -> None:
        """Book a correction's evaluations: the problem's counters, the hand-backs (logged)."""
        res = self.res
        res.n_evals += out.n_c
        res.n_integrations += out.n_runs
        if flow and out.n_python:
            self.n_python_evaluations += out.n_python
            if not self.handback_reason:
                self.handback_reason = ("an integration with the parameter sensitivity failed (a grazing contact?): "
                                        "the problem's own evaluation, F_lambda by finite difference")
                _log.info("continuation corrector: a residual evaluated in Python: %s", self.handback_reason)
            else:
                _log.debug("continuation corrector: %d residual(s) evaluated in Python", out.n_python)

    def _corrector(self, lam: float) -> Corrector:
        """THE Newton iteration for this problem (made once): with the C evaluator of the shooting
        residual where it applies (:meth:`_flow_setup`), else the problem evaluates.  The choice and
        its reason are kept in :attr:`corrector_engine` (the branch's ``info["corrector"]``) and
        logged."""
        corrector = self.__dict__.get("_corrector_obj")
        if corrector is not None and corrector.nr == self.res.n:
            return corrector
        try:
            flow = self._flow_setup(lam)
        except GearsymError as exc:
            flow = f"the C evaluator could not be set up ({exc})"
        res = self.res
        anchor = res.anchor_rows(lam)
        n_anchor = 0 if anchor is None else len(anchor)
        if isinstance(flow, str):  # the reason why not
            self.corrector_engine = f"C, residuals in Python: {flow}"
            _log.info("continuation corrector: residuals evaluated in Python: %s", flow)
            flow = None
            engine = res.system.engine
        else:
            self.corrector_engine = "C"
            _log.debug("continuation corrector: residuals evaluated in C")
            engine = flow.engine
        corrector = Corrector(engine, res.n, tol=self.tol, max_iter=self.max_newton, min_damping=0.125,
                              n_anchor=n_anchor, flow=flow)
        self.__dict__.update(_corrector_obj=corrector, _flow=flow, _n_anchor=n_anchor)
        return corrector

    def _flow_setup(self, lam: float) -> CorrectorFlow | str:
        """The C evaluator's settings (:class:`gearsym.engine.shoot.CorrectorFlow`), or the reason why
        it does not apply: not a shooting residual (harmonic balance), a method without the
        variational equations or the sensitivities, a parameter that does not enter the parameter
        vector linearly (an argument of a bound parameter), no exact parameter derivative (the
        finite-difference ``F_lambda``), anchor rows (rigid-body modes) that change with the
        parameter."""
        res = self.res
        system = getattr(res, "system", None)
        if system is None or not hasattr(res, "segments") or not hasattr(res, "times"):
            return f"{type(res).__name__} is not the shooting residual over the flow"
        gen = system.generated
        method = res.method or default_method(gen.implicit, system.defaults.get("method"))
        if not (supports_monodromy(method) and supports_sensitivities(method)):
            return f"method '{method}' integrates no variational equations or no sensitivities"
        if res.param not in gen.param_names or res.param in gen.bound or any(
                res.param in args for _, args in gen.bound.values()):
            return f"'{res.param}' is not a plain entry of the parameter vector"
        if not getattr(res, "flam_with_residual", lambda lam: False)(lam):
            return "no exact parameter derivative (the finite-difference F_lambda)"
        anchor = res.anchor_rows(lam)
        if anchor is not None:
            # the C evaluator keeps the anchor rows of its start; they must not move with lambda
            for d in (1.0, -0.5):
                other = res.anchor_rows(lam + d * max(1.0, abs(lam)))
                if other is None or other.shape != anchor.shape or np.max(np.abs(other - anchor)) > 1e-12:
                    return "rigid-body anchor rows that move with the parameter"
        engine = system.derivative_engine()
        if not hasattr(engine._lib, "gs_correct_ws"):
            return "the build has no C evaluator"
        p0 = np.array(res.pvec(lam), float)
        D = directions(system, [res.param], p0, res.params(lam))[:, 0]
        # p(lambda) must be p0 + (lambda - lam0) D (declared-unit scaling is linear; check it)
        for d in (1.0, -0.5):
            pl = res.pvec(lam + d * max(1.0, abs(lam)))
            if np.max(np.abs(pl - (p0 + d * max(1.0, abs(lam)) * D))) > 1e-12 * max(1.0, float(np.max(np.abs(pl)))):
                return f"the parameter vector is not linear in '{res.param}'"
        n_samples = max(8, int(math.ceil(self.n_dense * res.periods))) + 1  # make_node's dense output
        return CorrectorFlow(engine=engine, method=method, rtol=res.rtol, atol=np.broadcast_to(
            np.asarray(res.atol, float), (gen.nx,)), max_steps=int(system.defaults.get("max_steps", 0)),
            segments=res.segments, nd=res.nx, periods=res.periods, t0=res.t0, lam0=float(lam), p0=p0, D=D,
            n_samples=n_samples)

    def engine_report(self) -> str:
        """Where the iteration's residuals were evaluated, for the branch's ``info["corrector"]``:
        ``"C"``, ``"C (N residuals evaluated in Python: <why>)"`` or ``"C, residuals in Python:
        <why not C>"`` (the iteration itself always runs in C)."""
        out = self.corrector_engine or "C"
        if out == "C" and self.n_python_evaluations:
            out += f" ({self.n_python_evaluations} residuals evaluated in Python: {self.handback_reason})"
        return out

    def tangent(self, ev: Evaluation, t_ref: np.ndarray, lam: float | None = None) -> np.ndarray:
        """Unit null vector of the scaled ``[F_u, F_lambda]`` with ``t . t_ref > 0`` (and, with
        rigid-body modes, no component along their shift: anchor rows at ``lam``): the rule of
        THE Newton iteration (``gs_newton_tangent``), which already computed it at a corrected
        point (``ev.tangent``)."""
        if ev.tangent is not None and ev.tangent[0] is t_ref:
            t = ev.tangent[1]  # the iteration's, at the corrected point
            tl = t.tolist()
            if all(map(math.isfinite, tl)) and any(tl):
                t = t / math.sqrt(float(t @ t))
                return -t if t @ t_ref < 0 else t
        anchor = self.scaled_anchor(lam) if lam is not None else None
        corrector = self._corrector(float(lam) if lam is not None else 0.0)
        t = corrector.tangent(ev.Fu, ev.Flam, np.asarray(t_ref, float), self.S, self.Rs, anchor)
        if t is None:
            raise ConvergenceError("corrector: no tangent (the scaled Jacobian is not finite)")
        return t

    # ------------------------------------------------------------ points
    def make_node(self, z: np.ndarray, ev: Evaluation, t_ref: np.ndarray, iterations: int = 0,
                  ref: Node | None = None) -> Node:
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
        basis = res.rigid_basis(lam)
        if ev.multipliers is not None and basis is None:  # computed in the corrector's C call
            fq = verdict(*ev.multipliers)
        else:
            fq = floquet(ev.monodromy, res.rtol, basis)
        mu = fq.multipliers
        smp = ev.samples
        G = H = g0 = None
        x0 = res.x0_of(u, lam)
        params = res.params(lam)
        if smp is not None:  # from the corrector's C call: the period's samples, end excluded
            t_dense, Y, G, H = smp.t[:-1], smp.y[:-1], smp.g[:-1].T, smp.mesh[:-1]
            ends = np.asarray(smp.y[-1:], float)  # one run without the variational equations
            if Y[0].tolist() == np.asarray(x0, float).tolist():
                g0 = smp.g[0]
        else:
            t_dense, Y, ends = res.dense_ends(u, lam, self.n_dense)
        st = smp.stats if smp is not None else None  # the reductions below, made in the same C call
        if st is not None:
            scale = np.maximum(np.maximum(st.max, -st.min), st.max - st.min)
        else:
            scale = np.maximum(np.max(np.abs(Y), axis=0), np.ptp(Y, axis=0))
        verified = res.closure(u, lam, ev, ends, Y, scale, self.tol, fq.max_multiplier)
        if verified is not None and not verified.ok:
            # the corrector's point is no orbit: reject it like a failed correction
            raise ConvergenceError(f"corrector: {verified.message(res.system.state_names)}")
        y = Y[:, self.state]
        if st is not None:
            i_max, i_min = st.argmax[self.state], st.argmin[self.state]
        else:
            i_max, i_min = int(np.argmax(y)), int(np.argmin(y))
        ext: dict[str, tuple[float, float]] = {}
        if self.surfaces:
            if G is None:
                G = res.system.switching(t_dense, Y, p=res.system.param_vector(params)).reshape(len(t_dense), -1).T
            for j, name in enumerate(self.surfaces):
                g = G[j]
                jmin, jmax = (st.g_argmin[j], st.g_argmax[j]) if st is not None else \
                    (int(np.argmin(g)), int(np.argmax(g)))
                ext[name] = (_periodic_extremum(g, jmin, +1.0), _periodic_extremum(g, jmax, -1.0))
        rss = mesh_rattle_states(res.system, x0, res.t0, ev.events, params, g0=g0)  # (a failure rejects the point)
        meshes = mesh_point(res.system, t_dense, Y, params, rss, deflections=H,
                            extrema_at=None if st is None else (st.mesh_argmin, st.mesh_argmax))
        t = self.tangent(ev, t_ref, lam)
        tau_mu: dict[str, float] = {}
        if len(mu):
            tau_mu = {"period_doubling": tau_period_doubling(mu), "neimark_sacker": tau_neimark_sacker(mu),
                      "branch_point": tau_branch_point(mu)}
        if res.natural_steps and ref is not None and ref.t[-1] * t[-1] < 0 and graph_like(
                mu, ref.point.multipliers, tau_b=tau_mu.get("branch_point", math.nan),
                tau_a=ref.tau.get("branch_point", math.nan)):
            t = -t
        period = float(res.periods) * ev.period if ev.period is not None else res.period(lam)
        rms = math.sqrt(float(st.sum_squares[self.state]) / len(y)) if st is not None else float(np.sqrt(np.mean(y ** 2)))
        pt = BranchPoint(
            value=lam, x0=np.asarray(x0, float), period=period, periods=res.periods, multipliers=mu,
            stable=fq.stable, n_unstable=fq.n_unstable,
            max=_periodic_extremum(y, i_max, -1.0), min=_periodic_extremum(y, i_min, +1.0),
            rms=rms, rattle_state=max(rss.values()) if rss else None,
            n_events=len(ev.events),
            surface_extrema=ext, tangent=t, residual=max(map(abs, self.scaled_residual(ev).tolist())),
            iterations=iterations, u=np.asarray(u, float).copy(), monodromy=ev.monodromy,
            stability=fq.stability, trivial_multipliers=fq.trivial, multiplier_tolerances=fq.tolerances,
            meshes=meshes, closure=math.nan if verified is None else verified.relative)
        tau: dict[str, float] = {"fold": float(t[-1]), **tau_mu}
        for name, (gmin, gmax) in ext.items():
            tau[f"grazing|{name}|min"] = gmin
            tau[f"grazing|{name}|max"] = gmax
        return Node(z=np.array(z, float), ev=ev, point=pt, t=t, tau=tau, iterations=iterations, scale=scale,
                    size=float(np.max(scale)))


def _failure(out: CorrectOutcome) -> str:
    """The message of a correction that did not converge."""
    if out.code == MAX_ITER:
        return f"corrector: no convergence in {out.iterations} Newton steps (residual {out.residual:.3g})"
    if out.code == DIVERGED:
        return f"corrector: Newton diverges (residual {out.residual_prev:.3g} -> {out.residual:.3g})"
    if out.code == NONFINITE:
        return "corrector: non-finite residual"
    if out.code == SINGULAR:
        return "corrector: singular Newton matrix"
    return f"corrector: {out.message or 'no damped step reduces the residual'}"


def distance_to_one(mu: np.ndarray) -> float:
    """``min |mu_i - 1|`` (NaN if a multiplier is not finite, as numpy's ``min``)."""
    d = [abs(m - 1.0) for m in np.asarray(mu, complex).tolist()]
    return math.nan if any(math.isnan(v) for v in d) else min(d)


def graph_like(mu_b: np.ndarray, mu_a: np.ndarray, margin: float = 0.05, *, tau_b: float | None = None,
               tau_a: float | None = None) -> bool:
    """No multiplier within ``margin`` of +1 at either point and none crossed +1 in between
    (``tau_b``, ``tau_a``: the points' ``tau_branch_point`` when already known)."""
    if len(mu_a) == 0 or len(mu_b) == 0:
        return False
    if distance_to_one(mu_a) <= margin or distance_to_one(mu_b) <= margin:
        return False
    tau_a = tau_branch_point(mu_a) if tau_a is None else tau_a
    tau_b = tau_branch_point(mu_b) if tau_b is None else tau_b
    return (tau_a > 0) == (tau_b > 0)


def rescale(C: Continuer, node: Node, force: bool = False) -> tuple[Continuer, Node]:
    """Grow the state scales when the orbit outgrows them; re-express the tangent."""
    if not force and not any(a > 2 * b for a, b in zip(np.asarray(node.scale, float).tolist(),
                                                        C.state_scale.tolist())):
        return C, node  # (the common case, on Python floats)
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
    node.point = replace(node.point, tangent=node.t)
    node.tau["fold"] = float(node.t[-1])
    return C, node
