"""Harmonic sets for harmonic balance: which multiples of the base frequency to keep.

A scene with several excitation frequencies (the NFG of Liu et al.: the
instantaneous-centre frequency ``w_c`` and the mesh frequency ``w_e = Z2 w_c``)
has a response whose harmonics cluster around the multiples of the fast
excitation, ``m w_e +- j w_c`` (Liu et al. eq. 13).  A series in ``1..H`` of the
slowest frequency reaches the mesh harmonic only with ``H >= Z2`` and wastes all
the harmonics between the clusters; a *set* ``{0..h} U {m c - h .. m c + h}`` does
not.

The excitation harmonics are read from the model itself: the right-hand side and
its Jacobian (a DAE's: :func:`~gearsym.analysis.periodic._hbm.sample_field`) are sampled along a constant state over one period and their
spectra give every frequency the model's time dependence contains
(:func:`excitation_harmonics`).  :func:`harmonic_set` builds the set for a band
half-width ``h`` and ``m`` multiples of every carrier; :func:`growth_sets` the
sequence of sets that the automatic growth of :func:`gearsym.analysis.periodic.harmonic_balance`
walks through (band and multiples grow together, each set contains the previous).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ._hbm import sample_field, sample_jacobian

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["excitation_harmonics", "carriers_of", "harmonic_set", "growth_sets"]


def excitation_harmonics(system: CompiledSystem, period: float, x: np.ndarray, params: Mapping[str, float] | None = None,
                         t0: float = 0.0, samples: int = 4096, rel: float = 1e-4) -> dict[int, float]:
    """Harmonics of the base frequency ``2*pi/period`` in the model's time dependence.

    The right-hand side ``f(t, x)`` and the Jacobian ``df/dx(t, x)`` are sampled at
    ``samples`` equidistant times along the constant state ``x`` (contact sides from
    the switching functions at ``t0``, held over the period); a harmonic counts when its amplitude exceeds
    ``rel`` times the largest non-constant amplitude of the same entry.

    Returns
    -------
    dict
        Harmonic number (>= 1) -> largest relative amplitude over the entries.
    """
    gen = system.generated
    if gen.schedules:
        return {}  # scheduled jumps: every harmonic is excited; the caller keeps 1..H
    p = system.param_vector(params)
    t = t0 + period * np.arange(samples) / samples
    X = np.tile(np.asarray(x, float)[None, :], (samples, 1))
    sigma = None
    if gen.nsw:
        # one contact mode over the whole period (that of the first sample): the spectrum of
        # the time dependence, not of the switching a constant state sees as the backlash moves
        g = system.engine.evaluate("sw", t[:1], X[:1], p)[0]
        sigma = np.tile(np.where(g >= 0, 1.0, -1.0)[None, :], (samples, 1))
    F, H = sample_field(system, t, X, p, sigma)  # (samples, nd), a DAE's algebraic variables (samples, nalg)
    J = sample_jacobian(system, t, X, p, sigma)  # (samples, i, j)
    rows = np.vstack([F.T, H.T, J.reshape(samples, -1).T])
    A = np.abs(np.fft.rfft(rows, axis=1))[:, 1:samples // 2]
    out: dict[int, float] = {}
    for a in A:
        top = float(np.max(a)) if a.size else 0.0
        if not np.isfinite(top) or top <= 1e-14 * max(1.0, float(np.max(np.abs(rows)))) * samples:
            continue
        for k in np.nonzero(a > rel * top)[0]:
            out[int(k) + 1] = max(out.get(int(k) + 1, 0.0), float(a[k] / top))
    return out


def carriers_of(excitation: Mapping[int, float], gap: int = 4) -> list[int]:
    """The fast excitation harmonics: the strongest harmonic of every cluster of
    excitation harmonics except the one at the origin (clusters split by gaps
    larger than ``gap``), dropping clusters centred on a multiple of an earlier carrier."""
    ks = sorted(excitation)
    if not ks:
        return []
    clusters: list[list[int]] = [[0]]
    for k in ks:
        if k - clusters[-1][-1] > gap:
            clusters.append([k])
        else:
            clusters[-1].append(k)
    out: list[int] = []
    for cl in clusters[1:]:
        c = max(cl, key=lambda k: excitation[k])
        if any(abs(c - round(c / d) * d) <= gap for d in out):
            continue
        out.append(c)
    return out


def harmonic_set(h: int, multiples: int, carriers: Sequence[int] = (), kmax: int | None = None) -> np.ndarray:
    """``{1..h}`` and the bands ``n.c - h .. n.c + h`` around every combination
    ``n.c = sum n_i c_i`` of the carriers with ``sum |n_i| <= multiples`` (positive
    frequencies only), capped at ``kmax``; sorted, without 0 (the mean is always kept)."""
    ks: set[int] = set(range(1, h + 1))
    cs = list(carriers)
    if cs and multiples > 0:
        rng = range(-multiples, multiples + 1)
        for n in itertools.product(rng, repeat=len(cs)):
            if sum(abs(v) for v in n) > multiples:
                continue
            f = sum(v * c for v, c in zip(n, cs, strict=True))
            if f <= 0:
                continue
            ks.update(k for k in range(f - h, f + h + 1) if k >= 1)
    if kmax is not None:
        ks = {k for k in ks if k <= kmax}
    return np.array(sorted(ks), dtype=int)


def growth_sets(carriers: Sequence[int], max_harmonics: int, h0: int = 1) -> list[np.ndarray]:
    """The sets of the automatic growth: without carriers ``1..h`` for ``h = h0, 2 h0,
    4 h0, ..., max_harmonics``; with carriers the band half-width doubles from
    ``max(h0, 4)`` and the multiples of the carriers grow by one each time (the
    first set already holds every carrier), all capped at ``max_harmonics``."""
    out: list[np.ndarray] = []
    if not carriers:
        h = max(1, int(h0))
        while h < max_harmonics:
            out.append(np.arange(1, h + 1))
            h *= 2
        out.append(np.arange(1, int(max_harmonics) + 1))
        return out
    h, m = max(int(h0), 4), 1
    while True:
        s = harmonic_set(h, m, carriers, max_harmonics)
        if out and len(s) == len(out[-1]):
            break
        out.append(s)
        if len(s) and s[-1] >= max_harmonics and len(s) == max_harmonics:
            break
        h, m = 2 * h, m + 1
    return out
