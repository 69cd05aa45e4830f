"""Harmonic balance with alternating frequency/time (AFT) and a quasi-Newton solve.

The periodic solution of ``x' = f(t, x)`` with period ``P`` (``w = 2*pi/P``) is
sought as a truncated Fourier series of every state::

    x(t) = a_0 + sum_{k=1..H} a_k cos(k w (t - t0)) + b_k sin(k w (t - t0))

(Liu, Lv & Zhao 2021, eq. 13, for the NFG: there the response's harmonics are
combinations of the mesh and instantaneous-centre frequencies; with
``w_e / w_c = Z2`` an integer they are all harmonics of ``w_c = 2*pi/P``, which is
what a series in ``k w`` with ``H >= Z2 + 2`` contains).  Balancing the harmonics of
``x'`` and ``f`` gives the algebraic system ``R(C) = D C - F(C) = 0`` (their eq. 14 and
the set ``s_i = 0``).  The harmonics ``F`` of the nonlinear force are computed the
way their eqs. 15-17 do: sample the series at ``M`` equidistant times (eq. 15),
evaluate the right-hand side there -- the compiled model's, with the contact
mode taken from the sign of each switching function at the sample (eq. 16) --
and take the discrete Fourier transform (eq. 17).

The algebraic system is solved by a quasi-Newton method (Broyden's good update,
as in Liu et al.), started from the exact AFT Jacobian
``D - DFT diag(df/dx(t_m)) IDFT`` (assembled from the FFT of ``df/dx(t_m)``) and
refreshed when the Broyden steps stop reducing the residual; steps are damped by
backtracking.  A contact makes the residual kinked wherever a sample changes side and
the Newton direction overshoots: then Levenberg-Marquardt steps in scaled variables
take over.  The harmonics are given (``harmonics=H`` or a set) or grown through sets
that contain every excitation frequency (:mod:`gearsym.analysis.periodic._hbm_sets`) until one
period integrated from the balanced state closes to ``defect_tol`` of the orbit's
size (:mod:`gearsym.analysis.periodic._hbm_driver`, which also adapts the AFT samples).

**Implicit models and DAEs** (integrated by IDA): the derivatives of the differential states
``x_d`` and the algebraic variables ``z`` of an index-1 DAE are solved for at every time sample
from the residual ``F(t, [x_d; z], [x_d'; .]) = 0`` (the engine's ``"dae"`` evaluation: the
model as the ODE ``x_d' = f_d(t, x_d)`` of its differential states, with ``z = h(t, x_d)``).
Every state keeps its series; a differential state is balanced as above, an algebraic one by
``w (C_z - DFT(h(t_m, x_d(t_m)))) = 0`` (its series is that of ``h`` along the orbit; the
factor ``w`` gives its rows the size of the differential rows'), and the Jacobian's
algebraic blocks are ``w (I - DFT diag(dh/dx_d) IDFT)`` (``d h / d x_d`` and ``d f_d / d x_d``
by the implicit function theorem, the engine's ``"dae_jac"``).

This is a second, independent periodic solver: it shares only the generated
model functions with shooting, not the integrator.  The Floquet multipliers of
the orbit it finds come from one engine integration of the variational
equations from the balanced state ``x(t0)`` (``monodromy=False`` skips it).

Honest results: when that monodromy has a multiplier at +1 to working precision
(:func:`~gearsym.analysis.periodic.isolation`, outside the known ``trivial``
directions), the orbit is not isolated and the balance may have "converged" only
relative to coefficients that a singular Jacobian blew up (the undamped oscillator at
exact resonance gives coefficients ~1e33 with a residual ~1e18); such a solve counts as
converged only if its residual is also below ``tol`` times the size of the initial guess.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ...budget import MAX_MATRIX_VALUES
from ...errors import ParameterError
from ._floquet import segment_breaks

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["HarmonicBalance", "sample_field", "sample_jacobian"]

#: Largest harmonic-balance Jacobian (entries): the matrix budget of :mod:`gearsym.budget`.
MAX_JACOBIAN_VALUES = MAX_MATRIX_VALUES


def sample_field(system: CompiledSystem, t: np.ndarray, X: np.ndarray, p: np.ndarray,
                 sigma: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The vector field at samples ``(t_m, X_m)``, in the mode the driver would use there.

    Returns
    -------
    F : ndarray, shape (M, nd)
        The derivatives of the differential states (an explicit model's right-hand side).
    H : ndarray, shape (M, nalg)
        The algebraic variables solved for at the samples (empty without).
    """
    if not system.generated.implicit:
        F = system.engine.evaluate("rhs", t, X, p, sigma)
        return F, F[:, :0]
    nx = system.generated.nx
    Y = system.engine.evaluate("dae", t, X, p, sigma)
    nd = Y.shape[1] - nx
    return Y[:, nx:], Y[:, nd:nx]


