"""Parameter sensitivities of compiled systems: directions, tolerances, period derivative.

The engine integrates ``S = d x(t) / d lambda`` for directions ``D = d p / d lambda`` in
the space of the generated parameter vector (``S' = J S + (df/dp) D``, with the
event-time and breakpoint-time jumps derived at the top of ``gearsym/engine/gs_driver.c``).  This
module turns the names users give (run-time inputs of a :class:`~gearsym.system.System`)
into those directions:

* an input that is a generated parameter contributes its unit vector;
* an input that is an argument of a *bound* parameter (a numeric function of parameters
  evaluated in Python, :mod:`gearsym.bound_functions`, e.g. a fractal mean height)
  contributes ``d bound / d input`` too.  That one derivative is a central finite
  difference of the scalar function (it has no symbolic form); everything else is exact.

No sympy here; the derivatives come from the generated functions (``gs_jacp``; for
implicit models, integrated by IDA, ``gs_resp`` and ``gs_rest``; ``gs_swp``, ``gs_schedp``,
``gs_periodp``) of the scene's build with derivatives
(:meth:`gearsym.system.System.derivative_engine`).  On a DAE the sensitivities of the
algebraic variables are those of the solution, ``S_z = h_x S_d + h_p D``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .bound_functions import evaluate as evaluate_bound
from .engine.driver import Engine, load_engine
from .errors import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from .system import CompiledSystem as System

__all__ = ["SensitivityMethods", "directions", "period_gradient", "sensitivity_atol"]

#: The generated function that marks a build with the parameter derivatives, by model form
#: (implicit?): d f / d p of the right-hand side, or d F / d p of the residual.
_DERIVATIVE_FN = {False: "gs_jacp", True: "gs_resp"}


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
    values: dict[str, float] = {}
    if gen.bound:
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


class SensitivityMethods:
    """The parameter-sensitivity part of :class:`~gearsym.system.System` (mixed in)."""

    @property
    def has_derivatives(self) -> bool:
        """Whether exact parameter sensitivities are available (a build with the parameter
        derivatives, or one that can be made on demand)."""
        return _DERIVATIVE_FN[bool(self.generated.implicit)] in self.generated.functions or \
            self.derivative_build is not None

    def derivative_engine(self) -> Engine:
        """The engine of the build with the parameter derivatives (made on first use).

        Returns
        -------
        Engine
            This system's own engine if its build has them, else the one of the scene's
            second build (same model and parameter order, ``gs_jacp`` etc. added).

        Raises
        ------
        ParameterError
            A system without a scene to build from.
        """
        if _DERIVATIVE_FN[bool(self.generated.implicit)] in self.generated.functions:
            return self.engine
        if self._derivative_engine is None:
            if self.derivative_build is None:
                raise ParameterError("this system's build has no parameter derivatives; compile the scene "
                                     "with Scene.compile(derivatives=True)")
            gen = self.derivative_build()
            if list(gen.param_names) != list(self.generated.param_names) or gen.nx != self.generated.nx:
                raise ParameterError("the build with parameter derivatives does not match this system")
            self._derivative_engine = load_engine(gen.so_path, sha256=gen.so_sha256 or None,
                                                  build_key=gen.build_key or None)
        return self._derivative_engine

    def _sensitivity_args(self, names: list[str], p: np.ndarray, ax: np.ndarray, mono: bool,
                          atol_mono: np.ndarray | float, scales: np.ndarray | None = None,
                          inputs: Mapping[str, float] | None = None) -> dict:
        """Engine arguments of the sensitivities ``names``: directions and a tolerance vector
        (state, monodromy as :meth:`flow` sets it, then ``atol_i / |p|`` per sensitivity)."""
        if not names:
            raise ParameterError("sensitivities: give at least one parameter name")
        D = directions(self, names, p, inputs)
        nx = self.generated.nx
        nd = nx - len(self.generated.algebraic)  # monodromy columns: the differential states
        parts = [ax]
        if mono:
            sc = np.ones(nx) if scales is None else np.maximum(np.asarray(scales, float), np.finfo(float).tiny)
            am = np.broadcast_to(np.asarray(atol_mono, float), (nx,))
            parts.append((am[:, None] / sc[None, :nd]).T.ravel())
        parts.append(sensitivity_atol(ax, p, D))
        return {"sens_dir": D, "atol_vec": np.concatenate(parts)}

    def period_gradient(self, sensitivities: Sequence[str], p: np.ndarray | None = None,
                        inputs: Mapping[str, float] | None = None) -> np.ndarray:
        """Exact derivatives ``d T / d p`` of the forcing period (generated ``gs_periodp``).

        Parameters
        ----------
        sensitivities
            Run-time parameter names.
        p
            Parameter vector (default: the current values).
        inputs
            The parameter overrides ``p`` was made with (see :meth:`flow`).

        Returns
        -------
        ndarray, shape (len(sensitivities),)
            Zero for parameters the period does not depend on.
        """
        pv = self.param_vector() if p is None else p
        return period_gradient(self, pv, directions(self, list(sensitivities), pv, inputs))

    # ------------------------------------------- generated functions for the analyses
