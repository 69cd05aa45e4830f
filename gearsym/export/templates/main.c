/*
 * main.c -- command-line program of a gearsym-exported model (no Python needed).
 *
 * Written by `gearsym export SCENE --c DIR`; the same file for every model.  The model
 * is in gs_model.c (generated C), its metadata and the scene's defaults in
 * gs_export_data.h, and the integration (CVODE/IDA with events, mode switch and
 * scheduled breakpoints) in gs_driver.c, gearsym's own driver, through gs_simulate().
 *
 *   ./PROG [NAME=VALUE ...] [--file FILE] [--out FILE] [--events FILE] [--list] [--help]
 *
 * NAME is a parameter (SI units), a state (its initial value, SI units) or an option
 * (periods, t_end, t0, n_out, points_per_period, rtol, atol, method, max_step,
 * max_steps).  --file reads NAME=VALUE lines ('#' starts a comment; a regular text file
 * of at most 1 MiB, lines of any length); later settings win.  The trajectory goes to
 * stdout (or --out FILE) as CSV with the header t,<states>,<outputs>; the events to
 * --events FILE (default with --out FILE: FILE with ".csv" replaced by "_events.csv").
 *
 * Exit codes: 0 success, 2 bad arguments, 1 integration or SUNDIALS failure.
 */
#if !defined(_POSIX_C_SOURCE) || _POSIX_C_SOURCE < 200809L
#undef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#endif
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "gs_driver.h"
#include "gs_model.h"
#include "gs_export_data.h"

typedef struct {
  double p[GSX_NP + 1];
  double x0[GSX_NX + 1];
  double periods, t_end, t0, max_step, rtol, atol;
  long n_out, ppp, max_steps;
  int method; /* index in the method table of gs_export_data.h */
  int periods_set, t_end_set, n_out_set, max_step_set;
  const char* out;
  const char* events;
} gsx_opts;

static void usage(FILE* fp) {
  fprintf(fp,
          "usage: %s [NAME=VALUE ...] [--file FILE] [--out FILE] [--events FILE] [--list] [--help]\n"
          "  NAME=VALUE   a parameter (SI units), an initial state (SI units) or an option:\n"
          "               periods, t_end, t0, n_out, points_per_period, rtol, atol,\n"
          "               method (" GSX_METHOD_CHOICES "), max_step, max_steps\n"
          "  --file FILE  NAME=VALUE lines ('#' starts a comment; a text file of at most 1 MiB)\n"
          "  --out FILE   CSV trajectory (default: stdout); header t,<states>,<outputs>\n"
          "  --events FILE  CSV events t,surface,direction,speed (default with --out X.csv: X_events.csv)\n"
          "  --list       parameters, states, outputs and options with their defaults\n",
          GSX_PROGRAM);
}

static int bad(const char* fmt, const char* a, const char* b) {
  fprintf(stderr, "%s: error: ", GSX_PROGRAM);
  fprintf(stderr, fmt, a, b);
  fprintf(stderr, "\n");
  return 2;
}

static int parse_double(const char* s, double* v) {
  char* end = NULL;
  errno = 0;
  *v = strtod(s, &end);
  if (end == s || *end != '\0' || errno == ERANGE || !isfinite(*v)) return -1;
  return 0;
}

static int parse_long(const char* s, long* v) {
  double d;
  if (parse_double(s, &d) || d != floor(d) || fabs(d) > 2e9) return -1;
  *v = (long)d;
  return 0;
}

static int find(const char* const* names, int n, const char* name) {
  int i;
  for (i = 0; i < n; ++i)
    if (strcmp(names[i], name) == 0) return i;
  return -1;
}

