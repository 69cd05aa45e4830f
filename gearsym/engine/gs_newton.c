/*
 * gs_newton.c -- part of the gearsym driver (shared declarations in gs_internal.h): THE damped
 * Newton iteration of the periodic-orbit solvers, written once.  Shooting's Newton
 * (gearsym.analysis.periodic.shoot) and the continuation's pseudo-arclength corrector
 * (gearsym.analysis.continuation._corrector.Continuer.correct) are two problems of this one
 * iteration; nothing else in gearsym iterates Newton on them.
 *
 * The rules, each written here only:
 *  - the damped step: from damping 1, halved down to min_damping until the damping's norm
 *    falls below (1 - decrease * damping) r, or below accept_below, or (accept_last) the
 *    smallest damping is taken anyway; a failed evaluation of a trial halves the damping too;
 *  - the convergence tests (orbit: the residual relative to the state scales <= tol, a full
 *    step below tol with the residual <= 100 tol, a step below 10 tol added without another
 *    evaluation, the noise floor when no damped step helps; corrector: the scaled residual
 *    <= tol or a step below tol with the residual <= 100 tol, and the constraint within 1e-9),
 *    the iteration budget, a non-finite residual, the corrector's divergence test;
 *  - the orbit's state scales from the amplitude (max |x_i| on the orbit, at least 1e-9 of the
 *    largest and atol / tol);
 *  - the steps: the orbit's minimum-norm step with the singular values of the scaled Jacobian
 *    below the monodromy's error level dropped (a multiplier at +1 to working precision moves
 *    nothing); the corrector's bordered step [J_s; row] dw = -[R_s; c] in the scaled variables
 *    (LU, least squares where LU meets a zero pivot); with rigid-body anchor rows both are the
 *    least-squares solutions of the system with those rows (dgelsd);
 *  - the corrector's chord: an evaluation without F_lambda uses the last one given;
 *  - the corrector's unit tangent along t_ref: [J_s; anchor; t_ref] t = e_n, else the null
 *    vector of J_s.
 * The problem's data come from its evaluator, by reverse communication (gs_driver.h): the C
 * evaluators of the shooting residuals (gs_shoot.c, gs_correct.c) in the same C call, the
 * analysis in Python for residuals they do not evaluate.  The relaxation of shooting by
 * integration (a different algorithm) is the caller's: the iteration reports STALLED, the
 * caller integrates and calls gs_newton_restart.  The linear algebra is scipy's LAPACK
 * (numpy.linalg's routines: dgetrf/dgetrs for solve, dgesdd for svd, dgelsd for lstsq).
 */
#include "gs_internal.h"

/* The iteration's state between calls, at the start of nw->work. */
typedef struct {
  int phase;          /* PH_*                                                              */
  int it;             /* steps accepted (kept over restarts)                               */
  int last;           /* the pending trial has the smallest damping                        */
  int n_drop;         /* singular values dropped from the current step                     */
  int have_chord;     /* corrector: chord holds an F_lambda                                */
  int cur_flam_given; /* corrector: the current evaluation had its own F_lambda             */
  int cur_is_last;    /* the buffers hold the evaluation of the current iterate            */
  int hist_kind;      /* the history entry of a start / restart                            */
  int end_outcome;    /* kept while the final evaluation is pending                        */
  int end_note;
  double size;        /* the last step relative to the tolerance's scale                   */
  double damping;
  double r;           /* the damping's norm at the current iterate                         */
  double r_prev;
  double rel;         /* orbit: the relative residual at the current iterate               */
  char last_err[256]; /* the last failed trial's message                                   */
} gs_nstate;

enum { PH_IDLE = 0, PH_FIRST, PH_TRIAL, PH_FINAL, PH_DONE };

#define NSTATE_DOUBLES ((sizeof(gs_nstate) + sizeof(double) - 1) / sizeof(double))

