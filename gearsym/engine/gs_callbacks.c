/*
 * gs_callbacks.c -- part of the gearsym driver (gs_driver.c; shared declarations in
 * gs_internal.h): the model's CasADi functions (setup, checks, calls) and the CVODE / IDA
 * callbacks (right-hand side, residual, Jacobians, roots, variational and sensitivity
 * equations), solver counters.
 */
#include "gs_internal.h"

/* --------------------------------------------------------------------------
 * CasADi function wrappers
 * -------------------------------------------------------------------------- */
void gs_fn_setup(gs_fn* fn, const char* name, gs_cfun_ptr f, gs_work_ptr work, gs_nio_ptr n_in,
                        gs_nio_ptr n_out, gs_sp_ptr sp_in, gs_sp_ptr sp_out) {
  memset(fn, 0, sizeof(*fn));
  fn->name = name;
  fn->f = f;
  fn->present = (f && work && n_in && n_out && sp_in && sp_out) ? 1 : 0;
}

/* Validate inputs/outputs of a present function and record the output pattern;
 * update the maximal work sizes.  Returns 0 or writes a message. */
int gs_fn_check(gs_fn* fn, gs_work_ptr work, gs_nio_ptr n_in, gs_nio_ptr n_out, gs_sp_ptr sp_in,
                       gs_sp_ptr sp_out, const int* in_sizes, int n_expected_in, int nrow, int ncol,
                       casadi_int* mx, char* msg, int len) {
  casadi_int sz[4] = {0, 0, 0, 0};
  const casadi_int* sp;
  int i;
  if (!fn->present) {
    snprintf(msg, (size_t)len, "the compiled model lacks the function %s (or its CasADi helpers)", fn->name);
    return -1;
  }
  if ((int)n_in() != n_expected_in || (int)n_out() != 1) {
    snprintf(msg, (size_t)len, "model function %s has %d inputs and %d outputs, expected %d and 1", fn->name,
             (int)n_in(), (int)n_out(), n_expected_in);
    return -1;
  }
  for (i = 0; i < n_expected_in; ++i) {
    casadi_int nnz;
    sp = sp_in(i);
    if (!sp) {
      snprintf(msg, (size_t)len, "model function %s: no sparsity for input %d", fn->name, i);
      return -1;
    }
    /* CasADi's compact encoding {nrow, ncol, 1} means dense (a sparse pattern
     * always starts its column offsets with colind[0] == 0) */
    nnz = (sp[2] == 1) ? sp[0] * sp[1] : sp[2 + sp[1]];
    if (sp[0] * sp[1] != in_sizes[i] || nnz != in_sizes[i]) {
      snprintf(msg, (size_t)len,
               "model function %s: input %d has shape %lldx%lld with %lld nonzeros, expected %d dense entries",
               fn->name, i, (long long)sp[0], (long long)sp[1], (long long)nnz, in_sizes[i]);
      return -1;
    }
  }
  sp = sp_out(0);
  if (!sp || sp[0] != nrow || sp[1] != ncol) {
    snprintf(msg, (size_t)len, "model function %s: output has shape %lldx%lld, expected %dx%d", fn->name,
             sp ? (long long)sp[0] : -1LL, sp ? (long long)sp[1] : -1LL, nrow, ncol);
    return -1;
  }
  fn->nrow = nrow;
  fn->ncol = ncol;
  if (sp[2] == 1) { /* compact encoding of a dense pattern */
    fn->dense = 1;
    fn->nnz = nrow * ncol;
  } else {
    fn->colind = sp + 2;
    fn->row = sp + 3 + ncol;
    fn->nnz = (int)fn->colind[ncol];
    fn->dense = (fn->nnz == nrow * ncol);
  }
  if (work(&sz[0], &sz[1], &sz[2], &sz[3]) != 0) {
    snprintf(msg, (size_t)len, "model function %s: work size query failed", fn->name);
    return -1;
  }
  for (i = 0; i < 4; ++i)
    if (sz[i] > mx[i]) mx[i] = sz[i];
  if (fn->nnz > mx[4]) mx[4] = fn->nnz;
  return 0;
}

/* Call fn with inputs in[0..n_in-1]; write the dense (column-major) output. */
int gs_call(gs_ud* ud, const gs_fn* fn, const double** in, int n_in, double* out) {
  int i, c, k;
  double* dst = fn->dense ? out : ud->nzbuf;
  for (i = 0; i < n_in; ++i) ud->arg[i] = in[i];
  ud->resp[0] = dst;
  if (fn->f(ud->arg, ud->resp, ud->iw, ud->w, 0) != 0) return -1;
  if (!fn->dense) {
    memset(out, 0, sizeof(double) * (size_t)(fn->nrow * fn->ncol));
    for (c = 0; c < fn->ncol; ++c)
      for (k = (int)fn->colind[c]; k < (int)fn->colind[c + 1]; ++k) out[c * fn->nrow + fn->row[k]] = dst[k];
  }
  return 0;
}

