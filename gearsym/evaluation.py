"""Evaluations of a compiled system's generated functions at given points (part of
:class:`gearsym.system.CompiledSystem`): right-hand side, Jacobian, switching functions, outputs,
modes, mesh deflections and schedules, all by the engine in C (no CasADi call on the
analyses' path), plus a cached CasADi map for what only CasADi has.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .codegen.artifact import decode_schedules, generated_map
from .errors import ParameterError
from .results import Trajectory

if TYPE_CHECKING:  # pragma: no cover
    from .codegen.artifact import GeneratedModel
    from .engine.driver import Engine

__all__ = ["Evaluations"]


class Evaluations:
    """Point evaluations of the generated functions (mixed into :class:`~gearsym.system.CompiledSystem`)."""

    generated: GeneratedModel
    engine: Engine

    def rhs(self, t: float, x: Sequence[float], sigma: Sequence[float] | None = None,
            params: Mapping[str, float] | None = None) -> np.ndarray:
        """Evaluate the right-hand side (explicit models) in a given mode.

        Parameters
        ----------
        t
            Time.
        x
            State.
        sigma
            Side (+1/-1) of each switching surface; by default the sides at ``(t, x)``.
        params
            Parameter overrides (declared units).

        Returns
        -------
        ndarray
            ``dx/dt``.
        """
        return self._eval_one("rhs", t, x, sigma, params)

    def jacobian(self, t: float, x: Sequence[float], sigma: Sequence[float] | None = None,
                 params: Mapping[str, float] | None = None) -> np.ndarray:
        """The generated Jacobian ``df/dx`` (explicit models).

        Parameters
        ----------
        t
            Time.
        x
            State.
        sigma
            Side (+1/-1) of each switching surface; by default the sides at ``(t, x)``.
        params
            Parameter overrides (declared units).

        Returns
        -------
        ndarray, shape (n_states, n_states)
            The Jacobian in that mode.
        """
        return self._eval_one("jac", t, x, sigma, params)

    def _eval_one(self, name: str, t: float, x: Sequence[float], sigma: Sequence[float] | None,
                  params: Mapping[str, float] | None) -> np.ndarray:
        if self.generated.implicit:
            raise ParameterError(f"{name}() needs an explicit model; this one is in implicit (residual) form")
        sg = None if sigma is None else np.asarray(sigma, float).reshape(1, -1)
        return self.engine.evaluate(name, [float(t)], np.asarray(x, float).reshape(1, -1),
                                    self.param_vector(params), sg)[0]

    def switching(self, t: Sequence[float] | float, x: Sequence[float], params: Mapping[str, float] | None = None,
                  p: np.ndarray | None = None) -> np.ndarray:
        """The switching functions ``g(t, x)`` at one or many points (generated C, no CasADi call).

        Parameters
        ----------
        t
            Time(s), shape () or (n,).
        x
            State(s), shape (nx,) or (n, nx).
        params
            Parameter overrides (declared units).
        p
            The parameter vector itself (from :meth:`param_vector`); when given,
            ``params`` is ignored.

        Returns
        -------
        ndarray
            Shape (nsw,) for one point, (n, nsw) for many.
        """
        one = np.ndim(t) == 0
        ta = np.atleast_1d(np.asarray(t, float))
        xa = np.asarray(x, float).reshape(ta.shape[0], self.generated.nx)
        pv = self.param_vector(params) if p is None else p
        g = self.engine.evaluate("sw", ta, xa, pv)
        return g[0] if one else g

    @property
    def output_names(self) -> list[str]:
        """Names of the model's ``[outputs]`` (quantities evaluated along trajectories)."""
        return list(self.generated.outputs)

    def outputs(self, traj: Trajectory) -> dict[str, np.ndarray]:
        """Evaluate the model's ``[outputs]`` along a trajectory.

        Parameters
        ----------
        traj
            A trajectory of this system (its parameters are used).

        Returns
        -------
        dict
            Output name -> array of values at ``traj.t`` (SI units).
        """
        if not self.generated.outputs:
            return {}
        p = self.run_vector(traj.params)
        vals = self.engine.evaluate("out", traj.t, traj.y, p)
        return {name: vals[:, i].copy() for i, name in enumerate(self.generated.outputs)}

    def run_vector(self, run_params: Mapping[str, float]) -> np.ndarray:
        """The parameter vector a run used, from its :attr:`Trajectory.params`.

        A run's parameters are the entries of the parameter vector (:meth:`param_dict`: every
        name of ``generated.param_names`` in declared units, a bound function's value in SI),
        not the scene's parameters: a bound function's inputs (e.g. ``D`` of
        ``wm_mean_height(D, ...)``) are not among them, so rebuilding the vector through
        :meth:`param_vector` would evaluate the function at the system's own inputs instead
        of the run's.  A mapping without every entry falls back to :meth:`param_vector` of
        its run-time parameters.

        Parameters
        ----------
        run_params
            ``Trajectory.params`` of a run of this system.

        Returns
        -------
        ndarray
            The parameter vector (SI), in the order of ``generated.param_names``.
        """
        names = list(self.generated.param_names)
        if all(n in run_params for n in names):
            si = self.units.to_si({n: run_params[n] for n in names})
            return np.array([si[n] for n in names], dtype=float)
        return self.param_vector({k: v for k, v in run_params.items() if k in self.params})

    def _sched_mode(self, t: float, p: np.ndarray) -> np.ndarray:
        """Schedule part of the mode vector at time ``t``: ``[n_0, seg_0, n_1, seg_1, ...]``."""
        m = self.engine.evaluate("mode", [float(t)], np.zeros((1, self.generated.nx)), p)[0]
        return m[self.generated.nsw:].copy()

    # -------------------------------------------------------------- simulate

    def contact_modes(self, t: Sequence[float] | float, x: Sequence[float], p: np.ndarray | None = None) -> np.ndarray:
        """The contact mode vector (surface sides, then each schedule's cycle and segment) at many points.

        The *modes of the hybrid system* (which side of each contact surface, which segment of
        each schedule), not its natural (vibration) modes: those are
        :meth:`gearsym.System.natural_modes` (``gearsym modes``).

        Evaluated by the engine in C (the driver's own mode logic), so the analyses never
        decode the schedules themselves.

        Parameters
        ----------
        t
            Times, shape (n,).
        x
            States, shape (n, nx).
        p
            Parameter vector (:meth:`param_vector`); the current values when ``None``.

        Returns
        -------
        ndarray
            Shape (n, nm): ``[sigma_0, ..., sigma_{nsw-1}, n_0, seg_0, n_1, seg_1, ...]``.
        """
        ta = np.atleast_1d(np.asarray(t, float))
        pv = self.param_vector() if p is None else p
        return self.engine.evaluate("mode", ta, np.asarray(x, float).reshape(ta.shape[0], self.generated.nx), pv)

    def modes(self, t: Sequence[float] | float, x: Sequence[float], p: np.ndarray | None = None) -> np.ndarray:
        """Alias of :meth:`contact_modes` (the older name; natural modes: :meth:`gearsym.System.natural_modes`).

        Parameters
        ----------
        t, x, p
            As for :meth:`contact_modes`.

        Returns
        -------
        ndarray
        """
        return self.contact_modes(t, x, p)

    def mesh_deflections(self, t: Sequence[float] | float, x: Sequence[float],
                         p: np.ndarray | None = None) -> np.ndarray:
        """Dynamic deflection (deflection - error) of every mesh at many points (generated C).

        Parameters
        ----------
        t
            Times, shape (n,).
        x
            States, shape (n, nx).
        p
            Parameter vector (:meth:`param_vector`); the current values when ``None``.

        Returns
        -------
        ndarray
            Shape (n, number of meshes), in the model's order (``generated.meshes``); the
            mode at each point from the signs of the switching functions, as the driver's.
        """
        ta = np.atleast_1d(np.asarray(t, float))
        if not getattr(self.generated, "meshes", None):
            return np.empty((ta.shape[0], 0))
        pv = self.param_vector() if p is None else p
        return self.engine.evaluate("mesh", ta, np.asarray(x, float).reshape(ta.shape[0], self.generated.nx), pv)

    def schedule_table(self, p: np.ndarray | None = None) -> list[tuple[float, np.ndarray]]:
        """``(period, break fractions)`` of every schedule at a parameter vector.

        Parameters
        ----------
        p
            Parameter vector (:meth:`param_vector`); the current values when ``None``.

        Returns
        -------
        list of (float, ndarray)
            One entry per schedule, in model order (empty without schedules).
        """
        if not self.generated.schedules:
            return []
        pv = self.param_vector() if p is None else p
        return decode_schedules(generated_map(self.generated, "gs_sched", 1)(pv), self.generated.schedules)

    def generated_map(self, name: str, n: int):
        """The generated CasADi function ``name`` mapped over ``n`` points (cached).

        For what the engine does not evaluate in C: the analysis extras (``gs_mesh``,
        ``gs_rigid``) and evaluations vectorised over many parameter vectors.

        Parameters
        ----------
        name
            ``"gs_mesh"``, ``"gs_rigid"``, ``"gs_jac"``, ...
        n
            Number of points (columns).

        Returns
        -------
        casadi.Function
        """
        return generated_map(self.generated, name, n)

    # --------------------------------------------------------- periodic orbits
