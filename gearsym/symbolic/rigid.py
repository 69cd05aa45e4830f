"""Rigid-body modes: coordinate combinations that no element sees.

A combination ``r`` of the coordinates is a rigid-body mode when moving the model along
it (``q -> q + s r``, ``v -> v + s' r``) changes no force: every spring, damper and mesh
deflection is blind to it (``d(delta)/dq . r = 0``), and so is every other
state-dependent expression that enters a force (stiffness, damping, backlash or error
fields that use the states, ``force`` elements, ``[equations]`` forces and masses).  The
modes are the null space of the matrix ``D`` whose rows are the gradients of all these
expressions with respect to the coordinates (and velocities); rows that depend on the
states or on time are sampled at two random states (a coordinate that appears in a row
that stays non-polynomial after that, e.g. inside a state-dependent ``Piecewise``, is
taken as seen: the test is conservative).

For a linear change of coordinates ``x = A q + s(t)`` (a reduction) the modes of the
reduced model are the columns of ``A R``.

The state-space rigid-body subspace of the first-order system ``x = [q; v]`` is
``span{[R; 0], [0; R]}``: invariant under the monodromy (a Jordan block of multipliers
at +1 per mode), which :func:`gearsym.analysis.periodic.floquet` uses to split off the trivial
multipliers.
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Sequence

import numpy as np
import sympy as sp

__all__ = ["mode_dicts", "rigid_body_modes", "transform_modes"]


def _numeric(M: sp.Matrix, values: dict[sp.Symbol, sp.Expr]) -> np.ndarray | None:
    try:
        return np.array(M.xreplace(values).evalf(), dtype=float)
    except (TypeError, ValueError):
        return None


def _random_values(symbols: Iterable[sp.Symbol], seed: int) -> dict[sp.Symbol, sp.Expr]:
    rng = random.Random(seed)
    return {s: sp.Float(rng.uniform(0.6, 1.7)) for s in sorted(symbols, key=str)}


def rigid_body_modes(q: Sequence[sp.Symbol], v: Sequence[sp.Symbol], deflections: Sequence[sp.Expr],
                     force_exprs: Sequence[sp.Expr], masses: Sequence[sp.Expr], t: sp.Symbol) -> sp.Matrix:
    """A basis of the rigid-body modes, one column per mode (``n x k``; ``k`` may be 0).

    Parameters
    ----------
    q, v
        Coordinates and velocities.
    deflections
        Geometric deflections of the spring, damper and mesh elements.
    force_exprs
        Every other expression entering a force that may depend on the states.
    masses
        The diagonal of the mass matrix.
    t
        Time.

    Returns
    -------
    sympy.Matrix
        Columns normalised so that their first non-zero entry is 1.
    """
    n = len(q)
    states = set(q) | set(v)
    rows: list[list[sp.Expr]] = []
    for d in deflections:
        rows.append([sp.diff(d, qi) for qi in q])
    of_velocity = dict(zip(v, q))
    for e in list(force_exprs) + list(masses):
        dep = e.free_symbols & states
        if not dep:
            continue
        if e.has(sp.Piecewise, sp.Abs, sp.sign, sp.Max, sp.Min, sp.Heaviside):
            # a state-dependent switch (e.g. a dynamic backlash): every coordinate it uses is seen
            seen = {of_velocity.get(s, s) for s in dep}
            rows += [[sp.Integer(1) if qi == c else sp.Integer(0) for qi in q] for c in q if c in seen]
            continue
        rows.append([sp.diff(e, qi) for qi in q])
        if e.free_symbols & set(v):
            rows.append([sp.diff(e, vi) for vi in v])
    # rows that depend on the states or on time: sample them; rows with a Piecewise left in them:
    # every coordinate they use counts as seen (conservative)
    dyn = states | {t}

    def indicator(row: list[sp.Expr]) -> list[list[sp.Expr]]:
        return [[sp.Integer(1) if j == i else sp.Integer(0) for j in range(n)] for i, x in enumerate(row)
                if x != 0]

    clean: list[list[sp.Expr]] = []
    for row in rows:
        row = [x if isinstance(x, sp.Basic) else sp.Integer(x) for x in row]
        if not any(x.free_symbols & dyn for x in row):
            clean += indicator(row) if any(x.has(sp.Piecewise) for x in row) else [row]
            continue
        for seed in (1, 2):
            point = _random_values(dyn, seed)
            sampled = [x.xreplace(point) for x in row]
            if any(x.has(sp.Piecewise) or x.free_symbols & dyn for x in sampled):
                clean += indicator(row)
                break
            clean.append(sampled)
    if not clean:
        return sp.eye(n)
    D = sp.Matrix(clean)
    vals = _random_values(D.free_symbols, 7)
    num = _numeric(D, vals)
    if num is None:
        return sp.zeros(n, 0)
    sv = np.linalg.svd(num, compute_uv=False)
    tol = max(num.shape) * np.finfo(float).eps * (sv[0] if sv.size else 1.0) * 1e3
    k = n - int(np.sum(sv > tol))
    if k <= 0:
        return sp.zeros(n, 0)
    # the exact null space on the support of the numerical one (the coordinates a mode moves),
    # from the simplest independent rows: a mesh row of a transverse-torsional pair is long in
    # the translations, but the rotations' null space needs only its rotation entries
    _, _, vt = np.linalg.svd(num)
    N = vt[n - k:].T
    big = np.max(np.abs(N))
    support = [j for j in range(n) if np.max(np.abs(N[j])) > 1e-9 * big]
    DS = D.extract(list(range(D.rows)), support)
    numS = num[:, support]
    order = sorted((i for i in range(D.rows) if np.any(np.abs(numS[i]) > 0)),
                   key=lambda i: sum(sp.count_ops(x) for x in DS.row(i)))
    basis: list[int] = []
    for i in order:
        if len(basis) == len(support) - k:
            break
        if np.linalg.matrix_rank(numS[basis + [i]], tol) > len(basis):
            basis.append(i)
    Db = DS.extract(basis, list(range(len(support)))) if basis else sp.zeros(0, len(support))
    nullS = Db.nullspace(simplify=True) if basis else [sp.eye(len(support))[:, j] for j in range(len(support))]
    null = []
    for vec in nullS:
        full = sp.zeros(n, 1)
        for a, j in enumerate(support):
            full[j] = vec[a]
        null.append(full)
    if len(null) != k:
        return sp.zeros(n, 0)
    cols = []
    for vec in null:
        first = next(x for x in vec if x != 0)
        cols.append(vec.applyfunc(lambda x, first=first: sp.simplify(x / first)))
    return sp.Matrix.hstack(*cols)


def transform_modes(R: sp.Matrix, A: sp.Matrix) -> sp.Matrix:
    """The rigid-body modes ``A R`` of a reduced model (independent columns only, normalised)."""
    if R.cols == 0:
        return sp.zeros(A.rows, 0)
    AR = (A * R).applyfunc(sp.simplify)
    vals = _random_values(AR.free_symbols, 11)
    num = _numeric(AR, vals)
    if num is None:
        return sp.zeros(A.rows, 0)
    keep: list[int] = []
    for j in range(AR.cols):
        if np.linalg.matrix_rank(num[:, keep + [j]], 1e-9 * max(1.0, float(np.max(np.abs(num))))) > len(keep):
            keep.append(j)
    cols = []
    for j in keep:
        vec = AR[:, j]
        first = next(x for x in vec if x != 0)
        cols.append(vec.applyfunc(lambda x, first=first: sp.simplify(x / first)))
    return sp.Matrix.hstack(*cols) if cols else sp.zeros(A.rows, 0)


def mode_dicts(R: sp.Matrix, names: Sequence[str]) -> list[dict[str, sp.Expr]]:
    """``[{coordinate: coefficient}]`` of each mode (zero entries left out)."""
    return [{names[i]: R[i, j] for i in range(R.rows) if R[i, j] != 0} for j in range(R.cols)]