int eval_rhs(gs_ud* ud, double t, const double* x, const double* m, double* out) {
  const double* in[4];
  double s;
  in[2] = model_args(ud, t, &s); /* (t, p), or the speed ramp's (gs_ramp.c) */
  in[0] = &s;
  in[1] = x;
  in[3] = ud->nm ? m : ud->dummy;
  return gs_call(ud, &ud->rhs, in, 4, out);
}

static int eval_jac(gs_ud* ud, double t, const double* x, const double* m, double* out) {
  const double* in[4];
  double s;
  in[2] = model_args(ud, t, &s);
  in[0] = &s;
  in[1] = x;
  in[3] = ud->nm ? m : ud->dummy;
  return gs_call(ud, &ud->jac, in, 4, out);
}

/* A function of the residual's inputs (t, x, xd, p, m): gs_res, gs_resp, gs_rest. */
static int eval_resfn(gs_ud* ud, const gs_fn* fn, double t, const double* x, const double* xd, const double* m,
                      double* out) {
  const double* in[5];
  double s;
  in[3] = model_args(ud, t, &s);
  in[0] = &s;
  in[1] = x;
  in[2] = xd;
  in[4] = ud->nm ? m : ud->dummy;
  return gs_call(ud, fn, in, 5, out);
}

static int eval_res(gs_ud* ud, double t, const double* x, const double* xd, const double* m, double* out) {
  return eval_resfn(ud, &ud->res, t, x, xd, m, out);
}

static int eval_resjac(gs_ud* ud, double t, const double* x, const double* xd, const double* m, double cj,
                       double* out) {
  const double* in[6];
  double s;
  in[3] = model_args(ud, t, &s);
  in[0] = &s;
  in[1] = x;
  in[2] = xd;
  in[4] = ud->nm ? m : ud->dummy;
  in[5] = &cj;
  return gs_call(ud, &ud->resjac, in, 6, out);
}

int eval_swfn(gs_ud* ud, const gs_fn* fn, double t, const double* x, double* out) {
  const double* in[3];
  double s;
  if (fn->nrow * fn->ncol == 0) return 0;
  in[2] = model_args(ud, t, &s);
  in[0] = &s;
  in[1] = x;
  return gs_call(ud, fn, in, 3, out);
}

int eval_xdot_dae(gs_ud* ud, double t, const double* x, const double* m, const double* guess, double* out);

/* xdot in mode m.  Explicit: gs_rhs.  Implicit: Newton on gs_res(t,x,xd)=0 for
 * xd from the initial guess `guess` (dr/dxd = resjac(cj=1) - resjac(cj=0)).
 * With algebraic variables: eval_xdot_dae. */
int eval_xdot(gs_ud* ud, double t, const double* x, const double* m, const double* guess, double* out) {
  int it, i, n = ud->nx;
  if (!ud->implicit) return eval_rhs(ud, t, x, m, out);
  if (ud->nalg > 0) return eval_xdot_dae(ud, t, x, m, guess, out);
  double* r = ud->f; /* scratch (out may be f2 or f3) */
  if (out != guess) memcpy(out, guess, sizeof(double) * (size_t)n);
  for (it = 0; it < 6; ++it) {
    double dmax = 0.0, xmax = 0.0;
    if (eval_res(ud, t, x, out, m, r)) return -1;
    if (eval_resjac(ud, t, x, out, m, 1.0, ud->J)) return -1;
    if (eval_resjac(ud, t, x, out, m, 0.0, ud->J2)) return -1;
    for (i = 0; i < n * n; ++i) ud->J[i] -= ud->J2[i];
    for (i = 0; i < n; ++i) r[i] = -r[i];
    if (lu_solve(n, ud->J, r)) return -1;
    for (i = 0; i < n; ++i) {
      out[i] += r[i];
      if (fabs(r[i]) > dmax) dmax = fabs(r[i]);
      if (fabs(out[i]) > xmax) xmax = fabs(out[i]);
    }
    if (!(dmax <= 1e-13 * (1.0 + xmax))) continue;
    break;
  }
  return all_finite(out, n, NULL) ? 0 : -1;
}