/* nw->work: the state, then dx [n], the current residual [nr], the chord's F_lambda [nr]. */
static gs_nstate* nst(gs_newton* nw) { return (gs_nstate*)(void*)nw->work; }
static double* n_dx(gs_newton* nw) { return nw->work + NSTATE_DOUBLES; }
static double* n_rcur(gs_newton* nw) { return n_dx(nw) + nw->n; }
static double* n_chord(gs_newton* nw) { return n_rcur(nw) + nw->nr; }

/* -1 unless the sizes are one problem's: orbit n = nr = segments * nx (nx, segments >= 1),
 * corrector n = nr + 1; n_anchor >= 0 (every array the iteration reads is sized from them). */
int gs_newton_work_size(const gs_newton* nw) {
  if (!nw || nw->n < 1 || nw->nr < 1 || nw->n_anchor < 0 || nw->hist_cap < 0) return -1;
  if (nw->kind == GS_NEWTON_ORBIT) {
    if (nw->nx < 1 || nw->segments < 1 || nw->n != nw->nr || nw->n / nw->segments != nw->nx ||
        nw->n % nw->segments != 0)
      return -1;
  } else if (nw->kind != GS_NEWTON_CORRECTOR || nw->n - 1 != nw->nr) {
    return -1;
  }
  return (int)(NSTATE_DOUBLES + (size_t)nw->n + 2 * (size_t)nw->nr);
}

/* ================================================================ LAPACK */

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

/* x = A^-1 b for the row-major n x n A (numpy.linalg.solve's dgesv: dgetrf, dgetrs).  Returns 0,
 * 1 when A is exactly singular (a zero pivot: numpy raises LinAlgError), -1 on another failure. */
static int lapack_solve(const gs_newton* nw, int n, const double* A, const double* b, double* x) {
  gs_dgetrf_t dgetrf = (gs_dgetrf_t)nw->lapack_dgetrf;
  gs_dgetrs_t dgetrs = (gs_dgetrs_t)nw->lapack_dgetrs;
  int i, j, info = 0, one = 1, lda = n, rc = -1;
  char no = 'N';
  double* Af;
  int* piv;
  if (!dgetrf || !dgetrs || n < 1) return -1;
  Af = (double*)malloc(sizeof(double) * (size_t)n * (size_t)n);
  piv = (int*)malloc(sizeof(int) * (size_t)n);
  if (!Af || !piv) goto done;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) Af[i + (size_t)j * n] = A[(size_t)i * n + j];
  dgetrf(&n, &n, Af, &lda, piv, &info);
  if (info > 0) {
    rc = 1;
    goto done;
  }
  if (info < 0) goto done;
  memcpy(x, b, sizeof(double) * (size_t)n);
  dgetrs(&no, &n, &one, Af, &lda, piv, x, &n, &info);
  rc = info == 0 ? 0 : -1;
done:
  free(Af);
  free(piv);
  return rc;
}

/* The full SVD of the column-major m x n A (dgesdd, jobz 'A': numpy.linalg.svd): s [min(m, n)],
 * U [m*m] and VT [n*n] column-major.  A is overwritten.  Returns 0 on success. */
static int lapack_svd(void* dgesdd_ptr, int m, int n, double* A, double* s, double* U, double* VT) {
  gs_dgesdd_t dgesdd = (gs_dgesdd_t)dgesdd_ptr;
  int info = 0, lwork = -1, lda = m, ldu = m, ldvt = n, mn = m < n ? m : n, rc = 1;
  double q = 0.0, *work = NULL;
  int* iwork;
  char job_a = 'A';
  if (!dgesdd || m < 1 || n < 1) return 1;
  iwork = (int*)malloc(sizeof(int) * 8 * (size_t)mn);
  if (!iwork) return 1;
  dgesdd(&job_a, &m, &n, A, &lda, s, U, &ldu, VT, &ldvt, &q, &lwork, iwork, &info);
  if (info != 0) goto done;
  lwork = (int)q > 1 ? (int)q : 1;
  work = (double*)malloc(sizeof(double) * (size_t)lwork);
  if (!work) goto done;
  dgesdd(&job_a, &m, &n, A, &lda, s, U, &ldu, VT, &ldvt, work, &lwork, iwork, &info);
  rc = info != 0;
done:
  free(work);
  free(iwork);
  return rc;
}

