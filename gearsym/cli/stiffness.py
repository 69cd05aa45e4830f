"""``gearsym stiffness``: the mesh stiffness of a spur pair from its geometry (potential energy, ISO 6336).

Registered by :mod:`gearsym.cli.parser`; the numbers come from :mod:`gearsym.gears`.
Lengths and moduli take a unit (``3mm``, ``0.003m``, ``206GPa``); a bare number is in the
option's default unit (mm for lengths, GPa for Young's modulus).  Per-gear options take one
value (both gears) or two, ``PINION,WHEEL``.
"""

from __future__ import annotations

import argparse
import math
import re

from ..errors import ParameterError
from .helptext import examples

__all__ = ["add_stiffness_parser", "cmd_stiffness"]

EXAMPLES = examples(
    ("gearsym stiffness --z1 50 --z2 50 --module 3 --face-width 20",
     "the 50/50-teeth pair of Yu et al. (Fig. 14): module 3 mm, face width 20 mm, 20 deg, steel"),
    ("gearsym stiffness --z1 19 --z2 48 --module 3.2mm --face-width 16mm --profile-shift 0.3,-0.1 --out tvms",
     "profile-shifted pair; writes tvms/stiffness.csv, stiffness.json and stiffness.png"),
    ("gearsym stiffness --z1 25 --z2 40 --module 2 --face-width 15 --youngs 206GPa,110GPa --poisson 0.3,0.34 "
     "--json", "steel pinion, bronze wheel; one JSON object on stdout"),
    note="Bad geometry exits 2 naming the parameter: undercut, a pointed tooth, interference, a tip hitting "
         "the mating root, a contact ratio below 1, a centre distance below the tight-mesh one.")

#: a number and what follows it (the unit)
_NUMBER = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:inf|nan))\s*(.*)$", re.IGNORECASE)

#: option -> (Gear field, kind, default unit)
_PER_GEAR = {
    "--profile-shift": ("profile_shift", "number", None),
    "--addendum": ("addendum", "number", None),
    "--dedendum": ("dedendum", "number", None),
    "--root-fillet": ("root_fillet", "number", None),
    "--youngs": ("youngs_modulus", "pressure", "GPa"),
    "--poisson": ("poisson", "number", None),
    "--bore": ("bore_radius", "length", "mm"),
}


