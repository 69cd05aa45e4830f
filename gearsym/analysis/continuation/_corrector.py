"""The corrector of the continuation: scaling, bordered Newton, tangents and branch points.

:class:`Continuer` holds the scaled variables of one periodic-orbit problem
(unknowns by the state magnitudes, the parameter by its range), corrects a
predicted point onto the branch with Newton on ``F = 0`` plus one linear
constraint (the pseudo-arclength hyperplane, or a fixed parameter), computes
unit tangents and turns a corrected point into a :class:`~gearsym.analysis.continuation.BranchPoint`
with its test functions.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ...engine.shoot import MAX_STATES, Corrector
from ...errors import ConvergenceError, GearsymError
from ...integrators import default_method, supports_c_corrector
from ...sensitivity import directions
from ..periodic import (
    Evaluation,
    NewtonPolicy,
    PeriodicOrbitProblem,
    damped_newton,
    floquet,
    log_events,
    mesh_point,
    mesh_rattle_states,
    segment_jacobian,
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
        #: where the corrector runs: ``"C"`` or ``"Python"`` with the reason (decided on the first correction)
        self.corrector_engine: str | None = None
        #: corrections the C corrector gave up (a failed run, a singular matrix, ...) and the Python one made
        self.n_c_fallbacks = 0
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
        """Newton on ``F(z) = 0``, ``row . (z / S) = target``.

        ``t_ref``: the reference direction :meth:`make_node` will orient the point's tangent
        along (the corrector in C then solves for the tangent in the same call).

        ``F_lambda``, where it is a finite difference (the costly column), is computed at
        the first iterate and kept (chord) until convergence, then recomputed at the
        solution for the tangent; where the residual's integration gives it
        (:meth:`~gearsym.analysis.periodic.ShootingResidual.flam_with_residual`) it is
        taken at every iterate.  A residual at the integrator's noise floor (a Newton step
        below ``tol`` that no longer reduces it, up to ``100 * tol``) is accepted.

        Raises
        ------
        ConvergenceError, GearsymError
            No convergence (step to be rejected).
        """
        z = np.asarray(z_guess, float).copy()
        fast = self._correct_in_c(z, row, target, t_ref)
        if fast is not None:
            return fast
        # F_lambda integrated with the residual (exact sensitivities) is nearly free: then it is
        # computed at every iterate (plain Newton); else the chord described above
        every = bool(getattr(self.res, "flam_with_residual", lambda lam: False)(float(z[-1])))
        ev = self.res.evaluate(z[:-1], z[-1], dlam=every or Flam is None)
        if Flam is None or every:
            Flam = ev.Flam
        tol, S = self.tol, self.S

        def evaluate(z: np.ndarray) -> tuple[np.ndarray, Evaluation]:
            return z, self.res.evaluate(z[:-1], z[-1], dlam=every)

        def norm(rec: tuple[np.ndarray, Evaluation]) -> float:
            return float(np.max(np.abs(self.scaled_residual(rec[1]))))

        def converged(rec: tuple[np.ndarray, Evaluation], size: float, damping: float) -> str | None:
            r = norm(rec)
            c = float(row @ (rec[0] / S) - target)
            return "" if (r <= tol or (size <= tol and r <= 100 * tol)) and abs(c) <= 1e-9 else None

        def direction(z: np.ndarray, rec: tuple[np.ndarray, Evaluation]) -> tuple[np.ndarray, float, dict]:
            ev = rec[1]
            if ev.Flam is None:
                ev.Flam = Flam
            c = float(row @ (z / S) - target)
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
            return dw * S, float(np.max(np.abs(dw))), {}

        # damped step: halve it (up to 3 times) while the residual grows, then take it anyway
        policy = NewtonPolicy(max_iter=self.max_newton, min_damping=0.125, decrease=0.0, accept_below=tol,
                              accept_last=True, diverge=(0.9, 100 * tol))
        out = damped_newton(z, (z, ev), evaluate=evaluate, norm=norm, direction=direction, converged=converged,
                            policy=policy)
        z, ev = out.ev
        if not out.converged:
            if out.failure == "max_iter":
                raise ConvergenceError(f"corrector: no convergence in {out.iterations} Newton steps "
                                       f"(residual {norm(out.ev):.3g})")
            raise ConvergenceError(f"corrector: {out.failure}")
        if ev.Flam is None:
            ev.Flam = self.res._fd_lambda(z[:-1], float(z[-1]), ev.R)
        return z, ev, out.iterations

    def _c_setup(self, lam: float) -> dict | None:
        """What the corrector in C needs (:func:`gearsym.engine.shoot.correct_in_c`), or ``None``
        where it does not apply: not single shooting, a method the C corrector does not run (IDA:
        implicit and DAE models), no exact parameter derivatives, a parameter that does not enter
        the parameter vector linearly (an argument of a bound parameter), anchor rows (rigid-body
        modes) that change with the parameter.  Decided once; the choice and its reason are kept in
        :attr:`corrector_engine` (the branch's ``info["corrector"]``)."""
        if "_c_setup_cache" in self.__dict__:
            return self.__dict__["_c_setup_cache"]
        try:
            out = self._make_c_setup(lam)
        except GearsymError as exc:
            out = f"the C corrector could not be set up ({exc})"
        if isinstance(out, str):  # the reason why not: reported in the branch's info["corrector"]
            self.corrector_engine = f"Python: {out}"
            out = None
            _log.info("continuation corrector in Python: %s", self.corrector_engine[8:])
        else:
            self.corrector_engine = "C"
            _log.debug("continuation corrector in C")
        self.__dict__["_c_setup_cache"] = out
        return out

    def _make_c_setup(self, lam: float) -> dict | str:
        """The C corrector's setup, or the reason why it does not apply."""
        res = self.res
        system = getattr(res, "system", None)
        if system is None or not hasattr(res, "segments"):
            return "not a shooting residual"
        if res.segments != 1:
            return "multiple shooting"
        gen = system.generated
        method = res.method or default_method(gen.implicit, system.defaults.get("method"))
        if not supports_c_corrector(method):
            return f"method '{method}' (the C corrector runs only the methods of the registry that allow it)"
        if gen.nx > MAX_STATES or len(gen.param_names) > MAX_STATES:
            return f"more than {MAX_STATES} states or parameters"
        if res.param not in gen.param_names or res.param in gen.bound or any(
                res.param in args for _, args in gen.bound.values()):
            return f"'{res.param}' is not a plain entry of the parameter vector"
        if not getattr(res, "flam_with_residual", lambda lam: False)(lam):
            return "no exact parameter derivative"
        anchor = res.anchor_rows(lam)
        if anchor is not None:
            # the C iteration keeps the anchor rows of its start; they must not move with lambda
            for d in (1.0, -0.5):
                other = res.anchor_rows(lam + d * max(1.0, abs(lam)))
                if other is None or other.shape != anchor.shape or np.max(np.abs(other - anchor)) > 1e-12:
                    return "rigid-body anchor rows that move with the parameter"
        engine = system.derivative_engine()
        if not hasattr(engine._lib, "gs_correct_ws"):
            return "the build has no C corrector"
        if np.ndim(res.atol):
            return "per-state absolute tolerances"
        p0 = np.array(res.pvec(lam), float)
        D = directions(system, [res.param], p0, res.params(lam))[:, 0]
        # p(lambda) must be p0 + (lambda - lam0) D (declared-unit scaling is linear; check it)
        for d in (1.0, -0.5):
            pl = res.pvec(lam + d * max(1.0, abs(lam)))
            if np.max(np.abs(pl - (p0 + d * max(1.0, abs(lam)) * D))) > 1e-12 * max(1.0, float(np.max(np.abs(pl)))):
                return f"the parameter vector is not linear in '{res.param}'"
        return {"engine": engine, "method": method, "lam0": float(lam), "p0": p0, "D": D,
                "max_steps": int(system.defaults.get("max_steps", 0)), "anchor": anchor}

    def _correct_in_c(self, z: np.ndarray, row: np.ndarray, target: float, t_ref: np.ndarray | None = None
                      ) -> tuple[np.ndarray, Evaluation, int] | None:
        """:meth:`correct` in one C call where it applies (see :meth:`_c_setup`); ``None`` where it
        does not or where the C iteration gave up (the Python iteration then starts from ``z``)."""
        setup = self._c_setup(float(z[-1]))
        if setup is None:
            return None
        res = self.res
        corrector = setup.get("corrector")
        if corrector is None:
            # the converged orbit's samples in the same call (make_node's dense output; single shooting)
            n_samples = max(8, int(math.ceil(self.n_dense * res.periods))) + 1
            corrector = setup["corrector"] = Corrector(
                setup["engine"], tol=self.tol, max_iter=self.max_newton, min_damping=0.125, periods=res.periods,
                lam0=setup["lam0"], p0=setup["p0"], D=setup["D"], atol=float(res.atol), t0=res.t0,
                method=setup["method"], rtol=res.rtol, max_steps=setup["max_steps"], n_samples=n_samples,
                n_anchor=0 if setup["anchor"] is None else len(setup["anchor"]))
        anchor = None if setup["anchor"] is None else self.scaled_anchor(float(z[-1]))
        out = corrector(z, row, target, self.S, self.Rs, t_ref=t_ref, want_run=False, anchor=anchor)
        res.n_evals += out.n_runs
        res.n_integrations += out.n_runs
        # the failures the Python iteration would meet the same way are raised as it raises them
        # (not iterated again); the others (a failed run, a singular matrix, a full event log)
        # are left to it
        if out.code == 2:
            raise ConvergenceError(f"corrector: no convergence in {out.iterations} Newton steps "
                                   f"(residual {out.residual:.3g})")
        if out.code == 1:
            raise ConvergenceError(f"corrector: Newton diverges (residual {out.residual:.3g})")
        if out.code == 6:
            raise ConvergenceError("corrector: non-finite residual")
        if not out.converged:
            self.n_c_fallbacks += 1
            return None
        ev_log = out.events
        ev = Evaluation(out.R, segment_jacobian([out.monodromy]), out.f_lambda, monodromy=out.monodromy,
                        events=log_events(res.system, ev_log.t, ev_log.surface, ev_log.direction),
                        samples=out.samples, tangent=None if out.tangent is None else (t_ref, out.tangent),
                        period=out.period if math.isfinite(out.period) else None, multipliers=out.multipliers)
        return out.z, ev, out.iterations

    def engine_report(self) -> str:
        """Where the corrections ran, for the branch's ``info["corrector"]``: ``"C"``, ``"C (the
        Python corrector took over N times)"`` or ``"Python: <why not C>"``."""
        out = self.corrector_engine or "Python"
        if out == "C" and self.n_c_fallbacks:
            out += f" (the Python corrector took over {self.n_c_fallbacks} times)"
        return out

    def tangent(self, ev: Evaluation, t_ref: np.ndarray, lam: float | None = None) -> np.ndarray:
        """Unit null vector of the scaled ``[F_u, F_lambda]`` with ``t . t_ref > 0`` (and, with
        rigid-body modes, no component along their shift: anchor rows at ``lam``)."""
        anchor = self.scaled_anchor(lam) if lam is not None else None
        if ev.tangent is not None and ev.tangent[0] is t_ref:
            t = ev.tangent[1]  # the same solve (least squares with anchor rows), made by the corrector in C
            tl = t.tolist()
            if all(map(math.isfinite, tl)) and any(tl):
                t = t / math.sqrt(float(t @ t))
                return -t if t @ t_ref < 0 else t
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
