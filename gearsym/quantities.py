r"""Gear quantities: what gear papers report, per mesh, from a trajectory or a periodic orbit.

Every quantity is defined here once; :meth:`gearsym.Trajectory.gear_quantities`,
:meth:`gearsym.PeriodicOrbit.gear_quantities`, the points of a continuation branch
(:meth:`gearsym.Branch.gear_quantities`), the maps and the command line (``simulate
--gear-quantities``, ``orbit --json``, ``continue --quantity``, ``map --quantity``) all call
:func:`gear_quantities`.

**What is measured.**  For every mesh element (``mesh``, ``gear_mesh``), along the trajectory
``x(t)``:

* the mesh deflection :math:`\delta(t) = \delta(t, x(t))` (deflection minus error, the
  generated ``gs_mesh``) and the mesh force :math:`W(t) = k(t) f(\delta) + c(t) \dot\delta`
  along the line of action (``gs_mesh_force``: elastic force through the backlash dead zone
  ``f`` plus the mesh damping force; positive when the drive side of a ``drive_side =
  "positive"`` mesh is loaded);
* at the **static equilibrium** :math:`x_s` under the mean loads
  (:func:`gearsym.static.static_equilibrium`, rigid-body directions kept at the scene's
  state, the same state ``gearsym modes`` linearises about): the static deflection
  :math:`\delta_s(t) = \delta(t, x_s)` and force :math:`W_s(t) = W(t, x_s)` in the static
  contact state.

**The window.**  Over a trajectory, the steady part: the last whole forcing periods of the
run after the scene's ``transient_periods`` (when the run is longer), else of its second half
(``steady_fraction`` or an explicit ``window`` choose otherwise); over a periodic orbit, one
period of the orbit.  The window must start on an output sample and the samples in it must
be evenly spaced (the default grid of a run of whole forcing periods is); the ``m`` samples
:math:`t_0 \dots t_{m-1}` of the window (its end excluded) are what the mean, RMS, extrema
and DFT below use, so they are exact for a periodic response whose harmonics lie below the
Nyquist order of the grid.  Contact ratios and impacts are taken from the engine's located
events in ``[t_start, t_end)`` and are exact (no sampling).

**Definitions** (:math:`\langle \cdot \rangle`: mean over the window samples; :math:`\bar{\cdot}`
over one forcing period at the static state, by the Gauss-Legendre nodes of the static
equilibrium, exact for piecewise-constant stiffness):

=============================  ==================================================================
``static_deflection``          static transmission error under the mean load,
                               :math:`\bar\delta_s = \overline{\delta(t, x_s)}`
``static_force``               the mean load of the mesh, :math:`\bar W_s = \overline{W(t, x_s)}`
``dte_mean``, ``dte_rms``      of the dynamic transmission error relative to the static one,
                               :math:`e(t) = \delta(t, x(t)) - \delta(t, x_s)`:
                               :math:`\langle e \rangle`, :math:`\sqrt{\langle e^2 \rangle}`
                               (RMS about the static deflection; the RMS of the alternating part
                               is :math:`\sqrt{\mathrm{rms}^2 - \mathrm{mean}^2}`)
``dte_peak_to_peak``           :math:`\max e - \min e` over the samples
``dte_harmonic_<h>``           amplitude of mesh order ``h`` of ``e``: :math:`A_h = 2 |E_{h K}| / m`,
                               :math:`E_k = \sum_j e(t_j) \exp(-2\pi i jk/m)` (numpy's FFT), ``K``
                               mesh periods in the window; NaN when :math:`hK \ge m/2` (the grid
                               does not resolve that order)
``force_mean``, ``force_rms``  :math:`\langle W \rangle`, :math:`\sqrt{\langle W^2 \rangle}`
``force_min``, ``force_max``   extrema of :math:`W` over the samples
``dynamic_factor``             peak dynamic over static mesh force,
                               :math:`\max_j W(t_j) / \bar W_s` (pointwise ratio: for a mesh
                               loaded on its negative side, the most negative force over the
                               negative static force)
``dynamic_factor_rms``         :math:`\sqrt{\langle W^2 \rangle} / |\bar W_s|`
``contact_loss_ratio``         fraction of the window with the drive flank open (drive surface
                               on its no-contact side), from the side at ``t_start`` and the
                               event times of ``NAME.drive``
``back_contact_ratio``         fraction of the window with the back flank closed (``NAME.back``)
``impact_count``               contact-closing events (drive or back surface crossed into
                               contact) in the window
``impacts_per_period``         ``impact_count`` per forcing period
``impact_velocity_max``        the largest impact velocity; the impact velocity of an event is
                               :math:`|\mathrm{d}g/\mathrm{d}t|` of its surface at the event
                               (the engine's event speed: the closing speed of the flanks,
                               :math:`|\dot\delta|` for a constant backlash)
``load_sharing_factor``        for a planet's mesh: :math:`\max_j W_n(t_j) / (\frac1N \sum_m
                               \langle W_m \rangle)`, ``N`` the meshes of its planet set
=============================  ==================================================================

Contact ratios, impacts are ``None`` for a mesh without backlash (no contact surfaces), the
load-sharing factor for a mesh in no planet set; a ratio to a static force that is exactly
zero is NaN.

**Mesh order.**  Order 1 of a mesh is its mesh frequency :math:`1/T_m`.  :math:`T_m` is,
in this order: the caller's ``mesh_periods[NAME]``; the period of the schedule named like
the mesh (``[schedules.NAME]``, e.g. the rectangular stiffness of ``two_stage_train``'s
``mesh1``); else the forcing period (every shipped single-mesh model and the planetary sets
are forced at their mesh frequency).  A model whose forcing period spans several mesh
cycles without a schedule (``liu_nfg``: Z2 mesh cycles per forcing period) needs
``mesh_periods``.  The window must hold a whole number of mesh periods.

**Planet sets.**  Meshes named ``<prefix><n>``, ``n = 1 .. N`` (``N >= 2``), form the set
``<prefix>`` when another prefix has the same numbers: a planet meshes with the sun and the
ring (``sp1 .. spN``, ``rp1 .. rpN`` of ``models/planetary_n*.toml``).  A gear train's
``mesh1``, ``mesh2`` in series is no set.  ``planet_sets`` names the sets explicitly.

**Units.**  Deflections, forces and times in the units of the states and of the generated
mesh functions: SI (m, N, s; rad and N*m for a torsional deflection) for a dimensional
model, the model's own scaled units for a dimensionless one (``kahraman_singh``); impact
velocities in deflection unit per time unit; factors and ratios dimensionless.
"""

