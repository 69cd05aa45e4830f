"""Dimensionless form of a model: scaled equations and their dimensionless groups.

With reference scales (:mod:`gearsym.symbolic.scales`) ``t = T*tau``, ``q_i = s_i*Q_i``,
``v_i = (s_i/T)*V_i`` the equations ``q_i'' = a_i(t, q, v)`` become
``Q_i'' = (T^2/s_i)*a_i(T*tau, s*Q, s/T*V)`` (an implicit model: every residual row
divided by the scale of its own dimension).  The substitution keeps the structure of
the equations: the *structured* model (derived quantities such as ``m_e`` kept as
symbols) is scaled, every maximal parameter sub-expression becomes a dimensionless
block (:class:`~gearsym.symbolic.groups.Normalizer`), and only the blocks -- small
expressions -- are simplified and written in groups
(:class:`~gearsym.symbolic.groups.GroupFinder`): the groups of ``[dimensionless.groups]``
first (each solved for the parameter it eliminates), then Buckingham pi groups from
the dimension matrix.  No global ``simplify``: a 6-DOF model takes about a second.

Every block is checked numerically at the scene's parameter values against its group
expression (``DimensionlessForm.check``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import TYPE_CHECKING

import sympy as sp

from ..display import DimensionlessDisplay
from ..errors import GearsymError, SpecError
from ..spec.exprtree import BOUND_FUNCTIONS
from .dims import ZERO, Dim, Dimensions, monomial
from .groups import GroupFinder, Normalizer, vector_of
from .scales import Scales, choose_scales

if TYPE_CHECKING:
    from .model import SymbolicModel

_log = logging.getLogger(__name__)


@dataclass(frozen=True, repr=False)
class DimensionlessForm(DimensionlessDisplay):
    """A model's equations in dimensionless variables.

    In Jupyter it shows the dimensionless equations, switching functions and groups
    (definition = value) typeset (``_repr_latex_``); ``repr`` is one line.

    Attributes
    ----------
    time
        The dimensionless time symbol (``tau``).
    states
        Dimensionless states (same names as the model's).
    accelerations
        ``Q_i'' = ...`` in the modal form (conditions replaced by surface sides); for an
        implicit model the dimensionless residual rows (``0 = ...``).
    switching
        Dimensionless switching functions (each divided by the scale of its dimension).
    groups
        ``{name: definition}`` of the dimensionless groups, in the model's parameters.
    group_symbols
        The symbols the groups appear as.
    definitions
        The definitions written with the model's derived quantities (for display).
    values
        The value of every group at the scene's parameters.
    leftover
        Dimensional parameters that still appear (empty for a consistent model).
    scales
        The reference scales (``time``, ``length``, ``mass`` and one per coordinate),
        in the model's parameters.
    scale_values
        Their values at the scene's parameters (SI).
    origin
        How each scale was chosen.
    implicit
        True if ``accelerations`` are residual rows.
    check
        Largest relative difference between a block and its group expression at the
        scene's parameter values.
    seconds
        Time taken to derive the form.
    scales_inlined
        The reference scales in the model's parameters alone (for code generation).
    """

    time: sp.Symbol
    states: list[sp.Symbol]
    accelerations: list[sp.Expr]
    switching: list[sp.Expr]
    groups: dict[str, sp.Expr]
    group_symbols: dict[str, sp.Symbol]
    leftover: list[str]
    scales: dict[str, sp.Expr]
    definitions: dict[str, sp.Expr] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    scale_values: dict[str, float] = field(default_factory=dict)
    origin: dict[str, str] = field(default_factory=dict)
    implicit: bool = False
    check: float = 0.0
    seconds: float = 0.0
    scales_inlined: dict[str, sp.Expr] = field(default_factory=dict)

    def equations(self) -> list[str]:
        """The dimensionless equations as text (``x'' = ...`` or ``0 = ...``)."""
        n = len(self.states) // 2
        if self.implicit:
            return [f"0 = {sp.sstr(r)}" for r in self.accelerations]
        return [f"{self.states[i]}'' = {sp.sstr(self.accelerations[i])}" for i in range(n)]

    def describe(self) -> str:
        """Human-readable summary: equations, groups (definition = value), scales."""
        lines = list(self.equations())
        for j, g in enumerate(self.switching):
            lines.append(f"  g{j} = {sp.sstr(g)}")
        for name, d in self.definitions.items():
            lines.append(f"  {name} = {sp.sstr(d)} = {self.values.get(name, float('nan')):.6g}")
        for k, v in self.scales.items():
            lines.append(f"  reference {k} = {sp.sstr(v)} = {self.scale_values.get(k, float('nan')):.6g}")
        if self.leftover:
            lines.append(f"  (dimensional parameters left: {', '.join(self.leftover)})")
        return "\n".join(lines)


def dimensionless_form(model: SymbolicModel) -> DimensionlessForm:
    """Derive the dimensionless form of a model (see the module docstring).

    Raises
    ------
    SpecError
        A ``[dimensionless]`` entry that cannot be used (a group that cannot be solved
        for the parameter it eliminates, a scale that depends on the state).
    """
    import time as _time

    t_start = _time.perf_counter()
    sm = model.structured_model
    spec = sm.spec
    ns = sm.ns
    dims = _dimension_table(sm)
    values = _values(sm)
    tidy = _Tidy(sm, dims)
    scales = choose_scales(sm, dims, values, tidy.translate)
    n = len(sm.coordinates)
    implicit = sm.form == "implicit"
    tau = sp.Symbol("tau", real=True)
    Q = [sp.Symbol(str(c), real=True) for c in sm.coordinates]
    V = [sp.Symbol(str(v), real=True) for v in sm.velocities]
    sT, sL, sM = (sp.Dummy(k, positive=True) for k in ("T", "L", "M"))
    sq = [sp.Dummy(f"s_{c}", positive=True) for c in sm.coordinates]
    table = dict(dims.table)
    table.update({sT: tuple(Fraction(x) for x in spec.time_dims.dims), sL: (Fraction(0), Fraction(1), Fraction(0)),
                  sM: (Fraction(1), Fraction(0), Fraction(0))})
    for c, s in zip(sm.coordinates, sq):
        table[s] = dims(c)
    for sym in (*Q, *V, tau):
        table[sym] = ZERO
    dimz = Dimensions(table)
    sub = {sm.t: sT * tau}
    for i in range(n):
        sub[sm.coordinates[i]] = sq[i] * Q[i]
        sub[sm.velocities[i]] = sq[i] / sT * V[i]
    if implicit:
        xd = [sp.Symbol(f"{c}''", real=True) for c in sm.coordinates]
        rows = []
        for i in range(n):
            r = sum(sm.mass_matrix[i, j] * sq[j] / sT ** 2 * xd[j] for j in range(n)) - sm.modal.forces[i]
            rows.append(r.xreplace(sub))
        dyn_extra = set(xd)
    else:
        rows = [(sT ** 2 / sq[i]) * sm.modal.rhs[n + i].xreplace(sub) for i in range(n)]
        dyn_extra = set()
    switching = [g.expr.xreplace(sub) for g in sm.switching]
    dynamic = {tau, *Q, *V, *sm.modal.sigma, *dyn_extra}
    for s in sm.schedules:
        dynamic |= {s.n, s.seg}
    dynamic |= set(ns.sched_n.values()) | set(ns.sched_seg.values())
    norm = Normalizer(dynamic, dimz, (sM, sL, sT))
    rows = [norm(r) for r in rows]
    switching = [norm(g) for g in switching]

    # block values in the parameters: scale symbols replaced by the scales
    scale_sub = {sT: scales.time, sL: scales.length, sM: scales.mass}
    scale_sub.update({s: scales.coordinates[c] for c, s in zip(sm.coordinates, sq)})
    elim, user_syms = tidy.eliminations()
    identity = [s for s in ns.params.values() if dims(s) == ZERO]
    finder = GroupFinder(dims, [], _scale_atoms(scales, tidy), _reserved(spec))
    split = {}
    originals = {}
    in_use = set().union(*[e.free_symbols for e in (*rows, *switching)])
    for b, value in norm.blocks.items():
        if b not in in_use:  # a block of a term that was collected with its like terms
            continue
        v = value.xreplace(scale_sub)
        originals[b] = v
        split[b] = finder.split(tidy(v, elim))
    finder.identity = [tidy.pos(s) for s in identity] + list(user_syms)
    finder.choose()
    final = {b: tidy.real(finder.finish(e)) for b, e in split.items()}
    rows = [r.xreplace(final) for r in rows]
    switching = [g.xreplace(final) for g in switching]

    # groups: definitions (display with derived names; inlined in parameters) and values
    groups: dict[str, sp.Expr] = {}
    definitions: dict[str, sp.Expr] = {}
    gsyms: dict[str, sp.Symbol] = {}
    for name in finder.groups:
        sym = sp.Symbol(name, real=True)
        if not any(e.has(sym) for e in (*rows, *switching)):
            continue
        if name in tidy.user:
            d_struct = tidy.user[name]
        else:
            d_struct = tidy.real(finder.definition(name))
        definitions[name] = d_struct
        groups[name] = ns.inline(d_struct)
        gsyms[name] = sym
    gvalues = {name: _number(groups[name], values) for name in groups}
    # numerical check of every block
    gnum = {gsyms[k]: v for k, v in gvalues.items()}
    worst = 0.0
    for b, v in originals.items():
        a = _number(tidy.real(v), values)
        c = _number(final[b], {**values, **gnum})
        if math.isfinite(a) and math.isfinite(c):
            worst = max(worst, abs(a - c) / max(abs(a), 1e-300)) if a != 0 else max(worst, abs(c))
        elif not (math.isnan(a) and math.isnan(c)):
            worst = math.inf
        _log.debug("dimensionless block %s -> %s: %.17g (dimensional) vs %.17g (groups)", v, final[b], a, c)
    allowed = set(gsyms.values()) | dynamic
    leftover = sorted({str(s) for e in (*rows, *switching) for s in e.free_symbols if s not in allowed})
    scale_exprs = {"time": scales.time, "length": scales.length, "mass": scales.mass}
    scale_exprs.update({str(c): s for c, s in scales.coordinates.items()})
    return DimensionlessForm(
        time=tau, states=Q + V, accelerations=rows, switching=switching, groups=groups,
        group_symbols=gsyms, leftover=leftover, scales={k: tidy.real(tidy(v, {})) for k, v in scale_exprs.items()},
        definitions=definitions, values=gvalues,
        scale_values={k: _number(v, values) for k, v in scale_exprs.items()}, origin=dict(scales.origin),
        implicit=implicit, check=worst, seconds=_time.perf_counter() - t_start,
        scales_inlined={k: ns.inline(v) for k, v in scale_exprs.items()})


class DimensionlessSystem:
    """A model in dimensionless variables, for code generation (same interface as
    :class:`~gearsym.symbolic.model.SymbolicModel` as far as :mod:`gearsym.codegen` uses it).

    The states are the dimensionless ``Q, V`` (same names), time is ``tau``, and the
    run-time parameters are still the model's own: the groups are computed from them in
    the generated code.  Schedules and the forcing period are in units of ``tau``, the
    ``[outputs]`` stay dimensional (evaluated at ``t = T*tau, q = s*Q``).  ``scales``
    (``[T, s_1, ..., s_n]``) converts states: ``q = s*Q``, ``v = s/T*V``.

    Parameters
    ----------
    model
        The (explicit) symbolic model.
    """

    def __init__(self, model: SymbolicModel):
        from .switching import ModalForm, ScheduleInfo

        if model.form != "explicit":
            raise SpecError("simulating in dimensionless variables needs an explicit model",
                            file=model.spec.path, field="model.form")
        d = model.dimensionless()
        if [s.name for s in model.structured_model.switching] != [s.name for s in model.switching]:
            raise GearsymError("the structured form of the model found other switching surfaces than the model "
                               "itself; cannot simulate it in dimensionless variables")
        self.base = model
        self.form = "explicit"
        self.name = model.name
        self.spec = model.spec
        self.t = d.time
        self.states = list(d.states)
        self.coordinates = self.states[: len(self.states) // 2]
        self.velocities = self.states[len(self.states) // 2:]
        groups = {d.group_symbols[k]: v for k, v in d.groups.items()}
        n = len(self.coordinates)
        acc = [a.xreplace(groups) for a in d.accelerations]
        if any(a.free_symbols - set(model.parameters) - set(self.states) - {self.t} - set(model.modal.sigma)
               - {s.n for s in model.schedules} - {s.seg for s in model.schedules} for a in acc):
            raise SpecError("the dimensionless form still has dimensional parameters "
                            f"({', '.join(d.leftover)})", file=model.spec.path, field="dimensionless")
        self.modal = ModalForm(sp.Matrix(list(self.velocities) + acc), sp.Matrix([]),
                               [], list(model.modal.sigma), set(model.modal.used_schedules))
        self.switching = [replace(s, expr=g.xreplace(groups)) for s, g in zip(model.switching, d.switching)]
        self.modal.surfaces = self.switching
        T = d.scales_inlined["time"]
        self.scales = [T] + [d.scales_inlined[str(c)] for c in model.coordinates]
        self.schedules = [ScheduleInfo(s.name, s.period / T, s.breaks, s.n, s.seg) for s in model.schedules]
        self.forcing_period = model.forcing_period / T if model.forcing_period is not None else None
        sub = {model.t: T * self.t}
        for i in range(n):
            sub[model.coordinates[i]] = self.scales[1 + i] * self.coordinates[i]
            sub[model.velocities[i]] = self.scales[1 + i] / T * self.velocities[i]
        self.outputs = {k: v.xreplace(sub) for k, v in model.outputs.items()}
        self.parameters = list(model.parameters)
        self.bound_parameters = dict(model.bound_parameters)
        self.dimensionless_form = d

    @property
    def state_names(self) -> list[str]:
        """Names of the (dimensionless) states."""
        return [str(s) for s in self.states]

    @property
    def parameter_names(self) -> list[str]:
        """Names of the run-time parameters (the model's)."""
        return [str(p) for p in self.parameters]


# ------------------------------------------------------------------------------- helpers


def _dimension_table(sm: SymbolicModel) -> Dimensions:
    """Dimensions of the parameters, derived quantities, bound functions and states."""
    spec = sm.spec
    table: dict[sp.Symbol, Dim] = {}

    def dim_of(name: str) -> Dim:
        u = spec.units.get(name)
        return tuple(Fraction(x) for x in u.dims) if u is not None else ZERO  # type: ignore[return-value]

    for name, sym in sm.ns.params.items():
        table[sym] = dim_of(name)
    for sym in sm.ns.derived:
        table[sym] = dim_of(str(sym))
    for sym, (fname, _) in sm.ns.bound.items():
        table[sym] = tuple(Fraction(x) for x in BOUND_FUNCTIONS[fname][1])  # type: ignore[assignment]
    for s in sm.states:
        table[s] = dim_of(str(s))
    table[sm.t] = tuple(Fraction(x) for x in spec.time_dims.dims)  # type: ignore[assignment]
    return Dimensions(table)


def _values(sm: SymbolicModel) -> dict[sp.Symbol, float]:
    """Numeric values (SI) of parameters, bound functions and derived symbols at the scene's values."""
    from ..bound_functions import evaluate

    rs = sm.resolved
    vals: dict[sp.Symbol, float] = {sym: float(rs.values[name]) for name, sym in sm.ns.params.items()}
    for sym, (fname, args) in sm.ns.bound.items():
        try:
            vals[sym] = evaluate(fname, [rs.values[a] for a in args])
        except Exception:  # noqa: BLE001 - a value outside the function's domain: no number
            vals[sym] = math.nan
    for sym, d in sm.ns.derived.items():
        vals[sym] = _number(d, vals)
    return vals


def _number(e: sp.Expr, values: dict[sp.Symbol, float]) -> float:
    try:
        expr = e if isinstance(e, sp.Basic) else sp.Float(float(e))
        r = expr.xreplace(values)  # a plain float when expr is one of the symbols
        v = complex(r.evalf() if isinstance(r, sp.Basic) else r)
    except (TypeError, ValueError, ZeroDivisionError):
        return math.nan
    return v.real if abs(v.imag) <= 1e-12 * max(1.0, abs(v.real)) else math.nan


def _reserved(spec) -> set[str]:
    names = set(spec.parameters) | set(spec.derived) | set(spec.coordinates) | set(spec.outputs)
    names |= {c.velocity for c in spec.coordinates.values()}
    if spec.reduction is not None:
        names |= {spec.reduction.coordinate, spec.reduction.velocity}
    if spec.dimensionless is not None:
        names |= {g.name for g in spec.dimensionless.groups}
    return names | {"tau", "t"}


def _scale_atoms(scales: Scales, tidy: _Tidy) -> set[sp.Basic]:
    atoms: set[sp.Basic] = set()
    for e in (scales.time, scales.length, scales.mass, *scales.coordinates.values()):
        v = vector_of(tidy(e, {}), tidy.dims)
        if v is not None:
            atoms |= set(v[1])
        else:
            atoms |= tidy(e, {}).free_symbols
    return atoms


class _Tidy:
    """Local simplification of one block: derived quantities whose definition appears
    whole folded back into their names, positive symbols, derived quantities that are
    monomials in symbols inlined (``omega_n -> sqrt(k_m/m_e)``, so powers cancel),
    common factors pulled out of sums, user groups substituted."""

    def __init__(self, sm: SymbolicModel, dims: Dimensions):
        self.sm = sm
        self.dims = dims
        ns = sm.ns
        syms = set(ns.params.values()) | set(ns.bound) | set(ns.derived)
        self._pos = {s: sp.Symbol(str(s), positive=True) for s in syms}
        self._real = {v: k for k, v in self._pos.items()}
        for k, v in self._pos.items():
            dims.table.setdefault(v, dims.table.get(k, ZERO))
        self.inline_map: dict[sp.Symbol, sp.Expr] = {}
        self.fold_map: dict[sp.Expr, sp.Expr] = {}
        for sym, d in ns.derived.items():
            p = self._pos[sym]
            dp = d.xreplace(self._pos)
            if _symbol_monomial(dp.xreplace(self.inline_map)):
                self.inline_map[p] = dp.xreplace(self.inline_map)
                continue
            for form in {dp, sp.factor_terms(dp)}:
                self.fold_map.setdefault(form, p)
                if isinstance(form, sp.Pow) and isinstance(form.base, sp.Add) and form.exp in (1, -1):
                    self.fold_map.setdefault(form.base, p ** form.exp)
                    # the same sum over a common denominator: N/Dn = p**e  ->  N = Dn*p**e
                    num, den = sp.fraction(sp.together(form.base))
                    if isinstance(num, sp.Add) and den != 1:
                        self.fold_map.setdefault(num, den * p ** form.exp)
        self.user: dict[str, sp.Expr] = {}

    def translate(self, other_ns, e: sp.Expr) -> sp.Expr:
        """An expression of another namespace of the same model (e.g. with every effect off)
        in this model's symbols: a derived symbol whose definition is the same here is kept,
        the others are replaced by their definitions."""
        mine = self.sm.ns.inlined_definitions()
        theirs = other_ns.inlined_definitions()
        sub = {s: d for s, d in theirs.items() if mine.get(s) != d}
        for _ in range(8):
            e2 = e.xreplace(sub)
            if e2 == e:
                break
            e = e2
        return self.real(self._fold(sp.factor_terms(e.xreplace(self._pos))))

    def pos(self, s: sp.Symbol) -> sp.Symbol:
        return self._pos.get(s, s)

    def real(self, e: sp.Basic) -> sp.Basic:
        return e.xreplace(self._real)

    def eliminations(self) -> tuple[dict[sp.Symbol, sp.Expr], list[sp.Symbol]]:
        """User groups: ``{eliminated parameter: solution}`` and the group symbols."""
        sm, spec = self.sm, self.sm.spec
        dl = spec.dimensionless
        if dl is None:
            return {}, []
        elim: dict[sp.Symbol, sp.Expr] = {}
        syms = []
        for g in dl.groups:
            gsym = sp.Symbol(g.name, real=True)
            self.dims.table[gsym] = ZERO
            definition = sm.ns.parse(g.definition, f"dimensionless.groups.{g.name}.definition")
            self.user[g.name] = definition
            target = self._pos[sm.ns.params[g.eliminates]]
            dp = self(definition, {})
            sol = sp.solve(sp.Eq(dp, gsym), target)
            sol = [s for s in sol if not s.has(sp.I)]
            if not sol:
                raise SpecError(f"cannot solve the definition of '{g.name}' for '{g.eliminates}'",
                                file=spec.path, field=f"dimensionless.groups.{g.name}")
            elim[target] = sol[0]
            syms.append(gsym)
        return elim, syms

    def __call__(self, e: sp.Expr, elim: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
        e = self._fold(e.xreplace(self._pos))
        for _ in range(8):
            e2 = e.xreplace(self.inline_map)
            if e2 == e:
                break
            e = e2
        e = self._fold(sp.factor_terms(e))
        if _has_sum_in_denominator(e):
            f = self._fold(sp.factor_terms(sp.together(e)))
            if sp.count_ops(f) < sp.count_ops(e):
                e = f
        if elim:
            e = e.xreplace(elim)
            e = self._fold(sp.factor_terms(sp.expand(e)))
            if _has_sum_in_denominator(e):
                c = sp.factor_terms(sp.cancel(e))
                if sp.count_ops(c) <= sp.count_ops(e):
                    e = self._fold(c)
        return e

    def _fold(self, e: sp.Expr) -> sp.Expr:
        if not self.fold_map:
            return e
        e2 = e.xreplace(self.fold_map)
        return sp.factor_terms(e2) if e2 != e else e


def _symbol_monomial(e: sp.Expr) -> bool:
    for f in sp.Mul.make_args(e):
        b, x = f.as_base_exp()
        if b.is_Number or b in (sp.pi, sp.E):
            continue
        if not (isinstance(b, sp.Symbol) and x.is_Rational):
            return False
    return True


def _sums(e: sp.Expr) -> int:
    return sum(1 for a in sp.preorder_traversal(e) if isinstance(a, sp.Add))


def _has_sum_in_denominator(e: sp.Expr) -> bool:
    return any(isinstance(p.base, sp.Add) and p.exp.is_negative for p in e.atoms(sp.Pow))


_ = monomial
