"""Options objects, not keyword lists (issue 26): every analysis takes its frozen options
object, the settings one by one keep working, and a keyword that is no setting is a
ParameterError that names it and the closest setting (it was a TypeError of Python, or for
branch switching, silently ignored).  The parameter derivative of the continuation's residual
is a setting of the residual (``f_lambda``), not a process-wide switch.

Cheap checks on the benchmark oscillator.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.analysis.periodic import harmonic_balance, shoot

ROOT = Path(__file__).resolve().parents[1]
KS = {"zeta": 0.05, "Fm": 0.1, "Fa": 0.05, "eps": 0.2, "b": 1.0, "Omega": 0.9}


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()


@pytest.mark.parametrize("call, wrong, right", [
    (lambda s: shoot(s, params=KS, max_iters=10), "max_iters", "max_iter"),
    (lambda s: s.periodic_orbit(params=KS, segmnts=2), "segmnts", "segments"),
    (lambda s: harmonic_balance(s, params=KS, harmonic=4), "harmonic", "harmonics"),
    (lambda s: s.periodic_orbit(params=KS, method="hbm", max_harmonic=8), "max_harmonic", "max_harmonics"),
    (lambda s: gearsym.continuation(s, "Omega", 0.8, 0.9, ds_mx=0.01), "ds_mx", "ds_max"),
])
def test_an_unknown_keyword_is_named_with_the_closest_setting(ks, call, wrong, right):
    with pytest.raises(gearsym.ParameterError, match=rf"unknown option '{wrong}'; did you mean '{right}'\?"):
        call(ks)


def test_branch_switching_refuses_an_unknown_keyword(ks):
    """The old ``**options`` of branch switching dropped every key it did not know."""
    br = gearsym.continuation(ks, "Omega", 1.3, 1.35, params=KS, progress=False, detect=False)
    with pytest.raises(gearsym.ParameterError, match=r"unknown option 'ds_maxx'; did you mean 'ds_max'\?"):
        gearsym.switch_period_doubling(br, ds_maxx=0.05)


def test_harmonic_balance_options_equal_the_keywords(ks):
    from gearsym.analysis.periodic import HarmonicBalanceOptions

    opts = HarmonicBalanceOptions(harmonics=6, rtol=1e-10, atol=1e-12)
    o = harmonic_balance(ks, params=KS, options=opts)
    k = harmonic_balance(ks, params=KS, harmonics=6, rtol=1e-10, atol=1e-12)
    assert o.converged and np.array_equal(o.coefficients, k.coefficients) and o.harmonics == 6
    # a keyword given wins over the options object
    m = harmonic_balance(ks, params=KS, options=opts, harmonics=4)
    assert m.harmonics == 4 and m.info["rtol"] == 1e-10
    with pytest.raises(gearsym.ParameterError, match=r"^harmonics must be an integer in \[0, 4,096\]"):
        HarmonicBalanceOptions(harmonics=10 ** 12)
    with pytest.raises(gearsym.ParameterError, match="HarmonicBalanceOptions"):
        harmonic_balance(ks, params=KS, options=gearsym.ShootingOptions())


def test_continuation_options_carry_every_setting(ks):
    """The settings that were keywords of continuation() only (periods, method, t0,
    defect_tol, ...) are fields of ContinuationOptions: the options object alone gives the
    same branch as the keywords."""
    base = {k: v for k, v in KS.items() if k != "Omega"}
    kw = dict(periods=1, method="shooting", segments=1, ds_max=0.2, detect=False, progress=False, rtol=1e-9)
    a = gearsym.continuation(ks, "Omega", 1.3, 1.4, params=base, options=gearsym.ContinuationOptions(**kw))
    b = gearsym.continuation(ks, "Omega", 1.3, 1.4, params=base, **kw)
    assert a.complete and len(a.points) == len(b.points)
    assert np.array_equal(np.array([p.value for p in a.points]), np.array([p.value for p in b.points]))
    assert a.info["rtol"] == 1e-9
    with pytest.raises(gearsym.ParameterError, match=r"f_lambda must be one of exact, finite_difference"):
        gearsym.ContinuationOptions(f_lambda="central")


def test_the_parameter_derivative_is_a_setting_of_the_residual_not_of_the_process(ks):
    """Two residuals side by side: one with the exact F_lambda (from the parameter
    sensitivities), one with the finite difference; each keeps its own, whichever is
    evaluated first (the old switch was a module-level list that every residual read)."""
    from gearsym.analysis.periodic import ShootingResidual

    orb = ks.periodic_orbit(params=KS, rtol=1e-12, atol=1e-14, tol=1e-11)
    exact = ShootingResidual(ks, "Omega", params=KS, rtol=1e-10, atol=1e-12)
    fd = ShootingResidual(ks, "Omega", params=KS, rtol=1e-10, atol=1e-12, fd_step=1e-5, f_lambda="finite_difference")
    assert exact.flam_with_residual(0.9) and not fd.flam_with_residual(0.9)
    g_fd = fd.evaluate(orb.x0, 0.9).Flam
    g_exact = exact.evaluate(orb.x0, 0.9).Flam
    assert exact.flam_with_residual(0.9) and not fd.flam_with_residual(0.9)
    # the same derivative two ways (the forward difference to its truncation error)
    assert np.max(np.abs(g_fd - g_exact)) < 1e-3 * np.max(np.abs(g_exact))
    with pytest.raises(gearsym.ParameterError, match="f_lambda must be one of"):
        ShootingResidual(ks, "Omega", f_lambda="central")
