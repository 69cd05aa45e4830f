"""Parameter sensitivities of compiled systems: directions, tolerances, period derivative.

The engine integrates ``S = d x(t) / d lambda`` for directions ``D = d p / d lambda`` in
the space of the generated parameter vector (``S' = J S + (df/dp) D``, with the
event-time and breakpoint-time jumps derived in ``gearsym/engine/gs_driver.c``).  This
module turns the names users give (run-time inputs of a :class:`~gearsym.system.System`)
into those directions:

* an input that is a generated parameter contributes its unit vector;
* an input that is an argument of a *bound* parameter (a numeric function of parameters
  evaluated in Python, :mod:`gearsym.bound_functions`, e.g. a fractal mean height)
  contributes ``d bound / d input`` too.  That one derivative is a central finite
  difference of the scalar function (it has no symbolic form); everything else is exact.

No sympy here; the derivatives come from the generated functions (``gs_jacp``,
``gs_swp``, ``gs_schedp``, ``gs_periodp``) of the scene's build with derivatives
(:meth:`gearsym.system.System.derivative_engine`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .bound_functions import evaluate as evaluate_bound
from .errors import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from .system import System

__all__ = ["directions", "period_gradient", "sensitivity_atol"]


def directions(system: System, names: Sequence[str], p: np.ndarray,
               inputs: Mapping[str, float] | None = None) -> np.ndarray:
    """Directions ``d p / d name`` in the generated parameter vector, one column per name.

    ``p`` is SI and ``name`` in its declared unit (the public convention), so a
    sensitivity is per declared unit: ``d x / d b_m`` per micrometre for ``b_m`` in um.

    Parameters
    ----------
    system
        The compiled system.
    names
        Run-time input parameters (:attr:`System.params`).
    p
        The parameter vector (:meth:`System.param_vector`) at which to differentiate.
    inputs
        Overrides of the run-time inputs ``p`` was made with (the arguments of bound
        parameters are inputs that ``p`` does not hold); default: the current values.

    Returns
    -------
    ndarray, shape (np, len(names))

    Raises
    ------
    ParameterError
        A name that is not a run-time input, or a repeated name.
    """
    gen = system.generated
    pnames = list(gen.param_names)
    names = [str(n) for n in names]
    if len(set(names)) != len(names):
        raise ParameterError(f"sensitivities: repeated parameter in {names}")
    # SI values of every input (the public mappings are in declared units, the vector p is SI)
    values = system.units.to_si({**system.params, **{k: float(v) for k, v in (inputs or {}).items()}})
    values.update({k: float(v) for k, v in zip(pnames, p, strict=True)})
    D = np.zeros((len(pnames), len(names)))
    for s, name in enumerate(names):
        if name not in system.params:
            raise ParameterError(f"sensitivities: '{name}' is not a run-time parameter of this system (have: "
                                 f"{', '.join(system.params) or 'none'})")
        # d p_SI / d name: the name's value is in its declared unit (one convention)
        unit = system.units.scale(name)
        if name in pnames and name not in gen.bound:
            D[pnames.index(name), s] = unit
        for bname, (fn, args) in gen.bound.items():
            if name not in args:
                continue
            # the bound function is numeric (no symbolic derivative): central difference
            v = values[name]
            h = 1e-6 * max(abs(v), 1e-12)
            argv = [values[a] for a in args]
            i = args.index(name)
            up, dn = list(argv), list(argv)
            up[i], dn[i] = v + h, v - h
            D[pnames.index(bname), s] += unit * (evaluate_bound(fn, up) - evaluate_bound(fn, dn)) / (2 * h)
    return D


def period_gradient(system: System, p: np.ndarray, D: np.ndarray) -> np.ndarray:
    """``d T / d lambda_s`` of the forcing period along the directions ``D`` (``gs_periodp``).

    Parameters
    ----------
    system
        The compiled system.
    p
        Parameter vector.
    D
        Directions, shape (np, n_sens).

    Returns
    -------
    ndarray, shape (n_sens,)
        Zero where the period does not depend on the parameter (or there is none).
    """
    if not system.generated.param_names:
        return np.zeros(D.shape[1])
    g = system.derivative_engine().period_gradient(np.ascontiguousarray(p, dtype=float))
    g = np.where(np.isfinite(g), g, 0.0)
    return g @ D


def sensitivity_atol(atol: np.ndarray, p: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Absolute tolerances of the sensitivity columns: ``atol_i / |lambda_s|``.

    ``S_is = d x_i / d lambda_s`` times a change of ``lambda_s`` of its own size is a
    change of ``x_i``; its tolerance is therefore ``atol_i / scale_s`` with ``scale_s``
    the magnitude of the parameter (the largest ``|p_k|`` the direction moves; 1 if zero).

    Parameters
    ----------
    atol
        Absolute tolerance of each state, shape (nx,).
    p
        Parameter vector.
    D
        Directions, shape (np, n_sens).

    Returns
    -------
    ndarray, shape (nx * n_sens,)
        Column-major (the engine's layout of ``S``).
    """
    scale = np.array([np.max(np.abs(p[D[:, s] != 0]), initial=0.0) for s in range(D.shape[1])])
    scale = np.where(scale > 0, scale, 1.0)
    return (np.asarray(atol, float)[:, None] / scale[None, :]).T.ravel()
