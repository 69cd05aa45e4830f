"""Tables in the spec language: data with a unit and a domain (``[tables.NAME]``).

A table is a function given by samples, used wherever an expression is: called as
``k_ltca(mesh_phase)`` in any expression field, or by its name alone (``stiffness =
"k_ltca"``) when it declares its ``arguments``.  The spec layer reads and checks the
numbers (here, with :mod:`~gearsym.spec.table_data` for files and
:mod:`~gearsym.spec.table_gears` for gear geometry) and decides the interpolant
(:mod:`~gearsym.spec.interpolants`); the symbolic layer writes it into the equations
(:mod:`gearsym.symbolic.tables`): its knots become scheduled breakpoints (over a mesh phase
or time) or switching surfaces (over a state).

::

    [tables.k_ltca]
    meaning = "mesh stiffness from loaded tooth contact analysis"
    unit = "N/m"                       # the values
    domain = ["phase", "N*m"]          # one entry per axis: "phase" (a schedule's mesh phase,
                                       # cycles in [0, 1], periodic) or the unit of the argument
    file = "k_ltca.csv"                # or x = [...], (y = [...],) values = [...]; or [tables.k.gears]
    interpolation = "cubic"            # linear (default), cubic, fourier (along the first axis)
    arguments = ["mesh_phase", "T1"]   # what the bare name means (optional)
    scale = "s_k"                      # a dimensionless factor of the parameters (optional)

Keys: ``meaning``, ``unit`` (required), ``domain`` (required), ``x`` / ``y`` / ``values`` or
``file`` (and ``column``) or ``gears``, ``interpolation``, ``tolerance`` (``fourier``: the
largest deviation from a sample, in ``unit``; default 1e-9 of the largest value), ``periodic``
(a table over time: the last sample closes the period), ``outside`` (``hold`` or ``extend``
outside a non-periodic domain), ``arguments``, ``scale``.

The second axis of a two-axis table (a load, a deflection) is always interpolated linearly.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import SpecError
from .fields import Ctx, as_table, expr_str, only_keys, string, unit_of
from .table_data import Grid, inline_grid, read_csv_grid, resolve_table_file
from .units import ONE, Unit

if TYPE_CHECKING:  # numpy and the interpolants are imported when a table is read (`gearsym --version` stays light)
    import numpy as np

    from .interpolants import Fourier, Pieces

__all__ = ["Axis", "Table", "parse_tables", "INTERPOLATIONS", "MAX_KNOTS", "MAX_COLUMNS"]

#: Interpolation along the first axis.
INTERPOLATIONS = ("linear", "cubic", "fourier")
#: Most knots of the first axis (each is a breakpoint or a switching surface; the generated C
#: evaluates a piece per knot).  Every piece is a term of the derived equations, and their
#: derivation grows with the pieces (measured: an LTCA-like 2-D table of 128 / 256 / 512 phases x
#: 5 torques took 7.5 / 14 / 30 s to derive, 2,000 phases over 400 s): a finer table is refused
#: up front with that reason rather than left to run for minutes.
MAX_KNOTS = 512
#: Most knots of the second axis.
MAX_COLUMNS = 64
#: Most values of one table (pieces of the equations, see :data:`MAX_KNOTS`).
MAX_VALUES = 4096
#: The limits of a ``fourier`` table, whose equations carry its harmonics, not a piece per knot
#: (the data: knots along the first axis, values).
MAX_FOURIER_KNOTS, MAX_FOURIER_VALUES = 2048, 65_536
#: What to do about a table beyond the limits.
_TOO_FINE = ("every knot is a piece of the derived equations (their derivation grows with the pieces: 2,560 "
             "values took about 30 s); resample the table more coarsely (an LTCA table rarely needs more than "
             "a few hundred phases), or use interpolation = \"fourier\" (its equations carry harmonics, not pieces)")
#: Most knots of a table over a state (one switching surface per knot; a model has at most 256).
MAX_STATE_KNOTS = 128

_KEYS = {"meaning", "unit", "domain", "x", "y", "values", "file", "column", "gears", "interpolation",
         "tolerance", "periodic", "outside", "arguments", "scale"}


@dataclass(frozen=True)
class Axis:
    """One axis of a table's domain.

    Attributes
    ----------
    kind
        ``"phase"`` (the phase of a schedule, in cycles; periodic) or ``"value"`` (an argument
        with a unit: time, a coordinate, a deflection, a load).
    unit, dims
        The unit of the knots as declared (``"1"`` for a phase) and its dimensions.
    knots
        The knots in SI (a phase in cycles); the first axis may repeat a knot (a jump).
    """

    kind: str
    unit: str
    dims: Unit
    knots: tuple[float, ...]


@dataclass(frozen=True)
class Table:
    """A validated table (see the module docstring).

    Attributes
    ----------
    name, meaning, unit, dims
        Name, text, the values' unit and its dimensions.
    axes
        One or two :class:`Axis`.
    columns
        The values (SI) along the first axis: one tuple per knot of the second axis (one in
        all for a one-axis table).
    interpolation
        ``"linear"``, ``"cubic"`` or ``"fourier"`` (the first axis).
    period
        The period of the first axis (1 for a phase, the span of a periodic table over time),
        else ``None``.
    outside
        ``"hold"`` or ``"extend"`` (non-periodic axes).
    tolerance
        ``fourier``: the largest deviation from a sample (SI).
    interpolants
        The interpolant of every column (:class:`~gearsym.spec.interpolants.Pieces` or
        :class:`~gearsym.spec.interpolants.Fourier`).
    arguments
        The arguments the bare name stands for (empty: the table must be called).
    scale
        A dimensionless factor (an expression of the parameters), or ``None``.
    source, file
        ``"inline"``, ``"file"`` (the resolved path in ``file``) or ``"gears"``.
    info
        What the gear geometry gave (``source == "gears"``), for ``inspect``.
    digest
        SHA-256 of the numbers and settings (part of the build key).
    """

    name: str
    meaning: str
    unit: str
    dims: Unit
    axes: tuple[Axis, ...]
    columns: tuple[tuple[float, ...], ...]
    interpolation: str
    period: float | None
    outside: str
    tolerance: float
    interpolants: tuple[Pieces | Fourier, ...] = field(repr=False)
    arguments: tuple[str, ...] = ()
    scale: str | None = None
    source: str = "inline"
    file: str | None = None
    info: dict[str, Any] = field(default_factory=dict, repr=False)
    digest: str = ""

    @property
    def scale_si(self) -> float:
        """SI value of one unit of the values."""
        return self.dims.scale

    def __call__(self, *args: Any) -> np.ndarray:
        """Evaluate the table in Python (SI arguments, a phase in cycles; SI values, without
        ``scale``): the reference of what the generated C computes."""
        import numpy as np

        from .interpolants import evaluate

        if len(args) != len(self.axes):
            raise TypeError(f"table '{self.name}' takes {len(self.axes)} argument(s)")
        cols = [evaluate(f, args[0]) for f in self.interpolants]
        if len(self.axes) == 1:
            return cols[0]
        y = np.asarray(self.axes[1].knots)
        a2 = np.broadcast_to(np.asarray(args[1], float), cols[0].shape)
        return _linear_across(np.stack(cols, axis=-1), y, a2, self.outside)

    def to_dict(self, data: bool = True) -> dict[str, Any]:
        """Plain numbers for JSON (``inspect --json``)."""
        out: dict[str, Any] = {
            "unit": self.unit, "domain": [a.unit if a.kind == "value" else "phase" for a in self.axes],
            "interpolation": self.interpolation, "period": self.period, "outside": self.outside,
            "knots": [len(a.knots) for a in self.axes], "source": self.source, "file": self.file,
            "arguments": list(self.arguments), "scale": self.scale, "meaning": self.meaning,
            "min": min(min(c) for c in self.columns) / self.scale_si,
            "max": max(max(c) for c in self.columns) / self.scale_si,
        }
        if self.interpolation == "fourier":
            out["harmonics"] = max(f.harmonics for f in self.interpolants)  # type: ignore[union-attr]
            out["tolerance"] = self.tolerance / self.scale_si
        if self.info:
            out["gears"] = dict(self.info)
        if data:
            out["x"] = [k / a_scale(self.axes[0]) for k in self.axes[0].knots]
            if len(self.axes) == 2:
                out["y"] = [k / a_scale(self.axes[1]) for k in self.axes[1].knots]
            out["values"] = [[v / self.scale_si for v in c] for c in self.columns]
        return out


def a_scale(axis: Axis) -> float:
    """SI value of one unit of an axis's knots."""
    return 1.0 if axis.kind == "phase" else axis.dims.scale