/* A DAE (nalg > 0 algebraic variables, the last states): Newton on
 * gs_res(t, [x_d; z], [xd_d; 0]) = 0 for the derivatives xd_d of the differential
 * states AND the algebraic variables z (z's derivative is not part of the DAE),
 * starting from xd_d = guess and z = x's.  out[0..nd) = xd_d, out[nd..nx) = 0; the
 * consistent state [x_d; z] is left in ud->xs.  Used for the flow direction at a
 * switching surface, the saltation matrices and as IDA's initial guess (IDACalcIC
 * then makes the initial conditions consistent itself). */
int eval_xdot_dae(gs_ud* ud, double t, const double* x, const double* m, const double* guess, double* out) {
  int it, i, j, n = ud->nx, nd = ud->nd;
  double* r = ud->f; /* scratch (out may be f2 or f3) */
  double* xs = ud->xs;
  memcpy(xs, x, sizeof(double) * (size_t)n);
  if (out != guess) memcpy(out, guess, sizeof(double) * (size_t)nd);
  for (i = nd; i < n; ++i) out[i] = 0.0;
  for (it = 0; it < 8; ++it) {
    double dmax = 0.0, xmax = 0.0;
    if (eval_res(ud, t, xs, out, m, r)) return -1;
    if (eval_resjac(ud, t, xs, out, m, 1.0, ud->J)) return -1;
    if (eval_resjac(ud, t, xs, out, m, 0.0, ud->J2)) return -1;
    /* unknowns u = [xd_d; z]: columns dr/dxd_j (j < nd), dr/dz_j (j >= nd) */
    for (j = 0; j < nd; ++j)
      for (i = 0; i < n; ++i) ud->J[(size_t)j * n + i] -= ud->J2[(size_t)j * n + i];
    for (j = nd; j < n; ++j) memcpy(ud->J + (size_t)j * n, ud->J2 + (size_t)j * n, sizeof(double) * (size_t)n);
    for (i = 0; i < n; ++i) r[i] = -r[i];
    if (lu_solve(n, ud->J, r)) return -1;
    for (i = 0; i < n; ++i) {
      double* u = i < nd ? &out[i] : &xs[i];
      *u += r[i];
      if (fabs(r[i]) > dmax) dmax = fabs(r[i]);
      if (fabs(*u) > xmax) xmax = fabs(*u);
    }
    if (dmax <= 1e-13 * (1.0 + xmax)) break;
  }
  return all_finite(out, n, NULL) && all_finite(xs, n, NULL) ? 0 : -1;
}

/* d F / d p of the residual into ud->Fp (nx x np, column-major) at (t, y, y'): gs_resp for an
 * implicit model, -gs_jacp for an explicit one on IDA (F = y' - f). */
static int ida_res_p(gs_ud* ud, double t, const double* yv, const double* ypv) {
  int i;
  if (ud->implicit) return eval_resfn(ud, &ud->resp_fn, t, yv, ypv, ud->m, ud->Fp);
  {
    const double* in[4];
    in[0] = &t;
    in[1] = yv;
    in[2] = ud->p;
    in[3] = ud->nm ? ud->m : ud->dummy;
    if (gs_call(ud, &ud->jacp, in, 4, ud->Fp)) return -1;
  }
  for (i = 0; i < ud->nx * ud->np; ++i) ud->Fp[i] = -ud->Fp[i];
  return 0;
}

/* b += F_p D(:, s) for sensitivity direction s (ud->Fp from ida_res_p). */
static void add_res_p(const gs_ud* ud, int s, double* b) {
  const double* d = ud->sdir + (size_t)s * ud->np;
  int k, i;
  for (k = 0; k < ud->np; ++k) {
    const double* fk = ud->Fp + (size_t)k * ud->nx;
    if (d[k] == 0.0) continue;
    for (i = 0; i < ud->nx; ++i) b[i] += fk[i] * d[k];
  }
}

/* J <- [F_y'(:, d) | F_y(:, z)] at (t, y, y') (J2 keeps F_y): the matrix of the unknowns
 * [x_d'; z] (and of [S_d'; S_z] of every variational block) of an index-1 DAE. */
static int dae_matrix(gs_ud* ud, double t, const double* yv, const double* ypv, const double* m) {
  int nx = ud->nx, nd = ud->nd, i, j;
  if (eval_resjac(ud, t, yv, ypv, m, 1.0, ud->J) || eval_resjac(ud, t, yv, ypv, m, 0.0, ud->J2)) return -1;
  for (j = 0; j < nd; ++j)
    for (i = 0; i < nx; ++i) ud->J[(size_t)j * nx + i] -= ud->J2[(size_t)j * nx + i];
  for (j = nd; j < nx; ++j) memcpy(ud->J + (size_t)j * nx, ud->J2 + (size_t)j * nx, sizeof(double) * (size_t)nx);
  return 0;
}

