"""Involute geometry of an external spur gear pair cut by a rack (ISO 53 / ISO 21771 conventions).

Inputs are :class:`Gear` (per gear: teeth, profile shift, basic-rack coefficients,
material, bore) and :class:`GearPair` (module, pressure angle, face width, centre
distance).  :func:`pair_geometry` derives everything the stiffness needs and refuses a
pair that cannot mesh, naming the parameter (:class:`~gearsym.errors.ParameterError`).

Formulas (per gear, module :math:`m`, pressure angle :math:`\\alpha`, teeth :math:`z`,
profile shift :math:`x`, addendum / dedendum / root-fillet coefficients
:math:`h_a^*, h_f^*, \\rho_f^*` of the basic rack):

* reference, base, tip and root radii: :math:`r = mz/2`, :math:`r_b = r\\cos\\alpha`,
  :math:`r_a = r + (h_a^* + x)m`, :math:`r_f = r - (h_f^* - x)m`;
* half tooth angle on the base circle
  :math:`\\beta_b = \\pi/(2z) + 2x\\tan\\alpha/z + \\operatorname{inv}\\alpha`
  (:math:`\\operatorname{inv}\\alpha = \\tan\\alpha - \\alpha`); at radius :math:`r_y`
  with pressure angle :math:`\\alpha_y = \\arccos(r_b/r_y)` the half angle is
  :math:`\\psi_y = \\beta_b - \\operatorname{inv}\\alpha_y`, so the tip thickness is
  :math:`s_a = 2 r_a \\psi_a` (a pointed tooth has :math:`s_a \\le 0`);
* form circle (where the generated involute starts): the straight flank of the rack ends
  :math:`(h_f^* - \\rho_f^*(1-\\sin\\alpha) - x)m` below the rolling line, so the roll
  length of the form point is
  :math:`g_F = r\\sin\\alpha - (h_f^* - \\rho_f^*(1-\\sin\\alpha) - x)m/\\sin\\alpha`;
  :math:`g_F < 0` is undercut (the classical
  :math:`x_{min} = h_f^* - \\rho_f^*(1-\\sin\\alpha) - z\\sin^2\\alpha/2`);
* half angle of the generated tooth on the root circle (where the fillet meets it):
  the rack tip's flat has half width
  :math:`w = m[\\pi/4 - h_f^*\\tan\\alpha - \\rho_f^*(1-\\sin\\alpha)/\\cos\\alpha]`
  and generates the tooth space, so
  :math:`\\theta_f = [\\pi/2 + 2h_f^*\\tan\\alpha + 2\\rho_f^*(1-\\sin\\alpha)/\\cos\\alpha]/z`.

Pair: working pressure angle from
:math:`\\operatorname{inv}\\alpha_w = \\operatorname{inv}\\alpha + 2\\tan\\alpha\\,(x_1+x_2)/(z_1+z_2)`
and centre distance :math:`a_w = a\\cos\\alpha/\\cos\\alpha_w` (:math:`a = m(z_1+z_2)/2`), or
from a given :math:`a_w` (not below the tight-mesh distance) by
:math:`\\cos\\alpha_w = a\\cos\\alpha/a_w`.  On the line of action :math:`T_1T_2`
(length :math:`a_w\\sin\\alpha_w`) contact starts at :math:`A`, where the wheel's tip
circle cuts it, and ends at :math:`E`, on the pinion's tip circle:
:math:`T_1A = a_w\\sin\\alpha_w - \\sqrt{r_{a2}^2 - r_{b2}^2}`,
:math:`T_1E = \\sqrt{r_{a1}^2 - r_{b1}^2}`, and the transverse contact ratio is

.. math:: \\varepsilon_\\alpha = \\frac{\\sqrt{r_{a1}^2-r_{b1}^2} + \\sqrt{r_{a2}^2-r_{b2}^2}
          - a_w\\sin\\alpha_w}{\\pi m\\cos\\alpha}.

References: ISO 21771:2007 (cylindrical involute gears: geometry), ISO 53:1998 (basic
rack: :math:`h_a^* = 1`, :math:`h_f^* = 1.25`, :math:`\\rho_f^* = 0.38` for profile A).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from ..errors import ParameterError

__all__ = ["Gear", "GearPair", "PairGeometry", "ToothGeometry", "involute", "pair_geometry"]


def involute(alpha: float) -> float:
    """The involute function :math:`\\operatorname{inv}\\alpha = \\tan\\alpha - \\alpha`.

    Parameters
    ----------
    alpha
        Pressure angle (rad), in [0, pi/2).

    Returns
    -------
    float
        :math:`\\tan\\alpha - \\alpha`.
    """
    return math.tan(alpha) - alpha


def _inverse_involute(value: float) -> float:
    """The angle in (0, pi/2) whose involute is ``value`` > 0 (Newton on tan(a) - a, from Cheng's start)."""
    a = (3 * value) ** (1 / 3)  # inv(a) ~ a^3/3 for small a
    a = min(a, 1.5)
    for _ in range(60):
        t = math.tan(a)
        step = (t - a - value) / (t * t)
        a = min(max(a - step, 1e-12), math.pi / 2 - 1e-12)
        if abs(step) < 1e-16 * max(1.0, a):
            break
    return a


@dataclass(frozen=True)
class Gear:
    """One spur gear of a pair: tooth count, profile shift, basic rack, material, bore.

    Parameters
    ----------
    teeth
        Number of teeth :math:`z` (an integer >= 5).
    profile_shift
        Profile shift coefficient :math:`x` (multiples of the module; positive away from the centre).
    addendum
        Addendum coefficient :math:`h_a^*` (tip radius :math:`r_a = r + (h_a^* + x)m`); default 1.
    dedendum
        Dedendum coefficient :math:`h_f^*` of the basic rack (root radius
        :math:`r_f = r - (h_f^* - x)m`); default 1.25.
    root_fillet
        Root fillet radius coefficient :math:`\\rho_f^*` of the basic rack (the tip radius of
        the generating rack over the module); default 0.38 (ISO 53 profile A).  It sets the
        form circle (where the involute starts) and the root thickness.
    youngs_modulus
        Young's modulus :math:`E` (Pa); default 2.06e11.
    poisson
        Poisson's ratio :math:`\\nu`; default 0.3.
    bore_radius
        Radius :math:`r_{int}` of the bore (m), which the fillet-foundation term needs
        (:math:`h_f = r_f / r_{int}`); ``None`` (default) takes :math:`r_{int} = r_f/2`
        (:math:`h_f = 2`).
    """

    teeth: int
    profile_shift: float = 0.0
    addendum: float = 1.0
    dedendum: float = 1.25
    root_fillet: float = 0.38
    youngs_modulus: float = 2.06e11
    poisson: float = 0.3
    bore_radius: float | None = None


@dataclass(frozen=True)
class GearPair:
    """An external spur gear pair: the pinion (gear 1, driving) and the wheel (gear 2).

    Parameters
    ----------
    module
        Module :math:`m` (m), e.g. ``3e-3``.
    pinion
        Gear 1 (:class:`Gear`).
    wheel
        Gear 2 (:class:`Gear`).
    face_width
        Face width :math:`b` (m) in contact.
    pressure_angle_deg
        Pressure angle :math:`\\alpha` of the basic rack (degrees); default 20.
    centre_distance
        Working centre distance :math:`a_w` (m); ``None`` (default) takes the tight-mesh
        distance of the profile shifts.
    """

    module: float
    pinion: Gear
    wheel: Gear
    face_width: float
    pressure_angle_deg: float = 20.0
    centre_distance: float | None = None


@dataclass(frozen=True)
class ToothGeometry:
    """Derived geometry of one gear of a pair (lengths in m, angles in rad).

    Attributes
    ----------
    name
        ``"pinion"`` or ``"wheel"``.
    teeth, profile_shift
        :math:`z`, :math:`x`.
    r, r_b, r_a, r_f
        Reference, base, tip and root radii.
    r_form
        Form radius: the involute starts there (the fillet is below).
    beta_b
        Half tooth angle on the base circle, :math:`\\beta_b`.
    theta_f
        Half angle of the generated tooth on the root circle, :math:`\\theta_f`.
    tip_thickness
        Arc tooth thickness on the tip circle, :math:`s_a = 2 r_a \\psi_a`.
    roll_form
        Roll length :math:`g_F = \\sqrt{r_{form}^2 - r_b^2}` of the form point.
    youngs_modulus, poisson, bore_radius
        Material and bore (:math:`r_{int}`).
    """

    name: str
    teeth: int
    profile_shift: float
    r: float
    r_b: float
    r_a: float
    r_f: float
    r_form: float
    beta_b: float
    theta_f: float
    tip_thickness: float
    roll_form: float
    youngs_modulus: float
    poisson: float
    bore_radius: float

    @property
    def root_below_base(self) -> bool:
        """Whether the root circle lies inside the base circle (:math:`r_f < r_b`)."""
        return self.r_f < self.r_b


@dataclass(frozen=True)
class PairGeometry:
    """Derived geometry of a spur pair: both teeth, working pressure angle, path of contact.

    Attributes
    ----------
    pinion, wheel
        :class:`ToothGeometry` of gear 1 and gear 2.
    module, face_width
        :math:`m`, :math:`b` (m).
    alpha, alpha_w
        Pressure angle of the rack and working pressure angle (rad).
    a, a_w, a_w_tight
        Reference, working and tight-mesh (no backlash) centre distances (m).
    base_pitch
        :math:`p_b = \\pi m\\cos\\alpha` (m): the mesh cycle along the line of action.
    line_of_action
        :math:`T_1T_2 = a_w\\sin\\alpha_w` (m).
    start_roll, end_roll
        :math:`T_1A` and :math:`T_1E` (m): pinion roll lengths where contact starts and ends.
    contact_ratio
        :math:`\\varepsilon_\\alpha = (T_1E - T_1A)/p_b`.
    """

    pinion: ToothGeometry
    wheel: ToothGeometry
    module: float
    face_width: float
    alpha: float
    alpha_w: float
    a: float
    a_w: float
    a_w_tight: float
    base_pitch: float
    line_of_action: float
    start_roll: float
    end_roll: float
    contact_ratio: float

    @property
    def path_length(self) -> float:
        """Length :math:`AE` (m) of the path of contact."""
        return self.end_roll - self.start_roll

    def to_dict(self) -> dict[str, object]:
        """Plain numbers for JSON (lengths in m, angles in degrees where the key says ``_deg``).

        Returns
        -------
        dict
            Pair and per-gear quantities.
        """
        def tooth(t: ToothGeometry) -> dict[str, object]:
            return {"teeth": t.teeth, "profile_shift": t.profile_shift, "r": t.r, "r_b": t.r_b, "r_a": t.r_a,
                    "r_f": t.r_f, "r_form": t.r_form, "beta_b": t.beta_b, "theta_f": t.theta_f,
                    "tip_thickness": t.tip_thickness, "bore_radius": t.bore_radius,
                    "youngs_modulus": t.youngs_modulus, "poisson": t.poisson,
                    "tooth_model": "root below base circle" if t.root_below_base else "root above base circle"}

        return {"module": self.module, "face_width": self.face_width, "pressure_angle_deg": math.degrees(self.alpha),
                "working_pressure_angle_deg": math.degrees(self.alpha_w), "centre_distance": self.a_w,
                "tight_mesh_centre_distance": self.a_w_tight, "base_pitch": self.base_pitch,
                "path_of_contact": self.path_length, "contact_ratio": self.contact_ratio,
                "pinion": tooth(self.pinion), "wheel": tooth(self.wheel)}


# ------------------------------------------------------------------ checks of the inputs
def _finite(name: str, v: object, low: float | None = None, high: float | None = None,
            low_open: bool = True) -> float:
    try:
        f = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(f):
        raise ParameterError(f"{name} must be finite, got {f}")
    if low is not None and (f <= low if low_open else f < low):
        raise ParameterError(f"{name} must be {'>' if low_open else '>='} {low:g}, got {f:g}")
    if high is not None and f >= high:
        raise ParameterError(f"{name} must be < {high:g}, got {f:g}")
    return f


def _check_gear(g: Gear, i: int, alpha: float) -> None:
    label = "pinion" if i == 1 else "wheel"
    if isinstance(g.teeth, bool) or not isinstance(g.teeth, numbers.Integral) or not 5 <= g.teeth <= 100_000:
        raise ParameterError(f"z{i} ({label} teeth) must be an integer in [5, 100000], got {g.teeth!r}")
    _finite(f"x{i} ({label} profile shift)", g.profile_shift, -5.0, 5.0)
    _finite(f"ha{i} ({label} addendum coefficient)", g.addendum, 0.0, 5.0)
    hf = _finite(f"hf{i} ({label} dedendum coefficient)", g.dedendum, 0.0, 5.0)
    rho = _finite(f"rho_f{i} ({label} root fillet coefficient)", g.root_fillet, 0.0, 5.0, low_open=False)
    _finite(f"E{i} ({label} Young's modulus)", g.youngs_modulus, 0.0)
    _finite(f"nu{i} ({label} Poisson's ratio)", g.poisson, -1.0, 0.5)
    if g.bore_radius is not None:
        _finite(f"bore{i} ({label} bore radius)", g.bore_radius, 0.0)
    if rho * (1 - math.sin(alpha)) >= hf:
        raise ParameterError(f"rho_f{i}={rho:g} ({label} root fillet coefficient): the fillet does not fit in "
                             f"the dedendum hf{i}={hf:g} (need rho_f*(1 - sin(alpha)) < hf)")
    w = math.pi / 4 - hf * math.tan(alpha) - rho * (1 - math.sin(alpha)) / math.cos(alpha)
    if w < -1e-12:
        raise ParameterError(f"rho_f{i}={rho:g}, hf{i}={hf:g} ({label}): the generating rack's tip is pointed "
                             f"(its tip flat would be {2 * w:.3g} modules wide); reduce the root fillet or the "
                             f"dedendum")


def _check_pair(pair: GearPair) -> float:
    if not isinstance(pair, GearPair):
        raise ParameterError(f"expected a GearPair, got {type(pair).__name__}")
    _finite("module", pair.module, 0.0, 10.0)
    _finite("face_width", pair.face_width, 0.0, 100.0)
    alpha_deg = _finite("pressure_angle_deg", pair.pressure_angle_deg, 5.0, 45.0)
    alpha = math.radians(alpha_deg)
    for i, g in ((1, pair.pinion), (2, pair.wheel)):
        if not isinstance(g, Gear):
            raise ParameterError(f"{'pinion' if i == 1 else 'wheel'} must be a Gear, got {type(g).__name__}")
        _check_gear(g, i, alpha)
    if pair.centre_distance is not None:
        _finite("centre_distance", pair.centre_distance, 0.0)
    return alpha


# ------------------------------------------------------------------ one gear
def _tooth(g: Gear, i: int, m: float, alpha: float) -> ToothGeometry:
    label = "pinion" if i == 1 else "wheel"
    z, x = int(g.teeth), float(g.profile_shift)
    r = m * z / 2
    r_b = r * math.cos(alpha)
    r_a = r + (g.addendum + x) * m
    r_f = r - (g.dedendum - x) * m
    if r_f <= 0:
        raise ParameterError(f"hf{i}={g.dedendum:g}, x{i}={x:g} ({label}): the root radius "
                             f"r - (hf - x) m = {r_f:.4g} m is not positive")
    beta_b = math.pi / (2 * z) + 2 * x * math.tan(alpha) / z + involute(alpha)
    psi_a = beta_b - involute(math.acos(r_b / r_a))
    s_a = 2 * r_a * psi_a
    if s_a <= 0:
        raise ParameterError(f"x{i}={x:g}, ha{i}={g.addendum:g} ({label}, z{i}={z}): pointed tooth, the tip "
                             f"thickness is {s_a * 1e3:.4g} mm <= 0; reduce the profile shift or the addendum")
    flank_end = (g.dedendum - g.root_fillet * (1 - math.sin(alpha)) - x) * m  # below the rolling line
    roll_form = r * math.sin(alpha) - flank_end / math.sin(alpha)
    if roll_form < 0:
        x_min = g.dedendum - g.root_fillet * (1 - math.sin(alpha)) - z * math.sin(alpha) ** 2 / 2
        raise ParameterError(f"x{i}={x:g} ({label}, z{i}={z}): undercut, the generating rack cuts into the "
                             f"involute near the base circle; the profile shift must be >= {x_min:.4f} for "
                             f"{z} teeth (or use more teeth)")
    theta_f = (math.pi / 2 + 2 * g.dedendum * math.tan(alpha)
               + 2 * g.root_fillet * (1 - math.sin(alpha)) / math.cos(alpha)) / z
    bore = r_f / 2 if g.bore_radius is None else float(g.bore_radius)
    if bore >= r_f:
        raise ParameterError(f"bore{i}={bore:g} m ({label} bore radius) must be smaller than the root radius "
                             f"{r_f:.6g} m")
    return ToothGeometry(name=label, teeth=z, profile_shift=x, r=r, r_b=r_b, r_a=r_a, r_f=r_f,
                         r_form=math.hypot(r_b, roll_form), beta_b=beta_b, theta_f=theta_f, tip_thickness=s_a,
                         roll_form=roll_form, youngs_modulus=float(g.youngs_modulus), poisson=float(g.poisson),
                         bore_radius=bore)


# ------------------------------------------------------------------ the pair
def _working(pair: GearPair, alpha: float) -> tuple[float, float, float, float]:
    """``(a, a_w_tight, a_w, alpha_w)``."""
    z1, z2 = int(pair.pinion.teeth), int(pair.wheel.teeth)
    a = pair.module * (z1 + z2) / 2
    target = involute(alpha) + 2 * math.tan(alpha) * (pair.pinion.profile_shift + pair.wheel.profile_shift) / (z1 + z2)
    if target <= 0:
        raise ParameterError(f"x1 + x2 = {pair.pinion.profile_shift + pair.wheel.profile_shift:g}: the profile "
                             f"shifts leave no positive working pressure angle")
    alpha_tight = _inverse_involute(target)
    a_tight = a * math.cos(alpha) / math.cos(alpha_tight)
    if pair.centre_distance is None:
        return a, a_tight, a_tight, alpha_tight
    a_w = float(pair.centre_distance)
    if a_w < a_tight * (1 - 1e-12):
        raise ParameterError(f"centre_distance={a_w:.6g} m is below the tight-mesh distance {a_tight:.6g} m of "
                             f"these profile shifts: the teeth would interfere")
    return a, a_tight, a_w, math.acos(a * math.cos(alpha) / a_w)


def pair_geometry(pair: GearPair) -> PairGeometry:
    """The derived geometry of a spur pair, after checking that it can mesh.

    Parameters
    ----------
    pair
        The pair (:class:`GearPair`).

    Returns
    -------
    PairGeometry
        Radii, angles, path of contact and contact ratio.

    Raises
    ------
    ParameterError
        A parameter out of range, or a geometry that cannot work, naming the parameter:
        undercut, a pointed tooth, a centre distance below the tight-mesh one, a tip that
        hits the mating root (negative tip clearance), interference (the mating tip reaches
        below the form circle, into the fillet), a contact ratio below 1.
    """
    alpha = _check_pair(pair)
    m = float(pair.module)
    t1, t2 = _tooth(pair.pinion, 1, m, alpha), _tooth(pair.wheel, 2, m, alpha)
    a, a_tight, a_w, alpha_w = _working(pair, alpha)
    for i, (ta, tf) in enumerate(((t1, t2), (t2, t1)), start=1):
        clearance = a_w - ta.r_a - tf.r_f
        if clearance < 0:
            j = 3 - i
            raise ParameterError(f"ha{i}={(pair.pinion, pair.wheel)[i - 1].addendum:g}, x1 + x2 = "
                                 f"{t1.profile_shift + t2.profile_shift:g}: the tip of gear {i} hits the root of "
                                 f"gear {j} (tip clearance {clearance * 1e3:.4g} mm); shorten the tip (ha{i}) or "
                                 f"increase the centre distance")
    line = a_w * math.sin(alpha_w)
    start = line - math.sqrt(t2.r_a ** 2 - t2.r_b ** 2)  # T1A
    end = math.sqrt(t1.r_a ** 2 - t1.r_b ** 2)  # T1E
    if start < t1.roll_form:
        raise ParameterError(f"interference: the wheel's tip (ha2={pair.wheel.addendum:g}, x2="
                             f"{t2.profile_shift:g}) reaches the pinion below its form circle "
                             f"(roll length {start * 1e3:.4g} mm < {t1.roll_form * 1e3:.4g} mm, z1={t1.teeth}, "
                             f"x1={t1.profile_shift:g}); shorten the wheel's tip or shift the pinion's profile")
    if line - end < t2.roll_form:
        raise ParameterError(f"interference: the pinion's tip (ha1={pair.pinion.addendum:g}, x1="
                             f"{t1.profile_shift:g}) reaches the wheel below its form circle "
                             f"(roll length {(line - end) * 1e3:.4g} mm < {t2.roll_form * 1e3:.4g} mm, "
                             f"z2={t2.teeth}, x2={t2.profile_shift:g}); shorten the pinion's tip or shift the "
                             f"wheel's profile")
    p_b = math.pi * m * math.cos(alpha)
    eps = (end - start) / p_b
    if eps < 1:
        raise ParameterError(f"contact ratio {eps:.4f} < 1 (z1={t1.teeth}, z2={t2.teeth}, ha1="
                             f"{pair.pinion.addendum:g}, ha2={pair.wheel.addendum:g}, centre_distance="
                             f"{a_w:.6g} m): the pair loses contact once per tooth")
    return PairGeometry(pinion=t1, wheel=t2, module=m, face_width=float(pair.face_width), alpha=alpha,
                        alpha_w=alpha_w, a=a, a_w=a_w, a_w_tight=a_tight, base_pitch=p_b, line_of_action=line,
                        start_roll=start, end_roll=end, contact_ratio=eps)
