/*
 * gs_correct.c -- part of the gearsym driver (gs_driver.c; shared declarations in
 * gs_internal.h): the continuation's residual over the flow, evaluated for THE Newton
 * iteration's corrector (gs_newton.c) in the same C call (gs_correct_ws), and the corrected
 * point's samples, statistics and multipliers.
 */
#include "gs_internal.h"

/* ================================================================ the continuation's residual
 *
 * One evaluation at z = nw->z_eval = (u, lambda), u the differential states at the segment
 * starts: p(lambda) = p0 + (lambda - lam0) D, T from gs_period, P = periods T, d P / d lambda =
 * periods (dT/dp) . D from gs_periodp, s_i = t0 + P i / N; one run per segment from (u_i, y_i)
 * (a DAE's algebraic variables y_i: the last consistent values, updated from each run's end as
 * ShootingResidual._keep_z does) with the monodromy and the parameter sensitivity along D
 * (span derivatives dP i / N, dP (i + 1) / N); tolerances as System.flow sets them: the state's,
 * the same for the monodromy's columns, atol / max |p_k| (over the entries D moves) for the
 * sensitivity.  R_i = x(s_{i+1})[:nd] - u_{i+1}, F_u from the differential blocks (segment
 * Jacobian), F_lambda the sensitivity's differential rows.  Returns 0 (answered),
 * GS_HANDBACK_CALLER (a run failed or there is no period: the caller evaluates this request,
 * falling back on a finite-difference F_lambda where only the sensitivity failed),
 * GS_HANDBACK_EVENTS, or GS_ERR_INTERRUPTED. */
static int corrector_eval(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_corrector_flow* f, double* p,
                          double* atolv, double* x0) {
  int N = f->segments, nd = f->nd, nx = ws->U.nx, nalg = nx - nd, np = ws->U.np, nr = nw->nr, i, j, k, rc = 0,
      n_ev = 0;
  const double* z = nw->z_eval;
  double lam = z[nr], T, dT = 0.0, ps = 0.0, P, amin = HUGE_VAL, dt0, dt1;
  const double* in[1];
  double* gbuf = NULL;
  gs_sim_args keep;
  for (k = 0; k < np; ++k) {
    p[k] = f->p0[k] + (lam - f->lam0) * f->D[k];
    if (f->D[k] != 0.0 && fabs(p[k]) > ps) ps = fabs(p[k]);
  }
  in[0] = np ? p : ws->U.dummy;
  if (gs_call(&ws->U, &ws->U.period, in, 1, &T) || !isfinite(T) || T <= 0.0) return GS_HANDBACK_CALLER;
  if (np) {
    gbuf = (double*)malloc(sizeof(double) * (size_t)np);
    if (!gbuf || gs_call(&ws->U, &ws->U.periodp, in, 1, gbuf)) {
      free(gbuf);
      return GS_HANDBACK_CALLER;
    }
    for (k = 0; k < np; ++k)
      if (f->D[k] != 0.0 && isfinite(gbuf[k])) dT += gbuf[k] * f->D[k];
    free(gbuf);
  }
  f->dP = f->periods * dT;
  P = f->periods * T;
  if (ps <= 0.0) ps = 1.0;
  for (i = 0; i < nx; ++i) {
    if (f->atol[i] < amin) amin = f->atol[i];
    for (k = 0; k <= nd; ++k) atolv[(size_t)k * nx + i] = f->atol[i]; /* the state, then Phi's columns */
    atolv[(size_t)(nd + 1) * nx + i] = f->atol[i] / ps;                /* the sensitivity */
  }
  memcpy(&keep, a, sizeof(keep));
  a->p = np ? p : NULL;
  a->atol = amin;
  a->atol_vec = atolv;
  a->max_step = T / 8.0;
  a->n_out = 0;
  a->sens_dt0 = &dt0;
  a->sens_dt1 = &dt1;
  a->sens_dir = f->D;
  for (i = 0; i < N; ++i) {
    double* Mi = f->Ms + (size_t)i * nd * nd;
    int nxt = (i + 1) % N;
    a->t0 = N == 1 ? f->t0 : f->t0 + P * (double)i / (double)N;
    a->t_end = i + 1 == N ? f->t0 + P : f->t0 + P * (double)(i + 1) / (double)N;
    dt0 = f->dP * (double)i / (double)N;
    dt1 = f->dP * (double)(i + 1) / (double)N;
    memcpy(x0, z + (size_t)i * nd, sizeof(double) * (size_t)nd);
    if (nalg) memcpy(x0 + nd, f->zalg + (size_t)i * nalg, sizeof(double) * (size_t)nalg);
    if (f->ev_cap - n_ev < 1) {
      f->events_needed = 2 * f->ev_cap;
      rc = GS_HANDBACK_EVENTS;
      break;
    }
    a->x0 = x0;
    a->ev_t = f->ev_t + n_ev;
    a->ev_surface = f->ev_surface + n_ev;
    a->ev_dir = f->ev_dir + n_ev;
    a->ev_speed = f->ev_speed + n_ev;
    a->max_events_out = f->ev_cap - n_ev;
    rc = gs_simulate_ws(ws, a);
    f->n_runs++;
    if (rc == GS_ERR_INTERRUPTED) break;
    if (rc) { /* e.g. a grazing event: the sensitivity's event-time derivative is infinite */
      rc = GS_HANDBACK_CALLER;
      break;
    }
    if (a->n_events > a->max_events_out) {
      f->events_needed = n_ev + a->n_events > 2 * f->ev_cap ? n_ev + a->n_events : 2 * f->ev_cap;
      rc = GS_HANDBACK_EVENTS;
      break;
    }
    n_ev += a->n_events;
    if (nalg && all_finite(a->x_final, nx, NULL))
      memcpy(f->zalg + (size_t)nxt * nalg, a->x_final + nd, sizeof(double) * (size_t)nalg);
    for (j = 0; j < nd; ++j) {
      nw->R[(size_t)i * nd + j] = a->x_final[j] - z[(size_t)nxt * nd + j];
      nw->Flam[(size_t)i * nd + j] = a->sens_final[j]; /* one direction: row-major [nx][1] */
      for (k = 0; k < nd; ++k) Mi[(size_t)j * nd + k] = a->monodromy[(size_t)j * nx + k];
    }
  }
  keep.n_events = a->n_events;
  keep.t_reached = a->t_reached;
  memcpy(a, &keep, sizeof(keep));
  a->status = GS_OK;
  a->errmsg[0] = '\0';
  if (rc) return rc;
  /* F_u: the segment Jacobian (M_i in block (i, i), -I in block (i, i + 1), cyclically) */
  memset(nw->J, 0, sizeof(double) * (size_t)nr * nr);
  for (i = 0; i < N; ++i) {
    const double* Mi = f->Ms + (size_t)i * nd * nd;
    int col = ((i + 1) % N) * nd;
    for (j = 0; j < nd; ++j) {
      double* row = nw->J + (size_t)(i * nd + j) * nr;
      for (k = 0; k < nd; ++k) row[i * nd + k] = Mi[(size_t)j * nd + k];
      row[col + j] -= 1.0;
    }
  }
  nw->flam_given = 1;
  nw->eval_status = 0;
  nw->answered = 1;
  f->period = T;
  f->n_events = n_ev;
  f->n_evals++;
  f->last_c_eval = nw->n_evals;
  return 0;
}