/* IDACalcIC's starting point for a DAE (nalg > 0): the algebraic variables and the
 * derivatives of the differential states solved for in the current mode
 * (eval_xdot_dae), and with variational columns the same for every block:
 * [F_y'(:, d) | F_y(:, z)] [S'_d; S_z] = -F_y(:, d) S_d (- F_p D(:, s) for the
 * sensitivity of direction s).  IDACalcIC then makes them
 * consistent in IDA's own norm.  Needed because IDACalcIC weighs its Newton
 * corrections with error weights computed from the guess: an algebraic variable
 * guessed as 0 gets the weight 1/atol (1e14 for atol = 1e-14), and its roundoff
 * alone then failed the convergence test (IDA_LINESEARCH_FAIL, measured on
 * models/spur_pair_coupled_load.toml at rtol 1e-10).  If a solve fails the guess
 * is left as it is (IDACalcIC then reports what goes wrong). */
void ida_consistent_guess(gs_ud* ud, double t, double* yv, double* ypv) {
  int nx = ud->nx, nd = ud->nd, nphi = ud->mono * nd, i, j, k;
  int* piv;
  if (eval_xdot_dae(ud, t, yv, ud->m, ypv, ud->f3)) return;
  memcpy(ypv, ud->f3, sizeof(double) * (size_t)nd);
  memcpy(yv + nd, ud->xs + nd, sizeof(double) * (size_t)(nx - nd));
  if (!ud->nvc) return;
  /* F_y' (J) and F_y (J2) at the consistent point; A = [F_y'(:, d) | F_y(:, z)] in J */
  if (dae_matrix(ud, t, yv, ypv, ud->m)) return;
  if (ud->ns && ida_res_p(ud, t, yv, ypv)) return;
  piv = (int*)malloc(sizeof(int) * (size_t)nx);
  if (!piv) return;
  if (lu_factor(nx, ud->J, piv) == 0) {
    for (k = 0; k < ud->nvc; ++k) {
      double* Sk = yv + (size_t)(k + 1) * nx;
      double* b = ud->f;
      for (i = 0; i < nx; ++i) {
        double sum = 0.0;
        for (j = 0; j < nd; ++j) sum += ud->J2[(size_t)j * nx + i] * Sk[j];
        b[i] = sum;
      }
      if (k >= nphi) add_res_p(ud, k - nphi, b);
      for (i = 0; i < nx; ++i) b[i] = -b[i];
      lu_apply(nx, ud->J, piv, b);
      memcpy(ypv + (size_t)(k + 1) * nx, b, sizeof(double) * (size_t)nd);
      memcpy(Sk + nd, b + nd, sizeof(double) * (size_t)(nx - nd));
    }
  }
  free(piv);
}

/* The whole derivative y' = [x_d'; z'] of an implicit model on its solution at (t, y), y
 * consistent: x_d' as eval_xdot (from `guess`), and for a DAE z' from the time derivative
 * of F(t, y, y') = 0 along the solution, F_t + F_y y' + F_y' y'' = 0, whose unknowns
 * [x_d''; z'] have the matrix [F_y'(:, d) | F_y(:, z)] (gs_rest gives F_t).  Explicit
 * models: f.  The total derivative of x(t_end(lambda)) needs it (sens_final). */
int ida_xdot_full(gs_ud* ud, double t, const double* y, const double* guess, double* out) {
  int nx = ud->nx, nd = ud->nd, i, j;
  double* b = ud->f;
  if (!ud->implicit) return eval_rhs(ud, t, y, ud->m, out);
  if (eval_xdot(ud, t, y, ud->m, guess, out)) return -1;
  if (ud->nalg == 0) return 0;
  y = ud->xs; /* the consistent state eval_xdot_dae solved for (y to round-off) */
  if (!ud->rest_fn.present || dae_matrix(ud, t, y, out, ud->m) || eval_resfn(ud, &ud->rest_fn, t, y, out, ud->m, b))
    return -1;
  for (i = 0; i < nx; ++i) {
    double sum = b[i];
    for (j = 0; j < nd; ++j) sum += ud->J2[(size_t)j * nx + i] * out[j];
    b[i] = -sum;
  }
  if (lu_solve(nx, ud->J, b)) return -1;
  for (i = nd; i < nx; ++i) out[i] = b[i];
  return all_finite(out, nx, NULL) ? 0 : -1;
}

/* One point of gs_eval's GS_EVAL_DAE / GS_EVAL_DAE_JAC: the model as the ODE of its
 * differential states x_d, x_d' = f_d(t, x_d), with the algebraic variables z = h(t, x_d)
 * solved for in the mode m (index 1).  want_jac = 0: out = [y (nx, consistent: [x_d; z]);
 * f_d (nd)]; want_jac = 1: out = [d f_d / d x_d; d h / d x_d] (nx x nd, column-major) by
 * the implicit function theorem, [F_y'(:, d) | F_y(:, z)] [df_d/dx_d; dh/dx_d] = -F_y(:, d).
 * Explicit models: [x; f] and d f / d x; implicit ones without algebraic variables: the
 * derivative solved for (eval_xdot). */