/* Apply one NAME=VALUE setting; returns 0 or 2 (message printed). */
static int apply(gsx_opts* o, const char* item, const char* where) {
  char name[256];
  const char* eq = strchr(item, '=');
  const char* val;
  double v;
  long l;
  int k;
  size_t len;
  if (!eq) return bad("expected NAME=VALUE, got '%s'%s", item, where);
  len = (size_t)(eq - item);
  while (len > 0 && (item[len - 1] == ' ' || item[len - 1] == '\t')) --len;
  while (len > 0 && (*item == ' ' || *item == '\t')) {
    ++item;
    --len;
  }
  if (len == 0 || len >= sizeof(name)) return bad("bad setting '%s'%s", item, where);
  memcpy(name, item, len);
  name[len] = '\0';
  val = eq + 1;
  while (*val == ' ' || *val == '\t') ++val;
  if (strcmp(name, "method") == 0) {
    for (k = 0; k < GSX_NMETHODS; ++k) /* the table of gs_export_data.h (gearsym.integrators) */
      if (strcmp(val, gsx_method_names[k]) == 0) {
        o->method = k;
        return 0;
      }
    return bad("method must be one of " GSX_METHOD_LIST ", got '%s'%s", val, where);
  }
  if (strcmp(name, "n_out") == 0 || strcmp(name, "points_per_period") == 0 || strcmp(name, "max_steps") == 0) {
    if (parse_long(val, &l) || l < (strcmp(name, "max_steps") == 0 ? 0 : 2))
      return bad("%s: '%s' is not a valid count", name, val);
    if (name[0] == 'n') {
      o->n_out = l;
      o->n_out_set = 1;
    } else if (name[0] == 'p') {
      o->ppp = l;
    } else {
      o->max_steps = l;
    }
    return 0;
  }
  if (parse_double(val, &v)) return bad("%s: '%s' is not a finite number", name, val);
  if (strcmp(name, "periods") == 0) {
    if (!(v > 0)) return bad("periods must be > 0 (got %s)%s", val, "");
    o->periods = v;
    o->periods_set = 1;
    o->t_end_set = 0;
  } else if (strcmp(name, "t_end") == 0) {
    o->t_end = v;
    o->t_end_set = 1;
    o->periods_set = 0;
  } else if (strcmp(name, "t0") == 0) {
    o->t0 = v;
  } else if (strcmp(name, "rtol") == 0) {
    if (!(v >= 1e-15 && v < 1)) return bad("rtol must be in [1e-15, 1) (got %s)%s", val, "");
    o->rtol = v;
  } else if (strcmp(name, "atol") == 0) {
    if (!(v > 0)) return bad("atol must be > 0 (got %s)%s", val, "");
    o->atol = v;
  } else if (strcmp(name, "max_step") == 0) {
    if (!(v >= 0)) return bad("max_step must be >= 0 (got %s)%s", val, "");
    o->max_step = v;
    o->max_step_set = 1;
  } else if ((k = find(gsx_param_names, GSX_NP, name)) >= 0) {
    if (gsx_p_locked[k] && v != gsx_p_default[k]) return bad("%s is fixed: %s", name, gsx_p_lock_note[k]);
    o->p[k] = v;
  } else if ((k = find(gsx_extra_names, GSX_NEXTRA, name)) >= 0) {
    if (v != gsx_extra_value[k]) return bad("%s is fixed: %s", name, gsx_extra_note[k]);
  } else if ((k = find(gsx_state_names, GSX_NX, name)) >= 0) {
    o->x0[k] = v;
  } else {
    return bad("unknown name '%s' (not a parameter, state or option; see --list)%s", name, where);
  }
  return 0;
}

/* Largest --file accepted: a settings file is a few kB; anything bigger is not one. */
#define GSX_MAX_FILE (1L << 20)

/* Read all of the regular file `path` (at most GSX_MAX_FILE bytes) into a NUL-terminated
 * buffer (*out, *len; free it).  Refuses, with a message and 2, what is not a settings file:
 * a file that cannot be opened, not a regular file (a device such as /dev/zero, a FIFO, a
 * folder: opened non-blocking, so a FIFO does not block), bigger than GSX_MAX_FILE. */
static int slurp(const char* path, char** out, size_t* len) {
  struct stat st;
  char* buf;
  size_t n = 0;
  ssize_t r;
  int fd = open(path, O_RDONLY | O_NONBLOCK);
  *out = NULL;
  if (fd < 0) return bad("cannot read %s: %s", path, strerror(errno));
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    return bad("--file %s: not a regular file%s", path, "");
  }
  if (st.st_size > GSX_MAX_FILE) {
    close(fd);
    return bad("--file %s: larger than 1 MiB%s (not a settings file)", path, "");
  }
  buf = (char*)malloc(GSX_MAX_FILE + 2);
  if (!buf) {
    close(fd);
    return bad("--file %s: out of memory%s", path, "");
  }
  for (;;) { /* read to the end (the file may have grown since fstat): at most GSX_MAX_FILE + 1 */
    r = read(fd, buf + n, GSX_MAX_FILE + 1 - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      free(buf);
      close(fd);
      return bad("cannot read %s: %s", path, strerror(errno));
    }
    if (r == 0 || (n += (size_t)r) > GSX_MAX_FILE) break;
  }
  close(fd);
  if (n > GSX_MAX_FILE) {
    free(buf);
    return bad("--file %s: larger than 1 MiB%s (not a settings file)", path, "");
  }
  buf[n] = '\0';
  *out = buf;
  *len = n;
  return 0;
}

