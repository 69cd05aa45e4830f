"""Code generation: symbolic model -> CasADi SX functions -> C -> shared object.

The generated functions follow the contract in ``gearsym/engine/gs_model_abi.h``
(``gs_rhs``, ``gs_jac``, ``gs_res``, ``gs_resjac``, ``gs_sw``, ``gs_swx``, ``gs_swt``,
``gs_sched``, ``gs_period`` and ``gs_model_info``, and for the parameter sensitivities
``gs_jacp``, ``gs_swp``, ``gs_schedp``, ``gs_periodp``).  Parameters are inputs of every
function, so changing one never recompiles.  :func:`write_and_compile` writes the
sources into a private staging folder and compiles them with ``gcc -O3`` together
with the engine's C driver into ``gs_<sha256[:16]>.so`` (named by its own bytes:
``dlopen`` caches by path, so a different object never hides behind an old name);
:mod:`gearsym.codegen.cache` keys, verifies and installs builds.

Nothing user-written reaches the C files unescaped: names appear only in the
header comment, through :func:`c_comment`.
"""

from __future__ import annotations

import time
from pathlib import Path

import casadi as ca
import sympy as sp

from ..errors import CompileError
from ..symbolic.budget import Budget
from ..symbolic.model import SymbolicModel
from .artifact import CODEGEN_VERSION, GeneratedModel
from .cache import KEY_MARKER
from .extras import DOCS as _EXTRA_DOCS
from .extras import analysis_functions, analysis_meta
from .sx import SXTranslator

ENGINE_DIR = Path(__file__).resolve().parent.parent / "engine"


#: Characters that :func:`c_comment` keeps as they are.
_COMMENT_SAFE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_ .,:;=+-()[]{}<>'\"#!&|^~@$")


def c_comment(text: object, limit: int = 160) -> str:
    """Text made safe for the inside of a C ``/* ... */`` comment.

    Every character outside a conservative printable set (letters, digits, space,
    ``_ . , : ; = + - ( ) [ ] { } < > ' " # ! & | ^ ~ @ $``) is written as ``%XX``
    (UTF-8 bytes, percent-encoded; ``%`` itself too), so no ``*/``, ``/*``,
    backslash-newline, trigraph or control character can end the comment or splice
    lines; text longer than ``limit`` characters is cut with ``...``.

    Parameters
    ----------
    text
        Any user-derived text (model, scene, state, parameter or element names).
    limit
        Maximal length of the result before the ``...``.

    Returns
    -------
    str
        A single line containing no ``*``, ``/``, ``\\``, ``?`` or control characters.
    """
    out = []
    n = 0
    for ch in str(text):
        piece = ch if ch in _COMMENT_SAFE else "".join(f"%{b:02X}" for b in ch.encode("utf-8"))
        if n + len(piece) > limit:
            out.append("...")
            break
        out.append(piece)
        n += len(piece)
    return "".join(out)


def build_functions(model: SymbolicModel, derivatives: bool = False) -> dict[str, ca.Function]:
    """Build the CasADi functions of the engine contract from a symbolic model.

    With ``derivatives`` also the parameter derivatives of the sensitivities: ``gs_jacp``
    (d f / d p; implicit models: ``gs_resp``, d F / d p of the residual, and ``gs_rest``,
    d F / d t, for the time derivative of the algebraic variables), ``gs_swp`` (d g / d p),
    ``gs_schedp`` and ``gs_periodp``, with respect to *every* parameter (sparse), so that choosing the
    parameters at run time never recompiles.  They are a separate build, made on the
    first sensitivity request (:meth:`gearsym.system.System.simulate`): measured on the
    shipped scenes they add 20-370 % to the C compile (``benchmarks/sensitivity_cost.py``:
    ``gs_jacp`` has 1.3-4x the operations of ``gs_rhs``), which a user who never asks
    for sensitivities should not pay.
    """
    budget = Budget(what=f"generating the functions of model '{model.name}'", file=model.spec.path)
    with budget.active():
        return _build_functions(model, derivatives, budget)