def sample_jacobian(system: CompiledSystem, t: np.ndarray, X: np.ndarray, p: np.ndarray,
                    sigma: np.ndarray | None = None) -> np.ndarray:
    """``d [f_d; h] / d x_d`` at the samples, shape (M, nx, nd) (an explicit model's Jacobian)."""
    if not system.generated.implicit:
        return system.engine.evaluate("jac", t, X, p, sigma)
    return system.engine.evaluate("dae_jac", t, X, p, sigma)


class HarmonicBalance:
    """The AFT harmonic-balance residual of a compiled system for a fixed ``H``.

    Parameters
    ----------
    system
        The compiled system (an implicit one and a DAE too: module docstring).
    period
        Period of the sought orbit.
    harmonics
        Number of harmonics ``H``.
    params
        Parameter overrides (declared units, as ``--set``).
    t0
        Time origin of the series.
    samples
        Number of time samples ``M`` of the AFT (default: a power of two >= 4(2H+1),
        at least 64).  Equidistant (a DFT, Liu et al. eqs. 15-17), except when the
        model has scheduled coefficient jumps: then Gauss-Legendre nodes on each
        segment between breakpoints (about ``M`` in all), because the DFT of an
        integrand that jumps between samples is only first-order accurate.
    """

    def __init__(self, system: CompiledSystem, period: float, harmonics: int | Sequence[int],
                 params: Mapping[str, float] | None = None, t0: float = 0.0, samples: int | None = None):
        self.system = system
        if isinstance(harmonics, (int, np.integer)):
            if int(harmonics) < 0:
                raise ParameterError(f"harmonics must be >= 0, got {harmonics}")
            ks = np.arange(1, int(harmonics) + 1)
        else:
            ks = np.unique(np.asarray(list(harmonics), dtype=int))
            ks = ks[ks != 0]
            if ks.size and ks[0] < 0:
                raise ParameterError(f"harmonic numbers must be >= 0, got {int(ks[0])}")
        #: the harmonic numbers kept (>= 1; the mean is always kept)
        self.ks = ks
        #: the highest harmonic (``H`` of a full set ``1..H``)
        self.H = H = int(ks[-1]) if ks.size else 0
        self.full = bool(ks.size == H)
        self.P = float(period)
        self.w = 2 * np.pi / self.P
        self.t0 = float(t0)
        self.nx = system.generated.nx
        #: the differential states (the first ``nd``; the rest are a DAE's algebraic variables)
        self.nd = self.nx - len(system.generated.algebraic)
        self.nc = 2 * len(ks) + 1
        n = self.nx * self.nc
        if float(n) * n > MAX_JACOBIAN_VALUES:
            raise ParameterError(f"harmonics={len(ks)}: the harmonic-balance Jacobian would have {n} x {n} entries "
                                 f"({8.0 * n * n / 2**30:.3g} GiB), above the limit of {MAX_JACOBIAN_VALUES:.3g} "
                                 f"({8 * MAX_JACOBIAN_VALUES / 2**30:g} GiB): use fewer harmonics")
        M = samples or max(64, 1 << int(math.ceil(math.log2(4 * (2 * H + 1)))))
        if M < 2 * H + 1:
            raise ParameterError(f"samples={M} must be at least 2*harmonics+1 = {2 * H + 1}")
        self.p = system.param_vector(params)
        breaks = None
        if system.generated.schedules:
            breaks = segment_breaks(system, self.P, params, self.t0)
        if breaks is not None and len(breaks) > 2:
            # coefficients that jump at scheduled times: the uniform DFT of a
            # discontinuous integrand is only O(1/M); integrate segment by segment
            # with Gauss-Legendre nodes instead (spectral within each segment)
            ts, ws = [], []
            for a, b in zip(breaks[:-1], breaks[1:], strict=True):
                n = max(8, int(math.ceil(M * (b - a) / self.P)))
                xg, wg = np.polynomial.legendre.leggauss(n)
                ts.append(0.5 * (a + b) + 0.5 * (b - a) * xg)
                ws.append(0.5 * (b - a) * wg)
            self.t = np.concatenate(ts)
            weights = np.concatenate(ws) / self.P
            M = len(self.t)
            self.quadrature = "gauss-legendre per scheduled segment"
        else:
            self.t = self.t0 + self.P * np.arange(M) / M
            weights = np.full(M, 1.0 / M)
            self.quadrature = "uniform (DFT)"
        self.M = M
        th = self.w * (self.t - self.t0)
        E = np.ones((M, self.nc))
        for i, k in enumerate(ks, start=1):
            E[:, 2 * i - 1] = np.cos(k * th)
            E[:, 2 * i] = np.sin(k * th)
        self.E = E
        Ep = E.T * (2.0 * weights)[None, :]
        Ep[0] = weights
        self.Ep = Ep
        D = np.zeros((self.nc, self.nc))
        for i, k in enumerate(ks, start=1):
            D[2 * i - 1, 2 * i] = k * self.w
            D[2 * i, 2 * i - 1] = -k * self.w
        self.D = D
        self.uniform = self.quadrature.startswith("uniform")
        # f and df/dx at the samples are evaluated by the engine (gs_eval: sample_field,
        # sample_jacobian), in the mode the driver would use there: the side of each surface
        # from the sign of g, the schedule cycle and segment from t (the one schedule decoder, in C)
        self.n_evals = 0

    # -------------------------------------------------------------- series
    def samples_of(self, C: np.ndarray) -> np.ndarray:
        """Time samples ``x(t_m)``, shape (M, nx), of coefficients ``C`` (nc, nx)."""
        return self.E @ C

    def residual(self, C: np.ndarray) -> np.ndarray:
        """``R(C) = D C - DFT(f(t_m, x(t_m)))``, shape (nc, nx); a DAE's algebraic columns
        ``w (C_z - DFT(h(t_m, x_d(t_m))))``."""
        X = self.samples_of(C)
        F, H = sample_field(self.system, self.t, X, self.p)  # (M, nd), (M, nalg)
        self.n_evals += 1
        nd = self.nd
        R = np.empty_like(C)
        R[:, :nd] = self.D @ C[:, :nd] - self.Ep @ F
        if nd < self.nx:
            R[:, nd:] = self.w * (C[:, nd:] - self.Ep @ H)
        return R

    def jacobian(self, C: np.ndarray) -> np.ndarray:
        """Exact AFT Jacobian ``dR/dC`` (ordering: state-major, then coefficient).

        Block ``(i, j)`` is ``D delta_ij - DFT diag(df_i/dx_j(t_m)) IDFT``; on the uniform
        grid it is assembled from the FFT of ``df_i/dx_j(t_m)`` (the product of two
        harmonics is a sum and a difference frequency, aliased modulo ``M`` exactly as the
        DFT of the samples aliases them), in ``O(nc^2)`` per block instead of ``O(nc^2 M)``.
        """
        X = self.samples_of(C)
        Jm = sample_jacobian(self.system, self.t, X, self.p)  # (M, i, j): d f_i / d x_j (j < nd)
        nc, nd = self.nc, self.nd
        n = self.nx * nc
        Jr = np.zeros((n, n))
        for i in range(self.nx):
            w = 1.0 if i < nd else self.w  # a DAE's algebraic rows: w (C_z - DFT h)
            for j in range(nd):
                col = Jm[:, i, j]
                if not np.any(col):
                    continue
                Jr[i * nc:(i + 1) * nc, j * nc:(j + 1) * nc] = -w * self.product_matrix(col)
            Jr[i * nc:(i + 1) * nc, i * nc:(i + 1) * nc] += self.D if i < nd else self.w * np.eye(nc)
        return Jr

    def product_matrix(self, col: np.ndarray) -> np.ndarray:
        """``DFT diag(col) IDFT`` restricted to the harmonic set: the coefficients of
        ``col(t) x(t)`` as a linear map of the coefficients of ``x`` (shape (nc, nc))."""
        if not self.uniform:
            return self.Ep @ (col[:, None] * self.E)
        idx = self.__dict__.get("_prod_idx")
        if idx is None:
            f = np.concatenate([[0], np.repeat(self.ks, 2)])
            sin = np.zeros(self.nc, bool)
            sin[2::2] = True
            dm = (f[:, None] - f[None, :]) % self.M
            sm = (f[:, None] + f[None, :]) % self.M
            half = np.where(np.arange(self.nc) == 0, 0.5, 1.0)[:, None]
            idx = self._prod_idx = (dm, sm, sin[:, None], sin[None, :], half)
        dm, sm, sr, sl, half = idx
        c = np.fft.fft(col) / self.M
        A, B = c.real, -c.imag
        Am, Ap, Bm, Bp = A[dm], A[sm], B[dm], B[sm]
        out = np.where(sr, np.where(sl, Am - Ap, Bp + Bm), np.where(sl, Bp - Bm, Am + Ap))
        return out * half

    def full_coefficients(self, C: np.ndarray) -> np.ndarray:
        """Coefficients on the set, expanded to the full layout ``[a0, a1, b1, ..., aH, bH]``
        (zeros for the harmonics not in the set), shape (2H+1, nx)."""
        if self.full:
            return np.asarray(C, float)
        out = np.zeros((2 * self.H + 1, C.shape[1]))
        out[0] = C[0]
        out[2 * self.ks - 1] = C[1::2]
        out[2 * self.ks] = C[2::2]
        return out

    def restrict(self, C_full: np.ndarray) -> np.ndarray:
        """Coefficients in the full layout (any number of harmonics) restricted to the set."""
        C_full = np.asarray(C_full, float)
        out = np.zeros((self.nc, C_full.shape[1]))
        out[0] = C_full[0]
        Hf = (C_full.shape[0] - 1) // 2
        for i, k in enumerate(self.ks, start=1):
            if k <= Hf:
                out[2 * i - 1] = C_full[2 * k - 1]
                out[2 * i] = C_full[2 * k]
        return out

    def x_at_t0(self, C: np.ndarray) -> np.ndarray:
        """The state ``x(t0)`` of the series (a DAE's algebraic variables solved for from the
        differential states there, not read from their series)."""
        x = np.asarray(C[0] + C[1::2].sum(axis=0), float)
        if self.nd < self.nx:
            _, H = sample_field(self.system, np.array([self.t0]), x[None, :], self.p)
            x[self.nd:] = H[0]
        return x

    def relative_residual(self, C: np.ndarray, R: np.ndarray | None = None) -> float:
        """``max_i |R_i| / |(D C)_i|`` (2-norms over the harmonics of state ``i``): the
        residual relative to the size of the derivative it balances (dimensionless; a DAE's
        algebraic rows relative to ``w |C_z|``)."""
        R = self.residual(C) if R is None else R
        DC = np.linalg.norm(self.D @ C, axis=0)
        DC[self.nd:] = self.w * np.linalg.norm(C[:, self.nd:], axis=0)  # a DAE's algebraic rows: w |C_z|
        Rn = np.linalg.norm(R, axis=0)
        ref = np.maximum(DC, 1e-300)
        return float(np.max(Rn / ref)) if Rn.size else 0.0

    @staticmethod
    def _flat(C: np.ndarray) -> np.ndarray:
        return C.T.ravel()  # state-major

    def _unflat(self, z: np.ndarray) -> np.ndarray:
        return z.reshape(self.nx, self.nc).T

    # --------------------------------------------------------------- solve
    def solve(self, C0: np.ndarray, tol: float = 1e-10, max_iter: int = 100, floor_tol: float = 0.0,
              floor_rel: float = 0.0, lm: bool = False) -> tuple[np.ndarray, int, float, bool, list[dict[str, Any]], str]:
        """Quasi-Newton (Broyden) solve from ``C0``.

        ``floor_tol``: when no damped step reduces the residual any more but it is
        below ``floor_tol * max(1, max|C|)`` (or its :meth:`relative_residual` is below
        ``floor_rel``), accept it (``self.floor = True``): the residual floor of a
        non-smooth vector field.  ``lm``: when the damped quasi-Newton step stalls, go on
        with Levenberg-Marquardt steps (:meth:`levenberg_marquardt`) before giving up.

        Returns ``(C, iterations, residual, converged, history, failure)``.
        """
        self.floor = False
        z = self._flat(np.asarray(C0, float))
        R = self._flat(self.residual(self._unflat(z)))
        r = float(np.max(np.abs(R)))
        J = self.jacobian(self._unflat(z))
        n_jac = 1
        history: list[dict[str, Any]] = [{"iteration": 0, "residual": r, "jacobian": True}]
        fresh = True
        it = 0
        failure = ""

        def scale(zz: np.ndarray) -> float:
            return max(1.0, float(np.max(np.abs(zz))))

        def small(zz: np.ndarray, RR: np.ndarray, rr: float, level: float) -> bool:
            # absolute (relative to max(1, max|C|)) or relative to the derivative balanced
            return rr <= level * scale(zz) or self.relative_residual(self._unflat(zz), self._unflat(RR)) <= level

        lm_done = not lm
        while not small(z, R, r, tol) and it < max_iter:
            it += 1
            try:
                dz = np.linalg.solve(J, -R)
            except np.linalg.LinAlgError:
                dz = np.linalg.lstsq(J, -R, rcond=None)[0]
            lam, ok = 1.0, False
            r2 = float(np.linalg.norm(R))
            while lam >= 2.0 ** -10:
                zn = z + lam * dz
                Rn = self._flat(self.residual(self._unflat(zn)))
                rn = float(np.max(np.abs(Rn)))
                if math.isfinite(rn) and (float(np.linalg.norm(Rn)) < (1 - 1e-4 * lam) * r2
                                          or small(zn, Rn, rn, tol)):
                    ok = True
                    break
                lam *= 0.5
            if not ok:
                if not fresh:  # Broyden's Jacobian went stale: refresh and retry
                    J = self.jacobian(self._unflat(z))
                    n_jac += 1
                    fresh = True
                    history.append({"iteration": it, "residual": r, "jacobian": True, "note": "refresh"})
                    continue
                if not lm_done:
                    # a contact nonlinearity makes the residual kinked wherever a sample changes
                    # side: the Newton direction overshoots; Levenberg-Marquardt steps do not
                    lm_done = True
                    z, R, k_lm, hist_lm = self.levenberg_marquardt(z, R, max_iter - it, tol)
                    r = float(np.max(np.abs(R)))
                    history += [dict(h, iteration=it + h["iteration"]) for h in hist_lm]
                    it += k_lm
                    J = self.jacobian(self._unflat(z))
                    fresh = True
                    continue
                if r <= floor_tol * scale(z) or (
                        floor_rel > 0 and self.relative_residual(self._unflat(z), self._unflat(R)) <= floor_rel):
                    # a vector field that jumps across a switching surface makes the AFT
                    # residual jump whenever a sample changes side: the residual has a
                    # floor of the order of (jump)/M that no step can go below
                    self.floor = True
                    history.append({"iteration": it, "residual": r, "note": "residual floor"})
                    break
                failure = "the damped quasi-Newton step does not reduce the residual"
                break
            s = zn - z
            y = Rn - R
            slow = float(np.linalg.norm(Rn)) > 0.5 * r2
            z, R, r = zn, Rn, rn
            if slow:
                J = self.jacobian(self._unflat(z))
                n_jac += 1
                fresh = True
            else:  # Broyden's good update
                J = J + np.outer(y - J @ s, s) / float(s @ s)
                fresh = False
            history.append({"iteration": it, "residual": r, "step": lam, "jacobian": fresh})
        self.rel_residual = self.relative_residual(self._unflat(z), self._unflat(R))
        conv = small(z, R, r, tol) or self.floor
        if not conv and not failure:
            failure = f"no convergence in {max_iter} quasi-Newton iterations"
        return self._unflat(z), it, r, conv, history, failure

    def levenberg_marquardt(self, z: np.ndarray, R: np.ndarray, max_iter: int, tol: float
                            ) -> tuple[np.ndarray, np.ndarray, int, list[dict[str, Any]]]:
        """Levenberg-Marquardt on ``|R|^2`` in scaled variables (every state's coefficients
        by its amplitude ``s_i``, its equations by ``w s_i``), exact AFT Jacobian, from the
        flat coefficients ``z`` with residual ``R``; until the damping has to exceed 1e6 of
        the largest curvature, the squared residual falls by less than 1 % over 8 steps, or the
        residual is below ``tol``.  Returns ``(z, R, steps, history)``."""
        C = self._unflat(z)
        amp = np.sum(np.abs(C[1:]), axis=0)
        sc = np.where(amp > 0, amp, np.maximum(np.abs(C[0]) * 1e-6, 1e-300))
        if not np.all(amp > 0):
            sc = np.where(amp > 0, amp, np.max(amp) if np.any(amp > 0) else 1.0)
        us = np.repeat(sc, self.nc)
        rs = np.repeat(sc * self.w, self.nc)
        Rs = R / rs
        cost = float(Rs @ Rs)
        mu = 1e-3
        history: list[dict[str, Any]] = []
        k = 0
        eye = np.eye(len(z))
        while k < max_iter and mu <= 1e6:
            J = self.jacobian(self._unflat(z)) * us[None, :] / rs[:, None]
            A = J.T @ J
            g = J.T @ Rs
            dmax = float(np.max(np.diag(A))) or 1.0
            k += 1
            while mu <= 1e6:
                try:
                    du = -np.linalg.solve(A + mu * dmax * eye, g)
                except np.linalg.LinAlgError:
                    mu *= 10
                    continue
                zn = z + du * us
                Rn = self._flat(self.residual(self._unflat(zn)))
                Rns = Rn / rs
                cn = float(Rns @ Rns)
                if math.isfinite(cn) and cn < cost:
                    mu = max(mu / (10 if cn < 0.5 * cost else 3), 1e-12)
                    z, R, Rs, cost = zn, Rn, Rns, cn
                    break
                mu *= 10
            history.append({"iteration": k, "residual": float(np.max(np.abs(R))), "damping": mu,
                            "note": "levenberg-marquardt", "cost": cost})
            if k > 8 and cost > 0.99 * history[-9]["cost"]:
                break  # stagnates: the floor of the kinked residual
            if float(np.max(np.abs(R))) <= tol * max(1.0, float(np.max(np.abs(z)))):
                break
        return z, R, k, history
