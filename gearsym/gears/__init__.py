"""Spur-gear mesh stiffness from the gear geometry: involute geometry, potential energy, ISO 6336.

A standalone numeric package (numpy only; the figure needs the ``plots`` extra):

* :mod:`~gearsym.gears.geometry`: the pair (:class:`Gear`, :class:`GearPair`), its involute
  geometry, contact ratio and path of contact (:func:`pair_geometry`), refusing pairs that
  cannot mesh (undercut, pointed teeth, interference, contact ratio below 1);
* :mod:`~gearsym.gears.energy`: Hertzian, bending, shear, axial and fillet-foundation
  compliances of a tooth pair by the potential-energy method;
* :mod:`~gearsym.gears.stiffness`: the mesh stiffness over one mesh cycle
  (:func:`mesh_stiffness` -> :class:`MeshStiffness`: phase in [0, 1) -> N/m, with metadata);
* :mod:`~gearsym.gears.iso6336`: ISO 6336-1 method B single stiffness c' and mesh stiffness
  c_gamma_alpha (:func:`iso6336_stiffness`);
* :mod:`~gearsym.gears.report`: a text summary and the figure (k over the cycle, the contact
  zones shaded, the ISO mean as a line).

Example::

    from gearsym.gears import Gear, GearPair, mesh_stiffness
    pair = GearPair(module=3e-3, pinion=Gear(50), wheel=Gear(50), face_width=20e-3)
    res = mesh_stiffness(pair, samples=256)
    res.phase, res.stiffness            # the table: mesh phase in [0, 1) -> N/m
    res.mean, res.iso.mesh_stiffness    # potential-energy mean, ISO 6336 c_gamma_alpha * b (N/m)
    res.to_csv("stiffness.csv")

The command line: ``gearsym stiffness --z1 50 --z2 50 --module 3mm --face-width 20mm``.
"""

from __future__ import annotations

from .energy import (
           SAINSOT_COEFFICIENTS,
           ToothCompliance,
           fillet_coefficients,
           hertz_stiffness,
           tooth_compliances,
)
from .geometry import Gear, GearPair, PairGeometry, ToothGeometry, involute, pair_geometry
from .iso6336 import ISO_C, IsoStiffness, iso6336_stiffness
from .stiffness import MeshStiffness, PairStiffness, mesh_stiffness, pair_stiffness

__all__ = ["ISO_C", "SAINSOT_COEFFICIENTS", "Gear", "GearPair", "IsoStiffness", "MeshStiffness", "PairGeometry",
           "PairStiffness", "ToothCompliance", "ToothGeometry", "fillet_coefficients", "hertz_stiffness",
           "involute", "iso6336_stiffness", "mesh_stiffness", "pair_geometry", "pair_stiffness",
           "tooth_compliances"]
