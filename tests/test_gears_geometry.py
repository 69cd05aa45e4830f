"""Spur-pair geometry (issue 27 item 3): contact ratio and working pressure angle from their closed
forms, ISO 6336-1 method B from the standard's formulas (written here), and bad geometry refused
with a message naming the parameter."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from gearsym.errors import ParameterError
from gearsym.gears import Gear, GearPair, iso6336_stiffness, mesh_stiffness, pair_geometry


def inv(a: float) -> float:
    return math.tan(a) - a


def pair(z1=30, z2=50, x1=0.0, x2=0.0, m=3e-3, b=20e-3, alpha=20.0, a_w=None, **gear):
    if alpha > 20:  # a smaller tip radius of the rack: 0.38 m does not fit a 25 deg rack's tip
        gear.setdefault("root_fillet", 0.2)
    return GearPair(module=m, face_width=b, pressure_angle_deg=alpha, centre_distance=a_w,
                    pinion=Gear(z1, profile_shift=x1, **gear), wheel=Gear(z2, profile_shift=x2, **gear))


def closed_form_eps(z1, z2, x1, x2, m, alpha_deg, a_w=None, ha=1.0):
    al = math.radians(alpha_deg)
    r1, r2 = m * z1 / 2, m * z2 / 2
    rb1, rb2 = r1 * math.cos(al), r2 * math.cos(al)
    ra1, ra2 = r1 + (ha + x1) * m, r2 + (ha + x2) * m
    if a_w is None:
        target = inv(al) + 2 * math.tan(al) * (x1 + x2) / (z1 + z2)
        lo, hi = 1e-6, 1.5
        for _ in range(200):  # bisection: independent of the module's Newton
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if inv(mid) < target else (lo, mid)
        alw = (lo + hi) / 2
        a_w = (r1 + r2) * math.cos(al) / math.cos(alw)
    else:
        alw = math.acos((r1 + r2) * math.cos(al) / a_w)
    eps = (math.sqrt(ra1 ** 2 - rb1 ** 2) + math.sqrt(ra2 ** 2 - rb2 ** 2) - a_w * math.sin(alw)) / (
        math.pi * m * math.cos(al))
    return eps, alw, a_w


@pytest.mark.parametrize("z1, z2, x1, x2, alpha, a_w", [
    (50, 50, 0.0, 0.0, 20.0, None),
    (19, 48, 0.3, -0.1, 20.0, None),
    (25, 40, 0.5, 0.2, 20.0, None),
    (30, 50, 0.0, 0.0, 20.0, 0.121),  # opened centre distance (backlash)
    (22, 61, 0.1, 0.0, 25.0, None),
])
def test_contact_ratio_and_working_pressure_angle_are_the_closed_forms(z1, z2, x1, x2, alpha, a_w):
    g = pair_geometry(pair(z1, z2, x1, x2, alpha=alpha, a_w=a_w))
    eps, alw, aw = closed_form_eps(z1, z2, x1, x2, 3e-3, alpha, a_w)
    assert g.contact_ratio == pytest.approx(eps, rel=1e-12)
    assert g.alpha_w == pytest.approx(alw, rel=1e-12)
    assert g.a_w == pytest.approx(aw, rel=1e-12)
    assert g.path_length == pytest.approx(eps * math.pi * 3e-3 * math.cos(math.radians(alpha)), rel=1e-12)


def test_numpy_integers_are_tooth_numbers():
    import numpy as np

    g = pair_geometry(GearPair(module=3e-3, face_width=0.02, pinion=Gear(np.int64(50)), wheel=Gear(np.int32(50))))
    assert g.contact_ratio == pair_geometry(pair(50, 50)).contact_ratio and type(g.pinion.teeth) is int


def test_the_undercut_limit_is_the_classical_one():
    # x_min = hf - rho (1 - sin a) - z sin^2 a / 2 for the rack 1 / 1.25 / 0.38
    al = math.radians(20)
    x_min = 1.25 - 0.38 * (1 - math.sin(al)) - 14 * math.sin(al) ** 2 / 2
    with pytest.raises(ParameterError, match=r"x1=.*\(pinion, z1=14\): undercut.*>= 0\.1811"):
        pair_geometry(pair(14, 60, x1=x_min - 1e-6))
    g = pair_geometry(pair(14, 60, x1=x_min + 1e-6))
    assert g.pinion.r_form == pytest.approx(g.pinion.r_b, rel=1e-6)  # the involute starts at the base circle
    with pytest.raises(ParameterError, match="undercut"):
        pair_geometry(pair(17, 50))
    pair_geometry(pair(18, 50))


@pytest.mark.parametrize("p, needles", [
    (pair(12, 50, x1=1.5), ["x1=1.5", "pointed tooth", "tip thickness"]),
    (pair(30, 50, addendum=0.4), ["contact ratio 0.", "< 1", "ha1=0.4"]),
    (pair(30, 50, x1=0.8, x2=0.8), ["interference", "wheel's tip", "form circle", "x1=0.8"]),
    (pair(30, 50, addendum=1.3), ["ha1=1.3", "tip of gear 1 hits the root of gear 2"]),
    (pair(30, 50, a_w=0.119), ["centre_distance=0.119", "tight-mesh"]),
    (pair(30, 50, bore_radius=0.05), ["bore1=0.05", "root radius"]),
    (pair(30, 50, m=float("nan")), ["module must be finite"]),
    (pair(30, 50, b=-1.0), ["face_width must be > 0"]),
    (pair(30, 50, alpha=50.0), ["pressure_angle_deg must be < 45"]),
    (pair(30, 50, poisson=0.5), ["nu1", "Poisson", "< 0.5"]),
    (pair(30, 50, youngs_modulus=0.0), ["E1", "Young's modulus", "> 0"]),
    (pair(30, 50, root_fillet=0.6), ["rho_f1=0.6", "rack's tip is pointed"]),
    (GearPair(module=3e-3, face_width=0.02, pinion=Gear(30.5), wheel=Gear(50)), ["z1", "integer", "30.5"]),
    (GearPair(module=3e-3, face_width=0.02, pinion=Gear(True), wheel=Gear(50)), ["z1", "integer"]),
])
def test_bad_geometry_names_the_parameter(p, needles):
    with pytest.raises(ParameterError) as info:
        mesh_stiffness(p, samples=8)
    for n in needles:
        assert n in str(info.value), (n, str(info.value))


# ------------------------------------------------------------------ ISO 6336-1 method B
def iso_reference(z1, z2, x1, x2, alpha_deg, eps, b_m, hf=1.25, line_load=None, e=206e9):
    """ISO 6336-1:2006 clause 9.3 (method B), spur gears, solid discs: written from the standard."""
    q = (0.04723 + 0.15551 / z1 + 0.25791 / z2 - 0.00635 * x1 - 0.11654 * x1 / z1 - 0.00193 * x2
         - 0.24188 * x2 / z2 + 0.00529 * x1 ** 2 + 0.00182 * x2 ** 2)  # mm um / N
    c_th = 1 / q  # N / (mm um)
    c_m, c_r = 0.8, 1.0
    c_b = (1 + 0.5 * (1.2 - hf)) * (1 - 0.02 * (20 - alpha_deg))
    c = c_th * c_m * c_r * c_b * math.cos(0.0) * e / 206e9
    if line_load is not None and line_load < 100:
        c *= (line_load / 100) ** 0.25
    c_gamma = c * (0.75 * eps + 0.25)
    b_mm = b_m * 1e3
    return q, c, c_gamma, c * b_mm * 1e6, c_gamma * b_mm * 1e6  # N/(mm um) * mm = N/um = 1e6 N/m


@pytest.mark.parametrize("z1, z2, x1, x2, alpha, hf, line_load", [
    (50, 50, 0.0, 0.0, 20.0, 1.25, None),
    (19, 48, 0.3, -0.1, 20.0, 1.25, None),
    (22, 61, 0.1, 0.0, 25.0, 1.4, 40.0),
    (30, 50, 0.2, 0.1, 20.0, 1.25, 150.0),
])
def test_iso6336_equals_the_standard(z1, z2, x1, x2, alpha, hf, line_load):
    g = pair_geometry(pair(z1, z2, x1, x2, alpha=alpha, dedendum=hf))
    iso = iso6336_stiffness(g, line_load=line_load)
    q, c, c_gamma, k_single, k_mesh = iso_reference(z1, z2, x1, x2, alpha, g.contact_ratio, 20e-3, hf, line_load)
    assert iso.q_prime == pytest.approx(q, rel=1e-14)
    assert iso.c_prime == pytest.approx(c, rel=1e-13)
    assert iso.c_gamma_alpha == pytest.approx(c_gamma, rel=1e-13)
    assert iso.single_stiffness == pytest.approx(k_single, rel=1e-13)
    assert iso.mesh_stiffness == pytest.approx(k_mesh, rel=1e-13)


def test_iso6336_yu_pair_by_hand():
    # q' = 0.04723 + 0.15551/50 + 0.25791/50 = 0.0554984; c' = 0.8 * 0.975 / q' = 14.0545 N/(mm um)
    res = mesh_stiffness(pair(50, 50), samples=8)
    assert res.iso.q_prime == pytest.approx(0.0554984, rel=1e-12)
    assert res.iso.c_prime == pytest.approx(0.8 * 0.975 / 0.0554984, rel=1e-12)
    assert res.iso.mesh_stiffness == pytest.approx(0.8 * 0.975 / 0.0554984 * (0.75 * res.contact_ratio + 0.25)
                                                   * 20 * 1e6, rel=1e-12)


def test_the_package_is_base_layer_numpy_only():
    """gearsym.gears imports no sympy, no spec, no engine (its own modules, numpy, scipy, matplotlib lazily)."""
    root = Path(__file__).resolve().parents[1] / "gearsym" / "gears"
    for f in root.glob("*.py"):
        tree = ast.parse(f.read_text(encoding="utf-8"))
        mods = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
        mods += [("." * n.level) + (n.module or "") for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
        bad = [m for m in mods if m.split(".")[0] in ("sympy", "casadi") or m.lstrip(".").split(".")[0]
               in ("spec", "symbolic", "codegen", "engine", "system", "analysis", "facade", "cli")]
        assert bad == [], (f.name, bad)


@pytest.mark.parametrize("name", [n for n in __import__("gearsym.gears", fromlist=["__all__"]).__all__])
def test_public_names_have_complete_docstrings(name):
    """numpydoc's validator on gearsym.gears.__all__, as tests/test_docstrings.py does for gearsym.__all__."""
    import inspect

    from numpydoc.docscrape import NumpyDocString
    from numpydoc.validate import validate

    import gearsym.gears as gears

    obj = getattr(gears, name)
    if not callable(obj):
        return  # a table of coefficients: documented by its #: comment
    assert inspect.getdoc(obj), name
    checks = {"GL08", "PR01", "PR02", "RT01"}
    if inspect.isclass(obj):
        doc = NumpyDocString(inspect.getdoc(obj))
        documented = {n.strip() for p in doc["Parameters"] + doc["Attributes"] for n in p.name.split(",")}
        missing = [p for p in inspect.signature(obj).parameters if p not in documented]
        assert missing == [], (name, missing)
        for attr, value in vars(obj).items():
            if attr.startswith("_"):
                continue
            if isinstance(value, property):
                assert (value.__doc__ or "").strip(), f"{name}.{attr}"
            elif inspect.isfunction(value):
                errs = [e for e in validate(f"{obj.__module__}.{obj.__qualname__}.{attr}")["errors"] if e[0] in checks]
                assert errs == [], (name, attr, errs)
    else:
        errs = [e for e in validate(f"{obj.__module__}.{obj.__qualname__}")["errors"] if e[0] in checks]
        assert errs == [], (name, errs)
