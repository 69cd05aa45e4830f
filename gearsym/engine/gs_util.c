/*
 * gs_util.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * small helpers: error messages, non-finite values, dense LU, the block-diagonal linear solver
 * of the variational system, SUNDIALS warnings.
 */
#include "gs_internal.h"

/* --------------------------------------------------------------------------
 * Small helpers
 * -------------------------------------------------------------------------- */
int set_err(gs_sim_args* a, int status, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(a->errmsg, sizeof(a->errmsg), fmt, ap);
  va_end(ap);
  a->status = status;
  return status;
}

void record_nonfinite(gs_ud* ud, double t, const char* what, int index, const double* x) {
  int k;
  ud->nf_seen = 1;
  ud->nf_t = t;
  ud->nf_what = what;
  ud->nf_index = index;
  ud->nf_state_index = -1;
  if (x) {
    for (k = 0; k < ud->nx; ++k) {
      if (!isfinite(x[k])) {
        ud->nf_state_index = k;
        break;
      }
    }
  }
}

/* Solve A z = b in place (A column-major n x n, overwritten); partial pivoting. */
int lu_solve(int n, double* A, double* b) {
  int i, j, k, piv;
  for (k = 0; k < n; ++k) {
    double amax = fabs(A[k * n + k]);
    piv = k;
    for (i = k + 1; i < n; ++i) {
      if (fabs(A[k * n + i]) > amax) {
        amax = fabs(A[k * n + i]);
        piv = i;
      }
    }
    if (!(amax > 0.0)) return -1;
    if (piv != k) {
      for (j = 0; j < n; ++j) {
        double tmp = A[j * n + k];
        A[j * n + k] = A[j * n + piv];
        A[j * n + piv] = tmp;
      }
      {
        double tmp = b[k];
        b[k] = b[piv];
        b[piv] = tmp;
      }
    }
    for (i = k + 1; i < n; ++i) {
      double l = A[k * n + i] / A[k * n + k];
      A[k * n + i] = l;
      for (j = k + 1; j < n; ++j) A[j * n + i] -= l * A[j * n + k];
      b[i] -= l * b[k];
    }
  }
  for (k = n - 1; k >= 0; --k) {
    double s = b[k];
    for (j = k + 1; j < n; ++j) s -= A[j * n + k] * b[j];
    b[k] = s / A[k * n + k];
  }
  return 0;
}

/* LU factorisation with partial pivoting of A (column-major n x n, in place);
 * piv[k] is the row swapped with row k.  Returns 0, or -1 if A is singular. */
int lu_factor(int n, double* A, int* piv) {
  int i, j, k, p;
  for (k = 0; k < n; ++k) {
    double amax = fabs(A[(size_t)k * n + k]);
    p = k;
    for (i = k + 1; i < n; ++i) {
      double v = fabs(A[(size_t)k * n + i]);
      if (v > amax) {
        amax = v;
        p = i;
      }
    }
    piv[k] = p;
    if (!(amax > 0.0)) return -1;
    if (p != k)
      for (j = 0; j < n; ++j) {
        double tmp = A[(size_t)j * n + k];
        A[(size_t)j * n + k] = A[(size_t)j * n + p];
        A[(size_t)j * n + p] = tmp;
      }
    {
      double inv = 1.0 / A[(size_t)k * n + k];
      for (i = k + 1; i < n; ++i) A[(size_t)k * n + i] *= inv;
    }
    for (j = k + 1; j < n; ++j) {
      double akj = A[(size_t)j * n + k];
      if (akj != 0.0) {
        double* colj = A + (size_t)j * n;
        const double* colk = A + (size_t)k * n;
        for (i = k + 1; i < n; ++i) colj[i] -= colk[i] * akj;
      }
    }
  }
  return 0;
}

/* Solve with the factors of lu_factor, b overwritten by the solution. */
void lu_apply(int n, const double* LU, const int* piv, double* b) {
  int i, k;
  /* whole-row interchanges were applied to L as well (as in LAPACK's getrf):
   * permute b first, then forward and back substitution */
  for (k = 0; k < n; ++k)
    if (piv[k] != k) {
      double tmp = b[k];
      b[k] = b[piv[k]];
      b[piv[k]] = tmp;
    }
  for (k = 0; k < n; ++k) {
    double bk = b[k];
    if (bk != 0.0) {
      const double* col = LU + (size_t)k * n;
      for (i = k + 1; i < n; ++i) b[i] -= col[i] * bk;
    }
  }
  for (k = n - 1; k >= 0; --k) {
    const double* col = LU + (size_t)k * n;
    double bk = b[k] / col[k];
    b[k] = bk;
    if (bk != 0.0)
      for (i = 0; i < k; ++i) b[i] -= col[i] * bk;
  }
}

