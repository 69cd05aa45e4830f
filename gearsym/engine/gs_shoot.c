/*
 * gs_shoot.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * the shooting residual over the flow, evaluated for THE Newton iteration (gs_newton.c) in
 * the same C call (gs_shoot_ws), and a converged orbit's multipliers and isolation by LAPACK.
 */
#include "gs_internal.h"

/* The multipliers of the row-major n x n monodromy M and their tolerances into m (see
 * gs_multipliers in gs_driver.h): balance (dgebal, 'S'), the 2-norm of the balanced matrix
 * (dgesdd, singular values only), delta, the eigenvalues and left / right vectors (dgeev),
 * kappa_i = 1 / |y_i^H x_i| (a complex pair's vectors are the columns a +- i b), tol_i =
 * max(min(kappa_i delta, sqrt(delta max(1, |M|))), 16 eps).  Sets m->ok. */
void lapack_multipliers(gs_multipliers* m, int n, const double* M) {
  gs_dgebal_t dgebal = (gs_dgebal_t)m->lapack_dgebal;
  gs_dgesdd_t dgesdd = (gs_dgesdd_t)m->lapack_dgesdd;
  gs_dgeev_t dgeev = (gs_dgeev_t)m->lapack_dgeev;
  double *mu_re = m->mu_re, *mu_im = m->mu_im, *mu_tol = m->mu_tol;
  int i, j, k, info = 0, ilo, ihi, lda = n, one = 1, lwork, lw_sdd, rc = 1;
  size_t nn = (size_t)n * (size_t)n;
  double *A = NULL, *B = NULL, *vl = NULL, *vr = NULL, *work = NULL, *scale = NULL, *sv = NULL, *wr, *wi;
  double dummy = 0.0, q = 0.0, nM, delta, cap, eps = DBL_EPSILON;
  int* iwork = NULL;
  char job_s = 'S', job_n = 'N', job_v = 'V';
  m->ok = 0;
  if (n < 1 || !dgebal || !dgesdd || !dgeev || !mu_re || !mu_im || !mu_tol) return;
  for (i = 0; i < n * n; ++i)
    if (!isfinite(M[i])) return; /* floquet's "non-finite monodromy" verdict is Python's */
  A = (double*)malloc(sizeof(double) * nn * 4);
  scale = (double*)malloc(sizeof(double) * (size_t)n * 2);
  iwork = (int*)malloc(sizeof(int) * (size_t)n * 8);
  if (!A || !scale || !iwork) goto done;
  B = A + nn;
  vl = B + nn;
  vr = vl + nn;
  sv = scale + n;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) A[i + (size_t)j * n] = M[(size_t)i * n + j]; /* column-major */
  dgebal(&job_s, &n, A, &lda, &ilo, &ihi, scale, &info);
  if (info != 0) goto done;
  /* the 2-norm: the largest singular value of the balanced matrix */
  memcpy(B, A, sizeof(double) * nn);
  lwork = -1;
  dgesdd(&job_n, &n, &n, B, &lda, sv, &dummy, &one, &dummy, &one, &q, &lwork, iwork, &info);
  if (info != 0) goto done;
  lw_sdd = (int)q > 1 ? (int)q : 1;
  lwork = lw_sdd > 4 * n ? lw_sdd : 4 * n;
  work = (double*)malloc(sizeof(double) * (size_t)lwork);
  if (!work) goto done;
  dgesdd(&job_n, &n, &n, B, &lda, sv, &dummy, &one, &dummy, &one, work, &lw_sdd, iwork, &info);
  if (info != 0) goto done;
  nM = sv[0];
  delta = 100.0 * fmax(m->rtol, eps) * fmax(1.0, nM);
  /* eigenvalues and vectors of the balanced matrix (scipy's default workspace, 4 n) */
  memcpy(B, A, sizeof(double) * nn);
  wr = mu_re;
  wi = mu_im;
  lw_sdd = 4 * n;
  dgeev(&job_v, &job_v, &n, B, &lda, wr, wi, vl, &lda, vr, &lda, work, &lw_sdd, &info);
  if (info != 0) goto done;
  cap = sqrt(delta * fmax(1.0, nM));
  for (j = 0; j < n;) {
    double kap = HUGE_VAL, d;
    if (wi[j] > 0 && j + 1 < n) { /* a complex pair: columns j and j + 1 */
      const double *al = vl + (size_t)j * n, *bl = al + n, *ar = vr + (size_t)j * n, *br = ar + n;
      double s1 = 0.0, s2 = 0.0, s3 = 0.0, s4 = 0.0;
      for (k = 0; k < n; ++k) {
        s1 += al[k] * ar[k];
        s2 += bl[k] * br[k];
        s3 += al[k] * br[k];
        s4 += bl[k] * ar[k];
      }
      d = hypot(s1 + s2, s3 - s4);
      if (d > 0) kap = 1.0 / d;
      mu_tol[j] = mu_tol[j + 1] = fmax(fmin(kap * delta, cap), 16.0 * eps);
      j += 2;
      continue;
    }
    d = 0.0;
    for (k = 0; k < n; ++k) d += vl[(size_t)j * n + k] * vr[(size_t)j * n + k];
    d = fabs(d);
    if (d > 0) kap = 1.0 / d;
    mu_tol[j] = fmax(fmin(kap * delta, cap), 16.0 * eps);
    j += 1;
  }
  m->delta = delta;
  rc = 0;
