"""Planetary gear modes: the classification of Lin & Parker (1999).

For a planetary set with equally spaced planets (and isotropic bearings), Lin &
Parker (J. Vib. Acoust. 121, 1999) prove that every free-vibration mode is one of

* a **rotational** mode (simple): the central members (sun, ring, carrier) only
  rotate, every planet moves alike;
* a **translational** mode (multiplicity 2): the central members only translate;
* a **planet** mode (multiplicity N - 3, for N >= 4 planets): the central members
  are at rest;

with 6 rotational, 6 pairs of translational and 3 groups of planet modes:
``6 + 6*2 + 3*(N - 3) = 3*(N + 3)`` modes.

The classifier recognises a planetary model by its coordinate names (the layout of
``models/planetary_n*.toml``): ``x_M, y_M, u_M`` for the central members ``M`` in
``s`` (sun), ``r`` (ring), ``c`` (carrier) and ``zeta_n, eta_n, u_n`` for the
planets ``n = 1..N``.  It works on each group of equal frequencies as a whole (the
basis inside a repeated frequency is arbitrary): the kinetic-energy fractions of the
central translations and of the central rotations decide the type.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._modes import ModalAnalysis

__all__ = ["PlanetaryLayout", "classify_planetary", "planetary_layout", "MODE_TYPES"]

#: Mode types of Lin & Parker, and ``"mixed"`` for a mode that fits none (e.g. unequally
#: spaced planets).
MODE_TYPES = ("rotational", "translational", "planet", "mixed")

_CENTRAL = ("s", "r", "c")


@dataclass(frozen=True)
class PlanetaryLayout:
    """Indices of the coordinate groups of a planetary model.

    Attributes
    ----------
    n_planets : int
    central_translation : list of int
        ``x_s, y_s, x_r, y_r, x_c, y_c``.
    central_rotation : list of int
        ``u_s, u_r, u_c``.
    planets : list of list of int
        ``[zeta_n, eta_n, u_n]`` for n = 1..N.
    """

    n_planets: int
    central_translation: list[int]
    central_rotation: list[int]
    planets: list[list[int]]


def planetary_layout(names: Sequence[str]) -> PlanetaryLayout | None:
    """The layout of a planetary model from its coordinate names, or None if it is not one."""
    idx = {n: i for i, n in enumerate(names)}
    try:
        ct = [idx[f"{q}_{m}"] for m in _CENTRAL for q in "xy"]
        cr = [idx[f"u_{m}"] for m in _CENTRAL]
    except KeyError:
        return None
    planet_ids = sorted({int(m.group(1)) for n in names if (m := re.fullmatch(r"zeta_(\d+)", n))})
    N = len(planet_ids)
    if N == 0 or planet_ids != list(range(1, N + 1)):
        return None
    try:
        planets = [[idx[f"zeta_{n}"], idx[f"eta_{n}"], idx[f"u_{n}"]] for n in planet_ids]
    except KeyError:
        return None
    if len(names) != 9 + 3 * N:
        return None
    return PlanetaryLayout(N, ct, cr, planets)


def _group_type(e: np.ndarray, layout: PlanetaryLayout, tol: float) -> str:
    et = float(e[layout.central_translation].sum())
    er = float(e[layout.central_rotation].sum())
    if et <= tol and er <= tol:
        return "planet"
    if et <= tol:
        return "rotational"
    if er <= tol:
        return "translational"
    return "mixed"


def classify_planetary(result: ModalAnalysis, tol: float = 1e-8) -> ModalAnalysis:
    """Attach the Lin & Parker classification to a modal analysis of a planetary model.

    Parameters
    ----------
    result
        A :class:`~gearsym.analysis.linear.ModalAnalysis`; returned unchanged if its
        coordinates are not a planetary layout or the mass could not be recovered.
    tol
        Largest kinetic-energy fraction of the central translations (rotations) in a
        mode group that still counts as "at rest".

    Returns
    -------
    ModalAnalysis
        With ``classification`` (one type per mode) and ``info["structure"]``: the
        number of groups of each type, their multiplicities, and ``lin_parker`` (the
        counts 6 simple rotational, 6 double translational and 3 groups of N - 3 planet
        modes hold).
    """
    layout = planetary_layout(result.coordinate_names)
    if layout is None or not result.symmetric:
        return result
    types = [""] * result.n_modes
    counts = {t: 0 for t in MODE_TYPES}
    mults: dict[str, list[int]] = {t: [] for t in MODE_TYPES}
    for g in result.groups:
        kind = _group_type(result.energy_fractions(g), layout, tol)
        for i in g:
            types[i] = kind
        counts[kind] += 1
        mults[kind].append(len(g))
    N = layout.n_planets
    expected = {"rotational": [1] * 6, "translational": [2] * 6, "planet": [N - 3] * 3 if N > 3 else []}
    holds = all(mults[k] == v for k, v in expected.items()) and counts["mixed"] == 0
    structure = {"n_planets": N, "groups": counts, "multiplicities": mults, "lin_parker": bool(holds)}
    return dataclasses.replace(result, classification=types, info={**result.info, "structure": structure})
