"""ctypes mirrors of the driver's argument structs (``gs_sim_args``, ... in gs_driver.h);
keep in sync.

Every mirror is checked when a model is loaded (:func:`gearsym.engine.driver.load_engine`):
its size against ``gs_sizeof_*`` and every field's offset, size and kind against the
driver's ``gs_abi_field`` table, so a mismatch (a field missing, two fields swapped) is an
error naming the field at load, never memory corruption.
"""

from __future__ import annotations

import ctypes as C

__all__ = ["GsCorrectArgs", "GsIsolation", "GsMultipliers", "GsRamp", "GsShootArgs", "GsSimArgs"]

# Pointer members are declared c_void_p (same layout as double*/int*) so that
# numpy buffers can be passed as plain addresses (fast: no ctypes casts).
_PD = C.c_void_p
_PI = C.c_void_p


class GsRamp(C.Structure):
    """ctypes mirror of ``struct gs_ramp`` (gs_driver.h: a speed ramp); keep in sync."""

    _fields_ = [
        ("on", C.c_int),
        ("index", C.c_int),
        ("t0", C.c_double),
        ("speed0", C.c_double),
        ("rate", C.c_double),
    ]


class GsSimArgs(C.Structure):
    """ctypes mirror of ``struct gs_sim_args`` (gs_driver.h); keep in sync."""

    _fields_ = [
        # inputs
        ("method", C.c_int),
        ("rtol", C.c_double),
        ("atol", C.c_double),
        ("t0", C.c_double),
        ("t_end", C.c_double),
        ("x0", _PD),
        ("p", _PD),
        ("sigma0", _PD),
        ("n_out", C.c_int),
        ("t_out", _PD),
        ("max_steps", C.c_long),
        ("max_events", C.c_long),
        ("storm_events", C.c_int),
        ("storm_window", C.c_double),
        ("max_step", C.c_double),
        ("init_step", C.c_double),
        ("want_monodromy", C.c_int),
        ("max_events_out", C.c_int),
        ("check_interrupt", C.c_int),
        ("interrupt_fd", C.c_int),
        ("nonlinear", C.c_int),
        ("linear_solver", C.c_int),
        ("atol_vec", _PD),
        # outputs
        ("y_out", _PD),
        ("x_final", _PD),
        ("sigma_final", _PD),
        ("monodromy", _PD),
        ("ev_t", _PD),
        ("ev_surface", _PI),
        ("ev_dir", _PI),
        ("ev_speed", _PD),
        ("n_events", C.c_int),
        ("t_reached", C.c_double),
        ("n_steps", C.c_long),
        ("n_rhs", C.c_long),
        ("n_jac", C.c_long),
        ("n_root_evals", C.c_long),
        ("n_breaks", C.c_long),
        ("n_reinit", C.c_long),
        ("status", C.c_int),
        ("errmsg", C.c_char * 1024),
        # parameter sensitivities
        ("n_sens", C.c_int),
        ("sens_dir", _PD),
        ("sens_dt0", _PD),
        ("sens_dt1", _PD),
        ("sens_final", _PD),
        ("sens_out", _PD),
        # speed ramp, breakpoint log
        ("ramp", GsRamp),
        ("max_breaks_out", C.c_int),
        ("brk_t", _PD),
    ]


class GsMultipliers(C.Structure):
    """ctypes mirror of ``struct gs_multipliers`` (gs_driver.h); keep in sync."""

    _fields_ = [
        ("lapack_dgebal", C.c_void_p),
        ("lapack_dgesdd", C.c_void_p),
        ("lapack_dgeev", C.c_void_p),
        ("rtol", C.c_double),
        ("mu_re", _PD),
        ("mu_im", _PD),
        ("mu_tol", _PD),
        ("delta", C.c_double),
        ("ok", C.c_int),
    ]


class GsIsolation(C.Structure):
    """ctypes mirror of ``struct gs_isolation`` (gs_driver.h); keep in sync."""

    _fields_ = [
        ("direction", _PD),
        ("sigma", C.c_double),
        ("norm", C.c_double),
        ("ok", C.c_int),
    ]


class GsShootArgs(C.Structure):
    """ctypes mirror of ``struct gs_shoot_args`` (gs_driver.h); keep in sync."""

    _fields_ = [
        ("tol", C.c_double),
        ("scale_floor", C.c_double),
        ("pivot_tol", C.c_double),
        ("max_iter", C.c_int),
        ("x", _PD),
        ("scale", _PD),
        ("hist_abs", _PD),
        ("hist_rel", _PD),
        ("n_hist", C.c_int),
        ("iterations", C.c_int),
        ("note", C.c_int),
        ("outcome", C.c_int),
        ("mult", GsMultipliers),
        ("iso", GsIsolation),
        ("g0_out", _PD),
        ("g0_ok", C.c_int),
    ]


class GsCorrectArgs(C.Structure):
    """ctypes mirror of ``struct gs_correct_args`` (gs_driver.h); keep in sync."""

    _fields_ = [
        ("nx", C.c_int),
        ("z", _PD),
        ("row", _PD),
        ("target", C.c_double),
        ("S", _PD),
        ("Rs", _PD),
        ("tol", C.c_double),
        ("max_iter", C.c_int),
        ("min_damping", C.c_double),
        ("periods", C.c_double),
        ("lam0", C.c_double),
        ("p0", _PD),
        ("D", _PD),
        ("atol", C.c_double),
        ("dP", C.c_double),
        ("R_out", _PD),
        ("M_out", _PD),
        ("Flam_out", _PD),
        ("residual", C.c_double),
        ("iterations", C.c_int),
        ("n_runs", C.c_int),
        ("outcome", C.c_int),
        ("n_samples", C.c_int),
        ("t_samples", _PD),
        ("Y_samples", _PD),
        ("G_samples", _PD),
        ("H_samples", _PD),
        ("samples_ok", C.c_int),
        ("col_stats", _PD),
        ("col_args", _PD),
        ("stats_ok", C.c_int),
        ("t_ref", _PD),
        ("tangent_out", _PD),
        ("tangent_ok", C.c_int),
        ("period_out", C.c_double),
        ("mult", GsMultipliers),
        ("n_anchor", C.c_int),
        ("anchor", _PD),
        ("lapack_dgelsd", C.c_void_p),
    ]
