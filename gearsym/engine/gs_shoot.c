/*
 * gs_shoot.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * the multipliers by LAPACK and the single-shooting Newton (gs_shoot_ws).
 */
#include "gs_internal.h"

/* ================================================================ shooting Newton in C
 *
 * gs_shoot_ws(): Newton's method for a periodic orbit x(t_end; t0, x) = x of fixed period
 * (single shooting), each iterate one gs_simulate_ws() run with the monodromy M; the step
 * solves (M - I) dx = -R in the variables scaled by the orbit's state magnitudes, by LU
 * with partial pivoting.  It mirrors the full-step path of gearsym.analysis.shooting.shoot
 * (the same convergence tests, the same scales) and gives up -- outcome != 0, nothing
 * raised -- wherever that function would do more than a full Newton step: a residual that
 * does not decrease (damping), a nearly singular Newton matrix (truncated solve), a failed
 * run after the first, an event log too small, or the iteration budget.  The caller then
 * runs the Python iteration from its own start.  One C call in place of one ctypes call,
 * numpy step and bookkeeping per iterate. */
/* LAPACK through scipy's cython_lapack (C functions with Fortran's by-reference arguments). */
typedef void (*gs_dgebal_t)(char*, int*, double*, int*, int*, int*, double*, int*);
typedef void (*gs_dgesdd_t)(char*, int*, int*, double*, int*, double*, double*, int*, double*, int*, double*,
                            int*, int*, int*);
typedef void (*gs_dgelsd_t)(int*, int*, int*, double*, int*, double*, int*, double*, double*, int*, double*,
                            int*, int*, int*);
typedef void (*gs_dgeev_t)(char*, char*, int*, double*, int*, double*, double*, double*, int*, double*, int*,
                           double*, int*, int*);

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

/* The minimum-norm least-squares solution x (n) of the row-major m x n system A x = b by dgelsd
 * (numpy.linalg.lstsq's routine and default rcond, eps * max(m, n)).  Returns 0 on success. */
int lapack_lstsq(void* dgelsd_ptr, int m, int n, const double* A, const double* b, double* x) {
  gs_dgelsd_t dgelsd = (gs_dgelsd_t)dgelsd_ptr;
  int i, j, info = 0, nrhs = 1, lda = m, ldb = m > n ? m : n, lwork = -1, liwork, rank = 0, rc = 1;
  double *Af = NULL, *B = NULL, *sv = NULL, *work = NULL, q = 0.0, rcond;
  int* iwork = NULL;
  int qi = 0;
  if (!dgelsd || m < 1 || n < 1) return 1;
  rcond = DBL_EPSILON * (double)(m > n ? m : n);
  Af = (double*)malloc(sizeof(double) * ((size_t)m * n + (size_t)ldb + (size_t)(m < n ? m : n)));
  if (!Af) return 1;
  B = Af + (size_t)m * n;
  sv = B + ldb;
  for (i = 0; i < m; ++i)
    for (j = 0; j < n; ++j) Af[i + (size_t)j * m] = A[(size_t)i * n + j]; /* column-major */
  for (i = 0; i < ldb; ++i) B[i] = i < m ? b[i] : 0.0;
  dgelsd(&m, &n, &nrhs, Af, &lda, B, &ldb, sv, &rcond, &rank, &q, &lwork, &qi, &info);
  if (info != 0) goto done;
  lwork = (int)q > 1 ? (int)q : 1;
  liwork = qi > 1 ? qi : 1;
  work = (double*)malloc(sizeof(double) * (size_t)lwork);
  iwork = (int*)malloc(sizeof(int) * (size_t)liwork);
  if (!work || !iwork) goto done;
  dgelsd(&m, &n, &nrhs, Af, &lda, B, &ldb, sv, &rcond, &rank, work, &lwork, iwork, &info);
  if (info != 0) goto done;
  for (j = 0; j < n; ++j) x[j] = B[j];
  rc = 0;
done:
  free(Af);
  free(work);
  free(iwork);
  return rc;
}