int eval_dae_point(gs_ud* ud, double t, const double* x, const double* m, double* out, int want_jac) {
  int nx = ud->nx, nd = ud->nd, i, j;
  const double* y = x;
  int* piv;
  if (!ud->implicit) {
    if (want_jac) return eval_jac(ud, t, x, m, out);
    memcpy(out, x, sizeof(double) * (size_t)nx);
    return eval_rhs(ud, t, x, m, out + nx);
  }
  memset(ud->f2, 0, sizeof(double) * (size_t)nx);
  if (eval_xdot(ud, t, x, m, ud->f2, ud->f3)) return -1;
  if (ud->nalg > 0) y = ud->xs;
  if (!want_jac) {
    memcpy(out, y, sizeof(double) * (size_t)nx);
    memcpy(out + nx, ud->f3, sizeof(double) * (size_t)nd);
    return 0;
  }
  memcpy(ud->f2, y, sizeof(double) * (size_t)nx);
  if (dae_matrix(ud, t, ud->f2, ud->f3, m)) return -1;
  piv = (int*)malloc(sizeof(int) * (size_t)nx);
  if (!piv) return -1;
  if (lu_factor(nx, ud->J, piv)) {
    free(piv);
    return -1;
  }
  for (j = 0; j < nd; ++j) {
    double* col = out + (size_t)j * nx;
    for (i = 0; i < nx; ++i) col[i] = -ud->J2[(size_t)j * nx + i];
    lu_apply(nx, ud->J, piv, col);
  }
  free(piv);
  return all_finite(out, nx * nd, NULL) ? 0 : -1;
}

/* --------------------------------------------------------------------------
 * SUNDIALS callbacks
 * -------------------------------------------------------------------------- */
/* d f / d p times the sensitivity directions, added to the S columns of yd:
 * dS_s += Fp D(:,s). */
static int sens_forcing(gs_ud* ud, double t, const double* yv, double* yd) {
  const double* in[4];
  int nx = ud->nx, np = ud->np, s, k, i;
  double* dS = yd + sens_offset(ud);
  in[0] = &t;
  in[1] = yv;
  in[2] = ud->p;
  in[3] = ud->nm ? ud->m : ud->dummy;
  if (gs_call(ud, &ud->jacp, in, 4, ud->Fp)) return -1;
  for (s = 0; s < ud->ns; ++s) {
    double* col = dS + (size_t)s * nx;
    const double* d = ud->sdir + (size_t)s * np;
    for (k = 0; k < np; ++k) {
      const double* fk = ud->Fp + (size_t)k * nx;
      if (d[k] == 0.0) continue;
      for (i = 0; i < nx; ++i) col[i] += fk[i] * d[k];
    }
  }
  return 0;
}

/* Phi' = J Phi and S' = J S + Fp D (Phi, then S, column-major after the
 * state: nvc columns in all).  With a sparse generated Jacobian the product
 * runs over its nonzeros only: O(nnz n) instead of O(n^3) per evaluation. */
static int variational_rhs(gs_ud* ud, double t, const double* yv, double* yd) {
  const gs_fn* fn = &ud->jac;
  const double* Phi = yv + ud->nx;
  double* dPhi = yd + ud->nx;
  const double* in[4];
  int nx = ud->nx, nvc = ud->nvc, c, k, i;
  if (fn->dense) {
    if (eval_jac(ud, t, yv, ud->m, ud->J)) return -1;
    for (c = 0; c < nvc; ++c) {
      double* dcol = dPhi + (size_t)c * nx;
      const double* pcol = Phi + (size_t)c * nx;
      for (i = 0; i < nx; ++i) dcol[i] = 0.0;
      for (k = 0; k < nx; ++k) {
        double pk = pcol[k];
        const double* Jk = ud->J + (size_t)k * nx;
        if (pk == 0.0) continue;
        for (i = 0; i < nx; ++i) dcol[i] += Jk[i] * pk;
      }
    }
    return ud->ns ? sens_forcing(ud, t, yv, yd) : 0;
  }
  in[0] = &t;
  in[1] = yv;
  in[2] = ud->np ? ud->p : ud->dummy;
  in[3] = ud->nm ? ud->m : ud->dummy;
  for (i = 0; i < 4; ++i) ud->arg[i] = in[i];
  ud->resp[0] = ud->nzbuf;
  if (fn->f(ud->arg, ud->resp, ud->iw, ud->w, 0) != 0) return -1;
  memset(dPhi, 0, sizeof(double) * (size_t)nx * (size_t)nvc);
  for (c = 0; c < nvc; ++c) {
    double* dcol = dPhi + (size_t)c * nx;
    const double* pcol = Phi + (size_t)c * nx;
    for (k = 0; k < nx; ++k) {
      double pk = pcol[k];
      casadi_int q;
      if (pk == 0.0) continue;
      for (q = fn->colind[k]; q < fn->colind[k + 1]; ++q) dcol[fn->row[q]] += ud->nzbuf[q] * pk;
    }
  }
  return ud->ns ? sens_forcing(ud, t, yv, yd) : 0;
}

