/*
 * gs_ramp.c -- part of the gearsym driver (gs_driver.c; shared declarations in gs_internal.h):
 * the speed ramp (gs_ramp in gs_driver.h), in one place.  Everything that differs from a
 * run at constant speed is here: the time and parameters the generated functions get
 * (model_args in gs_internal.h calls ramp_model_args), the clock of the schedules and
 * its inverse (the exact breakpoints), the time derivative of the switching functions
 * along the ramp, and the checks of a call's ramp.
 *
 * With Omega(t) = speed0 + rate (t - t0), the phase of the speed is
 *     theta(t) = speed0 t0 + int_t0^t Omega(u) du = speed0 tau(t),
 *     tau(t)   = t + rate (t - t0)^2 / (2 speed0)            (the phase time),
 * and the generated functions are called at s(t) = theta(t) / Omega(t) with
 * p[index] = Omega(t): a time function h(Omega t, Omega) of the model becomes
 * h(theta(t), Omega(t)).  A schedule of period P_k(p) = C_k / speed (the caller checks
 * the proportionality) has the phase s / P_k(Omega(t)) = theta(t) / C_k = tau(t) /
 * P_k(speed0): the driver evaluates the schedule table at speed0 and runs the schedules
 * on tau(t).  Its breakpoints tau(t_b) = tau_b are the roots of the quadratic
 *     rate/(2 speed0) d^2 + d - (tau_b - t0) = 0,  d = t_b - t0,
 * taken as d = 2 D / (1 + sqrt(1 + 2 rate D / speed0)), D = tau_b - t0 (no cancellation;
 * the square root is Omega(t_b) / speed0).
 */
#include "gs_internal.h"

double ramp_speed(const gs_ramp* r, double t) { return r->speed0 + r->rate * (t - r->t0); }

double ramp_phase_time(const gs_ramp* r, double t) {
  double d = t - r->t0;
  return t + 0.5 * (r->rate / r->speed0) * d * d;
}

/* The time t >= t0 at which the phase time reaches tau (INFINITY if the speed reaches 0
 * first: a ramp down that never gets there). */
double ramp_time_at_phase(const gs_ramp* r, double tau) {
  double D = tau - r->t0, q = 1.0 + 2.0 * (r->rate / r->speed0) * D;
  if (!(q >= 0.0)) return INFINITY;
  return r->t0 + 2.0 * D / (1.0 + sqrt(q));
}

const double* ramp_model_args(gs_ud* ud, double t, double* s) {
  double w = ramp_speed(&ud->ramp, t);
  ud->pw[ud->ramp.index] = w;
  *s = ud->ramp.speed0 * ramp_phase_time(&ud->ramp, t) / w;
  return ud->pw;
}

/* The parameters the schedule table (gs_sched) is evaluated at: p, or with a ramp p with the
 * speed speed0 (the periods of its phase time tau). */
const double* ramp_schedule_params(gs_ud* ud, const double* p) {
  if (!ud->ramp.on) return p;
  ud->pw[ud->ramp.index] = ud->ramp.speed0;
  return ud->pw;
}

/* The schedules' clock at time t: tau(t) with a ramp, t without. */
double sched_clock(const gs_sched_data* sd, double t) {
  return (sd->ramp && sd->ramp->on) ? ramp_phase_time(sd->ramp, t) : t;
}

/* The time at which the schedules' clock reads c. */
double sched_time_at_clock(const gs_sched_data* sd, double c) {
  return (sd->ramp && sd->ramp->on) ? ramp_time_at_phase(sd->ramp, c) : c;
}

/* Check the call's ramp and make it the workspace's (ud->ramp, ud->pw).  The speed must
 * keep its sign over [a->t0, a->t_end] (then tau is increasing there, dtau/dt = Omega /
 * speed0 > 0, and ramp_time_at_phase its inverse).  Returns 0, or GS_ERR_INPUT with the
 * message in a. */
int ramp_setup(gs_ud* ud, gs_sim_args* a) {
  const gs_ramp* r = &a->ramp;
  double w0, w1;
  ud->ramp.on = 0;
  if (!r->on) return 0;
  if (r->index < 0 || r->index >= ud->np)
    return set_err(a, GS_ERR_INPUT, "speed ramp: parameter index %d outside [0, %d)", r->index, ud->np);
  if (!isfinite(r->t0) || !isfinite(r->speed0) || !isfinite(r->rate) || r->speed0 == 0.0)
    return set_err(a, GS_ERR_INPUT, "speed ramp: t0 = %g, speed0 = %g, rate = %g must be finite, speed0 nonzero",
                   r->t0, r->speed0, r->rate);
  w0 = ramp_speed(r, a->t0);
  w1 = ramp_speed(r, a->t_end);
  if (!(w0 * r->speed0 > 0.0) || !(w1 * r->speed0 > 0.0))
    return set_err(a, GS_ERR_INPUT,
                   "speed ramp: the speed goes from %g to %g over the run and must keep the sign of speed0 = %g", w0,
                   w1, r->speed0);
  if (a->want_monodromy || a->n_sens > 0)
    return set_err(a, GS_ERR_INPUT, "a speed ramp runs without variational equations (monodromy, sensitivities)");
  ud->ramp = *r;
  if (ud->np) memcpy(ud->pw, a->p, sizeof(double) * (size_t)ud->np);
  return 0;
}

/* d g / dt of the switching functions at (t, x) along the time-dependence of the model:
 * gs_swt, and with a ramp the total derivative of g(s(t), x, p(Omega(t))),
 *     dg/dt = g_s + rate (g_Omega - (s / Omega) g_s)
 * (for g = G(Omega s, Omega): g_s = Omega G_1, g_Omega = s G_1 + G_2, so that
 * dg/dt = Omega G_1 + rate G_2).  G_2 needs gs_swp; a model built without it gets
 * g_s alone, exact when no switching function depends on the speed but through the
 * phase (the caller builds with gs_swp otherwise). */
int eval_swdt(gs_ud* ud, double t, const double* x, double* out) {
  int j, nsw = ud->nsw;
  double s, w;
  const double* in[3];
  if (eval_swfn(ud, &ud->swt, t, x, out)) return -1;
  if (!ud->ramp.on || !ud->swp.present || nsw == 0) return 0;
  in[0] = &s;
  in[1] = x;
  in[2] = ramp_model_args(ud, t, &s);
  if (gs_call(ud, &ud->swp, in, 3, ud->Gp)) return -1;
  w = ud->pw[ud->ramp.index];
  for (j = 0; j < nsw; ++j) {
    double gw = ud->Gp[(size_t)ud->ramp.index * nsw + j];
    out[j] += ud->ramp.rate * (gw - (s / w) * out[j]);
  }
  return 0;
}