def _build_functions(model: SymbolicModel, derivatives: bool, budget: Budget) -> dict[str, ca.Function]:
    nx = len(model.states)
    params = model.parameters
    nsw = len(model.switching)
    nsched = len(model.schedules)
    nm = nsw + 2 * nsched
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", nx)
    p = ca.SX.sym("p", len(params))
    m = ca.SX.sym("m", nm)
    symbols: dict[sp.Symbol, ca.SX] = {model.t: t}
    symbols.update({s: x[i] for i, s in enumerate(model.states)})
    symbols.update({s: p[i] for i, s in enumerate(params)})
    symbols.update({s: m[j] for j, s in enumerate(model.modal.sigma)})
    for k, s in enumerate(model.schedules):
        symbols[s.n] = m[nsw + 2 * k]
        symbols[s.seg] = m[nsw + 2 * k + 1]
    tr = SXTranslator(symbols, budget)
    fns: dict[str, ca.Function] = {}
    if model.form == "explicit":
        f = ca.cse(tr.matrix(model.modal.rhs))  # common subexpressions once (10-30 % fewer operations)
        fns["gs_rhs"] = ca.Function("gs_rhs", [t, x, p, m], [f], ["t", "x", "p", "m"], ["xdot"])
        fns["gs_jac"] = ca.Function("gs_jac", [t, x, p, m], [ca.cse(ca.jacobian(f, x))],
                                    ["t", "x", "p", "m"], ["J"])
        if derivatives:  # d f / d p, all columns, sparse: the driver contracts it with the directions
            fns["gs_jacp"] = ca.Function("gs_jacp", [t, x, p, m], [ca.jacobian(f, p)],
                                         ["t", "x", "p", "m"], ["Jp"])
    else:
        xd = ca.SX.sym("xd", nx)
        cj = ca.SX.sym("cj")
        xd_syms = [sp.Symbol(f"__xd{i}") for i in range(nx)]
        tr.symbols.update({s: xd[i] for i, s in enumerate(xd_syms)})
        r = tr.matrix(model.residual(xd_syms))
        fns["gs_res"] = ca.Function("gs_res", [t, x, xd, p, m], [r], ["t", "x", "xd", "p", "m"], ["r"])
        jr = ca.jacobian(r, x) + cj * ca.jacobian(r, xd)  # sparse: the driver densifies
        fns["gs_resjac"] = ca.Function("gs_resjac", [t, x, xd, p, m, cj], [jr],
                                       ["t", "x", "xd", "p", "m", "cj"], ["Jr"])
        if derivatives:  # d F / d p (sparse; IDAS-style sensitivities) and d F / d t (z' at a moving end)
            fns["gs_resp"] = ca.Function("gs_resp", [t, x, xd, p, m], [ca.jacobian(r, p)],
                                         ["t", "x", "xd", "p", "m"], ["Rp"])
            fns["gs_rest"] = ca.Function("gs_rest", [t, x, xd, p, m], [ca.densify(ca.jacobian(r, t))],
                                         ["t", "x", "xd", "p", "m"], ["Rt"])
        # the explicit right-hand side is still useful from Python (plots, checks)
    budget.check("gs_sw")
    g = ca.vertcat(*[tr(s.expr) for s in model.switching]) if nsw else ca.SX(0, 1)
    fns["gs_sw"] = ca.Function("gs_sw", [t, x, p], [g], ["t", "x", "p"], ["g"])
    fns["gs_swx"] = ca.Function("gs_swx", [t, x, p], [ca.jacobian(g, x)], ["t", "x", "p"], ["G"])  # sparse
    fns["gs_swt"] = ca.Function("gs_swt", [t, x, p], [ca.densify(ca.jacobian(g, t))], ["t", "x", "p"], ["gt"])
    if derivatives:  # event-time sensitivities: d g / d p (sparse)
        fns["gs_swp"] = ca.Function("gs_swp", [t, x, p], [ca.jacobian(g, p)], ["t", "x", "p"], ["Gp"])
    sched = []
    for s in model.schedules:
        sched.append(tr(s.period))
        sched += [tr(b) for b in s.breaks]
    sv = ca.vertcat(*sched) if sched else ca.SX(0, 1)
    fns["gs_sched"] = ca.Function("gs_sched", [p], [sv], ["p"], ["s"])
    period = tr(model.forcing_period) if model.forcing_period is not None else ca.SX(float("nan"))
    fns["gs_period"] = ca.Function("gs_period", [p], [period], ["p"], ["T"])
    scales = getattr(model, "scales", None)
    if scales is not None:  # a model in dimensionless variables: [T, s_1, ..., s_n]
        fns["gs_scales"] = ca.Function("gs_scales", [p], [ca.vertcat(*[tr(e) for e in scales])], ["p"], ["s"])
    if derivatives:  # breakpoint-time and period sensitivities
        fns["gs_schedp"] = ca.Function("gs_schedp", [p], [ca.densify(ca.jacobian(sv, p))], ["p"], ["sp"])
        fns["gs_periodp"] = ca.Function("gs_periodp", [p], [ca.densify(ca.jacobian(period, p))], ["p"], ["Tp"])
    outputs = getattr(model, "outputs", {})
    if outputs:
        o = ca.vertcat(*[tr(e) for e in outputs.values()])
        fns["gs_out"] = ca.Function("gs_out", [t, x, p, m], [o], ["t", "x", "p", "m"], ["y"])
    budget.check("analysis functions")
    fns.update(analysis_functions(model, tr, t, x, p, m))
    return fns


