"""Floquet theory: multipliers, and the exact monodromy of piecewise-constant LTV systems.

* :func:`floquet_multipliers` -- eigenvalues of a monodromy (or of the product of
  segment monodromies, multiple shooting), sorted by decreasing modulus.
* :class:`PiecewiseLTV` -- a linear time-varying system ``x' = A(t) x + f(t)`` whose
  ``A`` is constant on each segment of the period (rectangular mesh stiffness and
  damping, Vaishya & Singh 2001 formulation A, the damped Meissner equation).
  Its state transition matrix over one period is the product of matrix
  exponentials (V&S eqs. 25, 28, 31)::

      Phi = expm(A_N dt_N) ... expm(A_2 dt_2) expm(A_1 dt_1)

  and, when the excitation ``f`` is a sum of a constant, a ramp and harmonics of
  the base frequency (V&S eq. 41a-c), the forced response has the closed form of
  V&S section 5, written here with the exosystem ``w' = S w``, ``f = B_i w``
  (``w = [1, t, cos(k w t), sin(k w t), ...]``): on each segment
  ``[x; w](t) = expm([[A_i, B_i], [0, S]] (t - t_i)) [x; w](t_i)`` (Van Loan), so the
  Cauchy integral of V&S eq. 34 is one matrix exponential per segment and the
  periodic response is ``x0 = (I - Phi)^-1 x_p(T)`` (eqs. 36-39 with n -> infinity).

:meth:`PiecewiseLTV.from_system` extracts the segments from a compiled system
(``A_i`` from the generated Jacobian on each schedule segment, ``B_i`` by an exact
least-squares fit of ``f(t) = rhs(t, 0)``) and checks that the system really is
piecewise constant and linear; otherwise it raises
:class:`NotPiecewiseConstantError`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import expm

from ..errors import GearsymError

if TYPE_CHECKING:  # pragma: no cover
    from ..system import System

__all__ = ["NotPiecewiseConstantError", "PiecewiseLTV", "floquet_multipliers", "monodromy_product",
           "segment_breaks"]


class NotPiecewiseConstantError(GearsymError):
    """The system is not linear with piecewise-constant coefficients (no exact path)."""

    exit_code = 2


def monodromy_product(mats: Sequence[np.ndarray]) -> np.ndarray:
    """Product ``M_{N-1} ... M_1 M_0`` of segment monodromies (first segment first in the list)."""
    out = np.array(mats[0], dtype=float, copy=True)
    for m in mats[1:]:
        out = np.asarray(m, float) @ out
    return out


def floquet_multipliers(monodromy: np.ndarray | Sequence[np.ndarray]) -> np.ndarray:
    """Floquet multipliers: eigenvalues of the monodromy, by decreasing modulus.

    Parameters
    ----------
    monodromy
        The monodromy matrix, or the list of segment monodromies of a multiple
        shooting (first segment first), whose product is formed here.

    Returns
    -------
    ndarray (complex)
    """
    if isinstance(monodromy, (list, tuple)):
        monodromy = monodromy_product(monodromy)
    M = np.asarray(monodromy, dtype=float)
    if M.size == 0:
        return np.zeros(0, complex)
    if not np.all(np.isfinite(M)):
        return np.full(M.shape[0], complex(math.nan, math.nan))
    mu = np.linalg.eigvals(M).astype(complex)
    order = np.lexsort((-mu.imag, -np.abs(mu)))
    return mu[order]


def segment_breaks(system: System, period: float, params: Mapping[str, float] | None = None,
                   t0: float = 0.0) -> np.ndarray:
    """All scheduled breakpoints in ``[t0, t0 + period]`` (both ends included), sorted."""
    p = system.param_vector(params)
    s = np.asarray(system.generated.casadi_function("gs_sched")(p)).ravel()
    times = [t0, t0 + period]
    i = 0
    for sch in system.generated.schedules:
        P = float(s[i])
        fr = s[i + 1: i + 1 + sch["n_breaks"]]
        i += 1 + sch["n_breaks"]
        n0 = math.floor(t0 / P) - 1
        n1 = math.ceil((t0 + period) / P) + 1
        for n in range(n0, n1 + 1):
            for c in fr:
                tb = (n + float(c)) * P
                if t0 < tb < t0 + period:
                    times.append(tb)
    times = np.array(sorted(times))
    tiny = 64 * np.finfo(float).eps * max(1.0, abs(t0) + abs(period))
    keep = np.concatenate([[True], np.diff(times) > tiny])
    out = times[keep]
    out[-1] = t0 + period
    return out


def _basis(t: np.ndarray, omega: float, K: int) -> np.ndarray:
    """Exosystem states ``[1, t, cos(w t), sin(w t), ..., cos(K w t), sin(K w t)]`` (rows)."""
    t = np.atleast_1d(np.asarray(t, float))
    rows = [np.ones_like(t), t]
    for k in range(1, K + 1):
        rows += [np.cos(k * omega * t), np.sin(k * omega * t)]
    return np.array(rows)


def _exo_generator(omega: float, K: int) -> np.ndarray:
    n = 2 + 2 * K
    S = np.zeros((n, n))
    S[1, 0] = 1.0  # d t / dt = 1 * (the constant state)
    for k in range(1, K + 1):
        c, s = 2 * k, 2 * k + 1
        S[c, s] = -k * omega  # d cos / dt = -k w sin
        S[s, c] = k * omega   # d sin / dt = +k w cos
    return S


@dataclass
class PiecewiseLTV:
    """``x' = A_i x + B_i w(t)`` on segment ``i`` (``[t_i, t_{i+1})``) of one period.

    Attributes
    ----------
    times : ndarray, shape (N + 1,)
        Segment boundaries ``t0 = t_0 < t_1 < ... < t_N = t0 + period``.
    A : list of ndarray
        System matrix of each segment.
    B : list of ndarray or None
        Excitation matrices on the exosystem states :func:`_basis` (``None``: the
        homogeneous system only).
    omega, K
        Base frequency and number of harmonics of the exosystem.
    """

    times: np.ndarray
    A: list[np.ndarray]
    B: list[np.ndarray] | None = None
    omega: float = 0.0
    K: int = 0

    @property
    def period(self) -> float:
        """Length of the period."""
        return float(self.times[-1] - self.times[0])

    @property
    def nx(self) -> int:
        """State dimension."""
        return int(self.A[0].shape[0])

    def segment_transitions(self) -> list[np.ndarray]:
        """``expm(A_i dt_i)`` for each segment (V&S eq. 26)."""
        return [expm(A * float(dt)) for A, dt in zip(self.A, np.diff(self.times), strict=True)]

    def monodromy(self) -> np.ndarray:
        """The exact state transition matrix over one period (V&S eqs. 25, 31)."""
        return monodromy_product(self.segment_transitions())

    def multipliers(self) -> np.ndarray:
        """Floquet multipliers of :meth:`monodromy`."""
        return floquet_multipliers(self.monodromy())

    def _aug(self, i: int, dt: float) -> np.ndarray:
        assert self.B is not None
        n, m = self.nx, self.B[i].shape[1]
        Z = np.zeros((n + m, n + m))
        Z[:n, :n] = self.A[i]
        Z[:n, n:] = self.B[i]
        Z[n:, n:] = _exo_generator(self.omega, self.K)
        return expm(Z * dt)

    def propagate(self, x0: Sequence[float], t_out: Sequence[float] | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form response from ``x(t_0) = x0`` (V&S eqs. 34-39).

        Parameters
        ----------
        x0
            State at ``times[0]``.
        t_out
            Ascending output times in ``[times[0], times[-1]]``.

        Returns
        -------
        x_end : ndarray
            State at ``times[-1]``.
        y : ndarray, shape (len(t_out), nx)
            States at ``t_out``.
        """
        x = np.asarray(x0, float).copy()
        t_out = np.asarray([] if t_out is None else t_out, float)
        y = np.full((len(t_out), self.nx), np.nan)
        forced = self.B is not None
        for i in range(len(self.A)):
            ts, te = float(self.times[i]), float(self.times[i + 1])
            last = i == len(self.A) - 1
            sel = np.nonzero((t_out >= ts) & ((t_out < te) | (last & (t_out <= te))))[0]
            for k in sel:
                dt = float(t_out[k]) - ts
                if forced:
                    z = self._aug(i, dt) @ np.concatenate([x, _basis(ts, self.omega, self.K)[:, 0]])
                    y[k] = z[: self.nx]
                else:
                    y[k] = expm(self.A[i] * dt) @ x
            if forced:
                z = self._aug(i, te - ts) @ np.concatenate([x, _basis(ts, self.omega, self.K)[:, 0]])
                x = z[: self.nx]
            else:
                x = expm(self.A[i] * (te - ts)) @ x
        return x, y

    def periodic_state(self) -> np.ndarray:
        """The state at ``times[0]`` of the periodic forced response, ``(I - Phi)^-1 x_p``."""
        Phi = self.monodromy()
        if self.B is None:
            return np.zeros(self.nx)
        xp, _ = self.propagate(np.zeros(self.nx))
        return np.linalg.solve(np.eye(self.nx) - Phi, xp)

    # ----------------------------------------------------------- extraction
    @classmethod
    def from_system(cls, system: System, params: Mapping[str, float] | None = None,
                    period: float | None = None, periods: float = 1, t0: float = 0.0,
                    forcing: bool = True, harmonics: int = 8, check: bool = True) -> PiecewiseLTV:
        """Extract the piecewise-constant LTV form of a compiled system.

        Parameters
        ----------
        system
            An explicit compiled system without state-dependent switching.
        params
            Parameter overrides (SI).
        period, periods
            The period (default ``periods`` forcing periods).
        t0
            Start of the period.
        forcing
            Also fit the excitation ``f(t) = rhs(t, 0)`` on the exosystem basis
            (constant, ramp, ``harmonics * periods`` harmonics of ``2*pi/period``).
        check
            Verify linearity in ``x``, constancy of ``A`` on each segment and an
            exact fit of the excitation.

        Raises
        ------
        NotPiecewiseConstantError
            Implicit model, switching surfaces, nonlinearity, coefficients varying
            inside a segment, or an excitation outside the basis.
        """
        gen = system.generated
        if gen.implicit:
            raise NotPiecewiseConstantError("the exact LTV monodromy needs an explicit model")
        if gen.nsw:
            raise NotPiecewiseConstantError(
                f"the system has state-dependent switching ({', '.join(system.surface_names)}): it is "
                f"not linear time-varying")
        if period is None:
            T = system.period(params)
            if not T:
                raise NotPiecewiseConstantError("the scene has no forcing period; give period=")
            period = periods * T
        p = system.param_vector(params)
        jac = gen.casadi_function("gs_jac")
        rhs = gen.casadi_function("gs_rhs")
        times = segment_breaks(system, period, params, t0)
        nx = gen.nx
        rng = np.random.default_rng(12345)
        A_list: list[np.ndarray] = []
        B_list: list[np.ndarray] = []
        omega = 2 * np.pi / period
        K = int(max(1, round(harmonics * periods)))
        for i in range(len(times) - 1):
            ts, te = times[i], times[i + 1]
            tm = 0.5 * (ts + te)
            m = system._sched_mode(tm, p)
            A = np.asarray(jac(tm, np.zeros(nx), p, m), float)
            if check:
                scale = max(1.0, float(np.max(np.abs(A))))
                for frac in (0.13, 0.87):
                    tt = ts + frac * (te - ts)
                    xr = rng.standard_normal(nx)
                    A2 = np.asarray(jac(tt, xr, p, m), float)
                    if np.max(np.abs(A2 - A)) > 1e-11 * scale:
                        raise NotPiecewiseConstantError(
                            f"the Jacobian changes inside the segment [{ts:.6g}, {te:.6g}] (by "
                            f"{np.max(np.abs(A2 - A)):.3g}): the coefficients are not piecewise constant, "
                            f"or the system is nonlinear")
            A_list.append(A)
            if forcing:
                ns = 4 * (2 + 2 * K)
                tt = ts + (te - ts) * (np.arange(ns) + 0.5) / ns
                fs = np.array([np.asarray(rhs(t_, np.zeros(nx), p, m), float).ravel() for t_ in tt])
                Phi_b = _basis(tt, omega, K).T  # (ns, nb)
                if not np.any(fs):
                    B_list.append(np.zeros((nx, Phi_b.shape[1])))
                    continue
                # the ramp column makes the fit ill-conditioned on short segments; scale it
                coef, *_ = np.linalg.lstsq(Phi_b, fs, rcond=None)
                fit = Phi_b @ coef
                err = float(np.max(np.abs(fit - fs)))
                if check and err > 1e-9 * max(1.0, float(np.max(np.abs(fs)))):
                    raise NotPiecewiseConstantError(
                        f"the excitation rhs(t, 0) on segment [{ts:.6g}, {te:.6g}] is not a constant + ramp "
                        f"+ harmonics of 2*pi/{period:.6g} up to order {K} (fit error {err:.3g})")
                B_list.append(coef.T.copy())
        B = B_list if forcing and any(np.any(b) for b in B_list) else None
        return cls(times=times, A=A_list, B=B, omega=omega, K=K)