def _linear_across(cols: np.ndarray, y: np.ndarray, a: np.ndarray, outside: str) -> np.ndarray:
    """Linear interpolation across the second axis (``numpy.interp`` where ``outside`` holds)."""
    import numpy as np

    j = np.clip(np.searchsorted(y, a, side="right") - 1, 0, len(y) - 2)
    f0 = np.take_along_axis(cols, j[..., None], -1)[..., 0]
    f1 = np.take_along_axis(cols, (j + 1)[..., None], -1)[..., 0]
    out = f0 + (f1 - f0) / (y[j + 1] - y[j]) * (a - y[j])
    if outside == "hold":
        out = np.where(a < y[0], cols[..., 0], np.where(a >= y[-1], cols[..., -1], out))
    return out


# ------------------------------------------------------------------------------ parsing


def parse_tables(ctx: Ctx, data: dict[str, Any], declare: Callable[[str, str], None]) -> dict[str, Table]:
    """The ``[tables.NAME]`` sections of a model (see the module docstring).

    Raises
    ------
    SpecError
        Naming the model file and the field, or the table file, its row and column.
    """
    out: dict[str, Table] = {}
    section = data.get("tables", {})
    section = as_table(ctx, "tables", section)
    for name, tbl in section.items():
        where = f"tables.{name}"
        tbl = as_table(ctx, where, tbl)
        only_keys(ctx, where, tbl, _KEYS)
        declare(name, where)
        out[name] = _table(ctx, name, tbl)
    return out


