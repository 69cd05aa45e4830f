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

from ...codegen.artifact import decode_schedules, generated_map
from ...errors import GearsymError

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["NotPiecewiseConstantError", "PiecewiseLTV", "exact_multipliers", "expm", "expm_batch",
           "floquet_multipliers", "monodromy_product", "segment_breaks"]


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


def segment_breaks(system: CompiledSystem, period: float, params: Mapping[str, float] | None = None,
                   t0: float = 0.0) -> np.ndarray:
    """All scheduled breakpoints in ``[t0, t0 + period]`` (both ends included), sorted."""
    return _breaks_from(system.schedule_table(system.param_vector(params)), period, t0)


def _sched_modes_from(table: Sequence[tuple[float, np.ndarray]], t: np.ndarray) -> np.ndarray:
    """Schedule part of the mode vector at times ``t`` (rows: n_0, seg_0, n_1, seg_1, ...)
    from the decoded schedules (:func:`gearsym.system.decode_schedules`)."""
    t = np.atleast_1d(np.asarray(t, float))
    rows = []
    for P, br in table:
        u = t / P
        n = np.floor(u)
        rows += [n, (np.searchsorted(br, u - n, side="right") - 1).astype(float)]
    return np.array(rows).reshape(len(rows), len(t))


def _breaks_from(table: Sequence[tuple[float, np.ndarray]], period: float, t0: float) -> np.ndarray:
    times = [t0, t0 + period]
    for P, fr in table:
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


_PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
           129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0,
           960960.0, 16380.0, 182.0, 1.0)
_THETA13 = 5.371920351148152


def expm(A: np.ndarray) -> np.ndarray:
    """Matrix exponential: scaling and squaring with the [13/13] Pade approximant.

    Higham (SIAM J. Matrix Anal. Appl. 26, 2005), the algorithm of
    ``scipy.linalg.expm`` without its degree selection, in plain numpy: for the
    small matrices here it avoids the per-call threading overhead of scipy's
    compiled version (milliseconds per 2x2 matrix on a loaded machine).
    """
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    norm = float(np.max(np.sum(np.abs(A), axis=0))) if n else 0.0
    if not math.isfinite(norm):
        return np.full_like(A, np.nan)
    sq = max(0, int(math.ceil(math.log2(norm / _THETA13)))) if norm > _THETA13 else 0
    A = A / (2.0 ** sq)
    b = _PADE13
    ident = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * ident)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * ident
    R = np.linalg.solve(V - U, V + U)
    for _ in range(sq):
        R = R @ R
    return R


def expm_batch(A: np.ndarray) -> np.ndarray:
    """:func:`expm` of a stack of matrices, shape (..., n, n), vectorised."""
    A = np.asarray(A, dtype=float)
    shp = A.shape
    n = shp[-1]
    A = A.reshape(-1, n, n)
    norm = np.max(np.sum(np.abs(A), axis=1), axis=1)
    with np.errstate(divide="ignore"):
        sq = np.where(norm > _THETA13, np.ceil(np.log2(np.maximum(norm, 1e-300) / _THETA13)), 0)
    sq = np.nan_to_num(sq, nan=0.0, posinf=0.0).astype(int)
    A = A / (2.0 ** sq)[:, None, None]
    b = _PADE13
    ident = np.eye(n)[None]
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * ident)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * ident
    R = np.linalg.solve(V - U, V + U)
    for k in range(int(sq.max()) if len(sq) else 0):
        m = sq > k
        R[m] = R[m] @ R[m]
    return R.reshape(shp)


def _mapped(gen, name: str, n: int):
    """The generated function ``name`` mapped over ``n`` points (:func:`gearsym.system.generated_map`)."""
    return generated_map(gen, name, n)


_CHUNK = 2048


