/*
 * gs_correct.c -- part of the gearsym driver (gs_driver.c; shared declarations in
 * gs_internal.h): the continuation's pseudo-arclength corrector (gs_correct_ws).
 */
#include "gs_internal.h"

/* ================================================================ the continuation's corrector in C
 *
 * gs_correct_ws(): Newton on F(x, lambda) = phi(t0 + P(lambda); t0, x, p(lambda)) - x = 0 plus the
 * linear constraint row . (z / S) = target, z = (x, lambda): the pseudo-arclength corrector of
 * gearsym.analysis.corrector.Continuer.correct for single shooting, with the parameter entering
 * linearly, p(lambda) = p0 + (lambda - lambda0) D, the period P = periods T(p) from gs_period
 * and dP/dlambda = periods (dT/dp) . D from gs_periodp.  Each iterate is one run with the
 * monodromy and the parameter sensitivity (F_lambda, exact); the bordered step is solved in
 * the scaled variables by LU.  The damping (halving down to min_damping while the scaled
 * residual does not decrease, the last one taken anyway), the divergence test and the
 * convergence tests are those of the Python corrector; anything else -- a failed run, a
 * singular bordered matrix, the iteration budget, divergence -- gives up (outcome != 0) and
 * the caller corrects in Python from the same guess (and fails there the way it always did). */
static int correct_eval(gs_workspace* ws, gs_sim_args* a, gs_correct_args* c, const double* z, double* p,
                        double* atolv, double* R, double* M, double* Fl, double* r_scaled) {
  int nx = c->nx, np = ws->U.np, i, k, rc;
  double lam = z[nx], T, dT = 0.0, ps = 0.0;
  const double* in[1];
  double gbuf[GS_SHOOT_MAXN];
  for (k = 0; k < np; ++k) {
    p[k] = c->p0[k] + (lam - c->lam0) * c->D[k];
    if (c->D[k] != 0.0 && fabs(p[k]) > ps) ps = fabs(p[k]);
  }
  in[0] = np ? p : ws->U.dummy;
  if (gs_call(&ws->U, &ws->U.period, in, 1, &T) || !isfinite(T) || T <= 0.0) return GS_ERR_NONFINITE;
  if (np > GS_SHOOT_MAXN) return GS_ERR_INPUT;
  if (np) {
    if (gs_call(&ws->U, &ws->U.periodp, in, 1, gbuf)) return GS_ERR_NONFINITE;
    for (k = 0; k < np; ++k)
      if (c->D[k] != 0.0 && isfinite(gbuf[k])) dT += gbuf[k] * c->D[k];
  }
  c->dP = c->periods * dT;
  a->t_end = a->t0 + c->periods * T;
  a->max_step = T / 8.0;
  /* tolerances as System.flow sets them: state, monodromy columns, then atol / |p| for S */
  if (ps <= 0.0) ps = 1.0;
  for (i = 0; i < nx; ++i) atolv[(size_t)nx * (nx + 1) + i] = c->atol / ps;
  a->x0 = z;
  rc = gs_simulate_ws(ws, a);
  if (rc) return rc;
  *r_scaled = 0.0;
  for (i = 0; i < nx; ++i) {
    R[i] = a->x_final[i] - z[i];
    Fl[i] = a->sens_final[i]; /* one direction: row-major [nx][1] */
    if (!(fabs(R[i]) / c->Rs[i] <= *r_scaled)) *r_scaled = fabs(R[i]) / c->Rs[i];
  }
  memcpy(M, a->monodromy, sizeof(double) * (size_t)nx * (size_t)nx);
  return 0;
}

/* Per-column maximum, minimum, sum of squares and first argmax / argmin of the n - 1 samples
 * (end excluded) of the states, and the first argmin / argmax of the switching functions
 * and of the mesh deflections (gs_correct_args.col_stats / col_args); stats_ok stays 0 on a
 * non-finite sample. */
/* First argmin / argmax of column j of the row-major m x ncol array X; 1 on a non-finite entry. */
static int column_argext(const double* X, int m, int ncol, int j, int* imin, int* imax) {
  double vmin = X[j], vmax = vmin;
  int k;
  *imin = *imax = 0;
  for (k = 0; k < m; ++k) {
    double v = X[(size_t)k * ncol + j];
    if (!isfinite(v)) return 1;
    if (v < vmin) { vmin = v; *imin = k; }
    if (v > vmax) { vmax = v; *imax = k; }
  }
  return 0;
}

