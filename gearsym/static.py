"""Static equilibrium: the state a gear pair rests in under its mean load.

Definition (what ``[initial] static = true`` solves for): the coordinates ``q_s`` at rest
(velocities zero) where the generalised accelerations, averaged over one forcing period
``T``, vanish::

    (1/T) * integral_0^T  a(t, q_s, 0) dt = 0,     a = M(q)^-1 Q(t, q, v)

with every backlash mesh in **drive-side contact** and every other switching surface
on the side the state is on.  For a constant mass matrix this is the balance of the
period-averaged generalised forces: mean loads against mean stiffness.  For the spur
pair ``m x'' + c x' + k(t) f(x - e(t)) = F(t)`` with backlash ``b`` and time functions
of zero mean it is ``x_s = F_mean / k_mean + b``.  (A product of two time functions,
e.g. a varying stiffness times a transmission error, contributes the average of the
product.)  A model without a forcing period is evaluated at ``t = 0``.

The average is a Gauss-Legendre quadrature on the forcing period, split at every
scheduled breakpoint, so piecewise-constant mesh stiffness is averaged exactly.  The
equations are solved by MINPACK's hybrid Powell method (:func:`scipy.optimize.root`)
with the generated Jacobian.  The result is refused (:class:`~gearsym.errors.SpecError`
naming ``initial.static``) when the equilibrium is not determined (a singular mean
stiffness: a rigid-body mode, as in an unreduced pair of free gears) or when a backlash
mesh is not in drive-side contact at it (a mean load that does not press the drive
flanks).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .errors import ConvergenceError, SpecError

if TYPE_CHECKING:  # pragma: no cover
    from .system import System

__all__ = ["period_nodes", "static_state"]

#: Gauss-Legendre points per sub-interval and sub-intervals per forcing period (at least)
_GL_POINTS = 8
_MIN_PIECES = 8
_MAX_NODES = 20_000


def period_nodes(system: System, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes and weights for the average over one forcing period.

    Parameters
    ----------
    system
        The compiled system.
    p
        Its parameter vector.

    Returns
    -------
    t : ndarray
        Nodes in ``[0, T)`` (``[0.0]`` without a forcing period).
    w : ndarray
        Weights summing to 1.
    """
    T = system.period_of(p)
    if not T:
        return np.zeros(1), np.ones(1)
    cuts = {0.0, T}
    for P, fractions in system.schedule_table(p):
        if not (math.isfinite(P) and P > 0) or T / P * (len(fractions) + 1) > _MAX_NODES / _GL_POINTS:
            continue
        for k in range(int(math.ceil(T / P)) + 1):
            for f in (0.0, *fractions):
                c = (k + float(f)) * P
                if 0 < c < T:
                    cuts.add(c)
    edges = np.array(sorted(cuts))
    # at least _MIN_PIECES pieces: trigonometric terms of the forcing frequency are then exact
    fine = np.unique(np.concatenate([edges, np.linspace(0, T, _MIN_PIECES + 1)]))
    x, wx = np.polynomial.legendre.leggauss(_GL_POINTS)
    a, b = fine[:-1, None], fine[1:, None]
    t = (a + (b - a) * (x + 1) / 2).ravel()
    w = ((b - a) / 2 * wx).ravel() / T
    return t, w


