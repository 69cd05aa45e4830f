"""Reference scales of the dimensionless form: time, length, mass and one per coordinate.

Defaults (each overridable in the model's ``[dimensionless]`` section), the choices a
gear researcher makes by hand:

* **time** ``1/omega_n``: the natural frequency of the model with every effect
  switched off (its linear time-invariant core), ``omega_n^2 = -d(q1'')/d(q1)`` at the
  zero state for the first coordinate ``q1`` (for a gear pair ``k_m/m_e``);
* **length**: the half backlash of the first mesh with one (at the zero state, e.g.
  ``b_s`` for a dynamic backlash ``b_s + b_dy(x)``; each element type offers its candidate,
  :meth:`~gearsym.symbolic.elements.base.SymbolicElement.length_scale`), else the static deflection
  ``(q1'' at the zero state)/omega_n^2`` of that core (mean load over stiffness), else
  1 m;
* **mass**: the inertia of the first coordinate (the equivalent mass ``m_e`` of a
  reduced pair), divided by the length scale squared for a rotation; so the force
  scale ``mass*length/time^2`` is the stiffness times the length scale -- the mean
  load when the length scale is the static deflection;
* **coordinates**: a length coordinate takes the length scale, an angle 1, any other
  the product of the base scales of its unit.

A model whose time is already dimensionless (``time_unit = "1"``) keeps every scale 1.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import sympy as sp

from ..errors import GearsymError, SpecError
from .dims import LENGTH, MASS, TIME, ZERO, Dimensions, monomial


@dataclass(frozen=True)
class Scales:
    """Reference scales, as expressions of the (structured) model's symbols.

    Attributes
    ----------
    time, length, mass
        Base scales ``T``, ``L``, ``M``.
    coordinates
        Scale of each coordinate (by coordinate symbol).
    origin
        How each scale was chosen (``"time"``, ``"length"``, ``"mass"``, coordinate names).
    """

    time: sp.Expr
    length: sp.Expr
    mass: sp.Expr
    coordinates: dict[sp.Symbol, sp.Expr]
    origin: dict[str, str]


def _zero_state(model, expr: sp.Expr) -> sp.Expr:
    """``expr`` at the zero state, t = 0, every surface side +1, schedule indices 0."""
    sub = {s: sp.Integer(0) for s in model.states}
    sub[model.t] = sp.Integer(0)
    sub.update({s: sp.Integer(1) for s in model.modal.sigma})
    for s in model.schedules:
        sub[s.n] = sp.Integer(0)
        sub[s.seg] = sp.Integer(0)
    for sym in model.ns.sched_n.values():
        sub.setdefault(sym, sp.Integer(0))
    for sym in model.ns.sched_seg.values():
        sub.setdefault(sym, sp.Integer(0))
    return expr.xreplace(sub)


def _core(model):
    """The structured model of the same scene with every effect switched off (or ``None``)."""
    rs = model.resolved
    off = dataclasses.replace(rs, effects={e: False for e in rs.effects})
    try:
        return type(model)(off, structured=True)  # (no import of the model module: no cycle)
    except (GearsymError, ValueError, TypeError, ZeroDivisionError):
        return None


def _positive_number(expr: sp.Expr, values: dict[sp.Symbol, float]) -> bool:
    try:
        v = float(expr.xreplace(values))
    except (TypeError, ValueError):
        return False
    return math.isfinite(v) and v > 0


def choose_scales(model, dims: Dimensions, values: dict[sp.Symbol, float],
                  translate: Callable[[object, sp.Expr], sp.Expr] | None = None) -> Scales:
    """Reference scales of a structured model (see the module docstring).

    Parameters
    ----------
    model
        The structured :class:`~gearsym.symbolic.model.SymbolicModel`.
    dims
        Dimensions of its symbols.
    values
        Numeric values of its parameters and derived symbols (to check signs).
    translate
        ``translate(namespace, expr)``: an expression of the core model (every effect
        off) in this model's symbols (default: the core's definitions inlined).
    """
    spec = model.spec
    dl = spec.dimensionless
    ns = model.ns
    one = sp.Integer(1)
    q = model.coordinates
    origin: dict[str, str] = {}

    def parse(text: str, where: str) -> sp.Expr:
        e = ns.parse(text, where)
        if e.free_symbols & set(model.states) or e.has(model.t):
            raise SpecError("a reference scale must depend on parameters only", file=spec.path, field=where)
        return e

    if spec.time_dims == dims_unit_one() and not (dl and (dl.time or dl.length or dl.mass or dl.coordinates)):
        origin.update(time="the model is dimensionless", length="the model is dimensionless",
                      mass="the model is dimensionless")
        return Scales(one, one, one, {c: one for c in q}, origin)

    core = None
    T = L = M = None
    if dl is not None and dl.time:
        T = parse(dl.time, "dimensionless.time")
        origin["time"] = "[dimensionless] time"
    k2 = c0 = None
    if T is None or (dl is None or not dl.length):
        core = _core(model)
        if core is not None and core.accelerations is not None and core.coordinates:
            q1 = core.coordinates[0]
            a1 = core.accelerations[0]
            tr = translate or (lambda ns_, e: ns_.inline(e))
            k2 = tr(core.ns, _zero_state(core, -sp.diff(a1, q1)))
            c0 = tr(core.ns, _zero_state(core, a1))
            if k2.free_symbols & (set(core.states) | {core.t}) or not _positive_number(k2, values) \
                    or not (k2.free_symbols <= set(values)):
                k2 = None
    if T is None:
        if k2 is not None:
            T = 1 / sp.sqrt(k2)
            origin["time"] = "1/omega_n, omega_n^2 = -d(q1'')/d(q1) with every effect off"
        else:
            T = one
            origin["time"] = "1 (no natural frequency found)"
    if dl is not None and dl.length:
        L = parse(dl.length, "dimensionless.length")
        origin["length"] = "[dimensionless] length"
    if L is None:
        for name, part in model.elements.items():  # each element's candidate (a half backlash)
            b = part.length_scale()
            if b is None or b == 0:
                continue
            b = _zero_state(model, b)
            if dims(b) == LENGTH and _positive_number(ns.inline(b), values):
                L = b
                origin["length"] = f"half backlash of {name}"
                break
    if L is None and k2 is not None and c0 is not None and c0 != 0 and core is not None:
        dq = dims(core.coordinates[0])
        xs = c0 / k2
        if dq == LENGTH and _positive_number(abs(xs), values):
            L = xs if _positive_number(xs, values) else -xs
            origin["length"] = "static deflection (mean load / stiffness) with every effect off"
    if L is None:
        L = one
        origin["length"] = "1 m (no backlash or static deflection found)"
    if dl is not None and dl.mass:
        M = parse(dl.mass, "dimensionless.mass")
        origin["mass"] = "[dimensionless] mass"
    if M is None:
        m00 = model.mass_matrix[0, 0] if model.mass_matrix.shape[0] else one
        d = dims(m00)
        if d[0] == 1 and not (m00.free_symbols & set(model.states)):
            M = m00 / monomial((0, d[1], d[2]), (one, L, T))
            origin["mass"] = f"inertia of {q[0]}" if d == MASS else f"inertia of {q[0]} / length^2"
        else:
            M = one
            origin["mass"] = "1 kg"
    coords: dict[sp.Symbol, sp.Expr] = {}
    for c in q:
        name = str(c)
        if dl is not None and name in dl.coordinates:
            coords[c] = parse(dl.coordinates[name], f"dimensionless.coordinates.{name}")
            origin[name] = "[dimensionless] coordinates"
            continue
        d = dims(c)
        if d == LENGTH:
            coords[c] = L
            origin[name] = "length scale"
        elif d == ZERO:
            coords[c] = one
            origin[name] = "1 (dimensionless or an angle)"
        else:
            coords[c] = monomial(d, (M, L, T))
            origin[name] = "product of the base scales of its unit"
    _ = TIME
    return Scales(T, L, M, coords, origin)


def dims_unit_one():
    """The spec layer's dimensionless unit (for comparing ``ModelSpec.time_dims``)."""
    from ..spec.units import ONE

    return ONE