/* ================================================================ norms and scales */

/* max_i |v_i| / d_{i mod m} (d NULL: 1); NaN when a term is NaN (numpy's max). */
static double max_ratio(const double* v, int n, const double* d, int m) {
  double out = 0.0;
  int i;
  for (i = 0; i < n; ++i) {
    double q = d ? fabs(v[i]) / d[i % m] : fabs(v[i]);
    if (isnan(q)) return NAN;
    if (q > out) out = q;
  }
  return out;
}

static int all_finite_v(const double* v, int n) {
  int i;
  for (i = 0; i < n; ++i)
    if (!isfinite(v[i])) return 0;
  return 1;
}

/* The orbit's per-state scales from the evaluation's amplitude: max(amplitude_i, 1e-9 max_j
 * amplitude_j, scale_floor), all 1 when the amplitude is not finite. */
static void orbit_scale(gs_newton* nw) {
  int i, nx = nw->nx;
  double top = 0.0, fl;
  for (i = 0; i < nx; ++i) {
    double v = nw->amplitude[i];
    if (isnan(v) || isnan(top)) top = NAN;
    else if (v > top) top = v;
  }
  if (!isfinite(top)) {
    for (i = 0; i < nx; ++i) nw->scale[i] = 1.0;
    return;
  }
  fl = 1e-9 * top >= nw->scale_floor ? 1e-9 * top : nw->scale_floor;
  for (i = 0; i < nx; ++i) {
    double v = nw->amplitude[i];
    nw->scale[i] = isnan(v) ? v : (v > fl ? v : fl);
  }
}

/* The norms of the evaluation in the buffers: *r the damping's (orbit: max |R|; corrector:
 * max |R_i / Rs_i|), *rel the convergence test's (orbit: max |R_i| / scale_i). */
static void eval_norms(gs_newton* nw, double* r, double* rel) {
  if (nw->kind == GS_NEWTON_ORBIT) {
    orbit_scale(nw);
    *r = max_ratio(nw->R, nw->n, NULL, 1);
    *rel = max_ratio(nw->R, nw->n, nw->scale, nw->nx);
  } else {
    *r = max_ratio(nw->R, nw->nr, nw->Rs, nw->nr);
    *rel = *r;
  }
}

/* corrector: row . (z / S) - target */
static double constraint(const gs_newton* nw, const double* z) {
  double c = 0.0;
  int j;
  for (j = 0; j < nw->n; ++j) c += nw->row[j] * (z[j] / nw->S[j]);
  return c - nw->target;
}

/* ================================================================ the steps */

/* The truncated step: in the variables scaled by the state scales (D = diag(d), J_s = D^-1 J D,
 * b_s = D^-1 rhs) the minimum-norm solution of J_s w = b_s without the singular values below
 * trunc_level * max(1, sigma_1), dx = D w.  Returns 1 (dx not set) when J_s or b_s is not finite
 * or the SVD fails. */