from __future__ import annotations

import logging
import math
import re
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .codegen.artifact import generated_map
from .display import GearQuantitiesDisplay, MeshQuantitiesDisplay
from .errors import GearsymError, ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from .results import Trajectory
    from .system import CompiledSystem as System

_log = logging.getLogger(__name__)

__all__ = ["QUANTITIES", "GearQuantities", "MeshQuantities", "branch_quantities", "gear_quantities", "map_quantities",
           "mesh_order_periods", "orbit_gear_quantities", "orbit_quantities", "parse_quantity", "periodic_quantities",
           "planet_sets", "planet_sets_of"]

#: The scalar quantities of a mesh: name -> (unit, meaning); ``dte_harmonic_<h>`` (mesh order
#: ``h``) besides.  Units: ``deflection`` / ``force`` / ``velocity`` of the mesh (module docstring).
QUANTITIES: dict[str, tuple[str, str]] = {
    "static_deflection": ("deflection", "static transmission error under the mean load (mesh deflection at the "
                                        "static equilibrium, mean over the forcing period)"),
    "static_force": ("force", "mean mesh force at the static equilibrium (the mean load of the mesh)"),
    "dte_mean": ("deflection", "mean of the dynamic transmission error (dynamic minus static deflection)"),
    "dte_rms": ("deflection", "RMS of the dynamic transmission error (about the static deflection)"),
    "dte_peak_to_peak": ("deflection", "peak-to-peak of the dynamic transmission error"),
    "force_mean": ("force", "mean mesh force"),
    "force_rms": ("force", "RMS of the mesh force"),
    "force_min": ("force", "smallest mesh force"),
    "force_max": ("force", "largest mesh force"),
    "dynamic_factor": ("1", "peak dynamic mesh force over the static mesh force"),
    "dynamic_factor_rms": ("1", "RMS dynamic mesh force over the static mesh force"),
    "contact_loss_ratio": ("1", "fraction of the time with the drive flank open"),
    "back_contact_ratio": ("1", "fraction of the time with the back flank in contact"),
    "impact_count": ("1", "contact-closing events (drive or back flank) in the window"),
    "impacts_per_period": ("1", "contact-closing events per forcing period"),
    "impact_velocity_max": ("velocity", "largest closing speed of the flanks at an impact"),
    "load_sharing_factor": ("1", "largest mesh force of a planet over the mean of its set's mean forces"),
}
#: Harmonic amplitudes of the DTE reported by default (mesh orders 1 .. this).
HARMONICS = 5
_HARMONIC = re.compile(r"dte_harmonic_([1-9][0-9]*)")
_QUANTITY = re.compile(r"([a-z_0-9]+)(?:\[([^\]]+)\])?")
#: a window end or an output time within this fraction of the sample step is on the grid
_GRID_TOL = 1e-6


