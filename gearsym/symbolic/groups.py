"""Dimensionless groups of scaled equations: blocks, monomials, Buckingham pi.

Two steps, both local (no global ``simplify``):

* :class:`Normalizer` rewrites an expression ``e`` of dimension ``d`` as
  ``e / scale(d)`` (``scale(d) = M**d_M * L**d_L * T**d_T``, the reference scales), node by node:
  every maximal sub-expression free of the dynamic symbols (states, time, surface
  sides) becomes one *block*, divided by the scale of its own dimension, so every block
  is a dimensionless combination of parameters, and like terms of a sum have their
  blocks added.  The structure of the equation around the blocks is kept as it is.
* :class:`GroupFinder` writes every block in *groups*: each block is split into
  monomials over *atoms* (parameters, named derived quantities, bound functions,
  sums that do not factor); the exponent vectors of the dimensionless monomials are
  spanned by a small set of group vectors chosen greedily, simplest first (each new
  vector is first reduced by the groups already chosen), which is Buckingham's
  construction with the reference scales as repeating variables.  A group with a
  single atom besides those of the scales is named after it (``k_px_hat = k_px/k_m``),
  the others ``Pi1``, ``Pi2``, ...; dimensionless parameters are groups of their own.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from fractions import Fraction

import sympy as sp
from sympy.core.relational import Relational

from .budget import checkpoint
from .dims import ZERO, Dim, DimensionError, Dimensions, add, monomial, scale

Vector = dict[sp.Basic, Fraction]


class Normalizer:
    """Rewrite expressions as ``e / scale(dim e)`` with dimensionless parameter blocks.

    Parameters
    ----------
    dynamic
        Symbols that are not parameters (dimensionless states, time, surface sides,
        schedule indices): everything free of them is a block.
    dims
        Dimensions of sub-expressions.
    base
        The reference scales ``(M, L, T)`` (symbols or expressions).
    """

    def __init__(self, dynamic: Iterable[sp.Symbol], dims: Dimensions, base: tuple[sp.Expr, sp.Expr, sp.Expr]):
        self.dynamic = frozenset(dynamic)
        self.dims = dims
        self.base = base
        #: block symbol -> its (dimensionless) value
        self.blocks: dict[sp.Symbol, sp.Expr] = {}
        self._by_value: dict[sp.Expr, sp.Symbol] = {}

    def block(self, value: sp.Expr) -> sp.Expr:
        """A block symbol standing for ``value`` (numbers stay numbers)."""
        if value.is_Number:
            return value
        sym = self._by_value.get(value)
        if sym is None:
            sym = sp.Dummy(f"B{len(self.blocks)}")
            self.blocks[sym] = value
            self._by_value[value] = sym
        return sym

    def _static(self, e: sp.Basic) -> bool:
        return not (e.free_symbols & self.dynamic)

    def __call__(self, e: sp.Basic) -> sp.Basic:
        """``e / scale(dim e)`` with blocks, like terms collected."""
        return self._collect(self._norm(e))

    def _norm(self, e: sp.Basic) -> sp.Basic:  # noqa: C901 - a flat dispatch
        checkpoint("dimensionless")
        if self._static(e):
            if isinstance(e, (Relational, sp.logic.boolalg.Boolean)) and not isinstance(e, sp.Expr):
                return e
            return self.block(e / monomial(self.dims(e), self.base))
        if e in self.dynamic:
            return e
        if isinstance(e, sp.Add):
            d = self.dims(e)
            static = [a for a in e.args if self._static(a)]
            rest = [self._norm(a) for a in e.args if not self._static(a)]
            if static:
                rest.append(self.block(sp.Add(*static) / monomial(d, self.base)))
            return sp.Add(*rest)
        if isinstance(e, sp.Mul):
            numbers = [a for a in e.args if a.is_Number]
            static = [a for a in e.args if self._static(a) and not a.is_Number]
            rest = [self._norm(a) for a in e.args if not self._static(a)]
            if static:
                s = sp.Mul(*static)
                rest.append(self.block(s / monomial(self.dims(s), self.base)))
            return sp.Mul(*numbers, *rest)
        if isinstance(e, sp.Pow):
            if not self._static(e.exp):
                return e.func(self._norm(e.base), self._norm(e.exp))
            return sp.Pow(self._norm(e.base), e.exp)
        if isinstance(e, sp.Piecewise):
            return sp.Piecewise(*[(self._norm(v), self._norm(c)) for v, c in e.args])
        if isinstance(e, Relational):
            return e.func(self._norm(e.lhs), self._norm(e.rhs))
        if isinstance(e, (sp.And, sp.Or, sp.Not)):
            return e.func(*[self._norm(a) for a in e.args])
        return e.func(*[self._norm(a) for a in e.args])

    def _collect(self, e: sp.Basic) -> sp.Basic:
        """Add the blocks of like terms (terms whose dynamic parts are equal)."""
        if not e.args or self._static(e):
            return e
        args = [self._collect(a) for a in e.args]
        if not isinstance(e, sp.Add):
            return e.func(*args)
        groups: dict[sp.Basic, list[sp.Expr]] = {}
        for a in args:
            coeff, dyn = [], []
            for f in sp.Mul.make_args(a):
                (coeff if (f.is_Number or f in self.blocks) else dyn).append(f)
            key = sp.Mul(*dyn)
            value = sp.Mul(*[self.blocks.get(f, f) for f in coeff])
            groups.setdefault(key, []).append((value, sp.Mul(*coeff)))
        out = []
        for key, items in groups.items():
            if len(items) == 1:
                out.append(items[0][1] * key)
            else:
                out.append(self.block(sp.Add(*[v for v, _ in items])) * key)
        return sp.Add(*out)


class GroupFinder:
    """Express dimensionless parameter expressions in a small set of groups.

    Parameters
    ----------
    dims
        Dimensions of parameters, derived quantities and bound functions.
    identity
        Dimensionless symbols that are groups of their own (dimensionless parameters,
        user-defined groups), in the order they should be listed.
    scale_atoms
        Atoms of the reference scales (groups with a single other atom are named
        after that atom).
    reserved
        Names a generated group must not take.
    """

    def __init__(self, dims: Dimensions, identity: Iterable[sp.Symbol], scale_atoms: Iterable[sp.Basic],
                 reserved: Iterable[str]):
        self.dims = dims
        self.identity = list(dict.fromkeys(identity))
        self.scale_atoms = set(scale_atoms)
        self.reserved = set(reserved)
        self._placeholders: dict[sp.Symbol, Vector] = {}
        self._solved: dict[sp.Symbol, sp.Expr] = {}
        self._names: dict[sp.Basic, str] = {}
        #: echelon basis of the group vectors: (pivot atom, vector, combination of groups)
        self._basis: list[tuple[sp.Basic, Vector, dict[str, Fraction]]] = []
        #: chosen groups: name -> exponent vector over atoms
        self.groups: dict[str, Vector] = {}
        self.symbols: dict[str, sp.Symbol] = {}
        #: monomials that are not dimensionless (a unit inconsistency): placeholder -> vector
        self.leftover: list[Vector] = []

    # ---------------------------------------------------------------- pass 1
    def split(self, e: sp.Basic) -> sp.Basic:
        """``e`` with every monomial over atoms replaced by a placeholder (see :meth:`finish`)."""
        checkpoint("dimensionless")
        if e.is_Number or isinstance(e, sp.logic.boolalg.BooleanAtom):
            return e
        if isinstance(e, sp.Add):
            return sp.Add(*[self.split(a) for a in e.args])
        if isinstance(e, Relational):
            return e.func(self.split(e.lhs), self.split(e.rhs))
        if isinstance(e, (sp.And, sp.Or, sp.Not)):
            return e.func(*[self.split(a) for a in e.args])
        if isinstance(e, sp.Piecewise):
            return sp.Piecewise(*[(self.split(v), self.split(c)) for v, c in e.args])
        vec: Vector = {}
        rest: list[sp.Expr] = []
        self._factors(e, Fraction(1), vec, rest)
        out = sp.Mul(*rest)
        vec = {a: k for a, k in vec.items() if k}
        if vec:
            ph = sp.Dummy("P")
            self._placeholders[ph] = vec
            out = out * ph
        return out

    def _factors(self, e: sp.Basic, k: Fraction, vec: Vector, rest: list[sp.Expr]) -> None:
        for f in sp.Mul.make_args(e):
            base, ex = f.as_base_exp() if isinstance(f, sp.Pow) else (f, sp.Integer(1))
            if not ex.is_Rational:
                rest.append(self._function(f) if f.free_symbols else f)
                continue
            kk = k * Fraction(int(ex.p), int(ex.q))
            if base.is_Number or base in (sp.pi, sp.E):
                rest.append(base ** (sp.Rational(kk.numerator, kk.denominator)))
            elif isinstance(base, sp.Symbol):
                vec[base] = vec.get(base, Fraction(0)) + kk
            elif isinstance(base, sp.Mul):
                self._factors(base, kk, vec, rest)
            elif isinstance(base, sp.Add):
                self._add_factor(base, kk, vec, rest)
            else:
                fb = self._function(base) if self.dims(base) == ZERO else None
                if fb is None:  # a dimensional function (Abs, Max of dimensional values): an atom
                    vec[base] = vec.get(base, Fraction(0)) + kk
                else:
                    rest.append(fb ** sp.Rational(kk.numerator, kk.denominator))

    def _add_factor(self, base: sp.Add, k: Fraction, vec: Vector, rest: list[sp.Expr]) -> None:
        if self.dims(base) == ZERO:
            rest.append(self.split(base) ** sp.Rational(k.numerator, k.denominator))
            return
        common, inner = sp.factor_terms(base).as_independent(sp.Add, as_Add=False) \
            if isinstance(sp.factor_terms(base), sp.Mul) else (sp.Integer(1), sp.factor_terms(base))
        if common != 1:
            self._factors(common, k, vec, rest)
        if not isinstance(inner, sp.Add):
            self._factors(inner, k, vec, rest)
            return
        if self.dims(inner) == ZERO:
            rest.append(self.split(inner) ** sp.Rational(k.numerator, k.denominator))
            return
        if inner.could_extract_minus_sign() and k.denominator == 1:
            inner = -inner
            rest.append(sp.Integer(-1) ** int(k))
        vec[inner] = vec.get(inner, Fraction(0)) + k

    def _function(self, f: sp.Basic) -> sp.Basic:
        return f.func(*[self.split(a) if isinstance(a, sp.Basic) and a.free_symbols else a for a in f.args])

    # ---------------------------------------------------------------- pass 2
    def atom_dims(self, vec: Vector) -> Dim:
        out = ZERO
        for a, k in vec.items():
            out = add(out, scale(self.dims(a), k))
        return out

    def choose(self, user: Mapping[str, Vector] | None = None) -> None:
        """Choose the groups (identity symbols, ``user`` groups, then greedily)."""
        for s in self.identity:
            self._add_group(str(s), {s: Fraction(1)}, s)
        for name, vec in (user or {}).items():
            self._add_group(name, vec, sp.Symbol(name, real=True))
        todo = []
        for vec in self._placeholders.values():
            if self.atom_dims(vec) != ZERO:
                self.leftover.append(vec)
                continue
            todo.append(vec)
        todo.sort(key=lambda v: (len(self._free(v)), len(v), sum(abs(x) for x in v.values()),
                                 sorted(map(self._str, v))))
        for vec in todo:
            if self._solve(vec) is not None:
                continue
            vec = self._reduce(vec)
            free = self._free(vec)
            name = None
            if len(free) == 1 and isinstance(free[0], sp.Symbol):
                a = free[0]
                vec = {b: x / vec[a] for b, x in vec.items()}
                name = self._fresh(f"{a}_hat")
            else:
                if vec and next(iter(sorted(vec.items(), key=lambda kv: self._str(kv[0]))))[1] < 0:
                    vec = {b: -x for b, x in vec.items()}
                name = self._fresh("Pi1")
            self._add_group(name, vec, sp.Symbol(name, real=True))

    def _fresh(self, name: str) -> str:
        if name.startswith("Pi") and name[2:].isdigit():
            k = 1
            while f"Pi{k}" in self.reserved or f"Pi{k}" in self.groups:
                k += 1
            return f"Pi{k}"
        out, k = name, 2
        while out in self.reserved or out in self.groups:
            out = f"{name}{k}"
            k += 1
        return out

    def _str(self, a: sp.Basic) -> str:
        k = self._names.get(a)
        if k is None:
            k = self._names[a] = str(a)
        return k

    def _free(self, vec: Vector) -> list[sp.Basic]:
        return sorted((a for a in vec if a not in self.scale_atoms), key=self._str)

    def _add_group(self, name: str, vec: Vector, sym: sp.Symbol) -> None:
        self.groups[name] = dict(vec)
        self.symbols[name] = sym
        self._basis_add(name, vec)

    def _reduce(self, vec: Vector) -> Vector:
        """Subtract multiples of chosen groups while that makes ``vec`` simpler."""
        def size(v: Vector) -> tuple:
            return (len(self._free(v)), len(v), sum(abs(x) for x in v.values()))

        improved = True
        while improved:
            improved = False
            for g in self.groups.values():
                for a in list(vec):
                    if a not in g or not g[a]:
                        continue
                    c = vec[a] / g[a]
                    # (the atoms in a fixed order, not a set's: the first improvement found is taken)
                    cand = {b: vec.get(b, Fraction(0)) - c * g.get(b, Fraction(0)) for b in dict.fromkeys([*vec, *g])}
                    cand = {b: x for b, x in cand.items() if x}
                    if cand and size(cand) < size(vec):
                        vec = cand
                        improved = True
                        break
                if improved:
                    break
        return vec

    def _solve(self, vec: Vector) -> dict[str, Fraction] | None:
        """Exponents ``c`` with ``vec = sum c_k groups_k`` (``None`` if not in their span)."""
        residual, combo = self._basis_reduce(vec)
        return None if residual else {k: v for k, v in combo.items() if v}

    def _basis_reduce(self, vec: Vector) -> tuple[Vector, dict[str, Fraction]]:
        """``vec`` reduced by the echelon basis of the groups: ``(residual, combination)``."""
        v = dict(vec)
        combo: dict[str, Fraction] = {}
        for pivot, bv, bc in self._basis:
            c = v.get(pivot)
            if not c:
                continue
            for a, x in bv.items():
                y = v.get(a, Fraction(0)) - c * x
                if y:
                    v[a] = y
                else:
                    v.pop(a, None)
            for g, x in bc.items():
                combo[g] = combo.get(g, Fraction(0)) + c * x
        return v, combo

    def _basis_add(self, name: str, vec: Vector) -> None:
        residual, combo = self._basis_reduce(vec)
        if not residual:
            return  # dependent on the groups before it (a user group may be)
        pivot = min(residual, key=self._str)
        k = residual[pivot]
        rv = {a: x / k for a, x in residual.items()}
        rc = {g: -x / k for g, x in combo.items()}
        rc[name] = rc.get(name, Fraction(0)) + 1 / k
        for i, (p, bv, bc) in enumerate(self._basis):
            c = bv.get(pivot)
            if not c:
                continue
            nv = dict(bv)
            for a, x in rv.items():
                y = nv.get(a, Fraction(0)) - c * x
                if y:
                    nv[a] = y
                else:
                    nv.pop(a, None)
            nc = dict(bc)
            for g, x in rc.items():
                nc[g] = nc.get(g, Fraction(0)) - c * x
            self._basis[i] = (p, nv, nc)
        self._basis.append((pivot, rv, rc))

    # ---------------------------------------------------------------- pass 3
    def finish(self, e: sp.Basic) -> sp.Basic:
        """Replace the placeholders of :meth:`split` by products of group symbols."""
        sub = {}
        for ph in e.free_symbols & self._placeholders.keys():
            if ph not in self._solved:
                vec = self._placeholders[ph]
                c = self._solve(vec)
                if c is None:  # not dimensionless: keep the monomial as it is
                    self._solved[ph] = sp.Mul(*[a ** sp.Rational(k.numerator, k.denominator)
                                                for a, k in vec.items()])
                else:
                    self._solved[ph] = sp.Mul(*[self.symbols[n] ** sp.Rational(k.numerator, k.denominator)
                                                for n, k in c.items()])
            sub[ph] = self._solved[ph]
        return e.xreplace(sub)

    def definition(self, name: str, display: Callable[[sp.Basic], sp.Basic] = lambda a: a) -> sp.Expr:
        """The product of atom powers that defines group ``name``."""
        return sp.Mul(*[display(a) ** sp.Rational(k.numerator, k.denominator)
                        for a, k in self.groups[name].items()])


def vector_of(expr: sp.Expr, dims: Dimensions) -> tuple[sp.Expr, Vector] | None:
    """``(coefficient, exponent vector)`` if ``expr`` is a number times a monomial over atoms."""
    gf = GroupFinder(dims, (), (), ())
    vec: Vector = {}
    rest: list[sp.Expr] = []
    try:
        gf._factors(expr, Fraction(1), vec, rest)
    except DimensionError:
        return None
    coeff = sp.Mul(*rest)
    if not coeff.is_Number or gf._placeholders:
        return None
    return coeff, {a: k for a, k in vec.items() if k}