/* NAME=VALUE lines of any length ('#' starts a comment, CR LF accepted); a NUL byte (a
 * binary file) is refused with the number of its line. */
static int read_file(gsx_opts* o, const char* path) {
  char where[600], num[32];
  char *buf, *line, *next, *s, *e;
  size_t len;
  int lineno = 0, rc = 0;
  if ((rc = slurp(path, &buf, &len)) != 0) return rc;
  for (line = buf; rc == 0 && line < buf + len; line = next) {
    char* nl = (char*)memchr(line, '\n', (size_t)(buf + len - line));
    char* end = nl ? nl : buf + len;
    ++lineno;
    next = nl ? nl + 1 : buf + len;
    if (memchr(line, '\0', (size_t)(end - line))) {
      snprintf(num, sizeof(num), "%d", lineno);
      rc = bad("--file %s: a NUL byte on line %s (not a text file)", path, num);
      break;
    }
    *end = '\0';
    if ((e = strchr(line, '#')) != NULL) *e = '\0';
    s = line;
    e = s + strlen(s);
    while (e > s && (e[-1] == '\r' || e[-1] == ' ' || e[-1] == '\t')) *--e = '\0';
    while (*s == ' ' || *s == '\t') ++s;
    if (!*s) continue;
    snprintf(where, sizeof(where), " (%s, line %d)", path, lineno);
    rc = apply(o, s, where);
  }
  free(buf);
  return rc;
}

static void list(void) {
  int i;
  printf("%s: %s\n", GSX_PROGRAM, GSX_DESCRIPTION);
  printf("parameters (SI units; scene values):\n");
  for (i = 0; i < GSX_NP; ++i)
    printf("  %-24s = %-24.17g %s%s%s\n", gsx_param_names[i], gsx_p_default[i], gsx_param_units[i],
           gsx_p_locked[i] ? "  fixed: " : "", gsx_p_locked[i] ? gsx_p_lock_note[i] : "");
  for (i = 0; i < GSX_NEXTRA; ++i)
    printf("  %-24s = %-24.17g %s  fixed: %s\n", gsx_extra_names[i], gsx_extra_value[i], gsx_extra_units[i],
           gsx_extra_note[i]);
  printf("initial states (SI units):\n");
  for (i = 0; i < GSX_NX; ++i) printf("  %-24s = %-24.17g %s\n", gsx_state_names[i], gsx_x0[i], gsx_state_units[i]);
  printf("outputs:");
  for (i = 0; i < GSX_NOUT; ++i) printf(" %s", gsx_output_names[i]);
  printf("%s\nswitching surfaces:", GSX_NOUT ? "" : " (none)");
  for (i = 0; i < GSX_NSW; ++i) printf(" %s", gsx_surface_names[i]);
  printf("%s\noptions (defaults):\n", GSX_NSW ? "" : " (none)");
  if (GSX_HAS_PERIOD) printf("  periods = %.17g (forcing periods)\n", GSX_DEFAULT_PERIODS);
  printf("  t_end = %s\n", GSX_HAS_PERIOD ? "t0 + periods * forcing period" : GSX_DEFAULT_T_END_STR);
  printf("  t0 = 0\n  points_per_period = %d\n  n_out = %s\n", GSX_DEFAULT_PPP,
         GSX_HAS_PERIOD ? "round(periods * points_per_period) + 1" : "1001");
  printf("  rtol = %.17g\n  atol = %.17g\n  method = %s\n  max_step = %s\n  max_steps = %ld\n", GSX_DEFAULT_RTOL,
         GSX_DEFAULT_ATOL, gsx_method_names[GSX_DEFAULT_METHOD], GSX_HAS_PERIOD ? "forcing period / 8" : "0 (unlimited)",
         (long)GSX_DEFAULT_MAX_STEPS);
}

/* Mode for the outputs at (t, x): sides from the sign of g (g >= 0 -> +1) and the
 * schedule segment at t, as gearsym.System.outputs does. */
