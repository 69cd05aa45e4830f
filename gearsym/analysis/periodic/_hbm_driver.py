"""Harmonic balance, the solver: :func:`harmonic_balance` drives the AFT residual of
:class:`~gearsym.analysis.periodic.HarmonicBalance` through guesses, harmonic growth, adaptive
AFT sampling and the time-domain verification of every orbit.

Per harmonic set of the growth (:mod:`gearsym.analysis.periodic._hbm_sets`):

1. solve the AFT system (:meth:`HarmonicBalance.solve`) from the previous set's solution;
2. **AFT samples**: evaluate the residual of that solution on a grid twice as fine; if it
   does not agree (above ``max(2 r, aft_tol)`` relative to the derivative it balances), the
   contact nonlinearity is under-sampled: double the samples and solve again;
3. **verify in the time domain**: integrate one period from the series' ``x(t0)`` and
   compare, ``defect = max_i |phi(t0 + P, x(t0)) - x(t0)|_i / size_i`` with ``size_i`` the
   peak-to-peak of state ``i`` on the series (the truncation error as the integrator sees
   it, relative to the orbit's size);
4. stop growing when ``defect <= defect_tol`` (and, if ``harmonics_tol`` is given, the
   series changed by less than it since the previous set); give up when the defect of a set
   is more than :data:`DEFECT_BLOWUP` times the smallest one so far: the larger set's balance
   moved away from the orbit (measured on the free two-stage train with contact loss: 0.067 at
   64 harmonics, 41 at 128 with the Newton iteration stuck on a residual floor, and the next
   set took 7 more minutes to fail the same way).

An orbit counts as converged only if its defect is at most ``defect_tol`` (with harmonics fixed
by the caller, at most :data:`FIXED_HARMONICS_DEFECT`: the series is an approximation, but one
that does not close to a tenth of the orbit's size is no orbit); the defect is
``info["verification"]``, the independent integration every reported orbit passes.  The
rattle state comes from the harmonic series itself (contact sides of the sampled
series); the Floquet multipliers from one variational integration from ``x(t0)``
(shooting from the HBM orbit), the rattle state of which is kept for comparison.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import ConvergenceError, GearsymError, ParameterError
from .._options import check_tolerances, resolve_options
from ._hbm import HarmonicBalance
from ._hbm_sets import carriers_of, excitation_harmonics, growth_sets
from ._isolation import isolation
from ._options import HarmonicBalanceOptions
from ._orbit import VANISHING, PeriodicOrbit, SolvedOrbit, finish_orbit
from ._rattle import mesh_rattle_states as rattle_states
from ._verification import orbit_period

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["FIXED_HARMONICS_DEFECT", "harmonic_balance", "state_sizes", "time_defect"]

#: Largest Jacobian (entries) that the automatic growth goes to: 2**26 doubles = 512 MiB.
GROWTH_JACOBIAN_VALUES = 2 ** 26
#: A balance with the harmonics fixed by the caller is an approximation: it is reported as an orbit
#: when one period integrated from its ``x(t0)`` closes to this fraction of every state's size
#: (the truncation error of one or two harmonics on the benchmark oscillator's orbits was 0.3 % to
#: 6.7 %); beyond it the series is not the orbit's (and ``defect_tol`` when that is larger).
FIXED_HARMONICS_DEFECT = 0.1
#: The growth gives up when a set's defect exceeds this many times the smallest defect of the
#: sets before it (converging balances only ever reduced it; those in the tests stay within 5x).
DEFECT_BLOWUP = 10.0


def dense_series(C: np.ndarray, n: int = 4096) -> np.ndarray:
    """Samples ``x(t0 + j P / n)``, shape (n, nx), of full-layout coefficients (2H+1, nx)."""
    H = (C.shape[0] - 1) // 2
    n_fft = max(n, 2 * H + 2)
    Z = np.zeros((n_fft // 2 + 1, C.shape[1]), complex)
    Z[0] = C[0] * n_fft
    if H:
        Z[1:H + 1] = 0.5 * n_fft * (C[1::2] - 1j * C[2::2])
    return np.fft.irfft(Z, n=n_fft, axis=0)


def default_samples(H: int) -> int:
    """AFT samples for highest harmonic ``H``: a power of two >= 4(2H+1), at least 64."""
    return max(64, 1 << int(math.ceil(math.log2(4 * (2 * H + 1)))))


def series_from_samples(y: np.ndarray, H: int) -> np.ndarray:
    """Full-layout coefficients (2H+1, nx) of equidistant samples ``y`` (n, nx) of one period."""
    Cf = np.fft.rfft(y, axis=0) / len(y)
    Cg = np.zeros((2 * H + 1, y.shape[1]))
    Cg[0] = Cf[0].real
    m = min(H, Cf.shape[0] - 1)
    Cg[1:2 * m:2] = 2 * Cf[1:m + 1].real
    Cg[2:2 * m + 1:2] = -2 * Cf[1:m + 1].imag
    return Cg


def state_sizes(Y: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Size of every state on an orbit: its peak-to-peak, at least 1e-6 of its magnitude
    (a state that does not move is measured against its value), at least
    :data:`~gearsym.analysis.periodic.VANISHING` of the largest state's size (a state that
    vanishes on the orbit is round-off: its defect relative to its own size was ~1, and
    harmonic balance of the 4-planet set failed at 64 harmonics), at least ``floor``, never
    zero.

    ``floor``: the absolute floor, ``atol / defect_tol`` in the driver (as shooting's state
    scales, at least ``atol / tol``): a defect below the integrator's ``atol`` always passes.
    Without it the trivial orbit ``x = 0`` was measured against its own round-off (noise
    divided by noise: the damped Meissner equation grew to 512 harmonics and failed).
    """
    ptp = np.ptp(Y, axis=0)
    mag = np.max(np.abs(Y), axis=0)
    size = np.maximum(ptp, 1e-6 * mag)
    top = float(np.max(size)) if size.size else 0.0
    return np.maximum(size, max(VANISHING * top, float(floor), 1e-300))


