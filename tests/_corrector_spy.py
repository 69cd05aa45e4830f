"""Which continuation steps the corrector in C made: a spy on ``Continuer._correct_in_c``, and
the switch that sends every step to the Python corrector (to compare the two paths)."""

from __future__ import annotations

import gearsym.analysis.continuation._corrector as corrector_mod


def spy_on_c_corrector(monkeypatch) -> list[bool]:
    """Record, per call, whether the C corrector returned a point (``False``: it gave up or did
    not apply, and the Python corrector ran)."""
    calls: list[bool] = []
    orig = corrector_mod.Continuer._correct_in_c

    def counting(self, z, row, target, t_ref=None):
        out = orig(self, z, row, target, t_ref)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(corrector_mod.Continuer, "_correct_in_c", counting)
    return calls


def python_corrector_only(monkeypatch) -> None:
    """Every step corrected by the Python iteration."""
    monkeypatch.setattr(corrector_mod.Continuer, "_correct_in_c", lambda self, z, row, target, t_ref=None: None)
