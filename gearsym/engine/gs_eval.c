/*
 * gs_eval.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * evaluating the generated functions without integrating (forcing period, outputs, switching
 * functions, right-hand side, Jacobian).
 */
#include "gs_internal.h"

/* --------------------------------------------------------------------------
 * Evaluating the generated functions from the caller (no integration): the
 * forcing period, and switching functions, outputs, right-hand side,
 * Jacobian or the model as the ODE of its differential states at many points with the mode the driver would use there (sides
 * from the signs of g unless given, schedule segment from t).  Lets Python
 * avoid CasADi's own Python calls on hot paths.
 * -------------------------------------------------------------------------- */
static int ws_ready(gs_workspace* ws, char* msg, int len) {
  gs_sim_args a;
  if (!ws) {
    snprintf(msg, (size_t)len, "no workspace");
    return -1;
  }
  if (ws->ready) return 0;
  memset(&a, 0, sizeof(a));
  if (ws_model_setup(ws, &a)) {
    snprintf(msg, (size_t)len, "%s", a.errmsg);
    return -1;
  }
  return 0;
}

int gs_eval_period(gs_workspace* ws, const double* p, double* T, char* msg, int len) {
  gs_ud* ud;
  const double* in[1];
  if (ws_ready(ws, msg, len)) return -1;
  ud = &ws->U;
  if (!ud->period.present) {
    *T = NAN;
    return 0; /* no forcing period (an autonomous or test model) */
  }
  in[0] = ud->np ? p : ud->dummy;
  if (gs_call(ud, &ud->period, in, 1, T)) {
    snprintf(msg, (size_t)len, "gs_period failed");
    return -1;
  }
  return 0;
}

int gs_eval_period_grad(gs_workspace* ws, const double* p, double* dT, char* msg, int len) {
  gs_ud* ud;
  const double* in[1];
  if (ws_ready(ws, msg, len)) return -1;
  ud = &ws->U;
  if (!ud->periodp.present) {
    snprintf(msg, (size_t)len, "the compiled model has no gs_periodp (built by an older gearsym; rebuild it)");
    return -1;
  }
  if (ud->np == 0) return 0;
  in[0] = p;
  if (gs_call(ud, &ud->periodp, in, 1, dT)) {
    snprintf(msg, (size_t)len, "gs_periodp failed");
    return -1;
  }
  return 0;
}

int gs_n_outputs(gs_workspace* ws) {
  char msg[256];
  if (ws_ready(ws, msg, (int)sizeof(msg))) return -1;
  return ws->n_out_fn;
}

int gs_n_meshes(gs_workspace* ws) {
  char msg[256];
  if (ws_ready(ws, msg, (int)sizeof(msg))) return -1;
  return ws->n_mesh_fn;
}

/* Schedule part of the mode at time t (n_k, seg_k) from the schedule vector s (on the speed
 * ramp's clock when ud->ramp is on). */
static void sched_modes_at(gs_workspace* ws, const double* s, double t, double* m) {
  gs_ud* ud = &ws->U;
  int k, off = 0;
  for (k = 0; k < ud->nsched; ++k) {
    gs_sched_data sd;
    int nbk = ws->nb[k], zero = 0;
    sd.nsched = 1;
    sd.nb = &nbk;
    sd.off = &zero;
    sd.s = s + off;
    sd.ramp = &ud->ramp;
    sched_mode_at(&sd, 0, t, &m[2 * k], &m[2 * k + 1]);
    off += 1 + nbk;
  }
}

int gs_eval(gs_workspace* ws, int fn, int n, const double* t, const double* x, const double* p, const double* sigma,
            double* out, char* msg, int len) {
  return gs_eval_ramp(ws, fn, n, t, x, p, sigma, NULL, out, msg, len);
}

/* Make `ramp` (NULL: none) the workspace's for one gs_eval_ramp call.  Returns 0 or -1 with a
 * message. */
static int eval_ramp_setup(gs_ud* ud, const double* p, const gs_ramp* ramp, char* msg, int len) {
  ud->ramp.on = 0;
  if (!ramp || !ramp->on) return 0;
  if (ramp->index < 0 || ramp->index >= ud->np || !isfinite(ramp->t0) || !isfinite(ramp->speed0) ||
      !isfinite(ramp->rate) || ramp->speed0 == 0.0) {
    snprintf(msg, (size_t)len, "bad speed ramp (index %d, t0 %g, speed0 %g, rate %g)", ramp->index, ramp->t0,
             ramp->speed0, ramp->rate);
    return -1;
  }
  ud->ramp = *ramp;
  memcpy(ud->pw, p, sizeof(double) * (size_t)ud->np);
  return 0;
}