static void sample_stats(gs_correct_args* c, int n, int nx, int nsw, int nmesh) {
  int m = n - 1, j, k;
  c->stats_ok = 0;
  if (!c->col_stats || !c->col_args || m < 1 || (nsw && !c->G_samples) || (nmesh > 0 && !c->H_samples)) return;
  for (j = 0; j < nx; ++j) {
    double ss = 0.0;
    int imax, imin;
    if (column_argext(c->Y_samples, m, nx, j, &imin, &imax)) return;
    for (k = 0; k < m; ++k) ss += c->Y_samples[(size_t)k * nx + j] * c->Y_samples[(size_t)k * nx + j];
    c->col_stats[j] = c->Y_samples[(size_t)imax * nx + j];
    c->col_stats[nx + j] = c->Y_samples[(size_t)imin * nx + j];
    c->col_stats[2 * nx + j] = ss;
    c->col_args[j] = imax;
    c->col_args[nx + j] = imin;
  }
  for (j = 0; j < nsw; ++j)
    if (column_argext(c->G_samples, m, nsw, j, &c->col_args[2 * nx + j], &c->col_args[2 * nx + nsw + j])) return;
  for (j = 0; j < nmesh; ++j)
    if (column_argext(c->H_samples, m, nmesh, j, &c->col_args[2 * nx + 2 * nsw + j],
                      &c->col_args[2 * nx + 2 * nsw + nmesh + j]))
      return;
  c->stats_ok = 1;
}

/* The samples of the corrected orbit z (see gs_correct_args.n_samples): one run without the
 * variational equations, as System.flow(x, t0, t0 + P, p, monodromy=False, n_samples=n) makes
 * it, then the switching functions and mesh deflections at the samples.  The run description,
 * event log and final state of `a` are restored afterwards.  Returns 1 on success. */
static int correct_samples(gs_workspace* ws, gs_sim_args* a, gs_correct_args* c, const double* z, double* p) {
  int nx = c->nx, n = c->n_samples, np = ws->U.np, nsw = ws->U.nsw, k, ok = 0, rc;
  int n_keep = a->n_events < a->max_events_out ? a->n_events : a->max_events_out;
  double lam = z[nx], T, step;
  const double* in[1];
  char msg[256];
  gs_sim_args saved;
  double *ev = NULL, *xf = NULL;
  int* evi = NULL;
  if (n < 2 || !c->t_samples || !c->Y_samples || n_keep < 0) return 0;
  for (k = 0; k < np; ++k) p[k] = c->p0[k] + (lam - c->lam0) * c->D[k];
  in[0] = np ? p : ws->U.dummy;
  if (gs_call(&ws->U, &ws->U.period, in, 1, &T) || !isfinite(T) || T <= 0.0) return 0;
  ev = (double*)malloc(sizeof(double) * (2 * (size_t)n_keep + 1));
  evi = (int*)malloc(sizeof(int) * (2 * (size_t)n_keep + 1));
  xf = (double*)malloc(sizeof(double) * ((size_t)nx + (size_t)nsw + 1));
  if (!ev || !evi || !xf) goto done;
  memcpy(&saved, a, sizeof(saved));
  if (n_keep) {
    memcpy(ev, a->ev_t, sizeof(double) * (size_t)n_keep);
    memcpy(ev + n_keep, a->ev_speed, sizeof(double) * (size_t)n_keep);
    memcpy(evi, a->ev_surface, sizeof(int) * (size_t)n_keep);
    memcpy(evi + n_keep, a->ev_dir, sizeof(int) * (size_t)n_keep);
  }
  memcpy(xf, a->x_final, sizeof(double) * (size_t)nx);
  if (nsw && a->sigma_final) memcpy(xf + nx, a->sigma_final, sizeof(double) * (size_t)nsw);
  /* the grid of numpy.linspace(t0, t0 + P, n) */
  a->t_end = a->t0 + c->periods * T;
  step = (a->t_end - a->t0) / (double)(n - 1);
  for (k = 0; k < n; ++k) c->t_samples[k] = (double)k * step + a->t0;
  c->t_samples[n - 1] = a->t_end;
  a->x0 = z;
  a->p = np ? p : NULL;
  a->max_step = T / 8.0;
  a->want_monodromy = 0;
  a->n_sens = 0;
  a->sens_dir = a->sens_dt0 = a->sens_dt1 = NULL;
  a->sens_final = a->sens_out = NULL;
  a->atol_vec = NULL;
  a->atol = c->atol;
  a->n_out = n;
  a->t_out = c->t_samples;
  a->y_out = c->Y_samples;
  rc = gs_simulate_ws(ws, a);
  if (rc == 0 && a->n_events <= a->max_events_out) {
    ok = 1;
    if (nsw && c->G_samples && gs_eval(ws, GS_EVAL_SW, n, c->t_samples, c->Y_samples, a->p, NULL, c->G_samples, msg,
                                       (int)sizeof(msg)))
      ok = 0;
    if (ok && ws->n_mesh_fn > 0 && c->H_samples &&
        gs_eval(ws, GS_EVAL_MESH, n, c->t_samples, c->Y_samples, a->p, NULL, c->H_samples, msg, (int)sizeof(msg)))
      ok = 0;
  }
  if (ok) sample_stats(c, n, nx, nsw, c->H_samples ? ws->n_mesh_fn : 0);
  rc = (rc == GS_ERR_INTERRUPTED);
  memcpy(a, &saved, sizeof(saved));
  if (rc) {
    a->status = GS_ERR_INTERRUPTED;
    ok = -1;
  }
  if (n_keep) {
    memcpy(a->ev_t, ev, sizeof(double) * (size_t)n_keep);
    memcpy(a->ev_speed, ev + n_keep, sizeof(double) * (size_t)n_keep);
    memcpy(a->ev_surface, evi, sizeof(int) * (size_t)n_keep);
    memcpy(a->ev_dir, evi + n_keep, sizeof(int) * (size_t)n_keep);
  }
  memcpy(a->x_final, xf, sizeof(double) * (size_t)nx);
  if (nsw && a->sigma_final) memcpy(a->sigma_final, xf + nx, sizeof(double) * (size_t)nsw);
done:
  free(ev);
  free(evi);
  free(xf);
  return ok;
}

