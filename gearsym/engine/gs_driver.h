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
int gs_sizeof_newton(void);        /* sizeof(gs_newton): the ctypes mirror's check */
int gs_sizeof_orbit_flow(void);    /* sizeof(gs_orbit_flow) */
int gs_sizeof_corrector_flow(void);/* sizeof(gs_corrector_flow) */

/* The layout of the argument structs (gs_sim_args, gs_multipliers, gs_isolation,
 * gs_newton, gs_orbit_flow, gs_corrector_flow), one field per index i = 0, 1, ...: the struct's and
 * the field's names, offsetof, sizeof and kind ('d' double, 'i' int, 'l' long, 'p'
 * pointer, 'a' char array, 's' struct), so that the Python side verifies its ctypes
 * mirrors field by field (two swapped fields of one size keep the struct's size).
 * Returns 0, or -1 past the last field. */
int gs_abi_field(int i, const char** type, const char** field, long* offset, long* size, int* kind);

/* ---- multipliers of a monodromy, computed by the orbit solvers in C once they converge ---- */
/* With the three LAPACK routines given (scipy's cython_lapack dgebal, dgesdd, dgeev: C functions */
/* taking Fortran's arguments): the multipliers and their tolerances as                           */
/* gearsym.analysis.periodic.multiplier_tolerances computes them (balance, 2-norm, delta = 100    */
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

/* ---- is the converged orbit isolated?  (gearsym.analysis.periodic.isolation without trivial --- */
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

/* ==========================================================================================
 * THE damped Newton iteration of the periodic-orbit solvers (gs_newton.c), written once:
 * shooting's Newton on F(X) = 0 (GS_NEWTON_ORBIT) and the continuation's pseudo-arclength
 * corrector on F(u, lambda) = 0 plus row . (z / S) = target (GS_NEWTON_CORRECTOR).
 *
 * Reverse communication: the iteration never integrates.  gs_newton_start() sets
 * request = GS_NEWTON_EVALUATE and z_eval; the caller evaluates the problem there, writes
 * R, J (, Flam, amplitude) and eval_status, sets answered = 1 and calls gs_newton_next(),
 * which makes the next request or ends (request = GS_NEWTON_DONE, see outcome).  The C
 * evaluators (gs_shoot_ws: the shooting residual over the flow; gs_correct_ws: the
 * continuation's) answer in the same C call; the analysis answers (in Python) what they do
 * not evaluate (harmonic balance, ...).  All arrays are the caller's.
 * ========================================================================================== */
#define GS_NEWTON_ORBIT      0   /* unknowns X (segments x nx), F_i = phi_i(X_i) - X_{i+1}     */
#define GS_NEWTON_CORRECTOR  1   /* unknowns z = (u, lambda): F(u, lambda) = 0 and the row      */

#define GS_NEWTON_DONE       0   /* request: the iteration ended (outcome)                      */
#define GS_NEWTON_EVALUATE   1   /* request: evaluate at z_eval                                 */

#define GS_NEWTON_CONVERGED   0
#define GS_NEWTON_DIVERGED    1  /* the residual fell by less than diverge_ratio (corrector)    */
#define GS_NEWTON_MAX_ITER    2  /* max_iter steps taken                                        */
#define GS_NEWTON_SINGULAR    3  /* the Newton step is not finite                               */
#define GS_NEWTON_EVAL_FAILED 4  /* an evaluation that had to succeed failed (eval_status,      */
                                 /* eval_msg): the start, or the corrector's last damped trial  */
#define GS_NEWTON_STALLED     5  /* no damped step reduces the residual (eval_msg: the last     */
                                 /* failed trial's message, if any)                             */
#define GS_NEWTON_NONFINITE   6  /* a non-finite residual                                       */

/* history entry kinds (orbit) */
#define GS_NEWTON_H_START     0  /* the evaluation at the start                                */
#define GS_NEWTON_H_STEP      1  /* an accepted step                                           */
#define GS_NEWTON_H_RESTART   2  /* the evaluation at a restart (gs_newton_restart)            */
#define GS_NEWTON_H_FLOOR     3  /* converged at the integration's noise floor                 */

