/*
 * gs_model_abi.h -- the contract between gearsym-generated model code and the
 * generic C driver (gs_driver.c).  Both are compiled together into one shared
 * object per scene (named by content hash), so the driver links the model's
 * functions directly.
 *
 * The model translation unit (written by gearsym.codegen via CasADi) defines
 * these CasADi-style functions.  Every one has the standard CasADi C API:
 *     int  NAME(const casadi_real** arg, casadi_real** res,
 *               casadi_int* iw, casadi_real* w, int mem);
 *     int  NAME_work(casadi_int* sz_arg, casadi_int* sz_res,
 *                    casadi_int* sz_iw, casadi_int* sz_w);
 * Dense matrix outputs are column-major (CasADi's storage).
 *
 *   gs_rhs   (t[1], x[nx], p[np], m[nm])            -> xdot[nx]        explicit form
 *   gs_jac   (t[1], x[nx], p[np], m[nm])            -> J[nx x nx]      d xdot / d x
 *   gs_res   (t[1], x[nx], xd[nx], p[np], m[nm])    -> r[nx]           implicit form
 *   gs_resjac(t[1], x[nx], xd[nx], p[np], m[nm], cj[1])
 *                                                    -> Jr[nx x nx]     dr/dx + cj dr/dxd
 *   gs_sw    (t[1], x[nx], p[np])                    -> g[nsw]          switching functions
 *   gs_swx   (t[1], x[nx], p[np])                    -> G[nsw x nx]     dg/dx
 *   gs_swt   (t[1], x[nx], p[np])                    -> gt[nsw]         dg/dt
 *   gs_sched (p[np])                                 -> s[nsched_total] schedules
 *
 * In explicit models gs_res/gs_resjac are absent; in implicit models gs_rhs/gs_jac
 * are absent (GS_MODEL_IMPLICIT tells which).  nsw may be 0 (then gs_sw* still
 * exist, with empty outputs); nsched may be 0 (gs_sched then has an empty output).
 *
 * Mode vector m (length nm = nsw + 2*nsched):
 *   m[j],            j < nsw : sigma_j = +1.0 if the model is on the g_j > 0 side,
 *                               -1.0 on the g_j < 0 side.  The right-hand side is
 *                               smooth for fixed m; only the driver changes m.
 *   m[nsw + 2k]              : n_k, the integer cycle index of schedule k
 *   m[nsw + 2k + 1]          : seg_k, the segment index of schedule k
 * Schedule k (periodic, piecewise-in-time coefficients) has period P_k and nb_k
 * break fractions 0 = c_0 < c_1 < ... < c_{nb_k-1} < 1 (c_0 is always 0: the
 * cycle boundary is always a break).  gs_sched(p) returns, concatenated for
 * k = 0..nsched-1, [P_k, c_0, ..., c_{nb_k-1}] (so nsched_total = sum(1+nb_k)).
 * At time t: u = t/P_k, n_k = floor(u), frac = u - n_k, seg_k = max{i : c_i <= frac}.
 * Breakpoints (where the integrator must stop exactly) are t = (n + c_i) * P_k.
 *
 * Model metadata, also defined by the model translation unit:
 *   int gs_model_info(int* out, int len);
 *     writes out[0]=nx, out[1]=np, out[2]=nm, out[3]=nsw, out[4]=nsched,
 *     out[5]=implicit (0/1), out[6+k]=nb_k for k < nsched, out[6+nsched]=nalg (the
 *     number of algebraic variables: the last nalg states of an implicit model, whose
 *     derivatives do not appear in gs_res; IDA's id vector is 0 there; a model that
 *     does not write this entry has none); returns the count written (7+nsched, or
 *     6+nsched without nalg) or -1 if len is too small.
 */
#ifndef GS_MODEL_ABI_H
#define GS_MODEL_ABI_H
#endif