/* --------------------------------------------------------------------------
 * Block-diagonal linear solver of the variational equations.
 *
 * With the monodromy on, the solver state is [x; Phi(:,0); ...; Phi(:,nx-1)]
 * (nx + 1 blocks of nx).  The Newton matrix of the augmented system is
 * approximated by blockdiag(I - gamma J, ..., I - gamma J) (the terms
 * d(J Phi)/dx are left out, as a modified Newton iteration may), so one
 * n x n factorisation serves all nx + 1 blocks: O(n^3) per setup and O(n^3)
 * per solve instead of O(n^6) and O(n^4) for the dense (n + n^2)^2 matrix,
 * and O(n^3) memory instead of O(n^4).  CVODE builds I - gamma J in an
 * (n + n^2) x n dense SUNMatrix whose top n x n block cv_jac fills (the
 * rest stays zero); setup factors that block, solve applies it per block.
 * -------------------------------------------------------------------------- */
typedef struct {
  int n, nblk;
  double* lu;
  int* piv;
  long last_flag;
} gs_bdls;

static int bdls_gettype(SUNLinearSolver S) {
  (void)S;
  return GS_SUNLINEARSOLVER_DIRECT;
}
static int bdls_getid(SUNLinearSolver S) {
  (void)S;
  return GS_SUNLINEARSOLVER_CUSTOM;
}
static SUNErrCode bdls_initialize(SUNLinearSolver S) {
  ((gs_bdls*)S->content)->last_flag = 0;
  return SUN_SUCCESS;
}
static int bdls_setup(SUNLinearSolver S, SUNMatrix A) {
  gs_bdls* c = (gs_bdls*)S->content;
  const double* a = SUNDenseMatrix_Data(A);
  size_t ld = (size_t)SUNDenseMatrix_Rows(A);
  int j, n = c->n;
  for (j = 0; j < n; ++j) memcpy(c->lu + (size_t)j * n, a + (size_t)j * ld, sizeof(double) * (size_t)n);
  c->last_flag = lu_factor(n, c->lu, c->piv) ? GS_SUNLS_LUFACT_FAIL : 0;
  return (int)c->last_flag;
}
static int bdls_solve(SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, sunrealtype tol) {
  gs_bdls* c = (gs_bdls*)S->content;
  double* xv = N_VGetArrayPointer(x);
  const double* bv = N_VGetArrayPointer(b);
  int k, n = c->n;
  (void)A;
  (void)tol;
  if (xv != bv) memcpy(xv, bv, sizeof(double) * (size_t)n * (size_t)c->nblk);
  for (k = 0; k < c->nblk; ++k) lu_apply(n, c->lu, c->piv, xv + (size_t)k * n);
  c->last_flag = 0;
  return 0;
}
static sunindextype bdls_lastflag(SUNLinearSolver S) { return (sunindextype)((gs_bdls*)S->content)->last_flag; }
static SUNErrCode bdls_space(SUNLinearSolver S, long int* lrw, long int* liw) {
  gs_bdls* c = (gs_bdls*)S->content;
  *lrw = (long)c->n * c->n;
  *liw = c->n;
  return SUN_SUCCESS;
}
static SUNErrCode bdls_free(SUNLinearSolver S) {
  if (!S) return SUN_SUCCESS;
  if (S->content) {
    gs_bdls* c = (gs_bdls*)S->content;
    free(c->lu);
    free(c->piv);
    free(c);
    S->content = NULL;
  }
  SUNLinSolFreeEmpty(S);
  return SUN_SUCCESS;
}

/* A block-diagonal solver for nblk blocks of size n (NULL when out of memory). */
SUNLinearSolver bdls_new(int n, int nblk, SUNContext ctx) {
  SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
  gs_bdls* c;
  if (!S) return NULL;
  c = (gs_bdls*)calloc(1, sizeof(gs_bdls));
  if (c) {
    c->n = n;
    c->nblk = nblk;
    c->lu = (double*)calloc((size_t)n * n, sizeof(double));
    c->piv = (int*)calloc((size_t)n, sizeof(int));
  }
  S->content = c;
  S->ops->gettype = bdls_gettype;
  S->ops->getid = bdls_getid;
  S->ops->initialize = bdls_initialize;
  S->ops->setup = bdls_setup;
  S->ops->solve = bdls_solve;
  S->ops->lastflag = bdls_lastflag;
  S->ops->space = bdls_space;
  S->ops->free = bdls_free;
  if (!c || !c->lu || !c->piv) {
    bdls_free(S);
    return NULL;
  }
  return S;
}

/* Last line written to the SUNDIALS warning stream, as "; last SUNDIALS
 * warning: ..." (or "" if none); the stream is then rewound. */
void last_warning(FILE* fp, char** bufp, size_t* len, char* out, int outlen) {
  const char *s, *e, *p, *buf;
  out[0] = '\0';
  if (!fp) return;
  fflush(fp); /* updates *bufp and *len */
  buf = *bufp;
  if (!buf || *len == 0) return;
  e = buf + *len;
  while (e > buf && (e[-1] == '\n' || e[-1] == ' ')) --e;
  s = e;
  while (s > buf && s[-1] != '\n') --s;
  /* drop the "[WARNING][rank 0][file:line]" prefix, keep "[Function] text" */
  p = strstr(s, "] ");
  if (p && p < e) {
    while (p > s && *p != '[') --p;
    s = p;
  }
  snprintf(out, (size_t)outlen, "; last SUNDIALS warning: %.*s", (int)(e - s), s);
  rewind(fp);
}
