"""THE Newton iteration's Python entry points check the sizes, dtypes and buffers the C iteration
(``gs_newton.c``) and its corrector evaluator (``gs_correct.c``) read, before C reads them.

Each case was a crash or a silent wrong read before: an orbit iteration without ``nx`` divided by
zero in C (``i % nx``: SIGFPE, the Python process gone); a corrector with ``n != nr + 1`` read one
column past its scales and a row of uninitialised memory; a scalar residual was broadcast into the
residual buffer (a wrong answer taken as the evaluation); the DAE corrector's ``zalg`` address was
taken without checking its dtype / size and kept from an earlier call when the next gave none.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gearsym
from gearsym.engine.errors import EngineInputError
from gearsym.engine.newton import CORRECTOR, EVAL_FAILED, ORBIT, NewtonCore, NewtonPolicy

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def ks():
    return gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml").compile()


@pytest.fixture(scope="module")
def dae():
    return gearsym.load_scene(ROOT / "scenes" / "spur_pair_coupled_load.toml").compile()


@pytest.mark.parametrize("kind, n, nr, nx, segments", [
    (ORBIT, 2, 2, 0, 1),      # nx missing: i % nx in C
    (ORBIT, 2, 2, 1, 1),      # n != segments * nx: the segment blocks past the buffers
    (ORBIT, 4, 2, 2, 2),      # n != nr
    (CORRECTOR, 3, 3, 0, 1),  # n != nr + 1: the bordered row's lambda column past S
    (CORRECTOR, 5, 2, 0, 1),
    (7, 2, 2, 2, 1),          # no kind
])
def test_inconsistent_sizes_are_refused(ks, kind, n, nr, nx, segments):
    with pytest.raises(EngineInputError, match="Newton iteration"):
        NewtonCore(ks.engine._lib, kind, n, nr, NewtonPolicy(max_iter=3), tol=1e-8, nx=nx, segments=segments)


def test_c_refuses_sizes_changed_after_the_work_array(ks):
    """gs_newton_start checks the sizes itself: the iteration ends at once (no request)."""
    core = NewtonCore(ks.engine._lib, ORBIT, 2, 2, NewtonPolicy(max_iter=3), tol=1e-8, nx=2, segments=1)
    core.nw.nx = 0
    core.start(np.zeros(2))
    assert core.done and core.outcome == EVAL_FAILED and "inconsistent sizes" in core.message


def test_answers_of_the_wrong_size_are_refused(ks):
    core = NewtonCore(ks.engine._lib, CORRECTOR, 3, 2, NewtonPolicy(max_iter=3), tol=1e-8)
    core.row[:], core.S[:], core.Rs[:] = [0.0, 0.0, 1.0], 1.0, 1.0
    with pytest.raises(EngineInputError, match="z has 1 entries"):
        core.start(0.0)
    core.start(np.zeros(3))
    with pytest.raises(EngineInputError, match="R has 1 entries"):
        core.answer(0.0, np.eye(2), np.ones(2))
    with pytest.raises(EngineInputError, match="Flam has 1 entries"):
        core.answer(np.zeros(2), np.eye(2), 1.0)
    assert core.pending  # nothing was answered
    with pytest.raises(EngineInputError, match="did not answer"):
        core.solve_in_python(lambda z: None)


def test_linear_corrector_answered_in_python(ks):
    """The checks leave a well-posed problem as it was: F(u, lam) = A u - lam b, lam pinned to 2
    by the row, solved exactly (numpy's solve of A u = 2 b)."""
    A, b = np.array([[3.0, 1.0], [0.5, 2.0]]), np.array([1.0, -1.0])
    policy = NewtonPolicy(max_iter=5, min_damping=0.125, decrease=0.0, accept_below=1e-12, accept_last=True)
    core = NewtonCore(ks.engine._lib, CORRECTOR, 3, 2, policy, tol=1e-12)
    core.row[:], core.S[:], core.Rs[:] = [0.0, 0.0, 1.0], 1.0, 1.0
    core.nw.target = 2.0
    core.start(np.array([1.0, 1.0, 0.0]))
    core.solve_in_python(lambda z: core.answer(A @ z[:2] - z[2] * b, A, -b))
    assert core.outcome == 0
    assert np.allclose(core.z[:2], np.linalg.solve(A, 2 * b), rtol=0, atol=1e-12) and core.z[2] == 2.0


def _dae_corrector(dae):
    from gearsym.engine.shoot import Corrector, CorrectorFlow
    from gearsym.sensitivity import directions

    eng = dae.derivative_engine()
    nd = eng.nx - eng.nalg
    assert eng.nalg >= 1
    p0 = dae.param_vector()
    fl = CorrectorFlow(engine=eng, method="ida", rtol=1e-8, atol=np.full(eng.nx, 1e-10), max_steps=0, segments=1,
                       nd=nd, periods=1.0, t0=0.0, lam0=float(dae.params["omega"]), p0=p0,
                       D=directions(dae, ["omega"], p0)[:, 0])
    return Corrector(eng, nd, tol=1e-6, max_iter=3, flow=fl), nd, eng.nalg


def test_dae_corrector_checks_zalg(dae):
    """zalg is read and written by C (segments x nalg doubles): a wrong dtype or size, or none
    after an earlier call gave one (its address was kept), is refused."""
    corr, nd, nalg = _dae_corrector(dae)
    z = np.zeros(nd + 1)
    z[-1] = float(dae.params["omega"])
    row = np.zeros(nd + 1)
    row[-1] = 1.0
    args = (z, row, z[-1], np.ones(nd + 1), np.ones(nd))
    with pytest.raises(EngineInputError, match="zalg"):
        corr(*args, zalg=np.zeros((1, 2 * nalg), dtype=np.float32))
    with pytest.raises(EngineInputError, match="zalg"):
        corr(*args, zalg=np.zeros((1, nalg + 1)))
    out = corr(*args, zalg=np.zeros((1, nalg)))  # a good one: runs (converged or not)
    assert out.code >= 0
    with pytest.raises(EngineInputError, match="zalg"):
        corr(*args)


@pytest.mark.parametrize("bad", [{"max_events_out": -1}, {"max_events_out": 0}, {"max_iter": 2 ** 32}])
def test_shooting_settings_out_of_range_are_refused(ks, bad):
    """An event log of no entries (was numpy's ValueError, or the driver's refusal naming no
    setting) and an iteration budget past the C struct's int are refused naming the setting."""
    from gearsym.engine.driver import METHODS
    from gearsym.engine.shoot import shoot_in_c

    T = ks.period()
    kw = dict(method=METHODS["adams"], rtol=1e-11, atol=1e-13, max_step=T / 8, max_steps=0, tol=1e-10, max_iter=50,
              trunc_level=1e-9, scale_floor=1e-3)
    kw.update(bad)
    with pytest.raises(EngineInputError, match=next(iter(bad))):
        shoot_in_c(ks.engine, np.zeros(2), ks.param_vector(), np.array([0.0, T]), **kw)


def test_corrector_without_any_f_lambda_fails_clearly(ks):
    """F_lambda None means the chord (the last one given in this iteration): at the start there is
    none, and the buffer held the previous iteration's, which was used silently."""
    A, b = np.array([[3.0, 1.0], [0.5, 2.0]]), np.array([1.0, -1.0])
    policy = NewtonPolicy(max_iter=5, min_damping=0.125, decrease=0.0, accept_below=1e-12, accept_last=True)
    core = NewtonCore(ks.engine._lib, CORRECTOR, 3, 2, policy, tol=1e-12)
    core.row[:], core.S[:], core.Rs[:] = [0.0, 0.0, 1.0], 1.0, 1.0
    core.nw.target = 2.0
    core.start(np.array([1.0, 1.0, 0.0]))
    core.solve_in_python(lambda z: core.answer(A @ z[:2] - z[2] * b, A, 5.0 * b))  # another problem's F_lambda
    core.start(np.array([1.0, 1.0, 0.0]))
    core.solve_in_python(lambda z: core.answer(A @ z[:2] - z[2] * b, A, None))
    assert core.outcome == EVAL_FAILED and "no F_lambda" in core.message
