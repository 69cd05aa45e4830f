"""Where switching surfaces come from, and their names.

Every state-dependent condition of a ``Piecewise`` and every kink or jump of ``abs``,
``sign``, ``Heaviside``, ``Max`` and ``Min`` of the states is a switching surface
(:mod:`gearsym.symbolic.switching`).  While an expression field is built
(:class:`gearsym.symbolic.parsing.Builder`), :class:`SurfaceFinder` records each such
condition and call with the field it is written in, and turns them into *surface hints*:
a switching function, oriented as written, with a name that does not depend on anything
but the spec:

* the ``surface`` key of the term table, if the user gave one: ``OWNER.NAME`` (one name
  per surface of the term, in the order they are written);
* otherwise ``OWNER.CONDITION``, the condition as written without spaces (``mesh.x-b>0``,
  ``fx.w<0``); the kink of ``Max(a, b)`` / ``Min(a, b)`` is ``OWNER.a=b`` (one per pair of
  arguments), that of ``abs(e)`` / ``sign(e)`` / ``Heaviside(e)`` is ``OWNER.e=0``.

``OWNER`` is the element, derived quantity or equation the field belongs to (``fx`` for
``elements.fx.value[1]``, ``d`` for ``derived.d.value``).  The model transforms the hints
with its equations (constraints, reductions) and :func:`~gearsym.symbolic.switching.make_modal`
gives every surface it finds in the equations the name of the first hint with the same
canonical form (the contact surfaces ``NAME.drive`` / ``NAME.back`` of the elements come
first).  So the names are the same in ``inspect``, in every compile and for every hash
seed.

A function that jumps at infinitely many places of the states (``floor``) cannot be a
switching surface: it is refused, naming the field, as are ``Max``/``Min`` calls and
``Piecewise`` with too many state-dependent arguments (:mod:`gearsym.symbolic.budget`).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field

import sympy as sp
from sympy.core.relational import Relational

from ..errors import SpecError
from ..spec import syntax as sx
from .budget import MAX_PIECEWISE_CONDITIONS, MAX_STATE_ARGS, MAX_SURFACES

#: Calls of the spec language whose kinks or jumps in the states are switching surfaces.
SWITCHING_CALLS = frozenset({"abs", "Abs", "sign", "Heaviside", "Max", "Min", "max", "min"})
_MAX_MIN = frozenset({"Max", "Min", "max", "min"})
#: Calls that jump at every integer of their argument (no finite set of surfaces).
JUMP_CALLS = frozenset({"floor"})
#: Calls and nodes :class:`SurfaceFinder` records.
RECORDED_CALLS = SWITCHING_CALLS | JUMP_CALLS

#: Longest condition text in a generated surface name (longer ones end in a short digest).
MAX_LABEL = 40
_LABEL_CHARS = re.compile(r"[^A-Za-z0-9_.+\-*/^()<>=,]")


@dataclass(frozen=True)
class SurfaceHint:
    """A switching function found in a spec field.

    Attributes
    ----------
    name
        ``OWNER.LABEL`` (see the module docstring).
    expr
        ``g``, oriented so that ``g > 0`` is the side where the condition holds (for a
        kink: where the first argument is the larger).
    meaning
        One line for ``inspect``.
    origin
        The spec field (``elements.fx.value[1]``).
    given
        Whether the user named it (a ``surface`` key).
    """

    name: str
    expr: sp.Expr
    meaning: str
    origin: str
    given: bool = False


@dataclass
class _Found:
    g: sp.Expr
    label: str
    meaning: str


class Recorder:
    """What :class:`~gearsym.symbolic.parsing.Builder` reports while it builds one field.

    Parameters
    ----------
    finder
        The namespace's :class:`SurfaceFinder`.
    expr
        The checked expression being built.
    where
        Its spec field.
    """

    def __init__(self, finder: SurfaceFinder, expr: sx.Expression, where: str):
        self.finder = finder
        self.expr = expr
        self.where = where
        self.records: list[tuple[sx.Node, sp.Basic, tuple]] = []
        self.first = not finder.seen(where, expr.text)  # a field built again counts once

    def source(self, node: sx.Node) -> str:
        return self.expr.text[node.start:node.end]

    def error(self, message: str) -> SpecError:
        return SpecError(message, file=self.finder.file, field=self.where or None)

    def before(self, node: sx.Node, args: tuple) -> None:
        """Check a call (or the conditions of a ``Piecewise``) before sympy builds it.

        Raises
        ------
        SpecError
            ``floor`` of a time- or state-dependent argument, a ``Max``/``Min`` or
            ``Piecewise`` with too many state-dependent arguments.
        """
        self._check(node, args)
        self._count(node, args)

    def _check(self, node: sx.Node, args: tuple) -> None:
        of_states = self.finder.of_states
        if isinstance(node, sx.Piecewise):
            n = sum(1 for c in args for r in _relations(c) if of_states(r))
            if n > MAX_PIECEWISE_CONDITIONS:
                raise self.error(f"Piecewise with {n} conditions on the states (limit {MAX_PIECEWISE_CONDITIONS}: "
                                 f"each one is a switching surface)")
            return
        if not isinstance(node, sx.Call):
            return
        if node.func in JUMP_CALLS:
            src = sx.quote(self.source(node))
            if of_states(args[0]):
                raise self.error(f"{node.func}() of the states ('{src}') jumps at every integer: it is not a "
                                 f"switching surface the integrator can locate (write the jumps the model needs "
                                 f"as Piecewise conditions)")
            if args[0].has(self.finder.t):
                raise self.error(f"{node.func}() of time ('{src}') jumps at every integer, which the integrator "
                                 f"would step across: declare a [schedules] entry and use a piecewise_cycle "
                                 f"field (or <schedule>_segment)")
        elif node.func in _MAX_MIN and len(args) > MAX_STATE_ARGS \
                and any(of_states(a) for a in args):
            raise self.error(f"{node.func}() of the states with {len(args)} arguments (limit {MAX_STATE_ARGS}: "
                             f"every pair of arguments is a switching surface)")

    def _count(self, node: sx.Node, args: tuple) -> None:
        """Count the surfaces this call or comparison can make, before sympy builds it (a
        field of 20 000 ``Max`` calls would take sympy minutes to build)."""
        of_states = self.finder.of_states
        if not self.first:
            return
        if isinstance(node, sx.Compare):
            n = 1 if any(of_states(a) for a in args) else 0
        elif isinstance(node, sx.Call) and node.func in SWITCHING_CALLS and any(of_states(a) for a in args):
            n = len(args) * (len(args) - 1) // 2 if node.func in _MAX_MIN else 1
        else:
            return
        self.finder.potential += n
        if self.finder.potential > MAX_SURFACES:
            raise self.error(f"the fields up to this one have more than {MAX_SURFACES} switching surfaces "
                             f"(state-dependent conditions and kinks)")

    def __call__(self, node: sx.Node, value: sp.Basic, args: tuple) -> None:
        self.records.append((node, value, args))

    def surfaces(self) -> list[_Found]:
        """The switching surfaces of the recorded comparisons and calls, in the order written."""
        found: list[_Found] = []
        for node, value, args in self.records:
            found += self._surfaces_of(node, value, args)
        unique: list[_Found] = []
        seen: set[sp.Expr] = set()
        for f in found:  # one surface per distinct function (g and -g are one surface)
            if f.g not in seen and -f.g not in seen:
                seen.add(f.g)
                unique.append(f)
        return unique

    def _surfaces_of(self, node: sx.Node, value: sp.Basic, args: tuple) -> list[_Found]:
        of_states, where, src = self.finder.of_states, self.where, self.source(node)
        if isinstance(node, sx.Compare):
            if not isinstance(value, Relational) or not of_states(value):
                return []
            left, right = args
            g = left - right if node.op in (">", ">=") else right - left
            return [_Found(g, label(src), f"{sx.quote(src)} holds where g > 0 ({where})")]
        if not isinstance(node, sx.Call) or node.func not in SWITCHING_CALLS:
            return []
        if node.func in _MAX_MIN:
            out = []
            for i in range(len(args)):
                for j in range(i + 1, len(args)):
                    g = args[i] - args[j]
                    if of_states(g):
                        si, sj = self.source(node.args[i]), self.source(node.args[j])
                        out.append(_Found(g, label(f"{si}={sj}"), f"kink of {sx.quote(src)} where "
                                                                    f"{sx.quote(si, 30)} = {sx.quote(sj, 30)} ({where})"))
            return out
        if not of_states(args[0]):  # abs, sign, Heaviside (its value at 0 may be anything)
            return []
        kind = "kink" if node.func in ("abs", "Abs") else "jump"
        return [_Found(args[0], label(f"{self.source(node.args[0])}=0"),
                       f"{kind} of {sx.quote(src)} where g = 0 ({where})")]


@dataclass
class SurfaceFinder:
    """Records the switching surfaces of the fields of one namespace.

    Parameters
    ----------
    dynamic
        The symbols that make a condition state-dependent (coordinates, velocities,
        algebraic variables).
    t
        Time.
    file
        The model file (for messages).
    """

    dynamic: frozenset
    t: sp.Symbol
    file: str | None = None
    hints: list[SurfaceHint] = field(default_factory=list)
    #: surfaces the fields built so far can make (counted before sympy builds them)
    potential: int = 0
    _done: set = field(default_factory=set)

    def recorder(self, expr: sx.Expression, where: str) -> Recorder:
        """A :class:`Recorder` for building one field."""
        return Recorder(self, expr, where)

    def seen(self, where: str, text: str) -> bool:
        """Whether the field ``where`` with this text was collected already."""
        return (where, text) in self._done

    def of_states(self, e: sp.Basic) -> bool:
        """Whether ``e`` depends on the states."""
        return bool(e.free_symbols & self.dynamic)

    def collect(self, record: Recorder, names: tuple[str, ...] = ()) -> None:
        """Keep the surfaces of one built field as hints, named by ``names`` if given.

        Raises
        ------
        SpecError
            If ``names`` are given and their number is not the number of surfaces.
        """
        unique = record.surfaces()
        where = record.where
        if names and len(names) != len(unique):
            listed = ", ".join(f"'{u.label}'" for u in unique) or "none"
            raise SpecError(f"{len(names)} surface name{'s' if len(names) != 1 else ''} for "
                            f"{len(unique)} switching surface{'s' if len(unique) != 1 else ''} of the "
                            f"states ({listed})", file=self.file, field=f"{where}.surface")
        key = (where, record.expr.text)
        if key in self._done:  # a field built twice (its hints are there already)
            return
        self._done.add(key)
        owner = owner_of(where)
        for i, u in enumerate(unique):
            name = f"{owner}.{names[i]}" if names else f"{owner}.{u.label}"
            self.hints.append(SurfaceHint(name, u.g, u.meaning, where, bool(names)))


def _relations(cond: sp.Basic) -> list[Relational]:
    out, todo = [], [cond]
    while todo:
        c = todo.pop()
        if isinstance(c, Relational):
            out.append(c)
        elif isinstance(c, sp.logic.boolalg.Boolean):
            todo.extend(c.args)
    return out


def owner_of(where: str) -> str:
    """The element, derived quantity or equation a field path belongs to (``fx`` for
    ``elements.fx.value[1]``; the whole path without indices if it has one part)."""
    parts = re.sub(r"\[[0-9]+\]", "", where).split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def label(text: str) -> str:
    """A condition as a name: no spaces, ``**`` as ``^``, only ``[A-Za-z0-9_.+-*/^()<>=,]``;
    longer than :data:`MAX_LABEL` characters: cut, with a digest of the whole."""
    text = _LABEL_CHARS.sub("", "".join(text.split()).replace("**", "^"))
    while text.startswith("(") and text.endswith(")") and _balanced(text[1:-1]):
        text = text[1:-1]
    if len(text) > MAX_LABEL:
        digest = hashlib.sha256(text.encode()).hexdigest()[:8]
        text = f"{text[:MAX_LABEL - 9]}~{digest}"
    return text


def _balanced(text: str) -> bool:
    depth = 0
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if depth < 0:
            return False
    return depth == 0
