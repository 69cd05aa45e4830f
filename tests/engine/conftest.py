"""Fixtures for the engine tests: hand-written CasADi test models compiled with
the engine's own build helpers (no dependency on gearsym.symbolic/codegen)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from gearsym.engine.build import ENGINE_DIR, build_shared_object, content_hash, driver_sources
from gearsym.engine.driver import Engine, load_engine

INFO_C = """\
/* hand-written model metadata (gs_model_abi.h) */
int gs_model_info(int* out, int len) {{
  static const int info[] = {{ {vals} }};
  int i, n = (int)(sizeof(info) / sizeof(info[0]));
  if (len < n) return -1;
  for (i = 0; i < n; ++i) out[i] = info[i];
  return n;
}}
"""


def compile_model(
    out_dir: Path,
    *,
    t: ca.SX,
    x: ca.SX,
    p: ca.SX,
    m: ca.SX,
    g: ca.SX,
    rhs: ca.SX | None = None,
    res: ca.SX | None = None,
    xd: ca.SX | None = None,
    sched: ca.SX | list[float] | None = None,
    nb: list[int] | None = None,
    omit: tuple[str, ...] = (),
    nalg: int | None = None,
) -> Engine:
    """Generate gs_model.c/.h + gs_info.c for the given expressions, build with
    the driver and load.  Explicit if ``rhs`` is given, implicit if ``res``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    nx, np_, nm = x.numel(), p.numel(), m.numel()
    nsw = g.numel()
    nb = nb or []
    nsched = len(nb)
    assert nm == nsw + 2 * nsched
    funcs = []
    if rhs is not None:
        funcs.append(ca.Function("gs_rhs", [t, x, p, m], [rhs]))
        funcs.append(ca.Function("gs_jac", [t, x, p, m], [ca.densify(ca.jacobian(rhs, x))]))
        implicit = 0
    else:
        cj = ca.SX.sym("cj")
        funcs.append(ca.Function("gs_res", [t, x, xd, p, m], [res]))
        jr = ca.jacobian(res, x) + cj * ca.jacobian(res, xd)
        funcs.append(ca.Function("gs_resjac", [t, x, xd, p, m, cj], [ca.densify(jr)]))
        implicit = 1
    g = ca.reshape(g, nsw, 1) if nsw else ca.SX(0, 1)
    funcs.append(ca.Function("gs_sw", [t, x, p], [g]))
    funcs.append(ca.Function("gs_swx", [t, x, p], [ca.densify(ca.jacobian(g, x)) if nsw else ca.SX(0, nx)]))
    funcs.append(ca.Function("gs_swt", [t, x, p], [ca.densify(ca.jacobian(g, t)) if nsw else ca.SX(0, 1)]))
    if isinstance(sched, ca.SX):
        s = sched
    elif sched:
        s = ca.vertcat(*[ca.SX(v) for v in sched])
    else:
        s = ca.SX(0, 1)
    funcs.append(ca.Function("gs_sched", [p], [s]))
    cg = ca.CodeGenerator("gs_model.c", {"with_header": True})
    for f in funcs:
        if f.name() not in omit:
            cg.add(f)
    cg.generate(f"{out_dir}/")  # prefix: writes out_dir/gs_model.c and .h
    vals = [nx, np_, nm, nsw, nsched, implicit, *nb] + ([] if nalg is None else [nalg])
    (out_dir / "gs_info.c").write_text(INFO_C.format(vals=", ".join(str(v) for v in vals)))
    dsrc, dinc = driver_sources()
    srcs = [out_dir / "gs_model.c", out_dir / "gs_info.c", *dsrc]
    h = content_hash([*srcs, out_dir / "gs_model.h", *(ENGINE_DIR / f for f in ("gs_driver.h", "gs_internal.h", "sundials7.h"))])
    so = build_shared_object(srcs, [out_dir, *dinc], out_dir / f"model_{h}.so")
    return load_engine(so)


