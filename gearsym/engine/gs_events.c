/*
 * gs_events.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * schedules (breakpoints) and events (logging, saltation, switching surfaces).
 */
#include "gs_internal.h"

/* --------------------------------------------------------------------------
 * Schedules
 * -------------------------------------------------------------------------- */

/* Next breakpoint strictly after t + tiny for schedule k: the next (n + c_i) P_k on the
 * schedules' clock (t, or a speed ramp's phase time: sched_clock, gs_ramp.c), as a time. */
static double sched_next_break(const gs_sched_data* sd, int k, double t, double tiny) {
  double P = sd->s[sd->off[k]];
  const double* c = sd->s + sd->off[k] + 1;
  double n = floor(sched_clock(sd, t) / P), best = INFINITY;
  int cyc, i;
  for (cyc = -1; cyc <= 1; ++cyc) {
    for (i = 0; i < sd->nb[k]; ++i) {
      double tb = sched_time_at_clock(sd, (n + cyc + c[i]) * P);
      if (tb > t + tiny && tb < best) best = tb;
    }
  }
  if (!(best < INFINITY)) best = sched_time_at_clock(sd, (n + 2.0) * P); /* unreachable with c_0 = 0 */
  return best;
}

void sched_mode_at(const gs_sched_data* sd, int k, double t, double* n_out, double* seg_out) {
  double P = sd->s[sd->off[k]];
  const double* c = sd->s + sd->off[k] + 1;
  double u = sched_clock(sd, t) / P, n = floor(u), frac = u - n;
  int i, seg = 0;
  for (i = 0; i < sd->nb[k]; ++i)
    if (c[i] <= frac) seg = i;
  *n_out = n;
  *seg_out = (double)seg;
}

/* Interval starting at t: returns its end tb (<= t_end), sets the schedule
 * part of the mode from the interval midpoint, *is_break = 1 if tb is a
 * scheduled breakpoint before t_end. */
double next_interval(const gs_sched_data* sd, gs_ud* ud, double t, double t_end, double tiny, int* is_break) {
  double tb = t_end, mid;
  int k;
  *is_break = 0;
  for (k = 0; k < sd->nsched; ++k) {
    double cand = sched_next_break(sd, k, t, tiny);
    if (cand < tb - tiny) {
      tb = cand;
      *is_break = 1;
    }
  }
  mid = 0.5 * (t + tb);
  for (k = 0; k < sd->nsched; ++k)
    sched_mode_at(sd, k, mid, &ud->m[ud->nsw + 2 * k], &ud->m[ud->nsw + 2 * k + 1]);
  return tb;
}

/* d t_b / d p of the breakpoint t_b reached at time tb (within tiny): t_b =
 * (n + c_i) P_k, so dt_b/dp = (n + c_i) dP_k/dp + P_k dc_i/dp, from the
 * schedule Jacobian sp (nsched_total x np, column-major; gs_schedp).  The
 * first schedule with a break at tb is used.  Returns 0, or -1 if none. */
int sched_break_dtdp(const gs_sched_data* sd, int nsched_total, const double* sp, int np, double tb,
                            double tiny, double* dtdp) {
  int k, i, cyc, q;
  for (k = 0; k < sd->nsched; ++k) {
    double P = sd->s[sd->off[k]];
    const double* c = sd->s + sd->off[k] + 1;
    double n = floor(tb / P);
    for (cyc = -1; cyc <= 1; ++cyc)
      for (i = 0; i < sd->nb[k]; ++i) {
        double u = n + cyc + c[i];
        if (fabs(u * P - tb) > tiny) continue;
        for (q = 0; q < np; ++q) {
          const double* col = sp + (size_t)q * nsched_total;
          dtdp[q] = u * col[sd->off[k]] + P * col[sd->off[k] + 1 + i];
        }
        return 0;
      }
  }
  return -1;
}

/* --------------------------------------------------------------------------
 * Events
 * -------------------------------------------------------------------------- */

static int ev_record(gs_evlog* L, double t, int j, int dir, double speed) {
  gs_sim_args* a = L->a;
  double win = L->storm_window > 0.0 ? L->storm_window : 1e-9 * fmax(1.0, fabs(t));
  int k = a->n_events;
  if (k < a->max_events_out) {
    if (a->ev_t) a->ev_t[k] = t;
    if (a->ev_surface) a->ev_surface[k] = j;
    if (a->ev_dir) a->ev_dir[k] = dir;
    if (a->ev_speed) a->ev_speed[k] = speed;
  }
  a->n_events = k + 1;
  if (k > 0 && fabs(t - L->last_t) <= win)
    L->storm_count++;
  else
    L->storm_count = 1;
  L->last_t = t;
  if ((long)a->n_events > L->max_events)
    return set_err(a, GS_ERR_MAX_EVENTS, "more than max_events=%ld events (last: surface %d at t=%.17g)",
                   L->max_events, j, t);
  if (L->storm_count > L->storm_events)
    return set_err(a, GS_ERR_EVENT_STORM,
                   "event storm: %d events within %.3g of each other, last on switching surface %d at t=%.17g "
                   "(chattering / Zeno behaviour or a sliding motion on the surface)",
                   L->storm_count, win, j, t);
  return 0;
}