def _choice(ctx: Ctx, tbl: dict[str, Any], where: str, options: tuple[str, ...], default: str) -> str:
    v = tbl.get(where.rsplit(".", 1)[-1], default)
    if v not in options:
        raise ctx.error(where, f"must be one of {', '.join(options)}, got {v!r:.40}")
    return v


def _domain(ctx: Ctx, where: str, value: Any) -> list[tuple[str, str, Unit]]:
    """``(kind, unit, dims)`` of each axis of ``domain``."""
    items = value if isinstance(value, list) else [value]
    if value is None or not 1 <= len(items) <= 2 or not all(isinstance(v, str) for v in items):
        raise ctx.error(where, "expected \"phase\", a unit (\"um\", \"s\", \"N*m\"), or an array of two of them "
                               "(a two-axis table)")
    axes = []
    for i, v in enumerate(items):
        fld = where if not isinstance(value, list) else f"{where}[{i}]"
        if v == "phase":
            if i == 1:
                raise ctx.error(fld, "the mesh phase is the first axis of a table")
            axes.append(("phase", "1", ONE))
        else:
            axes.append(("value", v, unit_of(ctx, fld, v)))
    return axes


def _grid(ctx: Ctx, name: str, tbl: dict[str, Any], naxes: int) -> tuple[Grid, str, str | None, dict]:
    """The numbers of a table and where they come from."""
    where = f"tables.{name}"
    sources = [k for k in ("file", "gears", "values") if k in tbl]
    if len(sources) != 1:
        raise ctx.error(where, "give the data one way: values (with x, and y for two axes), file = \"...\" "
                               "(a CSV file beside the model) or a [tables.NAME.gears] section")
    for key in ("x", "y"):
        if key in tbl and sources[0] != "values":
            raise ctx.error(f"{where}.{key}", f"'{key}' goes with inline values, not with {sources[0]}")
    if "column" in tbl and sources[0] != "file":
        raise ctx.error(f"{where}.column", "'column' chooses a column of a table file")
    if sources[0] == "file":
        path = resolve_table_file(ctx.path, tbl["file"], name)
        column = string(ctx, tbl, f"{where}.column")
        if column is not None and naxes != 1:
            raise ctx.error(f"{where}.column", "'column' applies to a one-axis table file")
        return read_csv_grid(path, str(path), name, naxes, column), "file", str(path), {}
    if sources[0] == "gears":
        if naxes != 1:
            raise ctx.error(f"{where}.domain", "a table from gear geometry has one axis, the mesh phase")
        from .table_gears import gear_table

        x, k, info = gear_table(ctx.path, name, tbl["gears"])
        return (Grid(x, None, [[v] for v in k], ctx.path, lambda i, j: f"phase {x[i]:.6g}"), "gears", None, info)
    return inline_grid(ctx.path, name, tbl, naxes), "inline", None, {}