static int output_mode(double t, const double* x, const double* p, const double* sched, double* m, double* g,
                       casadi_int* iw, casadi_real* w, const casadi_real** arg, casadi_real** res) {
  int j, k, i, off = 0;
  if (GSX_NSW > 0) {
    arg[0] = &t;
    arg[1] = x;
    arg[2] = p;
    res[0] = g;
    if (gs_sw(arg, res, iw, w, 0)) return -1;
    for (j = 0; j < GSX_NSW; ++j) m[j] = g[j] >= 0.0 ? 1.0 : -1.0;
  }
  for (k = 0; k < GSX_NSCHED; ++k) {
    double P = sched[off], u = t / P, n = floor(u), frac = u - n;
    int seg = 0;
    for (i = 0; i < gsx_sched_nb[k]; ++i)
      if (sched[off + 1 + i] <= frac) seg = i;
    m[GSX_NSW + 2 * k] = n;
    m[GSX_NSW + 2 * k + 1] = seg;
    off += 1 + gsx_sched_nb[k];
  }
  return 0;
}

static int write_outputs(FILE* fp, const gsx_opts* o, const double* tt, long n, const double* y) {
  casadi_int sz[4], mx[4] = {0, 0, 0, 0};
  const casadi_real** arg;
  casadi_real** res;
  casadi_int* iw;
  casadi_real* w;
  double m[GSX_NM + 1], g[GSX_NSW + 1], sched[GSX_NSCHED_TOTAL + 1], out[GSX_NOUT + 1], dummy[1] = {0.0};
  const double* pp = GSX_NP ? o->p : dummy;
  long i;
  int j, rc = 0;
#define GSX_WORK(NAME)                                \
  if (NAME##_work(&sz[0], &sz[1], &sz[2], &sz[3]) == 0) \
    for (j = 0; j < 4; ++j) mx[j] = sz[j] > mx[j] ? sz[j] : mx[j];
  GSX_WORK(gs_sw)
  GSX_WORK(gs_sched)
#if GSX_NOUT > 0
  GSX_WORK(gs_out)
#endif
#undef GSX_WORK
  arg = (const casadi_real**)calloc((size_t)mx[0] + 8, sizeof(*arg));
  res = (casadi_real**)calloc((size_t)mx[1] + 2, sizeof(*res));
  iw = (casadi_int*)calloc((size_t)mx[2] + 1, sizeof(*iw));
  w = (casadi_real*)calloc((size_t)mx[3] + 1, sizeof(*w));
  if (!arg || !res || !iw || !w) rc = -1;
  if (!rc && GSX_NSCHED_TOTAL > 0) {
    arg[0] = pp;
    res[0] = sched;
    rc = gs_sched(arg, res, iw, w, 0);
  }
  fprintf(fp, "t");
  for (j = 0; j < GSX_NX; ++j) fprintf(fp, ",%s", gsx_state_names[j]);
  for (j = 0; j < GSX_NOUT; ++j) fprintf(fp, ",%s", gsx_output_names[j]);
  fprintf(fp, "\n");
  for (i = 0; i < n && !rc; ++i) {
    const double* x = y + (size_t)i * GSX_NX;
    fprintf(fp, "%.17g", tt[i]);
    for (j = 0; j < GSX_NX; ++j) fprintf(fp, ",%.17g", x[j]);
#if GSX_NOUT > 0
    {
      double t = tt[i];
      rc = output_mode(t, x, pp, sched, m, g, iw, w, arg, res);
      if (!rc) {
        arg[0] = &t;
        arg[1] = x;
        arg[2] = pp;
        arg[3] = GSX_NM ? m : dummy;
        res[0] = out;
        rc = gs_out(arg, res, iw, w, 0);
      }
      for (j = 0; j < GSX_NOUT && !rc; ++j) fprintf(fp, ",%.17g", out[j]);
    }
#else
    (void)m;
    (void)g;
    (void)out;
#endif
    fprintf(fp, "\n");
  }
  free((void*)arg);
  free(res);
  free(iw);
  free(w);
  return rc;
}

int main(int argc, char** argv) {
  gsx_opts o;
  gs_sim_args a;
  double T = NAN, dummy[1] = {0.0};
  double *tt = NULL, *y = NULL, *ev_t = NULL, *ev_speed = NULL, *xf = NULL;
  int *ev_s = NULL, *ev_d = NULL;
  char events_default[4096];
  char abimsg[256];
  long n, i;
  int k, rc, cap;
  FILE* fp;
  struct timespec w0, w1;

  memset(&o, 0, sizeof(o));
  for (k = 0; k < GSX_NP; ++k) o.p[k] = gsx_p_default[k];
  for (k = 0; k < GSX_NX; ++k) o.x0[k] = gsx_x0[k];
  o.periods = GSX_DEFAULT_PERIODS;
  o.t_end = GSX_DEFAULT_T_END;
  o.rtol = GSX_DEFAULT_RTOL;
  o.atol = GSX_DEFAULT_ATOL;
  o.ppp = GSX_DEFAULT_PPP;
  o.method = GSX_DEFAULT_METHOD;
  o.max_steps = GSX_DEFAULT_MAX_STEPS;

  for (k = 1; k < argc; ++k) {
    const char* s = argv[k];
    if (strcmp(s, "--help") == 0 || strcmp(s, "-h") == 0) {
      usage(stdout);
      return 0;
    } else if (strcmp(s, "--list") == 0) {
      list();
      return 0;
    } else if (strcmp(s, "--file") == 0 || strcmp(s, "--out") == 0 || strcmp(s, "--events") == 0) {
      if (k + 1 >= argc) return bad("%s needs a file name%s", s, "");
      if (s[2] == 'f') {
        rc = read_file(&o, argv[++k]);
        if (rc) return rc;
      } else if (s[2] == 'o') {
        o.out = argv[++k];
      } else {
        o.events = argv[++k];
      }
    } else if (s[0] == '-' && s[1] == '-') {
      usage(stderr);
      return bad("unknown option '%s'%s", s, "");
    } else {
      rc = apply(&o, s, "");
      if (rc) return rc;
    }
  }

  if (gs_check_abi(abimsg, (int)sizeof(abimsg)) != 0) {
    fprintf(stderr, "%s: error: SUNDIALS: %s\n", GSX_PROGRAM, abimsg);
    return 1;
  }
  if (GSX_IMPLICIT && !gsx_method_implicit[o.method])
    return bad("this model is implicit (mass-matrix form): use method=%s%s", GSX_IMPLICIT_METHODS, "");
  if (!GSX_IMPLICIT && !gsx_method_explicit[o.method])
    return bad("method=%s needs a model in implicit form%s", gsx_method_names[o.method], "");

  /* forcing period from the generated gs_period */
#if GSX_HAS_PERIOD
  {
    casadi_int sz[4] = {0, 0, 0, 0};
    const casadi_real** arg;
    casadi_real** res;
    casadi_int* iw;
    casadi_real* wbuf;
    gs_period_work(&sz[0], &sz[1], &sz[2], &sz[3]);
    arg = (const casadi_real**)calloc((size_t)sz[0] + 2, sizeof(*arg));
    res = (casadi_real**)calloc((size_t)sz[1] + 2, sizeof(*res));
    iw = (casadi_int*)calloc((size_t)sz[2] + 1, sizeof(*iw));
    wbuf = (casadi_real*)calloc((size_t)sz[3] + 1, sizeof(*wbuf));
    if (!arg || !res || !iw || !wbuf) {
      fprintf(stderr, "%s: error: out of memory\n", GSX_PROGRAM);
      return 1;
    }
    arg[0] = GSX_NP ? o.p : dummy;
    res[0] = &T;
    rc = gs_period(arg, res, iw, wbuf, 0);
    free((void*)arg);
    free(res);
    free(iw);
    free(wbuf);
    if (rc || !isfinite(T) || !(T > 0)) {
      fprintf(stderr, "%s: error: the forcing period is not finite and > 0 at these parameters (%g)\n",
              GSX_PROGRAM, T);
      return 2;
    }
  }
#endif
  if (!o.t_end_set) {
    if (GSX_HAS_PERIOD)
      o.t_end = o.t0 + o.periods * T;
    else if (o.periods_set)
      return bad("periods= needs a model with a forcing period; give t_end%s%s", "", "");
  }
  if (!(o.t_end > o.t0)) return bad("t_end must be greater than t0%s%s", "", "");
  if (!o.n_out_set) {
    if (GSX_HAS_PERIOD)
      o.n_out = (long)nearbyint((o.t_end - o.t0) / T * (double)o.ppp) + 1;
    else
      o.n_out = 1001;
  }
  n = o.n_out < 2 ? 2 : o.n_out;
  if (!o.max_step_set) o.max_step = GSX_HAS_PERIOD ? T / 8.0 : 0.0;

  tt = (double*)malloc(sizeof(double) * (size_t)n);
  y = (double*)malloc(sizeof(double) * (size_t)n * GSX_NX);
  xf = (double*)malloc(sizeof(double) * (GSX_NX + 1));
  if (!tt || !y || !xf) {
    fprintf(stderr, "%s: error: out of memory (n_out=%ld)\n", GSX_PROGRAM, n);
    return 1;
  }
  {
    double step = (o.t_end - o.t0) / (double)(n - 1); /* as numpy.linspace */
    for (i = 0; i < n; ++i) tt[i] = (double)i * step + o.t0;
    tt[n - 1] = o.t_end;
  }

  cap = 100000;
  for (;;) {
    ev_t = (double*)malloc(sizeof(double) * (size_t)cap);
    ev_speed = (double*)malloc(sizeof(double) * (size_t)cap);
    ev_s = (int*)malloc(sizeof(int) * (size_t)cap);
    ev_d = (int*)malloc(sizeof(int) * (size_t)cap);
    if (!ev_t || !ev_speed || !ev_s || !ev_d) {
      fprintf(stderr, "%s: error: out of memory (events)\n", GSX_PROGRAM);
      return 1;
    }
    memset(&a, 0, sizeof(a));
    a.method = gsx_method_code[o.method];
    a.nonlinear = gsx_method_nonlinear[o.method];
    a.rtol = o.rtol;
    a.atol = o.atol;
    a.t0 = o.t0;
    a.t_end = o.t_end;
    a.x0 = o.x0;
    a.p = GSX_NP ? o.p : dummy;
    a.sigma0 = NULL;
    a.n_out = (int)n;
    a.t_out = tt;
    a.max_steps = o.max_steps;
    a.max_step = o.max_step;
    a.max_events_out = cap;
    a.y_out = y;
    a.x_final = xf;
    a.ev_t = ev_t;
    a.ev_surface = ev_s;
    a.ev_dir = ev_d;
    a.ev_speed = ev_speed;
    clock_gettime(CLOCK_MONOTONIC, &w0);
    rc = gs_simulate(&a);
    clock_gettime(CLOCK_MONOTONIC, &w1);
    if (rc != GS_OK) {
      fprintf(stderr, "%s: error: integration failed (status %d): %s\n", GSX_PROGRAM, rc, a.errmsg);
      return rc == GS_ERR_INPUT ? 2 : 1;
    }
    if (a.n_events <= cap) break;
    cap = a.n_events; /* the event log did not fit: run again with room for all */
    free(ev_t);
    free(ev_speed);
    free(ev_s);
    free(ev_d);
  }

  fp = o.out ? fopen(o.out, "w") : stdout;
  if (!fp) return bad("cannot write %s: %s", o.out, strerror(errno));
  if (write_outputs(fp, &o, tt, n, y)) {
    fprintf(stderr, "%s: error: evaluating the outputs failed\n", GSX_PROGRAM);
    return 1;
  }
  if (o.out && fclose(fp) != 0) return bad("cannot write %s: %s", o.out, strerror(errno));
  if (!o.events && o.out) {
    size_t len = strlen(o.out);
    if (len > 4 && strcmp(o.out + len - 4, ".csv") == 0)
      snprintf(events_default, sizeof(events_default), "%.*s_events.csv", (int)(len - 4), o.out);
    else
      snprintf(events_default, sizeof(events_default), "%s_events.csv", o.out);
    o.events = events_default;
  }
  if (o.events) {
    fp = fopen(o.events, "w");
    if (!fp) return bad("cannot write %s: %s", o.events, strerror(errno));
    fprintf(fp, "t,surface,direction,speed\n");
    for (k = 0; k < a.n_events; ++k)
      fprintf(fp, "%.17g,%s,%d,%.17g\n", ev_t[k], gsx_surface_names[ev_s[k]], ev_d[k], ev_speed[k]);
    if (fclose(fp) != 0) return bad("cannot write %s: %s", o.events, strerror(errno));
  }
  fprintf(stderr, "%s: t = %g .. %g, %ld steps, %ld rhs, %d events, %ld breakpoints, %.2f ms\n", GSX_PROGRAM,
          o.t0, o.t_end, a.n_steps, a.n_rhs, a.n_events, a.n_breaks,
          (double)(w1.tv_sec - w0.tv_sec) * 1e3 + (double)(w1.tv_nsec - w0.tv_nsec) * 1e-6);
  free(tt);
  free(y);
  free(xf);
  free(ev_t);
  free(ev_speed);
  free(ev_s);
  free(ev_d);
  return 0;
}