def static_state(system: System, coordinates: Sequence[str], velocities: Sequence[str],
                 guess: Sequence[float] | None = None, params: Mapping[str, float] | None = None,
                 where: tuple[str | None, str] = (None, "initial.static")) -> np.ndarray:
    """The static equilibrium state (see the module docstring for the definition).

    Parameters
    ----------
    system
        The compiled system.
    coordinates, velocities
        Names of the coordinate states (solved for) and of their velocities (zero).
    guess
        Full state whose coordinates start the solve (default: the system's ``x0``).
    params
        Parameter overrides (declared units, as every ``params=``).
    where
        ``(file, field)`` named by the errors.

    Returns
    -------
    ndarray
        The full state: coordinates at the static equilibrium, velocities zero, any
        other state as in ``guess``.

    Raises
    ------
    SpecError
        The equilibrium is not determined (singular mean stiffness) or a backlash mesh
        is not in drive-side contact at it.
    ConvergenceError
        The nonlinear solve did not converge.
    """
    from scipy.optimize import root

    gen = system.generated
    names = list(gen.state_names)
    qi = [names.index(n) for n in coordinates]
    vi = [names.index(n) for n in velocities]
    file, fld = where
    x = np.array(system.x0 if guess is None else guess, dtype=float)
    x[vi] = 0.0
    p = system.param_vector(params)
    t, w = period_nodes(system, p)
    n = len(t)
    surfaces = gen.surfaces
    kind = np.array([s["kind"] for s in surfaces], dtype=object)
    sign = np.array([float(s.get("contact_sign", 0)) for s in surfaces])
    forced = np.where(kind == "drive", sign, np.where(kind == "back", -sign, 0.0))
    sched = np.array([system._sched_mode(float(tk), p) for tk in t]).reshape(n, -1).T
    sw = gen.casadi_function("gs_sw").map(n)
    if gen.implicit:
        fres = gen.casadi_function("gs_res").map(n)
        fjac = gen.casadi_function("gs_resjac").map(n)
    else:
        frhs = gen.casadi_function("gs_rhs").map(n)
        fjac = gen.casadi_function("gs_jac").map(n)
    tt = t.reshape(1, n)
    nx = len(names)

    def modes(xx: np.ndarray) -> np.ndarray:
        if not surfaces:
            return sched
        g = np.asarray(sw(tt, xx, p)).reshape(-1, n)
        sigma = np.where(forced[:, None] != 0, forced[:, None], np.where(g >= 0, 1.0, -1.0))
        return np.vstack([sigma, sched]) if sched.size else sigma

    def fun(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xs = x.copy()
        xs[qi] = q
        xx = np.repeat(xs[:, None], n, axis=1)
        m = modes(xx)
        if gen.implicit:
            zero = np.zeros((nx, n))
            r = -np.asarray(fres(tt, xx, zero, p, m)).reshape(nx, n)
            J = -np.asarray(fjac(tt, xx, zero, p, m, 0.0)).reshape(nx, n, nx).transpose(0, 2, 1)
        else:
            r = np.asarray(frhs(tt, xx, p, m)).reshape(nx, n)
            J = np.asarray(fjac(tt, xx, p, m)).reshape(nx, n, nx).transpose(0, 2, 1)
        return r[vi] @ w, (J[np.ix_(vi, qi)] * w).sum(axis=2)

    q0 = x[qi].copy()
    _, J0 = fun(q0)
    s = np.linalg.svd(J0, compute_uv=False) if J0.size else np.zeros(0)
    if s.size and not (s[-1] > 1e-12 * s[0]):
        raise SpecError("the static equilibrium is not determined: the mean stiffness matrix is singular "
                        "(a rigid-body mode? reduce the model to relative coordinates with [reduction])",
                        file=file, field=fld)
    sol = root(fun, q0, jac=True, method="hybr", options={"xtol": 1e-13})
    r, J = fun(sol.x)
    scale = np.abs(J).max(axis=1) * np.maximum(np.abs(sol.x).max(), 1e-300)
    if not (sol.success or np.all(np.abs(r) <= 1e-10 * scale)) or not np.all(np.isfinite(sol.x)):
        raise ConvergenceError(f"the static equilibrium did not converge: {sol.message} (residual "
                               f"{np.abs(r).max():.3g})")
    xs = x.copy()
    xs[qi] = sol.x
    if surfaces:
        g = np.asarray(sw(tt, np.repeat(xs[:, None], n, axis=1), p)).reshape(-1, n) @ w
        for j, s_ in enumerate(surfaces):
            if s_["kind"] == "drive" and not g[j] * sign[j] > 0:
                mesh = s_["name"].rsplit(".", 1)[0]
                raise SpecError(f"no static equilibrium in drive-side contact: at the solution mesh '{mesh}' "
                                f"is not in contact (mean of g[{s_['name']}] = {g[j]:.6g}); the mean load does "
                                f"not press the drive flanks", file=file, field=fld)
    return xs
