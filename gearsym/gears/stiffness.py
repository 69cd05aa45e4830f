"""Time-varying mesh stiffness of a spur pair over one mesh cycle, and the ISO 6336 means beside it.

**Mesh phase.**  One mesh cycle is one base pitch :math:`p_b` of travel of the contact
along the line of action (one tooth of either gear).  The pinion (gear 1) drives: its
contact moves from its root to its tip.  The phase :math:`\\varphi \\in [0, 1)` is
counted from the instant a tooth pair comes into contact at :math:`A` (the start of the
path of contact, on the wheel's tip circle).  At phase :math:`\\varphi` the pairs
:math:`j = 0, 1, \\dots` are at :math:`s_j = (\\varphi + j)p_b` from :math:`A` and in
contact while :math:`s_j \\le \\varepsilon_\\alpha p_b`; for
:math:`1 \\le \\varepsilon_\\alpha < 2` that is two pairs on
:math:`[0, \\varepsilon_\\alpha - 1]` and one pair on :math:`(\\varepsilon_\\alpha - 1, 1)`.
The pinion's contact point has roll length :math:`T_1A + s_j`, the wheel's
:math:`a_w\\sin\\alpha_w - T_1A - s_j`.

**Mesh stiffness.**  :math:`k(\\varphi) = \\sum_j k_{pair}(s_j)`, each pair a chain of the
Hertzian contact and both teeth (:mod:`~gearsym.gears.energy`).  The stiffness jumps where a
pair enters or leaves (the ends of the zones); its mean over the cycle is integrated segment
by segment (Gauss-Legendre), not from the samples.

**Measured (pinned in ``tests/test_gears_stiffness.py``, discussed in ``docs/gears.md``).**
For the pair Yu et al. compare with in their Fig. 14 (50/50 teeth, m = 3 mm, 20 deg,
b = 20 mm, E = 206 GPa, nu = 0.3, basic rack 1 / 1.25 / 0.38, bore radius r_f/2), contact
ratio 1.7547: the potential-energy stiffness is 4.74e8 - 5.00e8 N/m with two pairs and
2.77e8 - 2.79e8 N/m with one, its mean 4.390e8 N/m; ISO 6336-1's
:math:`c_{\\gamma\\alpha} b` is 4.402e8 N/m, so the mean is 0.3 % below ISO's.  The mean
depends on the bore through the fillet-foundation term: 3.53e8 N/m for a 20 mm bore radius
(20 % below ISO), 4.69e8 N/m for 50 mm (6.5 % above).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..budget import check_count
from ..errors import ParameterError
from .energy import ToothCompliance, gauss_legendre, hertz_stiffness, tooth_compliances
from .geometry import GearPair, PairGeometry, pair_geometry
from .iso6336 import IsoStiffness, iso6336_stiffness

__all__ = ["MeshStiffness", "PairStiffness", "mesh_stiffness", "pair_stiffness"]

#: Gauss-Legendre nodes per smooth segment of the mean over the cycle
_MEAN_NODES = 24


@dataclass(frozen=True)
class PairStiffness:
    """One tooth pair along the path of contact: its stiffness and the parts of it.

    Attributes
    ----------
    position
        Distance from :math:`A` along the path of contact, in base pitches (0 ... contact ratio).
    stiffness
        :math:`k_{pair}` (N/m).
    hertz
        :math:`1/k_h` (m/N), one number.
    pinion, wheel
        :class:`~gearsym.gears.energy.ToothCompliance` of each tooth (m/N).
    """

    position: np.ndarray
    stiffness: np.ndarray
    hertz: float
    pinion: ToothCompliance
    wheel: ToothCompliance


def pair_stiffness(geometry: PairGeometry, position: np.ndarray) -> PairStiffness:
    """The stiffness of one tooth pair at positions along the path of contact.

    Parameters
    ----------
    geometry
        The pair (:func:`~gearsym.gears.geometry.pair_geometry`).
    position
        Distances from the start of contact :math:`A`, in base pitches, each in
        :math:`[0, \\varepsilon_\\alpha]`.

    Returns
    -------
    PairStiffness
        :math:`1/k_{pair} = 1/k_h + \\sum_{i}(1/k_{b,i} + 1/k_{s,i} + 1/k_{a,i} + 1/k_{f,i})` and its parts.

    Raises
    ------
    ParameterError
        A position outside the path of contact.
    """
    g = geometry
    pos = np.atleast_1d(np.asarray(position, dtype=float))
    if pos.size and not (np.all(np.isfinite(pos)) and pos.min() >= -1e-12 and pos.max() <= g.contact_ratio + 1e-12):
        raise ParameterError(f"positions must lie on the path of contact [0, {g.contact_ratio:.6g}] (base pitches)")
    roll1 = g.start_roll + pos * g.base_pitch
    roll2 = g.line_of_action - roll1
    t1, t2 = g.pinion, g.wheel
    hertz = 1.0 / hertz_stiffness(t1.youngs_modulus, t1.poisson, t2.youngs_modulus, t2.poisson, g.face_width)
    c1 = tooth_compliances(t1, roll1, g.face_width)
    c2 = tooth_compliances(t2, roll2, g.face_width)
    return PairStiffness(position=pos, stiffness=1.0 / (hertz + c1.total + c2.total), hertz=hertz, pinion=c1, wheel=c2)


def _stiffness_at(geometry: PairGeometry, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mesh stiffness and pairs in contact at phases in [0, 1)."""
    eps = geometry.contact_ratio
    k = np.zeros_like(phase)
    n = np.zeros(phase.shape, dtype=int)
    for j in range(int(math.floor(eps)) + 1):
        on = phase <= eps - j  # not phase + j <= eps: adding j would round a phase just past a jump onto it
        if np.any(on):
            k[on] += pair_stiffness(geometry, np.minimum(phase[on] + j, eps)).stiffness
            n[on] += 1
    return k, n