/* Phi <- Salt Phi with Salt = I + (f_a - f_b) G_j^T / (G_j . f_b + gt_j), and the
 * sensitivities S <- Salt S + (f_a - f_b) gp_j / d with gp_j = (dg_j/dp) D
 * (the event-time term; see the top of gs_driver.c).  ud->G and ud->gt hold
 * dg/dx and dg/dt at (t, x). */
static int apply_saltation(gs_ud* ud, gs_sim_args* a, double t, double* yv, int j, const double* f_b,
                           const double* f_a) {
  int nx = ud->nx, nsw = ud->nsw, np = ud->np, nphi = ud->mono * ud->nd, c, k;
  double d = ud->gt[j];
  double* Phi = yv + nx;
  if (ud->ns && eval_swfn(ud, &ud->swp, t, yv, ud->Gp))
    return set_err(a, GS_ERR_NONFINITE, "gs_swp failed at the event t=%.17g", t);
  for (k = 0; k < nx; ++k) d += ud->G[(size_t)k * nsw + j] * f_b[k];
  if (!(d != 0.0) || !isfinite(d))
    return set_err(a, GS_ERR_NONFINITE,
                   "grazing contact on switching surface %d at t=%.17g: dg/dt = %g along the flow, the saltation "
                   "matrix of the monodromy is undefined",
                   j, t, d);
  for (c = 0; c < ud->nvc; ++c) {
    double* col = Phi + (size_t)c * nx;
    double wv = 0.0;
    for (k = 0; k < nx; ++k) wv += ud->G[(size_t)k * nsw + j] * col[k];
    if (c >= nphi) { /* sensitivity column s: + gp_j = sum_q dg_j/dp_q D(q, s) */
      const double* dir = ud->sdir + (size_t)(c - nphi) * np;
      for (k = 0; k < np; ++k) wv += ud->Gp[(size_t)k * nsw + j] * dir[k];
    }
    wv /= d;
    for (k = 0; k < nx; ++k) col[k] += (f_a[k] - f_b[k]) * wv;
  }
  if (!all_finite(Phi, nx * ud->nvc, NULL))
    return set_err(a, GS_ERR_NONFINITE, "non-finite monodromy after the saltation at surface %d, t=%.17g", j, t);
  return 0;
}

/* The saltation matrix on IDA: the differential states x_d follow the underlying
 * ODE x_d' = f_m(t, x_d) (the algebraic variables solved for in each mode), so the
 * differential rows of the nd variational columns get
 *   S_d <- S_d + (f_a - f_b) (G_d . S_d) / (G_d . f_b + gt_j)
 * and those of the sensitivity of direction s the event-time term as on CVODE
 * (apply_saltation), + (f_a - f_b) gp_j / d with gp_j = (dg_j/dp) D(:, s),
 * with f_b, f_a the consistent derivatives in the old and new modes
 * (eval_xdot_dae); the algebraic rows are made consistent again by IDACalcIC
 * after the re-initialisation.  Switching functions do not depend on algebraic
 * variables (the spec layer allows those in [outputs] only). */
static int ida_saltation(gs_ud* ud, gs_sim_args* a, double t, double* yv, int j, int side) {
  int nx = ud->nx, nd = ud->nd, nsw = ud->nsw, np = ud->np, nphi = ud->mono * nd, c, k;
  double d = ud->gt[j];
  double* fb = ud->f2;
  double* fa = ud->f3;
  memcpy(ud->m_alt, ud->m, sizeof(double) * (size_t)ud->nm);
  ud->m_alt[j] = (double)side;
  memset(fb, 0, sizeof(double) * (size_t)nx);
  memset(fa, 0, sizeof(double) * (size_t)nx);
  if (eval_xdot(ud, t, yv, ud->m, fb, fb) || eval_xdot(ud, t, yv, ud->m_alt, fb, fa))
    return set_err(a, GS_ERR_NONFINITE, "consistent derivatives at the event t=%.17g could not be computed", t);
  if (ud->ns && eval_swfn(ud, &ud->swp, t, yv, ud->Gp))
    return set_err(a, GS_ERR_NONFINITE, "gs_swp failed at the event t=%.17g", t);
  for (k = 0; k < nd; ++k) d += ud->G[(size_t)k * nsw + j] * fb[k];
  if (!(d != 0.0) || !isfinite(d))
    return set_err(a, GS_ERR_NONFINITE,
                   "grazing contact on switching surface %d at t=%.17g: dg/dt = %g along the flow, the saltation "
                   "matrix of the monodromy is undefined",
                   j, t, d);
  for (c = 0; c < ud->nvc; ++c) {
    double* col = yv + (size_t)(c + 1) * nx;
    double wv = 0.0;
    for (k = 0; k < nd; ++k) wv += ud->G[(size_t)k * nsw + j] * col[k];
    if (c >= nphi) { /* sensitivity column s: + gp_j = sum_q dg_j/dp_q D(q, s) */
      const double* dir = ud->sdir + (size_t)(c - nphi) * np;
      for (k = 0; k < np; ++k) wv += ud->Gp[(size_t)k * nsw + j] * dir[k];
    }
    wv /= d;
    for (k = 0; k < nd; ++k) col[k] += (fa[k] - fb[k]) * wv;
  }
  if (!all_finite(yv + nx, nx * ud->nvc, NULL))
    return set_err(a, GS_ERR_NONFINITE, "non-finite monodromy after the saltation at surface %d, t=%.17g", j, t);
  return 0;
}

