/*
 * gs_workspace.c -- part of the gearsym driver (gs_driver.c; shared declarations in
 * gs_internal.h): the load-time ABI check and the reusable workspaces (model setup and checks).
 */
#include "gs_internal.h"

/* --------------------------------------------------------------------------
 * The argument structs' layout (the ctypes mirrors' check)
 * -------------------------------------------------------------------------- */
int gs_sizeof_args(void) { return (int)sizeof(gs_sim_args); }
int gs_sizeof_newton(void) { return (int)sizeof(gs_newton); }
int gs_sizeof_orbit_flow(void) { return (int)sizeof(gs_orbit_flow); }
int gs_sizeof_corrector_flow(void) { return (int)sizeof(gs_corrector_flow); }

/* The layout of every argument struct, field by field, for the ctypes mirrors'
 * load-time check (gearsym/engine/sim_args.py): a mirror with two fields swapped has
 * the right size but not the right offsets.  kind: 'd' double, 'i' int, 'l' long,
 * 'p' pointer, 'a' char array, 's' struct. */
#define GS_ABI_KIND(X) \
  _Generic((X), double: 'd', int: 'i', long: 'l', char*: 'a', gs_multipliers: 's', gs_isolation: 's', gs_ramp: 's', \
           default: 'p')
#define GS_ABI_FIELD(T, F) \
  {#T, #F, (long)offsetof(T, F), (long)sizeof(((T*)0)->F), GS_ABI_KIND(((T*)0)->F)}
typedef struct {
  const char* type;
  const char* field;
  long offset, size;
  int kind;
} gs_abi_entry;
static const gs_abi_entry gs_abi_table[] = {
    /* gs_sim_args */
    GS_ABI_FIELD(gs_sim_args, method), GS_ABI_FIELD(gs_sim_args, rtol), GS_ABI_FIELD(gs_sim_args, atol),
    GS_ABI_FIELD(gs_sim_args, t0), GS_ABI_FIELD(gs_sim_args, t_end), GS_ABI_FIELD(gs_sim_args, x0),
    GS_ABI_FIELD(gs_sim_args, p), GS_ABI_FIELD(gs_sim_args, sigma0), GS_ABI_FIELD(gs_sim_args, n_out),
    GS_ABI_FIELD(gs_sim_args, t_out), GS_ABI_FIELD(gs_sim_args, max_steps), GS_ABI_FIELD(gs_sim_args, max_events),
    GS_ABI_FIELD(gs_sim_args, storm_events), GS_ABI_FIELD(gs_sim_args, storm_window),
    GS_ABI_FIELD(gs_sim_args, max_step), GS_ABI_FIELD(gs_sim_args, init_step),
    GS_ABI_FIELD(gs_sim_args, want_monodromy), GS_ABI_FIELD(gs_sim_args, max_events_out),
    GS_ABI_FIELD(gs_sim_args, check_interrupt), GS_ABI_FIELD(gs_sim_args, interrupt_fd),
    GS_ABI_FIELD(gs_sim_args, nonlinear), GS_ABI_FIELD(gs_sim_args, linear_solver),
    GS_ABI_FIELD(gs_sim_args, atol_vec), GS_ABI_FIELD(gs_sim_args, y_out), GS_ABI_FIELD(gs_sim_args, x_final),
    GS_ABI_FIELD(gs_sim_args, sigma_final), GS_ABI_FIELD(gs_sim_args, monodromy), GS_ABI_FIELD(gs_sim_args, ev_t),
    GS_ABI_FIELD(gs_sim_args, ev_surface), GS_ABI_FIELD(gs_sim_args, ev_dir), GS_ABI_FIELD(gs_sim_args, ev_speed),
    GS_ABI_FIELD(gs_sim_args, n_events), GS_ABI_FIELD(gs_sim_args, t_reached), GS_ABI_FIELD(gs_sim_args, n_steps),
    GS_ABI_FIELD(gs_sim_args, n_rhs), GS_ABI_FIELD(gs_sim_args, n_jac), GS_ABI_FIELD(gs_sim_args, n_root_evals),
    GS_ABI_FIELD(gs_sim_args, n_breaks), GS_ABI_FIELD(gs_sim_args, n_reinit), GS_ABI_FIELD(gs_sim_args, status),
    GS_ABI_FIELD(gs_sim_args, errmsg), GS_ABI_FIELD(gs_sim_args, n_sens), GS_ABI_FIELD(gs_sim_args, sens_dir),
    GS_ABI_FIELD(gs_sim_args, sens_dt0), GS_ABI_FIELD(gs_sim_args, sens_dt1), GS_ABI_FIELD(gs_sim_args, sens_final),
    GS_ABI_FIELD(gs_sim_args, sens_out), GS_ABI_FIELD(gs_sim_args, ramp), GS_ABI_FIELD(gs_sim_args, max_breaks_out),
    GS_ABI_FIELD(gs_sim_args, brk_t),
    /* gs_ramp */
    GS_ABI_FIELD(gs_ramp, on), GS_ABI_FIELD(gs_ramp, index), GS_ABI_FIELD(gs_ramp, t0), GS_ABI_FIELD(gs_ramp, speed0),
    GS_ABI_FIELD(gs_ramp, rate),
    /* gs_multipliers */
    GS_ABI_FIELD(gs_multipliers, lapack_dgebal), GS_ABI_FIELD(gs_multipliers, lapack_dgesdd),
    GS_ABI_FIELD(gs_multipliers, lapack_dgeev), GS_ABI_FIELD(gs_multipliers, rtol),
    GS_ABI_FIELD(gs_multipliers, mu_re), GS_ABI_FIELD(gs_multipliers, mu_im), GS_ABI_FIELD(gs_multipliers, mu_tol),
    GS_ABI_FIELD(gs_multipliers, delta), GS_ABI_FIELD(gs_multipliers, ok),
    /* gs_isolation */
    GS_ABI_FIELD(gs_isolation, direction), GS_ABI_FIELD(gs_isolation, sigma), GS_ABI_FIELD(gs_isolation, norm),
    GS_ABI_FIELD(gs_isolation, ok),
    /* gs_newton */
    GS_ABI_FIELD(gs_newton, kind), GS_ABI_FIELD(gs_newton, n), GS_ABI_FIELD(gs_newton, nr),
    GS_ABI_FIELD(gs_newton, nx), GS_ABI_FIELD(gs_newton, segments), GS_ABI_FIELD(gs_newton, max_iter),
    GS_ABI_FIELD(gs_newton, tol), GS_ABI_FIELD(gs_newton, min_damping), GS_ABI_FIELD(gs_newton, decrease),
    GS_ABI_FIELD(gs_newton, accept_below), GS_ABI_FIELD(gs_newton, accept_last),
    GS_ABI_FIELD(gs_newton, apply_final_step), GS_ABI_FIELD(gs_newton, diverge_ratio),
    GS_ABI_FIELD(gs_newton, diverge_floor), GS_ABI_FIELD(gs_newton, trunc_level),
    GS_ABI_FIELD(gs_newton, scale_floor), GS_ABI_FIELD(gs_newton, row), GS_ABI_FIELD(gs_newton, target),
    GS_ABI_FIELD(gs_newton, S), GS_ABI_FIELD(gs_newton, Rs), GS_ABI_FIELD(gs_newton, n_anchor),
    GS_ABI_FIELD(gs_newton, anchor), GS_ABI_FIELD(gs_newton, t_ref), GS_ABI_FIELD(gs_newton, lapack_dgetrf),
    GS_ABI_FIELD(gs_newton, lapack_dgetrs), GS_ABI_FIELD(gs_newton, lapack_dgesdd),
    GS_ABI_FIELD(gs_newton, lapack_dgelsd), GS_ABI_FIELD(gs_newton, R), GS_ABI_FIELD(gs_newton, J),
    GS_ABI_FIELD(gs_newton, Flam), GS_ABI_FIELD(gs_newton, flam_given), GS_ABI_FIELD(gs_newton, amplitude),
    GS_ABI_FIELD(gs_newton, eval_status), GS_ABI_FIELD(gs_newton, eval_msg), GS_ABI_FIELD(gs_newton, z),
    GS_ABI_FIELD(gs_newton, z_eval), GS_ABI_FIELD(gs_newton, request), GS_ABI_FIELD(gs_newton, answered),
    GS_ABI_FIELD(gs_newton, must_succeed), GS_ABI_FIELD(gs_newton, n_evals), GS_ABI_FIELD(gs_newton, iterations),
    GS_ABI_FIELD(gs_newton, outcome), GS_ABI_FIELD(gs_newton, note), GS_ABI_FIELD(gs_newton, residual),
    GS_ABI_FIELD(gs_newton, residual_prev), GS_ABI_FIELD(gs_newton, relative), GS_ABI_FIELD(gs_newton, scale),
    GS_ABI_FIELD(gs_newton, hist_cap), GS_ABI_FIELD(gs_newton, n_hist), GS_ABI_FIELD(gs_newton, hist_kind),
    GS_ABI_FIELD(gs_newton, hist_abs), GS_ABI_FIELD(gs_newton, hist_rel), GS_ABI_FIELD(gs_newton, hist_step),
    GS_ABI_FIELD(gs_newton, hist_drop), GS_ABI_FIELD(gs_newton, tangent), GS_ABI_FIELD(gs_newton, tangent_ok),
    GS_ABI_FIELD(gs_newton, work),
    /* gs_orbit_flow */
    GS_ABI_FIELD(gs_orbit_flow, s), GS_ABI_FIELD(gs_orbit_flow, n_amp), GS_ABI_FIELD(gs_orbit_flow, grid),
    GS_ABI_FIELD(gs_orbit_flow, ev_t), GS_ABI_FIELD(gs_orbit_flow, ev_surface), GS_ABI_FIELD(gs_orbit_flow, ev_dir),
    GS_ABI_FIELD(gs_orbit_flow, ev_speed), GS_ABI_FIELD(gs_orbit_flow, ev_cap),
    GS_ABI_FIELD(gs_orbit_flow, n_events), GS_ABI_FIELD(gs_orbit_flow, handback),
    GS_ABI_FIELD(gs_orbit_flow, events_needed), GS_ABI_FIELD(gs_orbit_flow, n_runs),
    GS_ABI_FIELD(gs_orbit_flow, t_reached), GS_ABI_FIELD(gs_orbit_flow, mult), GS_ABI_FIELD(gs_orbit_flow, iso),
    GS_ABI_FIELD(gs_orbit_flow, g0_out), GS_ABI_FIELD(gs_orbit_flow, g0_ok),
    GS_ABI_FIELD(gs_orbit_flow, verify_ends), GS_ABI_FIELD(gs_orbit_flow, verify_ok),
    GS_ABI_FIELD(gs_orbit_flow, verify_status), GS_ABI_FIELD(gs_orbit_flow, verify_t_reached),
    GS_ABI_FIELD(gs_orbit_flow, verify_msg),
    /* gs_corrector_flow */
    GS_ABI_FIELD(gs_corrector_flow, segments), GS_ABI_FIELD(gs_corrector_flow, nd),
    GS_ABI_FIELD(gs_corrector_flow, periods), GS_ABI_FIELD(gs_corrector_flow, t0),
    GS_ABI_FIELD(gs_corrector_flow, lam0), GS_ABI_FIELD(gs_corrector_flow, p0), GS_ABI_FIELD(gs_corrector_flow, D),
    GS_ABI_FIELD(gs_corrector_flow, atol), GS_ABI_FIELD(gs_corrector_flow, zalg),
    GS_ABI_FIELD(gs_corrector_flow, Ms), GS_ABI_FIELD(gs_corrector_flow, ev_t),
    GS_ABI_FIELD(gs_corrector_flow, ev_surface), GS_ABI_FIELD(gs_corrector_flow, ev_dir),
    GS_ABI_FIELD(gs_corrector_flow, ev_speed), GS_ABI_FIELD(gs_corrector_flow, ev_cap),
    GS_ABI_FIELD(gs_corrector_flow, n_events), GS_ABI_FIELD(gs_corrector_flow, handback),
    GS_ABI_FIELD(gs_corrector_flow, events_needed), GS_ABI_FIELD(gs_corrector_flow, n_runs),
    GS_ABI_FIELD(gs_corrector_flow, n_evals), GS_ABI_FIELD(gs_corrector_flow, last_c_eval),
    GS_ABI_FIELD(gs_corrector_flow, period), GS_ABI_FIELD(gs_corrector_flow, dP),
    GS_ABI_FIELD(gs_corrector_flow, n_samples), GS_ABI_FIELD(gs_corrector_flow, t_samples),
    GS_ABI_FIELD(gs_corrector_flow, Y_samples), GS_ABI_FIELD(gs_corrector_flow, G_samples),
    GS_ABI_FIELD(gs_corrector_flow, H_samples), GS_ABI_FIELD(gs_corrector_flow, samples_ok),
    GS_ABI_FIELD(gs_corrector_flow, col_stats), GS_ABI_FIELD(gs_corrector_flow, col_args),
    GS_ABI_FIELD(gs_corrector_flow, stats_ok), GS_ABI_FIELD(gs_corrector_flow, mult),
};
#undef GS_ABI_FIELD
#undef GS_ABI_KIND

int gs_abi_field(int i, const char** type, const char** field, long* offset, long* size, int* kind) {
  const gs_abi_entry* e;
  if (i < 0 || (size_t)i >= sizeof(gs_abi_table) / sizeof(gs_abi_table[0])) return -1;
  e = &gs_abi_table[i];
  if (type) *type = e->type;
  if (field) *field = e->field;
  if (offset) *offset = e->offset;
  if (size) *size = e->size;
  if (kind) *kind = e->kind;
  return 0;
}

/* Layout check of the linear-solver operations table (used by the
 * block-diagonal solver): every slot gets a probe that records its own number
 * in the solver's content; each public SUNLinSol* wrapper must reach its slot. */
#define GS_PROBE(K, RET, NAME, ARGS, VAL) \
  static RET NAME ARGS {                 \
    *(int*)S->content = K;               \
    return VAL;                          \
  }
GS_PROBE(1, int, probe_gettype, (SUNLinearSolver S), 0)
GS_PROBE(2, int, probe_getid, (SUNLinearSolver S), 0)
GS_PROBE(5, SUNErrCode, probe_setscaling, (SUNLinearSolver S, N_Vector a, N_Vector b), ((void)a, (void)b, 0))
GS_PROBE(7, SUNErrCode, probe_setzeroguess, (SUNLinearSolver S, sunbooleantype f), ((void)f, 0))
GS_PROBE(8, SUNErrCode, probe_initialize, (SUNLinearSolver S), 0)
GS_PROBE(9, int, probe_setup, (SUNLinearSolver S, SUNMatrix A), ((void)A, 0))
GS_PROBE(10, int, probe_solve, (SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, sunrealtype tol),
         ((void)A, (void)x, (void)b, (void)tol, 0))
GS_PROBE(11, int, probe_numiters, (SUNLinearSolver S), 0)
GS_PROBE(12, sunrealtype, probe_resnorm, (SUNLinearSolver S), 0.0)
GS_PROBE(13, sunindextype, probe_lastflag, (SUNLinearSolver S), 0)
GS_PROBE(15, N_Vector, probe_resid, (SUNLinearSolver S), NULL)
#undef GS_PROBE

static int lsops_layout_ok(SUNContext ctx) {
  int hit = 0, ok = 1;
  SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
  if (!S || !S->ops) return 0;
  S->content = &hit;
  S->ops->gettype = probe_gettype;
  S->ops->getid = probe_getid;
  S->ops->setscalingvectors = probe_setscaling;
  S->ops->setzeroguess = probe_setzeroguess;
  S->ops->initialize = probe_initialize;
  S->ops->setup = probe_setup;
  S->ops->solve = probe_solve;
  S->ops->numiters = probe_numiters;
  S->ops->resnorm = probe_resnorm;
  S->ops->lastflag = probe_lastflag;
  S->ops->resid = probe_resid;
#define GS_EXPECT(CALL, K) \
  hit = 0;                 \
  (void)(CALL);            \
  ok = ok && (hit == (K));
  GS_EXPECT(SUNLinSolGetType(S), 1)
  GS_EXPECT(SUNLinSolGetID(S), 2)
  GS_EXPECT(SUNLinSolSetScalingVectors(S, NULL, NULL), 5)
  GS_EXPECT(SUNLinSolSetZeroGuess(S, SUNTRUE), 7)
  GS_EXPECT(SUNLinSolInitialize(S), 8)
  GS_EXPECT(SUNLinSolSetup(S, NULL), 9)
  GS_EXPECT(SUNLinSolSolve(S, NULL, NULL, NULL, 0.0), 10)
  GS_EXPECT(SUNLinSolNumIters(S), 11)
  GS_EXPECT(SUNLinSolResNorm(S), 12)
  GS_EXPECT(SUNLinSolLastFlag(S), 13)
  GS_EXPECT(SUNLinSolResid(S), 15)
#undef GS_EXPECT
  S->content = NULL;
  SUNLinSolFreeEmpty(S);
  return ok;
}

int gs_check_abi(char* msg, int len) {
  char ver[64];
  int major = 0, ok = 0;
  SUNContext ctx = NULL;
  SUNMatrix A = NULL;
  if (!msg || len <= 0) return -1;
  msg[0] = '\0';
  memset(ver, 0, sizeof(ver));
  if (SUNDIALSGetVersion(ver, (int)sizeof(ver) - 1) != 0) {
    snprintf(msg, (size_t)len, "SUNDIALSGetVersion failed");
    return -1;
  }
  major = atoi(ver);
  if (major < 7) {
    snprintf(msg, (size_t)len, "SUNDIALS %s found, gearsym needs SUNDIALS >= 7", ver);
    return -1;
  }
  if (SUNContext_Create(SUN_COMM_NULL, &ctx) != 0 || !ctx) {
    snprintf(msg, (size_t)len, "SUNDIALS %s: SUNContext_Create failed", ver);
    return -1;
  }
  A = SUNDenseMatrix(3, 5, ctx);
  if (!A) {
    snprintf(msg, (size_t)len, "SUNDIALS %s: SUNDenseMatrix failed", ver);
  } else {
    /* struct _generic_SUNMatrix { void* content; ... };
     * struct _SUNMatrixContent_Dense { sunindextype M, N; sunrealtype* data; ...} */
    void* content = *(void**)A;
    if (content) {
      const int32_t* idx = (const int32_t*)content;
      double* data_at_8 = *(double**)((char*)content + 8);
      ok = (idx[0] == 3 && idx[1] == 5 && data_at_8 == SUNDenseMatrix_Data(A));
    }
    if (!ok)
      snprintf(msg, (size_t)len,
               "SUNDIALS %s was not built with 32-bit sunindextype (SUNDIALS_INDEX_SIZE=32) and double "
               "precision as gearsym's driver assumes; use the SUNDIALS libraries of the scikit-sundae wheel",
               ver);
    SUNMatDestroy(A);
  }
  if (ok && !lsops_layout_ok(ctx)) {
    ok = 0;
    snprintf(msg, (size_t)len,
             "SUNDIALS %s: the linear-solver operations table (struct _generic_SUNLinearSolver_Ops) is not laid "
             "out as gearsym's driver declares it (sundials7.h); use the SUNDIALS libraries of the scikit-sundae "
             "wheel",
             ver);
  }
  SUNContext_Free(&ctx);
  if (!ok) return -1;
  snprintf(msg, (size_t)len, "%s", ver);
  return 0;
}

/* The workspace's tolerance vector, filled from v (length n); NULL if out of memory
 * (SUNDIALS then reports the NULL vector as an illegal input). */
N_Vector ws_atol(gs_workspace* ws, const double* v, int n) {
  if (ws->atol && ws->cfg_atol_n != n) {
    N_VDestroy(ws->atol);
    ws->atol = NULL;
  }
  if (!ws->atol) {
    ws->atol = N_VNew_Serial((sunindextype)n, ws->ctx);
    ws->cfg_atol_n = n;
  }
  if (ws->atol) memcpy(N_VGetArrayPointer(ws->atol), v, sizeof(double) * (size_t)n);
  return ws->atol;
}

gs_workspace* gs_ws_new(void) { return (gs_workspace*)calloc(1, sizeof(gs_workspace)); }

/* Free the SUNDIALS solver objects (vectors, matrix, solvers, integrator). */
void ws_free_solver(gs_workspace* ws) {
  gs_solver* S = &ws->S;
  if (S->mem) {
    if (S->ida)
      IDAFree(&S->mem);
    else
      CVodeFree(&S->mem);
  }
  if (S->LS) SUNLinSolFree(S->LS);
  if (S->NLS) SUNNonlinSolFree(S->NLS);
  if (S->A) SUNMatDestroy(S->A);
  if (S->y) N_VDestroy(S->y);
  if (S->yp) N_VDestroy(S->yp);
  if (S->id) N_VDestroy(S->id);
  memset(S, 0, sizeof(*S));
  ws->cfg_valid = 0;
}

void gs_ws_free(gs_workspace* ws) {
  gs_ud* ud;
  if (!ws) return;
  ud = &ws->U;
  ws_free_solver(ws);
  if (ws->atol) N_VDestroy(ws->atol);
  if (ws->ctx) SUNContext_Free(&ws->ctx);
  if (ws->warn_fp) fclose(ws->warn_fp);
  free(ws->warn_buf);
  free((void*)ud->arg);
  free(ud->resp);
  free(ud->iw);
  free(ud->w);
  free(ud->nzbuf);
  free(ud->m);
  free(ud->m_alt);
  free(ud->J);
  free(ud->J2);
  free(ud->f);
  free(ud->f2);
  free(ud->f3);
  free(ud->xs);
  free(ud->ypc);
  free(ud->g);
  free(ud->G);
  free(ud->gt);
  free(ud->rootsfound);
  free(ud->rootdir);
  free(ws->nb);
  free(ws->sched_off);
  free(ws->sched_s);
  free(ws->sched_sp);
  free(ud->Fp);
  free(ud->Gp);
  free(ud->pw);
  free(ws);
}

/* Set up the model part of a workspace (once): metadata, the generated
 * functions' shapes, work buffers, the SUNDIALS context.  Returns 0, or a
 * status with the message in a. */
int ws_model_setup(gs_workspace* ws, gs_sim_args* a) {
  gs_ud* ud = &ws->U;
  int* info = ws->info;
  casadi_int* mx = ws->mx;
  int nx, np, nm, nsw, nsched, rc, k;
  char cmsg[512];
  /* ---- model metadata ---- */
  memset(ud, 0, sizeof(*ud));
  if (!gs_model_info) return set_err(a, GS_ERR_INPUT, "the compiled model lacks gs_model_info");
  rc = gs_model_info(info, 64);
  if (rc < 6) return set_err(a, GS_ERR_INPUT, "gs_model_info failed (returned %d)", rc);
  nx = info[0];
  np = info[1];
  nm = info[2];
  nsw = info[3];
  nsched = info[4];
  ud->implicit = info[5];
  if (nx <= 0 || np < 0 || nsw < 0 || nsched < 0 || nsched > rc - 6 || (long long)nm != (long long)nsw + 2LL * nsched)
    return set_err(a, GS_ERR_INPUT, "inconsistent model info: nx=%d np=%d nm=%d nsw=%d nsched=%d", nx, np, nm, nsw,
                   nsched);
  ud->nx = nx;
  ud->np = np;
  ud->nm = nm;
  /* algebraic variables (the last nalg states), after the schedule breaks; older
   * models do not write the entry: none */
  ud->nalg = rc >= 7 + nsched ? info[6 + nsched] : 0;
  if (ud->nalg < 0 || ud->nalg >= nx || (ud->nalg > 0 && !ud->implicit))
    return set_err(a, GS_ERR_INPUT, "inconsistent model info: %d algebraic variables of %d states (%s model)",
                   ud->nalg, nx, ud->implicit ? "implicit" : "explicit");
  ud->nd = nx - ud->nalg;
  ud->nsw = nsw;
  ud->nsched = nsched;
  {
    /* the driver forms nx*nx (Jacobians), nsw*nx and nx*np in int: each must fit (nx*nx also
     * in SUNDIALS' 32-bit index: the state's dense Newton matrix) */
    long long t;
    if (gs_mul_le(nx, nx, GS_INDEX_MAX, &t) || gs_mul_le(nsw, nx, INT32_MAX, &t) || gs_mul_le(nx, np, INT32_MAX, &t))
      return set_err(a, GS_ERR_INPUT,
                     "the model is too large for the driver: nx = %d states, np = %d parameters, nsw = %d "
                     "switching functions; nx*nx, nsw*nx and nx*np must each be at most %lld (SUNDIALS' "
                     "32-bit index)",
                     nx, np, nsw, GS_INDEX_MAX);
  }

  /* ---- model functions ---- */
  GS_FN_SETUP(ud->rhs, gs_rhs);
  GS_FN_SETUP(ud->jac, gs_jac);
  GS_FN_SETUP(ud->res, gs_res);
  GS_FN_SETUP(ud->resjac, gs_resjac);
  GS_FN_SETUP(ud->sw, gs_sw);
  GS_FN_SETUP(ud->swx, gs_swx);
  GS_FN_SETUP(ud->swt, gs_swt);
  GS_FN_SETUP(ud->sched, gs_sched);
  GS_FN_SETUP(ud->period, gs_period);
  GS_FN_SETUP(ud->out, gs_out);
  GS_FN_SETUP(ud->mesh, gs_mesh);
  GS_FN_SETUP(ud->jacp, gs_jacp);
  GS_FN_SETUP(ud->swp, gs_swp);
  GS_FN_SETUP(ud->schedp, gs_schedp);
  GS_FN_SETUP(ud->periodp, gs_periodp);
  GS_FN_SETUP(ud->resp_fn, gs_resp);
  GS_FN_SETUP(ud->rest_fn, gs_rest);
  {
    int s4[4] = {1, nx, np, nm};
    int s5[5] = {1, nx, nx, np, nm};
    int s6[6] = {1, nx, nx, np, nm, 1};
    int s3[3] = {1, nx, np};
    int s1[1] = {np};
    long long nbsum = 0, t;
    for (k = 0; k < nsched; ++k) {
      if (info[6 + k] < 1) return set_err(a, GS_ERR_INPUT, "schedule %d has %d breaks (need >= 1)", k, info[6 + k]);
      nbsum += 1 + (long long)info[6 + k];
      if (nbsum > INT32_MAX) return set_err(a, GS_ERR_INPUT, "the schedules have more than %d breaks", INT32_MAX);
    }
    if (gs_mul_le(nbsum, np, INT32_MAX, &t))
      return set_err(a, GS_ERR_INPUT, "the schedule table (%lld entries) times np = %d parameters is above %d",
                     nbsum, np, INT32_MAX);
    ws->nsched_total = (int)nbsum;
    cmsg[0] = '\0';
#define GS_CHECK(FN, NAME, SIZES, NIN, NR, NC)                                                                  \
  if (gs_fn_check(&ud->FN, NAME##_work, NAME##_n_in, NAME##_n_out, NAME##_sparsity_in, NAME##_sparsity_out, \
                  SIZES, NIN, NR, NC, mx, cmsg, (int)sizeof(cmsg)))                                          \
    return set_err(a, GS_ERR_INPUT, "%s", cmsg);
    if (!ud->implicit) {
      GS_CHECK(rhs, gs_rhs, s4, 4, nx, 1)
      GS_CHECK(jac, gs_jac, s4, 4, nx, nx)
    } else {
      GS_CHECK(res, gs_res, s5, 5, nx, 1)
      GS_CHECK(resjac, gs_resjac, s6, 6, nx, nx)
    }
    GS_CHECK(sw, gs_sw, s3, 3, nsw, 1)
    GS_CHECK(swx, gs_swx, s3, 3, nsw, nx)
    GS_CHECK(swt, gs_swt, s3, 3, nsw, 1)
    GS_CHECK(sched, gs_sched, s1, 1, ws->nsched_total, 1)
    if (ud->period.present) GS_CHECK(period, gs_period, s1, 1, 1, 1)
    if (ud->out.present) {
      const casadi_int* sp = gs_out_sparsity_out(0);
      ws->n_out_fn = sp ? (int)sp[0] : 0;
      GS_CHECK(out, gs_out, s4, 4, ws->n_out_fn, 1)
    }
    if (ud->mesh.present) {
      const casadi_int* sp = gs_mesh_sparsity_out(0);
      ws->n_mesh_fn = sp ? (int)sp[0] : 0;
      GS_CHECK(mesh, gs_mesh, s4, 4, ws->n_mesh_fn, 1)
    }
    /* parameter derivatives: optional (models built before them, implicit models) */
    if (ud->jacp.present) GS_CHECK(jacp, gs_jacp, s4, 4, nx, np)
    if (ud->swp.present) GS_CHECK(swp, gs_swp, s3, 3, nsw, np)
    if (ud->schedp.present) GS_CHECK(schedp, gs_schedp, s1, 1, ws->nsched_total, np)
    if (ud->periodp.present) GS_CHECK(periodp, gs_periodp, s1, 1, 1, np)
    if (ud->implicit && ud->resp_fn.present) GS_CHECK(resp_fn, gs_resp, s5, 5, nx, np)
    if (ud->implicit && ud->rest_fn.present) GS_CHECK(rest_fn, gs_rest, s5, 5, nx, 1)
#undef GS_CHECK
  }

  /* ---- work buffers (freed by gs_ws_free) ---- */
  ud->arg = (const casadi_real**)calloc((size_t)mx[0] + 8, sizeof(casadi_real*));
  ud->resp = (casadi_real**)calloc((size_t)mx[1] + 2, sizeof(casadi_real*));
  ud->iw = (casadi_int*)calloc((size_t)mx[2] + 1, sizeof(casadi_int));
  ud->w = (casadi_real*)calloc((size_t)mx[3] + 1, sizeof(casadi_real));
  ud->nzbuf = (double*)calloc((size_t)mx[4] + 1, sizeof(double));
  ud->m = (double*)calloc((size_t)nm + 1, sizeof(double));
  ud->m_alt = (double*)calloc((size_t)nm + 1, sizeof(double));
  ud->J = (double*)calloc((size_t)nx * nx, sizeof(double));
  ud->J2 = (double*)calloc((size_t)nx * nx, sizeof(double));
  ud->f = (double*)calloc((size_t)nx, sizeof(double));
  ud->f2 = (double*)calloc((size_t)nx, sizeof(double));
  ud->f3 = (double*)calloc((size_t)nx, sizeof(double));
  ud->xs = (double*)calloc((size_t)nx, sizeof(double));
  ud->ypc = (double*)calloc((size_t)nx, sizeof(double));
  ud->g = (double*)calloc((size_t)nsw + 1, sizeof(double));
  ud->G = (double*)calloc((size_t)nsw * nx + 1, sizeof(double));
  ud->gt = (double*)calloc((size_t)nsw + 1, sizeof(double));
  ud->rootsfound = (int*)calloc((size_t)nsw + 1, sizeof(int));
  ud->rootdir = (int*)calloc((size_t)nsw + 1, sizeof(int));
  ws->nb = (int*)calloc((size_t)nsched + 1, sizeof(int));
  ws->sched_off = (int*)calloc((size_t)nsched + 1, sizeof(int));
  ws->sched_s = (double*)calloc((size_t)ws->nsched_total + 1, sizeof(double));
  ws->sched_sp = (double*)calloc((size_t)ws->nsched_total * np + 1, sizeof(double));
  ud->Fp = (double*)calloc((size_t)nx * np + 1, sizeof(double));
  ud->Gp = (double*)calloc((size_t)nsw * np + 1, sizeof(double));
  ud->pw = (double*)calloc((size_t)np + 1, sizeof(double));
  if (!ud->arg || !ud->resp || !ud->iw || !ud->w || !ud->nzbuf || !ud->m || !ud->m_alt || !ud->J || !ud->J2 ||
      !ud->f || !ud->f2 || !ud->f3 || !ud->xs || !ud->ypc || !ud->g || !ud->G || !ud->gt || !ud->rootsfound || !ud->rootdir || !ws->nb ||
      !ws->sched_off || !ws->sched_s || !ws->sched_sp || !ud->Fp || !ud->Gp || !ud->pw)
    return set_err(a, GS_ERR_INPUT, "out of memory");

  for (k = 0; k < nsched; ++k) ws->nb[k] = info[6 + k];

  /* ---- SUNDIALS context ---- */
  if (SUNContext_Create(SUN_COMM_NULL, &ws->ctx) != 0 || !ws->ctx) return set_err(a, GS_ERR_SOLVER, "SUNContext_Create failed");
  SUNContext_ClearErrHandlers(ws->ctx);
  SUNContext_PushErrHandler(ws->ctx, sun_err_handler, ud);
  {
    /* keep SUNDIALS' log output off stdout/stderr: errors arrive through
     * sun_err_handler, warnings go to a memory stream quoted in messages */
    SUNLogger logger = NULL;
    if (SUNContext_GetLogger(ws->ctx, &logger) == 0 && logger) {
      ws->warn_fp = open_memstream(&ws->warn_buf, &ws->warn_len);
      SUNLogger_SetWarningFile(logger, ws->warn_fp);
      SUNLogger_SetErrorFile(logger, NULL);
      SUNLogger_SetInfoFile(logger, NULL);
      SUNLogger_SetDebugFile(logger, NULL);
    }
  }
  ws->ready = 1;
  return 0;
}