/* Per-column maximum, minimum, sum of squares and first argmax / argmin of the n - 1 samples
 * (end excluded) of the states, and the first argmin / argmax of the switching functions
 * and of the mesh deflections (gs_corrector_flow.col_stats / col_args); stats_ok stays 0 on a
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

static void sample_stats(gs_corrector_flow* c, int n, int nx, int nsw, int nmesh) {
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

/* The samples of the corrected orbit from x0 (see gs_corrector_flow.n_samples): one run
 * without the variational equations, as System.flow(x, t0, t0 + P, p, monodromy=False,
 * n_samples=n) makes it, then the switching functions and mesh deflections at the samples.  The
 * run description of `a` is restored afterwards.  Returns 1 on success, 0 on a failure, -1
 * when interrupted. */
static int correct_samples(gs_workspace* ws, gs_sim_args* a, gs_corrector_flow* f, const double* x0, double lam,
                           double* p) {
  int nx = ws->U.nx, n = f->n_samples, np = ws->U.np, nsw = ws->U.nsw, k, ok = 0, rc;
  double T, step;
  const double* in[1];
  char msg[256];
  gs_sim_args saved;
  if (n < 2 || !f->t_samples || !f->Y_samples) return 0;
  for (k = 0; k < np; ++k) p[k] = f->p0[k] + (lam - f->lam0) * f->D[k];
  in[0] = np ? p : ws->U.dummy;
  if (gs_call(&ws->U, &ws->U.period, in, 1, &T) || !isfinite(T) || T <= 0.0) return 0;
  memcpy(&saved, a, sizeof(saved));
  /* the grid of numpy.linspace(t0, t0 + P, n) */
  a->t0 = f->t0;
  a->t_end = f->t0 + f->periods * T;
  step = (a->t_end - a->t0) / (double)(n - 1);
  for (k = 0; k < n; ++k) f->t_samples[k] = (double)k * step + a->t0;
  f->t_samples[n - 1] = a->t_end;
  a->x0 = x0;
  a->p = np ? p : NULL;
  a->max_step = T / 8.0;
  a->want_monodromy = 0;
  a->n_sens = 0;
  a->sens_dir = a->sens_dt0 = a->sens_dt1 = NULL;
  a->sens_final = a->sens_out = NULL;
  a->atol_vec = NULL;
  {
    int i;
    double amin = HUGE_VAL;
    for (i = 0; i < nx; ++i)
      if (f->atol[i] < amin) amin = f->atol[i];
    a->atol = amin;
  }
  a->n_out = n;
  a->t_out = f->t_samples;
  a->y_out = f->Y_samples;
  rc = gs_simulate_ws(ws, a);
  if (rc == 0 && a->n_events <= a->max_events_out) {
    ok = 1;
    if (nsw && f->G_samples && gs_eval(ws, GS_EVAL_SW, n, f->t_samples, f->Y_samples, a->p, NULL, f->G_samples, msg,
                                       (int)sizeof(msg)))
      ok = 0;
    if (ok && ws->n_mesh_fn > 0 && f->H_samples &&
        gs_eval(ws, GS_EVAL_MESH, n, f->t_samples, f->Y_samples, a->p, NULL, f->H_samples, msg, (int)sizeof(msg)))
      ok = 0;
  }
  if (ok) sample_stats(f, n, nx, nsw, f->H_samples ? ws->n_mesh_fn : 0);
  memcpy(a, &saved, sizeof(saved));
  a->status = GS_OK;
  a->errmsg[0] = '\0';
  return rc == GS_ERR_INTERRUPTED ? -1 : ok;
}