static int truncated_solve(gs_newton* nw, const double* J, const double* rhs, double* dx, int* n_drop) {
  int n = nw->n, nx = nw->nx, i, j, k, ok = 1;
  size_t nn = (size_t)n * (size_t)n;
  double *w = (double*)malloc(sizeof(double) * (3 * nn + 4 * (size_t)n)), *A, *U, *VT, *s, *d, *bs, *c, thr;
  if (!w) return 1;
  A = w;
  U = A + nn;
  VT = U + nn;
  s = VT + nn;
  d = s + n;
  bs = d + n;
  c = bs + n;
  for (i = 0; i < n; ++i) {
    double v = nw->scale[i % nx];
    d[i] = isfinite(v) && v > 0 ? v : 1.0;
  }
  for (i = 0; i < n; ++i) {
    for (j = 0; j < n; ++j) {
      double v = J[(size_t)i * n + j] * d[j] / d[i];
      if (!isfinite(v)) ok = 0;
      A[i + (size_t)j * n] = v; /* column-major */
    }
    bs[i] = rhs[i] / d[i];
    if (!isfinite(bs[i])) ok = 0;
  }
  if (!ok || lapack_svd(nw->lapack_dgesdd, n, n, A, s, U, VT)) {
    free(w);
    return 1;
  }
  thr = nw->trunc_level * (s[0] > 1.0 ? s[0] : 1.0);
  *n_drop = 0;
  for (k = 0; k < n; ++k) {
    double ub = 0.0;
    if (!(s[k] > thr)) {
      c[k] = 0.0;
      *n_drop += 1;
      continue;
    }
    for (i = 0; i < n; ++i) ub += U[i + (size_t)k * n] * bs[i];
    c[k] = ub / s[k];
  }
  for (j = 0; j < n; ++j) {
    double v = 0.0;
    for (k = 0; k < n; ++k)
      if (s[k] > thr) v += VT[k + (size_t)j * n] * c[k];
    dx[j] = d[j] * v;
  }
  free(w);
  return 0;
}

/* The orbit's step from the current evaluation: the segment Jacobian (M_i on the diagonal
 * blocks, -I right of them, cyclically; M - I for one segment), then the least-squares step
 * with the anchor rows, else the truncated step.  dx is NaN where no step was found. */
static void orbit_step(gs_newton* nw, double* dx, double* size, int* n_drop) {
  int n = nw->n, nx = nw->nx, N = nw->segments, na = nw->n_anchor > 0 ? nw->n_anchor : 0, i, j, blk, rc = 1;
  const double* Rc = n_rcur(nw);
  double *J = (double*)calloc((size_t)(n + na) * (size_t)n, sizeof(double));
  double *b = (double*)malloc(sizeof(double) * (size_t)(n + na));
  *n_drop = 0;
  *size = HUGE_VAL;
  if (J && b) {
    for (blk = 0; blk < N; ++blk) { /* row-major */
      const double* M = nw->J + (size_t)blk * nx * nx;
      int col_next = ((blk + 1) % N) * nx;
      for (i = 0; i < nx; ++i) {
        double* row = J + (size_t)(blk * nx + i) * n;
        for (j = 0; j < nx; ++j) row[blk * nx + j] = M[(size_t)i * nx + j];
        row[col_next + i] -= 1.0;
      }
    }
    for (i = 0; i < n; ++i) b[i] = -Rc[i];
    if (na) { /* rigid-body modes: [J; anchor] dx = [-R; 0], least squares */
      memcpy(J + (size_t)n * n, nw->anchor, sizeof(double) * (size_t)na * n);
      for (i = 0; i < na; ++i) b[n + i] = 0.0;
      rc = lapack_lstsq(nw->lapack_dgelsd, n + na, n, J, b, dx);
    } else {
      rc = truncated_solve(nw, J, b, dx, n_drop);
    }
  }
  if (rc)
    for (i = 0; i < n; ++i) dx[i] = NAN;
  else if (all_finite_v(dx, n))
    *size = max_ratio(dx, n, nw->scale, nx);
  free(J);
  free(b);
}

/* The scaled bordered matrix of the corrector into A (row-major, (nr + na + 1) x n): rows
 * [F_u, F_lambda] S_j / Rs_i, then the anchor rows, then `last` (the constraint row or t_ref). */
static void bordered(gs_newton* nw, const double* last, double* A) {
  int nr = nw->nr, n = nw->n, na = nw->n_anchor > 0 ? nw->n_anchor : 0, i, j;
  const double* Fl = nw->flam_given || !nst(nw)->have_chord ? nw->Flam : n_chord(nw);
  for (i = 0; i < nr; ++i) {
    double* row = A + (size_t)i * n;
    for (j = 0; j < nr; ++j) row[j] = nw->J[(size_t)i * nr + j] * nw->S[j] / nw->Rs[i];
    row[nr] = Fl[i] * nw->S[nr] / nw->Rs[i];
  }
  if (na) memcpy(A + (size_t)nr * n, nw->anchor, sizeof(double) * (size_t)na * n);
  memcpy(A + (size_t)(nr + na) * n, last, sizeof(double) * (size_t)n);
}

