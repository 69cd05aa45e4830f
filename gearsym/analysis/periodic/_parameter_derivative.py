"""Exact ``F_lambda`` of the continuation residuals, from the engine's parameter sensitivities.

For the (multiple) shooting residual with segment times ``s_i = t0 + P(lambda) i / N``
(``P = periods * T(lambda)``, so the orbit period follows a forcing-frequency parameter),

    R_i = phi(s_{i+1}(lambda), s_i(lambda), X_i; lambda) - X_{i+1}
    dR_i/dlambda = S_i(s_{i+1}-) + f(s_{i+1}-) ds_{i+1}/dlambda - Phi_i f(s_i+) ds_i/dlambda

with ``S_i`` the solution of the parameter variational equations (jumps at contact
events and breakpoints included, see ``gearsym/engine/gs_driver.c``) and
``ds_i/dlambda = (i/N) periods dT/dlambda`` from the generated ``gs_periodp``: one
integration per segment of the state and one sensitivity column, in place of the
finite difference with step ``sqrt(rtol)`` (whose truncation error moved fold locations).

Implicit (IDA) models and DAEs have it too (IDA's forward sensitivities; the residual's
unknowns and rows are the differential states).  Where the exact derivative is not
available, :func:`exact_f_lambda` returns ``None`` and
the continuation keeps its finite difference: the harmonic-balance residual, systems whose
build with the parameter derivatives cannot be made (the
first exact ``F_lambda`` makes it: :meth:`gearsym.system.System.derivative_engine`), and
integrations that fail for the sensitivities only (a grazing event, where the event-time
derivative is infinite).  A residual made with ``f_lambda="finite_difference"`` (the
continuation's option of that name) uses the finite difference throughout (comparisons,
benchmarks): a setting of the problem, not a switch of the process.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import CompileError, GearsymError

__all__ = ["F_LAMBDA", "exact_f_lambda", "sensitivity_setup"]

#: How a continuation residual gets ``F_lambda``: from the engine's parameter sensitivities where
#: they are available (else the finite difference), or always by the finite difference.
F_LAMBDA = ("exact", "finite_difference")


def sensitivity_setup(res: Any, lam: float) -> tuple[dict[str, float], np.ndarray, float] | None:
    """What the exact ``F_lambda`` of a shooting residual needs at ``lambda``, or ``None`` if not available.

    Returns ``(inputs, p, dP)``: the parameter overrides, the parameter vector and
    ``d P / d lambda`` of the orbit period ``P = periods * T``.  Cached per ``lambda`` on
    the residual (the corrector asks at a few values many times).  ``None``: the residual's
    ``f_lambda`` is ``"finite_difference"``, not a shooting residual, no derivative build (or
    its compilation failed: not retried).
    """
    system = res.system
    if getattr(res, "f_lambda", "exact") != "exact" or not system.has_derivatives or not hasattr(res, "segments") or not hasattr(res, "times"):
        return None
    cache = res.__dict__.setdefault("_sens_setup_cache", {})
    key = float(lam)
    hit = cache.get(key)
    if hit is not None:
        return hit
    try:
        system.derivative_engine()  # the build with the derivatives, made on first use
    except CompileError:
        system.derivative_build = None  # not retried: the finite difference from now on
        return None
    inputs = res.params(key)
    p = res.pvec(key)
    dP = float(res.periods) * float(system.period_gradient([res.param], p, inputs)[0])
    if len(cache) > 64:
        cache.clear()
    cache[key] = (inputs, p, dP)
    return cache[key]


def exact_f_lambda(res: Any, u: np.ndarray, lam: float) -> np.ndarray | None:
    """``dF/dlambda`` of a continuation residual at ``(u, lambda)``, or ``None`` if not available.

    Parameters
    ----------
    res
        The residual (:class:`gearsym.analysis.periodic.ShootingResidual`; others give ``None``).
    u
        Unknowns (segment start states).
    lam
        Parameter value.

    Returns
    -------
    ndarray or None
        Shape ``(N * nx,)``.
    """
    setup = sensitivity_setup(res, lam)
    if setup is None:
        return None
    try:  # the state and one sensitivity column per segment, no monodromy
        return res._integrate(u, lam, False, setup, count=False).Flam
    except GearsymError:  # e.g. a grazing event: the event-time derivative is infinite
        return None
