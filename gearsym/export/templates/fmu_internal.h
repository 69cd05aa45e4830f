/*
 * fmu_internal.h -- private header of the FMU runtime (fmu.c, fmu_access.c, fmu_cs.c):
 * the instance, and the functions of fmu.c that the other two call.  Not part of the FMU's
 * interface: those functions are hidden in the shared library even when it is built
 * without -fvisibility=hidden; the FMI entry points are exported by the FMI2_Export
 * declarations of fmi2Functions.h.
 */
#ifndef GSX_FMU_INTERNAL_H
#define GSX_FMU_INTERNAL_H

#include <stddef.h>

#include "fmi2Functions.h"
#include "gs_driver.h"
#include "gs_model.h"
#include "gs_export_data.h"

#if defined(__GNUC__) && !defined(_WIN32) && !defined(__CYGWIN__)
#define GSX_HIDDEN __attribute__((visibility("hidden")))
#else
#define GSX_HIDDEN
#endif

/* M_EVENT, M_CONT: Model Exchange; M_STEP: Co-Simulation, between communication points */
typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED, M_ERROR } gsx_mode;

/* One CasADi function with its single output's sparsity. */
typedef struct {
  int (*f)(const casadi_real**, casadi_real**, casadi_int*, casadi_real*, int);
  const casadi_int* sp;
  int nrow, ncol, nnz, dense;
} gsx_fn;

typedef struct {
  fmi2CallbackFunctions cb;
  char* name;
  int log_on;
  gsx_mode mode;
  double t, t_start, t_stop;
  int stop_defined;
  double x[GSX_NX + 1];
  double p[GSX_NP + 1];
  double m[GSX_NM + 1];
  int n_events;
  int storm_count;
  double last_event_t;
  int first_update; /* the event update right after initialisation */
  double next_event;
  int next_event_defined;
  /* scratch */
  double g[GSX_NSW + 1], gt[GSX_NSW + 1], G[GSX_NSW * GSX_NX + 1];
  double f[GSX_NX + 1], J[GSX_NX * GSX_NX + 1];
  double sched[GSX_NSCHED_TOTAL + 1];
  double outbuf[GSX_NOUT + 1];
  double outx[GSX_NOUT * GSX_NX + 1];
  double dummy[1];
  gsx_fn rhs, jac, sw, swx, swt, sch, per, out, outxf;
  /* Co-Simulation: gearsym's driver integrates each communication step */
  int cs;            /* 1: instantiated as fmi2CoSimulation */
  gs_workspace* ws;  /* the driver's workspace (integrator reused from step to step) */
  double rtol;       /* fmi2SetupExperiment's tolerance, else the scene's rtol */
  double xf[GSX_NX + 1], sf[GSX_NSW + 1];
  const casadi_real** arg;
  casadi_real** res;
  casadi_int* iw;
  casadi_real* w;
  double* nz;
  size_t nz_cap;
} gsx_inst;

/* ---- fmu.c: logging (errors go to the logger callback, fmi2OK messages only with logging on) */
GSX_HIDDEN void gsx_log(gsx_inst* c, fmi2Status st, const char* cat, const char* fmt, ...);
GSX_HIDDEN fmi2Status gsx_fail(gsx_inst* c, const char* fmt, const char* what);

/* ---- fmu.c: the generated functions at (c->t, c->x, c->p, mode); 0 if finite */
GSX_HIDDEN int gsx_call(gsx_inst* c, const gsx_fn* fn, const double** in, int n_in, double* out);
GSX_HIDDEN const double* gsx_pp(gsx_inst* c);
GSX_HIDDEN const double* gsx_mp(gsx_inst* c, const double* m);
GSX_HIDDEN int gsx_rhs(gsx_inst* c, const double* m, double* out);
GSX_HIDDEN int gsx_jacobian(gsx_inst* c);
GSX_HIDDEN int gsx_swfn(gsx_inst* c, const gsx_fn* fn, double* out);
GSX_HIDDEN int gsx_outputs(gsx_inst* c);
GSX_HIDDEN int gsx_period(gsx_inst* c, double* T);

/* ---- fmu.c: the event update (initial: the sides at initialisation), and the mode
 * before fmi2ExitInitializationMode */
GSX_HIDDEN int gsx_update(gsx_inst* c, int initial);
GSX_HIDDEN int gsx_pre_init_mode(gsx_inst* c);
/* ---- fmu.c: the schedule part of the mode for the interval starting at c->t */
GSX_HIDDEN int gsx_set_schedules(gsx_inst* c);

#endif
