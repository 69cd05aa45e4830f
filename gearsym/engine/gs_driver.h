/*
 * gs_driver.h -- public C API of the gearsym simulation driver.
 *
 * One call of gs_simulate() integrates a compiled model (see gs_model_abi.h)
 * from t0 to t_end with SUNDIALS 7 (CVODE for explicit models, IDA for implicit
 * ones): root finding on the switching functions with mode switch and
 * re-initialisation, exact stops at scheduled breakpoints, an output grid,
 * optional variational equations (monodromy with saltation matrices),
 * optional parameter sensitivities (with event-time and breakpoint-time terms),
 * and statistics.  It never aborts the process: every failure is a status code plus
 * a message in `errmsg`.
 *
 * All arrays are owned by the caller.  Row-major means y_out[i*nx + j].
 */
#ifndef GS_DRIVER_H
#define GS_DRIVER_H

#define GS_OK               0
#define GS_ERR_TOO_MUCH_WORK (-1)  /* max_steps exceeded                         */
#define GS_ERR_EVENT_STORM  (-2)   /* too many events without time advancing     */
#define GS_ERR_NONFINITE    (-3)   /* NaN/Inf in state or right-hand side        */
#define GS_ERR_SOLVER       (-4)   /* any other SUNDIALS failure (flag in msg)   */
#define GS_ERR_ABI          (-5)   /* SUNDIALS version / index size mismatch     */
#define GS_ERR_INPUT        (-6)   /* bad arguments (sizes, t_end <= t0, ...)    */
#define GS_ERR_MAX_EVENTS   (-7)   /* more events than max_events                */
#define GS_ERR_INTERRUPTED  (-8)   /* SIGINT (or SIGTERM) seen on interrupt_fd   */

/* check_interrupt bits: the signals that stop a run (GS_ERR_INTERRUPTED) */
#define GS_INTR_SIGINT  1
#define GS_INTR_SIGTERM 2

#define GS_METHOD_BDF   0          /* CVODE, BDF, Newton with dense analytic Jacobian */
#define GS_METHOD_ADAMS 1          /* CVODE, Adams-Moulton, Newton, dense Jacobian    */
#define GS_METHOD_IDA   2          /* IDA (implicit models), dense analytic Jacobian  */

/* CVODE's nonlinear solver.  AUTO: Newton. */
#define GS_NONLIN_AUTO       0
#define GS_NONLIN_NEWTON     1     /* modified Newton with the analytic Jacobian       */
#define GS_NONLIN_FIXEDPOINT 2     /* functional iteration: no Jacobian, no linear     */
                                   /* solve (non-stiff problems; cheap for large n)    */
/* Newton's linear solver.  AUTO: DENSE without the monodromy, BLOCKDIAG with it. */
#define GS_LINSOL_AUTO      0
#define GS_LINSOL_DENSE     1      /* SUNDIALS dense LU of the whole system matrix     */
                                   /* ((n + n^2)^2 with the monodromy: small n only)   */
#define GS_LINSOL_BLOCKDIAG 2      /* monodromy: one n x n LU for all n + 1 blocks     */

/* A speed ramp (gs_ramp.c): the parameter p[index] (the speed) runs linearly,
 *     Omega(t) = speed0 + rate (t - t0),
 * and the model's periodic time functions run on its phase theta(t) = speed0 t0 +
 * int_t0^t Omega = speed0 tau(t), tau(t) = t + rate (t - t0)^2 / (2 speed0) (the phase time:
 * the time at constant speed speed0 with the same phase).  The generated functions are
 * called with the time s(t) = theta(t) / Omega(t) and p[index] = Omega(t), so a time
 * function of the form h(Omega t, Omega) (a phase proportional to the speed, any
 * dependence of its amplitude on the speed) becomes h(theta(t), Omega(t)); the schedules
 * (periods proportional to 1 / speed) are evaluated on tau(t), and their breakpoints are
 * the exact roots t_b of tau(t_b) = (n + c_i) P_k(speed0), a quadratic.  The caller
 * checks that the model's time functions are of that form (gearsym.analysis.runup). */
typedef struct gs_ramp {
  int    on;               /* 1: the ramp is on (0: every other field is ignored)   */
  int    index;            /* the speed parameter p[index]                          */
  double t0;               /* start of the ramp: Omega(t0) = speed0, tau(t0) = t0   */
  double speed0;           /* nonzero; Omega keeps its sign over [t0, t_end]        */
  double rate;             /* d Omega / dt                                          */
} gs_ramp;

