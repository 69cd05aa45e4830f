"""Sizes that do not fit SUNDIALS' 32-bit index are refused before anything is allocated
(issue 24 item 13).

The solver state of a run has ``nA = nx (1 + nvc)`` components (``nvc`` variational
columns: the monodromy's and the sensitivities'), and the dense Newton matrix ``nA x nA``
entries, which SUNDIALS computes in its 32-bit ``sunindextype``: past it the product wraps,
the matrix is allocated too small and the Jacobian is written past it (before: a model of
215 states with ``linear_solver="dense"`` and the monodromy; here forged with a 2-state
model and many sensitivity directions, which gives the same sizes cheaply).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from gearsym.engine import driver
from gearsym.engine.driver import LINEAR_SOLVERS, NONLINEAR
from gearsym.engine.errors import EngineInputError
from gearsym.errors import ParameterError

ROOT = Path(__file__).resolve().parents[2]
DENSE, BLOCKDIAG, AUTO = LINEAR_SOLVERS["dense"], LINEAR_SOLVERS["blockdiag"], LINEAR_SOLVERS["auto"]


def test_the_rule_for_the_dense_monodromy_matrix():
    """nx = 215 with the monodromy: (215 * 216)**2 = 2.157e9 entries > 2**31 - 1 (the wrap of
    the issue); 214 fits the index, but not the 2 GiB matrix budget; 100 fits both."""
    INDEX_MAX, check_solver_size = driver.INDEX_MAX, driver.check_solver_size
    assert (215 * 216) ** 2 > INDEX_MAX >= (214 * 215) ** 2
    with pytest.raises(EngineInputError, match=r"^215 states .*32-bit index.*linear_solver='blockdiag'") as ei:
        check_solver_size(215, 215, True, 0, NONLINEAR["auto"], DENSE)
    assert isinstance(ei.value, ParameterError)  # bad input: exit 2
    with pytest.raises(EngineInputError, match=r"^214 states .*the limit is 2\.68e\+08 values.*blockdiag"):
        check_solver_size(214, 214, True, 0, NONLINEAR["auto"], DENSE)
    check_solver_size(100, 100, True, 0, NONLINEAR["auto"], DENSE)
    # the block-diagonal solver (nA x nx) and the fixed-point iteration (no matrix) take nx = 215
    for linsol in (AUTO, BLOCKDIAG):
        check_solver_size(215, 215, True, 0, NONLINEAR["auto"], linsol)
    check_solver_size(215, 215, True, 0, NONLINEAR["fixedpoint"], DENSE)


def test_the_rule_for_the_solver_state():
    check_solver_size = driver.check_solver_size
    # nx (1 + nx) > 2**31 - 1 from nx = 46341 on, whatever the linear solver
    with pytest.raises(EngineInputError, match=r"^46341 states .*solver state .*32-bit index"):
        check_solver_size(46341, 46341, True, 0, NONLINEAR["fixedpoint"], AUTO)
    with pytest.raises(EngineInputError, match=r"^2 states with 1073741824 variational columns"):
        check_solver_size(2, 2, False, 2 ** 30, NONLINEAR["fixedpoint"], AUTO)


def test_engine_refuses_a_wrapping_dense_matrix_in_python(backlash_engine):
    """nA = 2 (1 + 2 + 23168) = 46342: nA**2 = 2,147,580,964 wraps to a negative int32."""
    D = np.zeros((backlash_engine.np, 23168))
    D[0] = 1.0
    with pytest.raises(EngineInputError, match=r"^2 states .*46,342 x 46,342 .*32-bit index"):
        backlash_engine.run([1.1, 0.0], [0.05, 0.2, 0.8, 0.1, 0.3, 1.0], 0.0, 1.0, want_monodromy=True,
                            linear_solver="dense", sens_dir=D)


# A forged call straight into the driver (past the Python check): a run prepared with one
# sensitivity direction, then given 32766 (buffers of that size): nA = 2 (1 + 2 + 32766) =
# 65538, nA**2 = 2**32 + 262148 wraps to 262148 entries (2 MB) while the Jacobian writes 34 GB.
# Run in a child process: before, the driver wrote past the allocation (a crash).
FORGED = textwrap.dedent("""
    import ctypes, sys
    import numpy as np
    import gearsym
    from gearsym.engine.driver import LINEAR_SOLVERS

    eng = gearsym.load_scene(sys.argv[1]).compile().derivative_engine()
    x0, p = np.array([1.0, 0.0]), np.full(eng.np, 0.5)
    D = np.zeros((eng.np, 1))
    D[0] = 1.0
    sens = (np.ascontiguousarray(D.T).reshape(-1), 1, None, None, False)
    for ns, linsol in ((32766, "dense"), (2 ** 30, "blockdiag")):
        a, buf = eng._prepare(x0, p, 0.0, 1.0, np.empty(0), 0, 1e-8, 1e-10, None, True, 0, 0.0, 0.0, 0, 0, 0.0,
                              16, 0, LINEAR_SOLVERS[linsol], None, sens)
        n_buf = min(ns, 40000)  # the driver must refuse before it reads sens_dir (np * ns entries)
        sdir = np.zeros(eng.np * n_buf)
        sfin = np.zeros(eng.nx * n_buf)
        a.n_sens = ns
        a.sens_dir, a.sens_final = sdir.ctypes.data, sfin.ctypes.data
        status = eng._lib.gs_simulate_ws(eng._ws(), ctypes.byref(a))
        print(status, a.errmsg.decode(), flush=True)
""")


def test_driver_refuses_a_wrapping_size_before_allocating(tmp_path):
    r = subprocess.run([sys.executable, "-c", FORGED, str(ROOT / "scenes" / "kahraman_singh.toml")],
                       capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert r.returncode == 0, f"the driver crashed (exit {r.returncode}): {r.stderr[-2000:]}"
    dense, state = r.stdout.splitlines()
    assert dense.startswith("-6 ") and "dense system matrix would have 65538 x 65538" in dense
    assert "32-bit index" in dense and "linear_solver 'blockdiag'" in dense
    assert state.startswith("-6 ") and "nx*(1 + nvc) = 2*(1 + 1073741826)" in state and "32-bit index" in state
