"""The driver of :func:`gearsym.analysis.periodic.harmonic_balance`: guesses, harmonic growth,
adaptive AFT sampling and the time-domain verification of every orbit.

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
from typing import TYPE_CHECKING, Any

import numpy as np

from ...errors import ConvergenceError, GearsymError, ParameterError
from .._options import check_tolerances
from ._hbm_sets import carriers_of, excitation_harmonics, growth_sets
from ._isolation import isolation
from ._orbit import VANISHING, PeriodicOrbit, finish_orbit
from ._rattle import mesh_rattle_states as rattle_states
from ._verification import orbit_period

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

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
    """``(relative defect, absolute defect, trajectory)`` of one period integrated from ``x_start``."""
    tr = system.simulate(t_end=t0 + period, t0=t0, x0=x_start, rtol=rtol, atol=atol, n_out=256, params=params,
                         monodromy=monodromy)
    d = np.abs(tr.x_final - x_start)
    return float(np.max(d / sizes)), float(np.max(d)), tr


def run(hb_cls, system: CompiledSystem, period: float | None, periods: float, x0: Sequence[float] | None,
        params: Mapping[str, float] | None, *, harmonics: int | Sequence[int] | None, max_harmonics: int,
        harmonics_tol: float | None, samples: int | None, t0: float, tol: float, max_iter: int,
        guess: np.ndarray | PeriodicOrbit | None, monodromy: bool, rtol: float, atol: float,
        raise_on_failure: bool, initial_guess: str, transient: float, floor_tol: float,
        trivial: np.ndarray | None, defect_tol: float, aft_tol: float, max_samples: int,
        floor_rel: float) -> PeriodicOrbit:
    """The body of :func:`gearsym.analysis.periodic.harmonic_balance` (see there)."""
    wall = time.perf_counter()
    check_tolerances(tol=tol, rtol=rtol, atol=atol, defect_tol=defect_tol, aft_tol=aft_tol)
    floor = atol / defect_tol  # the absolute floor of every state's size (see state_sizes)
    if system.generated.implicit:
        raise ParameterError("harmonic balance needs an explicit model (x' = f(t, x)); this one is in implicit "
                             "(residual) form, a DAE: use shooting (method='shooting')")
    period, periods = orbit_period(system, params, period, periods)  # a whole number of forcing periods
    T = system.period(params)
    nx = system.generated.nx
    base = system.x0 if x0 is None else np.asarray(x0, float)
    if base.shape != (nx,):
        raise ParameterError(f"x0 must have {nx} entries, got shape {base.shape}")
    if max_harmonics < 1:
        raise ParameterError(f"max_harmonics must be >= 1, got {max_harmonics}")

    # ---------------------------------------------------------- harmonic sets
    carriers: list[int] = []
    if harmonics is not None:
        sets = [np.arange(1, int(harmonics) + 1) if isinstance(harmonics, (int, np.integer))
                else np.asarray(list(harmonics), int)]
        excitation: dict[int, float] = {}
    else:
        excitation = excitation_harmonics(system, period, base, params, t0)
        carriers = [c for c in carriers_of(excitation) if c <= max_harmonics]
        sets = growth_sets(carriers, max_harmonics)
        budget = [s for s in sets if float(nx * (2 * len(s) + 1)) ** 2 <= GROWTH_JACOBIAN_VALUES]
        sets = budget or sets[:1]

    def first_set_H(C: np.ndarray) -> int:
        return max(1, (C.shape[0] - 1) // 2)

    H_sim = int(max(sets[0].max() if len(sets[0]) else 1, 16))
    attempts: list[tuple[str, Any]] = []
    if isinstance(guess, PeriodicOrbit):
        Hg = int(max(s.max() if len(s) else 1 for s in sets))
        attempts.append(("orbit", series_from_samples(guess.trajectory(n_out=max(64, 8 * Hg) + 1).y[:-1], Hg)))
    elif guess is not None:
        attempts.append(("coefficients", np.asarray(guess, float)))
    else:
        C_const = np.zeros((3, nx))
        C_const[0] = base
        attempts.append(("constant", C_const))
        if initial_guess == "auto":
            # with contact surfaces the constant state may sit in the gap (no stiffness): start
            # from a simulated period there, from the constant state (cheaper) otherwise
            attempts.insert(0 if system.generated.nsw else 1, ("simulation", None))
        elif initial_guess == "simulation":
            attempts = [("simulation", None)]
        elif initial_guess != "constant":
            raise ParameterError(f"initial_guess must be 'auto', 'constant' or 'simulation', got "
                                 f"'{initial_guess}'")

    def simulation_guess() -> np.ndarray:
        Tt = T if T else period
        n_tr = max(1, int(math.ceil(transient)))
        Hs = int(max(s.max() if len(s) else 1 for s in sets))
        tr = system.simulate(t_end=t0, t0=t0 - n_tr * Tt, x0=base, rtol=1e-8, atol=1e-10, n_out=2,
                             params=params)
        tr = system.simulate(t_end=t0 + period, t0=t0, x0=tr.x_final, rtol=1e-8, atol=1e-10,
                             n_out=max(64, 8 * Hs, 8 * H_sim) + 1, params=params)
        return series_from_samples(tr.y[:-1], Hs)

    # no aliasing of the excitation onto the kept harmonics: samples above twice the highest one
    M_exc = default_samples(min(max(excitation), 4 * max_harmonics)) if excitation and samples is None else None

    def solve_set(ks: np.ndarray, C_full: np.ndarray, M: int | None):
        """Solve on one set; with ``samples=None`` double the samples until the residual on a
        grid twice as fine agrees: the Newton correction it implies moves no state by more than
        ``aft_tol`` of its size.  Returns (hb, C_full, solve outputs, aft checks)."""
        checks: list[dict[str, Any]] = []
        if samples is None:
            M = max(M or 0, M_exc or 0, default_samples(int(ks.max()) if len(ks) else 0))
        while True:
            hb = hb_cls(system, period, ks, params, t0, M)
            C, it, r, conv, hist, failure = hb.solve(hb.restrict(C_full), tol=tol, max_iter=max_iter,
                                                     floor_tol=floor_tol, floor_rel=floor_rel, lm=True)
            C_full = hb.full_coefficients(C)
            if samples is not None or not hb.uniform or not conv or hb.floor or len(checks) >= 3 \
                    or 2 * hb.M > max_samples:
                # (a residual floor of a kinked residual is no sampling question; at most 8x)
                return hb, C_full, (it, r, conv, hist, failure), checks
            fine = hb_cls(system, period, ks, params, t0, 2 * hb.M)
            Rf = hb._flat(fine.residual(C))
            try:
                dz = np.linalg.solve(hb.jacobian(C), -Rf)
            except np.linalg.LinAlgError:
                return hb, C_full, (it, r, conv, hist, failure), checks
            sizes = state_sizes(dense_series(C_full, max(1024, 4 * hb.H)), floor)
            move = float(np.max(np.sum(np.abs(hb._unflat(dz)), axis=0) / sizes))
            checks.append({"samples": hb.M, "correction": move})
            if move <= aft_tol:
                return hb, C_full, (it, r, conv, hist, failure), checks
            M = 2 * hb.M

    def grow(C: np.ndarray, stop_on_stall: bool):
        growth: list[dict[str, Any]] = []
        prev_dense: np.ndarray | None = None
        total_it = 0
        history: list[dict[str, Any]] = []
        hb = None
        r, conv, failure = math.inf, False, ""
        verified = None
        M = samples
        C_guess = C
        best: tuple[float, int] | None = None  # (smallest defect, its number of harmonics)
        for j, ks in enumerate(sets):
            hb, C, (it, r, conv, hist, failure), checks = solve_set(ks, C, M)
            if not conv:
                C = C_guess  # the next set starts from the guess, not from a failed solve
            if samples is None and len(checks) > 1:
                M = hb.M  # the contact needed more samples: keep them for the next set
            total_it += it
            history += [dict(h, harmonics=len(ks)) for h in hist]
            entry: dict[str, Any] = {"harmonics": len(ks), "max_harmonic": int(hb.H), "samples": hb.M,
                                     "iterations": it, "residual": r, "relative_residual": hb.rel_residual}
            if checks:
                entry["aft_checks"] = checks
            if not conv:
                growth.append(dict(entry, change=math.nan, peak_to_peak=math.nan, defect=math.nan,
                                   note=f"not converged ({failure})"))
                if stop_on_stall or j == len(sets) - 1:
                    break
                prev_dense = None
                continue
            dense = dense_series(C, max(4096, 8 * hb.H))
            sizes = state_sizes(dense, floor)
            x_start = hb.x_at_t0(hb.restrict(C))
            try:
                d_rel, d_abs, _ = time_defect(system, x_start, t0, period, params, sizes, rtol, atol)
            except GearsymError as exc:
                d_rel, d_abs = math.inf, math.inf
                failure = f"the integration from the balanced state failed: {exc}"
            change = math.nan
            if prev_dense is not None and prev_dense.shape == dense.shape:
                change = float(np.max(np.max(np.abs(dense - prev_dense), axis=0) / sizes))
            entry.update(change=change, peak_to_peak=float(np.ptp(dense[:, 0])), defect=d_rel,
                         defect_abs=d_abs)
            growth.append(entry)
            prev_dense = dense
            verified = (d_rel, d_abs, sizes)
            if harmonics is not None:
                break
            if best is not None and not d_rel <= max(DEFECT_BLOWUP * best[0], defect_tol):
                failure = (f"adding harmonics moved the balance away from the orbit: its time-domain defect "
                           f"went from {best[0]:.3g} ({best[1]} harmonics) to {d_rel:.3g} ({len(ks)} harmonics)"
                           + (" with the Newton iteration stopped on a residual floor" if hb.floor else "")
                           + "; a nonsmooth orbit (contact loss) may need method='shooting'")
                entry["note"] = "growth stopped: the defect grew"
                break
            if math.isfinite(d_rel) and (best is None or d_rel < best[0]):
                best = (d_rel, len(ks))
            if d_rel <= defect_tol and (harmonics_tol is None or (math.isfinite(change) and change < harmonics_tol)):
                break
        return hb, C, r, conv, failure, growth, total_it, history, verified

    total_it = 0
    history: list[dict[str, Any]] = []
    growth: list[dict[str, Any]] = []
    used = ""
    guess_scale = 1.0
    verified = None
    hb = C = None
    conv = False
    failure = ""
    for k, (name, C0) in enumerate(attempts):
        if C0 is None:
            C0 = simulation_guess()
        guess_scale = max(1.0, float(np.max(np.abs(C0))) if np.size(C0) else 1.0)
        last = k == len(attempts) - 1
        hb, C, r, conv, failure, g, it, hist, verified = grow(C0, stop_on_stall=name == "constant" and not last)
        total_it += it
        history += [dict(h, initial_guess=name) for h in hist]
        growth += [dict(x, initial_guess=name) for x in g]
        used = name
        if conv and harmonics is None and verified is not None and verified[0] > defect_tol:
            conv = False
            failure = failure or (
                f"the time-domain defect of the balanced orbit is {verified[0]:.3g} of its size (above "
                f"defect_tol={defect_tol:g}) with {len(hb.ks)} harmonics up to {hb.H}: more harmonics "
                f"(max_harmonics={max_harmonics}) or method='shooting'")
        if conv and harmonics is not None and verified is not None and \
                not verified[0] <= max(defect_tol, FIXED_HARMONICS_DEFECT):
            conv = False
            failure = failure or (
                f"one period integrated from the balanced state does not return to it: the time-domain defect is "
                f"{verified[0]:.3g} of the orbit's size with the {len(hb.ks)} harmonics given (a balance with fixed "
                f"harmonics counts as an orbit up to {max(defect_tol, FIXED_HARMONICS_DEFECT):g}): more harmonics, "
                f"harmonics=None (grown until the defect is below defect_tol) or method='shooting'")
        if conv:
            break
    assert hb is not None and C is not None
    if not conv and raise_on_failure:
        hist_txt = ", ".join(f"{h['residual']:.3g}" for h in history[-10:])
        raise ConvergenceError(
            f"harmonic balance did not converge ({len(hb.ks)} harmonics up to {hb.H}, initial guess '{used}'): "
            f"{failure}; residual history [{hist_txt}]. Try a guess (guess=<orbit from shooting>), a different "
            f"x0, more harmonics, or method='shooting'.")
    x_start = hb.x_at_t0(hb.restrict(C))
    mono = None
    events: list = []
    iso = None
    rss_integration = None
    mono_failure = None
    d_rel, d_abs = (verified[0], verified[1]) if verified is not None else (math.nan, math.nan)
    if monodromy and conv:
        try:
            sizes = verified[2] if verified is not None else state_sizes(dense_series(C), floor)
            d_rel, d_abs, tr = time_defect(system, x_start, t0, period, params, sizes, rtol, atol, monodromy=True)
            mono = tr.monodromy
            events = list(tr.events)
            amp = np.max(np.abs(tr.y), axis=0)
            iso = isolation(mono, np.maximum(amp, max(1e-9 * float(np.max(amp)), atol / tol)), rtol, trivial)
            rss_integration = rattle_states(system, x_start, t0, events, params)
        except GearsymError as exc:
            mono = None  # no multipliers ("unknown" stability), and why
            mono_failure = f"the variational integration from the balanced state failed: {exc}"
        if iso is not None and not iso.isolated and r > max(tol, floor_tol if hb.floor else tol) * guess_scale:
            conv = False
            failure = (f"{iso.reason()}: the balance's residual {r:.3g} is small only relative to coefficients "
                       f"of size {float(np.max(np.abs(C))):.3g} (initial guess {guess_scale:.3g})")
            if raise_on_failure:
                raise ConvergenceError(f"harmonic balance: {failure}. Add damping, move the forcing off the "
                                       f"resonance, or tighten rtol (now {rtol:g}) if the system is lightly "
                                       f"damped.")
    bound = defect_tol if harmonics is None else max(defect_tol, FIXED_HARMONICS_DEFECT)
    p = system.param_vector(params)
    n_s = max(8192, 16 * hb.H)
    series = (t0 + period * np.arange(n_s) / n_s, dense_series(C, n_s))
    orbit = finish_orbit(
        system, x0=x_start, period=period, periods=periods, t0=t0, monodromy=mono, iterations=total_it,
        residual=r, converged=conv, method="hbm",
        params={k: v for k, v in system.param_dict(p).items() if k in system.params},
        events=events, samples=series, harmonics=hb.H, coefficients=C, history=history,
        info={"harmonic_growth": growth, "harmonics_converged": bool(conv and d_rel <= defect_tol),
              "verification": {"residual": d_abs, "relative": d_rel, "tolerance": bound, "ok": bool(d_rel <= bound),
                               "how": "plain integration over one period from the balance's x(t0) (time-domain "
                                      "defect relative to each state's peak-to-peak)"},
              "defect": d_abs, "defect_relative": d_rel, "defect_tol": defect_tol,
              "harmonic_set": [int(k) for k in hb.ks], "n_harmonics": len(hb.ks),
              "excitation_harmonics": sorted(excitation), "carriers": carriers,
              "initial_guess": used, "quadrature": hb.quadrature, "failure": failure or None,
              "isolation": iso.to_dict() if iso is not None else None, "monodromy_failure": mono_failure,
              "samples": hb.M, "tol": tol, "rtol": rtol, "atol": atol,
              "relative_residual": hb.rel_residual, "residual_floor": bool(hb.floor),
              "rattle_state_source": "harmonic series", "rattle_states_integration": rss_integration,
              "wall_s": time.perf_counter() - wall})
    # the rattle state of the balance is that of its own series, not of the integration
    rss = rattle_states(system, x_start, t0, [], params, samples=series)
    return dataclasses.replace(orbit, rattle_states=rss, rattle_state=max(rss.values()) if rss else None)
