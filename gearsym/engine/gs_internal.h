/*
 * gs_internal.h -- private declarations shared by the translation units of the gearsym
 * driver (gs_driver.c and the gs_*.c files beside it): the model-function table, the
 * per-simulation data, the solver, schedule, event-log and workspace structs, and the
 * prototypes of the helpers one file defines and another calls.  Not part of the
 * public API (gs_driver.h); every function declared here has hidden visibility, so a
 * model's shared object exports only the gs_* entry points of gs_driver.h.
 */
#ifndef GS_INTERNAL_H
#define GS_INTERNAL_H

#if !defined(_POSIX_C_SOURCE) || _POSIX_C_SOURCE < 200809L
#undef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* open_memstream */
#endif
#include <errno.h>
#include <float.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The driver is compiled once (gearsym.engine.build.driver_object) and linked with
 * each generated model, so it does not include the model's header: the CasADi types
 * are CasADi's defaults (the generated code is made with the same defaults). */
#ifndef casadi_real
#define casadi_real double
#endif
#ifndef casadi_int
#define casadi_int long long int
#endif
#include "gs_model_abi.h"
#include "gs_driver.h"
#include "sundials7.h"

/* casadi_real must be double (sunrealtype and the driver API are double). */
typedef char gs_assert_casadi_real_is_double[(sizeof(casadi_real) == sizeof(double)) ? 1 : -1];

/* --------------------------------------------------------------------------
 * Model functions.  All are declared weak: an explicit model has no
 * gs_res/gs_resjac, an implicit one no gs_rhs/gs_jac, and a missing function
 * must become a clear error message at run time, not a link or dlopen error.
 * Redeclaring the prototypes of gs_model.h with the weak attribute is allowed.
 * -------------------------------------------------------------------------- */
#define GS_WEAK __attribute__((weak))
#define GS_DECLARE_MODEL_FN(NAME)                                                   \
  extern int NAME(const casadi_real** arg, casadi_real** res, casadi_int* iw,       \
                  casadi_real* w, int mem) GS_WEAK;                                 \
  extern int NAME##_work(casadi_int* sz_arg, casadi_int* sz_res, casadi_int* sz_iw, \
                         casadi_int* sz_w) GS_WEAK;                                 \
  extern casadi_int NAME##_n_in(void) GS_WEAK;                                      \
  extern casadi_int NAME##_n_out(void) GS_WEAK;                                     \
  extern const casadi_int* NAME##_sparsity_in(casadi_int i) GS_WEAK;                \
  extern const casadi_int* NAME##_sparsity_out(casadi_int i) GS_WEAK;

GS_DECLARE_MODEL_FN(gs_rhs)
GS_DECLARE_MODEL_FN(gs_jac)
GS_DECLARE_MODEL_FN(gs_res)
GS_DECLARE_MODEL_FN(gs_resjac)
GS_DECLARE_MODEL_FN(gs_sw)
GS_DECLARE_MODEL_FN(gs_swx)
GS_DECLARE_MODEL_FN(gs_swt)
GS_DECLARE_MODEL_FN(gs_sched)
GS_DECLARE_MODEL_FN(gs_period)
GS_DECLARE_MODEL_FN(gs_out)
GS_DECLARE_MODEL_FN(gs_mesh)
GS_DECLARE_MODEL_FN(gs_jacp)
GS_DECLARE_MODEL_FN(gs_swp)
GS_DECLARE_MODEL_FN(gs_schedp)
GS_DECLARE_MODEL_FN(gs_periodp)
GS_DECLARE_MODEL_FN(gs_resp)
GS_DECLARE_MODEL_FN(gs_rest)
extern int gs_model_info(int* out, int len) GS_WEAK;

typedef int (*gs_cfun_ptr)(const casadi_real**, casadi_real**, casadi_int*, casadi_real*, int);
typedef int (*gs_work_ptr)(casadi_int*, casadi_int*, casadi_int*, casadi_int*);
typedef casadi_int (*gs_nio_ptr)(void);
typedef const casadi_int* (*gs_sp_ptr)(casadi_int);

