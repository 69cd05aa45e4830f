"""Tooth stiffness of ISO 6336-1 (method B): single stiffness c' and mesh stiffness c_gamma_alpha.

ISO 6336-1:2006, clause 9 (method B), for spur gears (:math:`\\beta = 0`, virtual tooth numbers
:math:`z_n = z`) of solid disc blanks:

.. math::
   q' = C_1 + \\frac{C_2}{z_{n1}} + \\frac{C_3}{z_{n2}} + C_4 x_1 + C_5\\frac{x_1}{z_{n1}}
        + C_6 x_2 + C_7\\frac{x_2}{z_{n2}} + C_8 x_1^2 + C_9 x_2^2 \\quad [\\mathrm{mm\\,\\mu m/N}],

:math:`c'_{th} = 1/q'`, the single stiffness (the maximum stiffness of one tooth pair)

.. math:: c' = c'_{th}\\, C_M\\, C_R\\, C_B \\cos\\beta,

with the theoretical correction :math:`C_M = 0.8`, the blank factor :math:`C_R` (1 for
solid discs), the basic-rack factor
:math:`C_B = [1 + 0.5(1.2 - h_{fP}/m)][1 - 0.02(20^\\circ - \\alpha)]` (with
:math:`\\alpha` in degrees), and the mean mesh stiffness

.. math:: c_{\\gamma\\alpha} = c'(0.75\\,\\varepsilon_\\alpha + 0.25).

These hold for a line load :math:`F_t K_A / b \\ge 100` N/mm; below it c' (and so
:math:`c_{\\gamma\\alpha}`) is multiplied by :math:`(F_t K_A/b / 100)^{0.25}`.

Units: the standard gives :math:`c'` and :math:`c_{\\gamma\\alpha}` in N/(mm µm), a stiffness per
unit face width; times the face width :math:`b` (mm) it is N/µm, so the stiffness of the pair in
N/m is :math:`c \\cdot b[\\mathrm{mm}] \\cdot 10^6 = c \\cdot b[\\mathrm{m}] \\cdot 10^9`.

The coefficients :data:`ISO_C` are for steel (E = 206 GPa); the standard scales for other
materials by :math:`E/E_{st}` (:math:`E_{st} = 206` GPa, with the mean E of a mixed pair,
:math:`2E_1E_2/(E_1+E_2)`): :func:`iso6336_stiffness` applies that ratio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ParameterError
from .geometry import PairGeometry

__all__ = ["ISO_C", "E_STEEL", "IsoStiffness", "iso6336_stiffness"]

#: :math:`C_1 \dots C_9` of ISO 6336-1:2006, Table 8 (q' in mm µm / N).
ISO_C: tuple[float, ...] = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)

#: Young's modulus of steel (Pa) the coefficients are for.
E_STEEL = 206e9

#: The theoretical correction factor :math:`C_M`.
C_M = 0.8


@dataclass(frozen=True)
class IsoStiffness:
    """ISO 6336-1 method B stiffness of a spur pair.

    Attributes
    ----------
    q_prime
        Minimum flexibility :math:`q'` of a tooth pair (mm µm/N).
    c_th
        Theoretical single stiffness :math:`c'_{th} = 1/q'` (N/(mm µm)).
    c_prime
        Single stiffness :math:`c'` (N/(mm µm)).
    c_gamma_alpha
        Mesh stiffness :math:`c_{\\gamma\\alpha}` (N/(mm µm)).
    single_stiffness
        :math:`c'\\,b` in N/m.
    mesh_stiffness
        :math:`c_{\\gamma\\alpha} b` in N/m: the standard's mean mesh stiffness of the pair.
    factors
        ``C_M``, ``C_R``, ``C_B``, ``material`` (:math:`E/E_{st}`) and ``load`` (the low-load factor).
    """

    q_prime: float
    c_th: float
    c_prime: float
    c_gamma_alpha: float
    single_stiffness: float
    mesh_stiffness: float
    factors: dict[str, float]

    def to_dict(self) -> dict[str, object]:
        """The values and factors, with their units in the keys.

        Returns
        -------
        dict
            Plain numbers for JSON.
        """
        return {"q_prime_mm_um_per_N": self.q_prime, "c_th_N_per_mm_um": self.c_th,
                "c_prime_N_per_mm_um": self.c_prime, "c_gamma_alpha_N_per_mm_um": self.c_gamma_alpha,
                "single_stiffness_N_per_m": self.single_stiffness, "mesh_stiffness_N_per_m": self.mesh_stiffness,
                "factors": dict(self.factors)}


def iso6336_stiffness(geometry: PairGeometry, line_load: float | None = None, c_r: float = 1.0,
                      dedendum: float | None = None) -> IsoStiffness:
    """ISO 6336-1 (method B) single stiffness :math:`c'` and mesh stiffness :math:`c_{\\gamma\\alpha}`.

    Parameters
    ----------
    geometry
        The pair (:func:`~gearsym.gears.geometry.pair_geometry`).
    line_load
        :math:`F_t K_A / b` (N/mm); ``None`` (default) assumes at least 100 N/mm (no low-load factor).
    c_r
        Gear blank factor :math:`C_R` (1 for solid discs, the default).
    dedendum
        :math:`h_{fP}/m` of the basic rack for :math:`C_B` (default: the mean of the two gears' dedendum
        coefficients, recovered from their root radii).

    Returns
    -------
    IsoStiffness
        :math:`q'`, :math:`c'_{th}`, :math:`c'`, :math:`c_{\\gamma\\alpha}` per unit face width and for the pair.

    Raises
    ------
    ParameterError
        A non-positive line load or blank factor.
    """
    g1, g2 = geometry.pinion, geometry.wheel
    m = geometry.module
    if line_load is not None and not (math.isfinite(line_load) and line_load > 0):
        raise ParameterError(f"line_load (F_t K_A / b) must be positive and finite, got {line_load}")
    if not (math.isfinite(c_r) and c_r > 0):
        raise ParameterError(f"c_r (ISO 6336 gear blank factor) must be positive and finite, got {c_r}")
    zn1, zn2, x1, x2 = g1.teeth, g2.teeth, g1.profile_shift, g2.profile_shift
    c = ISO_C
    q = (c[0] + c[1] / zn1 + c[2] / zn2 + c[3] * x1 + c[4] * x1 / zn1 + c[5] * x2 + c[6] * x2 / zn2
         + c[7] * x1 ** 2 + c[8] * x2 ** 2)
    c_th = 1.0 / q
    if dedendum is None:
        dedendum = ((g1.r - g1.r_f) / m + g1.profile_shift + (g2.r - g2.r_f) / m + g2.profile_shift) / 2
    c_b = (1 + 0.5 * (1.2 - dedendum)) * (1 - 0.02 * (20.0 - math.degrees(geometry.alpha)))
    e1, e2 = g1.youngs_modulus, g2.youngs_modulus
    material = (2 * e1 * e2 / (e1 + e2)) / E_STEEL
    load = 1.0 if line_load is None or line_load >= 100 else (line_load / 100) ** 0.25
    c_prime = c_th * C_M * c_r * c_b * material * load  # cos(beta) = 1 for spur gears
    c_gamma = c_prime * (0.75 * geometry.contact_ratio + 0.25)
    to_n_per_m = geometry.face_width * 1e9  # N/(mm um) * b[m] * 1e9 = N/m
    return IsoStiffness(q_prime=q, c_th=c_th, c_prime=c_prime, c_gamma_alpha=c_gamma,
                        single_stiffness=c_prime * to_n_per_m, mesh_stiffness=c_gamma * to_n_per_m,
                        factors={"C_M": C_M, "C_R": c_r, "C_B": c_b, "material": material, "load": load})
