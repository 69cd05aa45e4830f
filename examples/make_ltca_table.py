"""Write ``models/ltca_pair_k.csv``: an LTCA-like mesh stiffness table over (mesh phase, load).

**What this is, honestly.**  Not a loaded tooth contact analysis.  It is the kind of table
an LTCA program gives -- the mesh stiffness over one mesh cycle at several transmitted
torques -- made here from gearsym's own potential-energy stiffness with a simple, stated load
dependence, so that the example model (``models/ltca_pair.toml``) has a plausible 2-D table
to read.  Replace the CSV by your LTCA output (same layout) and the model runs on it.

**The pair.**  26/39 teeth, module 4 mm, face width 30 mm, 20 deg, steel, standard rack
(contact ratio 1.665), with a linear **tip relief** on both gears: ``C_a = 25 um`` at the tip,
falling to 0 over the last quarter base pitch of each tooth's path of contact.

**The load dependence.**  Quasi-static load sharing of the tooth pairs in contact: at mesh
phase ``phi`` pair ``j`` has the stiffness ``k_j`` (``gearsym.gears.pair_stiffness``) and the
initial gap ``g_j`` (the relief of the two teeth at its contact point); under the force
``F = T/r_b1`` along the line of action the mesh deflects by ``delta``, with

    F = sum_j k_j * max(0, delta - g_j)

(a pair carries load once the deflection closes its gap), solved for ``delta`` at every phase;
the table holds the secant stiffness ``k(phi, T) = F / delta``.  At light load a relieved tip
carries little: the double-contact zones shrink and the stiffness varies more; at heavy load
the pairs share earlier and the variation flattens -- the trend LTCA shows for relieved gears.
The dynamic model uses ``k(phi, T) * f(x)`` as its mesh force (a secant stiffness at the mean
load: the gaps' own nonlinearity in the dynamic deflection is not modelled).

Layout: ``mesh_phase, T_1, T_2, ...`` (torques in N m in the header), then one row per phase
``k/64`` with the stiffness in N/m at each torque (``docs/spec.md``: tables).

Run: ``python examples/make_ltca_table.py [--out models/ltca_pair_k.csv] [--samples 64]``.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from gearsym.gears import Gear, GearPair, mesh_stiffness, pair_stiffness

ROOT = Path(__file__).resolve().parents[1]
PAIR = GearPair(module=4e-3, pinion=Gear(26), wheel=Gear(39), face_width=30e-3)
TORQUES = (50.0, 100.0, 200.0, 400.0, 700.0)      # N m on the pinion
RELIEF = 25e-6                                     # tip relief at the tip (m)
RELIEF_LENGTH = 0.25                               # over the last quarter base pitch of the path


def gaps(s: np.ndarray, eps: float) -> np.ndarray:
    """The initial gap of a pair at ``s`` base pitches from the start of contact: the wheel's tip relief
    near the start (the wheel's tip meets the pinion's root), the pinion's near the end."""
    near_start = np.clip(1 - s / RELIEF_LENGTH, 0, 1)
    near_end = np.clip(1 - (eps - s) / RELIEF_LENGTH, 0, 1)
    return RELIEF * (near_start + near_end)


def secant_stiffness(phase: float, torque: float, geometry) -> float:
    """``F / delta`` with ``F = sum_j k_j max(0, delta - g_j)`` at one phase."""
    eps = geometry.contact_ratio
    s = np.array([phase + j for j in range(int(eps) + 1) if phase + j <= eps])
    k = pair_stiffness(geometry, s).stiffness
    g = gaps(s, eps)
    force = torque / geometry.pinion.r_b

    def residual(delta: float) -> float:
        return float(np.sum(k * np.maximum(0.0, delta - g))) - force

    hi = g.min() + force / k.max() * 4 + 1e-9
    delta = brentq(residual, g.min(), hi, xtol=1e-18, rtol=1e-14)
    return force / delta


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "models" / "ltca_pair_k.csv"))
    ap.add_argument("--samples", type=int, default=64)
    a = ap.parse_args()
    geometry = mesh_stiffness(PAIR, samples=8).geometry
    phases = np.arange(a.samples) / a.samples
    table = np.array([[secant_stiffness(p, T, geometry) for T in TORQUES] for p in phases])
    with open(a.out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["mesh_phase", *(f"{T:g}" for T in TORQUES)])
        for p, row in zip(phases, table):
            w.writerow([repr(float(p)), *(f"{v:.10e}" for v in row)])
    print(f"wrote {a.out}: {a.samples} phases x {len(TORQUES)} torques; contact ratio {geometry.contact_ratio:.4f}")
    for T, col in zip(TORQUES, table.T):
        print(f"  T = {T:5.0f} N m: k = {col.min():.4g} .. {col.max():.4g} N/m, mean {col.mean():.4g}")


if __name__ == "__main__":
    main()