/* One CasADi function with its (single) output sparsity. */
typedef struct {
  const char* name;
  gs_cfun_ptr f;
  int present;
  int n_in;
  int nrow, ncol, nnz, dense;
  const casadi_int* colind; /* sparse output only */
  const casadi_int* row;
} gs_fn;

#define GS_FN_SETUP(FN, NAME) \
  gs_fn_setup(&(FN), #NAME, NAME, NAME##_work, NAME##_n_in, NAME##_n_out, NAME##_sparsity_in, NAME##_sparsity_out)

/* --------------------------------------------------------------------------
 * Per-simulation data (the SUNDIALS user data)
 * -------------------------------------------------------------------------- */
typedef struct {
  int nx, np, nm, nsw, nsched, implicit;
  int nalg;        /* algebraic variables: the last nalg states (IDA id = 0)  */
  int nd;          /* differential states nx - nalg                          */
  int nA;          /* solver state size: nx, or nx*(nd+1) with monodromy      */
  int mono;        /* variational equations on                               */
  int ns;          /* parameter sensitivity directions (0: none)             */
  int nvc;         /* variational columns after the state: mono*nd + ns      */
  const double* sdir; /* [np*ns] column-major sensitivity directions         */
  double* Fp;      /* [nx*np] dense d f / d p (IDA: d F / d p), scratch      */
  double* Gp;      /* [nsw*np] dense d g / d p (column-major), scratch       */
  int blockdiag;   /* block-diagonal linear solver of the variational system */
  int use_ida;
  const double* p;
  gs_ramp ramp;    /* speed ramp of the current call (gs_ramp.c; ramp.on = 0: none) */
  double* pw;      /* [np] the parameters with the ramped speed (ramp on)     */
  double* m;       /* current mode vector [nm]                               */
  double* m_alt;   /* scratch mode vector [nm]                               */
  double dummy[1]; /* non-NULL pointer for empty inputs                      */

  gs_fn rhs, jac, res, resjac, sw, swx, swt, sched, period, out, mesh;
  gs_fn jacp, swp, schedp, periodp; /* parameter derivatives (optional)     */
  gs_fn resp_fn, rest_fn; /* implicit models: d F / d p and d F / d t (optional)  */
  const casadi_real** arg;
  casadi_real** resp;
  casadi_int* iw;
  casadi_real* w;
  double* nzbuf;   /* raw nonzeros of a sparse output                        */

  double* J;       /* [nx*nx] dense Jacobian, column-major                   */
  double* J2;      /* [nx*nx] scratch                                        */
  double* f;       /* [nx] scratch                                           */
  double* f2;      /* [nx] scratch                                           */
  double* f3;      /* [nx] scratch                                           */
  double* xs;      /* [nx] scratch state (DAE: consistent algebraic part)    */
  double* ypc;     /* [nx] consistent derivative (IDA sensitivities)         */
  double* g;       /* [nsw]                                                  */
  double* G;       /* [nsw*nx] column-major                                  */
  double* gt;      /* [nsw]                                                  */
  int* rootsfound; /* [nsw]                                                  */
  int* rootdir;    /* [nsw]                                                  */

  /* last non-finite value seen in a callback */
  int nf_seen;
  double nf_t;
  int nf_index;
  int nf_state_index; /* first non-finite state entry, or -1 */
  const char* nf_what;

  /* interrupt polling (see the top of gs_driver.c) */
  int intr_fd;      /* -1: off */
  int intr_mask;    /* GS_INTR_SIGINT | GS_INTR_SIGTERM: the signals that stop the run */
  int intr_count;
  int interrupted;

  /* last SUNDIALS error message */
  char sunmsg[512];
} gs_ud;

/* --------------------------------------------------------------------------
 * Solver abstraction over CVODE and IDA
 * -------------------------------------------------------------------------- */
typedef struct {
  int ida;
  void* mem;
  N_Vector y, yp, id;
  SUNMatrix A;
  SUNLinearSolver LS;
  SUNNonlinearSolver NLS; /* fixed-point iteration (else CVODE's default Newton) */
  long acc_steps, acc_rhs, acc_jac, acc_g;
  char flagname[64];
} gs_solver;

/* Schedules: the breakpoint times t = (n + c_i) P_k of every schedule k (with a speed
 * ramp: the times where the phase time tau(t) is (n + c_i) P_k, gs_ramp.c). */
typedef struct {
  int nsched;
  const int* nb;
  const int* off; /* offset of [P_k, c_0..] in s */
  const double* s;
  const gs_ramp* ramp; /* NULL or off: the schedules run on t */
} gs_sched_data;

/* The event log of one run (gs_events.c). */
typedef struct {
  gs_sim_args* a;
  long max_events;
  int storm_events;
  double storm_window; /* <= 0: default 1e-9*max(1,|t|) */
  int storm_count;
  double last_t;
} gs_evlog;

/* --------------------------------------------------------------------------
 * Workspaces: what one model needs across calls (model metadata and function
 * checks, CasADi work buffers, the SUNDIALS context, vectors, matrix, linear
 * and nonlinear solvers and the CVODE/IDA memory).  A call with the same
 * configuration (method, monodromy, solvers) reuses them with CVodeReInit /
 * IDAReInit instead of allocating everything again: the fixed cost of a short
 * integration (a shooting residual) drops to the integration itself.  A
 * workspace is used by one thread at a time; gs_simulate makes a temporary one.
 * -------------------------------------------------------------------------- */
struct gs_workspace {
  int ready;                /* model part set up                                 */
  int info[64];
  int nsched_total;
  casadi_int mx[5];
  gs_ud U;
  gs_solver S;
  int cfg_valid, cfg_nA, cfg_ida, cfg_method, cfg_blockdiag, cfg_nonlin, cfg_atol_n;
  int* nb;
  int* sched_off;
  double* sched_s;
  SUNContext ctx;
  FILE* warn_fp;
  char* warn_buf;
  size_t warn_len;
  int n_out_fn;             /* outputs of gs_out (0: none)                       */
  int n_mesh_fn;            /* mesh deflections of gs_mesh (0: none)             */
  N_Vector atol;            /* absolute tolerances of the current call (atol_vec) */
  double* sched_sp;         /* [nsched_total*np] d s / d p (gs_schedp)           */
};

/* --------------------------------------------------------------------------
 * Sizes.  SUNDIALS indexes vectors and dense matrices with sunindextype, a 32-bit
 * integer in the libraries the driver links (gs_check_abi verifies it at load): a
 * vector of N components and a dense M x N matrix (M*N entries, computed by SUNDIALS
 * in sunindextype) must stay at or below GS_INDEX_MAX, or the product wraps and the
 * matrix is allocated too small.  Every size the driver derives from the model and the
 * arguments is computed in 64 bits with gs_mul_le and checked before it allocates.
 * -------------------------------------------------------------------------- */
#define GS_INDEX_MAX 2147483647LL /* INT32_MAX: the largest sunindextype */

/* *out = a * b when a, b >= 0 and a * b <= limit (limit >= 0): returns 0.  Otherwise
 * returns -1 and leaves *out unchanged (the product is never formed when it would
 * exceed the limit, so it cannot overflow). */
static inline int gs_mul_le(long long a, long long b, long long limit, long long* out) {
  if (a < 0 || b < 0 || limit < 0) return -1;
  if (a != 0 && b > limit / a) return -1;
  *out = a * b;
  return 0;
}


/* --------------------------------------------------------------------------
 * Hot helpers, inlined in every file
 * -------------------------------------------------------------------------- */
#define GS_POLL_EVERY 1024

/* 1 if a byte of a stopping signal (SIGINT; SIGTERM too when ud->intr_mask says so)
 * arrived on the interrupt pipe (checked every GS_POLL_EVERY calls; other signal
 * numbers are consumed and ignored: their Python handlers run when the call returns). */
static inline int poll_interrupt(gs_ud* ud) {
  unsigned char buf[64];
  ssize_t n, i;
  if (ud->intr_fd < 0) return 0;
  if (ud->interrupted) return 1;
  if (++ud->intr_count < GS_POLL_EVERY) return 0;
  ud->intr_count = 0;
  for (;;) {
    n = read(ud->intr_fd, buf, sizeof(buf));
    if (n > 0) {
      for (i = 0; i < n; ++i)
        if ((buf[i] == (unsigned char)SIGINT && (ud->intr_mask & GS_INTR_SIGINT)) ||
            (buf[i] == (unsigned char)SIGTERM && (ud->intr_mask & GS_INTR_SIGTERM)))
          ud->interrupted = 1;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break; /* EAGAIN (empty), EOF or an error: nothing pending */
  }
  return ud->interrupted;
}

static inline int all_finite(const double* v, int n, int* bad) {
  int i;
  for (i = 0; i < n; ++i) {
    if (!isfinite(v[i])) {
      if (bad) *bad = i;
      return 0;
    }
  }
  return 1;
}

/* The first sensitivity column of a solver vector [x; Phi (nd columns with the
 * monodromy); S (ns columns)], each column nx long. */
static inline size_t sens_offset(const gs_ud* ud) {
  return (size_t)ud->nx + (size_t)ud->mono * (size_t)ud->nd * (size_t)ud->nx;
}

/* --------------------------------------------------------------------------
 * Functions shared between the driver's files (hidden: not part of the API)
 * -------------------------------------------------------------------------- */
#pragma GCC visibility push(hidden)

/* gs_ramp.c: the speed ramp -- every place where the model's time and the schedules'
 * clock differ from the integrator's time t */
double ramp_speed(const gs_ramp* r, double t);
double ramp_phase_time(const gs_ramp* r, double t);
double ramp_time_at_phase(const gs_ramp* r, double tau);
const double* ramp_model_args(gs_ud* ud, double t, double* s);
const double* ramp_schedule_params(gs_ud* ud, const double* p);
double sched_clock(const gs_sched_data* sd, double t);
double sched_time_at_clock(const gs_sched_data* sd, double c);
int ramp_setup(gs_ud* ud, gs_sim_args* a);
int eval_swdt(gs_ud* ud, double t, const double* x, double* out);

/* The time s and parameters p the generated functions get at the integrator's time t:
 * (t, p) without a ramp; (theta(t)/Omega(t), p with the ramped speed) with one. */
static inline const double* model_args(gs_ud* ud, double t, double* s) {
  if (!ud->ramp.on) {
    *s = t;
    return ud->np ? ud->p : ud->dummy;
  }
  return ramp_model_args(ud, t, s);
}

/* gs_util.c */
int set_err(gs_sim_args* a, int status, const char* fmt, ...) __attribute__((format(printf, 3, 4)));
void record_nonfinite(gs_ud* ud, double t, const char* what, int index, const double* x);
int lu_solve(int n, double* A, double* b);
int lu_factor(int n, double* A, int* piv);
void lu_apply(int n, const double* LU, const int* piv, double* b);
SUNLinearSolver bdls_new(int n, int nblk, SUNContext ctx);
void last_warning(FILE* fp, char** bufp, size_t* len, char* out, int outlen);

/* gs_callbacks.c */
void gs_fn_setup(gs_fn* fn, const char* name, gs_cfun_ptr f, gs_work_ptr work, gs_nio_ptr n_in,
                        gs_nio_ptr n_out, gs_sp_ptr sp_in, gs_sp_ptr sp_out);
int gs_fn_check(gs_fn* fn, gs_work_ptr work, gs_nio_ptr n_in, gs_nio_ptr n_out, gs_sp_ptr sp_in,
                       gs_sp_ptr sp_out, const int* in_sizes, int n_expected_in, int nrow, int ncol,
                       casadi_int* mx, char* msg, int len);
int gs_call(gs_ud* ud, const gs_fn* fn, const double** in, int n_in, double* out);
int eval_rhs(gs_ud* ud, double t, const double* x, const double* m, double* out);
int eval_swfn(gs_ud* ud, const gs_fn* fn, double t, const double* x, double* out);
int eval_xdot(gs_ud* ud, double t, const double* x, const double* m, const double* guess, double* out);
int eval_xdot_dae(gs_ud* ud, double t, const double* x, const double* m, const double* guess, double* out);
void ida_consistent_guess(gs_ud* ud, double t, double* yv, double* ypv);
int ida_xdot_full(gs_ud* ud, double t, const double* y, const double* guess, double* out);
int eval_dae_point(gs_ud* ud, double t, const double* x, const double* m, double* out, int want_jac);
int cv_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user_data);
int cv_jac(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix Jm, void* user_data, N_Vector t1, N_Vector t2,
                  N_Vector t3);
int cv_root(sunrealtype t, N_Vector y, sunrealtype* gout, void* user_data);
int ida_res(sunrealtype t, N_Vector y, N_Vector yp, N_Vector r, void* user_data);
int ida_jac(sunrealtype t, sunrealtype cj, N_Vector y, N_Vector yp, N_Vector r, SUNMatrix Jm,
                   void* user_data, N_Vector t1, N_Vector t2, N_Vector t3);
int ida_root(sunrealtype t, N_Vector y, N_Vector yp, sunrealtype* gout, void* user_data);
void sun_err_handler(int line, const char* func, const char* file, const char* msg, SUNErrCode err_code,
                            void* err_user_data, SUNContext sunctx);
void slv_accumulate(gs_solver* S);
long slv_total_steps(const gs_solver* S);
const char* slv_flagname(gs_solver* S, int flag);

/* gs_events.c */
void sched_mode_at(const gs_sched_data* sd, int k, double t, double* n_out, double* seg_out);
double next_interval(const gs_sched_data* sd, gs_ud* ud, double t, double t_end, double tiny, int* is_break);
int sched_break_dtdp(const gs_sched_data* sd, int nsched_total, const double* sp, int np, double tb,
                            double tiny, double* dtdp);
int switch_surface(gs_ud* ud, gs_evlog* L, double t, double* yv, int j, int side, double speed);
int resolve_zero_surfaces(gs_ud* ud, gs_evlog* L, double t, double* yv, const double* xd_guess,
                                 int silent);

/* gs_workspace.c */
N_Vector ws_atol(gs_workspace* ws, const double* v, int n);
void ws_free_solver(gs_workspace* ws);
int ws_model_setup(gs_workspace* ws, gs_sim_args* a);

/* LAPACK through scipy's cython_lapack (C functions with Fortran's by-reference arguments). */
typedef void (*gs_dgebal_t)(char*, int*, double*, int*, int*, int*, double*, int*);
typedef void (*gs_dgesdd_t)(char*, int*, int*, double*, int*, double*, double*, int*, double*, int*, double*,
                            int*, int*, int*);
typedef void (*gs_dgelsd_t)(int*, int*, int*, double*, int*, double*, int*, double*, double*, int*, double*,
                            int*, int*, int*);
typedef void (*gs_dgeev_t)(char*, char*, int*, double*, int*, double*, double*, double*, int*, double*, int*,
                           double*, int*, int*);
typedef void (*gs_dgetrf_t)(int*, int*, double*, int*, int*, int*);
typedef void (*gs_dgetrs_t)(char*, int*, int*, double*, int*, int*, double*, int*, int*);

/* gs_newton.c */
int lapack_lstsq(void* dgelsd_ptr, int m, int n, const double* A, const double* b, double* x);

/* gs_shoot.c */
void lapack_multipliers(gs_multipliers* m, int n, const double* M);
void lapack_isolation(gs_isolation* iso, const gs_multipliers* m, int n, const double* M, const double* d_in);
#pragma GCC visibility pop

#endif /* GS_INTERNAL_H */