/* Solve the bordered system A w = b ((nr + na + 1) x n, row-major): least squares with anchor
 * rows, else LU with least squares where it meets a zero pivot (w NaN where neither works). */
static void bordered_solve(gs_newton* nw, const double* A, const double* b, double* w) {
  int n = nw->n, m = nw->nr + (nw->n_anchor > 0 ? nw->n_anchor : 0) + 1, i, rc;
  if (m == n) {
    rc = lapack_solve(nw, n, A, b, w);
    if (rc == 0) return;
    if (rc < 0) {
      for (i = 0; i < n; ++i) w[i] = NAN;
      return;
    }
  }
  if (lapack_lstsq(nw->lapack_dgelsd, m, n, A, b, w))
    for (i = 0; i < n; ++i) w[i] = NAN;
}

/* The corrector's step: [J_s; anchor; row] dw = -[R / Rs; 0; c], dx = dw * S, size = max |dw|. */
static void corrector_step(gs_newton* nw, double* dx, double* size, int* n_drop) {
  int n = nw->n, nr = nw->nr, na = nw->n_anchor > 0 ? nw->n_anchor : 0, m = nr + na + 1, i;
  const double* Rc = n_rcur(nw);
  double *A = (double*)malloc(sizeof(double) * ((size_t)m * n + (size_t)m)), *b;
  *n_drop = 0;
  *size = HUGE_VAL;
  if (!A) {
    for (i = 0; i < n; ++i) dx[i] = NAN;
    return;
  }
  b = A + (size_t)m * n;
  bordered(nw, nw->row, A);
  for (i = 0; i < nr; ++i) b[i] = -(Rc[i] / nw->Rs[i]);
  for (i = 0; i < na; ++i) b[nr + i] = 0.0;
  b[m - 1] = -constraint(nw, nw->z);
  bordered_solve(nw, A, b, dx);
  *size = all_finite_v(dx, n) ? max_ratio(dx, n, NULL, 1) : HUGE_VAL;
  for (i = 0; i < n; ++i) dx[i] *= nw->S[i];
  free(A);
}

int gs_newton_tangent(gs_newton* nw) {
  int n, nr, na, m, i, j, ok = 0;
  double *A, *b, *t, norm = 0.0, dot = 0.0;
  if (!nw || nw->kind != GS_NEWTON_CORRECTOR || !nw->t_ref || !nw->tangent || gs_newton_work_size(nw) < 1) return 0;
  n = nw->n;
  nr = nw->nr;
  na = nw->n_anchor > 0 ? nw->n_anchor : 0;
  m = nr + na + 1;
  t = nw->tangent;
  nw->tangent_ok = 0;
  A = (double*)malloc(sizeof(double) * ((size_t)m * n + (size_t)m));
  if (!A) return 0;
  b = A + (size_t)m * n;
  bordered(nw, nw->t_ref, A);
  for (i = 0; i < m; ++i) b[i] = i == m - 1 ? 1.0 : 0.0;
  bordered_solve(nw, A, b, t);
  for (i = 0; i < n; ++i) norm += t[i] * t[i];
  if (!all_finite_v(t, n) || norm == 0.0) { /* the smallest right singular vector of J_s */
    double *w = (double*)malloc(sizeof(double) * ((size_t)nr * n + (size_t)nr * nr + (size_t)n * n + (size_t)n));
    double *Jc, *Uf, *V, *sv;
    if (!w) goto done;
    Jc = w;
    Uf = Jc + (size_t)nr * n;
    V = Uf + (size_t)nr * nr;
    sv = V + (size_t)n * n;
    for (i = 0; i < nr; ++i)
      for (j = 0; j < n; ++j) Jc[i + (size_t)j * nr] = A[(size_t)i * n + j]; /* column-major */
    if (lapack_svd(nw->lapack_dgesdd, nr, n, Jc, sv, Uf, V)) {
      free(w);
      goto done;
    }
    for (j = 0; j < n; ++j) t[j] = V[(n - 1) + (size_t)j * n]; /* the last row of V^T */
    free(w);
    norm = 0.0;
    for (i = 0; i < n; ++i) norm += t[i] * t[i];
  }
  if (!(norm > 0.0) || !isfinite(norm)) goto done;
  norm = sqrt(norm);
  for (i = 0; i < n; ++i) {
    t[i] /= norm;
    dot += t[i] * nw->t_ref[i];
  }
  if (dot < 0)
    for (i = 0; i < n; ++i) t[i] = -t[i];
  ok = all_finite_v(t, n);
done:
  free(A);
  nw->tangent_ok = ok;
  return ok;
}