# ----------------------------------------------------------------------------
# Test model 1: backlash oscillator
#   x'' + 2 zeta c(x) x' + (1 + eps cos(Om t)) f(x) = Fm + Fa Om^2 cos(Om t)
#   f = x-b (x>b), 0 (|x|<=b), x+b (x<-b);  g0 = x-b, g1 = x+b
#   c(x) = 1 (smooth damping) or 1 only in contact (|x|>b, jump_damping)
# p = [zeta, eps, Om, Fm, Fa, b]
# ----------------------------------------------------------------------------
def backlash_exprs(jump_damping: bool = False):
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", 2)
    p = ca.SX.sym("p", 6)
    m = ca.SX.sym("m", 2)
    zeta, eps, Om, Fm, Fa, b = (p[i] for i in range(6))
    f = ca.if_else(m[0] > 0, x[0] - b, ca.if_else(m[1] < 0, x[0] + b, 0))
    if jump_damping:
        c = ca.if_else(m[0] > 0, 1, ca.if_else(m[1] < 0, 1, 0))
    else:
        c = 1
    F = -2 * zeta * c * x[1] - (1 + eps * ca.cos(Om * t)) * f + Fm + Fa * Om**2 * ca.cos(Om * t)
    g = ca.vertcat(x[0] - b, x[0] + b)
    return t, x, p, m, g, F


def _cache_dir(tmp_path_factory, key: str) -> Path:
    return tmp_path_factory.mktemp(hashlib.sha1(key.encode()).hexdigest()[:8])


@pytest.fixture(scope="session")
def backlash_engine(tmp_path_factory) -> Engine:
    t, x, p, m, g, F = backlash_exprs()
    return compile_model(
        _cache_dir(tmp_path_factory, "backlash"), t=t, x=x, p=p, m=m, g=g, rhs=ca.vertcat(x[1], F)
    )


@pytest.fixture(scope="session")
def backlash_jump_engine(tmp_path_factory) -> Engine:
    t, x, p, m, g, F = backlash_exprs(jump_damping=True)
    return compile_model(
        _cache_dir(tmp_path_factory, "backlash_jump"), t=t, x=x, p=p, m=m, g=g, rhs=ca.vertcat(x[1], F)
    )


@pytest.fixture(scope="session")
def backlash_ida_engine(tmp_path_factory) -> Engine:
    t, x, p, m, g, F = backlash_exprs()
    xd = ca.SX.sym("xd", 2)
    res = ca.vertcat(xd[0] - x[1], 1 * xd[1] - F)
    return compile_model(
        _cache_dir(tmp_path_factory, "backlash_ida"), t=t, x=x, p=p, m=m, g=g, res=res, xd=xd
    )


def _backlash_dae(tmp_path_factory, jump_damping: bool) -> Engine:
    t, x, p, m, g, F = backlash_exprs(jump_damping=jump_damping)
    x3 = ca.SX.sym("x", 3)
    F = ca.substitute(F, x, x3[:2])
    g = ca.substitute(g, x, x3[:2])
    xd = ca.SX.sym("xd", 3)
    res = ca.vertcat(xd[0] - x3[1], xd[1] - x3[2], x3[2] - F)
    return compile_model(
        _cache_dir(tmp_path_factory, f"backlash_dae{jump_damping}"), t=t, x=x3, p=p, m=m, g=g, res=res, xd=xd,
        nalg=1,
    )


@pytest.fixture(scope="session")
def backlash_dae_engine(tmp_path_factory) -> Engine:
    """The backlash oscillator as a DAE: the restoring force is an algebraic variable z,
    x = [x, v, z], r = [x' - v, v' - z, z - F(t, x, v)] (nalg = 1, the last state)."""
    return _backlash_dae(tmp_path_factory, False)


@pytest.fixture(scope="session")
def backlash_dae_jump_engine(tmp_path_factory) -> Engine:
    """The DAE with damping in contact only: the vector field jumps at the surfaces."""
    return _backlash_dae(tmp_path_factory, True)


