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
``D - DFT diag(df/dx(t_m)) IDFT`` and refreshed when the Broyden steps stop
reducing the residual; steps are damped by backtracking.  The number of
harmonics is given (``harmonics=H``) or grown ``1, 2, 4, ...`` until the time
series changes by less than ``harmonics_tol`` relative to its peak-to-peak
(each solve starts from the previous one).

This is a second, independent periodic solver: it shares only the generated
model functions with shooting, not the integrator.  The Floquet multipliers of
the orbit it finds come from one engine integration of the variational
equations from the balanced state ``x(t0)`` (``monodromy=False`` skips it).

Honest results: when that monodromy has a multiplier at +1 to working precision
(:func:`~gearsym.analysis.isolation.isolation`, outside the known ``trivial``
directions), the orbit is not isolated and the balance may have "converged" only
relative to coefficients that a singular Jacobian blew up (the undamped oscillator at
exact resonance gives coefficients ~1e33 with a residual ~1e18); such a solve counts as
converged only if its residual is also below ``tol`` times the size of the initial guess.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ConvergenceError, GearsymError, ParameterError
from .isolation import isolation
from .orbit import PeriodicOrbit, finish_orbit

if TYPE_CHECKING:  # pragma: no cover
    from ..system import System

__all__ = ["HarmonicBalance", "harmonic_balance"]

#: Largest harmonic-balance Jacobian (entries): 2**28 doubles = 2 GiB.
MAX_JACOBIAN_VALUES = 2 ** 28