/* ================================================================ the iteration */

static void hist(gs_newton* nw, int kind, double r_abs, double rel, double step, int drop) {
  int k = nw->n_hist;
  if (k >= nw->hist_cap || !nw->hist_kind) return;
  nw->hist_kind[k] = kind;
  nw->hist_abs[k] = r_abs;
  nw->hist_rel[k] = rel;
  nw->hist_step[k] = step;
  nw->hist_drop[k] = drop;
  nw->n_hist = k + 1;
}

static void request_eval(gs_newton* nw, int must_succeed) {
  nw->request = GS_NEWTON_EVALUATE;
  nw->answered = 0;
  nw->must_succeed = must_succeed;
  nw->eval_status = 0;
  nw->eval_msg[0] = '\0';
  nw->flam_given = 0;
  nw->n_evals++;
}

static void done(gs_newton* nw, int outcome, int note) {
  gs_nstate* st = nst(nw);
  st->phase = PH_DONE;
  nw->request = GS_NEWTON_DONE;
  nw->outcome = outcome;
  nw->note = note;
  nw->iterations = st->it;
  nw->residual = st->r;
  nw->residual_prev = st->r_prev;
  nw->relative = st->rel;
  if (outcome == GS_NEWTON_CONVERGED && nw->kind == GS_NEWTON_CORRECTOR && nw->t_ref && nw->tangent &&
      st->cur_flam_given)
    gs_newton_tangent(nw);
}

/* End with `outcome`; first evaluate the current iterate again when the buffers hold a later
 * trial's evaluation (the result's monodromy, events and scales are the iterate's). */
static void finish(gs_newton* nw, int outcome, int note) {
  gs_nstate* st = nst(nw);
  if (st->cur_is_last) {
    done(nw, outcome, note);
    return;
  }
  st->end_outcome = outcome;
  st->end_note = note;
  st->phase = PH_FINAL;
  memcpy(nw->z_eval, nw->z, sizeof(double) * (size_t)nw->n);
  request_eval(nw, 0);
}

/* The evaluation in the buffers becomes the current iterate's. */
static void accept(gs_newton* nw, double r, double rel) {
  gs_nstate* st = nst(nw);
  st->r = r;
  st->rel = rel;
  st->cur_is_last = 1;
  nw->residual = r;
  nw->relative = rel;
  memcpy(n_rcur(nw), nw->R, sizeof(double) * (size_t)nw->nr);
  if (nw->kind == GS_NEWTON_CORRECTOR) {
    st->cur_flam_given = nw->flam_given != 0;
    if (nw->flam_given) {
      memcpy(n_chord(nw), nw->Flam, sizeof(double) * (size_t)nw->nr);
      st->have_chord = 1;
    }
  }
}