typedef struct gs_newton {
  /* ---- the problem and the policy (in) ---- */
  int     kind;           /* GS_NEWTON_ORBIT or GS_NEWTON_CORRECTOR                           */
  int     n;              /* unknowns: segments * nx (orbit), nu + 1 (corrector)             */
  int     nr;             /* residual rows: n (orbit), nu (corrector)                        */
  int     nx;             /* orbit: states per segment (the amplitude's and the scale's size) */
  int     segments;       /* orbit: J holds the segment monodromies M_i (nx x nx each)        */
  int     max_iter;       /* Newton steps allowed (over restarts)                            */
  double  tol;
  double  min_damping;    /* the step is halved from 1 down to min_damping ...                */
  double  decrease;       /* ... until the norm falls below (1 - decrease * damping) r ...    */
  double  accept_below;   /* ... or below accept_below ...                                    */
  int     accept_last;    /* ... or (1) the smallest damping is taken anyway                   */
  int     apply_final_step; /* a step below the tolerance is added without an evaluation     */
  double  diverge_ratio;  /* > 0: after two steps, end when r > diverge_ratio r_prev ...      */
  double  diverge_floor;  /* ... and r > diverge_floor                                        */
  double  trunc_level;    /* orbit: singular values of the scaled Jacobian below             */
                          /* trunc_level * max(1, its largest) are dropped from the step      */
  double  scale_floor;    /* orbit: scale_i = max(amplitude_i, 1e-9 max_j amplitude_j,        */
                          /* scale_floor) (all 1 if the amplitude is not finite)              */
  const double* row;      /* corrector: [n] the constraint row . (z / S) = target            */
  double  target;
  const double* S;        /* corrector: [n] scales of the unknowns                           */
  const double* Rs;       /* corrector: [nr] scales of the residual rows                     */
  int     n_anchor;       /* rows pinning the rigid-body coordinates (0: none): the step is    */
  double* anchor;         /* the least-squares solution with them; [n_anchor * n] row-major, */
                          /* orbit: in the unknowns; corrector: in the scaled unknowns z / S  */
                          /* (an evaluator may rewrite them with each evaluation)             */
  const double* t_ref;    /* corrector: [n] or NULL: at convergence the unit tangent along it */
  void*   lapack_dgetrf;  /* scipy's cython_lapack routines (C functions, Fortran arguments)  */
  void*   lapack_dgetrs;
  void*   lapack_dgesdd;
  void*   lapack_dgelsd;
  /* ---- the evaluation at z_eval (written by the evaluator) ---- */
  double* R;              /* [nr] the residual                                               */
  double* J;              /* orbit: [segments*nx*nx] the segment monodromies, row-major;       */
                          /* corrector: [nr*nr] F_u, row-major                                */
  double* Flam;           /* corrector: [nr] F_lambda ...                                     */
  int     flam_given;     /* ... if 1; else the last one given is used (a chord)              */
  double* amplitude;      /* orbit: [nx] max |x_i| over the orbit's samples                   */
  int     eval_status;    /* 0: evaluated; else it failed (a GS_ERR_* of the run, or 1)       */
  char    eval_msg[256];  /* the failure                                                     */
  /* ---- the iteration (out, except z in gs_newton_start / gs_newton_restart) ---- */
  double* z;              /* [n] the current iterate (the result when done)                   */
  double* z_eval;         /* [n] the point of the pending evaluation                          */
  int     request;        /* GS_NEWTON_EVALUATE or GS_NEWTON_DONE                             */
  int     answered;       /* the caller's: 1 once the pending evaluation is written           */
  int     must_succeed;   /* the pending evaluation's failure ends the iteration              */
  int     n_evals;        /* evaluations requested so far                                     */
  int     iterations;     /* Newton steps accepted                                            */
  int     outcome;        /* GS_NEWTON_* when done                                            */
  int     note;           /* converged: 0 residual <= tol; 1 a full step below tol (residual  */
                          /* <= 100 tol); 2 a last step below 10 tol added without an         */
                          /* evaluation; 3 the noise floor (no damped step reduces the        */
                          /* residual, step <= 10 tol, residual <= 100 tol)                   */
  double  residual;       /* the damping's norm at z (orbit: max |R|; corrector: max |R/Rs|)  */
  double  residual_prev;  /* the one before the last step                                    */
  double  relative;       /* orbit: max |R_i| / scale_i at z                                  */
  double* scale;          /* orbit: [nx] the scales of the last evaluation                    */
  int     hist_cap;       /* history capacity: the entries since gs_newton_start / restart   */
  int     n_hist;
  int*    hist_kind;      /* [hist_cap] GS_NEWTON_H_*                                         */
  double* hist_abs;       /* [hist_cap] the damping's norm                                    */
  double* hist_rel;       /* [hist_cap] orbit: the relative residual                          */
  double* hist_step;      /* [hist_cap] the damping of a step                                 */
  int*    hist_drop;      /* [hist_cap] singular values dropped from the step                 */
  double* tangent;        /* corrector: [n] the unit tangent along t_ref (scaled unknowns) ... */
  int     tangent_ok;     /* ... when 1                                                       */
  double* work;           /* [gs_newton_work_size()] the iteration's state                    */
} gs_newton;