# ----------------------------------------------------------------------------
# Test model 2: one schedule (Meissner-type):  x'' + w^2 (1 + a s(t)) x = 0,
# s = +1 for phase < d, -1 after;  p = [w, a, P, d];  schedule [P, 0, d]
# ----------------------------------------------------------------------------
MEISSNER_P = dict(w=1.3, a=0.4, P=2.1, d=0.35, c=10.0)


@pytest.fixture(scope="session")
def meissner_engine(tmp_path_factory) -> Engine:
    """x'' + w^2 (1 + a s(t)) x = 0 with s = +1 for phase < d, -1 after.

    p = [w, a, P, d, c]; schedule [P, 0, d] computed from p; one switching
    function g = x - c whose side does NOT change the dynamics (to test event
    bookkeeping at breakpoints).  m = [sigma_0, n_0, seg_0].
    """
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", 2)
    p = ca.SX.sym("p", 5)
    m = ca.SX.sym("m", 3)
    w, a = p[0], p[1]
    s = ca.if_else(m[2] == 0, 1, -1)
    rhs = ca.vertcat(x[1], -(w**2) * (1 + a * s) * x[0] + 0 * m[0])
    return compile_model(
        _cache_dir(tmp_path_factory, "meissner"),
        t=t,
        x=x,
        p=p,
        m=m,
        g=x[0] - p[4],
        rhs=rhs,
        sched=ca.vertcat(p[2], 0, p[3]),
        nb=[2],
    )


def meissner_exact(p: dict, x0, t0: float, ts) -> tuple[np.ndarray, np.ndarray]:
    """Exact states at times ts (ascending, >= t0) and the transition matrix
    Phi(ts[-1], t0), by products of matrix exponentials."""
    from scipy.linalg import expm

    w, a, P, d = p["w"], p["a"], p["P"], p["d"]

    def A(seg):
        s = 1.0 if seg == 0 else -1.0
        return np.array([[0.0, 1.0], [-(w**2) * (1 + a * s), 0.0]])

    def seg_at(t):
        u = t / P
        return 0 if (u - np.floor(u)) < d else 1

    def breaks_between(ta, tb):
        out = []
        n = np.floor(ta / P) - 1
        while (n) * P <= tb + P:
            for c in (0.0, d):
                tt = (n + c) * P
                if ta < tt < tb:
                    out.append(tt)
            n += 1
        return sorted(out)

    Phi = np.eye(2)
    t = t0
    ys = []
    for tt in ts:
        knots = [t, *breaks_between(t, tt), tt]
        for ta, tb in zip(knots[:-1], knots[1:], strict=True):
            if tb > ta:
                Phi = expm(A(seg_at(0.5 * (ta + tb))) * (tb - ta)) @ Phi
        t = tt
        ys.append(Phi @ np.asarray(x0, dtype=float))
    return np.array(ys), Phi


# ----------------------------------------------------------------------------
# Error-path models
# ----------------------------------------------------------------------------
@pytest.fixture(scope="session")
def nan_engine(tmp_path_factory) -> Engine:
    """x' = -x + (NaN for t > p0): the RHS becomes non-finite at t = p0."""
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", 1)
    p = ca.SX.sym("p", 1)
    m = ca.SX.sym("m", 0)
    rhs = -x + ca.if_else(t > p[0], ca.SX(np.nan), 0)
    return compile_model(_cache_dir(tmp_path_factory, "nan"), t=t, x=x, p=p, m=m, g=ca.SX(0, 1), rhs=rhs)


@pytest.fixture(scope="session")
def chatter_engine(tmp_path_factory) -> Engine:
    """g = x, x' = -sigma * p0: the flow pushes straight back at the surface."""
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", 1)
    p = ca.SX.sym("p", 1)
    m = ca.SX.sym("m", 1)
    rhs = -m[0] * p[0] + 0 * x
    return compile_model(_cache_dir(tmp_path_factory, "chatter"), t=t, x=x, p=p, m=m, g=x[0], rhs=rhs)