/* converged(size, damping): the note (>= 0), or -1 while not converged. */
static int converged(gs_newton* nw, double size, double damping) {
  gs_nstate* st = nst(nw);
  double tol = nw->tol;
  if (nw->kind == GS_NEWTON_ORBIT) {
    double r = st->rel;
    if (r <= tol) return 0;
    /* a full Newton step below the tolerance: the residual left is integration noise */
    if (damping == 1.0 && size <= tol && r <= 100.0 * tol) return 1;
    /* the next step is below 10 tol: taken without integrating again (its effect on the
     * residual is quadratic in its size) */
    if (damping == 0.0 && size <= 10.0 * tol && r <= 100.0 * tol) return 2;
    return -1;
  }
  return ((st->r <= tol || (size <= tol && st->r <= 100.0 * tol)) && fabs(constraint(nw, nw->z)) <= 1e-9) ? 0 : -1;
}

static void trial(gs_newton* nw) {
  gs_nstate* st = nst(nw);
  const double* dx = n_dx(nw);
  int j;
  st->last = st->damping * 0.5 < nw->min_damping;
  for (j = 0; j < nw->n; ++j) nw->z_eval[j] = nw->z[j] + st->damping * dx[j];
  st->phase = PH_TRIAL;
  request_eval(nw, nw->accept_last && st->last);
}

/* At the current iterate: the convergence tests, then the next step's first trial. */
static void top(gs_newton* nw) {
  gs_nstate* st = nst(nw);
  double* dx = n_dx(nw);
  double size = HUGE_VAL;
  int note, n_drop = 0, j;
  if ((note = converged(nw, st->size, st->damping)) >= 0) {
    finish(nw, GS_NEWTON_CONVERGED, note);
    return;
  }
  if (st->it >= nw->max_iter) {
    finish(nw, GS_NEWTON_MAX_ITER, 0);
    return;
  }
  if (!isfinite(st->r)) {
    finish(nw, GS_NEWTON_NONFINITE, 0);
    return;
  }
  if (nw->diverge_ratio > 0 && st->it >= 2 && st->r > nw->diverge_ratio * st->r_prev && st->r > nw->diverge_floor) {
    finish(nw, GS_NEWTON_DIVERGED, 0);
    return;
  }
  if (nw->kind == GS_NEWTON_ORBIT) orbit_step(nw, dx, &size, &n_drop);
  else corrector_step(nw, dx, &size, &n_drop);
  if (!all_finite_v(dx, nw->n)) {
    finish(nw, GS_NEWTON_SINGULAR, 0);
    return;
  }
  st->size = size;
  st->n_drop = n_drop;
  if ((note = converged(nw, size, 0.0)) >= 0) { /* the step is below the tolerance: no evaluation at its end */
    if (nw->apply_final_step)
      for (j = 0; j < nw->n; ++j) nw->z[j] += dx[j];
    finish(nw, GS_NEWTON_CONVERGED, note);
    return;
  }
  st->it++;
  st->r_prev = st->r;
  st->damping = 1.0;
  trial(nw);
}

/* No damped step reduces the residual: the orbit's noise floor (converged), else STALLED. */
static void stalled(gs_newton* nw) {
  gs_nstate* st = nst(nw);
  if (nw->kind == GS_NEWTON_ORBIT) {
    double rdx = max_ratio(n_dx(nw), nw->n, nw->scale, nw->nx), rr = max_ratio(n_rcur(nw), nw->n, nw->scale, nw->nx);
    /* at the integration noise floor a tiny Newton step cannot reduce the residual any more */
    if (rdx <= 10.0 * nw->tol && rr <= 100.0 * nw->tol) {
      hist(nw, GS_NEWTON_H_FLOOR, st->r, NAN, 0.0, 0);
      finish(nw, GS_NEWTON_CONVERGED, 3);
      return;
    }
  }
  finish(nw, GS_NEWTON_STALLED, 0);
  if (nw->request == GS_NEWTON_DONE) snprintf(nw->eval_msg, sizeof(nw->eval_msg), "%s", st->last_err);
}