/* The anchored system of a bordered one: the nx rows of A (row-major, n1 = nx + 1 columns) and
 * their right-hand side b, the anchor rows with right-hand side 0, then A's last row and b's
 * last entry (Continuer.correct / Continuer.tangent stack them in this order). */
static void anchored_system(const gs_correct_args* c, int nx, int na, const double* A, const double* b, double* Aa,
                            double* ba) {
  int n1 = nx + 1, i;
  memcpy(Aa, A, sizeof(double) * (size_t)nx * n1);
  memcpy(Aa + (size_t)nx * n1, c->anchor, sizeof(double) * (size_t)na * n1);
  memcpy(Aa + (size_t)(nx + na) * n1, A + (size_t)nx * n1, sizeof(double) * (size_t)n1);
  for (i = 0; i < nx; ++i) ba[i] = b[i];
  for (i = 0; i < na; ++i) ba[nx + i] = 0.0;
  ba[nx + na] = b[nx];
}

int gs_correct_ws(gs_workspace* ws, gs_sim_args* a, gs_correct_args* c) {
  int nx, n1, i, j, rc = 0, it = 0, piv[GS_SHOOT_MAXN + 1], na, ma;
  double *p = NULL, *atolv = NULL, *A = NULL, *M = NULL, *zt = NULL, *Aa = NULL, *ba = NULL;
  double R[GS_SHOOT_MAXN], Fl[GS_SHOOT_MAXN], Rt[GS_SHOOT_MAXN], Flt[GS_SHOOT_MAXN], dw[GS_SHOOT_MAXN + 1];
  double r, r_prev = HUGE_VAL, size = HUGE_VAL, zero = 0.0;
  if (!a || !c) return GS_ERR_INPUT;
  c->iterations = 0;
  c->n_runs = 0;
  c->samples_ok = 0;
  c->stats_ok = 0;
  c->tangent_ok = 0;
  c->period_out = NAN;
  c->mult.ok = 0;
  c->outcome = GS_SHOOT_GAVE_UP_OTHER;
  if (!ws) return set_err(a, GS_ERR_INPUT, "no workspace");
  if (!ws->ready && (rc = ws_model_setup(ws, a)) != 0) return rc;
  nx = ws->U.nx;
  n1 = nx + 1;
  if (c->nx != nx || nx > GS_SHOOT_MAXN || ws->U.np > GS_SHOOT_MAXN || ws->U.nalg > 0 || !ws->U.period.present ||
      !ws->U.periodp.present || !a->monodromy || !a->want_monodromy || a->n_sens != 1 || !a->sens_final ||
      !c->z || !c->row || !c->S || !c->Rs || !c->p0 || !c->D || !c->R_out || !c->M_out || !c->Flam_out)
    return set_err(a, GS_ERR_INPUT, "gs_correct_ws: needs an explicit model with gs_period and gs_periodp, the "
                   "monodromy, one sensitivity direction and the buffers (nx <= %d)", GS_SHOOT_MAXN);
  na = c->n_anchor > 0 ? c->n_anchor : 0;
  ma = nx + na + 1; /* rows of the anchored system */
  if (na && (na > nx || !c->anchor || !c->lapack_dgelsd))
    return set_err(a, GS_ERR_INPUT, "gs_correct_ws: anchor rows need 1 <= n_anchor <= nx, the rows and dgelsd");
  p = (double*)malloc(sizeof(double) * (size_t)(ws->U.np > 0 ? ws->U.np : 1));
  atolv = (double*)malloc(sizeof(double) * (size_t)nx * (size_t)(nx + 2));
  A = (double*)malloc(sizeof(double) * (size_t)n1 * (size_t)n1);
  M = (double*)malloc(sizeof(double) * (size_t)nx * (size_t)nx * 2);
  zt = (double*)malloc(sizeof(double) * (size_t)n1 * 2);
  if (na) {
    Aa = (double*)malloc(sizeof(double) * (size_t)ma * (size_t)n1);
    ba = (double*)malloc(sizeof(double) * (size_t)ma);
  }
  if (!p || !atolv || !A || !M || !zt || (na && (!Aa || !ba))) {
    rc = set_err(a, GS_ERR_INPUT, "out of memory");
    goto done;
  }
  for (i = 0; i < nx * (nx + 1); ++i) atolv[i] = c->atol;
  a->atol_vec = atolv;
  a->p = ws->U.np ? p : NULL;
  a->sens_dir = c->D;
  a->sens_dt0 = &zero;
  a->sens_dt1 = &c->dP;
  a->n_out = 0;
  {
    double* z = zt;          /* the current iterate */
    double* zn = zt + n1;    /* a trial */
    double* Mt = M + (size_t)nx * nx;
    memcpy(z, c->z, sizeof(double) * (size_t)n1);
    rc = correct_eval(ws, a, c, z, p, atolv, R, M, Fl, &r);
    c->n_runs++;
    if (rc) {
      if (rc == GS_ERR_INTERRUPTED) goto done;
      rc = 0;
      a->status = GS_OK;
      c->outcome = GS_SHOOT_GAVE_UP_RUN;
      goto done;
    }
    for (;;) {
      double cval = -c->target;
      if (a->n_events > a->max_events_out) { c->outcome = GS_SHOOT_GAVE_UP_EVENTS; break; }
      for (j = 0; j < n1; ++j) cval += c->row[j] * z[j] / c->S[j];
      /* converged(ev, size, damping) */
      if ((r <= c->tol || (size <= c->tol && r <= 100.0 * c->tol)) && fabs(cval) <= 1e-9) {
        c->outcome = GS_SHOOT_CONVERGED;
        break;
      }
      if (it >= c->max_iter) { c->outcome = GS_SHOOT_GAVE_UP_ITER; break; }
      if (!isfinite(r)) { c->outcome = GS_SHOOT_GAVE_UP_OTHER; break; }
      if (it >= 2 && r > 0.9 * r_prev && r > 100.0 * c->tol) { c->outcome = GS_SHOOT_GAVE_UP_DECREASE; break; }
      /* the bordered step in scaled variables */
      for (i = 0; i < nx; ++i) {
        for (j = 0; j < nx; ++j)
          A[(size_t)i * n1 + j] = (M[(size_t)i * nx + j] - (i == j ? 1.0 : 0.0)) * c->S[j] / c->Rs[i];
        A[(size_t)i * n1 + nx] = Fl[i] * c->S[nx] / c->Rs[i];
        dw[i] = -R[i] / c->Rs[i];
      }
      for (j = 0; j < n1; ++j) A[(size_t)nx * n1 + j] = c->row[j];
      dw[nx] = -cval;
      if (na) { /* rigid-body modes: keep their coordinates where they are (least squares) */
        anchored_system(c, nx, na, A, dw, Aa, ba);
        if (lapack_lstsq(c->lapack_dgelsd, ma, n1, Aa, ba, dw)) { c->outcome = GS_SHOOT_GAVE_UP_SINGULAR; break; }
      } else {
        if (shoot_lu(n1, A, piv, 0.0)) { c->outcome = GS_SHOOT_GAVE_UP_SINGULAR; break; }
        shoot_lu_solve(n1, A, piv, dw);
      }
      size = 0.0;
      for (j = 0; j < n1; ++j) {
        if (!isfinite(dw[j])) size = HUGE_VAL;
        else if (fabs(dw[j]) > size) size = fabs(dw[j]);
      }
      if (!isfinite(size)) { c->outcome = GS_SHOOT_GAVE_UP_SINGULAR; break; }
      /* converged(ev, size, 0): no further integration (the point itself is returned) */
      if ((r <= c->tol || (size <= c->tol && r <= 100.0 * c->tol)) && fabs(cval) <= 1e-9) {
        c->outcome = GS_SHOOT_CONVERGED;
        break;
      }
      it++;
      r_prev = r;
      {
        double damping = 1.0, rn = HUGE_VAL;
        int accepted = 0;
        while (damping >= c->min_damping) {
          int last = damping * 0.5 < c->min_damping;
          for (j = 0; j < n1; ++j) zn[j] = z[j] + damping * dw[j] * c->S[j];
          rc = correct_eval(ws, a, c, zn, p, atolv, Rt, Mt, Flt, &rn);
          c->n_runs++;
          if (rc) {
            if (rc == GS_ERR_INTERRUPTED) goto done;
            rc = 0;
            a->status = GS_OK;
            a->errmsg[0] = '\0';
            if (last) break; /* Python raises here: give up */
            rn = NAN;
          } else if (isfinite(rn) && (rn < r || rn <= c->tol || last)) {
            accepted = 1;
            break;
          }
          damping *= 0.5;
        }
        if (!accepted) { c->outcome = GS_SHOOT_GAVE_UP_RUN; break; }
        memcpy(z, zn, sizeof(double) * (size_t)n1);
        memcpy(R, Rt, sizeof(double) * (size_t)nx);
        memcpy(Fl, Flt, sizeof(double) * (size_t)nx);
        memcpy(M, Mt, sizeof(double) * (size_t)nx * nx);
        r = rn;
      }
    }
    c->iterations = it;
    c->residual = r;
    if (c->outcome == GS_SHOOT_CONVERGED) {
      /* the forcing period at z (as correct_eval evaluates it) */
      const double* in[1];
      double T;
      for (j = 0; j < ws->U.np; ++j) p[j] = c->p0[j] + (z[nx] - c->lam0) * c->D[j];
      in[0] = ws->U.np ? p : ws->U.dummy;
      if (gs_call(&ws->U, &ws->U.period, in, 1, &T) == 0 && isfinite(T)) c->period_out = T;
      lapack_multipliers(&c->mult, nx, M);
      if (c->t_ref && c->tangent_out) {
        /* Continuer.tangent: [J_s; t_ref] t = e_nx, J_s as the bordered step scales it */
        for (i = 0; i < nx; ++i) {
          for (j = 0; j < nx; ++j)
            A[(size_t)i * n1 + j] = (M[(size_t)i * nx + j] - (i == j ? 1.0 : 0.0)) * c->S[j] / c->Rs[i];
          A[(size_t)i * n1 + nx] = Fl[i] * c->S[nx] / c->Rs[i];
          dw[i] = 0.0;
        }
        for (j = 0; j < n1; ++j) A[(size_t)nx * n1 + j] = c->t_ref[j];
        dw[nx] = 1.0;
        if (na) anchored_system(c, nx, na, A, dw, Aa, ba);
        if (na ? lapack_lstsq(c->lapack_dgelsd, ma, n1, Aa, ba, dw) == 0 : shoot_lu(n1, A, piv, 0.0) == 0) {
          if (!na) shoot_lu_solve(n1, A, piv, dw);
          c->tangent_ok = 1;
          for (j = 0; j < n1; ++j) {
            if (!isfinite(dw[j])) c->tangent_ok = 0;
            c->tangent_out[j] = dw[j];
          }
        }
      }
    }
    c->samples_ok = 0;
    if (c->outcome == GS_SHOOT_CONVERGED && c->n_samples >= 2) {
      c->samples_ok = correct_samples(ws, a, c, z, p);
      if (c->samples_ok < 0) {
        c->samples_ok = 0;
        rc = GS_ERR_INTERRUPTED;
      }
    }
    memcpy(c->z, z, sizeof(double) * (size_t)n1);
    memcpy(c->R_out, R, sizeof(double) * (size_t)nx);
    memcpy(c->Flam_out, Fl, sizeof(double) * (size_t)nx);
    memcpy(c->M_out, M, sizeof(double) * (size_t)nx * nx);
  }
done:
  a->x0 = NULL;
  a->p = NULL;
  a->atol_vec = NULL;
  a->sens_dir = a->sens_dt0 = a->sens_dt1 = NULL;
  free(p);
  free(atolv);
  free(A);
  free(M);
  free(zt);
  free(Aa);
  free(ba);
  return rc;
}
