"""Who evaluated the continuation's residuals: a spy on ``Continuer.correct`` recording, per
correction, whether every evaluation of THE Newton iteration (``gs_newton.c``) was made by the C
evaluator of the shooting residual, and the switch that sends every evaluation to the problem's
own evaluation (``System.flow``), to compare the two evaluators under the one iteration."""

from __future__ import annotations

import gearsym.analysis.continuation._corrector as corrector_mod


def spy_on_c_corrector(monkeypatch) -> list[bool]:
    """Record, per successful correction, whether all its residuals were evaluated in C
    (``False``: the C evaluator does not apply, or handed an evaluation back)."""
    calls: list[bool] = []
    orig = corrector_mod.Continuer.correct

    def counting(self, *args, **kwargs):
        before = self.n_python_evaluations
        out = orig(self, *args, **kwargs)
        calls.append(self.corrector_engine == "C" and self.n_python_evaluations == before)
        return out

    monkeypatch.setattr(corrector_mod.Continuer, "correct", counting)
    return calls


def python_corrector_only(monkeypatch) -> None:
    """Every residual of every correction evaluated by the problem (``System.flow``), not by the
    C evaluator (the iteration is the same)."""
    monkeypatch.setattr(corrector_mod.Continuer, "_flow_setup", lambda self, lam: "forced by the test")
