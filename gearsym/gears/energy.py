"""Tooth and contact compliances by the potential-energy method.

A tooth pair in contact is a chain of springs along the line of action:

.. math:: \\frac{1}{k_{pair}} = \\frac{1}{k_h}
          + \\sum_{i=1,2}\\left(\\frac{1}{k_{b,i}} + \\frac{1}{k_{s,i}} + \\frac{1}{k_{a,i}}
          + \\frac{1}{k_{f,i}}\\right)

(Yang & Lin 1987; Tian 2004; with the fillet foundation of Sainsot et al. 2004 as used by
Chaari et al. 2009).  All compliances here are per unit force along the line of action (m/N).

**Hertzian contact** (Yang & Lin 1987), for two materials through the effective modulus
:math:`1/E^* = (1-\\nu_1^2)/E_1 + (1-\\nu_2^2)/E_2`:

.. math:: k_h = \\frac{\\pi b E^*}{2},

which is the familiar :math:`k_h = \\pi E b / (4(1-\\nu^2))` when both gears are of one material.

**Tooth model.**  The tooth is a cantilever on the tooth centre line, of width :math:`b`
and half thickness :math:`h(x)` at distance :math:`x` from the gear centre, loaded at the
contact point :math:`(x_c, h_c)` by a unit force along the line of action, which makes the
angle :math:`\\tau_c` with the normal to the centre line (Tian's :math:`\\alpha_1`).  The
involute is parametrised by its roll angle :math:`u` (roll length over :math:`r_b`), with
:math:`\\tau = u - \\beta_b`:

.. math::
   x(u) = r_b(\\cos\\tau + u\\sin\\tau), \\quad h(u) = r_b(u\\cos\\tau - \\sin\\tau), \\quad
   \\frac{dx}{du} = r_b u\\cos\\tau,

(Tian's angle :math:`\\alpha` is :math:`-\\tau`, so these are Tian's integrals), and the
energies of bending, shear and axial compression give

.. math::
   \\frac{1}{k_b} = \\int \\frac{[(x_c - x)\\cos\\tau_c - h_c\\sin\\tau_c]^2}{E I(x)}\\,dx, \\quad
   \\frac{1}{k_s} = \\int \\frac{1.2\\cos^2\\tau_c}{G A(x)}\\,dx, \\quad
   \\frac{1}{k_a} = \\int \\frac{\\sin^2\\tau_c}{E A(x)}\\,dx,

with :math:`I = \\tfrac{2}{3}h^3 b`, :math:`A = 2hb`, :math:`G = E/(2(1+\\nu))` (plane
stress, as in Tian 2004), over the tooth from its fixed end to the contact point.  Where
the tooth is fixed depends on the root circle (Wan et al. 2014; Ma et al. 2015):

* root circle **below** the base circle (:math:`r_f < r_b`): the involute from the base
  circle (:math:`u = 0`) to the contact, plus a straight-sided part of constant half
  thickness :math:`h_b = r_b\\sin\\beta_b` from the root circle
  (:math:`x_r = r_f\\cos\\theta_r`, :math:`\\sin\\theta_r = h_b/r_f`) to the base circle
  (:math:`x_b = r_b\\cos\\beta_b`), integrated in closed form;
* root circle **above** the base circle: the involute from the root circle
  (:math:`u_0 = \\sqrt{(r_f/r_b)^2 - 1}`) to the contact.

The fillet between the form and the root circle is not resolved (the involute is
extended to the root circle), as in these references.  The involute integrals are
evaluated by Gauss-Legendre quadrature of twice :data:`QUADRATURE_NODES` nodes (the
integrands are smooth; :func:`tooth_compliances` checks the result against the one of
:data:`QUADRATURE_NODES` nodes, and the tests against mpmath quadrature).

**Fillet foundation** (Sainsot, Velex & Duverger 2004, Eq. (5) and Table 1, as used by
Chaari, Fakhfakh & Haddar 2009):

.. math::
   \\frac{1}{k_f} = \\frac{\\cos^2\\tau_c}{E b}\\left[L^*\\left(\\frac{u_f}{S_f}\\right)^2
   + M^*\\frac{u_f}{S_f} + P^*(1 + Q^*\\tan^2\\tau_c)\\right],

:math:`X^* = A/\\theta_f^2 + B h_f^2 + C h_f/\\theta_f + D/\\theta_f + E h_f + F` with the
coefficients :data:`SAINSOT_COEFFICIENTS`, :math:`h_f = r_f/r_{int}`,
:math:`S_f = 2 r_f\\theta_f` (:math:`\\theta_f` the half angle of the generated tooth on the
root circle, :mod:`~gearsym.gears.geometry`) and :math:`u_f = x_c - r_f` the distance along
the centre line from the root circle to the contact point.

References
----------
* D. C. H. Yang, J. Y. Lin, "Hertzian damping, tooth friction and bending elasticity in
  gear impact dynamics", J. Mech. Transm. Autom. Des. 109 (1987) 189-196.
* X. Tian, "Dynamic simulation for system response of gearbox including localized gear
  faults", MSc thesis, University of Alberta, 2004.
* P. Sainsot, P. Velex, O. Duverger, "Contribution of gear body to tooth deflections - a new
  bidimensional analytical formula", J. Mech. Des. 126 (2004) 748-752.
* F. Chaari, T. Fakhfakh, M. Haddar, "Analytical modelling of spur gear tooth crack and
  influence on gearmesh stiffness", Eur. J. Mech. A/Solids 28 (2009) 461-468.
* Z. Wan, H. Cao, Y. Zi, W. He, Y. Chen, "An improved time-varying mesh stiffness algorithm
  and dynamic modeling of gear-rotor system with tooth root crack", Eng. Fail. Anal. 42
  (2014) 157-177.
* H. Ma, J. Zeng, R. Feng, X. Pang, Q. Wang, B. Wen, "Review on dynamics of cracked gear
  systems", Eng. Fail. Anal. 55 (2015) 224-245.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import GearsymError
from .geometry import ToothGeometry

__all__ = ["QUADRATURE_NODES", "SAINSOT_COEFFICIENTS", "ToothCompliance", "fillet_coefficients",
           "hertz_stiffness", "tooth_compliances"]

#: Gauss-Legendre nodes of the check of the involute integrals (the result takes twice as many).
QUADRATURE_NODES = 48

#: Sainsot et al. (2004), Table 1: rows :math:`L^*, M^*, P^*, Q^*`, columns
#: :math:`A_i, B_i, C_i, D_i, E_i, F_i` of
#: :math:`X_i^* = A_i/\theta_f^2 + B_i h_f^2 + C_i h_f/\theta_f + D_i/\theta_f + E_i h_f + F_i`.
SAINSOT_COEFFICIENTS: dict[str, tuple[float, float, float, float, float, float]] = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}

#: relative agreement required between the quadrature and the one of twice the nodes
_SELF_CHECK = 1e-11


def hertz_stiffness(e1: float, nu1: float, e2: float, nu2: float, face_width: float) -> float:
    """Hertzian contact stiffness :math:`k_h = \\pi b E^*/2` of two elastic cylinders along a line.

    Parameters
    ----------
    e1, nu1
        Young's modulus (Pa) and Poisson's ratio of gear 1.
    e2, nu2
        The same for gear 2.
    face_width
        Face width :math:`b` (m).

    Returns
    -------
    float
        :math:`k_h` (N/m), with :math:`1/E^* = (1-\\nu_1^2)/E_1 + (1-\\nu_2^2)/E_2`.
    """
    e_star = 1.0 / ((1 - nu1 ** 2) / e1 + (1 - nu2 ** 2) / e2)
    return math.pi * face_width * e_star / 2


def fillet_coefficients(theta_f: float, h_f: float) -> dict[str, float]:
    """Sainsot's :math:`L^*, M^*, P^*, Q^*` for a root half angle and a root-to-bore ratio.

    Parameters
    ----------
    theta_f
        Half angle of the tooth on the root circle (rad).
    h_f
        :math:`r_f / r_{int}`.

    Returns
    -------
    dict
        ``{"L": ..., "M": ..., "P": ..., "Q": ...}``.
    """
    return {k: a / theta_f ** 2 + b * h_f ** 2 + c * h_f / theta_f + d / theta_f + e * h_f + f
            for k, (a, b, c, d, e, f) in SAINSOT_COEFFICIENTS.items()}


@dataclass(frozen=True)
class ToothCompliance:
    """Compliances (m/N) of one tooth at contact points along its profile (arrays of one shape).

    Attributes
    ----------
    bending, shear, axial, fillet
        :math:`1/k_b`, :math:`1/k_s`, :math:`1/k_a`, :math:`1/k_f`.
    """

    bending: np.ndarray
    shear: np.ndarray
    axial: np.ndarray
    fillet: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """The sum of the four compliances (m/N)."""
        return self.bending + self.shear + self.axial + self.fillet


@lru_cache(maxsize=8)
def gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1] (cached: numpy computes them by an eigenproblem).

    Parameters
    ----------
    nodes
        Number of nodes.

    Returns
    -------
    tuple of numpy.ndarray
        Nodes and weights (read-only).
    """
    s, w = np.polynomial.legendre.leggauss(nodes)
    s.setflags(write=False)
    w.setflags(write=False)
    return s, w