def _zones(eps: float) -> list[tuple[float, float, int]]:
    """``(start, end, pairs in contact)`` of the smooth segments of the cycle."""
    breaks = sorted({0.0, 1.0, *(eps - j for j in range(int(eps) + 1) if 0 < eps - j < 1)})
    return [(a, b, sum(1 for j in range(int(eps) + 1) if (a + b) / 2 + j <= eps)) for a, b in zip(breaks, breaks[1:])]


@dataclass(frozen=True)
class MeshStiffness:
    """The mesh stiffness of a spur pair over one mesh cycle (result of :func:`mesh_stiffness`).

    Attributes
    ----------
    pair
        The input (:class:`~gearsym.gears.geometry.GearPair`).
    geometry
        The derived geometry (:class:`~gearsym.gears.geometry.PairGeometry`).
    phase
        Mesh phase samples :math:`k/N`, :math:`k = 0 \\dots N-1`, in [0, 1).
    stiffness
        Mesh stiffness at ``phase`` (N/m).
    pairs_in_contact
        Tooth pairs in contact at ``phase``.
    contact_ratio
        :math:`\\varepsilon_\\alpha`.
    zones
        ``(start, end, pairs)`` of each contact zone of the cycle, in phase; the stiffness
        jumps at their ends.
    mean, minimum, maximum
        Mean over the cycle (integrated segment by segment), and the extremes (N/m) over the
        samples and both sides of every jump.
    iso
        ISO 6336-1 method B (:class:`~gearsym.gears.iso6336.IsoStiffness`).
    single_pair
        One pair along the path of contact (:class:`PairStiffness`).
    """

    pair: GearPair
    geometry: PairGeometry
    phase: np.ndarray
    stiffness: np.ndarray
    pairs_in_contact: np.ndarray
    contact_ratio: float
    zones: tuple[tuple[float, float, int], ...]
    mean: float
    minimum: float
    maximum: float
    iso: IsoStiffness
    single_pair: PairStiffness = field(repr=False)

    def __repr__(self) -> str:
        return (f"MeshStiffness(contact_ratio={self.contact_ratio:.4f}, mean={self.mean:.4g} N/m, "
                f"range=[{self.minimum:.4g}, {self.maximum:.4g}] N/m, iso_c_gamma={self.iso.mesh_stiffness:.4g} N/m, "
                f"samples={self.phase.size})")

    @property
    def jumps(self) -> tuple[float, ...]:
        """Phases in [0, 1) where a pair enters or leaves and the stiffness jumps (0 and the zone ends)."""
        return tuple(a for a, _, _ in self.zones)

    def at(self, phase: np.ndarray | float) -> np.ndarray:
        """The mesh stiffness at any phases (wrapped into [0, 1)), evaluated, not interpolated.

        Parameters
        ----------
        phase
            Mesh phases (cycles).

        Returns
        -------
        numpy.ndarray
            Stiffness (N/m), the shape of ``phase`` (at least 1-D).

        Raises
        ------
        ParameterError
            A phase that is not finite.
        """
        ph = np.mod(np.atleast_1d(np.asarray(phase, dtype=float)), 1.0)
        if not np.all(np.isfinite(ph)):
            raise ParameterError("phase must be finite")
        return _stiffness_at(self.geometry, ph)[0]

    def to_dict(self, samples: bool = True) -> dict[str, object]:
        """The result as plain numbers for JSON (units in the keys).

        Parameters
        ----------
        samples
            Include the ``phase`` / ``stiffness`` arrays (default True).

        Returns
        -------
        dict
            Geometry, contact ratio, zones, mean / min / max, ISO values, and the samples.
        """
        out: dict[str, object] = {
            "method": "potential energy (Hertz, bending, shear, axial compression, fillet foundation)",
            "contact_ratio": self.contact_ratio,
            "zones": [{"start": a, "end": b, "pairs": n} for a, b, n in self.zones],
            "mean_N_per_m": self.mean, "min_N_per_m": self.minimum, "max_N_per_m": self.maximum,
            "iso6336": self.iso.to_dict(),
            "mean_over_iso_c_gamma": self.mean / self.iso.mesh_stiffness,
            "geometry": self.geometry.to_dict(),
        }
        if samples:
            out["phase"] = self.phase
            out["stiffness_N_per_m"] = self.stiffness
        return out

    def to_csv(self, path: str | Path) -> Path:
        """Write ``mesh_phase,stiffness_N_per_m,pairs_in_contact`` (one header row, one row per sample).

        Parameters
        ----------
        path
            The CSV file (written atomically).

        Returns
        -------
        Path
            ``path``.
        """
        from ..files import atomic_path

        target = Path(path)
        with atomic_path(target) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["mesh_phase", "stiffness_N_per_m", "pairs_in_contact"])
            for p, k, n in zip(self.phase, self.stiffness, self.pairs_in_contact):
                w.writerow([repr(float(p)), repr(float(k)), int(n)])
        return target