int gs_newton_work_size(const gs_newton* nw); /* doubles of nw->work; -1: sizes of no problem    */
void gs_newton_start(gs_newton* nw);          /* from z: the first request                      */
void gs_newton_restart(gs_newton* nw);        /* from a new z, the step count kept              */
void gs_newton_next(gs_newton* nw);           /* take the answered evaluation, request the next */
/* The unit tangent along t_ref at the evaluation in the buffers (corrector: [J_s; anchor;
 * t_ref] t = e_n, least squares with anchor rows, else the null vector of J_s; oriented along
 * t_ref) into nw->tangent; returns tangent_ok. */
int gs_newton_tangent(gs_newton* nw);

/* ---- the shooting residual over the flow, evaluated in C (gs_shoot.c) ---- */
#define GS_HANDBACK_NONE    0
#define GS_HANDBACK_EVENTS  1   /* the event log is too small: events_needed entries           */
#define GS_HANDBACK_CALLER  2   /* the caller evaluates this request (corrector: the run with  */
                                /* the parameter sensitivity failed)                          */
typedef struct gs_orbit_flow {
  const double* s;      /* [segments + 1] the segment times                                  */
  int     n_amp;        /* samples per segment for the amplitude (>= 2; `a` has them as      */
  double* grid;         /* t_out / y_out): numpy.linspace(s_i, s_{i+1}, n_amp) into grid     */
  double* ev_t;         /* [ev_cap] the events of the last evaluation, all segments          */
  int*    ev_surface;
  int*    ev_dir;
  double* ev_speed;
  int     ev_cap;
  int     n_events;     /* out                                                               */
  int     handback;     /* out: GS_HANDBACK_* (the request is left unanswered)               */
  int     events_needed;/* out                                                               */
  int     n_runs;       /* out: integrations made (counted up)                               */
  double  t_reached;    /* out: where a failed run stopped                                   */
  /* converged, one segment: the multipliers, the isolation and the switching functions at   */
  /* (s_0, z) (NULL: not wanted) of the orbit                                                 */
  gs_multipliers mult;
  gs_isolation iso;
  double* g0_out;
  int     g0_ok;
  /* converged: the orbit's verification (gearsym.analysis.periodic._verification): one plain run */
  /* per segment (no variational equations, a fresh solver) from the converged X_i over            */
  /* [s_i, s_{i+1}] with the iteration's method, tolerances and max_step; NULL: not made           */
  double* verify_ends;  /* [segments * nx] out: the state at s_{i+1} of segment i's run            */
  int     verify_ok;    /* out: 1 made, 0 not made, -1 a run failed (its status, message, time)   */
  int     verify_status;
  double  verify_t_reached;
  char    verify_msg[1024]; /* out: as gs_sim_args.errmsg                                          */
} gs_orbit_flow;