def _involute_integrals(t: ToothGeometry, u_c: np.ndarray, b: float, nodes: int) -> tuple[np.ndarray, ...]:
    """Bending, shear and axial compliances of the involute part, from ``u0`` to each ``u_c``."""
    r_b, beta = t.r_b, t.beta_b
    e = t.youngs_modulus
    g = e / (2 * (1 + t.poisson))
    u0 = 0.0 if t.root_below_base else math.sqrt((t.r_f / r_b) ** 2 - 1)
    tau_c = u_c - beta
    x_c = r_b * (np.cos(tau_c) + u_c * np.sin(tau_c))
    h_c = r_b * (u_c * np.cos(tau_c) - np.sin(tau_c))
    s, w = gauss_legendre(nodes)
    half = (u_c - u0)[:, None] / 2
    u = u0 + half * (s[None, :] + 1)  # (points, nodes)
    tau = u - beta
    x = r_b * (np.cos(tau) + u * np.sin(tau))
    h = r_b * (u * np.cos(tau) - np.sin(tau))
    dx = r_b * u * np.cos(tau) * (w[None, :] * half)
    ct, st = np.cos(tau_c)[:, None], np.sin(tau_c)[:, None]
    moment = (x_c[:, None] - x) * ct - h_c[:, None] * st
    bending = np.sum(moment ** 2 / (e * (2 / 3) * h ** 3 * b) * dx, axis=1)
    shear = np.sum(1.2 * ct ** 2 / (g * 2 * h * b) * dx, axis=1)
    axial = np.sum(st ** 2 / (e * 2 * h * b) * dx, axis=1)
    return bending, shear, axial