done:
  free(A);
  free(scale);
  free(iwork);
  free(work);
  m->ok = rc == 0;
}

/* The isolation of the orbit with the row-major n x n monodromy M in the scales d (see
 * gs_isolation in gs_driver.h): the same arithmetic as gearsym.analysis.isolation.isolation
 * with no trivial directions (numpy's svd: dgesdd, jobz 'N' for the norm, 'A' for M_s - I). */
void lapack_isolation(gs_isolation* iso, const gs_multipliers* m, int n, const double* M, const double* d_in) {
  gs_dgesdd_t dgesdd = (gs_dgesdd_t)m->lapack_dgesdd;
  int i, j, info = 0, lda = n, one = 1, lwork = -1, lw;
  size_t nn = (size_t)n * (size_t)n;
  double *A = NULL, *B = NULL, *U = NULL, *VT = NULL, *sv = NULL, *d = NULL, *work = NULL, q = 0.0, dummy = 0.0;
  int* iwork = NULL;
  char job_n = 'N', job_a = 'A';
  iso->ok = 0;
  if (n < 1 || !dgesdd || !iso->direction) return;
  A = (double*)malloc(sizeof(double) * nn * 4);
  sv = (double*)malloc(sizeof(double) * (size_t)n * 2);
  iwork = (int*)malloc(sizeof(int) * (size_t)n * 8);
  if (!A || !sv || !iwork) goto done;
  B = A + nn;
  U = B + nn;
  VT = U + nn;
  d = sv + n;
  for (i = 0; i < n; ++i) d[i] = isfinite(d_in[i]) && d_in[i] > 0 ? d_in[i] : 1.0;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) {
      double v = M[(size_t)i * n + j] * d[j] / d[i]; /* numpy: M * d[None, :] / d[:, None] */
      if (!isfinite(v)) goto done;                   /* the Python function's verdicts */
      A[i + (size_t)j * n] = v;                      /* column-major */
    }
  /* workspace: the larger of the two queries */
  memcpy(B, A, sizeof(double) * nn);
  dgesdd(&job_a, &n, &n, B, &lda, sv, U, &lda, VT, &lda, &q, &lwork, iwork, &info);
  if (info != 0) goto done;
  lw = (int)q > 1 ? (int)q : 1;
  dgesdd(&job_n, &n, &n, B, &lda, sv, &dummy, &one, &dummy, &one, &q, &lwork, iwork, &info);
  if (info != 0) goto done;
  if ((int)q > lw) lw = (int)q;
  work = (double*)malloc(sizeof(double) * (size_t)lw);
  if (!work) goto done;
  lwork = lw;
  dgesdd(&job_n, &n, &n, B, &lda, sv, &dummy, &one, &dummy, &one, work, &lwork, iwork, &info);
  if (info != 0) goto done;
  iso->norm = sv[0];
  memcpy(B, A, sizeof(double) * nn);
  for (i = 0; i < n; ++i) B[i + (size_t)i * n] -= 1.0; /* Ms - I */
  dgesdd(&job_a, &n, &n, B, &lda, sv, U, &lda, VT, &lda, work, &lwork, iwork, &info);
  if (info != 0) goto done;
  iso->sigma = sv[n - 1];
  for (j = 0; j < n; ++j) iso->direction[j] = d[j] * VT[(n - 1) + (size_t)j * n]; /* row n-1 of V^T */
  iso->ok = 1;