typedef struct gs_sim_args {
  /* ---- inputs ---- */
  int     method;          /* GS_METHOD_*                                           */
  double  rtol, atol;      /* scalar tolerances                                     */
  double  t0, t_end;       /* integration interval, t_end > t0                      */
  const double* x0;        /* [nx] initial state                                    */
  const double* p;         /* [np] parameters                                       */
  const double* sigma0;    /* [nsw] initial side of each switching surface (+1/-1), */
                           /* or NULL: from the sign of g_j(t0, x0) (g >= 0 -> +1)  */
  int     n_out;           /* number of output times (may be 0)                     */
  const double* t_out;     /* [n_out] ascending, each in [t0, t_end]                */
  long    max_steps;       /* total internal steps allowed (0 -> 10,000,000)        */
  long    max_events;      /* total events allowed (0 -> 1,000,000)                 */
  int     storm_events;    /* events allowed within storm_window of each other      */
                           /* before GS_ERR_EVENT_STORM (0 -> 50)                    */
  double  storm_window;    /* (0 -> 1e-9 * max(1, |t|))                             */
  double  max_step;        /* max internal step, 0 = unlimited                      */
  double  init_step;       /* initial step, 0 = solver chooses                      */
  int     want_monodromy;  /* 1: integrate variational eqs (CVODE; IDA: F_y S + F_y' S' = 0, */
                           /* one block per differential state)                      */
  int     max_events_out;  /* capacity of the ev_* arrays                           */
  int     check_interrupt; /* GS_INTR_* bits (0: off): every GS_POLL_EVERY right-hand */
  int     interrupt_fd;    /* side evaluations, read the non-blocking pipe          */
                           /* interrupt_fd (Python's signal wakeup fd: one byte per */
                           /* signal number) and stop with GS_ERR_INTERRUPTED if it */
                           /* holds SIGINT (bit 1) or SIGTERM (bit 2)               */
  int     nonlinear;       /* GS_NONLIN_*: CVODE's nonlinear solver (0 = auto)      */
  int     linear_solver;   /* GS_LINSOL_*: Newton's linear solver (0 = auto)        */
  const double* atol_vec;  /* NULL: the scalar atol for every component; else one   */
                           /* absolute tolerance per solver component: nx, or       */
                           /* nx*(1 + nd*want_monodromy + n_sens), nd = nx - nalg  */
                           /* the differential states: the state, Phi column-major, */
                           /* then S column-major: the variational entries have     */
                           /* their own scale                                       */
  /* ---- outputs ---- */
  double* y_out;           /* [n_out*nx] row-major states at t_out                  */
  double* x_final;         /* [nx] state at the time reached                        */
  double* sigma_final;     /* [nsw] side of each surface at the end (may be NULL)   */
  double* monodromy;       /* [nx*nx] row-major d x(t_end) / d x0 (if requested);   */
                           /* the columns of algebraic variables (IDA) are 0        */
  double* ev_t;            /* [max_events_out] event times                          */
  int*    ev_surface;      /* [max_events_out] index j of the switching function    */
  int*    ev_dir;          /* [max_events_out] +1: g went - to +, -1: + to -         */
  double* ev_speed;        /* [max_events_out] dg/dt along the flow at the event    */
                           /* (old mode): ~0 means a grazing (tangential) contact   */
  int     n_events;        /* events that occurred (may exceed max_events_out; only */
                           /* the first max_events_out are stored)                  */
  double  t_reached;       /* last time reached (== t_end on success)               */
  long    n_steps, n_rhs, n_jac, n_root_evals, n_breaks, n_reinit;
  int     status;          /* GS_OK or GS_ERR_*  (also the return value)            */
  char    errmsg[1024];    /* human-readable message when status != GS_OK          */
  /* ---- parameter sensitivities (CVODE, or IDA on the residual; see gs_driver.c) ---- */
  int     n_sens;          /* number of parameter directions (0: none)              */
  const double* sens_dir;  /* [np*n_sens] column-major: column s is a direction     */
                           /* d p / d lambda_s in parameter space                   */
  const double* sens_dt0;  /* [n_sens] d t0 / d lambda_s, or NULL (t0 fixed)         */
  const double* sens_dt1;  /* [n_sens] d t_end / d lambda_s, or NULL (t_end fixed)   */
  double* sens_final;      /* [nx*n_sens] row-major total derivative                */
                           /* d x(t_end(lambda)) / d lambda_s (includes f dt_end)   */
  double* sens_out;        /* [n_out*nx*n_sens] d x(t_out[k]) / d lambda_s at fixed */
                           /* output times, [k][i][s] (may be NULL)                 */
  /* ---- speed ramp (no monodromy, no sensitivities with it) ---- */
  gs_ramp ramp;            /* zeroed: no ramp                                       */
  /* ---- the breakpoint log ---- */
  int     max_breaks_out;  /* capacity of brk_t (0: no log)                         */
  double* brk_t;           /* [max_breaks_out] the scheduled breakpoints reached, in */
                           /* order (n_breaks of them; the first max_breaks_out kept) */
} gs_sim_args;