int shoot_lu(int n, double* A, int* piv, double pivot_tol) {
  /* in-place LU with partial pivoting of the row-major n x n matrix A; 1: (nearly) singular */
  int i, j, k;
  double umax = 0.0, umin = HUGE_VAL;
  for (k = 0; k < n; ++k) {
    int r = k;
    double best = fabs(A[(size_t)k * n + k]);
    for (i = k + 1; i < n; ++i)
      if (fabs(A[(size_t)i * n + k]) > best) best = fabs(A[(size_t)(r = i) * n + k]);
    if (!isfinite(best)) return 1;
    piv[k] = r;
    if (r != k)
      for (j = 0; j < n; ++j) {
        double tmp = A[(size_t)k * n + j];
        A[(size_t)k * n + j] = A[(size_t)r * n + j];
        A[(size_t)r * n + j] = tmp;
      }
    if (best > umax) umax = best;
    if (best < umin) umin = best;
    if (best == 0.0) return 1;
    for (i = k + 1; i < n; ++i) {
      double f = A[(size_t)i * n + k] / A[(size_t)k * n + k];
      A[(size_t)i * n + k] = f;
      if (f != 0.0)
        for (j = k + 1; j < n; ++j) A[(size_t)i * n + j] -= f * A[(size_t)k * n + j];
    }
  }
  return umin <= pivot_tol * (umax > 1.0 ? umax : 1.0);
}

void shoot_lu_solve(int n, const double* LU, const int* piv, double* b) {
  int i, j;
  for (i = 0; i < n; ++i) {
    if (piv[i] != i) {
      double tmp = b[i];
      b[i] = b[piv[i]];
      b[piv[i]] = tmp;
    }
  }
  for (i = 0; i < n; ++i)
    for (j = 0; j < i; ++j) b[i] -= LU[(size_t)i * n + j] * b[j];
  for (i = n - 1; i >= 0; --i) {
    for (j = i + 1; j < n; ++j) b[i] -= LU[(size_t)i * n + j] * b[j];
    b[i] /= LU[(size_t)i * n + i];
  }
}

/* One evaluation at the start state a->x0: residual R = x(t_end) - x0, its max norm, the
 * scales and the scaled max norm.  Returns the run's status. */
static int shoot_eval(gs_workspace* ws, gs_sim_args* a, gs_shoot_args* s, int nx, double* R, double* r_abs,
                      double* r_rel) {
  int rc, i, k;
  double top = 0.0;
  rc = gs_simulate_ws(ws, a);
  if (rc) return rc;
  for (i = 0; i < nx; ++i) {
    double amp = 0.0;
    for (k = 0; k < a->n_out; ++k) {
      double v = fabs(a->y_out[(size_t)k * nx + i]);
      if (!(v <= amp)) amp = v; /* NaN propagates */
    }
    s->scale[i] = amp;
    if (!(amp <= top)) top = amp;
  }
  *r_abs = 0.0;
  *r_rel = 0.0;
  for (i = 0; i < nx; ++i) {
    double fl = 1e-9 * top > s->scale_floor ? 1e-9 * top : s->scale_floor;
    if (!isfinite(top)) s->scale[i] = 1.0;
    else if (s->scale[i] < fl) s->scale[i] = fl;
    R[i] = a->x_final[i] - a->x0[i];
    if (!(fabs(R[i]) <= *r_abs)) *r_abs = fabs(R[i]);
    if (!(fabs(R[i]) / s->scale[i] <= *r_rel)) *r_rel = fabs(R[i]) / s->scale[i];
  }
  return 0;
}