int gs_eval_ramp(gs_workspace* ws, int fn, int n, const double* t, const double* x, const double* p,
                 const double* sigma, const gs_ramp* ramp, double* out, char* msg, int len) {
  gs_ud* ud;
  int i, j, nx, nsw, nout;
  double* m;
  double* s;
  const double* in[4];
  const gs_fn* f;
  if (ws_ready(ws, msg, len)) return -1;
  ud = &ws->U;
  nx = ud->nx;
  nsw = ud->nsw;
  if (fn == GS_EVAL_SW) {
    f = &ud->sw;
    nout = nsw;
  } else if (fn == GS_EVAL_OUT) {
    f = &ud->out;
    nout = ws->n_out_fn;
  } else if (fn == GS_EVAL_RHS) {
    f = &ud->rhs;
    nout = nx;
  } else if (fn == GS_EVAL_JAC) {
    f = &ud->jac;
    nout = nx * nx;
  } else if (fn == GS_EVAL_MODE) {
    f = NULL;
    nout = ud->nm;
  } else if (fn == GS_EVAL_MESH) {
    f = &ud->mesh;
    nout = ws->n_mesh_fn;
  } else if (fn == GS_EVAL_DAE) {
    f = ud->implicit ? &ud->res : &ud->rhs;
    nout = nx + ud->nd;
  } else if (fn == GS_EVAL_DAE_JAC) {
    f = ud->implicit ? &ud->resjac : &ud->jac;
    nout = nx * ud->nd;
  } else {
    snprintf(msg, (size_t)len, "unknown function code %d", fn);
    return -1;
  }
  if (f && !f->present) {
    snprintf(msg, (size_t)len, "the compiled model has no %s", f->name ? f->name : "such function");
    return -1;
  }
  if (n < 0 || !t || !x || (ud->np > 0 && !p) || (nout > 0 && !out)) {
    snprintf(msg, (size_t)len, "bad arguments");
    return -1;
  }
  ud->p = p; /* eval_swfn reads the parameters from ud */
  if (eval_ramp_setup(ud, p, ramp, msg, len)) return -1;
  s = ws->sched_s;
  if (ws->nsched_total > 0) {
    in[0] = ramp_schedule_params(ud, ud->np ? p : ud->dummy);
    if (gs_call(ud, &ud->sched, in, 1, s)) {
      snprintf(msg, (size_t)len, "gs_sched failed");
      ud->ramp.on = 0;
      return -1;
    }
  }
  m = ud->m_alt;
  for (i = 0; i < n; ++i) {
    const double* xi = x + (size_t)i * nx;
    double ti = t[i], si;
    if (fn == GS_EVAL_SW) {
      if (eval_swfn(ud, &ud->sw, ti, xi, out + (size_t)i * nsw)) goto fail;
      continue;
    }
    /* mode at (t_i, x_i): sides given or from the signs of g, schedule segment from t */
    if (nsw > 0) {
      if (sigma) {
        for (j = 0; j < nsw; ++j) m[j] = sigma[(size_t)i * nsw + j];
      } else {
        if (eval_swfn(ud, &ud->sw, ti, xi, ud->g)) goto fail;
        for (j = 0; j < nsw; ++j) m[j] = ud->g[j] >= 0.0 ? 1.0 : -1.0;
      }
    }
    sched_modes_at(ws, s, ti, m + nsw);
    if (fn == GS_EVAL_MODE) {
      memcpy(out + (size_t)i * nout, m, sizeof(double) * (size_t)nout);
      continue;
    }
    if (fn == GS_EVAL_DAE || fn == GS_EVAL_DAE_JAC) {
      if (eval_dae_point(ud, ti, xi, m, out + (size_t)i * nout, fn == GS_EVAL_DAE_JAC)) goto fail;
      continue;
    }
    in[2] = model_args(ud, ti, &si); /* (t_i, p), or the speed ramp's (gs_ramp.c) */
    in[0] = &si;
    in[1] = xi;
    in[3] = ud->nm ? m : ud->dummy;
    if (gs_call(ud, f, in, 4, out + (size_t)i * nout)) goto fail;
  }
  ud->ramp.on = 0;
  return 0;
fail:
  ud->ramp.on = 0;
  snprintf(msg, (size_t)len, "evaluation of %s failed at point %d%s", f ? f->name : "the mode", i,
           fn == GS_EVAL_DAE || fn == GS_EVAL_DAE_JAC ? " (solving for the derivatives and algebraic variables)" : "");
  return -1;
}
