"""Pseudo-arclength continuation of a bifurcation curve: the solution set of an augmented system.

The augmented systems (:mod:`._augmented`, :mod:`._augmented_more`) have one unknown more than
equations; their solution set is a curve in ``y = (x0, lambda_1, lambda_2, extras)``.  The loop:

* **scaling**: every unknown by its magnitude (the states by their magnitudes on the first
  orbit, the parameters by their ranges), every residual row by the norm of its row of the
  scaled Jacobian at the last accepted point (a scaled residual is a distance in the scaled
  unknowns: ``tol`` means the same for every equation);
* **corrector**: Newton on ``G(y) = 0`` plus the hyperplane ``t . (w - w_pred) = 0`` (``w`` the
  scaled unknowns).  The rows of the shooting residual are exact at every iterate (monodromy
  and parameter sensitivities of one integration); the rows of the test functions (finite
  differences, several integrations) are computed at the first iterate and reused (a chord),
  renewed when an iteration does not reduce the residual threefold;
* **tangent**: the null vector of the scaled Jacobian, oriented along the previous tangent;
* **step control**: the step grows after easy corrections and shrinks after hard ones; a step
  is refused (and halved) when Newton fails, an integration fails, or the tangent turns by more
  than ``max_angle``;
* **the end**: the curve leaves the box of the two parameter ranges (its point on the boundary
  is corrected there: ``complete``), closes on itself (``complete``), reaches a point where the
  bifurcation ceases to exist (a Neimark-Sacker pair meeting at +1 or -1: ``complete``), or cannot
  advance (step below ``ds_min``, ``max_points``: not complete, with the reason).

Between two accepted points the codimension-2 test functions of the system are compared; a sign
change is located by solving ``tau(sigma) = 0`` in ``sigma = t_A . (w - w_A)`` (every evaluation a
corrected point; :func:`~gearsym.analysis.continuation._bifurcation.bracket_root`), and the point is
inserted into the curve.  A location that fails is reported with its bracket, never dropped.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import ConvergenceError, GearsymError
from ._augmented import AugEval, Augmented
from ._bifurcation import bracket_root

__all__ = ["Leg", "Node", "Tracer", "TracerSettings"]

#: test functions that end a curve where they change sign (the bifurcation ceases to exist there)
TERMINAL = {"neimark_sacker": ("resonance_1_1", "resonance_1_2")}
#: test functions whose sign changes count only above this size at both points (they vanish
#: identically on some curves, e.g. a double multiplier of a conservative system)
NOISY = {"resonance": 1e-6}
#: a residual up to this many times ``tol`` is accepted when Newton no longer moves the point (the
#: integration's noise floor: the test functions of strongly unstable orbits carry ``rtol |M|``)
NOISE_FLOOR = 1e3


@dataclass(frozen=True)
class TracerSettings:
    """The loop's settings (resolved from :class:`~gearsym.analysis.continuation.CurveOptions`)."""

    ds: float
    ds_min: float
    ds_max: float
    max_angle: float
    max_points: int
    tol: float
    max_newton: int
    locate: bool
    detect: bool


@dataclass
class Node:
    """An accepted point of the curve."""

    y: np.ndarray
    ev: AugEval
    t: np.ndarray
    tau: dict[str, float]
    iterations: int = 0


@dataclass
class Leg:
    """One direction of the curve from its first point: the accepted points, the special points
    (``(index of the point, type, info)``) and why it ended."""

    nodes: list[Node]
    specials: list[tuple[int, str, dict[str, Any]]] = field(default_factory=list)
    stop_reason: str = ""
    complete: bool = False
    n_rejected: int = 0


