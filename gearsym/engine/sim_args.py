"""ctypes mirrors of the driver's argument structs (``gs_sim_args``, ... in gs_driver.h);
keep in sync.

Every mirror is checked when a model is loaded (:func:`gearsym.engine.driver.load_engine`):
its size against ``gs_sizeof_*`` and every field's offset, size and kind against the
driver's ``gs_abi_field`` table, so a mismatch (a field missing, two fields swapped) is an
error naming the field at load, never memory corruption.
"""

from __future__ import annotations

import ctypes as C

__all__ = ["GsCorrectorFlow", "GsIsolation", "GsMultipliers", "GsNewton", "GsOrbitFlow", "GsRamp", "GsSimArgs"]

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


class GsNewton(C.Structure):
    """ctypes mirror of ``struct gs_newton`` (gs_driver.h): THE Newton iteration's problem,
    policy, evaluation buffers and results; keep in sync."""

    _fields_ = [
        ("kind", C.c_int),
        ("n", C.c_int),
        ("nr", C.c_int),
        ("nx", C.c_int),
        ("segments", C.c_int),
        ("max_iter", C.c_int),
        ("tol", C.c_double),
        ("min_damping", C.c_double),
        ("decrease", C.c_double),
        ("accept_below", C.c_double),
        ("accept_last", C.c_int),
        ("apply_final_step", C.c_int),
        ("diverge_ratio", C.c_double),
        ("diverge_floor", C.c_double),
        ("trunc_level", C.c_double),
        ("scale_floor", C.c_double),
        ("row", _PD),
        ("target", C.c_double),
        ("S", _PD),
        ("Rs", _PD),
        ("n_anchor", C.c_int),
        ("anchor", _PD),
        ("t_ref", _PD),
        ("lapack_dgetrf", C.c_void_p),
        ("lapack_dgetrs", C.c_void_p),
        ("lapack_dgesdd", C.c_void_p),
        ("lapack_dgelsd", C.c_void_p),
        ("R", _PD),
        ("J", _PD),
        ("Flam", _PD),
        ("flam_given", C.c_int),
        ("amplitude", _PD),
        ("eval_status", C.c_int),
        ("eval_msg", C.c_char * 256),
        ("z", _PD),
        ("z_eval", _PD),
        ("request", C.c_int),
        ("answered", C.c_int),
        ("must_succeed", C.c_int),
        ("n_evals", C.c_int),
        ("iterations", C.c_int),
        ("outcome", C.c_int),
        ("note", C.c_int),
        ("residual", C.c_double),
        ("residual_prev", C.c_double),
        ("relative", C.c_double),
        ("scale", _PD),
        ("hist_cap", C.c_int),
        ("n_hist", C.c_int),
        ("hist_kind", _PI),
        ("hist_abs", _PD),
        ("hist_rel", _PD),
        ("hist_step", _PD),
        ("hist_drop", _PI),
        ("tangent", _PD),
        ("tangent_ok", C.c_int),
        ("work", _PD),
    ]


class GsOrbitFlow(C.Structure):
    """ctypes mirror of ``struct gs_orbit_flow`` (gs_driver.h): the shooting residual's C
    evaluator; keep in sync."""

    _fields_ = [
        ("s", _PD),
        ("n_amp", C.c_int),
        ("grid", _PD),
        ("ev_t", _PD),
        ("ev_surface", _PI),
        ("ev_dir", _PI),
        ("ev_speed", _PD),
        ("ev_cap", C.c_int),
        ("n_events", C.c_int),
        ("handback", C.c_int),
        ("events_needed", C.c_int),
        ("n_runs", C.c_int),
        ("t_reached", C.c_double),
        ("mult", GsMultipliers),
        ("iso", GsIsolation),
        ("g0_out", _PD),
        ("g0_ok", C.c_int),
        ("verify_ends", _PD),
        ("verify_ok", C.c_int),
        ("verify_status", C.c_int),
        ("verify_t_reached", C.c_double),
        ("verify_msg", C.c_char * 1024),
    ]


class GsCorrectorFlow(C.Structure):
    """ctypes mirror of ``struct gs_corrector_flow`` (gs_driver.h): the continuation residual's
    C evaluator; keep in sync."""

    _fields_ = [
        ("segments", C.c_int),
        ("nd", C.c_int),
        ("periods", C.c_double),
        ("t0", C.c_double),
        ("lam0", C.c_double),
        ("p0", _PD),
        ("D", _PD),
        ("atol", _PD),
        ("zalg", _PD),
        ("Ms", _PD),
        ("ev_t", _PD),
        ("ev_surface", _PI),
        ("ev_dir", _PI),
        ("ev_speed", _PD),
        ("ev_cap", C.c_int),
        ("n_events", C.c_int),
        ("handback", C.c_int),
        ("events_needed", C.c_int),
        ("n_runs", C.c_int),
        ("n_evals", C.c_int),
        ("last_c_eval", C.c_int),
        ("period", C.c_double),
        ("dP", C.c_double),
        ("n_samples", C.c_int),
        ("t_samples", _PD),
        ("Y_samples", _PD),
        ("G_samples", _PD),
        ("H_samples", _PD),
        ("samples_ok", C.c_int),
        ("col_stats", _PD),
        ("col_args", _PI),
        ("stats_ok", C.c_int),
        ("mult", GsMultipliers),
    ]