_HEADER = """/*
 * Generated by gearsym {version} for scene '{scene}' (model '{model}').  Do not edit.
 *
 * States     x = [{states}]
 * Parameters p = [{params}]
 * Mode       m = [{modes}]
 *
 * Functions (CasADi C API; see gearsym/engine/gs_model_abi.h):
{functions}
 */
"""
_DOCS = {
    "gs_rhs": "first-order right-hand side xdot = f(t, x, p, m) in the mode m",
    "gs_jac": "Jacobian d f / d x (sparse, CasADi compressed-column)",
    "gs_res": "implicit residual r = [q' - v; M(q) v' - F(t, q, v, p, m); constraint rows]",
    "gs_resjac": "dr/dx + cj * dr/dxd (sparse), for IDA's Newton iteration",
    "gs_sw": "switching functions g(t, x, p) (events at their zeros)",
    "gs_swx": "d g / d x, for saltation matrices",
    "gs_swt": "d g / d t, for saltation matrices",
    "gs_sched": "schedules: [period, break fractions...] for each schedule",
    "gs_period": "the scene's forcing period T(p)",
    "gs_jacp": "d f / d p (sparse), for the parameter sensitivities",
    "gs_resp": "d r / d p of the implicit residual (sparse), for the parameter sensitivities (IDA)",
    "gs_rest": "d r / d t of the implicit residual, for the time derivative of the algebraic variables",
    "gs_swp": "d g / d p (sparse), for the event-time sensitivities",
    "gs_schedp": "d s / d p of the schedules (breakpoint-time sensitivities)",
    "gs_periodp": "d T / d p of the forcing period",
    "gs_out": "the model's [outputs] along a trajectory (post-processing, not used by the driver)",
    "gs_scales": "reference scales [T, s_1, ..., s_n] of the dimensionless variables (t = T*tau, q = s*Q)",
    **_EXTRA_DOCS,
}


def model_c_sources(model: SymbolicModel, fns: dict[str, ca.Function], scene: str,
                    build_key: str) -> tuple[str, str]:
    """The text of ``gs_model.c`` and ``gs_model.h``.

    User-written names enter only the header comment, escaped by :func:`c_comment`;
    the key (hex digits of our own) is compiled in as ``gs_build_key()``.
    """
    import tempfile

    if not all(c in "0123456789abcdef" for c in build_key):
        raise ValueError("build_key must be lowercase hex")
    cg = ca.CodeGenerator("gs_model.c", {"with_header": True, "casadi_real": "double"})
    for f in fns.values():
        cg.add(f)
    with tempfile.TemporaryDirectory(prefix="gearsym-cg-") as tmp:
        cg.generate(str(tmp) + "/")
        c_text = (Path(tmp) / "gs_model.c").read_text()
        h_text = (Path(tmp) / "gs_model.h").read_text()
    nsw = len(model.switching)
    modes = [f"sigma_{j} (side of {c_comment(s.name, 64)})" for j, s in enumerate(model.switching)]
    for s in model.schedules:
        modes += [f"n_{c_comment(s.name, 64)}", f"seg_{c_comment(s.name, 64)}"]
    header = _HEADER.format(
        version=CODEGEN_VERSION, scene=c_comment(scene), model=c_comment(model.name),
        states=c_comment(", ".join(model.state_names), 2000),
        params=c_comment(", ".join(model.parameter_names), 4000),
        modes=", ".join(modes),
        functions="\n".join(f" *   {name:10s} {_DOCS[name]}" for name in fns),
    )
    info = [len(model.states), len(model.parameters), nsw + 2 * len(model.schedules), nsw,
            len(model.schedules), 1 if model.form == "implicit" else 0]
    info += [len(s.breaks) for s in model.schedules]
    info.append(len(getattr(model, "algebraic", [])))  # algebraic variables: the last states (IDA id = 0)
    info_c = (
        "/* Model metadata for the gearsym driver (see gs_model_abi.h). */\n"
        "int gs_model_info(int* out, int len) {\n"
        f"  static const int info[{len(info)}] = {{{', '.join(map(str, info))}}};\n"
        f"  int i;\n  if (len < {len(info)}) return -1;\n"
        f"  for (i = 0; i < {len(info)}; ++i) out[i] = info[i];\n  return {len(info)};\n}}\n"
        "/* Key of this build (gearsym.codegen.cache.build_key), checked when it is loaded. */\n"
        f'static const char gs_build_key_text[] = "{KEY_MARKER.decode()}{build_key}";\n'
        f"const char* gs_build_key(void) {{ return gs_build_key_text + {len(KEY_MARKER)}; }}\n"
    )
    return (header + c_text + "\n" + info_c,
            header + h_text + "\nint gs_model_info(int* out, int len);\nconst char* gs_build_key(void);\n")


