"""Detection and location of special points between two neighbouring branch points.

The test functions of :mod:`gearsym.analysis.continuation._bifurcation` are compared at two
accepted points; a sign change is located by solving ``tau(sigma) = 0`` in the
arclength ``sigma`` between them (each evaluation a corrected point on the hyperplane
``row . (w - w_A) = sigma``).  A change of the number of unstable multipliers that no
test function explains (a multiplier jumping at a non-smooth point) is located by
bisection and classified by the multiplier that crossed.

Nothing detected is dropped: a special point whose location fails (a correction inside the
bracket that does not converge) is reported as detected but not located, at the branch point
after the change, with ``info["located"] = False``, the ``bracket`` of parameter values it lies
in and the ``reason``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ...errors import GearsymError, ParameterError
from ..periodic import complex_sides
from ._bifurcation import bracket_root, crossing_multiplier, unit_circle_pair
from ._corrector import Continuer, Node

__all__ = ["ALL_TYPES", "boundary_node", "detect_between", "detect_types"]

#: The special points a continuation can detect (see :data:`gearsym.analysis.continuation.BIFURCATION_TYPES`).
ALL_TYPES = ("fold", "period_doubling", "neimark_sacker", "grazing", "branch_point")


def boundary_node(C: Continuer, A: Node, B: Node, bound: float) -> Node:
    """The point on the branch between A and B where the parameter equals ``bound``.

    Newton at the fixed parameter ``bound`` from the interpolation between A and B, then
    from A's and from B's unknowns.

    Raises
    ------
    GearsymError
        None of the three corrections converged (the last one's error).
    """
    lamA, lamB = float(A.z[-1]), float(B.z[-1])
    f = (bound - lamA) / (lamB - lamA)
    row = np.zeros(len(A.z))
    row[-1] = 1.0
    last: GearsymError | None = None
    for z_guess in (A.z + f * (B.z - A.z), A.z.copy(), B.z.copy()):
        z_guess[-1] = bound
        try:
            z, ev, it = C.correct(z_guess, row, bound / C.S[-1], t_ref=A.t)
            return C.make_node(z, ev, A.t, it, ref=A)
        except GearsymError as exc:
            last = exc
    assert last is not None
    raise last


def _node_at(C: Continuer, A: Node, B: Node, sigma: float, sigma_B: float, cache: dict[float, Node],
             row: np.ndarray) -> Node:
    """The branch point with ``row . (w - w_A) = sigma`` between A and B (corrected)."""
    nd = cache.get(sigma)
    if nd is not None:
        return nd
    f = sigma / sigma_B if sigma_B else 0.0
    z_guess = A.z + f * (B.z - A.z)
    z, ev, it = C.correct(z_guess, row, float(row @ (A.z / C.S)) + sigma, t_ref=A.t)
    nd = C.make_node(z, ev, A.t, it, ref=A)
    cache[sigma] = nd
    return nd


def _sign_change(a: float, b: float) -> bool:
    return math.isfinite(a) and math.isfinite(b) and (a > 0) != (b > 0) and a != 0 and b != 0


def detect_between(C: Continuer, A: Node, B: Node, types: tuple[str, ...], locate: bool,
                    row: np.ndarray | None = None) -> list[tuple[Node, str, dict[str, Any]]]:
    """Locate the special points between two neighbouring branch points.

    The points in between are parametrised by ``sigma = row . (w - w_A)`` (``row``:
    A's tangent for an arclength step, the parameter axis for a natural step).
    """
    if row is None:
        row = A.t
    wA = A.z / C.S
    sigma_B = float(row @ (B.z / C.S - wA))
    cache: dict[float, Node] = {0.0: A, sigma_B: B}
    found: list[tuple[float, Node, str, dict[str, Any]]] = []
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
            found.append((sigma_B, B, kind, dict(info, located=False, bracket=_bracket(A, B),
                                                 reason="location not asked for" if not locate else
                                                 "the two points coincide")))
            continue
        rec = _locate_root(C, A, B, key, kind, info, sigma_B, cache, row)
        if rec is not None:
            found.append(rec)
    # an unexplained change of the number of unstable multipliers (a jump at a non-smooth point)
    if locate and A.point.n_unstable != B.point.n_unstable and not any(
            k in ("fold", "period_doubling", "neimark_sacker", "branch_point", "grazing") for _, _, k, _ in found):
        nd_info = _locate_jump(C, A, B, sigma_B, cache, row)
        if nd_info is not None and nd_info[2] in types:
            found.append(nd_info)
    found.sort(key=lambda x: abs(x[0]))
    return [(nd, kind, info) for _, nd, kind, info in found]


def _bracket(left: Node, right: Node) -> list[float]:
    """The parameter values of the two branch points a special point lies between."""
    return [float(left.z[-1]), float(right.z[-1])]


def _unlocated(A: Node, B: Node, a: float, b: float, sigma_B: float, cache: dict[float, Node], kind: str,
               info: dict[str, Any], reason: str) -> tuple[float, Node, str, dict[str, Any]]:
    """A special point detected between A and B whose location failed: reported at the branch
    point after the change (the right end of the last bracket) with the bracket and the reason,
    never dropped."""
    lo, hi = (a, b) if abs(a) <= abs(b) else (b, a)
    left, right = cache.get(lo, A), cache.get(hi, B)
    return (hi if hi in cache else sigma_B, right, kind,
            dict(info, located=False, bracket=_bracket(left, right), reason=reason))


def _locate_root(C: Continuer, A: Node, B: Node, key: str, kind: str, info: dict[str, Any], sigma_B: float,
                 cache: dict[float, Node], row: np.ndarray) -> tuple[float, Node, str, dict[str, Any]] | None:
    """Locate the sign change of the test function ``key`` between A and B: ``(sigma, node, kind,
    info)``; ``None`` only where the classification says it is no bifurcation (a numerical flip of
    the tangent without a multiplier at +1, a neutral saddle); a location that fails is reported
    as detected but not located (:func:`_unlocated`)."""
    failures: list[str] = []

    def f(s: float) -> float:
        try:
            return _node_at(C, A, B, s, sigma_B, cache, row).tau.get(key, math.nan)
        except GearsymError as exc:
            failures.append(str(exc))
            return math.nan

    xtol = max(1e-12, 1e-7 * abs(sigma_B))
    s_root, a, fa, b, fb = bracket_root(f, 0.0, A.tau[key], sigma_B, B.tau[key], xtol)
    if abs(b - a) > xtol and min(abs(fa), abs(fb)) > 1e-6 * max(abs(A.tau[key]), abs(B.tau[key])):
        # the root finding stopped before the bracket shrank and without a small value (failed
        # corrections: bracket_root's NaN exit)
        return _unlocated(A, B, a, b, sigma_B, cache, kind, info, "the location stopped: " + (
            failures[-1] if failures else "the test function could not be evaluated inside the bracket"))
    try:
        nd = _node_at(C, A, B, s_root, sigma_B, cache, row)
    except GearsymError as exc:
        return _unlocated(A, B, a, b, sigma_B, cache, kind, info, f"the point at the root failed: {exc}")
    scale = max(abs(A.tau[key]), abs(B.tau[key]))
    nonsmooth = abs(b - a) <= 10 * xtol and min(abs(fa), abs(fb)) > 1e-3 * scale
    info["located"] = True
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
            return None  # a neutral saddle (real pair with product 1): not a bifurcation
        info["frequency_ratio"] = float(abs(np.angle(m)) / (2 * np.pi))
    if kind == "period_doubling":
        mu = nd.point.multipliers
        info["multiplier"] = complex(mu[np.argmin(np.abs(mu + 1.0))])
    if kind in ("fold", "branch_point"):
        mu = nd.point.multipliers
        if len(mu):
            m1 = complex(mu[np.argmin(np.abs(mu - 1.0))])
            if abs(m1 - 1.0) > 0.05 and not nonsmooth and kind == "fold":
                return None  # no multiplier at +1: a numerical flip of the tangent, not a fold
            info["multiplier"] = m1
    return (s_root, nd, kind, info)


def _locate_jump(C: Continuer, A: Node, B: Node, sigma_B: float, cache: dict[float, Node],
                 row: np.ndarray):
    """Bisection on the number of unstable multipliers; classification by the crossing multiplier."""
    a, b = 0.0, sigma_B
    na = A.point.n_unstable
    left, right = A, B
    failure = ""
    for _ in range(40):
        if abs(b - a) <= max(1e-12, 1e-8 * abs(sigma_B)):
            break
        c = 0.5 * (a + b)
        try:
            nd = _node_at(C, A, B, c, sigma_B, cache, row)
        except GearsymError as exc:
            failure = str(exc)  # classified from the bracket reached so far, reported as not located
            break
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
    if failure:
        return (b, right, kind, dict(info, located=False, bracket=_bracket(left, right),
                                     reason=f"the bisection stopped: {failure}"))
    return (b, right, kind, dict(info, located=True))


def detect_types(detect: Sequence[str] | bool) -> tuple[str, ...]:
    """The bifurcation types to detect: ``True`` all of :data:`ALL_TYPES`, ``False`` none, or a list."""
    if detect is True:
        return ALL_TYPES
    if detect is False:
        return ()
    out = tuple(detect)
    for d in out:
        if d not in ALL_TYPES:
            raise ParameterError(f"unknown bifurcation type '{d}' (have: {', '.join(ALL_TYPES)})")
    return out