def map_quantities() -> dict[str, tuple[str, str]]:
    """The gear quantities a map can show (the scalar ones of :data:`gearsym.spec.settings.MAP_QUANTITIES`).

    Returns
    -------
    dict
        Name -> ``(unit, meaning)`` as :data:`QUANTITIES`.
    """
    from .spec.settings import MAP_QUANTITIES

    out = {}
    for name in MAP_QUANTITIES:
        h = _HARMONIC.fullmatch(name)
        if name in QUANTITIES:
            out[name] = QUANTITIES[name]
        elif h:
            out[name] = ("deflection", f"amplitude of mesh order {h.group(1)} of the dynamic transmission error")
    return out


def parse_quantity(name: str) -> tuple[str, str | None]:
    """Split ``"dynamic_factor[sp1]"`` into ``("dynamic_factor", "sp1")`` and check the name.

    Parameters
    ----------
    name
        A quantity of :data:`QUANTITIES` or ``dte_harmonic_<h>``, optionally with a mesh in
        brackets.

    Returns
    -------
    tuple
        ``(quantity, mesh or None)``.

    Raises
    ------
    ParameterError
        An unknown quantity (the known ones named).
    """
    m = _QUANTITY.fullmatch(str(name).strip())
    base = m.group(1) if m else str(name)
    if m is None or not (base in QUANTITIES or _HARMONIC.fullmatch(base)):
        raise ParameterError(f"unknown gear quantity '{name}' (have: {', '.join(QUANTITIES)}, dte_harmonic_<h>; "
                             f"a mesh in brackets, e.g. dynamic_factor[mesh])")
    return base, m.group(2)


@dataclass(frozen=True, repr=False)
class MeshQuantities(MeshQuantitiesDisplay):
    """The gear quantities of one mesh over one window (definitions: :mod:`gearsym.quantities`).

    Attributes
    ----------
    name : str
        The mesh element.
    mesh_period : float
        The period of mesh order 1 (time unit).
    static_deflection, static_force : float
        At the static equilibrium (NaN when it could not be found: see ``GearQuantities.notes``).
    dte_mean, dte_rms, dte_peak_to_peak : float
        Of the dynamic transmission error relative to the static deflection.
    dte_harmonics : ndarray
        Amplitudes of mesh orders ``1 .. len(dte_harmonics)`` of the DTE (NaN above the grid's
        Nyquist order).
    force_mean, force_rms, force_min, force_max : float
        Of the mesh force (NaN when the model's mesh forces are not generated).
    dynamic_factor, dynamic_factor_rms : float
        Peak and RMS dynamic over static mesh force.
    contact_loss_ratio, back_contact_ratio : float or None
        Fractions of the window with the drive flank open / the back flank closed (``None``
        without backlash).
    impact_times : ndarray
        Times of the contact-closing events in the window.
    impact_velocities : ndarray
        Closing speed ``|dg/dt|`` at each of them.
    impact_flanks : list of str
        ``"drive"`` or ``"back"`` for each of them.
    impacts_per_period : float or None
        Impacts per forcing period (``None`` without backlash).
    load_sharing_factor : float or None
        For a mesh of a planet set (``None`` otherwise).
    planet_set : str or None
        The set the mesh belongs to.
    """

    name: str
    mesh_period: float
    static_deflection: float
    static_force: float
    dte_mean: float
    dte_rms: float
    dte_peak_to_peak: float
    dte_harmonics: np.ndarray
    force_mean: float
    force_rms: float
    force_min: float
    force_max: float
    dynamic_factor: float
    dynamic_factor_rms: float
    contact_loss_ratio: float | None
    back_contact_ratio: float | None
    impact_times: np.ndarray
    impact_velocities: np.ndarray
    impact_flanks: list[str]
    impacts_per_period: float | None
    load_sharing_factor: float | None = None
    planet_set: str | None = None

    @property
    def impact_count(self) -> int | None:
        """Number of contact-closing events in the window (``None`` without backlash)."""
        return None if self.contact_loss_ratio is None else int(len(self.impact_times))

    @property
    def impact_velocity_max(self) -> float | None:
        """The largest impact velocity (0 without impacts, ``None`` without backlash)."""
        if self.contact_loss_ratio is None:
            return None
        return float(np.max(self.impact_velocities)) if len(self.impact_velocities) else 0.0

    def value(self, name: str) -> float:
        """One scalar quantity by name (``None`` values as NaN).

        Parameters
        ----------
        name
            A key of :data:`QUANTITIES` or ``dte_harmonic_<h>``.

        Returns
        -------
        float
        """
        base, _ = parse_quantity(name)
        h = _HARMONIC.fullmatch(base)
        if h:
            k = int(h.group(1))
            return float(self.dte_harmonics[k - 1]) if k <= len(self.dte_harmonics) else math.nan
        v = getattr(self, base)
        return math.nan if v is None else float(v)

    def to_dict(self, events: bool = True) -> dict[str, Any]:
        """JSON-ready dictionary (``None`` for what does not apply).

        Parameters
        ----------
        events
            Include the impact times, velocities and flanks (lists).

        Returns
        -------
        dict
        """
        d: dict[str, Any] = {"mesh_period": _num(self.mesh_period)}
        for k in QUANTITIES:
            v = getattr(self, k)
            d[k] = None if v is None else (int(v) if k == "impact_count" else _num(v))
        d["dte_harmonics"] = [_num(v) for v in self.dte_harmonics]
        d["planet_set"] = self.planet_set
        if events:
            d["impact_times"] = [float(v) for v in self.impact_times]
            d["impact_velocities"] = [float(v) for v in self.impact_velocities]
            d["impact_flanks"] = list(self.impact_flanks)
        return d