def write_and_compile(model: SymbolicModel, fns: dict[str, ca.Function], staging: Path, directory: Path,
                      scene: str, build_key: str, effects: dict,
                      key_parts: dict | None = None) -> GeneratedModel:
    """Write the C sources into ``staging``, compile and verify them, write ``meta.json``.

    Parameters
    ----------
    model, fns
        The symbolic model and its CasADi functions (:func:`build_functions`).
    staging
        A private, empty folder (:meth:`gearsym.codegen.cache.BuildCache.staging`).
    directory
        Where the build will be installed (recorded in ``meta.json``).
    scene, build_key, effects, key_parts
        Scene name, the build's key and what it was computed from.

    Returns
    -------
    GeneratedModel
        With paths inside ``directory``.

    Raises
    ------
    CompileError
        If the compiler fails or the object does not load with the right key.
    """
    from ..engine import build as engine_build
    from ..engine.driver import load_engine

    t0 = time.perf_counter()
    c_text, h_text = model_c_sources(model, fns, scene, build_key)
    (staging / "gs_model.c").write_text(c_text)
    (staging / "gs_model.h").write_text(h_text)
    built = staging / "gs_model.so"
    try:
        driver = engine_build.driver_object(engine_build.driver_cache_dir(staging.parent / ".driver"))
        engine_build.build_shared_object([Path("gs_model.c"), driver], [Path("."), ENGINE_DIR], built, cwd=staging,
                                         extra_cflags=engine_build.model_cflags(len(c_text)))
        digest = engine_build.file_sha256(built)
        so = staging / f"gs_{digest[:16]}.so"
        built.rename(so)
        load_engine(so, sha256=digest, build_key=build_key)  # the object loads and is ours
    except Exception as exc:  # surface compiler and loader errors as gearsym errors
        raise CompileError(f"compiling {directory.name} failed: {exc}") from exc
    gen = GeneratedModel(
        scene=scene, key=build_key[:16], directory=str(directory), so_path=str(directory / so.name),
        state_names=model.state_names, param_names=model.parameter_names,
        surfaces=[{"name": s.name, "kind": s.kind, "contact_sign": s.contact_sign,
                   "meaning": s.meaning, "expr": sp.sstr(s.expr), "field": s.origin} for s in model.switching],
        schedules=[{"name": s.name, "n_breaks": len(s.breaks)} for s in model.schedules],
        implicit=model.form == "implicit",
        n_ops={name: int(f.n_instructions()) for name, f in fns.items()},
        effects=dict(effects),
        compile_seconds=time.perf_counter() - t0,
        cached=False,
        functions={name: f.serialize() for name, f in fns.items()},
        bound={k: [f, list(a)] for k, (f, a) in getattr(model, "bound_parameters", {}).items()},
        outputs=list(getattr(model, "outputs", {})),
        output_units={k: (o.unit or "") for k, o in model.spec.outputs.items()},
        **analysis_meta(model),
        build_key=build_key, so_sha256=digest, key_parts=dict(key_parts or {}), model=model.name,
        built=time.time(), dimensionless=getattr(model, "scales", None) is not None,
        algebraic=[str(a) for a in getattr(model, "algebraic", [])],
    )
    (staging / "meta.json").write_text(gen.to_json())
    return gen