/* Integrate.  Returns args->status. */
int gs_simulate(gs_sim_args* args);

/* A workspace keeps what a model needs across calls (work buffers, the SUNDIALS
 * context, vectors, solvers and integrator memory): calls with the same method,
 * monodromy and solver options reuse them (CVodeReInit/IDAReInit), so a short
 * integration costs the integration only.  One thread at a time per workspace. */
typedef struct gs_workspace gs_workspace;
gs_workspace* gs_ws_new(void);
void gs_ws_free(gs_workspace* ws);
int gs_simulate_ws(gs_workspace* ws, gs_sim_args* args);

/* The forcing period T(p) (gs_period; NaN if the model has none).  Returns 0, or
 * -1 with a message. */
int gs_eval_period(gs_workspace* ws, const double* p, double* T, char* msg, int len);

/* d T / d p of the forcing period (gs_periodp) into dT[np].  Returns 0, or -1
 * with a message (also when the model was built without gs_periodp). */
int gs_eval_period_grad(gs_workspace* ws, const double* p, double* dT, char* msg, int len);

/* Number of model outputs (gs_out), or -1. */
int gs_n_outputs(gs_workspace* ws);

/* Number of mesh deflections (gs_mesh; 0 for a model without meshes), or -1. */
int gs_n_meshes(gs_workspace* ws);

/* Evaluate a generated function at n points (t[i], x[i*nx..]) with parameters p:
 * GS_EVAL_SW   g(t, x, p)                          -> out[i*nsw + j]
 * GS_EVAL_OUT  the model's outputs                 -> out[i*nout + j]
 * GS_EVAL_RHS  xdot (explicit models)              -> out[i*nx + j]
 * GS_EVAL_JAC  d xdot / d x, dense column-major    -> out[i*nx*nx + c*nx + r]
 * GS_EVAL_MODE the mode vector m (sides, schedule) -> out[i*nm + j]
 * GS_EVAL_MESH dynamic deflection of each mesh      -> out[i*nmesh + j]
 * GS_EVAL_DAE  the model as the ODE of its nd differential states (x_d' = f_d(t, x_d),
 *              the nalg algebraic variables z = h(t, x_d) solved for; explicit models:
 *              f): [y (nx, with the consistent z), f_d (nd)] -> out[i*(nx+nd) + j]
 * GS_EVAL_DAE_JAC [d f_d/d x_d; d h/d x_d] (nx x nd), dense column-major
 *                                                   -> out[i*nx*nd + c*nx + r]
 * in the mode the driver would use there: the side of each switching surface
 * from sigma[i*nsw + j] (or, with sigma NULL, +1 where g >= 0), the schedule
 * cycle and segment from t.  Returns 0, or -1 with a message. */
#define GS_EVAL_SW   0
#define GS_EVAL_OUT  1
#define GS_EVAL_RHS  2
#define GS_EVAL_JAC  3
#define GS_EVAL_MODE 4
#define GS_EVAL_MESH 5
#define GS_EVAL_DAE  6
#define GS_EVAL_DAE_JAC 7
int gs_eval(gs_workspace* ws, int fn, int n, const double* t, const double* x, const double* p, const double* sigma,
            double* out, char* msg, int len);
