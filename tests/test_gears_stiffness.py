"""Mesh stiffness from gear geometry (issue 27 item 3) against an independent evaluation of the
potential-energy integrals.

The reference is written here from the formulas, with mpmath quadrature (tanh-sinh, 25 digits),
in another variable than the module: the module integrates over the involute's roll angle
with closed forms of x, h and dx; here the tooth is parametrised by the radius r,

    psi(r) = beta_b - inv(arccos(r_b / r)),  x(r) = r cos psi,  h(r) = r sin psi,
    dx/dr = cos psi - r sin psi psi'(r),     psi'(r) = -sqrt(r^2 - r_b^2) / (r r_b),

the force angle at the contact radius r_c is tau_c = arccos(r_b / r_c) - psi(r_c), the straight
part below the base circle is integrated numerically too, and the geometry (radii, half
angles, start of contact, contact ratio) is recomputed from its textbook definitions.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest

from gearsym.gears import Gear, GearPair, mesh_stiffness, pair_geometry, pair_stiffness

mp.mp.dps = 25

#: Sainsot, Velex & Duverger (2004), Table 1 (rows L*, M*, P*, Q*; columns A..F)
SAINSOT = [
    (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
]

#: the pair Yu et al. compare with in their Fig. 14: 50/50 teeth, m = 3 mm, 20 deg, b = 20 mm,
#: E = 2.06e5 N/mm^2 (their Table 2), nu = 0.3; both roots above the base circle
YU = GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3)
#: profile-shifted, two materials, given bores: the pinion's root is below its base circle
#: (straight part), the wheel's above; the working pressure angle is not 20 deg
MIXED = GearPair(module=3.2e-3, face_width=16e-3,
                 pinion=Gear(19, profile_shift=0.3, youngs_modulus=2.1e11, poisson=0.29, bore_radius=0.012),
                 wheel=Gear(48, profile_shift=-0.1, youngs_modulus=1.1e11, poisson=0.34, bore_radius=0.03))


def inv(a):
    return mp.tan(a) - a


class Ref:
    """The reference evaluation of one pair, in mpmath."""

    def __init__(self, pair: GearPair):
        self.pair = pair
        m, al = mp.mpf(pair.module), mp.radians(pair.pressure_angle_deg)
        self.m, self.al, self.b = m, al, mp.mpf(pair.face_width)
        self.gears = [self._gear(g, m, al) for g in (pair.pinion, pair.wheel)]
        z1, z2 = pair.pinion.teeth, pair.wheel.teeth
        x1, x2 = pair.pinion.profile_shift, pair.wheel.profile_shift
        target = inv(al) + 2 * mp.tan(al) * (x1 + x2) / (z1 + z2)
        self.alw = mp.findroot(lambda a: inv(a) - target, al)
        self.aw = m * (z1 + z2) / 2 * mp.cos(al) / mp.cos(self.alw)
        g1, g2 = self.gears
        self.pb = mp.pi * m * mp.cos(al)
        self.line = self.aw * mp.sin(self.alw)
        self.eps = (mp.sqrt(g1["ra"] ** 2 - g1["rb"] ** 2) + mp.sqrt(g2["ra"] ** 2 - g2["rb"] ** 2)
                    - self.aw * mp.sin(self.alw)) / (mp.pi * m * mp.cos(al))
        self.start = self.line - mp.sqrt(g2["ra"] ** 2 - g2["rb"] ** 2)

    @staticmethod
    def _gear(g: Gear, m, al) -> dict:
        z, x = g.teeth, mp.mpf(g.profile_shift)
        r = m * z / 2
        rf = r - (mp.mpf(g.dedendum) - x) * m
        hf, rho = mp.mpf(g.dedendum), mp.mpf(g.root_fillet)
        return {"z": z, "r": r, "rb": r * mp.cos(al), "ra": r + (mp.mpf(g.addendum) + x) * m, "rf": rf,
                "beta": mp.pi / (2 * z) + 2 * x * mp.tan(al) / z + inv(al),
                # the rack's tip flat (half width pi m/4 - hf m tan(al) - rho m (1 - sin al)/cos al) cuts the space
                "theta_f": (mp.pi / 2 + 2 * hf * mp.tan(al) + 2 * rho * (1 - mp.sin(al)) / mp.cos(al)) / z,
                "E": mp.mpf(g.youngs_modulus), "nu": mp.mpf(g.poisson),
                "bore": rf / 2 if g.bore_radius is None else mp.mpf(g.bore_radius)}

    def tooth(self, g: dict, rc) -> dict:
        """Compliances of one tooth loaded at the contact radius rc."""
        rb, beta, E, b = g["rb"], g["beta"], g["E"], self.b
        G = E / (2 * (1 + g["nu"]))

        def psi(r):
            return beta - inv(mp.acos(rb / r))

        def dx(r):
            p = psi(r)
            return mp.cos(p) - r * mp.sin(p) * (-mp.sqrt(r * r - rb * rb) / (r * rb))

        tau = mp.acos(rb / rc) - psi(rc)
        xc, hc = rc * mp.cos(psi(rc)), rc * mp.sin(psi(rc))
        ct, st = mp.cos(tau), mp.sin(tau)

        def parts(x, h, dxdr):  # integrands per unit of the integration variable
            moment = (xc - x) * ct - hc * st
            return (moment ** 2 / (E * mp.mpf(2) / 3 * h ** 3 * b) * dxdr, 1.2 * ct ** 2 / (G * 2 * h * b) * dxdr,
                    st ** 2 / (E * 2 * h * b) * dxdr)

        r0 = max(g["rf"], rb)
        out = [mp.quad(lambda r, k=k: parts(r * mp.cos(psi(r)), r * mp.sin(psi(r)), dx(r))[k], [r0, rc])
               for k in range(3)]
        if g["rf"] < rb:  # straight part of half thickness r_b sin(beta) from the root circle to the base circle
            hb = rb * mp.sin(beta)
            x0, x1 = g["rf"] * mp.cos(mp.asin(hb / g["rf"])), rb * mp.cos(beta)
            for k in range(3):
                out[k] += mp.quad(lambda x, k=k: parts(x, hb, 1)[k], [x0, x1])
        hf_ratio, tf = g["rf"] / g["bore"], g["theta_f"]
        L, M, P, Q = (A / tf ** 2 + B * hf_ratio ** 2 + C * hf_ratio / tf + D / tf + Ei * hf_ratio + F
                      for A, B, C, D, Ei, F in SAINSOT)
        ratio = (xc - g["rf"]) / (2 * g["rf"] * tf)
        fillet = ct ** 2 / (E * b) * (L * ratio ** 2 + M * ratio + P * (1 + Q * mp.tan(tau) ** 2))
        return {"bending": out[0], "shear": out[1], "axial": out[2], "fillet": fillet}

    def hertz(self):
        g1, g2 = self.gears
        return 1 / (mp.pi * self.b / (2 * ((1 - g1["nu"] ** 2) / g1["E"] + (1 - g2["nu"] ** 2) / g2["E"])))

    def pair_k(self, s) -> mp.mpf:
        """Stiffness of one pair at s (base pitches) from the start of contact."""
        g1, g2 = self.gears
        roll1 = self.start + s * self.pb
        roll2 = self.line - roll1
        c1 = self.tooth(g1, mp.sqrt(g1["rb"] ** 2 + roll1 ** 2))
        c2 = self.tooth(g2, mp.sqrt(g2["rb"] ** 2 + roll2 ** 2))
        return 1 / (self.hertz() + sum(c1.values()) + sum(c2.values()))

    def mesh(self, phase: float) -> mp.mpf:
        return sum(self.pair_k(phase + j) for j in range(3) if phase + j <= self.eps)


@pytest.fixture(scope="module", params=[YU, MIXED], ids=["yu_50_50", "shifted_mixed"])
def case(request):
    return request.param, Ref(request.param), mesh_stiffness(request.param, samples=40)


def test_the_tooth_models_cover_both_roots():
    g = pair_geometry(MIXED)
    assert g.pinion.r_f < g.pinion.r_b and g.wheel.r_f > g.wheel.r_b  # straight part / involute from the root
    y = pair_geometry(YU)
    assert y.pinion.r_f > y.pinion.r_b


def test_contact_ratio_is_the_closed_form(case):
    pair, ref, res = case
    assert res.contact_ratio == pytest.approx(float(ref.eps), rel=1e-13)
    eps = float(ref.eps)
    assert [n for _, _, n in res.zones] == [2, 1]
    assert [v for a, b, _ in res.zones for v in (a, b)] == pytest.approx([0.0, eps - 1, eps - 1, 1.0], rel=1e-13)
    assert np.array_equal(res.pairs_in_contact, np.where(res.phase <= eps - 1, 2, 1))


def test_mesh_stiffness_equals_the_mpmath_integrals(case):
    pair, ref, res = case
    for i in (0, 7, 25, 31, 39):  # double contact, near its end, single contact
        want = float(ref.mesh(mp.mpf(i) / 40))
        assert res.stiffness[i] == pytest.approx(want, rel=1e-8), i


def test_each_compliance_equals_the_mpmath_integral(case):
    pair, ref, res = case
    pos = np.array([0.0, 0.6, float(ref.eps)])  # start of contact, inside, end of contact
    ps = pair_stiffness(res.geometry, pos)
    assert ps.hertz == pytest.approx(float(ref.hertz()), rel=1e-12)
    for i, s in enumerate(pos):
        roll1 = ref.start + mp.mpf(s) * ref.pb
        for g, ours, roll in ((ref.gears[0], ps.pinion, roll1), (ref.gears[1], ps.wheel, ref.line - roll1)):
            want = ref.tooth(g, mp.sqrt(g["rb"] ** 2 + roll ** 2))
            for name in ("bending", "shear", "axial", "fillet"):
                assert getattr(ours, name)[i] == pytest.approx(float(want[name]), rel=1e-8), (name, s)


def test_hertz_of_one_material_is_the_textbook_form():
    ps = pair_stiffness(pair_geometry(YU), np.array([0.5]))
    assert 1 / ps.hertz == pytest.approx(math.pi * 2.06e11 * 20e-3 / (4 * (1 - 0.3 ** 2)), rel=1e-14)


def test_mean_is_the_integral_over_the_cycle(case):
    from scipy.integrate import quad

    pair, ref, res = case
    eps = res.contact_ratio
    total = sum(quad(lambda p: float(res.at(p)[0]), a, b, epsabs=0, epsrel=1e-12)[0] for a, b, _ in res.zones)
    assert res.mean == pytest.approx(total, rel=1e-10)
    assert eps - 1 == pytest.approx(res.zones[0][1])


def test_at_wraps_and_is_exact_at_the_jump(case):
    pair, ref, res = case
    eps = res.contact_ratio
    jump = eps - 1
    left, right = res.at([jump, np.nextafter(jump, 1.0)])
    # two pairs up to and at the jump: one there, one at the end of the path of contact
    assert left == pytest.approx(float(ref.pair_k(mp.mpf(jump)) + ref.pair_k(ref.eps)), rel=1e-8)
    assert right < 0.8 * left  # one pair just after it
    assert np.allclose(res.at(res.phase + 3.0), res.stiffness, rtol=1e-12, atol=0)  # periodic


def test_yu_pair_potential_energy_mean_beside_iso():
    """The numbers docs/gears.md and the module docstring state for Yu et al.'s Fig. 14 pair."""
    res = mesh_stiffness(YU, samples=64)
    assert res.contact_ratio == pytest.approx(1.754673, abs=1e-6)
    assert res.mean == pytest.approx(4.3901e8, rel=1e-4)
    assert res.iso.mesh_stiffness == pytest.approx(4.4019e8, rel=1e-4)
    assert res.mean / res.iso.mesh_stiffness == pytest.approx(0.9973, abs=1e-4)
    assert (res.minimum, res.maximum) == pytest.approx((2.7702e8, 4.9993e8), rel=1e-4)


def test_high_contact_ratio_has_three_pair_zones():
    """A contact ratio above 2 (long addenda, 15 deg): three pairs on [0, eps - 2], two after; the mesh
    stiffness is the sum of the pairs at s = phase + j (pair_stiffness, checked against mpmath above)."""
    p = GearPair(module=2e-3, pressure_angle_deg=15, face_width=0.02,
                 pinion=Gear(60, addendum=1.3, dedendum=1.55, root_fillet=0.3),
                 wheel=Gear(80, addendum=1.3, dedendum=1.55, root_fillet=0.3))
    res = mesh_stiffness(p, samples=16)
    eps = res.contact_ratio
    assert 2 < eps < 3
    assert [n for _, _, n in res.zones] == [3, 2] and res.jumps == pytest.approx((0.0, eps - 2))
    for i, ph in enumerate(res.phase):
        pos = [ph + j for j in range(3) if ph + j <= eps]
        assert res.pairs_in_contact[i] == len(pos)
        assert res.stiffness[i] == pytest.approx(pair_stiffness(res.geometry, np.array(pos)).stiffness.sum(), rel=1e-14)