class HarmonicBalance:
    """The AFT harmonic-balance residual of a compiled system for a fixed ``H``.

    Parameters
    ----------
    system
        An explicit compiled system.
    period
        Period of the sought orbit.
    harmonics
        Number of harmonics ``H``.
    params
        Parameter overrides (SI).
    t0
        Time origin of the series.
    samples
        Number of time samples ``M`` of the AFT (default: a power of two >= 4(2H+1),
        at least 64).  Equidistant (a DFT, Liu et al. eqs. 15-17), except when the
        model has scheduled coefficient jumps: then Gauss-Legendre nodes on each
        segment between breakpoints (about ``M`` in all), because the DFT of an
        integrand that jumps between samples is only first-order accurate.
    """

    def __init__(self, system: System, period: float, harmonics: int, params: Mapping[str, float] | None = None,
                 t0: float = 0.0, samples: int | None = None):
        if system.generated.implicit:
            raise ParameterError("harmonic balance needs an explicit model (x' = f(t, x))")
        self.system = system
        self.H = H = int(harmonics)
        if H < 0:
            raise ParameterError(f"harmonics must be >= 0, got {harmonics}")
        self.P = float(period)
        self.w = 2 * np.pi / self.P
        self.t0 = float(t0)
        self.nx = system.generated.nx
        self.nc = 2 * H + 1
        n = self.nx * self.nc
        if float(n) * n > MAX_JACOBIAN_VALUES:
            raise ParameterError(f"harmonics={H}: the harmonic-balance Jacobian would have {n} x {n} entries "
                                 f"({8.0 * n * n / 2**30:.3g} GiB), above the limit of {MAX_JACOBIAN_VALUES:.3g} "
                                 f"({8 * MAX_JACOBIAN_VALUES / 2**30:g} GiB): use fewer harmonics")
        M = samples or max(64, 1 << int(math.ceil(math.log2(4 * self.nc))))
        if M < self.nc:
            raise ParameterError(f"samples={M} must be at least 2*harmonics+1 = {self.nc}")
        self.p = system.param_vector(params)
        breaks = None
        if system.generated.schedules:
            from .floquet import segment_breaks

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
        for k in range(1, H + 1):
            E[:, 2 * k - 1] = np.cos(k * th)
            E[:, 2 * k] = np.sin(k * th)
        self.E = E
        Ep = E.T * (2.0 * weights)[None, :]
        Ep[0] = weights
        self.Ep = Ep
        D = np.zeros((self.nc, self.nc))
        for k in range(1, H + 1):
            D[2 * k - 1, 2 * k] = k * self.w
            D[2 * k, 2 * k - 1] = -k * self.w
        self.D = D
        gen = system.generated
        self._rhs = gen.casadi_function("gs_rhs").map(M)
        self._jac = gen.casadi_function("gs_jac").map(M)
        self._sw = gen.casadi_function("gs_sw").map(M) if gen.nsw else None
        self._P = np.tile(self.p[:, None], (1, M))
        self._sched = self._sched_modes()
        self.n_evals = 0

    def _sched_modes(self) -> np.ndarray:
        gen = self.system.generated
        if not gen.schedules:
            return np.zeros((0, self.M))
        s = np.asarray(gen.casadi_function("gs_sched")(self.p)).ravel()
        rows = []
        i = 0
        for sch in gen.schedules:
            P = s[i]
            br = s[i + 1: i + 1 + sch["n_breaks"]]
            i += 1 + sch["n_breaks"]
            u = self.t / P
            n = np.floor(u)
            seg = np.searchsorted(br, u - n, side="right") - 1
            rows += [n, seg.astype(float)]
        return np.array(rows)

    # -------------------------------------------------------------- series
    def samples_of(self, C: np.ndarray) -> np.ndarray:
        """Time samples ``x(t_m)``, shape (M, nx), of coefficients ``C`` (nc, nx)."""
        return self.E @ C

    def _modes(self, X: np.ndarray) -> np.ndarray:
        if self._sw is not None:
            g = np.asarray(self._sw(self.t[None, :], X.T, self._P))
            sig = np.where(g >= 0, 1.0, -1.0)
        else:
            sig = np.zeros((0, self.M))
        return np.vstack([sig, self._sched])

    def residual(self, C: np.ndarray) -> np.ndarray:
        """``R(C) = D C - DFT(f(t_m, x(t_m)))``, shape (nc, nx)."""
        X = self.samples_of(C)
        F = np.asarray(self._rhs(self.t[None, :], X.T, self._P, self._modes(X))).T  # (M, nx)
        self.n_evals += 1
        return self.D @ C - self.Ep @ F

    def jacobian(self, C: np.ndarray) -> np.ndarray:
        """Exact AFT Jacobian ``dR/dC`` (ordering: state-major, then coefficient)."""
        X = self.samples_of(C)
        Jm = np.asarray(self._jac(self.t[None, :], X.T, self._P, self._modes(X)))  # (nx, nx*M)
        Jm = Jm.reshape(self.nx, self.M, self.nx).transpose(1, 0, 2)  # (M, i, j)
        # block (i, j) = D*delta_ij - Ep diag(J_ij) E   (BLAS products per block)
        nc = self.nc
        n = self.nx * nc
        Jr = np.zeros((n, n))
        for i in range(self.nx):
            for j in range(self.nx):
                col = Jm[:, i, j]
                if not np.any(col):
                    continue
                Jr[i * nc:(i + 1) * nc, j * nc:(j + 1) * nc] = -(self.Ep @ (col[:, None] * self.E))
            Jr[i * nc:(i + 1) * nc, i * nc:(i + 1) * nc] += self.D
        return Jr

    @staticmethod
    def _flat(C: np.ndarray) -> np.ndarray:
        return C.T.ravel()  # state-major

    def _unflat(self, z: np.ndarray) -> np.ndarray:
        return z.reshape(self.nx, self.nc).T

    # --------------------------------------------------------------- solve
    def solve(self, C0: np.ndarray, tol: float = 1e-10, max_iter: int = 100, floor_tol: float = 0.0
              ) -> tuple[np.ndarray, int, float, bool, list[dict[str, Any]], str]:
        """Quasi-Newton (Broyden) solve from ``C0``.

        ``floor_tol``: when no damped step reduces the residual any more but it is
        below ``floor_tol * max(1, max|C|)``, accept it (``self.floor = True``):
        the residual floor of a discontinuous vector field.

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

        while r > tol * scale(z) and it < max_iter:
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
                                          or rn <= tol * scale(zn)):
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
                if r <= floor_tol * scale(z):
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
        conv = r <= tol * scale(z) or self.floor
        if not conv and not failure:
            failure = f"no convergence in {max_iter} quasi-Newton iterations"
        return self._unflat(z), it, r, conv, history, failure


def _pad(C: np.ndarray, H_new: int) -> np.ndarray:
    out = np.zeros((2 * H_new + 1, C.shape[1]))
    n = min(C.shape[0], out.shape[0])
    out[:n] = C[:n]
    return out


def _dense(C: np.ndarray, n: int = 4096) -> np.ndarray:
    H = (C.shape[0] - 1) // 2
    th = 2 * np.pi * np.arange(n) / n
    y = np.tile(C[0], (n, 1))
    for k in range(1, H + 1):
        y += np.outer(np.cos(k * th), C[2 * k - 1]) + np.outer(np.sin(k * th), C[2 * k])
    return y


def harmonic_balance(system: System, period: float | None = None, periods: float = 1,
                     x0: Sequence[float] | None = None, params: Mapping[str, float] | None = None, *,
                     harmonics: int | None = None, max_harmonics: int = 256, harmonics_tol: float = 1e-6,
                     samples: int | None = None, t0: float = 0.0, tol: float = 1e-10, max_iter: int = 100,
                     guess: np.ndarray | PeriodicOrbit | None = None, monodromy: bool = True,
                     rtol: float = 1e-11, atol: float = 1e-13, raise_on_failure: bool = True,
                     initial_guess: str = "auto", transient: float = 50, floor_tol: float = 1e-5,
                     trivial: np.ndarray | None = None) -> PeriodicOrbit:
    """Find a periodic orbit by harmonic balance (AFT + quasi-Newton).

    Parameters
    ----------
    system
        An explicit compiled system.
    period, periods
        Orbit period (default ``periods`` forcing periods).
    x0
        A state used as the constant term of the first guess (default: the
        scene's initial state).
    params
        Parameter overrides (SI).
    harmonics
        Fixed number of harmonics; ``None``: grow ``1, 2, 4, ...`` up to
        ``max_harmonics`` until the time series changes by less than
        ``harmonics_tol`` (relative to each state's peak-to-peak).
    samples
        AFT samples per period (default: power of two >= 4(2H+1), >= 64).
    t0
        Time origin (the orbit's ``x0`` is ``x(t0)``).
    tol
        Residual tolerance of the algebraic system (relative to max(1, max|C|)).
    max_iter
        Quasi-Newton iterations per solve.
    guess
        Initial coefficients (shape (2H+1, nx)) or an orbit (e.g. from shooting)
        to start from instead of the harmonic continuation.
    monodromy
        Integrate the variational equations once from ``x(t0)`` for the Floquet
        multipliers, the events and the rattle state.
    rtol, atol
        Tolerances of that integration.
    raise_on_failure
        Raise :class:`ConvergenceError` if a solve fails.
    initial_guess
        ``"constant"``: continuation in the number of harmonics from the constant
        state ``x0``; ``"simulation"``: the harmonics of the last of ``transient``
        forcing periods simulated from ``x0`` (an initial guess only: the solution
        is the harmonic balance's); ``"auto"``: the first, then the second if a
        solve stalls (the constant start may sit in the basin of a local minimum of
        the residual, e.g. below an impacting orbit).
    transient
        Forcing periods simulated for the ``"simulation"`` guess.
    floor_tol
        Accept a residual that no damped step can reduce if it is below
        ``floor_tol * max(1, max|C|)``: with a vector field that jumps across a
        switching surface (mesh damping only in contact) the AFT residual jumps
        whenever a sample changes side and has a floor of order jump/samples.
        Recorded as ``"residual floor"`` in the history.
    trivial
        Known trivial directions of the state space (nx x k), e.g. a rigid-body mode: a
        multiplier +1 with its eigenvector in their span does not make the orbit
        non-isolated.  Default: none.

    Returns
    -------
    PeriodicOrbit
        With ``harmonics``, ``coefficients`` and ``info["harmonic_growth"]``
        (``H``, change, peak-to-peak of the first state, iterations per step)
        and ``info["defect"] = max |phi(t0 + P, x0) - x0|`` (truncation error seen by the integrator).

    Raises
    ------
    ConvergenceError
        The balance did not converge, or it converged only relative to coefficients
        blown up along a direction of a multiplier at +1 (no isolated orbit).
    """
    wall = time.perf_counter()
    from .shooting import _check_tolerances

    _check_tolerances(tol=tol, rtol=rtol, atol=atol)
    T = system.period(params)
    if period is None:
        if not T and system.has_forcing_period:
            system.require_period(params, "a periodic orbit")  # raises: says why
        if not T:
            raise ParameterError("the scene has no forcing period: give period=")
        period = float(periods) * T
    else:
        period = float(period)
        periods = period / T if T else 1.0
    nx = system.generated.nx
    base = system.x0 if x0 is None else np.asarray(x0, float)
    if base.shape != (nx,):
        raise ParameterError(f"x0 must have {nx} entries, got shape {base.shape}")

    def from_series(y: np.ndarray, H_g: int) -> np.ndarray:
        Cf = np.fft.rfft(y, axis=0) / len(y)
        Cg = np.zeros((2 * H_g + 1, nx))
        Cg[0] = Cf[0].real
        for k in range(1, min(H_g, Cf.shape[0] - 1) + 1):
            Cg[2 * k - 1] = 2 * Cf[k].real
            Cg[2 * k] = -2 * Cf[k].imag
        return Cg

    H_sim = int(harmonics or 16)
    attempts: list[tuple[str, Any]] = []
    if isinstance(guess, PeriodicOrbit):
        attempts.append(("orbit", from_series(guess.trajectory(n_out=max(64, 8 * H_sim) + 1).y[:-1], H_sim)))
    elif guess is not None:
        attempts.append(("coefficients", np.asarray(guess, float)))
    else:
        C_const = np.zeros((3, nx))
        C_const[0] = base
        attempts.append(("constant", C_const))
        if initial_guess == "auto":
            attempts.append(("simulation", None))
        elif initial_guess == "simulation":
            attempts = [("simulation", None)]
        elif initial_guess != "constant":
            raise ParameterError(f"initial_guess must be 'auto', 'constant' or 'simulation', got "
                                 f"'{initial_guess}'")

    def simulation_guess() -> np.ndarray:
        Tt = T if T else period
        n_tr = max(1, int(math.ceil(transient)))
        tr = system.simulate(t_end=t0, t0=t0 - n_tr * Tt, x0=base, rtol=1e-8, atol=1e-10, n_out=2,
                             params=params)
        tr = system.simulate(t_end=t0 + period, t0=t0, x0=tr.x_final, rtol=1e-8, atol=1e-10,
                             n_out=max(64, 8 * H_sim) + 1, params=params)
        return from_series(tr.y[:-1], H_sim)

    def grow(C: np.ndarray, stop_on_stall: bool):
        if harmonics is not None:
            sequence = [int(harmonics)]
        else:
            sequence = []
            H = max(1, (C.shape[0] - 1) // 2)
            while H < max_harmonics:
                sequence.append(H)
                H *= 2
            sequence.append(int(max_harmonics))
        growth: list[dict[str, Any]] = []
        prev_dense: np.ndarray | None = None
        total_it = 0
        history: list[dict[str, Any]] = []
        hb: HarmonicBalance | None = None
        r, conv, failure = math.inf, False, ""
        h_conv = harmonics is not None
        for H in sequence:
            hb = HarmonicBalance(system, period, H, params, t0, samples)
            C, it, r, conv, hist, failure = hb.solve(_pad(C, H), tol=tol, max_iter=max_iter,
                                                     floor_tol=floor_tol)
            total_it += it
            history += [dict(h, harmonics=H) for h in hist]
            if not conv:
                growth.append({"harmonics": H, "change": math.nan, "peak_to_peak": math.nan,
                               "iterations": it, "residual": r, "note": f"not converged ({failure})"})
                if stop_on_stall or H == sequence[-1]:
                    break
                prev_dense = None  # an intermediate truncation only provides a starting point
                continue
            dense = _dense(C)
            ptp = np.ptp(dense, axis=0)
            change = math.nan
            if prev_dense is not None:
                rel = np.max(np.abs(dense - prev_dense), axis=0) / np.maximum(ptp, 1e-300)
                change = float(np.max(rel))
            growth.append({"harmonics": H, "change": change, "peak_to_peak": float(ptp[0]),
                           "iterations": it, "residual": r})
            prev_dense = dense
            if harmonics is None and math.isfinite(change) and change < harmonics_tol:
                h_conv = True
                break
        return hb, C, r, conv, failure, growth, total_it, history, h_conv

    total_it = 0
    history: list[dict[str, Any]] = []
    growth: list[dict[str, Any]] = []
    used = ""
    guess_scale = 1.0
    for k, (name, C0) in enumerate(attempts):
        if C0 is None:
            C0 = simulation_guess()
        guess_scale = max(1.0, float(np.max(np.abs(C0))) if np.size(C0) else 1.0)
        last = k == len(attempts) - 1
        hb, C, r, conv, failure, g, it, hist, harmonics_converged = grow(C0, stop_on_stall=not last)
        total_it += it
        history += [dict(h, initial_guess=name) for h in hist]
        growth += [dict(x, initial_guess=name) for x in g]
        used = name
        if conv:
            break
    if not conv and raise_on_failure:
        hist_txt = ", ".join(f"{h['residual']:.3g}" for h in history[-10:])
        raise ConvergenceError(
            f"harmonic balance did not converge (H={hb.H} harmonics, initial guess '{used}'): {failure}; "
            f"residual history [{hist_txt}]. Try a guess (guess=<orbit from shooting>), a different x0, "
            f"more harmonics, or method='shooting'.")
    assert hb is not None and C is not None
    H = hb.H
    x_start = C[0] + sum(C[2 * k - 1] for k in range(1, H + 1)) if H else C[0].copy()
    x_start = np.asarray(x_start, float)
    mono = None
    events = []
    defect = math.nan
    iso = None
    if monodromy and conv:
        try:
            tr = system.simulate(t_end=t0 + period, t0=t0, x0=x_start, rtol=rtol, atol=atol, n_out=256,
                                 params=params, monodromy=True)
            mono = tr.monodromy
            events = list(tr.events)
            defect = float(np.max(np.abs(tr.x_final - x_start)))
            amp = np.max(np.abs(tr.y), axis=0)
            iso = isolation(mono, np.maximum(amp, max(1e-9 * float(np.max(amp)), atol / tol)), rtol, trivial)
        except GearsymError:
            mono = None
        if iso is not None and not iso.isolated and r > max(tol, floor_tol if hb.floor else tol) * guess_scale:
            # converged only relative to coefficients blown up along the unresolved direction
            conv = False
            failure = (f"{iso.reason()}: the balance's residual {r:.3g} is small only relative to coefficients "
                       f"of size {float(np.max(np.abs(C))):.3g} (initial guess {guess_scale:.3g})")
            if raise_on_failure:
                raise ConvergenceError(f"harmonic balance: {failure}. Add damping, move the forcing off the "
                                       f"resonance, or tighten rtol (now {rtol:g}) if the system is lightly "
                                       f"damped.")
    p = system.param_vector(params)
    samples = None
    if mono is None:  # no integration: contact sides from the series
        n_s = 4096
        samples = (t0 + period * np.arange(n_s) / n_s, _dense(C, n_s))
    return finish_orbit(
        system, x0=x_start, period=period, periods=periods, t0=t0, monodromy=mono, iterations=total_it,
        residual=r, converged=conv, method="hbm", params={k: v for k, v in system.param_dict(p).items()
                                                                        if k in system.params},
        events=events, samples=samples, harmonics=H, coefficients=C, history=history,
        info={"harmonic_growth": growth, "harmonics_converged": harmonics_converged, "defect": defect,
              "initial_guess": used, "quadrature": hb.quadrature, "failure": failure or None,
              "isolation": iso.to_dict() if iso is not None else None,
              "samples": hb.M, "tol": tol, "rtol": rtol, "atol": atol,
              "wall_s": time.perf_counter() - wall})