int gs_correct_ws(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_corrector_flow* f) {
  int nx, nd, np, rc = 0;
  double *p = NULL, *atolv = NULL, *x0 = NULL;
  if (!a || !nw || !f) return GS_ERR_INPUT;
  f->handback = GS_HANDBACK_NONE;
  f->samples_ok = 0;
  f->stats_ok = 0;
  f->mult.ok = 0;
  if (!ws) return set_err(a, GS_ERR_INPUT, "no workspace");
  if (!ws->ready && (rc = ws_model_setup(ws, a)) != 0) return rc;
  nx = ws->U.nx;
  nd = f->nd;
  np = ws->U.np;
  if (nw->kind != GS_NEWTON_CORRECTOR || nd != nx - ws->U.nalg || f->segments < 1 || nw->nr != f->segments * nd ||
      nw->n != nw->nr + 1 || !nw->work || !nw->z || !nw->z_eval || !nw->R || !nw->J || !nw->Flam ||
      !ws->U.period.present || !ws->U.periodp.present || !a->monodromy || !a->want_monodromy || a->n_sens != 1 ||
      !a->sens_final || !f->p0 || !f->D || !f->atol || !f->Ms || (ws->U.nalg && !f->zalg) || !f->ev_t ||
      !f->ev_surface || !f->ev_dir || !f->ev_speed || f->ev_cap < 1)
    return set_err(a, GS_ERR_INPUT, "gs_correct_ws: a corrector iteration of this model's differential states, a "
                   "model with gs_period and gs_periodp, the monodromy, one sensitivity direction and the buffers");
  p = (double*)malloc(sizeof(double) * (size_t)(np > 0 ? np : 1));
  atolv = (double*)malloc(sizeof(double) * (size_t)nx * (size_t)(nd + 2));
  x0 = (double*)malloc(sizeof(double) * (size_t)nx);
  if (!p || !atolv || !x0) {
    rc = set_err(a, GS_ERR_INPUT, "out of memory");
    goto done;
  }
  for (;;) {
    if (nw->request != GS_NEWTON_EVALUATE) break;
    if (!nw->answered) {
      rc = corrector_eval(ws, a, nw, f, p, atolv, x0);
      if (rc == GS_ERR_INTERRUPTED) {
        rc = set_err(a, rc, "interrupted");
        goto done;
      }
      if (rc) {
        f->handback = rc;
        rc = 0;
        goto done;
      }
    }
    gs_newton_next(nw);
  }
  /* the corrected point, when the C run evaluated it: one segment's multipliers and samples */
  if (nw->outcome == GS_NEWTON_CONVERGED && f->last_c_eval == nw->n_evals && f->segments == 1) {
    lapack_multipliers(&f->mult, nd, f->Ms);
    if (f->n_samples >= 2) {
      memcpy(x0, nw->z, sizeof(double) * (size_t)nd);
      if (nx > nd) memcpy(x0 + nd, f->zalg, sizeof(double) * (size_t)(nx - nd));
      f->samples_ok = correct_samples(ws, a, f, x0, nw->z[nw->nr], p);
      if (f->samples_ok < 0) {
        f->samples_ok = 0;
        rc = set_err(a, GS_ERR_INTERRUPTED, "interrupted");
      }
    }
  }
done:
  free(p);
  free(atolv);
  free(x0);
  return rc;
}