def _table(ctx: Ctx, name: str, tbl: dict[str, Any]) -> Table:
    where = f"tables.{name}"
    if "unit" not in tbl:
        raise ctx.error(f"{where}.unit", "missing: the unit of the values (\"N/m\", \"um\", \"1\")")
    unit = string(ctx, tbl, f"{where}.unit") or "1"
    dims = unit_of(ctx, f"{where}.unit", unit)
    if "domain" not in tbl and "gears" in tbl:
        tbl = {**tbl, "domain": "phase"}
    if "domain" not in tbl:
        raise ctx.error(f"{where}.domain", "missing: \"phase\" (a mesh phase) or the unit of the argument")
    axes_decl = _domain(ctx, f"{where}.domain", tbl["domain"])
    if "gears" in tbl and (axes_decl[0][0] != "phase" or not dims.same_dimension(Unit(1.0, (1, 0, -2)))):
        raise ctx.error(where, "a table from gear geometry is a mesh stiffness over the mesh phase: "
                               "domain = \"phase\", unit = \"N/m\" (or another stiffness unit)")
    kind = _choice(ctx, tbl, f"{where}.interpolation", INTERPOLATIONS, "linear")
    outside = _choice(ctx, tbl, f"{where}.outside", ("hold", "extend"), "hold")
    periodic = tbl.get("periodic", False)
    if not isinstance(periodic, bool):
        raise ctx.error(f"{where}.periodic", f"must be true or false, got {periodic!r:.40}")
    grid, source, file, info = _grid(ctx, name, tbl, len(axes_decl))
    check = _Checks(ctx, name, grid, source)
    axes = check.axes(axes_decl, periodic)
    period = check.period(axes[0], periodic)
    columns = tuple(tuple(row[j] * dims.scale for row in grid.values) for j in range(len(grid.values[0])))
    check.sizes(axes, columns, kind)
    tolerance = _tolerance(ctx, where, tbl, dims, columns)
    interpolants = check.interpolants(axes[0], columns, kind, period, outside, tolerance)
    arguments = _arguments(ctx, where, tbl, len(axes))
    scale = expr_str(ctx, f"{where}.scale", tbl["scale"]) if "scale" in tbl else None
    table = Table(name, string(ctx, tbl, f"{where}.meaning") or "", unit, dims, axes, columns, kind, period,
                  outside, tolerance, interpolants, arguments, scale, source, file, info)
    return _with_digest(table)


def _tolerance(ctx: Ctx, where: str, tbl: dict[str, Any], dims: Unit, columns) -> float:
    if "tolerance" not in tbl:
        return 1e-9 * max(max(abs(v) for v in c) for c in columns)
    if tbl.get("interpolation") != "fourier":
        raise ctx.error(f"{where}.tolerance", "the tolerance chooses the harmonics of a fourier table")
    v = tbl["tolerance"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0):
        raise ctx.error(f"{where}.tolerance", f"must be a number >= 0 (in the table's unit), got {v!r:.40}")
    return float(v) * dims.scale


def _arguments(ctx: Ctx, where: str, tbl: dict[str, Any], naxes: int) -> tuple[str, ...]:
    if "arguments" not in tbl:
        return ()
    v = tbl["arguments"]
    items = v if isinstance(v, list) else [v]
    if len(items) != naxes:
        raise ctx.error(f"{where}.arguments", f"one argument per axis of the domain ({naxes}), got {len(items)}")
    return tuple(expr_str(ctx, f"{where}.arguments" + (f"[{i}]" if isinstance(v, list) else ""), a)
                 for i, a in enumerate(items))


def _with_digest(t: Table) -> Table:
    payload = json.dumps({"axes": [(a.kind, a.unit, a.knots) for a in t.axes], "columns": t.columns,
                          "interp": t.interpolation, "period": t.period, "outside": t.outside,
                          "tol": t.tolerance, "unit": t.unit}, sort_keys=True)
    digest = hashlib.sha256(payload.encode()).hexdigest()
    return Table(**{**t.__dict__, "digest": digest})