def _call_columns(gen, name: str, *args: np.ndarray) -> np.ndarray:
    """Evaluate a generated function column-wise over many points (inputs (n_i, N)),
    in chunks of a fixed mapped size (building a CasADi map is costly for huge N)."""
    N = args[0].shape[1]
    if N <= _CHUNK:
        return np.asarray(_mapped(gen, name, N)(*args), float)
    f = _mapped(gen, name, _CHUNK)
    outs = []
    for a in range(0, N, _CHUNK):
        b = min(N, a + _CHUNK)
        chunk = [x[:, a:b] for x in args]
        if b - a < _CHUNK:  # pad with the last column
            chunk = [np.concatenate([c, np.repeat(c[:, -1:], _CHUNK - (b - a), axis=1)], axis=1)
                     for c in chunk]
        out = np.asarray(f(*chunk), float)
        k = out.shape[1] // _CHUNK
        outs.append(out[:, : (b - a) * k])
    return np.concatenate(outs, axis=1)


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

    def rounding_error(self) -> float:
        """Relative error of :meth:`monodromy`: ``eps * sum_i ||A_i dt_i||_1``.

        Scaling and squaring loses about ``eps * ||A dt||`` relative accuracy per
        exponential (Higham 2005), in the units of the states (no balancing): a stiff,
        badly scaled segment (mesh stiffness in N/m, deflections in m) costs digits.
        Measured on the undamped V&S pair: det(Phi) - 1 up to 1.6e-10 where this is 3e-10.
        """
        dts = np.diff(self.times)
        return float(np.finfo(float).eps * sum(np.max(np.sum(np.abs(A * dt), axis=0)) for A, dt in
                                                zip(self.A, dts, strict=True)))

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
    def from_system(cls, system: CompiledSystem, params: Mapping[str, float] | None = None,
                    period: float | None = None, periods: float = 1, t0: float = 0.0,
                    forcing: bool = True, harmonics: int = 8, check: bool = True) -> PiecewiseLTV:
        """Extract the piecewise-constant LTV form of a compiled system.

        Parameters
        ----------
        system
            An explicit compiled system without state-dependent switching.
        params
            Parameter overrides (declared units, as ``--set``).
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
        times = segment_breaks(system, period, params, t0)
        nx = gen.nx
        nseg = len(times) - 1
        omega = 2 * np.pi / period
        K = int(max(1, round(harmonics * periods)))
        ts, te = times[:-1], times[1:]
        modes = np.array([system._sched_mode(0.5 * (a + b), p) for a, b in zip(ts, te, strict=True)]).T
        modes = modes.reshape(-1, nseg)
        # Jacobian at the midpoint (x = 0) and at two more points with random x (checks)
        fr = np.array([0.5, 0.13, 0.87])
        tj = (ts[None, :] + fr[:, None] * (te - ts)[None, :]).ravel()  # (3*nseg,), row-major by fr
        xj = np.zeros((nx, 3 * nseg))
        xj[:, nseg:] = np.random.default_rng(12345).standard_normal((nx, 2 * nseg))
        mj = np.tile(modes, (1, 3))
        J = _mapped(gen, "gs_jac", 3 * nseg)(tj[None, :], xj, np.tile(p[:, None], (1, 3 * nseg)), mj)
        J = np.asarray(J, float).reshape(nx, 3 * nseg, nx).transpose(1, 0, 2)
        A_list = [J[i].copy() for i in range(nseg)]
        if check:
            for i in range(nseg):
                scale = max(1.0, float(np.max(np.abs(A_list[i]))))
                dev = max(float(np.max(np.abs(J[nseg + i] - A_list[i]))),
                          float(np.max(np.abs(J[2 * nseg + i] - A_list[i]))))
                if dev > 1e-11 * scale:
                    raise NotPiecewiseConstantError(
                        f"the Jacobian changes inside the segment [{ts[i]:.6g}, {te[i]:.6g}] (by {dev:.3g}): "
                        f"the coefficients are not piecewise constant, or the system is nonlinear")
        B_list: list[np.ndarray] = []
        if forcing:
            ns = 4 * (2 + 2 * K)
            u = (np.arange(ns) + 0.5) / ns
            tt = (ts[:, None] + u[None, :] * (te - ts)[:, None]).ravel()  # segment-major
            mm = np.repeat(modes, ns, axis=1)
            F = _mapped(gen, "gs_rhs", nseg * ns)(tt[None, :], np.zeros((nx, nseg * ns)),
                                                  np.tile(p[:, None], (1, nseg * ns)), mm)
            F = np.asarray(F, float).T.reshape(nseg, ns, nx)
            for i in range(nseg):
                fs = F[i]
                if not np.any(fs):
                    B_list.append(np.zeros((nx, 2 + 2 * K)))
                    continue
                Phi_b = _basis(tt[i * ns:(i + 1) * ns], omega, K).T  # (ns, nb)
                coef, *_ = np.linalg.lstsq(Phi_b, fs, rcond=None)
                err = float(np.max(np.abs(Phi_b @ coef - fs)))
                if check and err > 1e-9 * max(1.0, float(np.max(np.abs(fs)))):
                    raise NotPiecewiseConstantError(
                        f"the excitation rhs(t, 0) on segment [{ts[i]:.6g}, {te[i]:.6g}] is not a constant + "
                        f"ramp + harmonics of 2*pi/{period:.6g} up to order {K} (fit error {err:.3g})")
                B_list.append(coef.T.copy())
        B = B_list if forcing and any(np.any(b) for b in B_list) else None
        return cls(times=times, A=A_list, B=B, omega=omega, K=K)


def exact_multipliers(system: CompiledSystem, params_list: Sequence[Mapping[str, float]], periods: float = 1,
                      check: bool = True, monodromies: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Floquet multipliers of a piecewise-constant LTV system at many parameter points.

    The vectorised form of ``PiecewiseLTV.from_system(...).multipliers()`` for
    stability maps: one mapped call of the generated Jacobian for all points and
    segments, a batched matrix exponential and batched eigenvalues.

    Parameters
    ----------
    system
        Explicit compiled system without switching surfaces.
    params_list
        Parameter overrides (declared units) of each point.
    periods
        Period in forcing periods.
    check
        Verify that the Jacobian is constant on each segment (and independent of x).
    monodromies
        Also return the monodromy of each point and its relative rounding error (for the
        stability rule of :mod:`gearsym.analysis.periodic._stability`).

    Returns
    -------
    ndarray, shape (len(params_list), nx), complex
        Multipliers of each point, by decreasing modulus.  With ``monodromies``, also
        the monodromies, shape ``(len(params_list), nx, nx)``, and the relative error
        ``eps * sum_i ||A_i dt_i||_1`` of each (:meth:`PiecewiseLTV.rounding_error`).

    Raises
    ------
    NotPiecewiseConstantError
    """
    gen = system.generated
    if gen.implicit or gen.nsw:
        raise NotPiecewiseConstantError("the exact monodromy needs an explicit model without switching")
    N = len(params_list)
    nx = gen.nx
    P = np.array([system.param_vector(p) for p in params_list]).T.reshape(-1, N)
    T = _call_columns(gen, "gs_period", P).ravel() * periods
    if not np.all(np.isfinite(T) & (T > 0)):
        raise NotPiecewiseConstantError("the scene has no finite forcing period at some points")
    S = _call_columns(gen, "gs_sched", P).reshape(-1, N) if gen.schedules else np.zeros((0, N))
    tables = [decode_schedules(S[:, k], gen.schedules) for k in range(N)]
    seg_times = [_breaks_from(tables[k], float(T[k]), 0.0) for k in range(N)]
    out = np.full((N, nx), complex(math.nan, math.nan))
    monos = np.full((N, nx, nx), math.nan)
    errs = np.full(N, math.nan)
    groups: dict[int, list[int]] = {}
    for k, tt in enumerate(seg_times):
        groups.setdefault(len(tt) - 1, []).append(k)
    rng = np.random.default_rng(12345)
    for nseg, idx in groups.items():
        idx_a = np.array(idx)
        G = len(idx)
        tt = np.array([seg_times[k] for k in idx])  # (G, nseg+1)
        ts, te = tt[:, :-1], tt[:, 1:]
        fr = np.array([0.5, 0.13, 0.87]) if check else np.array([0.5])
        nf = len(fr)
        tj = ts[None] + fr[:, None, None] * (te - ts)[None]  # (nf, G, nseg)
        mid = 0.5 * (ts + te)
        nm = 2 * len(gen.schedules)
        modes = np.zeros((nm, G, nseg))
        for gi, k in enumerate(idx):
            modes[:, gi, :] = _sched_modes_from(tables[k], mid[gi])
        ncol = nf * G * nseg
        tcol = tj.reshape(1, ncol)
        xcol = np.zeros((nx, nf, G * nseg))
        if check:
            xcol[:, 1:, :] = rng.standard_normal((nx, nf - 1, G * nseg))
        xcol = xcol.reshape(nx, ncol)
        pcol = np.repeat(P[:, idx_a][:, None, :, None], nf, axis=1)
        pcol = np.repeat(pcol, nseg, axis=3).reshape(P.shape[0], ncol)
        mcol = np.repeat(modes[:, None], nf, axis=1).reshape(nm, ncol)
        J = _call_columns(gen, "gs_jac", tcol, xcol, pcol, mcol)
        J = J.reshape(nx, nf, G, nseg, nx).transpose(1, 2, 3, 0, 4)  # (nf, G, nseg, i, j)
        A = J[0]
        if check and nf > 1:
            dev = np.max(np.abs(J[1:] - A[None]), axis=(0, 3, 4))
            scale = np.maximum(1.0, np.max(np.abs(A), axis=(2, 3)))
            bad = dev > 1e-11 * scale
            if np.any(bad):
                gi, si = np.argwhere(bad)[0]
                raise NotPiecewiseConstantError(
                    f"the Jacobian changes inside segment {si} (by {dev[gi, si]:.3g}) at point "
                    f"{idx[gi]}: the coefficients are not piecewise constant, or the system is nonlinear")
        Adt = A * (te - ts)[:, :, None, None]
        errs[idx_a] = np.finfo(float).eps * np.sum(np.max(np.sum(np.abs(Adt), axis=-2), axis=-1), axis=1)
        E = expm_batch(Adt)  # (G, nseg, nx, nx)
        Mono = E[:, 0]
        for si in range(1, nseg):
            Mono = E[:, si] @ Mono
        monos[idx_a] = Mono
        mu = np.linalg.eigvals(Mono)
        order = np.argsort(-np.abs(mu), axis=1, kind="stable")
        out[idx_a] = np.take_along_axis(mu, order, axis=1)
    return (out, monos, errs) if monodromies else out
