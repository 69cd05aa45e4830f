"""Build helpers, loading, ABI check, thread safety."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from gearsym.engine.build import (
    DRIVER_C_FILES,
    ENGINE_DIR,
    build_shared_object,
    content_hash,
    find_sundials_libs,
)
from gearsym.engine.driver import GsSimArgs, load_engine
from gearsym.engine.errors import EngineABIError, EngineBuildError
from gearsym.errors import CompileError


def test_find_sundials_libs():
    sl = find_sundials_libs()
    names = " ".join(p.name for p in sl.libs)
    for stem in ("core", "cvode", "ida", "nvecserial", "sunmatrixdense", "sunlinsoldense"):
        assert f"libsundials_{stem}-" in names
    assert all(p.parent == sl.libdir for p in sl.libs)


def test_driver_sources_are_package_files():
    for f in (*DRIVER_C_FILES, "gs_driver.h", "gs_internal.h", "gs_model_abi.h", "sundials7.h"):
        assert (ENGINE_DIR / f).is_file()
    # every C file of the engine folder is a driver unit (the C project exporter copies them all)
    assert sorted(p.name for p in ENGINE_DIR.glob("*.c")) == sorted(DRIVER_C_FILES)


def test_build_failure_reports_compiler_stderr(tmp_path):
    src = tmp_path / "bad.c"
    src.write_text("int f(void) { return this_is_not_declared; }\n")
    with pytest.raises(EngineBuildError, match="this_is_not_declared") as ei:
        build_shared_object([src], [], tmp_path / "bad.so")
    assert isinstance(ei.value, CompileError)
    assert not (tmp_path / "bad.so").exists()
    assert not list(tmp_path.glob(".bad.so.*"))  # no temporary left behind


def test_content_hash_changes_with_content(tmp_path):
    a = tmp_path / "a.c"
    a.write_text("x")
    h1 = content_hash([a])
    a.write_text("y")
    assert content_hash([a]) != h1
    assert content_hash([a], "flags") != content_hash([a])


def test_load_checks(backlash_engine, tmp_path):
    assert backlash_engine.sundials_version.startswith("7.")
    assert backlash_engine._lib.gs_sizeof_args() == __import__("ctypes").sizeof(GsSimArgs)
    assert (backlash_engine.nx, backlash_engine.np, backlash_engine.nsw, backlash_engine.nsched) == (
        2,
        6,
        2,
        0,
    )
    with pytest.raises(EngineABIError, match="cannot load"):
        load_engine(tmp_path / "missing.so")


def test_parallel_threads_give_identical_results(backlash_engine):
    """No global state in the driver: concurrent runs (GIL released) agree
    with sequential ones."""
    Om = 0.8
    cases = [[0.05, 0.2, Om, 0.1, Fa, 1.0] for Fa in (0.3, 0.6, 1.0, 0.05)] * 2
    t_out = np.linspace(0, 100, 11)

    def run(p):
        return backlash_engine.run([1.1, 0.0], p, 0.0, 100.0, t_out, want_monodromy=True)

    seq = [run(p) for p in cases]
    with ThreadPoolExecutor(4) as ex:
        par = list(ex.map(run, cases))
    for a, b in zip(seq, par, strict=True):
        np.testing.assert_array_equal(a.y, b.y)
        np.testing.assert_array_equal(a.monodromy, b.monodromy)
        np.testing.assert_array_equal(a.events.t, b.events.t)


def test_missing_model_function_is_a_clear_error(tmp_path):
    """Model functions are weak symbols in the driver: a model without gs_jac
    loads, and running it gives a message naming the missing function."""
    import casadi as ca
    from conftest import backlash_exprs, compile_model

    from gearsym.engine.errors import EngineInputError

    t, x, p, m, g, F = backlash_exprs()
    eng = compile_model(tmp_path, t=t, x=x, p=p, m=m, g=g, rhs=ca.vertcat(x[1], F), omit=("gs_jac",))
    with pytest.raises(EngineInputError, match="lacks the function gs_jac"):
        eng.run([1.1, 0.0], [0.05, 0.2, 0.8, 0.1, 1.0, 1.0], 0.0, 1.0)


def test_sundials_symbols_stay_out_of_the_global_scope(backlash_engine):
    """The wheel's SUNDIALS 7 libraries are preloaded RTLD_LOCAL: a library that bundles
    another SUNDIALS (fmpy's CVODE) must not bind to them (with RTLD_GLOBAL fmpy's
    simulate_fmu crashed the process with a segmentation fault)."""
    import ctypes

    from gearsym.engine.build import preload_sundials

    preload_sundials()
    assert backlash_engine.sundials_version.startswith("7.")
    process = ctypes.CDLL(None)
    for name in ("CVodeCreate", "SUNContext_Create", "N_VNew_Serial"):
        assert not hasattr(process, name), name


def test_driver_helpers_are_not_exported(backlash_engine):
    """The driver is split into several files that share helpers through gs_internal.h;
    those have hidden visibility, so a model's shared object exports the API of gs_driver.h
    and nothing with the helpers' generic names (which could clash with another library)."""
    lib = backlash_engine._lib
    for name in ("gs_simulate", "gs_simulate_ws", "gs_shoot_ws", "gs_correct_ws", "gs_check_abi"):
        assert hasattr(lib, name), name
    internal = (ENGINE_DIR / "gs_internal.h").read_text()
    hidden = ("set_err", "lu_solve", "eval_rhs", "cv_rhs", "ws_model_setup", "lapack_multipliers")
    for name in hidden:
        assert f" {name}(" in internal, name  # still a shared helper
        assert not hasattr(lib, name), name


