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
from .budget import MAX_PIECEWISE_CONDITIONS, MAX_STATE_ARGS

#: Calls of the spec language whose kinks or jumps in the states are switching surfaces.
SWITCHING_CALLS = frozenset({"abs", "Abs", "sign", "Heaviside", "Max", "Min", "max", "min"})
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
    _done: set = field(default_factory=set)

    def recorder(self) -> tuple[list, object]:
        """A list and the ``record`` callback of :class:`~gearsym.symbolic.parsing.Builder` that fills it."""
        records: list[tuple[sx.Node, sp.Basic, tuple]] = []

        def record(node: sx.Node, value: sp.Basic, args: tuple) -> None:
            records.append((node, value, args))
        return records, record

    def of_states(self, e: sp.Basic) -> bool:
        return bool(e.free_symbols & self.dynamic)

    def collect(self, expr: sx.Expression, records: list, where: str, names: tuple[str, ...] = ()) -> None:
        """Check the recorded calls of one field and keep its surfaces as hints.

        Raises
        ------
        SpecError
            ``floor`` of a time- or state-dependent argument, a ``Max``/``Min`` or
            ``Piecewise`` with too many state-dependent arguments, or a ``surface`` key
            whose number of names is not the number of surfaces of the term.
        """
        found: list[_Found] = []
        for node, value, args in records:
            found += self._surfaces_of(expr, node, value, args, where)
        unique: list[_Found] = []
        for f in found:  # one surface per distinct function (g and -g are one surface)
            if not any(f.g == u.g or f.g == -u.g for u in unique):
                unique.append(f)
        if names and len(names) != len(unique):
            listed = ", ".join(f"'{u.label}'" for u in unique) or "none"
            raise SpecError(f"{len(names)} surface name{'s' if len(names) != 1 else ''} for "
                            f"{len(unique)} switching surface{'s' if len(unique) != 1 else ''} of the "
                            f"states ({listed})", file=self.file, field=f"{where}.surface")
        key = (where, expr.text)
        if key in self._done:  # a field parsed twice (its hints are there already)
            return
        self._done.add(key)
        owner = owner_of(where)
        for i, u in enumerate(unique):
            name = f"{owner}.{names[i]}" if names else f"{owner}.{u.label}"
            self.hints.append(SurfaceHint(name, u.g, u.meaning, where, bool(names)))

    def _surfaces_of(self, expr: sx.Expression, node: sx.Node, value: sp.Basic, args: tuple,
                     where: str) -> list[_Found]:
        src = expr.text[node.start:node.end]
        if isinstance(node, sx.Compare):
            if not isinstance(value, Relational) or not self.of_states(value):
                return []
            left, right = args
            g = left - right if node.op in (">", ">=") else right - left
            return [_Found(g, label(src), f"{sx.quote(src)} holds where g > 0 ({where})")]
        if isinstance(node, sx.Piecewise):
            conds = [c for _, c in value.args] if isinstance(value, sp.Piecewise) else []
            n = sum(1 for c in conds for r in sp.preorder_traversal(c)
                    if isinstance(r, Relational) and self.of_states(r))
            if n > MAX_PIECEWISE_CONDITIONS:
                raise SpecError(f"Piecewise with {n} conditions on the states (limit {MAX_PIECEWISE_CONDITIONS}: "
                                f"each one is a switching surface)", file=self.file, field=where)
            return []
        assert isinstance(node, sx.Call)
        state_args = [a for a in args if self.of_states(a)]
        if node.func in JUMP_CALLS:
            return self._jump(node, args, src, where)
        if not state_args:
            return []
        func = node.func
        if func in ("Max", "Min", "max", "min"):
            if len(args) > MAX_STATE_ARGS:
                raise SpecError(f"{func}() of the states with {len(args)} arguments (limit {MAX_STATE_ARGS}: "
                                f"every pair of arguments is a switching surface)", file=self.file, field=where)
            out = []
            for i in range(len(args)):
                for j in range(i + 1, len(args)):
                    g = args[i] - args[j]
                    if self.of_states(g):
                        si, sj = (expr.text[a.start:a.end] for a in (node.args[i], node.args[j]))
                        out.append(_Found(g, label(f"{si}={sj}"), f"kink of {sx.quote(src)} where "
                                                                    f"{sx.quote(si, 30)} = {sx.quote(sj, 30)} ({where})"))
            return out
        if not self.of_states(args[0]):  # (the value at 0 of a Heaviside may be anything)
            return []
        arg_src = expr.text[node.args[0].start:node.args[0].end]
        return [_Found(args[0], label(f"{arg_src}=0"), f"{'jump' if func != 'abs' and func != 'Abs' else 'kink'} "
                                                       f"of {sx.quote(src)} where g = 0 ({where})")]

    def _jump(self, node: sx.Call, args: tuple, src: str, where: str) -> list[_Found]:
        arg = args[0]
        if self.of_states(arg):
            raise SpecError(f"{node.func}() of the states ('{sx.quote(src)}') jumps at every integer: it is not "
                            f"a switching surface the integrator can locate (write the jumps the model needs as "
                            f"Piecewise conditions)", file=self.file, field=where)
        if arg.has(self.t):
            raise SpecError(f"{node.func}() of time ('{sx.quote(src)}') jumps at every integer, which the "
                            f"integrator would step across: declare a [schedules] entry and use a "
                            f"piecewise_cycle field (or <schedule>_segment)", file=self.file, field=where)
        return []


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