class _Checks:
    """The checks of a table's numbers; every problem names the place of the number."""

    def __init__(self, ctx: Ctx, name: str, grid: Grid, source: str):
        self.ctx = ctx
        self.name = name
        self.grid = grid
        self.source = source

    def error(self, i: int, j: int, message: str) -> SpecError:
        place = self.grid.place(i, j)
        return SpecError(f"{place}: {message}", file=self.grid.file, field=f"tables.{self.name}")

    def whole(self, message: str) -> SpecError:
        return SpecError(message, file=self.grid.file, field=f"tables.{self.name}")

    def axes(self, decl: list[tuple[str, str, Unit]], periodic: bool) -> tuple[Axis, ...]:
        g = self.grid
        x = g.x
        if len(x) < 2:
            raise self.whole("a table needs at least two knots along its first axis")
        for i in range(len(x) - 1):
            if x[i + 1] < x[i]:
                raise self.error(i + 1, -1, f"the domain must increase: {x[i + 1]:.10g} after {x[i]:.10g}")
            if x[i + 1] == x[i] and (i == 0 or i + 1 == len(x) - 1 or x[i - 1] == x[i]):
                raise self.error(i + 1, -1, f"the knot {x[i]:.10g} is written twice at the end of the domain or "
                                            f"three times (a jump is a knot written twice inside the domain)")
        kind, unit, dims = decl[0]
        if kind == "phase":
            if x[0] < 0 or x[-1] > 1 or x[-1] > x[0] + 1:
                bad = 0 if x[0] < 0 else len(x) - 1
                raise self.error(bad, -1, "a mesh phase is in cycles: the knots lie in [0, 1] (1 closes the cycle)")
            if periodic:
                raise self.whole("a table over the mesh phase is periodic anyway: remove 'periodic'")
        axes = [Axis(kind, unit, dims, tuple(v * (1.0 if kind == "phase" else dims.scale) for v in x))]
        if len(decl) == 2:
            y = g.y or []
            if len(y) < 2:
                raise self.whole("a two-axis table needs at least two knots along its second axis")
            for j in range(len(y) - 1):
                if not y[j + 1] > y[j]:
                    raise self.error(-1, j + 1, f"the knots of the second axis must increase strictly: "
                                                f"{y[j + 1]:.10g} after {y[j]:.10g}")
            _, unit2, dims2 = decl[1]
            axes.append(Axis("value", unit2, dims2, tuple(v * dims2.scale for v in y)))
        return tuple(axes)

    def period(self, axis: Axis, periodic: bool) -> float | None:
        if axis.kind == "phase":
            return 1.0
        if not periodic:
            return None
        if axis.dims.dims not in ((0, 0, 1), (0, 0, 0)):  # seconds, or the time of a dimensionless model
            raise self.whole("only a table over time (or the mesh phase) is periodic")
        p = axis.knots[-1] - axis.knots[0]
        if not p > 0:  # pragma: no cover - two increasing knots at least
            raise self.whole("a periodic table needs a positive span")
        return p

    def sizes(self, axes: tuple[Axis, ...], columns, kind: str) -> None:
        fourier = kind == "fourier"
        knots, values = (MAX_FOURIER_KNOTS, MAX_FOURIER_VALUES) if fourier else (MAX_KNOTS, MAX_VALUES)
        why = "" if fourier else f": {_TOO_FINE}"
        if len(axes[0].knots) > knots:
            raise self.whole(f"{len(axes[0].knots)} knots along the first axis (limit {knots}){why}")
        if len(axes) == 2 and len(axes[1].knots) > MAX_COLUMNS:
            raise self.whole(f"{len(axes[1].knots)} knots along the second axis (limit {MAX_COLUMNS})")
        n = sum(len(c) for c in columns)
        if n > values:
            raise self.whole(f"{n} values (limit {values}){why}")

    def interpolants(self, axis: Axis, columns, kind: str, period: float | None, outside: str,
                     tolerance: float) -> tuple[Pieces | Fourier, ...]:
        import numpy as np

        from .interpolants import column_interpolant, finite

        x = np.asarray(axis.knots)
        if kind == "fourier":
            self._fourier_ok(x, columns, period)
        out = []
        for j, col in enumerate(columns):
            f = column_interpolant(x, np.asarray(col), kind, period, outside, tolerance)
            if not finite(f):
                raise self.whole(f"the {kind} interpolant of column {j + 1} is not finite (values too large for "
                                 f"the spacing of their knots)")
            out.append(f)
        return tuple(out)

    def _fourier_ok(self, x: np.ndarray, columns, period: float | None) -> None:
        import numpy as np

        from .interpolants import uniform

        if period is None:
            raise self.whole("fourier interpolation needs a periodic domain (the mesh phase, or time with "
                             "periodic = true)")
        closing = x[-1] == x[0] + period
        if np.any(np.diff(x) == 0):
            i = int(np.argmax(np.diff(x) == 0)) + 1
            raise self.error(i, -1, "a fourier table has no jumps (a knot written twice)")
        xs = x[:-1] if closing else x
        if len(xs) < 2 or not uniform(xs, period):
            raise self.whole(f"fourier interpolation needs equally spaced samples over the cycle ({len(xs)} "
                             f"samples, spacing {period / max(len(xs), 1):.6g})")
        if closing:
            for j, col in enumerate(columns):
                if col[-1] != col[0]:
                    raise self.error(len(x) - 1, j, "the closing sample of a fourier table must equal the "
                                                    "first (a jump at the wrap)")
