"""Algebraic variables and constraints of a model (``[algebraic]``, ``[constraints.NAME]``).

A constraint ties one coordinate to the others, ``q_d = h(t, q)`` (a rigid coupling:
``th_L = th2``), and is enforced by a reaction force, an *algebraic variable* of the
model (``tau_c``): a state of the DAE whose derivative never appears.  The symbolic layer
removes ``q_d`` and its velocity from the states (every expression reads ``h`` and
``dh/dt`` instead), adds the reaction ``lambda * dC/dq_i`` with ``C = q_d - h`` to the
generalised forces (``+lambda`` on ``q_d``, ``-lambda * dh/dq_i`` on the others) and keeps
the equation of motion of ``q_d`` (with ``q_d'' = h''``) as the algebraic equation that
determines ``lambda``: an index-1 DAE for IDA (see ``docs/spec.md``).

The checks here name the field: an algebraic variable that no constraint uses, a
constraint that names an unknown coordinate or algebraic variable, a constraint whose
``equals`` uses a name that is not a parameter, derived quantity, time or another
(kept) coordinate, unit mismatches, and algebraic variables used outside ``[outputs]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from . import expressions as ex
from .fields import Ctx, as_table, expr_str, only_keys, string, table, unit_of
from .units import Unit

if TYPE_CHECKING:
    from .model import ModelSpec


@dataclass(frozen=True)
class Algebraic:
    """An algebraic variable (the reaction of a constraint): name, unit, meaning."""

    name: str
    unit: str
    meaning: str
    dims: Unit


@dataclass(frozen=True)
class Constraint:
    """``coordinate = equals`` (a function of time, parameters and the other coordinates),
    enforced by the generalised force ``multiplier`` on ``coordinate``."""

    name: str
    coordinate: str
    equals: str
    multiplier: str
    meaning: str = ""


def parse_algebraic(ctx: Ctx, data: dict[str, Any], declare: Any) -> dict[str, Algebraic]:
    """Read ``[algebraic]``: ``NAME = { unit, meaning }``."""
    out: dict[str, Algebraic] = {}
    for name, a in table(ctx, data, "algebraic").items():
        where = f"algebraic.{name}"
        a = as_table(ctx, where, a)
        only_keys(ctx, where, a, {"unit", "meaning"})
        declare(name, where)
        unit = string(ctx, a, f"{where}.unit") or "1"
        dims = unit_of(ctx, f"{where}.unit", unit)
        if dims.scale != 1.0:
            raise ctx.error(f"{where}.unit", f"algebraic variables must be in coherent SI units, not '{unit}'")
        out[name] = Algebraic(name, unit, string(ctx, a, f"{where}.meaning") or "", dims)
    return out


def parse_constraints(ctx: Ctx, data: dict[str, Any]) -> dict[str, Constraint]:
    """Read ``[constraints.NAME]``: ``coordinate``, ``equals``, ``multiplier``, ``meaning``."""
    from .names import check_symbol_name

    out: dict[str, Constraint] = {}
    for name, c in table(ctx, data, "constraints").items():
        where = f"constraints.{name}"
        problem = check_symbol_name(name)
        if problem:
            raise ctx.error(where, problem)
        c = as_table(ctx, where, c)
        only_keys(ctx, where, c, {"coordinate", "equals", "multiplier", "meaning"})
        out[name] = Constraint(
            name, string(ctx, c, f"{where}.coordinate", required=True) or "",
            expr_str(ctx, f"{where}.equals", c.get("equals")),
            string(ctx, c, f"{where}.multiplier", required=True) or "",
            string(ctx, c, f"{where}.meaning") or "")
    return out


def validate_constraints(ctx: Ctx, spec: ModelSpec, units: dict[str, Unit], energy: Unit | None,
                         term_fields: list[tuple[str, str]]) -> None:
    """Cross-field checks of ``[algebraic]`` and ``[constraints]`` (see the module docstring).

    Parameters
    ----------
    ctx
        Parsing context (file name for errors).
    spec
        The model.
    units
        Unit of every name (coordinates, parameters, derived quantities, ...).
    energy
        The model's energy unit (``None`` if no element fixed it).
    term_fields
        ``(field, expression)`` of every expression outside ``[outputs]`` and ``[constraints]``.
    """
    alg, cons = spec.algebraic, spec.constraints
    if not alg and not cons:
        return
    if spec.form != "implicit":
        where = f"constraints.{next(iter(cons))}" if cons else f"algebraic.{next(iter(alg))}"
        raise ctx.error(where, "algebraic variables and constraints need [model] form = \"implicit\" "
                               "(the model is a DAE integrated by IDA)")
    if spec.reduction is not None:
        raise ctx.error("reduction", "a model with [constraints] cannot have a [reduction]")
    used: dict[str, str] = {}
    eliminated: dict[str, str] = {}
    for c in cons.values():
        w = f"constraints.{c.name}"
        if c.coordinate not in spec.coordinates:
            raise ctx.error(f"{w}.coordinate", f"unknown coordinate '{c.coordinate}' "
                                               f"(coordinates: {', '.join(spec.coordinates)})")
        if spec.coordinates[c.coordinate].effect is not None:
            raise ctx.error(f"{w}.coordinate", f"coordinate '{c.coordinate}' is gated by an effect; a "
                                               f"constraint needs a coordinate that always exists")
        if c.coordinate in eliminated:
            raise ctx.error(f"{w}.coordinate", f"coordinate '{c.coordinate}' is already constrained by "
                                               f"{eliminated[c.coordinate]}")
        eliminated[c.coordinate] = w
        if c.multiplier not in alg:
            raise ctx.error(f"{w}.multiplier", f"unknown algebraic variable '{c.multiplier}' (declare it in "
                                               f"[algebraic]; have: {', '.join(alg) or 'none'})")
        if c.multiplier in used:
            raise ctx.error(f"{w}.multiplier", f"algebraic variable '{c.multiplier}' already enforces "
                                               f"{used[c.multiplier]}")
        used[c.multiplier] = w
    for a in alg.values():
        if a.name not in used:
            raise ctx.error(f"algebraic.{a.name}", f"algebraic variable '{a.name}' is not the multiplier of "
                                                   f"any [constraints] entry (each needs exactly one)")
    kept = {q for q in spec.coordinates if q not in eliminated}
    allowed = {"t"} | kept | set(spec.parameters) | set(spec.derived)
    velocities = {c.velocity for c in spec.coordinates.values()}
    for c in cons.values():
        w = f"constraints.{c.name}.equals"
        try:
            names = ex.names_in(c.equals)
            u = ex.infer_unit(c.equals, units)
        except ex.ExpressionError as exc:
            raise ctx.error(w, str(exc)) from None
        for n in sorted(names):
            if n in eliminated:
                raise ctx.error(w, f"'{n}' is a constrained coordinate itself (no chains of constraints)")
            if n in velocities or n in alg:
                raise ctx.error(w, f"'{n}' may not appear: a constraint is a relation between coordinates "
                                   f"(positions), time and parameters")
            if n not in allowed:
                raise ctx.error(w, f"unknown name '{n}'")
        q = spec.coordinates[c.coordinate]
        if not u.same_dimension(q.dims):
            raise ctx.error(w, f"unit mismatch: [{u.si_string()}] but coordinate '{q.name}' is "
                               f"[{q.dims.si_string()}]")
        lam = alg[c.multiplier]
        if energy is not None and not (lam.dims * q.dims).same_dimension(energy):
            raise ctx.error(f"algebraic.{lam.name}.unit",
                            f"unit mismatch: the reaction on '{q.name}' does work in "
                            f"[{(lam.dims * q.dims).si_string()}], the model's energy is [{energy.si_string()}]")
    for where, text in term_fields:
        try:
            bad = sorted(ex.names_in(text) & set(alg))
        except ex.ExpressionError:
            continue
        if bad:
            raise ctx.error(where, f"algebraic variable '{bad[0]}' may appear only in [outputs] (and as a "
                                   f"constraint's multiplier)")