static void begin(gs_newton* nw, int hist_kind) {
  gs_nstate* st = nst(nw);
  st->size = HUGE_VAL;
  st->damping = 1.0;
  st->hist_kind = hist_kind;
  st->last_err[0] = '\0';
  st->phase = PH_FIRST;
  st->cur_is_last = 0;
  nw->n_hist = 0;
  nw->tangent_ok = 0;
  nw->outcome = -1;
  memcpy(nw->z_eval, nw->z, sizeof(double) * (size_t)nw->n);
  request_eval(nw, 1);
}

/* Sizes that are no problem's (changed after the work array was sized): end at once. */
static int refuse_sizes(gs_newton* nw) {
  if (gs_newton_work_size(nw) >= 1) return 0;
  nw->request = GS_NEWTON_DONE;
  nw->outcome = GS_NEWTON_EVAL_FAILED;
  nw->answered = 0;
  snprintf(nw->eval_msg, sizeof(nw->eval_msg), "gs_newton: inconsistent sizes (kind %d, n %d, nr %d, nx %d, "
           "segments %d)", nw->kind, nw->n, nw->nr, nw->nx, nw->segments);
  return 1;
}

void gs_newton_start(gs_newton* nw) {
  gs_nstate* st;
  if (!nw || !nw->work || refuse_sizes(nw)) return;
  st = nst(nw);
  memset(st, 0, sizeof(*st));
  st->r_prev = HUGE_VAL;
  st->r = st->rel = NAN;
  nw->n_evals = 0;
  nw->iterations = 0;
  begin(nw, GS_NEWTON_H_START);
}

void gs_newton_restart(gs_newton* nw) {
  if (!nw || !nw->work || refuse_sizes(nw)) return;
  begin(nw, GS_NEWTON_H_RESTART);
}

void gs_newton_next(gs_newton* nw) {
  gs_nstate* st;
  double r = NAN, rel = NAN;
  int ok;
  if (!nw || !nw->work || nw->request != GS_NEWTON_EVALUATE || !nw->answered) return;
  st = nst(nw);
  nw->answered = 0;
  ok = nw->eval_status == 0;
  if (ok && nw->kind == GS_NEWTON_CORRECTOR && !nw->flam_given && !st->have_chord) {
    /* no F_lambda given since the start: the buffer holds an earlier problem's (or nothing) */
    ok = 0;
    nw->eval_status = 1;
    snprintf(nw->eval_msg, sizeof(nw->eval_msg), "the corrector's evaluation gave no F_lambda and none was given "
             "since the start (no chord)");
  }
  if (ok) eval_norms(nw, &r, &rel);
  switch (st->phase) {
    case PH_FIRST:
      if (!ok) {
        st->r = NAN;
        done(nw, GS_NEWTON_EVAL_FAILED, 0);
        return;
      }
      accept(nw, r, rel);
      hist(nw, st->hist_kind, r, rel, NAN, 0);
      top(nw);
      return;
    case PH_TRIAL:
      if (ok && isfinite(r) &&
          (r < (1.0 - nw->decrease * st->damping) * st->r || r <= nw->accept_below || (nw->accept_last && st->last))) {
        memcpy(nw->z, nw->z_eval, sizeof(double) * (size_t)nw->n);
        accept(nw, r, rel);
        hist(nw, GS_NEWTON_H_STEP, r, rel, st->damping, st->n_drop);
        top(nw);
        return;
      }
      st->cur_is_last = 0; /* the buffers hold a rejected trial's evaluation */
      if (!ok) {
        snprintf(st->last_err, sizeof(st->last_err), "%s", nw->eval_msg);
        if (nw->must_succeed) {
          done(nw, GS_NEWTON_EVAL_FAILED, 0);
          return;
        }
      }
      st->damping *= 0.5;
      if (st->damping >= nw->min_damping) trial(nw);
      else stalled(nw);
      return;
    case PH_FINAL:
      st->cur_is_last = 1;
      done(nw, st->end_outcome, st->end_note);
      if (st->end_outcome == GS_NEWTON_STALLED) snprintf(nw->eval_msg, sizeof(nw->eval_msg), "%s", st->last_err);
      return;
    default:
      return;
  }
}