int cv_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user_data) {
  gs_ud* ud = (gs_ud*)user_data;
  const double* yv = N_VGetArrayPointer(y);
  double* yd = N_VGetArrayPointer(ydot);
  int nx = ud->nx, bad = 0;
  if (poll_interrupt(ud)) return -1; /* unrecoverable: the solver returns at once */
  if (eval_rhs(ud, t, yv, ud->m, yd)) {
    record_nonfinite(ud, t, "gs_rhs (evaluation failed)", 0, yv);
    return 1;
  }
  if (ud->nvc && variational_rhs(ud, t, yv, yd)) {
    record_nonfinite(ud, t, "gs_jac (evaluation failed)", 0, yv);
    return 1;
  }
  if (!all_finite(yd, ud->nA, &bad)) {
    record_nonfinite(ud, t, bad < nx ? "the right-hand side (gs_rhs)" : "the variational equations", bad, yv);
    return 1;
  }
  return 0;
}

int cv_jac(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix Jm, void* user_data, N_Vector t1, N_Vector t2,
                  N_Vector t3) {
  gs_ud* ud = (gs_ud*)user_data;
  const double* yv = N_VGetArrayPointer(y);
  double* A = SUNDenseMatrix_Data(Jm);
  int nx = ud->nx, bad = 0;
  (void)fy;
  (void)t1;
  (void)t2;
  (void)t3;
  if (eval_jac(ud, t, yv, ud->m, ud->J) || !all_finite(ud->J, nx * nx, &bad)) {
    record_nonfinite(ud, t, "the Jacobian (gs_jac)", bad, yv);
    return 1;
  }
  if (!ud->nvc) {
    memcpy(A, ud->J, sizeof(double) * (size_t)(nx * nx));
  } else if (!ud->blockdiag) {
    /* dense (n + n^2)^2 matrix: blockdiag(J, ..., J), the terms d(J Phi)/dx
     * left out (modified Newton) */
    int nA = ud->nA, b, c;
    memset(A, 0, sizeof(double) * (size_t)nA * (size_t)nA);
    for (b = 0; b <= ud->nvc; ++b) {
      int off = b * nx;
      for (c = 0; c < nx; ++c)
        memcpy(A + (size_t)(off + c) * nA + off, ud->J + (size_t)c * nx, sizeof(double) * (size_t)nx);
    }
  } else {
    /* the (n + n^2) x n matrix of the block-diagonal solver (bdls_*): J in
     * its top n x n block, the rest zero (CVODE zeroes it before the call) */
    int nA = ud->nA, c;
    for (c = 0; c < nx; ++c) memcpy(A + (size_t)c * nA, ud->J + (size_t)c * nx, sizeof(double) * (size_t)nx);
  }
  return 0;
}

int cv_root(sunrealtype t, N_Vector y, sunrealtype* gout, void* user_data) {
  gs_ud* ud = (gs_ud*)user_data;
  const double* yv = N_VGetArrayPointer(y);
  int bad = 0;
  if (eval_swfn(ud, &ud->sw, t, yv, gout) || !all_finite(gout, ud->nsw, &bad)) {
    record_nonfinite(ud, t, "the switching functions (gs_sw)", bad, yv);
    return -1;
  }
  return 0;
}

/* Variational equations of the DAE F(t, y, y') = 0 on IDA: for each of the nd
 * differential initial directions k, the block S_k (= d y / d y_d0(k), length nx)
 * obeys F_y S_k + F_y' S_k' = 0 (the algebraic rows of S_k are algebraic again); the
 * sensitivity of parameter direction s (blocks after the monodromy's) obeys
 * F_y S_s + F_y' S_s' + F_p D(:, s) = 0 (ida_res_p).
 * F_y = gs_resjac(cj=0), F_y' = gs_resjac(1) - gs_resjac(0); explicit models run
 * through IDA have F = y' - f: F_y = -J, F_y' = I. */