done:
  free(A);
  free(sv);
  free(iwork);
  free(work);
}

/* ================================================================ the shooting residual
 *
 * One evaluation at X = nw->z_eval (segments x nx): for each segment i one run from X_i over
 * [s_i, s_{i+1}] with the monodromy (into nw->J's block i) and n_amp evenly spaced samples
 * (numpy.linspace's arithmetic, as System.flow(..., n_samples=n_amp) makes them); the residual
 * R_i = x(s_{i+1}) - X_{i+1} (cyclically), the amplitude max_k |x_j(t_k)| over all samples (NaN
 * propagates, as numpy's max), the events appended to f's log.  Returns 0 (answered: a failed
 * run is an evaluation that failed, its status and message in nw), GS_HANDBACK_EVENTS (the log
 * is too small: not answered) or GS_ERR_INTERRUPTED. */
static int orbit_eval(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_orbit_flow* f) {
  int N = nw->segments, nx = nw->nx, n_amp = f->n_amp, i, j, k, rc = 0, n_ev = 0;
  gs_sim_args keep;
  memcpy(&keep, a, sizeof(keep));
  for (j = 0; j < nx; ++j) nw->amplitude[j] = 0.0;
  for (i = 0; i < N; ++i) {
    double t0 = f->s[i], t1 = f->s[i + 1], step = (t1 - t0) / (double)(n_amp - 1);
    for (k = 0; k < n_amp; ++k) f->grid[k] = (double)k * step + t0;
    f->grid[n_amp - 1] = t1;
    if (f->ev_cap - n_ev < 1) {
      f->events_needed = 2 * f->ev_cap;
      rc = GS_HANDBACK_EVENTS;
      break;
    }
    a->t0 = t0;
    a->t_end = t1;
    a->x0 = nw->z_eval + (size_t)i * nx;
    a->monodromy = nw->J + (size_t)i * nx * nx;
    a->n_out = n_amp;
    a->t_out = f->grid;
    a->ev_t = f->ev_t + n_ev;
    a->ev_surface = f->ev_surface + n_ev;
    a->ev_dir = f->ev_dir + n_ev;
    a->ev_speed = f->ev_speed + n_ev;
    a->max_events_out = f->ev_cap - n_ev;
    rc = gs_simulate_ws(ws, a);
    f->n_runs++;
    if (rc == GS_ERR_INTERRUPTED) break;
    if (rc) { /* the evaluation failed: the iteration decides (halve the step, or end) */
      nw->eval_status = rc;
      snprintf(nw->eval_msg, sizeof(nw->eval_msg), "%s", a->errmsg);
      f->t_reached = a->t_reached;
      rc = 0;
      break;
    }
    if (a->n_events > a->max_events_out) {
      f->events_needed = n_ev + a->n_events > 2 * f->ev_cap ? n_ev + a->n_events : 2 * f->ev_cap;
      rc = GS_HANDBACK_EVENTS;
      break;
    }
    n_ev += a->n_events;
    for (j = 0; j < nx; ++j) {
      double amp = nw->amplitude[j];
      nw->R[(size_t)i * nx + j] = a->x_final[j] - nw->z_eval[(size_t)((i + 1) % N) * nx + j];
      for (k = 0; k < n_amp; ++k) {
        double v = fabs(a->y_out[(size_t)k * nx + j]);
        if (isnan(v) || isnan(amp)) amp = NAN;
        else if (v > amp) amp = v;
      }
      nw->amplitude[j] = amp;
    }
  }
  keep.n_events = a->n_events;
  keep.t_reached = a->t_reached;
  memcpy(a, &keep, sizeof(keep));
  a->status = GS_OK;
  a->errmsg[0] = '\0';
  if (rc) return rc;
  f->n_events = n_ev;
  nw->answered = 1;
  return 0;
}

/* The verification of the converged orbit X = nw->z (gs_orbit_flow.verify_ends): for each
 * segment one run without the variational equations from X_i over [s_i, s_{i+1}] (output at its
 * two ends, as System.flow(..., monodromy=False, n_samples=2) makes it; the events are not
 * logged: the orbit's are the last evaluation's), its end state into verify_ends.  A failed run
 * ends it with verify_ok = -1 and the run's status, message and stop time.  Returns
 * GS_ERR_INTERRUPTED or 0. */