def _mean(geometry: PairGeometry, zones: list[tuple[float, float, int]]) -> float:
    s, w = gauss_legendre(_MEAN_NODES)
    total = 0.0
    for a, b, _ in zones:
        ph = a + (b - a) * (s + 1) / 2
        total += float(np.sum(w * _stiffness_at(geometry, ph)[0])) * (b - a) / 2
    return total


def mesh_stiffness(pair: GearPair, samples: int = 256, line_load: float | None = None) -> MeshStiffness:
    """Time-varying mesh stiffness of a spur pair by the potential-energy method, with ISO 6336 beside it.

    Parameters
    ----------
    pair
        The gear pair (:class:`~gearsym.gears.geometry.GearPair`).
    samples
        Number of phase samples over one mesh cycle (uniform, ``k / samples``).
    line_load
        :math:`F_t K_A / b` (N/mm) for ISO 6336's low-load factor; ``None`` assumes >= 100 N/mm.

    Returns
    -------
    MeshStiffness
        Phase samples, stiffness (N/m), pairs in contact, contact ratio, zones, mean / min / max,
        ISO 6336 c' and c_gamma_alpha, one pair along the path.

    Raises
    ------
    ParameterError
        Bad geometry (see :func:`~gearsym.gears.geometry.pair_geometry`) or a bad ``samples``.

    Examples
    --------
    >>> from gearsym.gears import Gear, GearPair, mesh_stiffness
    >>> pair = GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3)
    >>> res = mesh_stiffness(pair, samples=64)
    >>> round(res.contact_ratio, 4), res.phase.shape
    (1.7547, (64,))
    """
    check_count("samples", samples, rule="samples", low=2)
    geometry = pair_geometry(pair)
    phase = np.arange(samples) / samples
    k, n = _stiffness_at(geometry, phase)
    zones = _zones(geometry.contact_ratio)
    path = np.linspace(0.0, geometry.contact_ratio, 201)
    sides = np.array([np.nextafter(b, 0.0) for _, b, _ in zones] + [np.nextafter(a, 1.0) for a, _, _ in zones])
    k_ends = _stiffness_at(geometry, sides)[0]  # both sides of every jump
    return MeshStiffness(pair=pair, geometry=geometry, phase=phase, stiffness=k, pairs_in_contact=n,
                         contact_ratio=geometry.contact_ratio, zones=tuple(zones), mean=_mean(geometry, zones),
                         minimum=float(min(k.min(), k_ends.min())), maximum=float(max(k.max(), k_ends.max())),
                         iso=iso6336_stiffness(geometry, line_load=line_load),
                         single_pair=pair_stiffness(geometry, path))
