"""Dimensionless form of a model.

The spec chooses reference scales (``[dimensionless] time = "1/omega_n"``,
``coordinates.x = "b_m"``) and names dimensionless groups with the parameter each
one eliminates (``zeta = { definition = "c_m/(2*sqrt(k_m*m_e))", eliminates = "c_m" }``).
With ``t = t_ref*tau`` and ``q = q_ref*Q`` the equations ``q'' = a(t, q, v)`` become
``Q'' = (t_ref**2/q_ref) * a(t_ref*tau, q_ref*Q, q_ref/t_ref*V)``; solving every group
definition for its eliminated parameter and substituting leaves an equation in the
groups alone (anything else left over is reported).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from ..errors import SpecError

if TYPE_CHECKING:
    from .model import SymbolicModel


@dataclass(frozen=True)
class DimensionlessForm:
    """A model's equations in dimensionless variables.

    Attributes
    ----------
    time
        The dimensionless time symbol (``tau``).
    states
        Dimensionless states (same names as the model's, capitalised meaning).
    accelerations
        ``Q_i'' = ...`` in the modal form (conditions replaced by surface sides).
    switching
        Dimensionless switching functions ``g / q_ref`` (same sides as the model's).
    groups
        ``{name: definition}`` of the dimensionless groups (sympy expressions).
    group_symbols
        The symbols the groups appear as.
    leftover
        Dimensional parameters that still appear (should be empty).
    scales
        The reference scales used.
    """

    time: sp.Symbol
    states: list[sp.Symbol]
    accelerations: list[sp.Expr]
    switching: list[sp.Expr]
    groups: dict[str, sp.Expr]
    group_symbols: dict[str, sp.Symbol]
    leftover: list[str]
    scales: dict[str, sp.Expr]

    def describe(self) -> str:
        """Human-readable summary: equations and the definitions of the groups."""
        lines = []
        n = len(self.states) // 2
        for i in range(n):
            lines.append(f"{self.states[i]}'' = {sp.sstr(self.accelerations[i])}")
        for name, d in self.groups.items():
            lines.append(f"  {name} = {sp.sstr(d)}")
        for k, v in self.scales.items():
            lines.append(f"  reference {k} = {sp.sstr(v)}")
        if self.leftover:
            lines.append(f"  (dimensional parameters left: {', '.join(self.leftover)})")
        return "\n".join(lines)


def dimensionless_form(model: SymbolicModel) -> DimensionlessForm:
    """Compute the dimensionless form of an explicit model (see module docstring)."""
    spec = model.spec
    dl = spec.dimensionless
    if dl is None:
        raise SpecError("the model has no [dimensionless] section", file=spec.path, field="dimensionless")
    if model.accelerations is None:
        raise SpecError("the dimensionless form needs an explicit model", file=spec.path,
                        field="model.form")
    ns = model.ns
    t_ref = ns.parse(dl.time, "dimensionless.time")
    tau = sp.Symbol("tau", real=True)
    n = len(model.coordinates)
    q_ref = [ns.parse(dl.coordinates.get(str(q), "1"), f"dimensionless.coordinates.{q}")
             for q in model.coordinates]
    Q = [sp.Symbol(str(q), real=True) for q in model.coordinates]
    V = [sp.Symbol(str(v), real=True) for v in model.velocities]
    sub = {model.t: t_ref * tau}
    for i in range(n):
        sub[model.coordinates[i]] = q_ref[i] * Q[i]
        sub[model.velocities[i]] = q_ref[i] / t_ref * V[i]
    acc = [sp.expand(model.modal.rhs[n + i].xreplace(sub) * t_ref ** 2 / q_ref[i]) for i in range(n)]
    sw = []
    for s in model.switching:
        g = s.expr.xreplace(sub)
        # scale by the reference of the coordinate it involves (keeps the sign of g)
        scale = next((q_ref[i] for i in range(n) if s.expr.has(model.coordinates[i])), 1)
        sw.append(sp.expand(g / scale))
    groups: dict[str, sp.Expr] = {}
    gsyms: dict[str, sp.Symbol] = {}
    elim: dict[sp.Symbol, sp.Expr] = {}
    for g in dl.groups:
        gsym = sp.Symbol(g.name, real=True)
        definition = ns.parse(g.definition, f"dimensionless.groups.{g.name}.definition")
        groups[g.name] = definition
        gsyms[g.name] = gsym
        target = ns.params[g.eliminates]
        pos = sp.Symbol(f"__{g.eliminates}", positive=True)
        # solve with the eliminated parameter positive (physical scales); other
        # parameters are assumed positive too for the purpose of the inversion
        positive = {s: sp.Symbol(str(s), positive=True) for s in definition.free_symbols}
        back = {v: k for k, v in positive.items()}
        sol = sp.solve(sp.Eq(definition.xreplace(positive).xreplace({positive[target]: pos}), gsym), pos)
        if not sol:
            raise SpecError(f"cannot solve the definition of '{g.name}' for '{g.eliminates}'",
                            file=spec.path, field=f"dimensionless.groups.{g.name}")
        elim[target] = sol[0].xreplace(back)

    def apply(e: sp.Expr) -> sp.Expr:
        for _ in range(len(elim) + 1):
            e2 = e.xreplace(elim)
            if e2 == e:
                break
            e = e2
        positive = {s: sp.Symbol(str(s), positive=True) for s in e.free_symbols
                    if str(s) in spec.parameters}
        e = e.xreplace(positive)
        # factor the bases of fractional powers so that sqrt(X**2) -> X is visible
        e = e.replace(lambda a: a.is_Pow and a.exp.is_Rational and not a.exp.is_Integer,
                      lambda a: sp.Pow(sp.factor(a.base), a.exp))
        e = _simplify(e)
        return e.xreplace({v: sp.Symbol(str(v), real=True) for v in positive.values()})

    acc = [apply(a) for a in acc]
    sw = [apply(g) for g in sw]
    leftover = sorted({str(s) for a in acc + sw for s in a.free_symbols if str(s) in spec.parameters
                       and str(s) not in gsyms})
    scales = {"time": t_ref, **{str(q): r for q, r in zip(model.coordinates, q_ref)}}
    return DimensionlessForm(tau, Q + V, acc, sw, groups, gsyms, leftover, scales)


def _simplify(e: sp.Expr) -> sp.Expr:
    """Simplify, branch by branch for Piecewise expressions."""
    if isinstance(e, sp.Piecewise):
        return sp.Piecewise(*[(_simplify(v), c) for v, c in e.args])
    if e.has(sp.Piecewise):
        e = sp.piecewise_fold(e)
        if isinstance(e, sp.Piecewise):
            return _simplify(e)
    return sp.expand(sp.simplify(sp.powsimp(sp.expand(e), force=True)))
