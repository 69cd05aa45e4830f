"""The symbolic model: equations of motion derived with sympy from a resolved scene.

:class:`SymbolicModel` follows the style of ``sympy.physics.mechanics``: the
derivation is done once in the constructor and every derived quantity is a named,
inspectable attribute (mass matrix, generalised forces, first-order right-hand
side, switching functions, modes, schedules, Jacobian, dimensionless form).

Derivation (virtual work): every element adds its mass-matrix entries and generalised
forces through the hooks of its type (:mod:`gearsym.symbolic.elements`; e.g. a mesh
contributes ``Q_i = -W * d(delta)/d(q_i)`` where ``delta`` is its deflection and ``W`` its
force ``k*f(delta) + c*d(delta)/dt`` with dead zone ``f``); explicit equations add to
``M`` and ``Q`` directly.  Then ``M q'' = Q``.
"""

from __future__ import annotations

from dataclasses import replace

import sympy as sp

from ..display import SymbolicDisplay
from ..errors import SpecError
from ..spec.scene import ResolvedScene
from .budget import Budget, check_expression, checkpoint
from .elements import ASSEMBLERS, Assembly, SymbolicElement
from .expand import _expand_in_states
from .parsing import Namespace, internal_symbol
from .reduction import reduce_model
from .rigid import mode_dicts, rigid_body_modes, transform_modes
from .switching import ModalForm, Mode, ScheduleInfo, SwitchingFunction, make_modal