/* gs_eval along a speed ramp: each point evaluated at s(t_i) with p[ramp->index] =
 * Omega(t_i), the schedule cycle and segment from tau(t_i) (see gs_ramp); ramp NULL or
 * off: gs_eval. */
int gs_eval_ramp(gs_workspace* ws, int fn, int n, const double* t, const double* x, const double* p,
                 const double* sigma, const gs_ramp* ramp, double* out, char* msg, int len);

/* Check the SUNDIALS runtime: version >= 7 and 32-bit sunindextype.  Writes the
 * version string (e.g. "7.9.0") or the problem into msg.  Returns 0 if OK. */
int gs_check_abi(char* msg, int len);

/* sizeof(gs_sim_args), so that the Python side can verify its ctypes layout. */
int gs_sizeof_args(void);
int gs_sizeof_shoot_args(void);   /* sizeof(gs_shoot_args): the ctypes mirror's check */
int gs_sizeof_correct_args(void); /* sizeof(gs_correct_args) */

/* The layout of the argument structs (gs_sim_args, gs_multipliers, gs_isolation,
 * gs_shoot_args, gs_correct_args), one field per index i = 0, 1, ...: the struct's and
 * the field's names, offsetof, sizeof and kind ('d' double, 'i' int, 'l' long, 'p'
 * pointer, 'a' char array, 's' struct), so that the Python side verifies its ctypes
 * mirrors field by field (two swapped fields of one size keep the struct's size).
 * Returns 0, or -1 past the last field. */
int gs_abi_field(int i, const char** type, const char** field, long* offset, long* size, int* kind);

/* ---- Newton's method for a periodic orbit, in C (see gs_shoot_ws in gs_driver.c) ---- */
#define GS_SHOOT_CONVERGED        0
#define GS_SHOOT_GAVE_UP_DECREASE 1  /* a full step did not decrease the residual (damping) */
#define GS_SHOOT_GAVE_UP_ITER     2  /* max_iter steps taken                               */
#define GS_SHOOT_GAVE_UP_SINGULAR 3  /* a (nearly) singular Newton matrix                  */
#define GS_SHOOT_GAVE_UP_RUN      4  /* an integration after the first failed              */
#define GS_SHOOT_GAVE_UP_EVENTS   5  /* more events than the event log holds               */
/* ---- multipliers of a monodromy, computed by the Newton iterations in C once they converge ---- */
/* With the three LAPACK routines given (scipy's cython_lapack dgebal, dgesdd, dgeev: C functions */
/* taking Fortran's arguments): the multipliers and their tolerances as                           */
/* gearsym.analysis.stability.multiplier_tolerances computes them (balance, 2-norm, delta = 100   */
/* max(rtol, eps) max(1, |M|), eigenvalue condition numbers from the left and right vectors);     */
/* unsorted, LAPACK's order.  Any routine failing leaves ok = 0 (Python computes them then).     */
typedef struct gs_multipliers {
  void*   lapack_dgebal;
  void*   lapack_dgesdd;
  void*   lapack_dgeev;
  double  rtol;         /* in: the rtol the monodromy's error is estimated from              */
  double* mu_re;        /* [nx] out                                                          */
  double* mu_im;        /* [nx] out                                                          */
  double* mu_tol;       /* [nx] out                                                          */
  double  delta;        /* out: the monodromy's estimated absolute error                     */
  int     ok;           /* out: 1 when the three arrays hold them                            */
} gs_multipliers;

#define GS_SHOOT_GAVE_UP_OTHER    6  /* a non-finite residual                              */

/* ---- is the converged orbit isolated?  (gearsym.analysis.isolation.isolation without trivial ---- */
/* directions): in the variables scaled by the orbit's state magnitudes d (entries that are not  */
/* finite and > 0 count as 1), Ms = D^-1 M D; `norm` is the 2-norm of Ms, `sigma` the smallest    */
/* singular value of Ms - I and direction = d * v its right singular vector (dgesdd, the routine  */
/* numpy's svd calls, through the dgesdd pointer of the gs_multipliers beside it).  Python        */
/* compares sigma with the monodromy's error level.  Any failure leaves ok = 0.                   */
typedef struct gs_isolation {
  double* direction;    /* [nx] out; NULL: not computed                                     */
  double  sigma;        /* out                                                              */
  double  norm;         /* out                                                              */
  int     ok;           /* out: 1 when the three outputs hold them                          */
} gs_isolation;