int gs_shoot_ws(gs_workspace* ws, gs_sim_args* a, gs_shoot_args* s) {
  double x[GS_SHOOT_MAXN], xn[GS_SHOOT_MAXN], R[GS_SHOOT_MAXN], dx[GS_SHOOT_MAXN];
  double *J = NULL, r_abs, r_rel, size = HUGE_VAL;
  int piv[GS_SHOOT_MAXN];
  int nx, i, j, rc, it = 0;
  if (!a || !s) return GS_ERR_INPUT;
  s->iterations = 0;
  s->n_hist = 0;
  s->note = 0;
  s->mult.ok = 0;
  s->iso.ok = 0;
  s->g0_ok = 0;
  s->outcome = GS_SHOOT_GAVE_UP_OTHER;
  if (!ws) return set_err(a, GS_ERR_INPUT, "no workspace");
  if (!ws->ready && (rc = ws_model_setup(ws, a)) != 0) return rc;
  nx = ws->U.nx;
  if (nx > GS_SHOOT_MAXN || nx < 1 || !a->want_monodromy || !a->monodromy || a->n_out < 2 || !a->y_out || !s->x ||
      !s->scale || !s->hist_abs || !s->hist_rel || s->max_iter < 0 || ws->U.nalg > 0)
    return set_err(a, GS_ERR_INPUT, "gs_shoot_ws: needs 1 <= nx <= %d, the monodromy, >= 2 samples and the "
                   "output buffers (explicit models)", GS_SHOOT_MAXN);
  J = (double*)malloc(sizeof(double) * (size_t)nx * (size_t)nx);
  if (!J) return set_err(a, GS_ERR_INPUT, "out of memory");
  memcpy(x, s->x, sizeof(double) * (size_t)nx);
  a->x0 = x;
  rc = shoot_eval(ws, a, s, nx, R, &r_abs, &r_rel);
  if (rc) goto done; /* the first integration fails: the caller raises, as the Python path would */
  for (;;) {
    if (a->n_events > a->max_events_out) { s->outcome = GS_SHOOT_GAVE_UP_EVENTS; break; }
    s->hist_abs[s->n_hist] = r_abs;
    s->hist_rel[s->n_hist] = r_rel;
    s->n_hist++;
    /* converged(ev, size, damping) */
    if (r_rel <= s->tol) { s->outcome = GS_SHOOT_CONVERGED; s->note = 0; break; }
    if (size <= s->tol && r_rel <= 100.0 * s->tol) { /* after a full step (the only kind taken here) */
      s->outcome = GS_SHOOT_CONVERGED;
      s->note = 1;
      break;
    }
    if (it >= s->max_iter) { s->outcome = GS_SHOOT_GAVE_UP_ITER; break; }
    if (!isfinite(r_abs)) { s->outcome = GS_SHOOT_GAVE_UP_OTHER; break; }
    /* the Newton step in scaled variables: (D^-1 (M - I) D) (D^-1 dx) = -D^-1 R */
    for (i = 0; i < nx; ++i)
      for (j = 0; j < nx; ++j)
        J[(size_t)i * nx + j] = (a->monodromy[(size_t)i * nx + j] - (i == j ? 1.0 : 0.0)) * s->scale[j] / s->scale[i];
    if (shoot_lu(nx, J, piv, s->pivot_tol)) { s->outcome = GS_SHOOT_GAVE_UP_SINGULAR; break; }
    for (i = 0; i < nx; ++i) dx[i] = -R[i] / s->scale[i];
    shoot_lu_solve(nx, J, piv, dx);
    size = 0.0;
    for (i = 0; i < nx; ++i) {
      if (!isfinite(dx[i])) size = HUGE_VAL;
      else if (fabs(dx[i]) > size) size = fabs(dx[i]);
      dx[i] *= s->scale[i];
    }
    if (!isfinite(size)) { s->outcome = GS_SHOOT_GAVE_UP_SINGULAR; break; }
    /* converged(ev, size, 0): a step below 10 tol is applied without integrating again */
    if (size <= 10.0 * s->tol && r_rel <= 100.0 * s->tol) {
      for (i = 0; i < nx; ++i) x[i] += dx[i];
      s->outcome = GS_SHOOT_CONVERGED;
      s->note = 2;
      break;
    }
    {
      double rn_abs, rn_rel, Rn[GS_SHOOT_MAXN];
      for (i = 0; i < nx; ++i) xn[i] = x[i] + dx[i];
      a->x0 = xn;
      rc = shoot_eval(ws, a, s, nx, Rn, &rn_abs, &rn_rel);
      if (rc == GS_ERR_INTERRUPTED) goto done;
      if (rc) { rc = 0; a->status = GS_OK; a->errmsg[0] = '\0'; s->outcome = GS_SHOOT_GAVE_UP_RUN; break; }
      /* the full step must decrease the residual (Python: 1 - 1e-4 of it), else damping */
      if (!(rn_abs < (1.0 - 1e-4) * r_abs)) { s->outcome = GS_SHOOT_GAVE_UP_DECREASE; break; }
      it++; /* an accepted step (a rejected one leaves x, the last accepted iterate, and it) */
      memcpy(x, xn, sizeof(double) * (size_t)nx);
      memcpy(R, Rn, sizeof(double) * (size_t)nx);
      a->x0 = x;
      r_abs = rn_abs;
      r_rel = rn_rel;
    }
  }
  s->iterations = it;
  memcpy(s->x, x, sizeof(double) * (size_t)nx);
  if (s->outcome == GS_SHOOT_CONVERGED) {
    lapack_multipliers(&s->mult, nx, a->monodromy);
    lapack_isolation(&s->iso, &s->mult, nx, a->monodromy, s->scale);
    if (s->g0_out && ws->U.nsw > 0) { /* the sides at the orbit's start (its rattle state) */
      char msg[256];
      s->g0_ok = gs_eval(ws, GS_EVAL_SW, 1, &a->t0, x, a->p, NULL, s->g0_out, msg, (int)sizeof(msg)) == 0;
    }
  }
done:
  a->x0 = NULL; /* points at this frame */
  free(J);
  return rc;
}
