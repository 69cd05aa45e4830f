"""Modal analysis: natural frequencies and mode shapes about the static equilibrium.

What gear researchers run before anything else: the linear model with the **mean**
mesh stiffness, linearised about the **static equilibrium** under the mean loads.
Everything is computed from the compiled system (the generated right-hand side and
Jacobian; no sympy), for explicit models ``x = [q, v]``, ``v = q'``,
``v' = a(t, q, v)``:

1. *Averaging.*  With a forcing period ``T`` the time average of a quantity over one
   period is by default exact (Gauss-Legendre on sub-intervals split at the schedule
   breaks, doubled until the mean settles: a mesh harmonic 64 times the forcing
   frequency is resolved); with ``samples`` it is the mean of that many equally spaced
   values (exact for trigonometric polynomials of degree below ``samples``, e.g.
   ``k (1 + eps cos(2 pi f t - phi))``, aliased above).
2. *Static equilibrium.*  :func:`gearsym.static.static_equilibrium` on the same
   samples: every coordinate, the averaged accelerations at rest ``<a(t, q, 0)> = 0``,
   each backlash mesh in the contact state its mean load implies (drive, back,
   separated; an unloaded clearance centred), rigid-body modes kept at the start.
3. *Linearisation.*  ``A = -<da/dq>`` and ``D = -<da/dv>`` at ``(q_eq, 0)``, in the
   contact state of the equilibrium: for
   ``M q'' + C q' + K q = F`` these are ``M^-1 K`` and ``M^-1 C``.
4. *Eigenproblem* ``K phi = w^2 M phi``.  ``M`` is not an output of the generated
   code, but for a lumped model it is diagonal (inertia elements act on single
   coordinates) and ``K = M A`` is symmetric, which fixes ``M`` up to one scale per
   coupled group of coordinates: ``m_i / m_j = A_ji / A_ij``.  These ratios are taken
   along the strongest couplings and checked on every coupling; when they hold the
   problem is solved as the symmetric pencil ``(M A, M)`` (``scipy.linalg.eigh``:
   real frequencies, ``M``-orthogonal shapes, kinetic-energy fractions per
   coordinate, modal damping ratios ``phi^T C phi / (2 w phi^T M phi)``).  Otherwise
   (gyroscopic or non-conservative couplings, non-diagonal mass) the eigenvalues of
   ``A`` are used and ``symmetric`` is false.

Repeated frequencies (to ``cluster_tol``, relative) are grouped: ``multiplicities``
gives the size of each mode's group, and
:func:`gearsym.analysis.linear.classify_planetary` classifies planetary gear modes
(Lin & Parker) by group.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg as sla

from ...budget import check_count
from ...display import ModalDisplay
from ...errors import ParameterError
from ...static import PeriodAverage, StaticEquilibrium, equal_nodes
from ...static import static_equilibrium as solve_static

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["ModalAnalysis", "averaged_linearization", "diagonal_mass", "equilibrium", "modal_analysis",
           "static_equilibrium"]


@dataclass(frozen=True, repr=False)
class ModalAnalysis(ModalDisplay):
    """Natural frequencies and mode shapes of a linearised model.

    ``repr`` is one line; ``to_dataframe()`` gives one row per mode, ``to_xarray()`` a dataset
    on ``(mode, coordinate)`` (:mod:`gearsym.display`).

    Attributes
    ----------
    coordinate_names : list of str
        The coordinates ``q`` (the first half of the states).
    equilibrium : ndarray
        ``q`` at the static equilibrium (SI units).
    frequencies_hz : ndarray
        Undamped natural frequencies ``w / (2 pi)``, ascending (Hz; cycles per unit time
        for models in dimensionless time); a negative value ``-sqrt(-w^2)/(2 pi)`` marks a
        statically unstable direction.
    shapes : ndarray, shape (n_modes, n_coordinates)
        Mode shapes, each scaled so that its largest component is ``+1``.
    multiplicities : ndarray of int
        Number of modes in each mode's group of equal frequencies.
    groups : list of list of int
        The groups of equal frequencies (mode indices).
    damping_ratios : ndarray
        Modal damping ratios (``nan`` for a zero frequency or without ``symmetric``).
    symmetric : bool
        Whether ``K = M A`` was symmetric with a diagonal ``M`` (see the module notes).
    mass : ndarray or None
        The recovered diagonal of ``M``, up to one scale per coupled group.
    stiffness : ndarray
        ``A = M^-1 K`` (averaged over the forcing period).
    damping : ndarray
        ``D = M^-1 C``.
    contact : dict
        Contact state of every backlash mesh at the equilibrium: ``"drive"``,
        ``"back"`` or ``"separated"``.
    params : dict
        Parameter values of the analysis (declared units).
    info : dict
        ``samples`` (``None``: the exact mean), ``nodes`` (of the average), ``period``,
        ``equilibrium_iterations`` and ``equilibrium_residual`` (Newton, all contact states
        tried), ``contact_states_tried``, ``rigid_body``, ``symmetry_error``, ``cluster_tol``,
        ``frequency_unit`` (``"Hz"``, or ``"1/time"`` for a model in dimensionless time).
    classification : list of str or None
        A type per mode where a classifier applies (planetary sets:
        ``"rotational"``, ``"translational"``, ``"planet"``, ``"mixed"``).
    vectors : ndarray or None
        The ``M``-orthonormal eigenvectors as columns (symmetric case), behind
        :meth:`mass_normalized` (constructor argument ``_vectors``).
    """

    coordinate_names: list[str]
    equilibrium: np.ndarray
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    multiplicities: np.ndarray
    groups: list[list[int]]
    damping_ratios: np.ndarray
    symmetric: bool
    mass: np.ndarray | None
    stiffness: np.ndarray
    damping: np.ndarray
    contact: dict[str, str]
    params: dict[str, float]
    info: dict[str, Any] = field(default_factory=dict)
    classification: list[str] | None = None
    _vectors: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def n_modes(self) -> int:
        """Number of modes (= number of coordinates)."""
        return len(self.frequencies_hz)

    def mass_normalized(self) -> np.ndarray:
        """Shapes as columns, ``M``-orthonormal in the recovered mass (symmetric case only).

        Returns
        -------
        ndarray, shape (n_coordinates, n_modes)
        """
        if self._vectors is None:
            raise ParameterError("mass-normalised shapes need the symmetric (diagonal-mass) case")
        return self._vectors

    def energy_fractions(self, group: Sequence[int]) -> np.ndarray:
        """Kinetic-energy fraction of every coordinate in a group of modes (summed over the
        group: independent of the basis chosen inside a repeated frequency).

        Parameters
        ----------
        group
            Mode indices (one of :attr:`groups`).

        Returns
        -------
        ndarray, shape (n_coordinates,)
            Sums to 1.  Without ``symmetric`` the squared amplitudes are used.
        """
        idx = list(group)
        if self._vectors is not None and self.mass is not None:
            V = self._vectors[:, idx]
            e = self.mass[:, None] * V ** 2
        else:
            e = self.shapes[idx].T ** 2
        tot = e.sum(axis=1)
        return tot / tot.sum()

    def table(self, title: str = "", frequency_unit: str = "Hz") -> str:
        """The text report of ``gearsym modes``: one row per mode (frequency, multiplicity,
        damping ratio, type, largest components), the contact state and the structure verdict.

        Parameters
        ----------
        title
            The scene's name (the first line's head).
        frequency_unit
            The label of the frequency column (``"1/time"`` for models in dimensionless time,
            whose ``frequencies_hz`` are cycles per unit time).

        Returns
        -------
        str
            Lines of text.
        """
        names = self.coordinate_names
        samples = self.info.get("samples")
        mean = (f"mean stiffness over {samples} samples per forcing period" if samples else
                f"exact mean stiffness over the forcing period, {self.info.get('nodes')} quadrature nodes")
        lines = [f"{title + ': ' if title else ''}{self.n_modes} modes of the linearisation about the static "
                 f"equilibrium ({mean})"]
        if self.contact:
            lost = {k: v for k, v in self.contact.items() if v != "drive"}
            lines.append("  contact at equilibrium: " + ("all meshes in drive-side contact" if not lost else
                                                         ", ".join(f"{k} {v}" for k, v in self.contact.items())))
        if not self.symmetric:
            lines.append("  (no diagonal mass symmetrises the stiffness: eigenvalues of M^-1 K, no damping ratios)")
        head = f"  {'mode':>4s} {'f [' + frequency_unit + ']':>12s} {'mult':>4s} {'damping':>8s}"
        if self.classification:
            head += f"  {'type':13s}"
        lines.append(head + "  largest components")
        for k in range(self.n_modes):
            shape = self.shapes[k]
            big = np.argsort(-np.abs(shape))[:3]
            z = self.damping_ratios[k]
            row = f"  {k + 1:4d} {self.frequencies_hz[k]:12.2f} {self.multiplicities[k]:4d} "
            row += f"{z:8.4f}" if math.isfinite(z) else f"{'-':>8s}"
            if self.classification:
                row += f"  {self.classification[k]:13s}"
            lines.append(row + "  " + ", ".join(f"{names[i]} {shape[i]:+.3f}" for i in big))
        st = self.info.get("structure")
        if st:
            g = st["groups"]
            lines.append(f"  Lin & Parker structure ({st['n_planets']} planets): {g['rotational']} rotational, "
                         f"{g['translational']} translational, {g['planet']} planet, {g['mixed']} mixed groups: "
                         + ("holds" if st["lin_parker"] else "does NOT hold"))
        return "\n".join(lines)

    def to_dict(self, shapes: bool = True) -> dict[str, Any]:
        """JSON-ready summary (``mode_shapes``: one mapping coordinate -> amplitude per mode).

        Parameters
        ----------
        shapes
            Include the mode shapes.

        Returns
        -------
        dict
        """
        d: dict[str, Any] = {
            "coordinate_names": list(self.coordinate_names),
            "frequencies_hz": [float(f) for f in self.frequencies_hz],
            "multiplicities": [int(m) for m in self.multiplicities],
            "damping_ratios": [None if not math.isfinite(z) else float(z) for z in self.damping_ratios],
            "classification": self.classification,
            "symmetric": bool(self.symmetric),
            "equilibrium": {n: float(v) for n, v in zip(self.coordinate_names, self.equilibrium)},
            "contact": dict(self.contact),
            "params": dict(self.params),
            **{k: v for k, v in self.info.items() if k not in ("structure",)},
        }
        if "structure" in self.info:
            d["structure"] = self.info["structure"]
        if shapes:
            d["mode_shapes"] = [{n: float(v) for n, v in zip(self.coordinate_names, s)} for s in self.shapes]
        return d


# ------------------------------------------------------------------------ evaluation
def _nodes(system: CompiledSystem, params: Mapping[str, float] | None, samples: int | None, t0: float
           ) -> tuple[np.ndarray, np.ndarray] | None:
    """``samples`` equally spaced times of one forcing period and their (equal) weights;
    ``None`` (the exact mean of :mod:`gearsym.static`) without ``samples``."""
    if samples is None:
        return None
    check_count("samples", samples)  # before the samples are allocated (gearsym.budget)
    return equal_nodes(system, system.param_vector(params), samples, t0)


def _check_explicit(system: CompiledSystem) -> int:
    gen = system.generated
    if gen.implicit:
        raise ParameterError("modal analysis needs an explicit model (model.form = 'explicit')")
    if gen.nx % 2:
        raise ParameterError(f"modal analysis needs states [q, q'] (got {gen.nx} states)")
    return gen.nx // 2


def equilibrium(system: CompiledSystem, params: Mapping[str, float] | None = None, *,
                x0: Sequence[float] | None = None, samples: int | None = None, t0: float = 0.0,
                where: tuple[str | None, str | None] = (None, None)) -> StaticEquilibrium:
    """The static equilibrium of a modal analysis: :func:`gearsym.static.static_equilibrium`
    with rigid-body modes kept at the starting state.

    Parameters
    ----------
    system
        A compiled explicit system.
    params
        Parameter overrides (declared units, as ``--set``).
    x0
        Starting state (default: the scene's initial state); only its coordinates are used.
    samples
        Equally spaced samples per forcing period for the averages (default: the exact
        mean, :func:`gearsym.static.period_nodes` refined until it settles).
    t0
        Start of the averaging period (with ``samples``).
    where
        ``(file, field)`` the errors name.

    Returns
    -------
    StaticEquilibrium
        Coordinates, contact state of every backlash mesh, the sides used at each sample.

    Raises
    ------
    SpecError
        No equilibrium: mean loads that do not balance along a rigid-body mode, or no
        contact state consistent with the mean loads (naming the meshes).
    ConvergenceError
        Newton did not converge.
    """
    nq = _check_explicit(system)
    x = np.array(system.x0 if x0 is None else x0, dtype=float)
    if x.shape != (2 * nq,):
        raise ParameterError(f"x0 must have {2 * nq} entries, got shape {x.shape}")
    return solve_static(system, params, guess=x, nodes=_nodes(system, params, samples, t0), rigid="keep",
                        where=where)


def static_equilibrium(system: CompiledSystem, params: Mapping[str, float] | None = None, *,
                       x0: Sequence[float] | None = None, samples: int | None = None, t0: float = 0.0
                       ) -> tuple[np.ndarray, dict[str, Any]]:
    """The coordinates at the static equilibrium (:func:`equilibrium`).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units, as ``--set``).
    x0
        Full state whose coordinates start the solve (default: the system's ``x0``).
    samples
        Average over this many equally spaced times of the forcing period instead of the
        exact mean (:class:`gearsym.static.PeriodAverage`).
    t0
        Start of the averaged period.

    Returns
    -------
    q : ndarray
        The coordinates at the equilibrium (SI units).
    info : dict
        ``{"iterations", "residual", "singular", "contact"}``.
    """
    eq = equilibrium(system, params, x0=x0, samples=samples, t0=t0)
    return eq.q, {"iterations": eq.info["iterations"], "residual": eq.info["residual"],
                  "singular": eq.free > 0, "contact": dict(eq.contact)}


def averaged_linearization(system: CompiledSystem, q: Sequence[float], params: Mapping[str, float] | None = None,
                           *, samples: int | None = None, t0: float = 0.0, sigma: np.ndarray | None = None,
                           nodes: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``A = -<da/dq>`` and ``D = -<da/dv>`` at ``(q, v = 0)``, averaged over the forcing period.

    For ``M q'' + C q' + K q = F(t)`` these are ``M^-1 K`` and ``M^-1 C`` with the mean
    stiffness and damping in the contact state ``sigma`` (the surface sides at each
    node, as :attr:`gearsym.static.StaticEquilibrium.sigma`; default: the sides at
    ``(t, q)``).  The nodes: ``nodes`` if given, else ``samples`` equally spaced, else the
    exact mean (:class:`gearsym.static.PeriodAverage`).
    """
    nq = _check_explicit(system)
    x = np.concatenate([np.asarray(q, float), np.zeros(nq)])
    avg = PeriodAverage(system, params, nodes if nodes is not None else _nodes(system, params, samples, t0),
                        probe=x)
    if sigma is None:
        sigma = np.where(avg.switching(x) >= 0, 1.0, -1.0)
    _, J = avg.average(x, sigma)
    assert J is not None
    return -J[nq:, :nq], -J[nq:, nq:]


def diagonal_mass(A: np.ndarray, rtol: float = 1e-9) -> tuple[np.ndarray | None, float]:
    """A diagonal ``M`` with ``M A`` symmetric, if there is one.

    ``m_i A_ij = m_j A_ji`` for every coupling: the ratios are taken along a maximum
    spanning tree of the couplings (strongest ``|A_ij A_ji|`` first, so round-off
    entries never set a ratio), one scale per connected group, and checked on all.

    Returns
    -------
    m : ndarray or None
        The diagonal (positive), or None if no diagonal ``M`` symmetrises ``A``.
    error : float
        ``max |m_i A_ij - m_j A_ji| / max |m_i A_ij|`` (inf when None).
    """
    n = A.shape[0]
    scale = float(np.max(np.abs(A))) if A.size else 0.0
    if scale == 0.0:
        return np.ones(n), 0.0
    tiny = 1e-12 * scale
    W = np.abs(A) * np.abs(A.T)
    W[np.abs(A) <= tiny] = 0.0
    W[np.abs(A.T) <= tiny] = 0.0
    np.fill_diagonal(W, 0.0)
    m = np.full(n, np.nan)
    # Prim's algorithm from every unvisited node (one tree per coupled group)
    for root in range(n):
        if not math.isnan(m[root]):
            continue
        m[root] = 1.0
        best = W[root].copy()
        parent = np.full(n, root)
        best[~np.isnan(m)] = -1.0
        while True:
            j = int(np.argmax(best))
            if best[j] <= 0.0:
                break
            i = parent[j]
            ratio = A[i, j] / A[j, i]  # m_j = m_i A_ij / A_ji
            if not ratio > 0:
                return None, math.inf
            m[j] = m[i] * ratio
            best[j] = -1.0
            upd = (W[j] > best) & np.isnan(m)
            best[upd] = W[j][upd]
            parent[upd] = j
    K = m[:, None] * A
    err = float(np.max(np.abs(K - K.T)) / np.max(np.abs(K)))
    return (m, err) if err <= rtol else (None, err)


def _groups(f: np.ndarray, cluster_tol: float) -> list[list[int]]:
    top = float(np.max(np.abs(f))) if f.size else 0.0
    out: list[list[int]] = []
    for i in range(len(f)):
        if out and abs(f[i] - f[out[-1][-1]]) <= cluster_tol * max(abs(f[i]), abs(f[out[-1][-1]])) \
                + 1e-9 * top:
            out[-1].append(i)
        else:
            out.append([i])
    return out


def _frequency_unit(system: CompiledSystem) -> str:
    """``"Hz"`` for a model in seconds, ``"1/time"`` in dimensionless time (or unknown)."""
    table = getattr(system, "units_table", None)
    return "Hz" if callable(table) and table().get("t") == "s" else "1/time"


def modal_analysis(system: CompiledSystem, params: Mapping[str, float] | None = None, *, samples: int | None = None,
                   t0: float = 0.0, x0: Sequence[float] | None = None, cluster_tol: float = 1e-6,
                   where: tuple[str | None, str | None] = (None, None)) -> ModalAnalysis:
    """Natural frequencies and mode shapes about the static equilibrium (mean stiffness).

    Parameters
    ----------
    system
        A compiled explicit system.
    params
        Parameter overrides (declared units, as ``--set``).
    samples
        Equally spaced samples per forcing period for the averages (mean stiffness, mean
        loads); default: the exact mean (Gauss-Legendre on the forcing period, split at the
        schedule breaks and refined until it settles, :class:`gearsym.static.PeriodAverage`).
    t0
        Start of the averaging period (with ``samples``).
    x0
        Starting guess of the equilibrium (default: the scene's initial state).
    cluster_tol
        Relative tolerance under which frequencies count as equal (multiplicities).
    where
        ``(file, field)`` named by the errors of the static equilibrium (the scene file).

    Returns
    -------
    ModalAnalysis

    Raises
    ------
    ParameterError
        Implicit model, bad options.
    SpecError
        No static equilibrium (:func:`gearsym.static.static_equilibrium`).
    ConvergenceError
        The static equilibrium did not converge.
    """
    if samples is not None:
        check_count("samples", samples)
    if (samples is not None and samples < 1) or not (0 < cluster_tol < 1):
        raise ParameterError("need samples >= 1 and 0 < cluster_tol < 1")
    eq = equilibrium(system, params, x0=x0, samples=samples, t0=t0, where=where)
    q = eq.q
    A, D = averaged_linearization(system, q, params, sigma=eq.sigma, nodes=eq.nodes)
    n = len(q)
    m, sym_err = diagonal_mass(A)
    vectors = None
    if m is not None:
        K = m[:, None] * A
        K = 0.5 * (K + K.T)
        w2, V = sla.eigh(K, np.diag(m))
        C = m[:, None] * D
        C = 0.5 * (C + C.T)
        vectors = V
        denom = 2.0 * np.sqrt(np.abs(w2)) * np.einsum("ik,i,ik->k", V, m, V)
        zeta = np.einsum("ik,ij,jk->k", V, C, V) / np.where(denom > 0, denom, np.nan)
        shapes = V.T.copy()
    else:
        w2c, Vc = np.linalg.eig(A)
        order = np.argsort(w2c.real)
        w2, shapes = w2c.real[order], Vc[:, order].real.T.copy()
        zeta = np.full(n, np.nan)
    top = float(np.max(np.abs(w2))) if n else 0.0
    w2 = np.where(np.abs(w2) <= 1e-12 * top, 0.0, w2)
    f = np.sign(w2) * np.sqrt(np.abs(w2)) / (2 * math.pi)
    zeta = np.where(f > 0, zeta, np.nan)
    for k in range(n):
        i = int(np.argmax(np.abs(shapes[k])))
        if shapes[k, i] != 0:
            shapes[k] /= shapes[k, i]
    groups = _groups(f, cluster_tol)
    mult = np.zeros(n, dtype=int)
    for g in groups:
        mult[g] = len(g)
    names = system.state_names[:n]
    p_used = system.run_params(params)
    return ModalAnalysis(
        coordinate_names=names, equilibrium=q, frequencies_hz=f, shapes=shapes, multiplicities=mult,
        groups=groups, damping_ratios=zeta, symmetric=m is not None, mass=m, stiffness=A, damping=D,
        contact=dict(eq.contact), params=p_used,
        info={"samples": samples, "nodes": len(eq.nodes[0]), "period": system.period(params),
              "equilibrium_iterations": eq.info["iterations"], "equilibrium_residual": eq.info["residual"],
              "contact_states_tried": eq.info["states_tried"],
              "rigid_body": eq.free > 0 or bool(np.any(f == 0.0)),
              "symmetry_error": sym_err if math.isfinite(sym_err) else None, "cluster_tol": cluster_tol,
              "frequency_unit": _frequency_unit(system)},
        _vectors=vectors)
