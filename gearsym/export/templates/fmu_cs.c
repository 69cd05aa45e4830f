/*
 * fmu_cs.c -- FMI 2.0 Co-Simulation entry points of the gearsym FMU runtime.
 *
 * fmi2DoStep integrates the communication step [t, t + h] with gearsym's own driver
 * (gs_simulate_ws of gs_driver.c, compiled into this FMU with the model): SUNDIALS
 * CVODE (IDA for implicit models) with root finding on the switching functions, the
 * mode switch of gearsym's rule at every crossing (a surface disarmed until the
 * trajectory crosses back, surfaces exactly at zero resolved along the flow, the event
 * storm limit), exact stops at scheduled breakpoints -- the events are handled inside
 * the step exactly as System.simulate handles them.  Each step starts from the state
 * and the side of every surface the previous one ended with; the integrator and its
 * work arrays are kept in the instance's workspace and re-initialised (CVodeReInit).
 *
 * Solver settings: the scene's method (gearsym.integrators); rtol = the tolerance of
 * fmi2SetupExperiment, else the scene's rtol; atol = rtol * nominal (the scene's
 * atol / rtol ratio, as the nominals of the states say); the largest internal step is
 * an eighth of the forcing period (T / 8, as System.simulate); the scene's
 * max_steps per step (0: the driver's default).  Tunable parameters may change between
 * steps.  No inputs: the output derivatives and input derivatives are not supported,
 * and a step is never asynchronous.
 */
#include <float.h>
#include <math.h>
#include <string.h>

#include "fmu_internal.h"

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  gsx_inst* c = (gsx_inst*)comp;
  gs_sim_args a;
  double T = NAN, ratio = GSX_DEFAULT_ATOL / GSX_DEFAULT_RTOL;
  int rc, j;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (!c) return fmi2Error;
  if (!c->cs) return gsx_fail(c, "fmi2DoStep: this instance is Model Exchange%s", "");
  if (c->mode != M_STEP) return gsx_fail(c, "fmi2DoStep: not initialised, terminated or after an error%s", "");
  if (!isfinite(t) || !isfinite(h) || h < 0.0) return gsx_fail(c, "fmi2DoStep: bad communication step%s", "");
  if (fabs(t - c->t) > 1e-9 * fmax(1.0, fabs(c->t))) {
    gsx_log(c, fmi2Error, "logStatusError", "fmi2DoStep: the communication point %.17g is not the time %.17g reached",
            t, c->t);
    return fmi2Error;
  }
  if (h == 0.0) return fmi2OK;
  if (gsx_period(c, &T)) return gsx_fail(c, "fmi2DoStep: the forcing period is not finite%s", "");
  memset(&a, 0, sizeof(a));
  a.method = gsx_method_code[GSX_DEFAULT_METHOD];
  a.nonlinear = gsx_method_nonlinear[GSX_DEFAULT_METHOD];
  a.rtol = c->rtol;
  a.atol = c->rtol * ratio;
  a.t0 = t;
  a.t_end = t + h;
  a.x0 = c->x;
  a.p = gsx_pp(c);
  a.sigma0 = GSX_NSW ? c->m : NULL;
  a.max_steps = GSX_DEFAULT_MAX_STEPS;
  a.max_step = (isfinite(T) && T > 0.0) ? T / 8.0 : 0.0;
  a.x_final = c->xf;
  a.sigma_final = GSX_NSW ? c->sf : NULL;
  rc = gs_simulate_ws(c->ws, &a);
  if (rc != GS_OK) {
    gsx_log(c, fmi2Error, "logStatusError", "fmi2DoStep from t=%.17g to %.17g: %s", t, t + h, a.errmsg);
    c->mode = M_ERROR;
    return fmi2Error;
  }
  memcpy(c->x, c->xf, sizeof(double) * GSX_NX);
  for (j = 0; j < GSX_NSW; ++j) c->m[j] = c->sf[j];
  c->n_events += a.n_events;
  c->t = a.t_end;
  if (gsx_set_schedules(c)) return gsx_fail(c, "fmi2DoStep: the schedules failed%s", "");
  gsx_log(c, fmi2OK, "logEvents", "t=%.17g: %d events in the step, %ld internal steps", c->t, a.n_events, a.n_steps);
  return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
  return gsx_fail((gsx_inst*)comp, "fmi2CancelStep: steps are never asynchronous%s", "");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr;
  (void)order;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2SetRealInputDerivatives: the FMU has no inputs%s", "");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr;
  (void)order;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2GetRealOutputDerivatives: maxOutputDerivativeOrder is 0%s", "");
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status* value) {
  gsx_inst* c = (gsx_inst*)comp;
  if (!c || !value) return fmi2Error;
  if (s != fmi2DoStepStatus) return fmi2Discard;
  *value = c->mode == M_ERROR ? fmi2Error : fmi2OK;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real* value) {
  gsx_inst* c = (gsx_inst*)comp;
  if (!c || !value) return fmi2Error;
  if (s != fmi2LastSuccessfulTime) return fmi2Discard;
  *value = c->t;
  return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer* value) {
  (void)s;
  (void)value;
  return comp ? fmi2Discard : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean* value) {
  gsx_inst* c = (gsx_inst*)comp;
  if (!c || !value) return fmi2Error;
  if (s != fmi2Terminated) return fmi2Discard;
  *value = fmi2False;
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String* value) {
  (void)s;
  (void)value;
  return comp ? fmi2Discard : fmi2Error;
}
