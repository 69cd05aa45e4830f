"""Tables in the equations: a call ``k(mesh_phase)`` becomes exact piecewise polynomials.

The spec layer gives every table its interpolant as numbers
(:mod:`gearsym.spec.interpolants`: piecewise polynomials or a Fourier series, per column).
Here a call is written into sympy so that the integrator never steps across a knot, with
no new machinery in the code generator or the C driver:

* **over a mesh phase** (``k(mesh_phase)``) or **over time** (``k(t)``): the knots are the
  breaks of a *hidden schedule* (named ``TABLE@SCHEDULE`` or ``TABLE@t``, with the period of
  the schedule, or of the table over time): the driver stops at every break as it does for
  any ``[schedules]`` entry, sets the segment index, and the table is a ``Piecewise`` over the
  segment index of one polynomial per segment, in the local variable of its piece
  (``u = phase - x_j``; the piece that wraps around the cycle is evaluated with the shifted
  phase, as ``numpy.interp(..., period=1)`` and ``CubicSpline(bc_type="periodic")`` do).
  A non-periodic table over time holds (or extends) its end values; its hidden schedule has
  the period ``2 x_N`` and reads the cycle index (before ``t = 0`` and after ``2 x_N``);
* **over a state** (a coordinate, a deflection): a ``Piecewise`` whose conditions
  ``arg < x_j`` are switching surfaces, one per knot, named ``OWNER.TABLE.knotJ`` (the
  engine locates every crossing; in each mode the polynomial of one piece is active);
* **over a parameter** (a load): the same ``Piecewise``, its conditions on the parameters
  (a run-time choice of the piece, no event);
* **fourier**: the series in ``t`` itself (``cos(2 pi k t/P)``): smooth, no breakpoints;
* **two axes**: every column of the first axis as above, combined linearly across the
  second axis (a ``Piecewise`` on its argument: surfaces for a state, conditions for a
  parameter), as ``numpy.interp`` over the columns.

So Jacobians, variational equations, monodromies and parameter sensitivities are those of
plain expressions (a table's ``scale`` is a factor of the parameters), and effects prune a
table's terms like any other.  :attr:`TableLowering.display` maps each written table to a
short function call (``k_ltca(mesh_phase)``) for ``inspect``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from ..errors import SpecError
from ..spec import syntax as sx
from ..spec.interpolants import Fourier, Pieces
from ..spec.tables import MAX_STATE_KNOTS, Table
from .budget import MAX_SURFACES
from .surfaces import SurfaceHint, owner_of

if TYPE_CHECKING:
    from .parsing import Namespace


def _poly(coefs: tuple[float, ...], u: sp.Expr) -> sp.Expr:
    """``c_0 u^d + ... + c_d`` in Horner's form (the evaluation order of the Python reference).

    A number times the local variable stays a product (sympy would distribute it over
    ``u = t/T - n - x_j``, and ``c*t/T - c*n`` loses digits as ``t`` grows).
    """
    out: sp.Expr = sp.Float(coefs[0])
    for c in coefs[1:]:
        prod = sp.Mul(out, u, evaluate=False) if out.is_Number else out * u
        out = prod + sp.Float(c) if c != 0 else prod
    return out


class TableLowering:
    """Writes table calls into sympy for one :class:`~gearsym.symbolic.parsing.Namespace`.

    Attributes
    ----------
    hidden
        The hidden schedules made so far: name -> ``(schedule it follows or None, period in
        seconds or None, break fractions)``.
    display
        Each written table expression -> its short form for ``inspect``.
    """

    def __init__(self, ns: Namespace, internal_symbol: Callable[[str], sp.Symbol]):
        self.ns = ns
        self.internal_symbol = internal_symbol
        self.hidden: dict[str, tuple[str | None, float | None, list[float]]] = {}
        self.display: dict[sp.Basic, sp.Basic] = {}
        self._cache: dict[tuple, sp.Expr] = {}

    # ------------------------------------------------------------------ entry point

    def call(self, table: Table, args: tuple[sx.Node, ...], visit: Callable[[sx.Node], sp.Basic],
             where: str, record) -> sp.Expr:
        """The sympy expression of ``table(args)`` in the field ``where``.

        Parameters
        ----------
        table
            The table.
        args
            The argument nodes of the call (one per axis).
        visit
            Builds the sympy object of a node (the field's builder).
        where
            The spec field (for messages and surface names).
        record
            The field's :class:`~gearsym.symbolic.surfaces.Recorder` (its surfaces), or ``None``.
        """
        if len(args) != len(table.axes):
            raise self._error(where, f"table '{table.name}' takes {len(table.axes)} argument(s), got {len(args)}")
        first, shown0 = self._first_argument(table, args[0], visit, where)
        second = None
        if len(table.axes) == 2:
            second = visit(args[1])
            if self._time_dependent(second):
                raise self._error(where, f"argument 2 of table '{table.name}' depends on time: the second axis "
                                         f"is a load or a deflection (a parameter or a state)")
        key = (table.name, first if not isinstance(first, tuple) else first[:2], second)
        if key in self._cache:
            return self._cache[key]
        cols = [self._column(table, f, first, where, record, j) for j, f in enumerate(table.interpolants)]
        value = cols[0] if second is None else self._across(table, cols, second, where, record)
        shown = [shown0] + ([second] if second is not None else [])
        self.display[value] = sp.Function(table.name)(*shown)
        if table.scale is not None:
            value = value * self.ns.parse(table.scale, f"tables.{table.name}.scale")
        self._cache[key] = value
        return value

    def hider(self) -> tuple[Callable[[sp.Basic], sp.Basic], Callable[[sp.Basic], sp.Basic]]:
        """``(hide, show)``: replace every table that depends on no state by a symbol, and back.

        Expanding and folding the equations (a reduction: :mod:`gearsym.symbolic.reduction`) would
        otherwise multiply every other term out over the table's 64 pieces (and the dead zone's
        branches into each piece); a table of time or of the parameters needs none of it.
        """
        dynamic = set(self.ns.coords.values()) | set(self.ns.vels.values())
        fwd = {k: sp.Dummy(f"table{i}", real=True) for i, k in enumerate(self.display)
               if not (k.free_symbols & dynamic)}
        back = {d: k for k, d in fwd.items()}
        if not fwd:
            return (lambda e: e), (lambda e: e)
        return (lambda e: e.xreplace(fwd)), (lambda e: e.xreplace(back))

    def _error(self, where: str, message: str) -> SpecError:
        return SpecError(message, file=self.ns.rs.model.path, field=where or None)

    def _time_dependent(self, e: sp.Basic) -> bool:
        ns = self.ns
        clocks = {ns.t, *ns.sched_n.values(), *ns.sched_seg.values()}
        return bool(e.free_symbols & clocks)

    def _first_argument(self, table: Table, node: sx.Node, visit, where: str):
        """What the first argument is: ``("phase", schedule)``, ``("time",)``, ``("state", expr)`` or
        ``("parameter", expr)``; and its display form."""
        ns = self.ns
        axis = table.axes[0]
        if axis.kind == "phase":
            sname = node.id[:-len("_phase")] if isinstance(node, sx.Name) and node.id.endswith("_phase") else None
            if sname not in ns.rs.model.schedules:
                raise self._error(where, f"table '{table.name}' is over the mesh phase: its argument must be a "
                                         f"schedule's phase (NAME_phase)")
            return ("phase", sname), sp.Symbol(f"{sname}_phase", real=True)
        a = visit(node)
        if a == ns.t:  # (the unit check made its domain the model's time unit)
            return ("time",), ns.t
        if table.period is not None:
            raise self._error(where, f"table '{table.name}' is periodic in time: its argument must be t")
        if a.free_symbols & ns.surfaces.dynamic:
            return ("state", a), a
        if self._time_dependent(a):
            raise self._error(where, f"the argument of table '{table.name}' depends on time but is not t itself "
                                     f"(its knots would be crossed at times the integrator does not know): call "
                                     f"it with t, or make it a table over a schedule's phase")
        return ("parameter", a), a

    # ------------------------------------------------------------------ first axis

    def _column(self, table: Table, f: Pieces | Fourier, first, where: str, record, j: int) -> sp.Expr:
        kind = first[0]
        if isinstance(f, Fourier):
            return self._fourier(f, self._clock(table, first))
        if kind in ("phase", "time") and f.period is not None:
            return self._periodic(table, f, first)
        if kind == "time":
            return self._timed(table, f)
        a = first[1]
        if kind == "state" and j == 0:
            self._hint_knots(table, a, f.breaks if f.outside == "hold" else f.breaks[1:-1], "knot", where, record)
        return self._by_condition(f, a)

    def _clock(self, table: Table, first) -> sp.Expr:
        """The argument in the table's units without wrapping: ``t/P`` (cycles) or ``t``."""
        ns = self.ns
        if first[0] == "phase":
            return ns.t / ns.period_of(first[1])
        return ns.t

    @staticmethod
    def _fourier(f: Fourier, x: sp.Expr) -> sp.Expr:
        theta = 2 * sp.pi * x / sp.Float(f.period) if f.period != 1.0 else 2 * sp.pi * x
        terms = [sp.Float(f.mean)]
        for k, (a, b) in enumerate(zip(f.cos, f.sin), start=1):
            terms += [sp.Float(a) * sp.cos(k * theta), sp.Float(b) * sp.sin(k * theta)]
        return sp.Add(*terms)

    def _schedule(self, name: str, follows: str | None, period: float | None, breaks: list[float]):
        """The cycle and segment symbols of a hidden schedule (made on first use)."""
        ns = self.ns
        if name not in self.hidden:
            self.hidden[name] = (follows, period, breaks)
            ns.sched_n[name] = self.internal_symbol(f"n_{name}")
            ns.sched_seg[name] = self.internal_symbol(f"seg_{name}")
            ns.schedule_period[name] = ns.period_of(follows) if follows is not None else sp.Float(period)
            ns.schedule_breaks[name] = [sp.Float(c) for c in breaks]
        return ns.sched_n[name], ns.sched_seg[name]

    def _periodic(self, table: Table, f: Pieces, first) -> sp.Expr:
        """A periodic table on a hidden schedule whose breaks are its knots (in cycle fractions)."""
        P = f.period
        assert P is not None
        b = np.asarray(f.breaks)
        cuts = sorted({float(c) for c in np.mod(b / P, 1.0) if 0.0 < c < 1.0})
        follows = first[1] if first[0] == "phase" else None
        name = f"{table.name}@{follows or 't'}"
        n, seg = self._schedule(name, follows, None if follows else P, cuts)
        if follows is not None:
            X = self.ns.t / self.ns.period_of(follows) - n       # the phase, cycles in [0, 1)
        else:
            X = self.ns.t - sp.Float(P) * n                       # time within the period
        edges = [0.0, *cuts, 1.0]
        pieces = []
        for s in range(len(edges) - 1):
            mid = 0.5 * (edges[s] + edges[s + 1]) * P
            xm = b[0] + np.mod(mid - b[0], P)
            jj = int(np.clip(np.searchsorted(b, xm, side="right") - 1, 0, len(b) - 2))
            shift = round((xm - mid) / P) * P
            u = X + sp.Float(shift - b[jj]) if shift - b[jj] != 0 else X
            pieces.append(_poly(f.coefs[jj], u))
        return _by_segment(pieces, seg)

    def _timed(self, table: Table, f: Pieces) -> sp.Expr:
        """A non-periodic table over time: a hidden schedule of period ``2 x_N`` selects the piece."""
        b = np.asarray(f.breaks)
        if b[0] < 0 or not b[-1] > 0:
            raise self._error(f"tables.{table.name}", f"a table over time starts at t >= 0 and ends after 0 (its "
                                                      f"domain is [{b[0]:g}, {b[-1]:g}] s)")
        P = 2.0 * float(b[-1])
        cuts = sorted({float(c) for c in b / P if 0.0 < c < 1.0})
        n, seg = self._schedule(f"{table.name}@t", None, P, cuts)
        t = self.ns.t
        ends = self._ends(f, t)
        edges = [0.0, *cuts, 1.0]
        pieces = []
        for s in range(len(edges) - 1):
            mid = 0.5 * (edges[s] + edges[s + 1]) * P
            if mid < b[0]:
                pieces.append(ends[0])
            elif mid > b[-1]:
                pieces.append(ends[1])
            else:
                jj = int(np.searchsorted(b, mid, side="right") - 1)
                pieces.append(_poly(f.coefs[jj], t - sp.Float(b[jj])))
        return sp.Piecewise((ends[0], n < -0.5), (ends[1], n > 0.5), (_by_segment(pieces, seg), True))

    @staticmethod
    def _ends(f: Pieces, a: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
        """The value before the first knot and after the last (held or the end pieces continued)."""
        b = f.breaks
        if f.outside == "hold":
            return sp.Float(f.left()), sp.Float(f.right())
        return _poly(f.coefs[0], a - sp.Float(b[0])), _poly(f.coefs[-1], a - sp.Float(b[-2]))

    def _by_condition(self, f: Pieces, a: sp.Expr) -> sp.Expr:
        """A table over a state or a parameter: conditions ``a < x_j`` select the piece."""
        b = f.breaks
        left, right = self._ends(f, a)
        args = []
        if f.outside == "hold":
            args.append((left, a < sp.Float(b[0])))
        last = len(f.coefs) - 1
        for jj, c in enumerate(f.coefs):
            if f.outside == "extend" and jj == last:
                args.append((_poly(c, a - sp.Float(b[jj])), True))
            else:
                args.append((_poly(c, a - sp.Float(b[jj])), a < sp.Float(b[jj + 1])))
        if f.outside == "hold":
            args.append((right, True))
        return sp.Piecewise(*args)

    # ------------------------------------------------------------------ second axis

    def _across(self, table: Table, cols: list[sp.Expr], a: sp.Expr, where: str, record) -> sp.Expr:
        """Linear interpolation of the columns across the second axis (``numpy.interp``)."""
        y = table.axes[1].knots
        if a.free_symbols & self.ns.surfaces.dynamic:
            self._hint_knots(table, a, y if table.outside == "hold" else y[1:-1], "y", where, record)
        args = []
        if table.outside == "hold":
            args.append((cols[0], a < sp.Float(y[0])))
        for j in range(len(y) - 1):
            slope = (cols[j + 1] - cols[j]) / sp.Float(y[j + 1] - y[j])
            cell = cols[j] + slope * (a - sp.Float(y[j]))
            last = j == len(y) - 2
            args.append((cell, True if (last and table.outside == "extend") else a < sp.Float(y[j + 1])))
        if table.outside == "hold":
            args.append((cols[-1], True))
        return sp.Piecewise(*args)

    # ------------------------------------------------------------------ surfaces

    def _hint_knots(self, table: Table, a: sp.Expr, knots, label: str, where: str, record) -> None:
        """Name the switching surfaces ``a = x_j`` of a table over a state (``OWNER.TABLE.knotJ``)."""
        finder = self.ns.surfaces
        if len(knots) > MAX_STATE_KNOTS:
            raise self._error(where, f"table '{table.name}' over a state has {len(knots)} knots (limit "
                                     f"{MAX_STATE_KNOTS}: each one is a switching surface)")
        if record is not None and not record.first:
            return
        finder.potential += len(knots)
        if finder.potential > MAX_SURFACES:
            raise self._error(where, f"the fields up to this one have more than {MAX_SURFACES} switching "
                                     f"surfaces (a table over a state has one per knot)")
        owner = owner_of(where) if where else table.name
        for j, x in enumerate(knots):
            finder.hints.append(SurfaceHint(f"{owner}.{table.name}.{label}{j}", a - sp.Float(x),
                                            f"{table.name}: its argument passes the knot {x:g} (SI) ({where})",
                                            where))


def _by_segment(pieces: list[sp.Expr], seg: sp.Symbol) -> sp.Expr:
    """``Piecewise`` over a schedule's segment index: piece ``s`` on segment ``s``."""
    if len(pieces) == 1:
        return pieces[0]
    args = [(p, seg < s + 0.5) for s, p in enumerate(pieces[:-1])]
    args.append((pieces[-1], True))
    return sp.Piecewise(*args)