@dataclass(frozen=True, repr=False)
class GearQuantities(GearQuantitiesDisplay):
    """The gear quantities of every mesh over one window (:func:`gear_quantities`).

    ``repr`` is one line; in Jupyter a table (quantity x mesh); ``to_dataframe()`` one row per
    mesh, ``to_xarray()`` a dataset on ``mesh`` (:mod:`gearsym.display`).

    Attributes
    ----------
    meshes : dict
        Mesh name -> :class:`MeshQuantities`, in model order.
    t_start, t_end : float
        The window.
    periods : float
        Forcing periods in the window.
    samples : int
        Output samples in the window (its end excluded).
    static_state : ndarray or None
        The static equilibrium the static quantities are taken at.
    planet_sets : dict
        Set name -> its meshes, in planet order.
    notes : list of str
        What could not be computed and why (e.g. no static equilibrium).
    """

    meshes: dict[str, MeshQuantities]
    t_start: float
    t_end: float
    periods: float
    samples: int
    static_state: np.ndarray | None = None
    planet_sets: dict[str, list[str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    _table = QUANTITIES  # (a class attribute, no field: what the display converts)

    def __getitem__(self, mesh: str) -> MeshQuantities:
        """The quantities of one mesh, e.g. ``gq["mesh"]``."""
        try:
            return self.meshes[mesh]
        except KeyError:
            raise KeyError(f"no mesh '{mesh}' (meshes: {', '.join(self.meshes)})") from None

    def value(self, name: str, mesh: str | None = None) -> float:
        """One scalar quantity: of one mesh, else of the only mesh, else the largest over the meshes.

        Parameters
        ----------
        name
            A key of :data:`QUANTITIES` or ``dte_harmonic_<h>``, optionally with the mesh in
            brackets (``"dynamic_factor[sp1]"``).
        mesh
            The mesh (default: from ``name``; with neither, the largest value over the meshes
            where it applies: the worst mesh for a factor, a ratio or an amplitude).

        Returns
        -------
        float
            NaN where the quantity applies to no mesh.
        """
        base, in_name = parse_quantity(name)
        mesh = mesh or in_name
        if mesh is not None:
            return self[mesh].value(base)
        vals = [v for v in (m.value(base) for m in self.meshes.values()) if not math.isnan(v)]
        return max(vals) if vals else math.nan

    def to_dict(self, events: bool = True) -> dict[str, Any]:
        """JSON-ready dictionary: the window, the notes and each mesh's :meth:`MeshQuantities.to_dict`.

        Parameters
        ----------
        events
            Include each mesh's impact times and velocities.

        Returns
        -------
        dict
        """
        return {"t_start": float(self.t_start), "t_end": float(self.t_end), "periods": float(self.periods),
                "samples": int(self.samples), "planet_sets": {k: list(v) for k, v in self.planet_sets.items()},
                "notes": list(self.notes),
                "meshes": {k: m.to_dict(events) for k, m in self.meshes.items()}}


def _num(v: float) -> float | None:
    """A float for JSON (NaN as ``None``)."""
    v = float(v)
    return None if math.isnan(v) else v


# ------------------------------------------------------------------ the entry point
def gear_quantities(system: System, trajectory: Trajectory, *, window: tuple[float, float] | None = None,
                    steady_fraction: float | None = None, harmonics: int = HARMONICS,
                    mesh_periods: Mapping[str, float] | None = None,
                    planet_sets: Mapping[str, Sequence[str]] | None = None) -> GearQuantities:
    """The gear quantities of every mesh over the steady part of a trajectory (module docstring).

    Parameters
    ----------
    system
        The compiled system the trajectory came from.
    trajectory
        A :class:`~gearsym.results.Trajectory` (its parameters are used).
    window
        ``(t_start, t_end)`` explicitly (default: the steady part, whole forcing periods ending
        at the last output time).
    steady_fraction
        The fraction of the run, at its end, that is steady (rounded down to whole forcing
        periods); default: after the scene's ``transient_periods`` when the run is longer,
        else one half.
    harmonics
        Mesh orders of the DTE reported (``1 .. harmonics``).
    mesh_periods
        Mesh name -> its mesh period (time unit), overriding the rule of the module docstring.
    planet_sets
        Set name -> its meshes in planet order, overriding the naming rule.

    Returns
    -------
    GearQuantities

    Raises
    ------
    ParameterError
        No mesh in the model, no forcing period, a window that is not on the output grid or
        not a whole number of mesh periods, an unknown mesh name.
    """
    names = list(getattr(system.generated, "meshes", []) or [])
    if not names:
        raise ParameterError(f"model '{system.generated.scene}' has no mesh elements: no gear quantities")
    if int(harmonics) != harmonics or harmonics < 0:
        raise ParameterError(f"harmonics must be a whole number >= 0, got {harmonics}")
    T = trajectory.period
    if not T:
        raise ParameterError("gear quantities need a forcing period (the steady window is whole periods)")
    ts, te = _window(trajectory, window, steady_fraction, T)
    k0, k1 = _grid_indices(trajectory.t, ts, te)
    t, Y = trajectory.t[k0:k1], trajectory.y[k0:k1]
    # the run's parameters: its vector as run (a bound function's value included) and, for the
    # static equilibrium, its overrides with the inputs of bound functions
    params = {k: v for k, v in trajectory.params.items() if k in system.params} | dict(trajectory.inputs)
    p = system.run_vector(trajectory.params)
    notes: list[str] = []
    D = system.mesh_deflections(t, Y, p)
    W = _forces(system, t, Y, p, None, notes)
    static = _static(system, params, p, t, notes)
    periods = mesh_order_periods(system, p, names, T, mesh_periods)
    contact = _contact(system, trajectory, p, Y[0], ts, te)
    sets = dict(planet_sets) if planet_sets is not None else planet_sets_of(names)
    unknown = [m for s in sets.values() for m in s if m not in names]
    if unknown:
        raise ParameterError(f"planet_sets: no mesh '{unknown[0]}' (meshes: {', '.join(names)})")
    out: dict[str, MeshQuantities] = {}
    for i, name in enumerate(names):
        out[name] = _mesh(name, i, D, W, static, periods[name], te - ts, int(harmonics), contact.get(name), T)
    out = _load_sharing(out, W, names, sets)
    return GearQuantities(meshes=out, t_start=ts, t_end=te, periods=(te - ts) / T, samples=len(t),
                          static_state=None if static is None else static[0],
                          planet_sets={k: list(v) for k, v in sets.items()}, notes=notes)


def planet_sets(system: System) -> dict[str, list[str]]:
    """The planet sets of a model by the naming rule (module docstring).

    Parameters
    ----------
    system
        The compiled system.

    Returns
    -------
    dict
        Set name (the prefix) -> its meshes in planet order (empty for a model without planets).
    """
    return planet_sets_of(list(getattr(system.generated, "meshes", []) or []))


def planet_sets_of(names: Sequence[str]) -> dict[str, list[str]]:
    """:func:`planet_sets` from the mesh names."""
    groups: dict[str, dict[int, str]] = {}
    for name in names:
        m = re.fullmatch(r"(.*\D)(\d+)", name)
        if m:
            groups.setdefault(m.group(1), {})[int(m.group(2))] = name
    numbered = {k: v for k, v in groups.items() if len(v) >= 2 and sorted(v) == list(range(1, len(v) + 1))}
    return {k: [v[n] for n in sorted(v)] for k, v in numbered.items()
            if any(o != k and set(w) == set(v) for o, w in numbered.items())}


# ------------------------------------------------------------------ the window
def _window(traj: Trajectory, window: tuple[float, float] | None, steady_fraction: float | None,
            T: float) -> tuple[float, float]:
    """The window ``(t_start, t_end)``: the caller's, else whole forcing periods ending at the end."""
    t0, t1 = float(traj.t[0]), float(traj.t[-1])
    if window is not None:
        ts, te = float(window[0]), float(window[1])
        if not (t0 - _GRID_TOL * T <= ts < te <= t1 + _GRID_TOL * T):
            raise ParameterError(f"window ({ts:g}, {te:g}) must be an interval inside the run [{t0:g}, {t1:g}]")
        return ts, te
    if steady_fraction is not None:
        if not (0.0 < float(steady_fraction) <= 1.0):
            raise ParameterError(f"steady_fraction must be in (0, 1], got {steady_fraction}")
        span = float(steady_fraction) * (t1 - t0)
    else:
        tp = traj.settings.get("transient_periods")
        span = t1 - t0 - float(tp) * T if tp and t1 - t0 > float(tp) * T * (1 + 1e-9) else 0.5 * (t1 - t0)
    n = math.floor(span / T + 1e-9)
    if n < 1:
        raise ParameterError(f"the run ({(t1 - t0) / T:.3g} forcing periods) has no whole forcing period in its "
                             f"steady part: simulate more periods")
    return t1 - n * T, t1


def _grid_indices(t: np.ndarray, ts: float, te: float) -> tuple[int, int]:
    """Indices of the window's first sample and of its end sample (excluded), on an even grid."""
    h = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    k0 = int(np.argmin(np.abs(t - ts)))
    k1 = int(np.argmin(np.abs(t - te)))
    if h <= 0 or abs(t[k0] - ts) > _GRID_TOL * h or abs(t[k1] - te) > _GRID_TOL * h or k1 - k0 < 2:
        raise ParameterError(f"the window [{ts:.12g}, {te:.12g}] does not start and end on output samples: "
                             "for gear quantities simulate a whole number of forcing periods (periods= or --periods) on the default output grid")
    d = np.diff(t[k0:k1 + 1])
    if np.max(np.abs(d - h)) > _GRID_TOL * h:
        raise ParameterError("the output samples in the window are not evenly spaced: gear quantities need the "
                             "even grid of n_out (not t_out)")
    return k0, k1


# ------------------------------------------------------------------ evaluations
def _forces(system: System, t: np.ndarray, Y: np.ndarray, p: np.ndarray, sigma: np.ndarray | None,
            notes: list[str]) -> np.ndarray | None:
    """Mesh forces ``(len(t), meshes)`` (generated ``gs_mesh_force``), in the mode of each point
    (``sigma``: the surface sides instead of those of the points); ``None`` without it."""
    gen = system.generated
    if "gs_mesh_force" not in gen.functions:
        if not any("force" in n for n in notes):
            notes.append("the model's mesh forces are not generated (a mesh force reads an eliminated "
                         "coordinate): no force quantities")
        return None
    n = len(t)
    M = np.asarray(system.modes(t, Y, p), float).reshape(n, -1)
    if sigma is not None and gen.nsw:
        M[:, :gen.nsw] = sigma
    m_arg = M.T if M.shape[1] else np.zeros((0, n))
    out = generated_map(gen, "gs_mesh_force", n)(np.asarray(t, float).reshape(1, n), np.asarray(Y, float).T, p, m_arg)
    return np.asarray(out, float).reshape(-1, n).T


def _static(system: System, params: Mapping[str, float], p: np.ndarray, t: np.ndarray,
            notes: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None] | None:
    """``(x_s, delta(t, x_s) at the window samples, mean delta_s, mean W_s)`` or ``None`` (noted)."""
    from .static import static_equilibrium

    try:
        eq = static_equilibrium(system, params, rigid="keep", where=(None, None))
    except GearsymError as exc:
        notes.append(f"no static equilibrium ({exc}): no static deflection, static force, DTE or dynamic factor")
        return None
    xs = np.asarray(eq.state, float)
    tn, w = eq.nodes
    Xn = np.tile(xs, (len(tn), 1))
    d_nodes = system.mesh_deflections(tn, Xn, p)
    W_nodes = _forces(system, tn, Xn, p, eq.sigma, notes)
    d_win = system.mesh_deflections(t, np.tile(xs, (len(t), 1)), p)
    return xs, d_win, w @ d_nodes, None if W_nodes is None else w @ W_nodes


def mesh_order_periods(system: System, p: np.ndarray, names: Sequence[str], T: float,
                       given: Mapping[str, float] | None = None) -> dict[str, float]:
    """The period of mesh order 1 of every mesh (the rule of the module docstring).

    Parameters
    ----------
    system
        The compiled system.
    p
        Parameter vector (SI).
    names
        The meshes.
    T
        The forcing period at ``p``.
    given
        Mesh name -> its period, overriding the rule.

    Returns
    -------
    dict
        Mesh name -> the period of its order 1 (time unit).

    Raises
    ------
    ParameterError
        A given period of an unknown mesh, or not positive.
    """
    given = dict(given or {})
    for nm in given:
        if nm not in names:
            raise ParameterError(f"mesh_periods: no mesh '{nm}' (meshes: {', '.join(names)})")
        if not (math.isfinite(float(given[nm])) and float(given[nm]) > 0):
            raise ParameterError(f"mesh_periods['{nm}'] must be positive, got {given[nm]}")
    sched = {s["name"]: P for s, (P, _) in zip(system.generated.schedules, system.schedule_table(p))}
    return {nm: float(given.get(nm, sched.get(nm, T))) for nm in names}


@dataclass
class _Contact:
    """One backlash mesh over the window: time with each flank closed, and its impacts."""

    closed: dict[str, float]
    impacts: list[tuple[float, float, str]]


def _contact(system: System, traj: Trajectory, p: np.ndarray, x_start: np.ndarray, ts: float,
             te: float) -> dict[str, _Contact]:
    """Per backlash mesh: the time each flank is closed in ``[ts, te)`` (its side at ``ts``, then
    the side after each crossing of its surface) and the contact-closing events."""
    table = system.generated.contact_surfaces
    if not table:
        return {}
    g0 = np.asarray(system.switching(float(ts), x_start, p=p), float).ravel()
    speed = np.asarray(traj.event_speed, float)
    if speed.shape != (len(traj.events),):
        speed = np.full(len(traj.events), math.nan)
    out: dict[str, _Contact] = {}
    for j, sname, mesh, kind, sign in table:
        c = out.setdefault(mesh, _Contact({"drive": 0.0, "back": 0.0}, []))
        closed, last, total = sign * g0[j] > 0, ts, 0.0
        for e, v in zip(traj.events, speed):
            if e.surface != sname or not (ts <= e.t < te):
                continue
            now = sign * e.direction > 0  # the side the crossing enters: contact or not
            total += (e.t - last) if closed else 0.0
            closed, last = now, e.t
            if now:
                c.impacts.append((float(e.t), abs(float(v)), str(kind)))
        total += (te - last) if closed else 0.0
        c.closed[str(kind)] = total
    for c in out.values():
        c.impacts.sort()
    return out


# ------------------------------------------------------------------ one mesh
def _mesh(name: str, i: int, D: np.ndarray, W: np.ndarray | None, static: tuple | None, Tm: float,
          span: float, harmonics: int, contact: _Contact | None, T: float) -> MeshQuantities:
    """The quantities of mesh ``i`` from the window samples (module docstring)."""
    nan = math.nan
    if static is not None:
        e = D[:, i] - static[1][:, i]
        ds, Ws = float(static[2][i]), (nan if static[3] is None else float(static[3][i]))
        amps = _harmonics(e, span, Tm, harmonics, name)
        dte = (float(np.mean(e)), float(np.sqrt(np.mean(e * e))), float(np.max(e) - np.min(e)))
    else:
        ds = Ws = nan
        amps = np.full(harmonics, nan)
        dte = (nan, nan, nan)
    if W is not None:
        w = W[:, i]
        fm, fr, fmin, fmax = float(np.mean(w)), float(np.sqrt(np.mean(w * w))), float(np.min(w)), float(np.max(w))
        loaded = Ws != 0.0 and not math.isnan(Ws)
        df = float(np.max(w / Ws)) if loaded else nan
        dfr = fr / abs(Ws) if loaded else nan
    else:
        fm = fr = fmin = fmax = df = dfr = nan
    loss = back = per = None
    times = vel = np.zeros(0)
    flanks: list[str] = []
    if contact is not None:
        loss, back = 1.0 - contact.closed["drive"] / span, contact.closed["back"] / span
        times = np.array([c[0] for c in contact.impacts])
        vel = np.array([c[1] for c in contact.impacts])
        flanks = [c[2] for c in contact.impacts]
        per = len(times) / (span / T)
    return MeshQuantities(name=name, mesh_period=Tm, static_deflection=ds, static_force=Ws, dte_mean=dte[0],
                          dte_rms=dte[1], dte_peak_to_peak=dte[2], dte_harmonics=amps, force_mean=fm, force_rms=fr,
                          force_min=fmin, force_max=fmax, dynamic_factor=df, dynamic_factor_rms=dfr,
                          contact_loss_ratio=loss, back_contact_ratio=back, impact_times=times,
                          impact_velocities=vel, impact_flanks=flanks, impacts_per_period=per)


def _harmonics(e: np.ndarray, span: float, Tm: float, harmonics: int, name: str) -> np.ndarray:
    """Amplitudes of mesh orders ``1 .. harmonics`` of ``e`` (samples over ``span``, end excluded)."""
    K = span / Tm
    if abs(K - round(K)) > 1e-6 * max(1.0, K) or round(K) < 1:
        raise ParameterError(f"mesh '{name}': the window ({span:.6g}) is not a whole number of its mesh period "
                             f"({Tm:.6g}, {K:.6g} periods); give mesh_periods or a window of whole mesh periods")
    m = len(e)
    E = np.fft.rfft(e)
    out = np.full(harmonics, math.nan)
    for h in range(1, harmonics + 1):
        k = h * int(round(K))
        if 2 * k < m:
            out[h - 1] = 2.0 * abs(E[k]) / m
    return out


def _load_sharing(meshes: dict[str, MeshQuantities], W: np.ndarray | None, names: Sequence[str],
                  sets: Mapping[str, Sequence[str]]) -> dict[str, MeshQuantities]:
    """The load-sharing factor of every mesh of a planet set (module docstring)."""
    from dataclasses import replace

    out = dict(meshes)
    for set_name, members in sets.items():
        mean = float(np.mean([meshes[m].force_mean for m in members])) if W is not None else math.nan
        for m in members:
            lsf = float(np.max(W[:, names.index(m)] / mean)) if W is not None and mean != 0 else math.nan
            out[m] = replace(out[m], load_sharing_factor=lsf, planet_set=set_name)
    return out


# ------------------------------------------------------------------ orbits and branches
def periodic_quantities(system: System, x0: Sequence[float], period: float, *, t0: float = 0.0,
                        params: Mapping[str, float] | None = None, rtol: float = 1e-10, atol: float = 1e-12,
                        n_out: int | None = None, **options: Any) -> GearQuantities:
    """The gear quantities of a periodic orbit given by its state ``x0`` at ``t0``: one period
    integrated with an even grid (``n_out``, default 2048 per forcing period), window the whole period.

    Parameters
    ----------
    system
        The compiled system.
    x0
        The orbit's state at ``t0``.
    period
        The orbit's period (whole forcing periods).
    t0
        Its phase.
    params
        Parameter overrides (declared units).
    rtol, atol
        Integrator tolerances.
    n_out
        Output samples over the period (both ends included).
    **options
        ``harmonics``, ``mesh_periods``, ``planet_sets`` of :func:`gear_quantities`.

    Returns
    -------
    GearQuantities
    """
    T = system.period(params) or period
    n = n_out or max(2049, int(round(2048 * period / T)) + 1)
    tr = system.simulate(t_end=t0 + period, t0=t0, x0=np.asarray(x0, float), rtol=rtol, atol=atol, n_out=n,
                         params=params)
    return gear_quantities(system, tr, window=(t0, t0 + period), **options)


def orbit_quantities(system: System, orbit: Any, names: Sequence[str] | None = None,
                     **options: Any) -> dict[str, float]:
    """Scalar gear quantities of a periodic orbit (what a map point shows).

    Parameters
    ----------
    system
        The compiled system.
    orbit
        A :class:`~gearsym.PeriodicOrbit` (its :meth:`~gearsym.PeriodicOrbit.trajectory` over one
        period is used).
    names
        Quantities (:func:`parse_quantity`: a mesh in brackets, else the largest over the
        meshes); default every key of :data:`QUANTITIES`.
    **options
        ``harmonics``, ``mesh_periods``, ``planet_sets`` of :func:`gear_quantities`.

    Returns
    -------
    dict
        Name -> value (NaN where it does not apply).
    """
    gq = orbit_gear_quantities(system, orbit, **options)
    return {n: gq.value(n) for n in (names if names is not None else list(QUANTITIES))}


def orbit_gear_quantities(system: System, orbit: Any, **options: Any) -> GearQuantities:
    """:func:`gear_quantities` over one period of a periodic orbit (its cached trajectory)."""
    tr = orbit.trajectory()
    return gear_quantities(system, tr, window=(float(orbit.t0), float(orbit.t0) + float(orbit.period)), **options)


#: gear quantities of branch points, computed once per point (a BranchPoint is immutable)
_BRANCH_CACHE: weakref.WeakKeyDictionary[Any, GearQuantities | str] = weakref.WeakKeyDictionary()


def branch_quantities(branch: Any, **options: Any) -> list[GearQuantities | None]:
    """The gear quantities of every point of a continuation branch (:func:`periodic_quantities`
    from each point's ``x0`` and period; computed once per point).

    Parameters
    ----------
    branch
        A :class:`~gearsym.Branch` attached to its system.
    **options
        ``harmonics``, ``mesh_periods``, ``planet_sets`` of :func:`gear_quantities` (given
        options are not cached).

    Returns
    -------
    list
        One :class:`GearQuantities` per point, ``None`` where the integration failed (logged).
    """
    if branch.system is None:
        raise ParameterError("the branch is not attached to a system")
    setup = branch.setup
    t0 = float(branch.info.get("t0", getattr(setup, "t0", 0.0) or 0.0))
    rtol = float(getattr(setup, "rtol", 1e-10) or 1e-10)
    atol = float(getattr(setup, "atol", 1e-12) or 1e-12)
    out: list[GearQuantities | None] = []
    for pt in branch.points:
        got = None if options else _BRANCH_CACHE.get(pt)
        if got is None:
            try:
                got = periodic_quantities(branch.system, pt.x0, pt.period, t0=t0, params=branch.params_at(pt.value),
                                          rtol=rtol, atol=atol, **options)
            except GearsymError as exc:
                _log.warning("gear quantities at %s = %g: %s", branch.param, pt.value, exc)
                got = str(exc)
            if not options:
                _BRANCH_CACHE[pt] = got
        out.append(got if isinstance(got, GearQuantities) else None)
    return out