class SymbolicModel(SymbolicDisplay):
    """Equations of motion of a resolved scene, derived with sympy.

    In Jupyter the model shows its equations of motion and switching functions typeset
    (``_repr_latex_``: :meth:`latex`); ``repr`` is one line.

    Parameters
    ----------
    rs
        A :class:`~gearsym.spec.scene.ResolvedScene` (model + effects + values).

    Attributes
    ----------
    t : sympy.Symbol
    coordinates, velocities : list of sympy.Symbol
        After reduction, if the model asks for one.
    states : list of sympy.Symbol
        ``coordinates + velocities``.
    mass_matrix : sympy.Matrix
        ``M`` in ``M q'' = F``.
    forces : sympy.Matrix
        ``F`` (generalised forces, with the original piecewise conditions).
    rhs : sympy.Matrix
        First-order right-hand side ``x' = f(t, x, p)`` (explicit form).
    switching : list of SwitchingFunction
    modal : ModalForm
        The right-hand side with each state-dependent condition replaced by the
        side ``sigma_j`` of its switching surface, and schedules by their segment.
    parameters : list of sympy.Symbol
        The run-time parameters the compiled system takes, in model order.
    forcing_period : sympy.Expr or None
    elements : dict
        The symbolic side of every element of the scene (effect on), by name
        (:class:`~gearsym.symbolic.elements.base.SymbolicElement`).
    mesh_deflections, mesh_forces : dict
        Per-mesh results: the dynamic deflection and the force along the line of action of
        every element that reports them (``mesh``, ``gear_mesh``), in the final states.
    """

    def __init__(self, rs: ResolvedScene, structured: bool = False):
        # the whole derivation under one time budget (gearsym/symbolic/budget.py)
        with Budget(what=f"deriving the equations of model '{rs.model.name}'", file=rs.model.path).active():
            self._derive(rs, structured)

    def _derive(self, rs: ResolvedScene, structured: bool) -> None:
        self.resolved = rs
        self.spec = rs.model
        self.name = rs.model.name
        self.structured = structured
        ns = Namespace(rs, structured=structured)
        self.ns = ns
        #: each table written into the equations -> its short form ``k_ltca(mesh_phase)`` (for display:
        #: ``expr.xreplace(model.table_display)``; gearsym/symbolic/tables.py)
        self.table_display = ns.tables.display
        self.t = ns.t
        self._surface_hints: list[SwitchingFunction] = []
        q = list(ns.coords.values())
        v = list(ns.vels.values())
        self._deflections: list[sp.Expr] = []    # geometric deflections of springs, dampers, meshes
        self._force_exprs: list[sp.Expr] = []    # other expressions that enter forces
        self._meshes: dict[str, sp.Expr] = {}    # mesh element -> dynamic deflection (deflection - error)
        self._mesh_forces: dict[str, sp.Expr] = {}  # mesh element -> mesh force k*f(delta) + c*delta'
        self._mesh_fields: dict[str, str] = {}  # mesh element -> the field its deflection errors name
        M, Q = self._assemble(ns, q, v)
        dynamic = frozenset(q) | frozenset(v)
        for i, qi in enumerate(q):  # the sums of the elements' terms, before anything expands them
            check_expression(Q[i, 0], self.spec.path, f"coordinates.{qi}", f"generalised force on '{qi}'", dynamic)
            check_expression(M[i, i], self.spec.path, f"coordinates.{qi}", f"mass of '{qi}'", dynamic)
        # the surfaces written in the fields (named after them), after the elements' contact surfaces
        self._surface_hints += [SwitchingFunction.of_hint(h) for h in ns.surfaces.hints]
        #: algebraic variables (constraint multipliers; states after the velocities) and the
        #: constraint rows ``= 0`` in terms of the accelerations (gearsym/symbolic/constraints.py)
        self.algebraic: list[sp.Symbol] = []
        self.constraint_rows: sp.Matrix | None = None
        if self.spec.constraints:
            q, v, M, Q = self._constrain(ns, q, v, M, Q)
        self.unreduced_mass_matrix = M
        self.unreduced_forces = Q
        self.unreduced_coordinates = list(q)
        R = rigid_body_modes(q, v, self._deflections, self._force_exprs, [M[i, i] for i in range(len(q))],
                             ns.t)
        #: rigid-body modes of the model's own coordinates (columns; before any reduction)
        self.unreduced_rigid_modes = R
        self.reduction_result = None
        if self.spec.reduction is not None and self.spec.reduction.keep:
            q, v, M, Q = self._reduce_keeping(ns, q, v, M, Q)
            # the modes of the kept coordinates and the reduced one: none remain (the pair
            # with its centres kept is definite in them); rigid modes are those of the rest
            R = sp.zeros(len(q), 0)
        elif self.spec.reduction is not None:
            rr = reduce_model(self, ns, q, v, M, Q)
            self.reduction_result = rr
            self._reduction_sub = rr.sub
            self.reduced_mass = rr.masses[0] if len(rr.masses) == 1 else sp.diag(*rr.masses)
            q, v, M, Q = rr.coordinates, rr.velocities, rr.mass, rr.forces
            states = tuple(q + v)
            others = set(rr.kept) | {v_ for q_, v_ in zip(self.unreduced_coordinates, ns.vels.values())
                                     if q_ in rr.kept}
            hints = []
            for h in self._surface_hints:
                g = _expand_in_states(h.expr.subs(rr.sub), states, ns.t)
                if g.free_symbols & others:
                    if h.kind == "switch":  # a condition the reduced equations do not have: no name needed
                        continue
                    raise SpecError(f"the reduced model is not closed: the switching function of {h.name} "
                                    f"still depends on {', '.join(sorted(map(str, g.free_symbols & others)))}",
                                    file=self.spec.path, field="reduction")
                hints.append(replace(h, expr=g))
            self._surface_hints = hints
            hide, show = ns.tables.hider()
            self._meshes = {k: show(_expand_in_states(hide(d.subs(rr.sub)), states, ns.t))
                            for k, d in self._meshes.items()}
            R = transform_modes(R, rr.A)
        #: rigid-body modes of the final coordinates (columns of coefficients)
        self.rigid_modes = R
        self.coordinates = q
        self.velocities = v
        self.states = q + v + self.algebraic
        self.mass_matrix = M
        self.forces = Q
        self.form = self.spec.form
        if self.form == "explicit":
            acc = M.LUsolve(Q) if not M.is_diagonal() else sp.Matrix([Q[i] / M[i, i] for i in range(len(q))])
            self.accelerations = acc
        else:
            self.accelerations = None
        self.rhs = sp.Matrix(list(v) + (list(self.accelerations) if self.accelerations is not None else []))
        self.modal: ModalForm = make_modal(self, self._surface_hints)
        self.switching: list[SwitchingFunction] = self.modal.surfaces
        self.outputs = self._outputs(ns)
        # the schedules the equations or the outputs read (an output may call a table the equations do not)
        clocks = set().union(*(e.free_symbols for e in self.outputs.values()))
        used = self.modal.used_schedules | {s for s in ns.sched_seg
                                            if {ns.sched_seg[s], ns.sched_n[s]} & clocks}
        self.schedules: list[ScheduleInfo] = [
            ScheduleInfo(s, ns.schedule_period[s], (sp.Integer(0), *ns.schedule_breaks[s]),
                         ns.sched_n[s], ns.sched_seg[s])
            for s in [*self.spec.schedules, *ns.tables.hidden] if s in used
        ]  # the model's schedules, then those of its tables (gearsym/symbolic/tables.py)
        self.forcing_period = ns.parse(self.spec.forcing_period, "forcing.period") \
            if self.spec.forcing_period else None
        #: dynamic deflection (deflection - error) of every active mesh element, in the final states
        self.mesh_deflections: dict[str, sp.Expr] = dict(self._meshes)
        self._check_final_states(ns)
        #: force of every active mesh element along its line of action, ``k*f(delta) + c*delta'``
        #: (``f`` the backlash dead zone), in the final states
        self.mesh_forces: dict[str, sp.Expr] = self._final_mesh_forces()
        self.parameters = self._parameter_list()

    # ----------------------------------------------------------------- assembly

    def _constrain(self, ns: Namespace, q, v, M, Q):
        """Tie the constrained coordinates to the others (:mod:`gearsym.symbolic.constraints`)."""
        from .constraints import apply_constraints

        cs = apply_constraints(self.spec, ns, q, v, M, Q)
        self.constrained = cs
        self.algebraic = cs.algebraic
        self.constraint_rows = cs.rows
        self._constraint_sub = cs.sub
        states = tuple(cs.coordinates + cs.velocities)
        self._deflections = [d.xreplace(cs.sub) for d in self._deflections]
        self._force_exprs = [f.xreplace(cs.sub) for f in self._force_exprs]
        self._meshes = {k: d.xreplace(cs.sub) for k, d in self._meshes.items()}
        self._surface_hints = [replace(h, expr=_expand_in_states(h.expr.xreplace(cs.sub), states, ns.t))
                               for h in self._surface_hints]
        return cs.coordinates, cs.velocities, cs.mass, cs.forces

    def _assemble(self, ns: Namespace, q: list[sp.Symbol], v: list[sp.Symbol]):
        """``M`` and ``Q`` from the elements (each through the hooks of its type,
        :mod:`gearsym.symbolic.elements`) and the explicit ``[equations]``."""
        spec = self.spec
        n = len(q)
        index = {s.name: i for i, s in enumerate(q)}
        M = sp.zeros(n, n)
        Q = sp.zeros(n, 1)
        a = Assembly(ns, q, v, M, Q)
        #: the elements of this scene (effect on), by name: their symbolic side
        self.elements: dict[str, SymbolicElement] = {}
        for el in spec.elements.values():
            if not self.resolved.effect_active(el.effect, el.variant):
                continue
            checkpoint(f"elements.{el.name}")
            part = ASSEMBLERS[el.type](a, el)
            self.elements[el.name] = part
            if not part.present():
                continue  # acts only on coordinates of switched-off effects
            for c, value in part.mass():
                a.add_mass(c, value)
            applied = [value for c, value in part.forces() if a.add_force(c, value)]
            self._surface_hints += part.surfaces()
            mesh = part.mesh()
            if mesh is not None:
                self._meshes[el.name] = mesh.deflection
                self._mesh_forces[el.name] = mesh.force
                self._mesh_fields[el.name] = mesh.field
            deflections, exprs = part.rigid_terms(applied)
            self._deflections += deflections
            self._force_exprs += exprs
        for eq in spec.equations.values():
            if eq.coordinate not in index:
                continue  # coordinate of a switched-off effect
            i = index[eq.coordinate]
            M[i, i] += ns.sum_terms(eq.mass)
            Q[i, 0] += ns.sum_terms(eq.force)
            self._force_exprs.append(ns.sum_terms(eq.force))
        for i, qi in enumerate(q):
            if M[i, i] == 0:
                raise SpecError(f"coordinate '{qi}' has no active inertia in this scene",
                                file=spec.path, field=f"coordinates.{qi}")
        return M, Q

    def _check_final_states(self, ns: Namespace) -> None:
        """Every generated expression reads the final states only (after constraints and reduction).

        A coordinate that is no longer a state would surface as an internal error of the
        code generator ("symbol 'th1' has no value"); this names the spec field instead.
        """
        gone = (set(ns.coords.values()) | set(ns.vels.values())) - set(self.states)
        if not gone:
            return
        spec = self.spec
        rows = [(e, f"coordinates.{c}" if spec.reduction is None else "reduction")
                for c, e in zip(self.coordinates, self.rhs[len(self.coordinates):])]
        checks = [*rows, *((h.expr, _surface_field(spec, h.name)) for h in self._surface_hints),
                  *((d, self._mesh_fields[k]) for k, d in self.mesh_deflections.items())]
        for expr, fld in checks:
            left = sorted(str(s) for s in expr.free_symbols & gone)
            if left:
                raise SpecError(f"after the {'reduction' if spec.reduction is not None else 'constraints'} "
                                f"this still depends on {', '.join(left)}, which are no longer states of the "
                                f"model", file=spec.path, field=fld)
    def _final_mesh_forces(self) -> dict[str, sp.Expr]:
        """The mesh forces in the final states (constraints, then the reduction, substituted
        as for the mesh deflections); a force that still reads an eliminated coordinate is left out."""
        states = tuple(self.states)
        allowed = set(states) | {self.t}
        dynamic = set(self.ns.coords.values()) | set(self.ns.vels.values())
        out = {}
        final = getattr(self, "_final_forces", {})  # rewritten with the reduction (keep)
        for name, W in self._mesh_forces.items():
            if name in final:
                W = final[name]
            else:
                if self.constraint_rows is not None:
                    W = W.xreplace(self._constraint_sub)
                sub = getattr(self, "_reduction_sub", None)
                if sub is not None:
                    hide, show = self.ns.tables.hider()
                    W = show(_expand_in_states(hide(W.subs(sub)), states, self.t))
            if not ((W.free_symbols & dynamic) - allowed):
                out[name] = W
        return out

    @staticmethod
    def _collect(expr: sp.Expr) -> sp.Expr:
        return expr

    def _reduce_keeping(self, ns: Namespace, q, v, M, Q):
        """Reduce to one relative coordinate, keeping ``reduction.keep`` as states
        (:mod:`gearsym.symbolic.reduction_keep`)."""
        from .reduction_keep import reduce_keeping

        hints = self._surface_hints
        forces = self._mesh_forces
        if self.constraint_rows is not None:
            forces = {k: W.xreplace(self._constraint_sub) for k, W in forces.items()}
        # the mesh deflections and forces (per-mesh results) are rewritten in the new states with the surfaces
        q2, v2, M2, Q2, sub, m_eq, g = reduce_keeping(self, ns, q, v, M, Q, [h.expr for h in hints], self._meshes,
                                                      [h.origin or _surface_field(self.spec, h.name) for h in hints]
                                                      + [self._mesh_fields[k] for k in self._meshes], forces)
        self._reduction_sub = sub
        self.reduced_mass = m_eq if self.structured else sp.simplify(m_eq)
        self._surface_hints = [replace(h, expr=gh) for h, gh in zip(hints, g)]
        n = len(hints) + len(self._meshes)
        self._meshes = dict(zip(self._meshes, g[len(hints):n]))
        self._final_forces = {k: W for k, W in zip(forces, g[n:]) if W is not None}
        return q2, v2, M2, Q2

    def _outputs(self, ns: Namespace) -> dict[str, sp.Expr]:
        """The model's [outputs], in terms of the final states (after reduction)."""
        out: dict[str, sp.Expr] = {}
        allowed = set(self.states)
        dynamic = set(ns.coords.values()) | set(ns.vels.values())
        for name, o in self.spec.outputs.items():
            expr = ns.sum_terms(o.terms)
            if self.spec.reduction is not None and hasattr(self, "_reduction_sub"):
                expr = expr.xreplace(self._reduction_sub)
            if self.constraint_rows is not None:
                expr = expr.xreplace(self._constraint_sub)
            bad = sorted(str(s) for s in (expr.free_symbols & dynamic) - allowed)
            if bad:
                raise SpecError(f"output '{name}' uses {', '.join(bad)}, which are not states of the "
                                f"(reduced) model", file=self.spec.path, field=f"outputs.{name}")
            out[name] = expr
        return out

    def _parameter_list(self) -> list[sp.Symbol]:
        exprs = list(self.modal.rhs) + list(self.modal.forces) + [g.expr for g in self.switching]
        exprs += list(getattr(self, "outputs", {}).values())
        exprs += list(getattr(self, "mesh_deflections", {}).values()) + list(self.rigid_modes)
        if self.form == "implicit":
            exprs += list(self.mass_matrix) + list(self.forces) + list(self.modal.algebraic)
        for s in self.schedules:
            exprs += [s.period, *s.breaks]
        if self.forcing_period is not None:
            exprs.append(self.forcing_period)
        free: set[sp.Symbol] = set()
        for e in exprs:
            free |= e.free_symbols
        #: bound (numeric) functions of parameters used: symbol name -> (function, argument names)
        self.bound_parameters = {str(b): spec for b, spec in self.ns.bound.items() if b in free}
        return ([sym for name, sym in self.ns.params.items() if sym in free]
                + [b for b in self.ns.bound if b in free])

    # ---------------------------------------------------------------- exposed

    @property
    def state_names(self) -> list[str]:
        """Names of the first-order states."""
        return [str(s) for s in self.states]

    @property
    def rigid_body_modes(self) -> list[dict[str, sp.Expr]]:
        """Rigid-body modes of the final coordinates: ``[{coordinate: coefficient}, ...]``.

        Coordinate combinations that no spring, damper, mesh or force sees (see
        :mod:`gearsym.symbolic.rigid`); each is normalised so that its first non-zero
        coefficient is 1.  Empty for a model tied to the ground or reduced to relative
        coordinates.
        """
        return mode_dicts(self.rigid_modes, [str(c) for c in self.coordinates])

    @property
    def unreduced_rigid_body_modes(self) -> list[dict[str, sp.Expr]]:
        """Rigid-body modes of the model's own coordinates (before a reduction eliminates them)."""
        return mode_dicts(self.unreduced_rigid_modes, [str(c) for c in self.unreduced_coordinates])

    @property
    def parameter_names(self) -> list[str]:
        """Names of the run-time parameters of the compiled system."""
        return [str(p) for p in self.parameters]

    @property
    def modes(self) -> list[Mode]:
        """Named modes of the hybrid system (contact states of each backlash mesh)."""
        out: list[Mode] = []
        contact = [g for g in self.switching if g.kind in ("drive", "back")]
        elements = list(dict.fromkeys(g.name.rsplit(".", 1)[0] for g in contact))
        for el in elements:
            by_kind = {g.kind: g for g in contact if g.name.rsplit(".", 1)[0] == el}
            conds = {}
            for kind, g in by_kind.items():
                rel = ">" if g.contact_sign > 0 else "<"
                conds[kind] = f"{sp.sstr(g.expr)} {rel} 0"
            out.append(Mode(f"{el}: drive-side contact", conds.get("drive", "")))
            out.append(Mode(f"{el}: separation",
                            " and ".join(f"not ({c})" for c in conds.values())))
            out.append(Mode(f"{el}: back-side contact", conds.get("back", "")))
        for g in self.switching:
            if g.kind == "switch":
                out += [Mode(f"{g.name}: g > 0", f"{sp.sstr(g.expr)} > 0"),
                        Mode(f"{g.name}: g < 0", f"{sp.sstr(g.expr)} < 0")]
        return out

    def equations(self) -> list[sp.Eq]:
        """The equations of motion ``M q'' = F`` (one per coordinate); a table is shown as its call
        (``k_ltca(mesh_phase)``, :attr:`table_display`), not as its pieces."""
        out = []
        for i, qi in enumerate(self.coordinates):
            acc = sp.Symbol(f"{qi}''")
            lhs = sum(self.mass_matrix[i, j] * sp.Symbol(f"{qj}''") for j, qj in enumerate(self.coordinates))
            if self.accelerations is not None and self.mass_matrix[i, i] != 0:
                out.append(sp.Eq(acc, self.accelerations[i].xreplace(self.table_display)))
            else:
                out.append(sp.Eq(lhs, self.forces[i].xreplace(self.table_display)))
        if self.constraint_rows is not None:  # q_d'' from the accelerations of the kept coordinates
            put = {a: sp.Symbol(f"{v_}'") for a, v_ in zip(self.constrained.accelerations, self.velocities)}
            out += [sp.Eq(r.xreplace(put), 0) for r in self.constraint_rows]
        return out

    def jacobian(self) -> sp.Matrix:
        """``d f / d x`` of the modal right-hand side (explicit form)."""
        return self.modal.rhs.jacobian(self.states)

    def variational(self) -> sp.Matrix:
        """The variational system ``Phi' = J(t, x) Phi`` as a matrix expression."""
        n = len(self.states)
        phi = sp.Matrix(n, n, lambda i, j: internal_symbol(f"Phi_{i}_{j}"))
        return self.jacobian() * phi

    def residual(self, xdot: list[sp.Symbol]) -> sp.Matrix:
        """Implicit residual ``[q' - v; M v' - F; constraint rows]`` (modal), for IDA.

        ``xdot`` has one entry per state; those of the algebraic variables (last) do not
        appear (their derivatives are not part of the DAE).
        """
        n = len(self.coordinates)
        r_kin = [xdot[i] - self.velocities[i] for i in range(n)]
        acc = sp.Matrix(xdot[n:2 * n])
        r_dyn = self.mass_matrix * acc - self.modal.forces
        rows = []
        if self.constraint_rows is not None:
            put = dict(zip(self.constrained.accelerations, acc))
            rows = [r.xreplace(put) for r in self.modal.algebraic]
        return sp.Matrix(r_kin + list(r_dyn) + rows)

    @property
    def algebraic_names(self) -> list[str]:
        """Names of the algebraic variables (the last states; IDA's id vector is 0 there)."""
        return [str(a) for a in self.algebraic]

    def latex(self) -> str:
        """LaTeX of the equations of motion and switching functions (an ``aligned`` block, aligned at ``=``;
        ``Piecewise`` as ``cases``): what a notebook shows for the model (``_repr_latex_``)."""
        lines = []
        for i, qi in enumerate(self.coordinates):
            lhs = sp.latex(sp.Symbol(f"\\ddot{{{sp.latex(qi)}}}"))
            rhs = self.accelerations[i] if self.accelerations is not None else self.forces[i]
            rhs = rhs.xreplace(self.table_display)
            if self.accelerations is None:
                lhs = sp.latex(sum(self.mass_matrix[i, j] * sp.Symbol(f"\\ddot{{{sp.latex(qj)}}}")
                                   for j, qj in enumerate(self.coordinates)))
            lines.append(f"{lhs} &= {sp.latex(rhs)}")
        if self.constraint_rows is not None:  # the algebraic equations, in the accelerations
            put = {a: sp.Symbol(f"\\dot{{{sp.latex(v_)}}}")
                   for a, v_ in zip(self.constrained.accelerations, self.velocities)}
            lines += [f"0 &= {sp.latex(r.xreplace(put))}" for r in self.constraint_rows]
        for g in self.switching:
            lines.append(f"g_{{\\mathrm{{{g.name}}}}} &= {sp.latex(g.expr)}")
        return "\\begin{aligned}\n" + " \\\\\n".join(lines) + "\n\\end{aligned}"

    @property
    def structured_model(self) -> SymbolicModel:
        """The same model with parameter-only derived quantities kept as symbols
        (``m_e``, ``omega_n``; see :class:`~gearsym.symbolic.parsing.Namespace`)."""
        if self.structured:
            return self
        cached = self.__dict__.get("_structured")
        if cached is None:
            cached = SymbolicModel(self.resolved, structured=True)
            self.__dict__["_structured"] = cached
        return cached

    def dimensionless_system(self):
        """The model in dimensionless variables, for code generation
        (:class:`~gearsym.symbolic.dimensionless.DimensionlessSystem`)."""
        from .dimensionless import DimensionlessSystem

        return DimensionlessSystem(self)

    def dimensionless(self):
        """The dimensionless form (see :mod:`gearsym.symbolic.dimensionless`), computed once."""
        from .dimensionless import dimensionless_form

        cached = self.__dict__.get("_dimensionless")
        if cached is None and self.table_display:
            raise SpecError("the dimensionless form (its groups) is not derived for equations that use tables: "
                            "a table's values carry its unit, which the form does not scale yet",
                            file=self.spec.path, field="tables")
        if cached is None:
            with Budget(what=f"the dimensionless form of model '{self.name}'", file=self.spec.path).active():
                cached = dimensionless_form(self)
            self.__dict__["_dimensionless"] = cached
        return cached


def _surface_field(spec, name: str) -> str:
    """The spec field a switching surface comes from: its element (``mesh.drive`` -> ``elements.mesh``)."""
    element = name.rsplit(".", 1)[0]
    return f"elements.{element}" if element in spec.elements else "reduction"