/* Switch surface j to side `side` (+1/-1) at (t, y), recording the event and,
 * with monodromy, applying the saltation matrix.  xdot_old: flow before. */
int switch_surface(gs_ud* ud, gs_evlog* L, double t, double* yv, int j, int side, double speed) {
  int rc = ev_record(L, t, j, side, speed);
  if (rc) return rc;
  if (ud->nvc && ud->use_ida) {
    rc = ida_saltation(ud, L->a, t, yv, j, side);
    if (rc) return rc;
  } else if (ud->nvc) {
    memcpy(ud->m_alt, ud->m, sizeof(double) * (size_t)ud->nm);
    ud->m_alt[j] = (double)side;
    if (eval_rhs(ud, t, yv, ud->m, ud->f) || eval_rhs(ud, t, yv, ud->m_alt, ud->f2))
      return set_err(L->a, GS_ERR_NONFINITE, "right-hand side evaluation failed at the event t=%.17g", t);
    rc = apply_saltation(ud, L->a, t, yv, j, ud->f, ud->f2);
    if (rc) return rc;
  }
  ud->m[j] = (double)side;
  return 0;
}

/* Surfaces sitting exactly on g_j = 0 (the root finder deactivates those at a
 * restart and would miss an immediate departure): decide from the flow in the
 * current mode whether the trajectory leaves to the other side; if so that is
 * another event at the same time (a surface attracting from both sides keeps
 * firing until the event-storm limit).  silent > 0 (start without sigma0):
 * that many side choices are made without recording an event.  xd_guess:
 * xdot guess for implicit models. */
int resolve_zero_surfaces(gs_ud* ud, gs_evlog* L, double t, double* yv, const double* xd_guess,
                                 int silent) {
  int j, k, nsw = ud->nsw, nx = ud->nx;
  long long iter, max_iter = (long long)nsw * ((long long)L->storm_events + 2) + 2; /* (storm_events: the caller's) */
  if (nsw == 0) return 0;
  for (iter = 0; iter < max_iter; ++iter) {
    int fired = 0;
    if (eval_swfn(ud, &ud->sw, t, yv, ud->g)) return set_err(L->a, GS_ERR_NONFINITE, "gs_sw failed at t=%.17g", t);
    for (j = 0; j < nsw; ++j)
      if (ud->g[j] == 0.0) break;
    if (j == nsw) return 0;
    if (eval_swfn(ud, &ud->swx, t, yv, ud->G) || eval_swdt(ud, t, yv, ud->gt) ||
        eval_xdot(ud, t, yv, ud->m, xd_guess, ud->f3))
      return set_err(L->a, GS_ERR_NONFINITE, "model evaluation failed on a switching surface at t=%.17g", t);
    memcpy(ud->f2, ud->f3, sizeof(double) * (size_t)nx); /* flow in the current mode */
    for (j = 0; j < nsw; ++j) {
      double d;
      if (ud->g[j] != 0.0) continue;
      d = ud->gt[j];
      for (k = 0; k < nx; ++k) d += ud->G[(size_t)k * nsw + j] * ud->f2[k];
      if (d * ud->m[j] < 0.0) {
        int side = d > 0.0 ? 1 : -1;
        if (silent > 0) {
          ud->m[j] = (double)side;
          --silent;
        } else {
          int rc = switch_surface(ud, L, t, yv, j, side, d);
          if (rc) return rc;
        }
        fired = 1;
        break; /* re-evaluate the flow in the new mode */
      }
    }
    if (!fired) return 0;
  }
  return set_err(L->a, GS_ERR_EVENT_STORM, "switching surfaces keep flipping at t=%.17g (sliding motion?)", t);
}