def time_defect(system: CompiledSystem, x_start: np.ndarray, t0: float, period: float, params: Mapping[str, float] | None,
                sizes: np.ndarray, rtol: float, atol: float, monodromy: bool = False):
    """``(relative defect, absolute defect, trajectory)`` of one period integrated from ``x_start``.

    Over the differential states: a DAE's algebraic variables follow from them (the integration
    makes them consistent), the orbit closes when they do."""
    tr = system.simulate(t_end=t0 + period, t0=t0, x0=x_start, rtol=rtol, atol=atol, n_out=256, params=params,
                         monodromy=monodromy)
    nd = system.generated.nx - len(system.generated.algebraic)
    d = np.abs(tr.x_final - x_start)[:nd]
    return float(np.max(d / np.asarray(sizes)[:nd])), float(np.max(d)), tr


def harmonic_balance(system: CompiledSystem, period: float | None = None, periods: float = 1,
                     x0: Sequence[float] | None = None, params: Mapping[str, float] | None = None, *,
                     guess: np.ndarray | PeriodicOrbit | None = None, options: HarmonicBalanceOptions | None = None,
                     **keywords: Any) -> PeriodicOrbit:
    """Find a periodic orbit by harmonic balance (AFT + quasi-Newton).

    Parameters
    ----------
    system
        The compiled system (an implicit model or a DAE too: the derivatives and the algebraic
        variables are solved for at every sample, :mod:`gearsym.analysis.periodic._hbm`).
    period, periods
        Orbit period (default ``periods`` forcing periods; a positive whole number for a forced
        system, and ``period`` a whole number of forcing periods).
    x0
        A state used as the constant term of the first guess (default: the
        scene's initial state).
    params
        Parameter overrides (declared units, as ``--set``).
    guess
        Initial coefficients (shape (2H+1, nx)) or an orbit (e.g. from shooting)
        to start from instead of the harmonic continuation.
    options
        The settings (:class:`~gearsym.analysis.periodic.HarmonicBalanceOptions`:
        ``harmonics``, ``max_harmonics``, ``harmonics_tol``, ``samples``, ``t0``, ``tol``,
        ``max_iter``, ``monodromy``, ``rtol``, ``atol``, ``raise_on_failure``,
        ``initial_guess``, ``transient``, ``floor_tol``, ``trivial``, ``defect_tol``,
        ``aft_tol``, ``max_samples``, ``floor_rel``; each documented there with its default).
    **keywords
        Any of those settings one by one (``harmonic_balance(system, harmonics=8)``); a
        keyword wins over ``options``.

    Returns
    -------
    PeriodicOrbit
        With ``harmonics`` (the highest), ``coefficients`` (full layout, zeros outside
        the set), ``info["harmonic_set"]``, ``info["harmonic_growth"]`` (per set:
        harmonics, samples and their checks, iterations, residual, change, defect),
        ``info["defect"] = max |phi(t0 + P, x0) - x0|`` and ``info["defect_relative"]``
        (per state relative to its peak-to-peak).  The rattle state comes from the
        harmonic series (``info["rattle_states_integration"]``: that of the integration).

    Raises
    ------
    ParameterError
        Bad options, a keyword that is no setting of
        :class:`~gearsym.analysis.periodic.HarmonicBalanceOptions`.
    ConvergenceError
        The balance did not converge, or it converged only relative to coefficients
        blown up along a direction of a multiplier at +1 (no isolated orbit).
    """
    o = resolve_options(options, HarmonicBalanceOptions, keywords, "harmonic_balance")
    return _Balance(system, params, o).run(period, periods, x0, guess)


