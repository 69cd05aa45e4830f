"""Result objects: trajectories (and their derived views)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from .display import TrajectoryDisplay

if TYPE_CHECKING:  # pragma: no cover
    from .quantities import GearQuantities
    from .system import CompiledSystem


class Event(NamedTuple):
    """A crossing of a switching surface (a contact transition).

    Attributes
    ----------
    t : float
        Time of the crossing, located by the integrator's root finding.
    surface : str
        Name of the switching surface, e.g. ``mesh.drive``.
    direction : int
        ``+1`` if ``g`` went from negative to positive, ``-1`` the other way.
    """

    t: float
    surface: str
    direction: int


@dataclass(frozen=True, repr=False)
class Trajectory(TrajectoryDisplay):
    """A simulated trajectory.

    Units: time and states in coherent SI units (``units`` names each: ``s``, ``m``,
    ``rad/s``; ``1`` for dimensionless variables), parameters in the model's declared units.
    ``repr`` is one line; in Jupyter it shows as a table; :meth:`to_xarray` and
    :meth:`to_dataframe` convert it (:mod:`gearsym.display`).

    Attributes
    ----------
    t : ndarray, shape (n_out,)
        Output times (evenly spaced from the start time to ``t_end``, both included), in the
        model's time unit (``units["t"]``: seconds, or ``1`` for dimensionless time).
    y : ndarray, shape (n_out, n_states)
        States at ``t`` (SI units: ``units[name]``).
    state_names : list of str
        Names of the states, in the order of the columns of ``y``.
    events : list of Event
        Every crossing of a switching surface (contact loss / contact), in order.
    stats : dict
        ``n_steps``, ``n_rhs``, ``n_jac``, ``n_events``, ``n_breaks`` and ``wall_s``
        (wall time of the whole ``simulate`` call, in seconds).
    period : float or None
        The forcing period of the scene at these parameters (time unit).
    params : dict
        Parameter values used, in the model's declared units (bound parameters: SI), as
        :attr:`gearsym.system.CompiledSystem.params`.
    x_final : ndarray
        State at ``t_end``.
    monodromy : ndarray or None
        ``d x(t_end) / d x(t0)`` when requested.
    event_speed : ndarray
        ``dg/dt`` along the flow at each event (near 0: grazing contact).
    sensitivities : dict or None
        Parameter name -> ``d y / d p`` at the output times, shape (n_out, n_states)
        (``simulate(..., sensitivities=[...])``; exact, including the shift of the
        contact events with the parameter; ``x0`` held fixed).
    settings : dict
        The settings the run used, resolved from the call and the scene's ``[simulate]``
        (``t0``, ``t_end``, ``rtol``, ``atol``, ``method``, ``n_out``, ``max_step``,
        ``max_steps``, ``transient_periods``).
    system : CompiledSystem or None
        The compiled system that made the trajectory (for :meth:`gear_quantities`).
    units : dict
        The unit of time ``"t"``, of every state (SI) and of every parameter (declared):
        :meth:`gearsym.system.CompiledSystem.units_table` (empty: unknown).
    inputs : dict
        The parameter overrides the run was given (declared units), among them the inputs of a
        bound function (e.g. ``D`` of ``wm_mean_height(D, ...)``), which :attr:`params` does
        not list: with :attr:`params` they rebuild the run's parameters (its static
        equilibrium, its contact flanks).
    """

    t: np.ndarray
    y: np.ndarray
    state_names: list[str]
    events: list[Event]
    stats: dict
    period: float | None
    params: dict[str, float]
    x_final: np.ndarray
    monodromy: np.ndarray | None = None
    event_speed: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sensitivities: dict[str, np.ndarray] | None = None
    settings: dict = field(default_factory=dict)
    system: CompiledSystem | None = field(default=None, repr=False, compare=False)
    units: dict[str, str] = field(default_factory=dict)
    inputs: dict[str, float] = field(default_factory=dict)

    @property
    def final_state(self) -> np.ndarray:
        """The state at the final time."""
        return self.x_final

    def __getitem__(self, name: str) -> np.ndarray:
        """Time history of one state by name, e.g. ``traj["x"]``."""
        try:
            return self.y[:, self.state_names.index(name)]
        except ValueError:
            raise KeyError(f"no state '{name}' (states: {', '.join(self.state_names)})") from None

    def poincare(self, skip: int = 0) -> np.ndarray:
        """States at the output times that are whole multiples of the forcing period.

        Parameters
        ----------
        skip
            Number of leading periods to drop (transient).

        Returns
        -------
        ndarray, shape (n_points, n_states)
            The Poincare section at ``t = t0 + k*T``.

        Raises
        ------
        ValueError
            The scene has no forcing period.
        """
        if not self.period:
            raise ValueError("the scene has no forcing period")
        k = (self.t - self.t[0]) / self.period
        on = np.abs(k - np.round(k)) < 1e-9 * max(1.0, float(np.max(k)))
        pts = self.y[on]
        return pts[skip:]

    def gear_quantities(self, **options: Any) -> GearQuantities:
        """Per mesh: static and dynamic transmission error, mesh force, dynamic factor, DTE harmonics,
        contact-loss and back-contact ratios, impacts, load sharing, over the steady part of the run
        (:func:`gearsym.quantities.gear_quantities`, where every quantity is defined).

        Parameters
        ----------
        **options
            ``window``, ``steady_fraction``, ``harmonics``, ``mesh_periods``, ``planet_sets`` of
            :func:`~gearsym.quantities.gear_quantities`.

        Returns
        -------
        gearsym.quantities.GearQuantities
        """
        from .errors import ParameterError
        from .quantities import gear_quantities

        if self.system is None:
            raise ParameterError("this trajectory is not attached to a system: use "
                                 "gearsym.quantities.gear_quantities(system, trajectory)")
        return gear_quantities(self.system, self, **options)

    def save_npz(self, path: str | Path) -> None:
        """Write the trajectory to a ``.npz`` file (atomically: a complete file or none).

        Parameters
        ----------
        path
            The file (``.npz``).  It holds ``t``, ``y``, ``state_names``, the events
            (``event_t``, ``event_direction``, ``event_surface``), ``period`` (NaN without
            one) and the parameters (``param_names``, ``param_values``: :attr:`params`, in the
            declared units).
        """
        from .files import save_npz

        ev = np.array([(e.t, e.direction) for e in self.events]).reshape(-1, 2)
        save_npz(
            path, t=self.t, y=self.y, state_names=np.array(self.state_names),
            event_t=ev[:, 0], event_direction=ev[:, 1],
            event_surface=np.array([e.surface for e in self.events]),
            period=np.nan if self.period is None else self.period,
            param_names=np.array(list(self.params)), param_values=np.array(list(self.params.values())),
        )


@dataclass(frozen=True)
class Flow:
    """One integration of the flow map ``phi(t1, t0, x0)``, as the periodic-orbit solvers use it.

    Returned by :meth:`gearsym.system.CompiledSystem.flow` (no output grid, no event objects: the
    cheap path of shooting and continuation).

    Attributes
    ----------
    x_final : ndarray, shape (nx,)
        ``phi(t1, t0, x0)``.
    monodromy : ndarray, shape (nx, nx), or None
        ``d x(t1) / d x0`` with saltation matrices at the events (when requested).
    event_t, event_surface, event_direction, event_speed : ndarray
        The events (times, surface indices, directions +1/-1, ``dg/dt`` along the flow).
    sigma_final : ndarray, shape (nsw,)
        Side of each switching surface at ``t1``.
    amplitude : ndarray, shape (nx,)
        ``max |x_i(t)|`` over the sampled points (``n_samples`` of :meth:`System.flow`).
    stats : dict
        ``n_steps``, ``n_rhs``, ``n_jac``, ``n_events``, ...
    sensitivity : ndarray, shape (nx, n_sens), or None
        ``d phi / d p`` for the requested parameters (:meth:`System.flow`'s
        ``sensitivities``), the total derivative when the span moves with them.
    samples : ndarray, shape (n_samples, nx), or None
        The state at the ``n_samples`` evenly spaced times from ``t0`` to ``t1``.
    """

    x_final: np.ndarray
    monodromy: np.ndarray | None
    event_t: np.ndarray
    event_surface: np.ndarray
    event_direction: np.ndarray
    event_speed: np.ndarray
    sigma_final: np.ndarray
    amplitude: np.ndarray
    stats: dict
    sensitivity: np.ndarray | None = None
    samples: np.ndarray | None = None