typedef struct gs_shoot_args {
  double  tol;          /* converged: max_i |R_i| / scale_i <= tol (or the noise rules)     */
  double  scale_floor;  /* scale_i = max(max_k |x_i(t_out[k])|, 1e-9 max_j(...), floor)    */
  double  pivot_tol;    /* give up when min |u_kk| <= pivot_tol * max(1, max |u_kk|)        */
  int     max_iter;     /* Newton steps allowed                                            */
  double* x;            /* [nx] in: the guess; out: the last iterate (the orbit's state)     */
  double* scale;        /* [nx] out: the scales of the last evaluation                      */
  double* hist_abs;     /* [max_iter + 1] out: max |R| of each accepted evaluation           */
  double* hist_rel;     /* [max_iter + 1] out: max |R_i| / scale_i                           */
  int     n_hist;       /* out: evaluations recorded                                       */
  int     iterations;   /* out: Newton steps accepted (s->x is the last accepted iterate)   */
  int     note;         /* out: 0 residual <= tol; 1 full step below tol, residual <= 100 tol; */
                        /* 2 a last step below 10 tol applied without integrating           */
  int     outcome;      /* out: GS_SHOOT_*                                                  */
  gs_multipliers mult;  /* the multipliers of the last evaluation's monodromy when converged */
  gs_isolation iso;     /* its isolation, in the scales s->scale, when converged            */
  double* g0_out;       /* [nsw] out (NULL: not wanted): the switching functions at        */
                        /* (t0, x) of the converged orbit, as gs_eval gives them            */
  int     g0_ok;        /* out: 1 when g0_out holds them                                    */
} gs_shoot_args;

/* Newton on x(t_end; t0, x) = x with the run described by `a` (want_monodromy = 1, an output
 * grid of >= 2 samples whose magnitudes give the scales, x0 ignored: s->x is the start).
 * After a converged outcome the run buffers of `a` (x_final, monodromy, events, y_out)
 * hold the last evaluation.  Returns 0 (see s->outcome) or the status of a failed first
 * run (or of an interrupt). */
int gs_shoot_ws(gs_workspace* ws, gs_sim_args* a, gs_shoot_args* s);