static int ida_variational_res(gs_ud* ud, double t, const double* yv, const double* ypv, double* rv) {
  int nx = ud->nx, nphi = ud->mono * ud->nd, k, c, i;
  double* Fy = ud->J;
  double* Fyp = ud->J2;
  const double* ypf = ypv; /* the y' at which the derivatives of F are taken */
  if (ud->ns && ud->implicit) {
    /* With sensitivities the derivatives of F are taken at (y, y'(y)), the derivative
     * solved for at the iterate y (eval_xdot, from IDA's y'), not at IDA's own y' = y'_pred
     * + cj (y - y_pred): F_p may depend on y' (an inertia parameter: F_p = v'), and through
     * IDA's y' every sensitivity residual would depend on the state's correction times cj,
     * a coupling the block-diagonal Newton matrix leaves out (IDAS's simultaneous corrector
     * has the same matrix): with it the Newton iteration diverged and the steps collapsed
     * (d/dJ_L on models/spur_pair_coupled_load.toml: 81 000 steps in 0.1 forcing periods,
     * then IDA_CONV_FAIL).  At convergence both agree to the corrector's tolerance. */
    if (eval_xdot(ud, t, yv, ud->m, ypv, ud->ypc)) return -1;
    for (i = ud->nd; i < nx; ++i) ud->ypc[i] = ypv[i];
    ypf = ud->ypc;
  }
  if (ud->implicit) {
    if (eval_resjac(ud, t, yv, ypf, ud->m, 1.0, Fyp) || eval_resjac(ud, t, yv, ypf, ud->m, 0.0, Fy)) return -1;
    for (i = 0; i < nx * nx; ++i) Fyp[i] -= Fy[i];
  } else {
    if (eval_jac(ud, t, yv, ud->m, Fy)) return -1;
    for (i = 0; i < nx * nx; ++i) Fy[i] = -Fy[i];
  }
  if (ud->ns && ida_res_p(ud, t, yv, ypf)) return -1;
  for (k = 0; k < ud->nvc; ++k) {
    const double* Sk = yv + (size_t)(k + 1) * nx;
    const double* Spk = ypv + (size_t)(k + 1) * nx;
    double* rk = rv + (size_t)(k + 1) * nx;
    for (i = 0; i < nx; ++i) rk[i] = ud->implicit ? 0.0 : Spk[i];
    for (c = 0; c < nx; ++c) {
      double s = Sk[c], sp = Spk[c];
      const double* col = Fy + (size_t)c * nx;
      const double* colp = Fyp + (size_t)c * nx;
      if (s != 0.0)
        for (i = 0; i < nx; ++i) rk[i] += col[i] * s;
      if (ud->implicit && sp != 0.0)
        for (i = 0; i < nx; ++i) rk[i] += colp[i] * sp;
    }
    if (k >= nphi) add_res_p(ud, k - nphi, rk);
  }
  return all_finite(rv, ud->nA, NULL) ? 0 : -1;
}

int ida_res(sunrealtype t, N_Vector y, N_Vector yp, N_Vector r, void* user_data) {
  gs_ud* ud = (gs_ud*)user_data;
  const double* yv = N_VGetArrayPointer(y);
  const double* ypv = N_VGetArrayPointer(yp);
  double* rv = N_VGetArrayPointer(r);
  int i, bad = 0;
  if (poll_interrupt(ud)) return -1;
  if (ud->implicit) {
    if (eval_res(ud, t, yv, ypv, ud->m, rv)) {
      record_nonfinite(ud, t, "gs_res (evaluation failed)", 0, yv);
      return 1;
    }
  } else {
    if (eval_rhs(ud, t, yv, ud->m, rv)) {
      record_nonfinite(ud, t, "gs_rhs (evaluation failed)", 0, yv);
      return 1;
    }
    for (i = 0; i < ud->nx; ++i) rv[i] = ypv[i] - rv[i];
  }
  if (!all_finite(rv, ud->nx, &bad)) {
    record_nonfinite(ud, t, ud->implicit ? "the residual (gs_res)" : "the right-hand side (gs_rhs)", bad, yv);
    return 1;
  }
  if (ud->nvc && ida_variational_res(ud, t, yv, ypv, rv)) {
    record_nonfinite(ud, t, ud->ns ? "the variational residual (gs_resjac, gs_resp)" : "the variational residual (gs_resjac)", 0, yv);
    return 1;
  }
  return 0;
}

/* With the variational equations the iteration matrix is approximated by
 * blockdiag(F_y + cj F_y', ...) (the terms d(F_y S)/dy left out, as for CVODE).
 * On entry the nx x nx matrix is packed at the start of A (as written for the
 * state alone, leading dimension nx); spread it to leading dimension nA: the
 * block-diagonal solver reads the top block of the nA x nx matrix, the dense
 * solver gets every diagonal block of the nA x nA matrix. */