/* Shooting's Newton (nw->kind = GS_NEWTON_ORBIT) with the run described by `a` (method,
 * tolerances, max_step, budgets, want_monodromy = 1, n_out = n_amp samples, y_out, x_final,
 * event log): answers nw's requests by one run per segment until the iteration ends or a
 * request is handed back (f->handback); once converged, the verification runs (verify_ends).
 * Call gs_newton_start / gs_newton_restart first.
 * Returns 0, or GS_ERR_INTERRUPTED. */
int gs_shoot_ws(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_orbit_flow* f);

/* ---- the continuation's residual over the flow, evaluated in C (gs_correct.c) ---- */
/* F_i(u, lambda) = phi(s_{i+1}; s_i, (u_i, y_i), p(lambda))[:nd] - u_{i+1}, s_i = t0 + P i / N,
 * P = periods T(p), p(lambda) = p0 + (lambda - lam0) D, a DAE's algebraic variables y_i carried
 * from the last consistent values (zalg); F_u from the segment monodromies' differential
 * blocks, F_lambda from the parameter sensitivity with the segment times' derivatives. */
typedef struct gs_corrector_flow {
  int     segments;
  int     nd;           /* unknowns per segment: the differential states                    */
  double  periods;
  double  t0;
  double  lam0;
  const double* p0;     /* [np]                                                             */
  const double* D;      /* [np]                                                             */
  const double* atol;   /* [nx] absolute tolerances of the states (and their variational     */
                        /* columns; the sensitivity's / max |p_k| over the entries D moves)  */
  double* zalg;         /* [segments*nalg] in/out                                           */
  double* Ms;           /* [segments*nd*nd] out: the segment monodromies' differential blocks */
  double* ev_t;         /* the events of the last evaluation, all segments                   */
  int*    ev_surface;
  int*    ev_dir;
  double* ev_speed;
  int     ev_cap;
  int     n_events;     /* out                                                               */
  int     handback;     /* out: GS_HANDBACK_*                                                */
  int     events_needed;/* out                                                               */
  int     n_runs;       /* out: integrations (counted up)                                   */
  int     n_evals;      /* out: evaluations answered (counted up)                           */
  int     last_c_eval;  /* out: nw->n_evals when this evaluator last answered (the caller's    */
                        /* answers leave it: == nw->n_evals when done means the result is C's) */
  double  period;       /* out: T(p(lambda)) of the last evaluation                          */
  double  dP;           /* scratch: d P / d lambda                                          */
  /* converged, one segment: the orbit sampled at n_samples evenly spaced times from t0 to    */
  /* t0 + P by one more run without the variational equations (what System.flow(...,         */
  /* monodromy=False) gives), the switching functions and mesh deflections there (gs_eval);   */
  /* the event log, x_final and the statistics of `a` still describe the point's run.  Any    */
  /* failure of this run only leaves samples_ok = 0.                                           */
  int     n_samples;
  double* t_samples;    /* [n_samples]                                                      */
  double* Y_samples;    /* [n_samples*nx] row-major                                         */
  double* G_samples;    /* [n_samples*nsw] (may be NULL)                                    */
  double* H_samples;    /* [n_samples*nmesh] (may be NULL)                                  */
  int     samples_ok;
  /* with samples_ok and all samples finite: their statistics over the period, the last       */
  /* sample (t0 + P, the first one again) excluded -- what make_node reads off the samples     */
  double* col_stats;    /* [3*nx] (may be NULL): per state max, min, sum of squares          */
  int*    col_args;     /* [2*nx + 2*nsw + 2*nmesh] per state the first argmax, the first    */
                        /* argmin; per switching function and per mesh deflection the first  */
                        /* argmin, the first argmax                                          */
  int     stats_ok;
  gs_multipliers mult;  /* one segment: the converged point's multipliers                    */
} gs_corrector_flow;

/* The continuation's corrector (nw->kind = GS_NEWTON_CORRECTOR) with the run described by `a`
 * (method, rtol, budgets, the event log, x_final / monodromy / sens_final buffers, n_sens =
 * 1; x0, p, t0, t_end, max_step, atol_vec and the sensitivity's span are set here): answers
 * nw's requests until the iteration ends or a request is handed back.  Returns 0, or
 * GS_ERR_INTERRUPTED. */
int gs_correct_ws(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_corrector_flow* f);

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
