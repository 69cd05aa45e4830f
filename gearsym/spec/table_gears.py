"""A table from gear geometry: ``[tables.NAME.gears]`` -> :func:`gearsym.gears.mesh_stiffness`.

"This pair, these gears": a model names the geometry and materials of a spur pair and its
mesh stiffness over the mesh cycle is computed when the model is read (the potential-energy
method of :mod:`gearsym.gears`), as the samples of a table over the mesh phase:

* ``samples`` equally spaced phases ``k/N`` (default 64) and **both sides of every jump**
  (a pair enters or leaves the contact at phase 0 and at the end of each contact zone): the
  knot of a jump is written twice, its value before and after, each evaluated (not
  interpolated) with the pairs in contact on that side;
* the closing sample at phase 1 holds the value at the end of the cycle (one pair fewer than
  at phase 0: the jump at the wrap).

So a ``linear`` or ``cubic`` table interpolates within the contact zones and jumps exactly
where the geometry does.  What the geometry gave (contact ratio, zones, the mean, ISO 6336's
``c'`` and ``c_gamma_alpha``) is kept with the table for ``gearsym inspect``.

Quantities with a dimension are strings with a unit (``"3 mm"``, ``"206 GPa"``, ``"20 deg"``);
per-gear entries take one value for both gears or ``[pinion, wheel]``.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from ..errors import GearsymError, SpecError
from .units import Unit, UnitSyntaxError, parse_unit

_QUANTITY = re.compile(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S.*)?")
_LENGTH = Unit(1.0, (0, 1, 0))
_PRESSURE = Unit(1.0, (1, -1, -2))
_TORQUE = Unit(1.0, (1, 2, -2))
_ONE = Unit(1.0, (0, 0, 0))

#: The keys of ``[tables.NAME.gears]``.
GEAR_KEYS = frozenset({"module", "teeth", "face_width", "pressure_angle", "profile_shift", "addendum", "dedendum",
                       "root_fillet", "youngs_modulus", "poisson", "bore_radius", "centre_distance", "samples",
                       "torque"})
#: Most samples per mesh cycle.
MAX_GEAR_SAMPLES = 1024


class _Reader:
    def __init__(self, file: str, table: str, tbl: dict[str, Any]):
        self.file = file
        self.base = f"tables.{table}.gears"
        self.tbl = tbl

    def error(self, key: str | None, msg: str) -> SpecError:
        return SpecError(msg, file=self.file, field=f"{self.base}.{key}" if key else self.base)

    def quantity(self, key: str, value: Any, want: Unit, what: str) -> float:
        """SI value of a quantity string with a unit (or a plain number for a dimensionless one)."""
        if key == "pressure_angle" and _bare_number(value):  # 20 would be 20 rad: say so, not "1145.92 deg"
            raise self.error(key, f"give {what} with its unit, e.g. \"{value} deg\" (a bare number would be "
                                  f"radians)")
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if want.dims != _ONE.dims:
                raise self.error(key, f"give {what} with its unit, e.g. \"{value} mm\"" if want == _LENGTH else
                                      f"give {what} with its unit")
            v = float(value)
        elif isinstance(value, str) and (m := _QUANTITY.fullmatch(value)) is not None:
            try:
                u = parse_unit(m.group(2) or "1")
            except UnitSyntaxError as exc:
                raise self.error(key, str(exc)) from None
            if not u.same_dimension(want):
                raise self.error(key, f"'{value}' is [{u.si_string()}], {what} is [{want.si_string()}]")
            v = float(m.group(1)) * u.scale
        else:
            raise self.error(key, f"expected {what} (a number with a unit such as \"3 mm\"), got {value!r:.40}")
        if not math.isfinite(v):
            raise self.error(key, f"{what} must be finite")
        return v

    def get(self, key: str, want: Unit, what: str, default: Any = None) -> float | None:
        return default if key not in self.tbl else self.quantity(key, self.tbl[key], want, what)

    def pair(self, key: str, want: Unit, what: str, default: Any) -> tuple[Any, Any]:
        if key not in self.tbl:
            return default, default
        v = self.tbl[key]
        if isinstance(v, list):
            if len(v) != 2:
                raise self.error(key, f"one value for both gears or two, [pinion, wheel]; got {len(v)}")
            return (self.quantity(f"{key}[0]", v[0], want, what), self.quantity(f"{key}[1]", v[1], want, what))
        q = self.quantity(key, v, want, what)
        return q, q


def _bare_number(value: Any) -> bool:
    """A number without a unit: a TOML number, or a string of one."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return True
    return isinstance(value, str) and (m := _QUANTITY.fullmatch(value)) is not None and not m.group(2)


