/*
 * fmu_access.c -- FMI 2.0 entry points of the gearsym FMU runtime that read and write
 * a running instance: values (fmi2Get/Set*), directional derivatives, the Model
 * Exchange calls (event mode, states, derivatives, event indicators; refused on a
 * Co-Simulation instance), and the unsupported FMU-state calls, which report an error.
 * The Co-Simulation calls are in fmu_cs.c.
 *
 * The instance, the calls of the generated functions and the event update are in
 * fmu.c (see there for the hybrid-model rule); fmu_internal.h is what the two share.
 */
#include <math.h>
#include <string.h>

#include "fmu_internal.h"

/* ---- value references (see gs_export_data.h and modelDescription.xml) ---- */
fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  gsx_inst* c = (gsx_inst*)comp;
  size_t i;
  int have_f = 0, have_out = 0;
  if (!c) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (i = 0; i < nvr; ++i) {
    fmi2ValueReference r = vr[i];
    if (r < GSX_VR_DER) {
      value[i] = c->x[r];
    } else if (r < GSX_VR_PAR) {
      if (!have_f) {
        if (gsx_pre_init_mode(c) || gsx_rhs(c, c->m, c->f)) {
          gsx_log(c, fmi2Error, "logStatusError", "the right-hand side is not finite at t=%.17g", c->t);
          return fmi2Error;
        }
        have_f = 1;
      }
      value[i] = c->f[r - GSX_VR_DER];
    } else if (r < GSX_VR_EXTRA) {
      value[i] = c->p[r - GSX_VR_PAR];
    } else if (r < GSX_VR_PERIOD) {
      value[i] = gsx_extra_value[r - GSX_VR_EXTRA];
    } else if (r < GSX_VR_OUT) {
      if (gsx_period(c, &value[i])) return gsx_fail(c, "the forcing period is not finite%s", "");
    } else if (r < GSX_VR_END) {
      if (!have_out) {
        if (gsx_pre_init_mode(c) || gsx_outputs(c)) {
          gsx_log(c, fmi2Error, "logStatusError", "an output is not finite at t=%.17g", c->t);
          return fmi2Error;
        }
        have_out = 1;
      }
      value[i] = c->outbuf[r - GSX_VR_OUT];
    } else {
      gsx_log(c, fmi2Error, "logStatusError", "fmi2GetReal: unknown value reference %u", (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  gsx_inst* c = (gsx_inst*)comp;
  size_t i;
  if (!c) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (i = 0; i < nvr; ++i) {
    fmi2ValueReference r = vr[i];
    if (!isfinite(value[i])) {
      gsx_log(c, fmi2Error, "logStatusError", "fmi2SetReal: non-finite value for reference %u", (unsigned)r);
      return fmi2Error;
    }
    if (r < GSX_VR_DER) {
      if (c->mode != M_INSTANTIATED && c->mode != M_INIT) {
        gsx_log(c, fmi2Error, "logStatusError",
                "fmi2SetReal: the state %s is set through fmi2SetContinuousStates after initialisation",
                gsx_state_names[r]);
        return fmi2Error;
      }
      c->x[r] = value[i];
    } else if (r >= GSX_VR_PAR && r < GSX_VR_EXTRA) {
      int k = (int)(r - GSX_VR_PAR);
      if (gsx_p_locked[k]) {
        if (value[i] == gsx_p_default[k]) continue;
        gsx_log(c, fmi2Error, "logStatusError", "fmi2SetReal: %s is fixed: %s", gsx_param_names[k],
                gsx_p_lock_note[k]);
        return fmi2Error;
      }
      if (c->mode == M_CONT || c->mode == M_TERMINATED || c->mode == M_ERROR) {
        gsx_log(c, fmi2Error, "logStatusError",
                "fmi2SetReal: the tunable parameter %s can only change in event mode", gsx_param_names[k]);
        return fmi2Error;
      }
      c->p[k] = value[i];
    } else if (r >= GSX_VR_EXTRA && r < GSX_VR_PERIOD) {
      int k = (int)(r - GSX_VR_EXTRA);
      if (value[i] == gsx_extra_value[k]) continue;
      gsx_log(c, fmi2Error, "logStatusError", "fmi2SetReal: %s is a constant: %s", gsx_extra_names[k],
              gsx_extra_note[k]);
      return fmi2Error;
    } else {
      gsx_log(c, fmi2Error, "logStatusError", "fmi2SetReal: value reference %u cannot be set", (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  gsx_inst* c = (gsx_inst*)comp;
  size_t i;
  if (!c) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  if (gsx_pre_init_mode(c)) return fmi2Error;
  for (i = 0; i < nvr; ++i) {
    if (vr[i] < GSX_NSW)
      value[i] = (fmi2Integer)c->m[vr[i]];
    else if (vr[i] == GSX_IVR_NEVENTS)
      value[i] = (fmi2Integer)c->n_events;
    else {
      gsx_log(c, fmi2Error, "logStatusError", "fmi2GetInteger: unknown value reference %u", (unsigned)vr[i]);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  (void)vr;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2SetInteger: the Integer variables are outputs%s", "");
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2GetBoolean: this FMU has no Boolean variables%s", "");
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2SetBoolean: this FMU has no Boolean variables%s", "");
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  (void)vr;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2GetString: this FMU has no String variables%s", "");
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  (void)vr;
  (void)value;
  if (nvr == 0) return fmi2OK;
  return gsx_fail((gsx_inst*)comp, "fmi2SetString: this FMU has no String variables%s", "");
}

/* ---- FMU state: not supported (canGetAndSetFMUstate="false") ---- */
fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate* s) {
  (void)s;
  return gsx_fail((gsx_inst*)comp, "fmi2GetFMUstate is not supported%s", "");
}
fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate s) {
  (void)s;
  return gsx_fail((gsx_inst*)comp, "fmi2SetFMUstate is not supported%s", "");
}
fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate* s) {
  (void)s;
  return gsx_fail((gsx_inst*)comp, "fmi2FreeFMUstate is not supported%s", "");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate s, size_t* size) {
  (void)s;
  (void)size;
  return gsx_fail((gsx_inst*)comp, "fmi2SerializedFMUstateSize is not supported%s", "");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate s, fmi2Byte b[], size_t size) {
  (void)s;
  (void)b;
  (void)size;
  return gsx_fail((gsx_inst*)comp, "fmi2SerializeFMUstate is not supported%s", "");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte b[], size_t size, fmi2FMUstate* s) {
  (void)s;
  (void)b;
  (void)size;
  return gsx_fail((gsx_inst*)comp, "fmi2DeSerializeFMUstate is not supported%s", "");
}

/* ---- directional derivatives from the generated Jacobians ---- */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  gsx_inst* c = (gsx_inst*)comp;
  size_t i, k;
  int have_j = 0, have_o = 0;
  if (!c) return fmi2Error;
  for (k = 0; k < nKnown; ++k)
    if (vKnown_ref[k] >= GSX_VR_DER) {
      gsx_log(c, fmi2Error, "logStatusError",
              "fmi2GetDirectionalDerivative: known %u is not a continuous state (the FMU has no inputs)",
              (unsigned)vKnown_ref[k]);
      return fmi2Error;
    }
  for (i = 0; i < nUnknown; ++i) {
    fmi2ValueReference u = vUnknown_ref[i];
    double s = 0.0;
    if (u >= GSX_VR_DER && u < GSX_VR_PAR) {
      int row = (int)(u - GSX_VR_DER);
      if (!have_j) {
        if (gsx_jacobian(c)) return gsx_fail(c, "the Jacobian is not finite%s", "");
        have_j = 1;
      }
      for (k = 0; k < nKnown; ++k) s += c->J[vKnown_ref[k] * GSX_NX + row] * dvKnown[k];
#if GSX_HAS_OUTX
    } else if (u >= GSX_VR_OUT && u < GSX_VR_END) {
      int row = (int)(u - GSX_VR_OUT);
      if (!have_o) {
        const double* in[4];
        in[0] = &c->t;
        in[1] = c->x;
        in[2] = gsx_pp(c);
        in[3] = gsx_mp(c, c->m);
        if (gsx_call(c, &c->outxf, in, 4, c->outx)) return gsx_fail(c, "the output Jacobian is not finite%s", "");
        have_o = 1;
      }
      for (k = 0; k < nKnown; ++k) s += c->outx[vKnown_ref[k] * GSX_NOUT + row] * dvKnown[k];
#endif
    } else if (u < GSX_VR_DER) {
      for (k = 0; k < nKnown; ++k) s += (vKnown_ref[k] == u) ? dvKnown[k] : 0.0;
    } else {
      gsx_log(c, fmi2Error, "logStatusError",
              "fmi2GetDirectionalDerivative: unknown %u is not a state derivative or an output", (unsigned)u);
      return fmi2Error;
    }
    dvUnknown[i] = s;
  }
  (void)have_o;
  return fmi2OK;
}

/* ---- Model Exchange ---- */
fmi2Status fmi2EnterEventMode(fmi2Component comp) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2EnterEventMode");
  if (!c) return fmi2Error;
  if (c->mode != M_CONT && c->mode != M_EVENT) return gsx_fail(c, "fmi2EnterEventMode: wrong state%s", "");
  c->mode = M_EVENT;
  return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo* ei) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2NewDiscreteStates");
  if (!c || !ei) return fmi2Error;
  if (c->mode != M_EVENT) return gsx_fail(c, "fmi2NewDiscreteStates: not in event mode%s", "");
  ei->newDiscreteStatesNeeded = fmi2False;
  ei->terminateSimulation = fmi2False;
  ei->nominalsOfContinuousStatesChanged = fmi2False;
  ei->valuesOfContinuousStatesChanged = fmi2False;
  if (c->first_update) {
    c->first_update = 0; /* modes were set by fmi2ExitInitializationMode */
  } else if (gsx_update(c, 0)) {
    ei->terminateSimulation = fmi2True;
    c->mode = M_ERROR;
    return fmi2Error;
  }
  ei->nextEventTimeDefined = c->next_event_defined ? fmi2True : fmi2False;
  ei->nextEventTime = c->next_event_defined ? c->next_event : 0.0;
  return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2EnterContinuousTimeMode");
  if (!c) return fmi2Error;
  if (c->mode != M_EVENT) return gsx_fail(c, "fmi2EnterContinuousTimeMode: not in event mode%s", "");
  c->mode = M_CONT;
  return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode, fmi2Boolean* terminateSimulation) {
  (void)comp;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (enterEventMode) *enterEventMode = fmi2False;
  if (terminateSimulation) *terminateSimulation = fmi2False;
  return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2SetTime");
  if (!c) return fmi2Error;
  c->t = time;
  return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2SetContinuousStates");
  if (!c || nx != GSX_NX || !x) return fmi2Error;
  memcpy(c->x, x, sizeof(double) * GSX_NX);
  return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2GetDerivatives");
  if (!c || nx != GSX_NX || !derivatives) return fmi2Error;
  if (gsx_pre_init_mode(c) || gsx_rhs(c, c->m, derivatives)) {
    gsx_log(c, fmi2Error, "logStatusError", "the right-hand side is not finite at t=%.17g", c->t);
    return fmi2Error;
  }
  return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2GetEventIndicators");
  if (!c || ni != GSX_NSW) return fmi2Error;
  if (ni == 0) return fmi2OK;
  if (gsx_swfn(c, &c->sw, eventIndicators)) {
    gsx_log(c, fmi2Error, "logStatusError", "the switching functions are not finite at t=%.17g", c->t);
    return fmi2Error;
  }
  return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2GetContinuousStates");
  if (!c || nx != GSX_NX || !x) return fmi2Error;
  memcpy(x, c->x, sizeof(double) * GSX_NX);
  return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx) {
  gsx_inst* c = (gsx_inst*)comp;
  if (c && c->cs) return gsx_fail(c, "%s: a Model Exchange call on a Co-Simulation instance", "fmi2GetNominalsOfContinuousStates");
  if (!c || nx != GSX_NX || !x_nominal) return fmi2Error;
  memcpy(x_nominal, gsx_nominal, sizeof(double) * GSX_NX);
  return fmi2OK;
}
