/*
 * gs_batch.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * many initial states over one time span in one call (gs_simulate_batch).
 *
 * A basin of attraction integrates thousands of initial states over the same few forcing
 * periods, checks where they landed and continues the ones that have not settled.  One
 * ctypes call per state costs ~30 us of Python (argument struct, buffers, result object)
 * against ~60 us of C per forcing period of the benchmark oscillator; this entry runs
 * gs_simulate_ws() once per state from a template gs_sim_args, in C, and returns every
 * state's output grid, end state, surface sides, status and counts.
 */
#include "gs_internal.h"

/* 1 if a stopping signal's byte (SIGINT; SIGTERM when the mask says so) is on the interrupt
 * pipe.  gs_simulate_ws() reads the pipe every GS_POLL_EVERY right-hand sides of one run and
 * empties it at the start of each run, so a short run might never see a Ctrl-C: the batch
 * reads it between its runs. */
static int batch_interrupted(const gs_sim_args* a) {
  unsigned char buf[64];
  ssize_t n, i;
  int hit = 0;
  if (!a->check_interrupt || a->interrupt_fd < 0) return 0;
  for (;;) {
    n = read(a->interrupt_fd, buf, sizeof(buf));
    if (n > 0) {
      for (i = 0; i < n; ++i)
        if ((buf[i] == (unsigned char)SIGINT && (a->check_interrupt & GS_INTR_SIGINT)) ||
            (buf[i] == (unsigned char)SIGTERM && (a->check_interrupt & GS_INTR_SIGTERM)))
          hit = 1;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break;
  }
  return hit;
}

int gs_simulate_batch(gs_workspace* ws, gs_sim_args* a, int n, const double* x0s, const double* sigma0s,
                      double* y_outs, double* x_finals, double* sigma_finals, int* status, long* counts) {
  const double *x0_keep, *sigma0_keep;
  double *y_keep, *xf_keep, *sf_keep;
  long tot_events = 0, tot_steps = 0, tot_rhs = 0, tot_jac = 0, tot_roots = 0, tot_breaks = 0, tot_reinit = 0;
  int i, j, nx, nsw, n_out, rc = GS_OK, first_fail = -1, info[8];
  char first_msg[sizeof(a->errmsg)];

  if (!a) return GS_ERR_INPUT;
  a->errmsg[0] = '\0';
  a->status = GS_OK;
  if (!ws) return set_err(a, GS_ERR_INPUT, "no workspace");
  if (!gs_model_info || gs_model_info(info, 8) < 6) return set_err(a, GS_ERR_INPUT, "gs_model_info failed");
  nx = info[0];
  nsw = info[3];
  n_out = a->n_out;
  if (n < 0 || (n > 0 && (!x0s || !x_finals || !status || !counts)))
    return set_err(a, GS_ERR_INPUT, "batch of %d states: x0s, x_finals, status and counts must not be NULL", n);
  if (n_out > 0 && !y_outs) return set_err(a, GS_ERR_INPUT, "n_out = %d but y_outs is NULL", n_out);
  if (a->want_monodromy || a->n_sens > 0)
    return set_err(a, GS_ERR_INPUT, "a batch integrates states only (no monodromy, no sensitivities)");
  x0_keep = a->x0;
  sigma0_keep = a->sigma0;
  y_keep = a->y_out;
  xf_keep = a->x_final;
  sf_keep = a->sigma_final;
  first_msg[0] = '\0';
  for (i = 0; i < n; ++i) {
    if (batch_interrupted(a)) {
      rc = GS_ERR_INTERRUPTED;
      break;
    }
    a->x0 = x0s + (size_t)i * nx;
    a->sigma0 = sigma0s ? sigma0s + (size_t)i * nsw : NULL;
    a->y_out = n_out > 0 ? y_outs + (size_t)i * n_out * nx : NULL;
    a->x_final = x_finals + (size_t)i * nx;
    a->sigma_final = sigma_finals ? sigma_finals + (size_t)i * nsw : NULL;
    status[i] = gs_simulate_ws(ws, a);
    counts[3 * i] = a->n_events;
    counts[3 * i + 1] = a->n_steps;
    counts[3 * i + 2] = a->n_rhs;
    tot_events += a->n_events;
    tot_steps += a->n_steps;
    tot_rhs += a->n_rhs;
    tot_jac += a->n_jac;
    tot_roots += a->n_root_evals;
    tot_breaks += a->n_breaks;
    tot_reinit += a->n_reinit;
    if (status[i] == GS_ERR_INTERRUPTED) {
      rc = GS_ERR_INTERRUPTED;
      ++i;
      break;
    }
    if (status[i] != GS_OK && first_fail < 0) {
      first_fail = i;
      snprintf(first_msg, sizeof(first_msg), "state %d: %s", i, a->errmsg);
    }
  }
  for (j = i; j < n; ++j) { /* not run (interrupted) */
    status[j] = GS_ERR_INTERRUPTED;
    counts[3 * j] = counts[3 * j + 1] = counts[3 * j + 2] = 0;
  }
  a->x0 = x0_keep;
  a->sigma0 = sigma0_keep;
  a->y_out = y_keep;
  a->x_final = xf_keep;
  a->sigma_final = sf_keep;
  a->n_events = tot_events > 2147483647L ? 2147483647 : (int)tot_events;
  a->n_steps = tot_steps;
  a->n_rhs = tot_rhs;
  a->n_jac = tot_jac;
  a->n_root_evals = tot_roots;
  a->n_breaks = tot_breaks;
  a->n_reinit = tot_reinit;
  if (rc == GS_ERR_INTERRUPTED) return set_err(a, GS_ERR_INTERRUPTED, "interrupted after %d of %d states", i, n);
  a->status = GS_OK;
  snprintf(a->errmsg, sizeof(a->errmsg), "%s", first_msg); /* the first failed state's message, if any */
  return GS_OK;
}