def gear_table(file: str, table: str, tbl: Any) -> tuple[list[float], list[float], dict[str, Any]]:
    """The samples of a table from gear geometry (see the module docstring).

    Parameters
    ----------
    file
        The model file (for messages).
    table
        The table's name.
    tbl
        The ``[tables.NAME.gears]`` table.

    Returns
    -------
    x, values, info
        Mesh phases (cycles; jumps written twice, the closing sample 1 last), the stiffness
        there (N/m), and what the geometry gave (for ``inspect``).

    Raises
    ------
    SpecError
        Naming ``tables.NAME.gears`` and the key: a missing or malformed entry, a geometry
        :mod:`gearsym.gears` refuses (undercut, interference, contact ratio below 1, ...).
    """
    from ..gears import Gear, GearPair, mesh_stiffness, pair_stiffness

    if not isinstance(tbl, dict):
        raise SpecError(f"wrong type: expected a table, got {type(tbl).__name__}", file=file,
                        field=f"tables.{table}.gears")
    r = _Reader(file, table, tbl)
    for k in tbl:
        if k not in GEAR_KEYS:
            from .fields import unknown_key

            raise r.error(k, unknown_key(k, GEAR_KEYS))
    for k in ("module", "teeth", "face_width"):
        if k not in tbl:
            raise r.error(k, f"missing '{k}'")
    teeth = tbl["teeth"]
    if not (isinstance(teeth, list) and len(teeth) == 2 and all(isinstance(z, int) and not isinstance(z, bool)
                                                                   for z in teeth)):
        raise r.error("teeth", "expected [pinion, wheel] tooth numbers (integers)")
    samples = tbl.get("samples", 64)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 4 <= samples <= MAX_GEAR_SAMPLES:
        raise r.error("samples", f"expected an integer from 4 to {MAX_GEAR_SAMPLES}, got {samples!r:.40}")
    shift = r.pair("profile_shift", _ONE, "a profile shift coefficient", 0.0)
    add = r.pair("addendum", _ONE, "an addendum coefficient", 1.0)
    ded = r.pair("dedendum", _ONE, "a dedendum coefficient", 1.25)
    fil = r.pair("root_fillet", _ONE, "a root fillet coefficient", 0.38)
    E = r.pair("youngs_modulus", _PRESSURE, "Young's modulus", 2.06e11)
    nu = r.pair("poisson", _ONE, "Poisson's ratio", 0.3)
    bore = r.pair("bore_radius", _LENGTH, "a bore radius", None)
    module = r.get("module", _LENGTH, "the module")
    width = r.get("face_width", _LENGTH, "the face width")
    alpha = r.get("pressure_angle", _ONE, "the pressure angle", math.radians(20.0))
    torque = r.get("torque", _TORQUE, "the pinion torque")
    gears = [Gear(teeth[i], profile_shift=shift[i], addendum=add[i], dedendum=ded[i], root_fillet=fil[i],
                  youngs_modulus=E[i], poisson=nu[i], bore_radius=bore[i]) for i in range(2)]
    try:
        pair = GearPair(module=module, pinion=gears[0], wheel=gears[1], face_width=width,
                        pressure_angle_deg=math.degrees(alpha), centre_distance=r.get(
                            "centre_distance", _LENGTH, "the centre distance"))
        line_load = None
        if torque is not None:  # F_t / b in N/mm, F_t = T / r_1 (reference radius)
            line_load = abs(torque) / (module * teeth[0] / 2) / (width * 1e3)
        res = mesh_stiffness(pair, samples=samples, line_load=line_load)
        x, k = _samples(res, pair_stiffness)
    except GearsymError as exc:
        raise r.error(None, f"the gear geometry is refused: {exc}") from None
    info = {
        "method": "potential energy (gearsym.gears.mesh_stiffness)",
        "teeth": list(teeth), "module_m": module, "face_width_m": width, "pressure_angle_deg": math.degrees(alpha),
        "samples": samples, "contact_ratio": res.contact_ratio,
        "zones": [[a, b, n] for a, b, n in res.zones],
        "mean_N_per_m": res.mean, "min_N_per_m": res.minimum, "max_N_per_m": res.maximum,
        "iso6336_c_prime_N_per_m": res.iso.single_stiffness, "iso6336_c_gamma_N_per_m": res.iso.mesh_stiffness,
        "mean_over_iso_c_gamma": res.mean / res.iso.mesh_stiffness,
    }
    return x, k, info


def _samples(res, pair_stiffness) -> tuple[list[float], list[float]]:
    """Uniform samples plus both sides of every jump, each evaluated with its zone's pairs."""
    g = res.geometry
    eps = res.contact_ratio
    points: list[tuple[float, float]] = []
    for a, b, n in res.zones:
        inner = [float(p) for p in res.phase if a < p < b]
        phases = np.array([a, *inner, b])
        k = np.zeros(len(phases))
        for j in range(n):
            k += pair_stiffness(g, np.minimum(phases + j, eps)).stiffness
        points += list(zip(phases.tolist(), k.tolist()))
    x = [p for p, _ in points]
    v = [k for _, k in points]
    return x, v
