"""Modes and switching functions of the hybrid system.

Every state-dependent condition in the equations (a ``Piecewise`` branch, or an
``Abs``/``sign``/``Max``/``Min``/``Heaviside`` of a state expression) is a switching
surface ``g(t, x, p) = 0``.  The *modal form* replaces each such condition by the
side ``sigma_j(t)`` (+1 or -1) of its surface, which the engine holds fixed between
events: for fixed ``sigma`` the right-hand side is smooth, so the integrator never
steps across a kink, and root finding on ``g`` locates every transition exactly.
Conditions on schedule segments (piecewise-in-time coefficients) stay as they are:
the engine sets the segment index between scheduled breakpoints.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import sympy as sp
from sympy.core.relational import Relational

from ..errors import SpecError
from .budget import MAX_SURFACES, checkpoint
from .parsing import internal_symbol
from .surfaces import SurfaceHint

if TYPE_CHECKING:
    from .model import SymbolicModel

@dataclass(frozen=True)
class ScheduleInfo:
    """A schedule of breakpoints: period and break fractions (0 first)."""

    name: str
    period: sp.Expr
    breaks: tuple[sp.Expr, ...]
    n: sp.Symbol
    seg: sp.Symbol


@dataclass(frozen=True)
class Mode:
    """A named mode of the hybrid system (e.g. drive-side contact)."""

    name: str
    condition: str


@dataclass(frozen=True)
class SwitchingFunction:
    """A switching surface ``g(t, x, p) = 0`` whose crossing changes the mode.

    Attributes
    ----------
    name
        E.g. ``mesh.drive`` / ``mesh.back`` for the two flanks of a backlash mesh.
    expr
        ``g`` in terms of the states, time and parameters.
    meaning
        What the ``g > 0`` side means.
    contact_sign
        ``+1`` if ``g > 0`` is the contact side, ``-1`` if ``g < 0`` is, ``0`` if the
        surface is not a contact surface.
    kind
        ``"drive"``, ``"back"`` or ``"switch"``.
    origin
        The spec field it is written in (``elements.fx.value[1]``), if known.
    given
        Whether the user named it (the ``surface`` key of a term).
    """

    name: str
    expr: sp.Expr
    meaning: str
    contact_sign: int = 0
    kind: str = "switch"
    origin: str = ""
    given: bool = False

    @classmethod
    def of_hint(cls, hint: SurfaceHint) -> SwitchingFunction:
        """The switching function of a surface found in a spec field."""
        return cls(hint.name, hint.expr, hint.meaning, 0, "switch", hint.origin, hint.given)



_NONSMOOTH = (sp.Abs, sp.sign, sp.Max, sp.Min, sp.Heaviside)


@dataclass
class ModalForm:
    """Right-hand side with conditions replaced by surface sides.

    Attributes
    ----------
    rhs
        Explicit first-order right-hand side in terms of ``sigma`` (or ``None``
        for implicit models).
    forces
        Generalised forces in terms of ``sigma`` (implicit models).
    surfaces
        The switching functions, in the order of ``sigma``.
    sigma
        One symbol per surface: +1 on its ``g > 0`` side, -1 on the other.
    used_schedules
        Names of the schedules the equations use.
    algebraic
        The constraint rows of a model with algebraic variables
        (:mod:`gearsym.symbolic.constraints`), in terms of ``sigma``.
    """

    rhs: sp.Matrix
    forces: sp.Matrix
    surfaces: list[SwitchingFunction]
    sigma: list[sp.Symbol]
    used_schedules: set[str]
    algebraic: sp.Matrix = field(default_factory=lambda: sp.Matrix([]))


def make_modal(model: SymbolicModel, hints: list[SwitchingFunction]) -> ModalForm:
    """Build the modal form of a model (see module docstring)."""
    states = set(model.states)
    t = model.t
    ns = model.ns
    seg_syms = {ns.sched_seg[s]: s for s in ns.sched_seg}
    n_syms = {ns.sched_n[s]: s for s in ns.sched_n}
    reg = _Registry(states, hints, model.spec.path)
    surfaces, sigma, register = reg.surfaces, reg.sigma, reg.register

    def to_sigma(rel: Relational) -> sp.Basic:
        free = rel.free_symbols
        if not (free & states):
            if t in free:
                raise SpecError(
                    f"the condition '{rel}' depends on time: declare a [schedules] entry and "
                    f"use a piecewise_cycle field (or <schedule>_segment) so that the integrator "
                    f"stops exactly at its breakpoints", file=model.spec.path)
            return rel
        if isinstance(rel, (sp.Eq, sp.Ne)):
            raise SpecError(f"equality condition on states '{rel}' is not a switching surface",
                            file=model.spec.path)
        j, sgn = register(rel.lhs - rel.rhs)
        s = sigma[j] * sgn
        if isinstance(rel, (sp.StrictGreaterThan, sp.GreaterThan)):
            return s > 0
        return s < 0

    def smooth_out(expr: sp.Expr) -> sp.Expr:
        # rewrite nonsmooth functions of states as Piecewise so that their kinks are surfaces;
        # not inside conditions: a continuous nonsmooth switching function (e.g. a contact
        # condition x > B(state) whose B has a Max) stays ONE surface -- rewriting it would
        # make sympy split the condition into ITE branches, i.e. spurious extra surfaces
        def fix(e: sp.Basic) -> sp.Basic:
            if isinstance(e, _NONSMOOTH) and (e.free_symbols & states):
                if isinstance(e, sp.Heaviside):  # (sympy's rewrite has Eq(x, 0): not a surface)
                    return sp.Piecewise((1, e.args[0] > 0), (0, True))
                return e.rewrite(sp.Piecewise)
            return e
        return _bottom_up(expr, fix, skip=Relational)

    def modalise(expr: sp.Expr) -> sp.Expr:
        expr = smooth_out(expr)

        def fix(e: sp.Basic) -> sp.Basic:
            if isinstance(e, sp.Piecewise):
                args = []
                for val, cond in e.args:
                    if cond not in (sp.true, sp.false):  # surfaces in the order they are met (not a set's)
                        cond = cond.xreplace({r: to_sigma(r) for r in _relationals(cond)})
                    args.append((val, cond))
                return sp.Piecewise(*args)
            return e
        return _bottom_up(expr, fix)

    algebraic = sp.Matrix([])
    if model.form == "explicit":
        rhs = model.rhs.applyfunc(modalise)
        forces = sp.Matrix([])
        exprs = list(rhs)
    else:
        forces = model.forces.applyfunc(modalise)
        rhs = sp.Matrix([])
        exprs = list(forces) + list(model.mass_matrix)
        rows = getattr(model, "constraint_rows", None)
        if rows is not None and len(rows):
            algebraic = rows.applyfunc(modalise)
            exprs += list(algebraic)
    used: set[str] = set()
    for e in exprs:
        for s in e.free_symbols:
            if s in seg_syms:
                used.add(seg_syms[s])
            if s in n_syms:
                used.add(n_syms[s])
    return ModalForm(rhs, forces, surfaces, sigma, used, algebraic)


class _Registry:
    """The surfaces of a model by canonical form, with their sides ``sigma_j``.

    The canonical form of a switching function: expanded in the states only, every
    parameter block and every nonsmooth function (the Max of a dynamic backlash) held as one
    symbol, the numeric content and the sign taken out (``g``, ``-g`` and ``4*g`` are one
    surface), so that equal surfaces meet by a dict lookup instead of expanding the
    difference with every registered surface (quadratic in the number of surfaces).  A
    surface with the canonical form of a hint (an element's contact surface, a condition
    found in a spec field) takes the hint's name and function.
    """

    def __init__(self, states: set[sp.Symbol], hints: list[SwitchingFunction], file: str | None):
        self.states = states
        self.file = file
        self.surfaces: list[SwitchingFunction] = []
        self.sigma: list[sp.Symbol] = []
        self.known: dict[sp.Expr, tuple[int, int]] = {}
        self.blocks: dict[sp.Expr, sp.Dummy] = {}
        self.nonsmooth: dict[tuple, tuple[sp.Dummy, sp.Expr]] = {}
        self.names = _Names(file)
        self.hint_keys: dict[sp.Expr, tuple[SwitchingFunction, int]] = {}
        for h in hints:
            key, sgn = _canonical(self.canon(h.expr)[0])
            self.hint_keys.setdefault(key, (h, sgn))

    def block(self, e: sp.Expr) -> sp.Expr:
        if e.is_Number:
            return e
        coeff, key = e.as_coeff_Mul()  # the number apart: g and 4*g are one surface
        if key.could_extract_minus_sign():
            coeff, key = -coeff, -key
        if key not in self.blocks:
            self.blocks[key] = sp.Dummy(f"c{len(self.blocks)}")
        return coeff * self.blocks[key]

    def atom(self, e: sp.Basic) -> sp.Basic:
        states = self.states
        if isinstance(e, sp.Expr) and not (e.free_symbols & states):
            return self.block(e)
        if e.is_Atom:
            return e
        if isinstance(e, (sp.Add, sp.Mul)):  # the parameter terms/factors together: one block
            static = [a for a in e.args if not (a.free_symbols & states)]
            rest = [self.atom(a) for a in e.args if a.free_symbols & states]
            return e.func(*rest, *([self.block(e.func(*static))] if static else []))
        if isinstance(e, _NONSMOOTH):  # keyed by its canonical arguments
            key = (e.func, tuple(sp.expand(self.atom(a)) for a in e.args))  # no Max(...) rebuilt: costly
            if key not in self.nonsmooth:
                self.nonsmooth[key] = (sp.Dummy(f"n{len(self.nonsmooth)}"), e)
            return self.nonsmooth[key][0]
        return e.func(*[self.atom(a) for a in e.args])

    def canon(self, g: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
        """``(canonical form, g expanded in the states)``."""
        ge = sp.expand(self.atom(g))
        back = {d: e for e, d in self.blocks.items()}
        back.update({d: e for d, e in self.nonsmooth.values()})
        return ge, ge.xreplace(back)

    def register(self, g: sp.Expr) -> tuple[int, int]:
        """``(j, s)``: ``g`` is ``s`` times a positive multiple of surface ``j`` (registered if new)."""
        gk, ge = self.canon(g)
        key, sgn = _canonical(gk)
        if key in self.known:  # ge = sgn*key, surface j = sj*key
            j, sj = self.known[key]
            return j, sgn * sj
        j = len(self.surfaces)
        if j >= MAX_SURFACES:
            raise SpecError(f"the equations have more than {MAX_SURFACES} switching surfaces (state-dependent "
                            f"conditions and kinks)", file=self.file)
        checkpoint("switching surfaces")
        self.sigma.append(internal_symbol(f"sigma_{j}"))
        if key in self.hint_keys:
            h, sh = self.hint_keys[key]
            self.surfaces.append(self.names.claim(h))
            self.known[key] = (j, sh)
            return j, sgn * sh
        self.surfaces.append(self.names.claim(SwitchingFunction(f"surface{j}", ge, f"switch {j} (g > 0 side)")))
        self.known[key] = (j, sgn)
        return j, 1


class _Names:
    """Surface names in use: a generated name taken twice gets ``#2``, ``#3``, ...; a name the
    user gave twice (to different surfaces) is an error."""

    def __init__(self, file: str | None):
        self.file = file
        self.used: set[str] = set()

    def claim(self, sf: SwitchingFunction) -> SwitchingFunction:
        name = sf.name
        if name in self.used:
            if sf.given:
                raise SpecError(f"the surface name '{name}' is given to two different switching surfaces",
                                file=self.file, field=f"{sf.origin}.surface" if sf.origin else None)
            k = 2
            while f"{sf.name}#{k}" in self.used:
                k += 1
            name = f"{sf.name}#{k}"
            sf = replace(sf, name=name)
        self.used.add(name)
        return sf


def _relationals(cond: sp.Basic) -> list[Relational]:
    """The relations of a condition, each once, in the order of its (sorted) ``args``.

    Not ``atoms()`` (a set) nor ``preorder_traversal`` (it walks the *set* of arguments of
    an ``And``/``Or``): both give an order that changes with the hash seed, and the
    surfaces are numbered in the order they are met.
    """
    out: dict[Relational, None] = {}
    todo = [cond]
    while todo:
        c = todo.pop()
        if isinstance(c, Relational):
            out.setdefault(c)
        else:
            todo.extend(reversed(c.args))
    return list(out)


def _canonical(e: sp.Expr) -> tuple[sp.Expr, int]:
    """``(key, s)`` with ``e = s*c*key`` for a number ``c > 0``; ``key`` is the same for ``e``,
    ``-e`` and ``c*e`` (one surface, the same sides)."""
    content, primitive = e.as_content_primitive()
    if not content.is_zero:
        e = primitive
    if e.could_extract_minus_sign():
        return -e, -1
    return e, 1


def _bottom_up(expr: sp.Basic, fn, skip: type | tuple[type, ...] = ()) -> sp.Basic:
    """Apply ``fn`` to every node, children first (like sympy's bottom_up); nodes of
    the types ``skip`` are left as they are, with their subtrees."""
    if skip and isinstance(expr, skip):
        return expr
    checkpoint()
    if expr.args:
        new_args = [_bottom_up(a, fn, skip) for a in expr.args]
        if any(a is not b for a, b in zip(new_args, expr.args)):
            try:
                expr = expr.func(*new_args)
            except TypeError:
                pass
    return fn(expr)


def dead_zone(name: str, drive_side: str, delta: sp.Expr, b: sp.Expr) -> tuple[sp.Expr, list[SwitchingFunction]]:
    """The backlash dead zone of a mesh and its contact surfaces.

    Parameters
    ----------
    name
        The mesh element's name (surfaces ``NAME.drive`` / ``NAME.back``).
    drive_side
        ``"positive"``: drive-side contact is ``delta > b``; else ``delta < -b``.
    delta
        The dynamic deflection.
    b
        The half backlash (0: no dead zone, no surfaces).

    Returns
    -------
    f, surfaces
        ``f(delta)`` (``delta - b`` / ``0`` / ``delta + b``) and the two switching functions,
        drive side first.
    """
    if b == 0:
        return delta, []
    f = sp.Piecewise((delta - b, delta - b > 0), (delta + b, delta + b < 0), (0, True))
    drive_pos = drive_side == "positive"
    up = SwitchingFunction(
        f"{name}.{'drive' if drive_pos else 'back'}", delta - b,
        f"{'drive' if drive_pos else 'back'}-side contact of {name} when > 0",
        +1, "drive" if drive_pos else "back")
    lo = SwitchingFunction(
        f"{name}.{'back' if drive_pos else 'drive'}", delta + b,
        f"{'back' if drive_pos else 'drive'}-side contact of {name} when < 0",
        -1, "back" if drive_pos else "drive")
    return f, ([up, lo] if drive_pos else [lo, up])