def add_stiffness_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``stiffness`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "stiffness", help="mesh stiffness of a spur pair from its geometry (potential energy, ISO 6336)",
        description="Time-varying mesh stiffness of an external spur pair over one mesh cycle by the "
                    "potential-energy method (Hertzian contact, bending, shear, axial compression, fillet "
                    "foundation), the contact ratio and the single/double contact zones, and ISO 6336-1 "
                    "(method B) c' and c_gamma_alpha beside it.  Mesh phase 0: a tooth pair enters contact "
                    "(pinion driving).  Lengths take a unit (3mm, 0.02m; bare numbers are mm), Young's modulus "
                    "too (206GPa; bare numbers are GPa).  Per-gear options take one value for both gears or "
                    "PINION,WHEEL.",
        epilog=EXAMPLES)
    p.add_argument("--z1", type=int, required=True, help="pinion teeth (gear 1, driving)")
    p.add_argument("--z2", type=int, required=True, help="wheel teeth (gear 2)")
    p.add_argument("--module", required=True, metavar="LENGTH", help="module (mm unless a unit is given)")
    p.add_argument("--face-width", required=True, metavar="LENGTH", help="face width in contact (mm unless a unit "
                   "is given)")
    p.add_argument("--pressure-angle", type=float, default=20.0, metavar="DEG",
                   help="pressure angle of the basic rack in degrees (default 20)")
    p.add_argument("--centre-distance", metavar="LENGTH",
                   help="working centre distance (default: the tight-mesh one of the profile shifts)")
    p.add_argument("--profile-shift", metavar="X[,X2]", help="profile shift coefficients x1,x2 (default 0)")
    p.add_argument("--addendum", metavar="HA[,HA2]", help="addendum coefficients ha* (default 1)")
    p.add_argument("--dedendum", metavar="HF[,HF2]", help="dedendum coefficients hf* of the rack (default 1.25)")
    p.add_argument("--root-fillet", metavar="RHO[,RHO2]",
                   help="root fillet radius coefficients rho_f* of the rack (default 0.38)")
    p.add_argument("--youngs", metavar="E[,E2]", help="Young's modulus (GPa unless a unit is given; default 206)")
    p.add_argument("--poisson", metavar="NU[,NU2]", help="Poisson's ratio (default 0.3)")
    p.add_argument("--bore", metavar="R[,R2]", help="bore radius, for the fillet-foundation term (mm unless a unit "
                   "is given; default: half the root radius)")
    p.add_argument("--torque", metavar="N*M",
                   help="pinion torque (N m unless a unit is given: 340, '340 N*m', 0.34kN*m): sets ISO 6336's line load F_t/b (K_A = 1); below 100 N/mm it "
                        "lowers c' (default: at least 100 N/mm)")
    p.add_argument("--samples", type=int, default=256, help="phase samples over the mesh cycle (default 256)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--out", help="folder for stiffness.csv (phase -> N/m), stiffness.json and stiffness.png")
    p.set_defaults(func=cmd_stiffness)


_SI = {"torque": "N*m"}  # kinds beyond length and pressure: their SI unit
_EXAMPLE = {"length": "mm", "pressure": "GPa", "torque": "N*m"}


def _quantity(text: str, flag: str, kind: str, default_unit: str | None) -> float:
    """A number, with a unit of ``kind`` (length, pressure) or the default unit: SI value."""
    text = text.strip()
    if kind == "number":
        try:
            v = float(text)
        except ValueError:
            raise ParameterError(f"{flag}: '{text}' is not a number") from None
        if not math.isfinite(v):
            raise ParameterError(f"{flag}: non-finite value '{text}'")
        return v
    from ..spec.units import KNOWN_UNITS, UnitSyntaxError, parse_unit

    match = _NUMBER.match(text)
    try:
        if match is None:
            raise ValueError(text)
        v = float(match.group(1))
        unit = match.group(2).strip() or str(default_unit)
        u = parse_unit(unit)
    except (ValueError, UnitSyntaxError):
        raise ParameterError(f"{flag}: '{text}' is not a number with a unit (e.g. 3mm, 206GPa)") from None
    want = parse_unit(_SI[kind]) if kind in _SI else KNOWN_UNITS["m" if kind == "length" else "Pa"]
    if not u.same_dimension(want):
        raise ParameterError(f"{flag}: '{unit}' is not a unit of {kind} (e.g. {_EXAMPLE.get(kind, 'GPa')})")
    if not math.isfinite(v):
        raise ParameterError(f"{flag}: non-finite value '{text}'")
    return v * u.scale


def _per_gear(args: argparse.Namespace) -> tuple[dict[str, object], dict[str, object]]:
    """Gear keyword arguments of the pinion and the wheel from the per-gear options."""
    kw1: dict[str, object] = {}
    kw2: dict[str, object] = {}
    for flag, (name, kind, unit) in _PER_GEAR.items():
        text = getattr(args, flag.lstrip("-").replace("-", "_"))
        if text is None:
            continue
        items = text.split(",")
        if len(items) not in (1, 2):
            raise ParameterError(f"{flag}: expected one value (both gears) or two (PINION,WHEEL), got '{text}'")
        values = [_quantity(s, flag, kind, unit) for s in items]
        kw1[name], kw2[name] = values[0], values[-1]
    return kw1, kw2


def _pair(args: argparse.Namespace):
    from ..gears import Gear, GearPair

    kw1, kw2 = _per_gear(args)
    for flag in ("--youngs",):
        for v in (kw1.get("youngs_modulus"), kw2.get("youngs_modulus")):
            if v is not None and not 1e6 <= float(v) <= 1e13:  # type: ignore[arg-type]
                raise ParameterError(f"{flag}: {v:g} Pa is not a plausible Young's modulus (a bare number is in GPa)")
    centre = None if args.centre_distance is None else _quantity(args.centre_distance, "--centre-distance",
                                                                  "length", "mm")
    return GearPair(module=_quantity(args.module, "--module", "length", "mm"),
                    pinion=Gear(args.z1, **kw1), wheel=Gear(args.z2, **kw2),  # type: ignore[arg-type]
                    face_width=_quantity(args.face_width, "--face-width", "length", "mm"),
                    pressure_angle_deg=args.pressure_angle, centre_distance=centre)


def cmd_stiffness(args: argparse.Namespace) -> int:
    """Mesh stiffness of a spur pair from its geometry: print, ``--json``, ``--out`` (CSV, JSON, PNG)."""
    from ..budget import check_count

    check_count("--samples", args.samples, low=2)
    torque = None if args.torque is None else _quantity(args.torque, "--torque", "torque", "N*m")
    if torque is not None and not torque > 0:
        raise ParameterError(f"--torque must be positive and finite, got {args.torque}")
    if args.out:
        from ..extras import require
        from ..files import check_out_dir

        check_out_dir(args.out)
        require("plots", "gearsym stiffness --out (figure)")
    pair = _pair(args)

    from ..gears import mesh_stiffness, pair_geometry

    line_load = None
    if torque is not None:
        g = pair_geometry(pair)
        line_load = torque / g.pinion.r / (g.face_width * 1e3)  # F_t / b in N/mm
    res = mesh_stiffness(pair, samples=args.samples, line_load=line_load)
    files = _write(res, args.out) if args.out else []
    if args.json:
        from .checks import emit

        emit({**res.to_dict(), "line_load_N_per_mm": line_load, "files": [str(f) for f in files]})
    else:
        from ..gears.report import summary

        print(summary(res))
        for f in files:
            print(f"wrote {f}")
    return 0


def _write(res, out: str) -> list:
    from pathlib import Path

    from ..files import write_json
    from ..gears.report import plot_mesh_stiffness

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    return [res.to_csv(folder / "stiffness.csv"), write_json(folder / "stiffness.json", res.to_dict()),
            plot_mesh_stiffness(res, folder / "stiffness.png")]