static void ida_jac_blocks(gs_ud* ud, double* A) {
  int nx = ud->nx, nA = ud->nA, c, b;
  memcpy(ud->J2, A, sizeof(double) * (size_t)nx * nx);
  if (ud->blockdiag) {
    memset(A, 0, sizeof(double) * (size_t)nA * nx);
    for (c = 0; c < nx; ++c) memcpy(A + (size_t)c * nA, ud->J2 + (size_t)c * nx, sizeof(double) * (size_t)nx);
  } else {
    memset(A, 0, sizeof(double) * (size_t)nA * nA);
    for (b = 0; b * nx < nA; ++b)
      for (c = 0; c < nx; ++c)
        memcpy(A + (size_t)(b * nx + c) * nA + (size_t)b * nx, ud->J2 + (size_t)c * nx, sizeof(double) * (size_t)nx);
  }
}

int ida_jac(sunrealtype t, sunrealtype cj, N_Vector y, N_Vector yp, N_Vector r, SUNMatrix Jm,
                   void* user_data, N_Vector t1, N_Vector t2, N_Vector t3) {
  gs_ud* ud = (gs_ud*)user_data;
  const double* yv = N_VGetArrayPointer(y);
  const double* ypv = N_VGetArrayPointer(yp);
  double* A = SUNDenseMatrix_Data(Jm);
  int nx = ud->nx, i, bad = 0, rc;
  (void)r;
  (void)t1;
  (void)t2;
  (void)t3;
  if (ud->implicit) {
    rc = eval_resjac(ud, t, yv, ypv, ud->m, cj, A);
  } else {
    rc = eval_jac(ud, t, yv, ud->m, A);
    if (!rc) {
      for (i = 0; i < nx * nx; ++i) A[i] = -A[i];
      for (i = 0; i < nx; ++i) A[i * nx + i] += cj;
    }
  }
  if (rc || !all_finite(A, nx * nx, &bad)) {
    record_nonfinite(ud, t, ud->implicit ? "the residual Jacobian (gs_resjac)" : "the Jacobian (gs_jac)", bad, yv);
    return 1;
  }
  if (ud->nvc) ida_jac_blocks(ud, A);
  return 0;
}

int ida_root(sunrealtype t, N_Vector y, N_Vector yp, sunrealtype* gout, void* user_data) {
  (void)yp;
  return cv_root(t, y, gout, user_data);
}

void sun_err_handler(int line, const char* func, const char* file, const char* msg, SUNErrCode err_code,
                            void* err_user_data, SUNContext sunctx) {
  gs_ud* ud = (gs_ud*)err_user_data;
  (void)line;
  (void)file;
  (void)err_code;
  (void)sunctx;
  if (!ud) return;
  snprintf(ud->sunmsg, sizeof(ud->sunmsg), "%s: %s", func ? func : "?", msg ? msg : "(no message)");
}

static void slv_counters(const gs_solver* S, long* st, long* rhs, long* jac, long* ge) {
  *st = *rhs = *jac = *ge = 0;
  if (!S->mem) return;
  if (S->ida) {
    IDAGetNumSteps(S->mem, st);
    IDAGetNumResEvals(S->mem, rhs);
    IDAGetNumJacEvals(S->mem, jac);
    IDAGetNumGEvals(S->mem, ge);
  } else {
    CVodeGetNumSteps(S->mem, st);
    CVodeGetNumRhsEvals(S->mem, rhs);
    CVodeGetNumJacEvals(S->mem, jac);
    CVodeGetNumGEvals(S->mem, ge);
  }
}

/* SUNDIALS counters restart at every ReInit: fold them into the totals. */
void slv_accumulate(gs_solver* S) {
  long st, rhs, jac, ge;
  slv_counters(S, &st, &rhs, &jac, &ge);
  S->acc_steps += st;
  S->acc_rhs += rhs;
  S->acc_jac += jac;
  S->acc_g += ge;
}

long slv_total_steps(const gs_solver* S) {
  long st, rhs, jac, ge;
  slv_counters(S, &st, &rhs, &jac, &ge);
  return S->acc_steps + st;
}

/* Name of a return flag (the SUNDIALS function returns a malloc'ed string
 * that the caller must free). */
const char* slv_flagname(gs_solver* S, int flag) {
  char* s = S->ida ? IDAGetReturnFlagName(flag) : CVodeGetReturnFlagName(flag);
  snprintf(S->flagname, sizeof(S->flagname), "%s", s ? s : "?");
  free(s);
  return S->flagname;
}