def _swapped(mirror: type, a: str, b: str) -> type:
    """``mirror`` with fields ``a`` and ``b`` (one size) exchanged: the same total size."""
    import ctypes

    fields = list(mirror._fields_)
    names = [f[0] for f in fields]
    i, j = names.index(a), names.index(b)
    fields[i], fields[j] = fields[j], fields[i]
    out = type(mirror.__name__, (ctypes.Structure,), {"_fields_": fields})
    assert ctypes.sizeof(out) == ctypes.sizeof(mirror)
    return out


@pytest.mark.parametrize("mirror, struct, a, b", [
    ("GsSimArgs", "gs_sim_args", "rtol", "atol"),
    ("GsSimArgs", "gs_sim_args", "x_final", "monodromy"),
    ("GsSimArgs", "gs_sim_args", "n_out", "storm_events"),
    ("GsNewton", "gs_newton", "hist_abs", "hist_rel"),
    ("GsCorrectorFlow", "gs_corrector_flow", "n_runs", "n_evals"),
    ("GsOrbitFlow", "gs_orbit_flow", "verify_ok", "verify_status"),
    ("GsMultipliers", "gs_multipliers", "mu_re", "mu_im"),
    ("GsIsolation", "gs_isolation", "sigma", "norm"),
])
def test_mirror_with_two_swapped_fields_is_refused_at_load(backlash_engine, monkeypatch, mirror, struct, a, b):
    """Issue 24 item 13b: the ctypes mirrors were checked by total size only, so two swapped
    fields of one size passed (and the driver read rtol as atol).  Now every field's offset is
    compared with the driver's own table (gs_abi_field), and the message names the field."""
    import gearsym.engine.driver as drv

    drv.load_engine(backlash_engine.path)  # the real mirrors load
    monkeypatch.setattr(drv, mirror, _swapped(getattr(drv, mirror), a, b))
    with pytest.raises(EngineABIError, match=rf"{struct}\.{a} is at offset \d+ \(\d+ bytes, \w+\) in C but at "
                                             rf"offset \d+ .* in the ctypes mirror {mirror} "):
        drv.load_engine(backlash_engine.path)


def test_mirror_with_a_field_of_another_kind_is_refused_at_load(backlash_engine, monkeypatch):
    """A double declared as a pointer (same offset, same size) is refused too."""
    import ctypes

    import gearsym.engine.driver as drv

    fields = [(n, ctypes.c_void_p if n == "atol" else t) for n, t in GsSimArgs._fields_]
    monkeypatch.setattr(drv, "GsSimArgs", type("GsSimArgs", (ctypes.Structure,), {"_fields_": fields}))
    with pytest.raises(EngineABIError, match=r"gs_sim_args\.atol is at offset 16 \(8 bytes, double\) in C but at "
                                             r"offset 16 \(8 bytes, pointer\)"):
        drv.load_engine(backlash_engine.path)


def test_the_layout_table_covers_every_field_of_the_mirrors(backlash_engine):
    from gearsym.engine.driver import c_layout, mirror_layout
    from gearsym.engine.sim_args import (
        GsCorrectorFlow,
        GsIsolation,
        GsMultipliers,
        GsNewton,
        GsOrbitFlow,
        GsRamp,
    )

    layout = c_layout(backlash_engine._lib)
    for struct, mirror in (("gs_sim_args", GsSimArgs), ("gs_newton", GsNewton), ("gs_orbit_flow", GsOrbitFlow),
                           ("gs_corrector_flow", GsCorrectorFlow), ("gs_multipliers", GsMultipliers),
                           ("gs_isolation", GsIsolation), ("gs_ramp", GsRamp)):
        assert layout[struct] == mirror_layout(mirror)