class Tracer:
    """The predictor-corrector loop on one augmented system.

    Parameters
    ----------
    aug
        The augmented system (its scales set).
    settings
        The loop's settings.
    box
        ``((lo_1, hi_1), (lo_2, hi_2))``: the parameter ranges (infinite bounds allowed).
    tests
        ``tests(y, ev) -> dict``: the codimension-2 test functions of an accepted point.
    fmt
        Formats ``(lambda_1, lambda_2)`` for messages.
    explain
        ``explain(node) -> str``: what to add to the reason when the curve cannot advance past a point.
    """

    def __init__(self, aug: Augmented, settings: TracerSettings, box: tuple[tuple[float, float], tuple[float, float]],
                 tests: Callable[[np.ndarray, AugEval], dict[str, float]], fmt: Callable[[np.ndarray], str],
                 explain: Callable[[Node], str] = lambda node: ""):
        self.aug, self.o, self.box, self.tests, self.fmt, self.explain = aug, settings, box, tests, fmt, explain
        self.S = np.concatenate([aug.x_scale, aug.lam_scale, aug.extra_scales()])
        self.Rs = aug.residual_scales()
        self.i_lam = aug.nx

    # ---------------------------------------------------------------- corrector
    def correct(self, y_guess: np.ndarray, row: np.ndarray, target: float) -> tuple[np.ndarray, AugEval, int, np.ndarray]:
        """Newton on ``G(y) = 0``, ``row . (y / S) = target``: ``(y, ev, iterations, J)`` (``J`` the
        unscaled Jacobian at the last iterate, test rows from the chord).

        Raises
        ------
        ConvergenceError, GearsymError
            No convergence, a failed integration, a singular bordered matrix.
        """
        y = np.asarray(y_guess, float).copy()
        Jt = None
        last, step = math.inf, math.inf
        tol = self.o.tol
        for it in range(self.o.max_newton + 1):
            ev = self.aug.evaluate(y, test_jac=Jt is None)
            if ev.J_test is not None:
                Jt = ev.J_test
            assert Jt is not None
            r = ev.R / self.Rs
            c = float(row @ (y / self.S) - target)
            norm = float(np.max(np.abs(r)))
            if not math.isfinite(norm):
                raise ConvergenceError("corrector: non-finite residual")
            J = np.vstack([ev.J_orbit, Jt])
            # converged: the residual below tol, or at the integration's noise floor (the last Newton
            # step moved the point by less than tol in scaled variables: the point is as good as the
            # integration makes it)
            if (norm <= tol or (step <= tol and norm <= NOISE_FLOOR * tol)) and abs(c) <= 1e-9:
                return y, ev, it, J
            if it == self.o.max_newton:
                break
            if norm > 0.3 * last and it > 0:
                Jt = None  # the chord stalls: renew the test rows at the next iterate
                if norm > 2 * last and norm > NOISE_FLOOR * tol:
                    raise ConvergenceError(f"corrector: Newton diverges (residual {norm:.3g})")
            last = norm
            A = np.vstack([J * self.S[None, :] / self.Rs[:, None], row[None, :]])
            try:
                dw = np.linalg.solve(A, -np.concatenate([r, [c]]))
            except np.linalg.LinAlgError:
                raise ConvergenceError("corrector: singular Newton matrix") from None
            if not np.all(np.isfinite(dw)):
                raise ConvergenceError("corrector: singular Newton matrix")
            step = float(np.max(np.abs(dw)))
            y = y + dw * self.S
        raise ConvergenceError(f"corrector: no convergence in {self.o.max_newton} Newton steps (residual {norm:.3g})")

    def tangent(self, J: np.ndarray, t_ref: np.ndarray) -> np.ndarray:
        """The unit null vector of the scaled Jacobian with ``t . t_ref > 0``."""
        Js = J * self.S[None, :] / self.Rs[:, None]
        A = np.vstack([Js, t_ref[None, :]])
        rhs = np.zeros(A.shape[0])
        rhs[-1] = 1.0
        try:
            t = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            t = np.linalg.svd(Js)[2][-1]
        if not np.all(np.isfinite(t)) or not np.any(t):
            t = np.linalg.svd(Js)[2][-1]
        t = t / np.linalg.norm(t)
        return -t if t @ t_ref < 0 else t

    def node(self, y: np.ndarray, ev: AugEval, J: np.ndarray, t_ref: np.ndarray, it: int) -> Node:
        """An accepted point: its tangent, its test functions; the borders and the row scales renewed there."""
        t = self.tangent(J, t_ref)
        tau = self.tests(y, ev) if self.o.detect else {}
        self.aug.accept(y, ev)
        self.equilibrate(J)
        return Node(np.asarray(y, float).copy(), ev, t, tau, it)

    def equilibrate(self, J: np.ndarray) -> None:
        """Scale every residual row by the norm of its row of the scaled Jacobian: a scaled residual is
        then the distance to that equation's solution set in the scaled unknowns (to first order), and
        ``tol`` means the same for the shooting rows and for test functions of any steepness."""
        norms = np.linalg.norm(J * self.S[None, :], axis=1)
        ok = np.isfinite(norms) & (norms > 0)
        self.Rs = np.where(ok, norms, self.Rs)

    def first(self, y0: np.ndarray, fixed: int, value: float) -> Node:
        """The first point: corrected with the parameter ``fixed`` (0 or 1) held at ``value``."""
        row = np.zeros(len(self.S))
        row[self.i_lam + fixed] = 1.0
        y, ev, it, J = self.correct(y0, row, value / self.S[self.i_lam + fixed])
        t_ref = np.zeros(len(self.S))
        t_ref[self.i_lam + 1 - fixed] = 1.0
        return self.node(y, ev, J, t_ref, it)

    # ---------------------------------------------------------------- the loop
    def trace(self, first: Node, direction: float, closing: Node | None = None) -> Leg:
        """Continue from ``first`` along ``direction * first.t`` until the curve ends."""
        A = Node(first.y, first.ev, direction * first.t, first.tau, first.iterations)
        leg = Leg([A])
        h = self.o.ds
        while True:
            if len(leg.nodes) >= self.o.max_points:
                leg.stop_reason = (f"max_points={self.o.max_points} reached at {self.fmt(self._lam(A.y))} before the "
                                   f"curve left the parameter box: raise max_points or ds_max")
                return leg
            try:
                B = self._step(A, h)
            except GearsymError as exc:
                leg.n_rejected += 1
                h *= 0.5
                if h < self.o.ds_min:
                    leg.stop_reason = (f"the curve cannot advance: step size below ds_min={self.o.ds_min:g} at "
                                       f"{self.fmt(self._lam(A.y))}; last rejection: {exc}{self.explain(A)}")
                    return leg
                continue
            if self._ends(leg, A, B, closing if closing is not None else first):
                return leg
            it = B.iterations
            # (the test functions' rows are a chord: one or two iterations more than Newton's)
            h = min(2 * h, self.o.ds_max) if it <= 2 else min(1.5 * h, self.o.ds_max) if it <= 4 else \
                max(0.6 * h, self.o.ds_min) if it >= 7 else h
            if float(B.t @ A.t) < math.cos(0.5 * self.o.max_angle):
                h = max(0.7 * h, self.o.ds_min)
            A = self.reanchored(B)

    def reanchored(self, B: Node) -> Node:
        """``B`` in a moved shooting section when an event came near the section (:meth:`Augmented.reanchor`);
        its tangent from the Jacobian there, oriented by the parameters' (and extras') components."""
        try:
            y = self.aug.reanchor(B.y, B.ev)
        except GearsymError:
            return B  # (the shift's integration failed: keep the section)
        if y is None:
            return B
        ev = self.aug.evaluate(y, test_jac=True)
        assert ev.J_test is not None
        J = np.vstack([ev.J_orbit, ev.J_test])
        t_ref = B.t.copy()
        t_ref[:self.aug.nx] = 0.0
        if not np.any(t_ref):
            t_ref = B.t
        t = self.tangent(J, t_ref)
        self.equilibrate(J)
        tau = self.tests(y, ev) if self.o.detect else {}
        self.aug.accept(y, ev)
        return Node(y, ev, t, tau, B.iterations)

    def _lam(self, y: np.ndarray) -> np.ndarray:
        return y[self.i_lam:self.i_lam + 2]

    def _step(self, A: Node, h: float) -> Node:
        wA = A.y / self.S
        y, ev, it, J = self.correct((wA + h * A.t) * self.S, A.t, float(A.t @ wA) + h)
        t = self.tangent(J, A.t)
        cosang = float(t @ A.t)
        if cosang < math.cos(self.o.max_angle) and h > 4 * self.o.ds_min:
            raise ConvergenceError(f"tangent turned by {math.degrees(math.acos(max(-1.0, cosang))):.1f} deg")
        tau = self.tests(y, ev) if self.o.detect else {}
        self.aug.accept(y, ev)
        self.equilibrate(J)
        return Node(y, ev, t, tau, it)

    def _ends(self, leg: Leg, A: Node, B: Node, origin: Node) -> bool:
        """Append ``B`` (and the special points between ``A`` and ``B``); whether the curve ends there."""
        out = self._outside(B)
        if out is not None:
            try:
                B = self._boundary(A, B, *out)
                leg.stop_reason = f"reached the boundary {self.fmt(self._lam(B.y))} of the parameter box"
                leg.complete = True
            except GearsymError as exc:
                leg.stop_reason = (f"the curve left the parameter box between {self.fmt(self._lam(A.y))} and "
                                   f"{self.fmt(self._lam(B.y))}, but its point on the boundary could not be "
                                   f"corrected: {exc}")
        found = self._detect(A, B) if self.o.detect else []
        n_before = len(leg.specials)
        after_b = []
        for nd, name, info in found:
            if nd is None:
                after_b.append((name, info))  # detected, not located: reported at B
            else:
                leg.nodes.append(nd)
                leg.specials.append((len(leg.nodes) - 1, name, info))
        leg.nodes.append(B)
        leg.specials.extend((len(leg.nodes) - 1, name, info) for name, info in after_b)
        if out is not None:
            return True
        for idx, name, _ in leg.specials[n_before:]:
            if name in TERMINAL.get(self.aug.kind, ()):
                end = leg.nodes[idx]
                del leg.nodes[idx + 1:]  # the points beyond retrace the curve
                leg.specials = [sp for sp in leg.specials if sp[0] <= idx]
                leg.stop_reason = (f"ended at a {name.replace('resonance_1_', '1:')} resonance at "
                                   f"{self.fmt(self._lam(end.y))}: the Neimark-Sacker pair leaves the unit circle")
                leg.complete = True
                return True
        if len(leg.nodes) > 3 and self._passes(A, B, origin):
            leg.stop_reason = "the curve closed on itself"
            leg.complete = True
            return True
        return False

    def _outside(self, B: Node) -> tuple[int, float] | None:
        lam = self._lam(B.y)
        for k in range(2):
            lo, hi = self.box[k]
            if lam[k] > hi:
                return k, hi
            if lam[k] < lo:
                return k, lo
        return None

    def _boundary(self, A: Node, B: Node, k: int, bound: float) -> Node:
        """The point on the curve between ``A`` and ``B`` where parameter ``k`` equals ``bound``."""
        lA, lB = self._lam(A.y)[k], self._lam(B.y)[k]
        f = (bound - lA) / (lB - lA) if lB != lA else 1.0
        row = np.zeros(len(self.S))
        row[self.i_lam + k] = 1.0
        y, ev, it, J = self.correct(A.y + f * (B.y - A.y), row, bound / self.S[self.i_lam + k])
        t = self.tangent(J, A.t)
        return Node(y, ev, t, self.tests(y, ev) if self.o.detect else {}, it)

    def _passes(self, A: Node, B: Node, origin: Node) -> bool:
        """The step from ``A`` to ``B`` passes the curve's first point (a closed curve)."""
        keep = slice(self.aug.nx, None)  # the parameters and extras (the states may be in other sections)
        a, b, o = (A.y / self.S)[keep], (B.y / self.S)[keep], (origin.y / self.S)[keep]
        d = b - a
        L2 = float(d @ d)
        if L2 == 0:
            return False
        s = float((o - a) @ d) / L2
        if not 0.0 <= s <= 1.0:
            return False
        return float(np.linalg.norm(a + s * d - o)) < 0.25 * math.sqrt(L2) and float(origin.t[keep] @ A.t[keep]) > 0

    # ---------------------------------------------------------------- detection
    def _detect(self, A: Node, B: Node) -> list[tuple[Node | None, str, dict[str, Any]]]:
        """The special points between ``A`` and ``B`` in the order of the arclength: ``(node, type,
        info)``, ``node`` ``None`` for a point detected but not located (reported at ``B``)."""
        wA = A.y / self.S
        sB = float(A.t @ (B.y / self.S - wA))
        found: list[tuple[float, Node | None, str, dict[str, Any]]] = []
        cache: dict[float, Node] = {0.0: A, sB: B}
        for key, ta in A.tau.items():
            tb = B.tau.get(key, math.nan)
            if key.startswith("count|"):
                if math.isfinite(ta) and math.isfinite(tb) and ta != tb:
                    found.append(self._locate_count(A, B, key, sB, cache))
                continue
            floor = NOISY.get(key, 0.0)
            if not (math.isfinite(ta) and math.isfinite(tb)) or ta == 0 or tb == 0 or (ta > 0) == (tb > 0):
                continue
            if min(abs(ta), abs(tb)) <= floor:
                continue
            found.append(self._locate(A, B, key, sB, cache))
        found.sort(key=lambda p: abs(p[0]))
        return [(nd, name, info) for _, nd, name, info in found]

    def _locate(self, A: Node, B: Node, key: str, sB: float, cache: dict[float, Node]
                ) -> tuple[float, Node | None, str, dict[str, Any]]:
        """Locate the sign change of ``key`` between ``A`` and ``B``: ``(sigma, node, type, info)``."""
        name = self._special_name(key)
        failures: list[str] = []
        wA = A.y / self.S

        def at(s: float) -> Node:
            nd = cache.get(s)
            if nd is None:
                f = s / sB if sB else 0.0
                y, ev, it, J = self.correct(A.y + f * (B.y - A.y), A.t, float(A.t @ wA) + s)
                nd = Node(y, ev, self.tangent(J, A.t), self.tests(y, ev), it)
                cache[s] = nd
            return nd

        def f(s: float) -> float:
            try:
                return at(s).tau.get(key, math.nan)
            except GearsymError as exc:
                failures.append(str(exc))
                return math.nan

        if not self.o.locate or sB == 0:
            return sB, None, name, self._info(key, False, A, B, "location not asked for")
        xtol = max(1e-12, 1e-7 * abs(sB))
        s, a, fa, b, fb = bracket_root(f, 0.0, A.tau[key], sB, B.tau[key], xtol)
        left, right = cache.get(min(a, b, key=abs), A), cache.get(max(a, b, key=abs), B)
        if abs(b - a) > xtol and min(abs(fa), abs(fb)) > 1e-6 * max(abs(A.tau[key]), abs(B.tau[key])):
            reason = failures[-1] if failures else "the test function could not be evaluated inside the bracket"
            return sB, None, name, self._info(key, False, left, right, f"the location stopped: {reason}")
        try:
            nd = at(s)
        except GearsymError as exc:
            return sB, None, name, self._info(key, False, left, right, f"the point at the root failed: {exc}")
        if nd is A or nd is B:
            nd = Node(nd.y.copy(), nd.ev, nd.t, nd.tau, nd.iterations)
        info = self._info(key, True, left, right)
        info["value_of_test_function"] = float(nd.tau.get(key, math.nan))
        return s, nd, name, info

    def _locate_count(self, A: Node, B: Node, key: str, sB: float, cache: dict[float, Node]
                      ) -> tuple[float, Node | None, str, dict[str, Any]]:
        """Bisection on a count that changed between ``A`` and ``B`` (the contact events: a local
        extremum of a switching function crossed zero): ``(sigma, node, type, info)``."""
        name = self._special_name(key)
        wA = A.y / self.S
        a, b, left, right = 0.0, sB, A, B
        counts = [int(A.tau[key]), int(B.tau[key])]
        reason = ""
        while self.o.locate and abs(b - a) > max(1e-9, 1e-5 * abs(sB)):
            c = 0.5 * (a + b)
            try:
                y, ev, it, J = self.correct(A.y + (c / sB) * (B.y - A.y), A.t, float(A.t @ wA) + c)
            except GearsymError as exc:
                reason = f"the bisection stopped: {exc}"
                break
            nd = Node(y, ev, self.tangent(J, A.t), self.tests(y, ev), it)
            if nd.tau.get(key) == A.tau[key]:
                a, left = c, nd
            else:
                b, right = c, nd
        info = self._info(key, not reason and self.o.locate, left, right, reason or (
            "" if self.o.locate else "location not asked for"))
        info.update(events=counts, nonsmooth=True)
        if not info["located"]:
            return sB, None, name, info
        if right is B:
            right = Node(B.y.copy(), B.ev, B.t, B.tau, B.iterations)
        return b, right, name, info

    def _special_name(self, key: str) -> str:
        if key == "resonance":
            return "resonance_1_1" if self.aug.kind == "fold" else "resonance_1_2"
        if key.startswith(("grazing|", "count|")):
            return "double_grazing" if self.aug.kind == "grazing" else f"{self.aug.kind}_grazing"
        return key

    def _info(self, key: str, located: bool, left: Node, right: Node, reason: str = "") -> dict[str, Any]:
        """What a special point reports: located or not, its bracket, the test function."""
        info: dict[str, Any] = {"located": located, "test_function": key,
                                "bracket": [self._lam(left.y).tolist(), self._lam(right.y).tolist()]}
        if key.startswith("grazing|"):
            _, surface, side = key.split("|")
            info.update(surface=surface, side=side)
        if reason:
            info["reason"] = reason
        return info