static int orbit_verify(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_orbit_flow* f) {
  int N = nw->segments, nx = nw->nx, i, rc = 0;
  double ends[2];
  gs_sim_args keep;
  memcpy(&keep, a, sizeof(keep));
  f->verify_ok = 0;
  for (i = 0; i < N; ++i) {
    ends[0] = f->s[i];
    ends[1] = f->s[i + 1];
    a->t0 = ends[0];
    a->t_end = ends[1];
    a->x0 = nw->z + (size_t)i * nx;
    a->want_monodromy = 0;
    a->monodromy = NULL;
    a->n_out = 2;
    a->t_out = ends;
    a->ev_t = NULL;
    a->ev_surface = NULL;
    a->ev_dir = NULL;
    a->ev_speed = NULL;
    a->max_events_out = 0;
    rc = gs_simulate_ws(ws, a);
    f->n_runs++;
    if (rc == GS_ERR_INTERRUPTED) break;
    if (rc) {
      f->verify_ok = -1;
      f->verify_status = rc;
      f->verify_t_reached = a->t_reached;
      snprintf(f->verify_msg, sizeof(f->verify_msg), "%s", a->errmsg);
      rc = 0;
      break;
    }
    memcpy(f->verify_ends + (size_t)i * nx, a->x_final, sizeof(double) * (size_t)nx);
  }
  if (!rc && f->verify_ok == 0) f->verify_ok = 1;
  keep.n_events = a->n_events;
  keep.t_reached = a->t_reached;
  memcpy(a, &keep, sizeof(keep));
  a->status = GS_OK;
  a->errmsg[0] = '\0';
  return rc;
}

int gs_shoot_ws(gs_workspace* ws, gs_sim_args* a, gs_newton* nw, gs_orbit_flow* f) {
  int rc, nx;
  if (!a || !nw || !f) return GS_ERR_INPUT;
  f->handback = GS_HANDBACK_NONE;
  f->mult.ok = 0;
  f->iso.ok = 0;
  f->g0_ok = 0;
  f->verify_ok = 0;
  f->verify_status = 0;
  f->verify_msg[0] = '\0';
  if (!ws) return set_err(a, GS_ERR_INPUT, "no workspace");
  if (!ws->ready && (rc = ws_model_setup(ws, a)) != 0) return rc;
  nx = ws->U.nx;
  if (nw->kind != GS_NEWTON_ORBIT || nw->nx != nx || nw->segments < 1 || nw->n != nw->segments * nx ||
      nw->nr != nw->n || !nw->work || !nw->z || !nw->z_eval || !nw->R || !nw->J || !nw->amplitude || !nw->scale ||
      f->n_amp < 2 || !f->s || !f->grid || a->n_out != f->n_amp || !a->y_out || !a->want_monodromy || !f->ev_t ||
      !f->ev_surface || !f->ev_dir || !f->ev_speed || f->ev_cap < 1)
    return set_err(a, GS_ERR_INPUT, "gs_shoot_ws: an orbit iteration of this model's nx, the monodromy, >= 2 samples "
                   "per segment and the buffers");
  for (;;) {
    if (nw->request != GS_NEWTON_EVALUATE) break;
    if (!nw->answered) {
      rc = orbit_eval(ws, a, nw, f);
      if (rc == GS_ERR_INTERRUPTED) return set_err(a, rc, "interrupted");
      if (rc) {
        f->handback = rc;
        return 0;
      }
    }
    gs_newton_next(nw);
  }
  if (nw->outcome == GS_NEWTON_CONVERGED && nw->segments == 1) {
    lapack_multipliers(&f->mult, nx, nw->J);
    lapack_isolation(&f->iso, &f->mult, nx, nw->J, nw->scale);
    if (f->g0_out && ws->U.nsw > 0) { /* the sides at the orbit's start (its rattle state) */
      char msg[256];
      f->g0_ok = gs_eval(ws, GS_EVAL_SW, 1, &f->s[0], nw->z, a->p, NULL, f->g0_out, msg, (int)sizeof(msg)) == 0;
    }
  }
  if (nw->outcome == GS_NEWTON_CONVERGED && f->verify_ends && orbit_verify(ws, a, nw, f) == GS_ERR_INTERRUPTED)
    return set_err(a, GS_ERR_INTERRUPTED, "interrupted");
  return 0;
}