def _straight_part(t: ToothGeometry, u_c: np.ndarray, b: float) -> tuple[np.ndarray, ...]:
    """Closed-form compliances of the straight part between root and base circle (``r_f < r_b``)."""
    e = t.youngs_modulus
    g = e / (2 * (1 + t.poisson))
    h_b = t.r_b * math.sin(t.beta_b)
    x_b = t.r_b * math.cos(t.beta_b)
    x_r = t.r_f * math.cos(math.asin(h_b / t.r_f))
    d = x_b - x_r
    tau_c = u_c - t.beta_b
    ct, st = np.cos(tau_c), np.sin(tau_c)
    x_c = t.r_b * (ct + u_c * st)
    h_c = t.r_b * (u_c * ct - st)

    def moment(x: float) -> np.ndarray:
        return (x_c - x) * ct - h_c * st

    # int_{x_r}^{x_b} M(x)^2 dx with M linear in x, slope -cos(tau_c)
    bending = (moment(x_r) ** 3 - moment(x_b) ** 3) / (3 * ct) / (e * (2 / 3) * h_b ** 3 * b)
    shear = 1.2 * ct ** 2 * d / (g * 2 * h_b * b)
    axial = st ** 2 * d / (e * 2 * h_b * b)
    return bending, shear, axial


def _fillet(t: ToothGeometry, u_c: np.ndarray, b: float) -> np.ndarray:
    tau_c = u_c - t.beta_b
    x_c = t.r_b * (np.cos(tau_c) + u_c * np.sin(tau_c))
    c = fillet_coefficients(t.theta_f, t.r_f / t.bore_radius)
    ratio = (x_c - t.r_f) / (2 * t.r_f * t.theta_f)
    return np.cos(tau_c) ** 2 / (t.youngs_modulus * b) * (
        c["L"] * ratio ** 2 + c["M"] * ratio + c["P"] * (1 + c["Q"] * np.tan(tau_c) ** 2))


def tooth_compliances(tooth: ToothGeometry, roll: np.ndarray, face_width: float,
                      nodes: int = QUADRATURE_NODES) -> ToothCompliance:
    """Bending, shear, axial and fillet-foundation compliances of one tooth at contact points.

    Parameters
    ----------
    tooth
        The tooth (:class:`~gearsym.gears.geometry.ToothGeometry`).
    roll
        Roll lengths (m) of the contact points on this gear's involute (distance from the
        base-circle tangent point along the line of action), 1-D.
    face_width
        Face width :math:`b` (m).
    nodes
        Gauss-Legendre nodes of the check; the result takes twice as many.

    Returns
    -------
    ToothCompliance
        The compliances (m/N) at each point.

    Raises
    ------
    GearsymError
        The two quadratures disagree by more than 1e-11 (relative): an integrand that is
        not smooth, which a valid geometry never gives.
    """
    u_c = np.atleast_1d(np.asarray(roll, dtype=float)) / tooth.r_b
    coarse = _involute_integrals(tooth, u_c, face_width, nodes)
    parts = [_involute_integrals(tooth, u_c, face_width, 2 * nodes)]  # the finer one is returned
    for a, ref in zip(coarse, parts[0]):
        err = float(np.max(np.abs(a - ref) / np.abs(ref)))
        if not err <= _SELF_CHECK:
            raise GearsymError(f"the potential-energy integrals of the {tooth.name} did not converge "
                               f"(relative change {err:.3g} from {nodes} to {2 * nodes} nodes)")
    if tooth.root_below_base:
        parts.append(_straight_part(tooth, u_c, face_width))
    bending, shear, axial = (sum(p[k] for p in parts) for k in range(3))
    return ToothCompliance(bending=np.asarray(bending), shear=np.asarray(shear), axial=np.asarray(axial),
                           fillet=_fillet(tooth, u_c, face_width))