/* ---- the continuation's pseudo-arclength corrector, in C (see gs_correct_ws in gs_driver.c) ---- */
typedef struct gs_correct_args {
  int     nx;           /* states (the unknowns are z = (x, lambda), nx + 1)               */
  double* z;            /* [nx+1] in: the predicted point; out: the corrected one          */
  const double* row;    /* [nx+1] the constraint row . (z / S) = target                    */
  double  target;
  const double* S;      /* [nx+1] scales of the unknowns                                   */
  const double* Rs;     /* [nx] scales of the residual rows                                */
  double  tol;          /* converged: max |R_i| / Rs_i <= tol (or a step below tol with    */
                        /* the residual below 100 tol), constraint within 1e-9             */
  int     max_iter;     /* Newton steps allowed                                            */
  double  min_damping;  /* smallest damping tried (halving from 1)                         */
  double  periods;      /* orbit period = periods * T(p)                                   */
  double  lam0;         /* p(lambda) = p0 + (lambda - lam0) D                              */
  const double* p0;     /* [np]                                                            */
  const double* D;      /* [np]                                                            */
  double  atol;         /* absolute tolerance of the states (variational: the same;        */
                        /* the sensitivity atol / max |p_k| over the entries D moves)      */
  double  dP;           /* scratch: d P / d lambda of the current run                      */
  double* R_out;        /* [nx] out: the residual at the corrected point                   */
  double* M_out;        /* [nx*nx] out: its monodromy, row-major                           */
  double* Flam_out;     /* [nx] out: its F_lambda                                          */
  double  residual;     /* out: max |R_i| / Rs_i                                           */
  int     iterations;   /* out: Newton steps taken                                         */
  int     n_runs;       /* out: integrations made                                          */
  int     outcome;      /* out: GS_SHOOT_*                                                 */
  /* after a converged outcome, with n_samples >= 2: one more run of the corrected orbit      */
  /* without variational equations (what System.flow(..., monodromy=False) gives), sampled   */
  /* at n_samples evenly spaced times from t0 to t0 + P, plus the switching functions and    */
  /* the mesh deflections at the samples (as gs_eval); the event log, x_final and the        */
  /* statistics of `a` still describe the corrected point's run.  Any failure of this run    */
  /* only leaves samples_ok = 0.                                                              */
  int     n_samples;
  double* t_samples;    /* [n_samples] out: the sample times                                 */
  double* Y_samples;    /* [n_samples*nx] out: the states, row-major                         */
  double* G_samples;    /* [n_samples*nsw] out: the switching functions (may be NULL)        */
  double* H_samples;    /* [n_samples*nmesh] out: the mesh deflections (may be NULL)         */
  int     samples_ok;   /* out: 1 when the four arrays hold the samples                       */
  /* with samples_ok and all samples finite: their statistics over the period, the last       */
  /* sample (t0 + P, the first one again) excluded -- what make_node reads off the samples     */
  double* col_stats;    /* [3*nx] out (may be NULL): per state max, min, sum of squares      */
  int*    col_args;     /* [2*nx + 2*nsw + 2*nmesh] out: per state the first argmax, the     */
                        /* first argmin; per switching function and per mesh deflection the  */
                        /* first argmin, the first argmax                                     */
  int     stats_ok;     /* out: 1 when col_stats / col_args hold them                        */
  /* after a converged outcome, with t_ref given: the solution t of [J_s; t_ref] t = e_nx,     */
  /* J_s = [F_u, F_lambda] at the point in the scaled variables (rows / Rs, columns * S):    */
  /* the unnormalised tangent along t_ref                                                     */
  const double* t_ref;  /* [nx+1] in (may be NULL)                                           */
  double* tangent_out;  /* [nx+1] out                                                        */
  int     tangent_ok;   /* out: 1 when tangent_out holds a finite solution                   */
  double  period_out;   /* out: T(p(lambda)) at the returned z (one forcing period)          */
  gs_multipliers mult;  /* the multipliers of the converged point's monodromy               */
  /* rigid-body modes: anchor rows pin the rigid coordinates; the bordered step and the       */
  /* tangent are then the minimum-norm least-squares solutions of [J_s; anchor; row] w = rhs  */
  /* (rhs 0 on the anchor rows), by dgelsd with numpy.linalg.lstsq's rcond (eps max(m, n))   */
  int     n_anchor;     /* 0: none (LU as above)                                            */
  const double* anchor; /* [n_anchor*(nx+1)] row-major, in the scaled unknowns z / S        */
  void*   lapack_dgelsd;/* scipy's cython_lapack dgelsd (needed with n_anchor > 0)         */
} gs_correct_args;

/* The corrector with the run described by `a` (method, tolerances, t0, max_steps, event log,
 * x_final / monodromy / sens_final buffers, n_sens = 1; the driver sets x0, p, t_end,
 * max_step, atol_vec and the sensitivity direction).  After a converged outcome the event
 * log of `a` holds the events of the corrected point's run.  Returns 0 (see c->outcome) or
 * the status of an interrupt. */
int gs_correct_ws(gs_workspace* ws, gs_sim_args* a, gs_correct_args* c);

/* ---- many initial states over one time span in one call (gs_batch.c) ---- */
/* Runs gs_simulate_ws() once per state i = 0..n-1 with the template `a` (method, tolerances,  */
/* t0, t_end, output grid, budgets; no monodromy, no sensitivities), its x0 / sigma0 taken    */
/* from x0s[i*nx..] / sigma0s[i*nsw..] (sigma0s may be NULL), its outputs written to          */
/* y_outs[i*n_out*nx..] (row-major per state; may be NULL when n_out = 0), x_finals[i*nx..]   */
/* and sigma_finals[i*nsw..] (may be NULL).  status[i] is the state's GS_OK / GS_ERR_*;        */
/* counts[3*i..] its events, steps and right-hand sides.  A failed state does not stop the     */
/* batch; a->errmsg then holds the first failed state's message, a->n_* the totals.  Returns  */
/* GS_OK, GS_ERR_INPUT, or GS_ERR_INTERRUPTED (the states not run have that status).          */
/* The template's x0, sigma0, y_out, x_final and sigma_final are restored on return.          */
int gs_simulate_batch(gs_workspace* ws, gs_sim_args* a, int n, const double* x0s, const double* sigma0s,
                      double* y_outs, double* x_finals, double* sigma_finals, int* status, long* counts);

#endif