@dataclass
class _Grown:
    """The outcome of the harmonic growth from one initial guess (:meth:`_Balance.grow`)."""

    hb: HarmonicBalance
    C: np.ndarray
    residual: float
    converged: bool
    failure: str
    growth: list[dict[str, Any]]
    iterations: int
    history: list[dict[str, Any]]
    verified: tuple[float, float, np.ndarray] | None  # (relative defect, absolute defect, state sizes)


@dataclass
class _Balance:
    """One :func:`harmonic_balance` call: its harmonic sets, initial guesses, the solve of one set
    with adaptive AFT samples, the growth through the sets and the assembled orbit."""

    system: CompiledSystem
    params: Mapping[str, float] | None
    o: HarmonicBalanceOptions
    excitation: dict[int, float] = field(default_factory=dict, init=False)
    carriers: list[int] = field(default_factory=list, init=False)

    def run(self, period: float | None, periods: float, x0: Sequence[float] | None,
            guess: np.ndarray | PeriodicOrbit | None) -> PeriodicOrbit:
        """The orbit (see :func:`harmonic_balance`)."""
        wall = time.perf_counter()
        o, system = self.o, self.system
        check_tolerances(tol=o.tol, rtol=o.rtol, atol=o.atol, defect_tol=o.defect_tol, aft_tol=o.aft_tol)
        self.floor = o.atol / o.defect_tol  # the absolute floor of every state's size (see state_sizes)
        self.period, self.periods = orbit_period(system, self.params, period, periods)  # whole forcing periods
        self.T = system.period(self.params)
        nx = system.generated.nx
        self.base = system.x0 if x0 is None else np.asarray(x0, float)
        if self.base.shape != (nx,):
            raise ParameterError(f"x0 must have {nx} entries, got shape {self.base.shape}")
        if o.max_harmonics < 1:
            raise ParameterError(f"max_harmonics must be >= 1, got {o.max_harmonics}")
        self.sets = self._harmonic_sets()
        # no aliasing of the excitation onto the kept harmonics: samples above twice the highest one
        self.M_exc = (default_samples(min(max(self.excitation), 4 * o.max_harmonics))
                      if self.excitation and o.samples is None else None)
        g, used, guess_scale, total_it, history, growth = self._solve_from(self._attempts(guess))
        if not g.converged and o.raise_on_failure:
            hist_txt = ", ".join(f"{h['residual']:.3g}" for h in history[-10:])
            raise ConvergenceError(
                f"harmonic balance did not converge ({len(g.hb.ks)} harmonics up to {g.hb.H}, initial guess "
                f"'{used}'): {g.failure}; residual history [{hist_txt}]. Try a guess (guess=<orbit from "
                f"shooting>), a different x0, more harmonics, or method='shooting'.")
        return self._orbit(g, used, guess_scale, total_it, history, growth, wall)

    # ---------------------------------------------------------- sets and guesses
    def _harmonic_sets(self) -> list[np.ndarray]:
        o, nx = self.o, self.system.generated.nx
        if o.harmonics is not None:
            return [np.arange(1, int(o.harmonics) + 1) if isinstance(o.harmonics, (int, np.integer))
                    else np.asarray(list(o.harmonics), int)]
        self.excitation = excitation_harmonics(self.system, self.period, self.base, self.params, o.t0)
        self.carriers = [c for c in carriers_of(self.excitation) if c <= o.max_harmonics]
        sets = growth_sets(self.carriers, o.max_harmonics)
        budget = [s for s in sets if float(nx * (2 * len(s) + 1)) ** 2 <= GROWTH_JACOBIAN_VALUES]
        return budget or sets[:1]

    def _attempts(self, guess: np.ndarray | PeriodicOrbit | None) -> list[tuple[str, Any]]:
        """The initial guesses to try, in order: ``(name, coefficients or None)`` (``None``: a
        simulated period, made when its turn comes)."""
        attempts: list[tuple[str, Any]] = []
        if isinstance(guess, PeriodicOrbit):
            Hg = int(max(s.max() if len(s) else 1 for s in self.sets))
            attempts.append(("orbit", series_from_samples(guess.trajectory(n_out=max(64, 8 * Hg) + 1).y[:-1], Hg)))
            return attempts
        if guess is not None:
            return [("coefficients", np.asarray(guess, float))]
        C_const = np.zeros((3, self.system.generated.nx))
        C_const[0] = self.base
        attempts.append(("constant", C_const))
        initial_guess = self.o.initial_guess
        if initial_guess == "auto":
            # with contact surfaces the constant state may sit in the gap (no stiffness): start
            # from a simulated period there, from the constant state (cheaper) otherwise
            attempts.insert(0 if self.system.generated.nsw else 1, ("simulation", None))
        elif initial_guess == "simulation":
            attempts = [("simulation", None)]
        elif initial_guess != "constant":
            raise ParameterError(f"initial_guess must be 'auto', 'constant' or 'simulation', got "
                                 f"'{initial_guess}'")
        return attempts

    def _simulation_guess(self) -> np.ndarray:
        """The harmonics of the last of ``transient`` forcing periods simulated from ``x0``."""
        o, system, period = self.o, self.system, self.period
        H_sim = int(max(self.sets[0].max() if len(self.sets[0]) else 1, 16))
        Tt = self.T if self.T else period
        n_tr = max(1, int(math.ceil(o.transient)))
        Hs = int(max(s.max() if len(s) else 1 for s in self.sets))
        tr = system.simulate(t_end=o.t0, t0=o.t0 - n_tr * Tt, x0=self.base, rtol=1e-8, atol=1e-10, n_out=2,
                             params=self.params)
        tr = system.simulate(t_end=o.t0 + period, t0=o.t0, x0=tr.x_final, rtol=1e-8, atol=1e-10,
                             n_out=max(64, 8 * Hs, 8 * H_sim) + 1, params=self.params)
        return series_from_samples(tr.y[:-1], Hs)

    # ---------------------------------------------------------- one set
    def _solve_set(self, ks: np.ndarray, C_full: np.ndarray, M: int | None):
        """Solve on one set; with ``samples=None`` double the samples until the residual on a
        grid twice as fine agrees: the Newton correction it implies moves no state by more than
        ``aft_tol`` of its size.  Returns (hb, C_full, solve outputs, aft checks)."""
        o, system, period, params = self.o, self.system, self.period, self.params
        checks: list[dict[str, Any]] = []
        if o.samples is None:
            M = max(M or 0, self.M_exc or 0, default_samples(int(ks.max()) if len(ks) else 0))
        while True:
            hb = HarmonicBalance(system, period, ks, params, o.t0, M)
            C, it, r, conv, hist, failure = hb.solve(hb.restrict(C_full), tol=o.tol, max_iter=o.max_iter,
                                                     floor_tol=o.floor_tol, floor_rel=o.floor_rel, lm=True)
            C_full = hb.full_coefficients(C)
            if o.samples is not None or not hb.uniform or not conv or hb.floor or len(checks) >= 3 \
                    or 2 * hb.M > o.max_samples:
                # (a residual floor of a kinked residual is no sampling question; at most 8x)
                return hb, C_full, (it, r, conv, hist, failure), checks
            fine = HarmonicBalance(system, period, ks, params, o.t0, 2 * hb.M)
            Rf = hb._flat(fine.residual(C))
            try:
                dz = np.linalg.solve(hb.jacobian(C), -Rf)
            except np.linalg.LinAlgError:
                return hb, C_full, (it, r, conv, hist, failure), checks
            sizes = state_sizes(dense_series(C_full, max(1024, 4 * hb.H)), self.floor)
            move = float(np.max(np.sum(np.abs(hb._unflat(dz)), axis=0) / sizes))
            checks.append({"samples": hb.M, "correction": move})
            if move <= o.aft_tol:
                return hb, C_full, (it, r, conv, hist, failure), checks
            M = 2 * hb.M

    # ---------------------------------------------------------- the growth
    def _grow(self, C: np.ndarray, stop_on_stall: bool) -> _Grown:
        """Solve set after set (each from the previous solution) until the time-domain defect is
        below ``defect_tol``, the defect blows up, or a solve fails (``stop_on_stall``)."""
        o = self.o
        g = _Grown(hb=None, C=C, residual=math.inf, converged=False, failure="", growth=[],  # type: ignore[arg-type]
                   iterations=0, history=[], verified=None)
        prev_dense: np.ndarray | None = None
        M = o.samples
        C_guess = C
        best: tuple[float, int] | None = None  # (smallest defect, its number of harmonics)
        for j, ks in enumerate(self.sets):
            g.hb, C, (it, g.residual, g.converged, hist, g.failure), checks = self._solve_set(ks, C, M)
            if not g.converged:
                C = C_guess  # the next set starts from the guess, not from a failed solve
            if o.samples is None and len(checks) > 1:
                M = g.hb.M  # the contact needed more samples: keep them for the next set
            g.C = C
            g.iterations += it
            g.history += [dict(h, harmonics=len(ks)) for h in hist]
            entry: dict[str, Any] = {"harmonics": len(ks), "max_harmonic": int(g.hb.H), "samples": g.hb.M,
                                     "iterations": it, "residual": g.residual,
                                     "relative_residual": g.hb.rel_residual}
            if checks:
                entry["aft_checks"] = checks
            if not g.converged:
                g.growth.append(dict(entry, change=math.nan, peak_to_peak=math.nan, defect=math.nan,
                                     note=f"not converged ({g.failure})"))
                if stop_on_stall or j == len(self.sets) - 1:
                    break
                prev_dense = None
                continue
            dense, d_rel = self._verify_set(g, entry, prev_dense)
            prev_dense = dense
            if o.harmonics is not None:
                break
            if best is not None and not d_rel <= max(DEFECT_BLOWUP * best[0], o.defect_tol):
                g.failure = (f"adding harmonics moved the balance away from the orbit: its time-domain defect "
                             f"went from {best[0]:.3g} ({best[1]} harmonics) to {d_rel:.3g} ({len(ks)} harmonics)"
                             + (" with the Newton iteration stopped on a residual floor" if g.hb.floor else "")
                             + "; a nonsmooth orbit (contact loss) may need method='shooting'")
                entry["note"] = "growth stopped: the defect grew"
                break
            if math.isfinite(d_rel) and (best is None or d_rel < best[0]):
                best = (d_rel, len(ks))
            if d_rel <= o.defect_tol and (o.harmonics_tol is None or (math.isfinite(entry["change"])
                                                                        and entry["change"] < o.harmonics_tol)):
                break
        return g

    def _verify_set(self, g: _Grown, entry: dict[str, Any], prev_dense: np.ndarray | None
                    ) -> tuple[np.ndarray, float]:
        """The time-domain defect of a converged set (recorded in ``entry`` and ``g.verified``)."""
        o = self.o
        dense = dense_series(g.C, max(4096, 8 * g.hb.H))
        sizes = state_sizes(dense, self.floor)
        x_start = g.hb.x_at_t0(g.hb.restrict(g.C))
        try:
            d_rel, d_abs, _ = time_defect(self.system, x_start, o.t0, self.period, self.params, sizes, o.rtol,
                                          o.atol)
        except GearsymError as exc:
            d_rel, d_abs = math.inf, math.inf
            g.failure = f"the integration from the balanced state failed: {exc}"
        change = math.nan
        if prev_dense is not None and prev_dense.shape == dense.shape:
            change = float(np.max(np.max(np.abs(dense - prev_dense), axis=0) / sizes))
        entry.update(change=change, peak_to_peak=float(np.ptp(dense[:, 0])), defect=d_rel, defect_abs=d_abs)
        g.growth.append(entry)
        g.verified = (d_rel, d_abs, sizes)
        return dense, d_rel

    def _solve_from(self, attempts: list[tuple[str, Any]]):
        """Grow from each initial guess in turn until one converges (and closes in the time domain)."""
        total_it = 0
        history: list[dict[str, Any]] = []
        growth: list[dict[str, Any]] = []
        used = ""
        guess_scale = 1.0
        g: _Grown | None = None
        for k, (name, C0) in enumerate(attempts):
            if C0 is None:
                C0 = self._simulation_guess()
            guess_scale = max(1.0, float(np.max(np.abs(C0))) if np.size(C0) else 1.0)
            last = k == len(attempts) - 1
            g = self._grow(C0, stop_on_stall=name == "constant" and not last)
            total_it += g.iterations
            history += [dict(h, initial_guess=name) for h in g.history]
            growth += [dict(x, initial_guess=name) for x in g.growth]
            used = name
            self._check_defect(g)
            if g.converged:
                break
        assert g is not None and g.hb is not None
        return g, used, guess_scale, total_it, history, growth

    def _check_defect(self, g: _Grown) -> None:
        """A converged balance is an orbit only if one period integrated from it closes."""
        o = self.o
        if not (g.converged and g.verified is not None):
            return
        if o.harmonics is None and g.verified[0] > o.defect_tol:
            g.converged = False
            g.failure = g.failure or (
                f"the time-domain defect of the balanced orbit is {g.verified[0]:.3g} of its size (above "
                f"defect_tol={o.defect_tol:g}) with {len(g.hb.ks)} harmonics up to {g.hb.H}: more harmonics "
                f"(max_harmonics={o.max_harmonics}) or method='shooting'")
        if o.harmonics is not None and not g.verified[0] <= max(o.defect_tol, FIXED_HARMONICS_DEFECT):
            g.converged = False
            g.failure = g.failure or (
                f"one period integrated from the balanced state does not return to it: the time-domain defect is "
                f"{g.verified[0]:.3g} of the orbit's size with the {len(g.hb.ks)} harmonics given (a balance with "
                f"fixed harmonics counts as an orbit up to {max(o.defect_tol, FIXED_HARMONICS_DEFECT):g}): more "
                f"harmonics, harmonics=None (grown until the defect is below defect_tol) or method='shooting'")

    # ---------------------------------------------------------- the orbit
    def _multipliers(self, g: _Grown, x_start: np.ndarray, guess_scale: float) -> dict[str, Any]:
        """One variational integration from the balance's ``x(t0)``: the monodromy, the events,
        the isolation and the rattle states of the integration; a balance that is small only
        relative to coefficients blown up along a multiplier at +1 is no orbit."""
        o, system = self.o, self.system
        out: dict[str, Any] = {"mono": None, "events": [], "iso": None, "rss": None, "failure": None}
        d_rel, d_abs = (g.verified[0], g.verified[1]) if g.verified is not None else (math.nan, math.nan)
        if not (o.monodromy and g.converged):
            out.update(d_rel=d_rel, d_abs=d_abs)
            return out
        try:
            sizes = g.verified[2] if g.verified is not None else state_sizes(dense_series(g.C), self.floor)
            d_rel, d_abs, tr = time_defect(system, x_start, o.t0, self.period, self.params, sizes, o.rtol, o.atol,
                                           monodromy=True)
            out["mono"] = tr.monodromy
            out["events"] = list(tr.events)
            amp = np.max(np.abs(tr.y), axis=0)
            out["iso"] = isolation(tr.monodromy, np.maximum(amp, max(1e-9 * float(np.max(amp)), o.atol / o.tol)),
                                   o.rtol, o.trivial)
            out["rss"] = rattle_states(system, x_start, o.t0, out["events"], self.params)
        except GearsymError as exc:
            out["mono"] = None  # no multipliers ("unknown" stability), and why
            out["failure"] = f"the variational integration from the balanced state failed: {exc}"
        out.update(d_rel=d_rel, d_abs=d_abs)
        iso = out["iso"]
        if iso is not None and not iso.isolated and \
                g.residual > max(o.tol, o.floor_tol if g.hb.floor else o.tol) * guess_scale:
            g.converged = False
            g.failure = (f"{iso.reason()}: the balance's residual {g.residual:.3g} is small only relative to "
                         f"coefficients of size {float(np.max(np.abs(g.C))):.3g} (initial guess {guess_scale:.3g})")
            if o.raise_on_failure:
                raise ConvergenceError(f"harmonic balance: {g.failure}. Add damping, move the forcing off the "
                                       f"resonance, or tighten rtol (now {o.rtol:g}) if the system is lightly "
                                       f"damped.")
        return out

    def _orbit(self, g: _Grown, used: str, guess_scale: float, total_it: int, history: list[dict[str, Any]],
               growth: list[dict[str, Any]], wall: float) -> PeriodicOrbit:
        o, system, hb, C = self.o, self.system, g.hb, g.C
        x_start = hb.x_at_t0(hb.restrict(C))
        m = self._multipliers(g, x_start, guess_scale)
        d_rel, d_abs = m["d_rel"], m["d_abs"]
        bound = o.defect_tol if o.harmonics is None else max(o.defect_tol, FIXED_HARMONICS_DEFECT)
        p = system.param_vector(self.params)
        n_s = max(8192, 16 * hb.H)
        series = (o.t0 + self.period * np.arange(n_s) / n_s, dense_series(C, n_s))
        iso = m["iso"]
        orbit = finish_orbit(system, SolvedOrbit(
            x0=x_start, period=self.period, periods=self.periods, t0=o.t0, monodromy=m["mono"],
            iterations=total_it, residual=g.residual, converged=g.converged, method="hbm",
            params={k: v for k, v in system.param_dict(p).items() if k in system.params},
            events=m["events"], samples=series),
            harmonics=hb.H, coefficients=C, history=history,
            info={"harmonic_growth": growth, "harmonics_converged": bool(g.converged and d_rel <= o.defect_tol),
                  "verification": {"residual": d_abs, "relative": d_rel, "tolerance": bound,
                                   "ok": bool(d_rel <= bound),
                                   "how": "plain integration over one period from the balance's x(t0) (time-domain "
                                          "defect relative to each state's peak-to-peak)"},
                  "defect": d_abs, "defect_relative": d_rel, "defect_tol": o.defect_tol,
                  "harmonic_set": [int(k) for k in hb.ks], "n_harmonics": len(hb.ks),
                  "excitation_harmonics": sorted(self.excitation), "carriers": self.carriers,
                  "initial_guess": used, "quadrature": hb.quadrature, "failure": g.failure or None,
                  "isolation": iso.to_dict() if iso is not None else None, "monodromy_failure": m["failure"],
                  "samples": hb.M, "tol": o.tol, "rtol": o.rtol, "atol": o.atol,
                  "relative_residual": hb.rel_residual, "residual_floor": bool(hb.floor),
                  "rattle_state_source": "harmonic series", "rattle_states_integration": m["rss"],
                  "wall_s": time.perf_counter() - wall})
        # the rattle state of the balance is that of its own series, not of the integration
        rss = rattle_states(system, x_start, o.t0, [], self.params, samples=series)
        return dataclasses.replace(orbit, rattle_states=rss, rattle_state=max(rss.values()) if rss else None)
