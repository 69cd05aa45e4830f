"""Lyapunov exponents of the hybrid system: variational equations with saltation, QR blocks.

:func:`lyapunov_exponents` runs the Benettin / Shimada-Nagashima algorithm on a compiled
:class:`~gearsym.System`:

1. **Transient.**  The state is integrated ``transient`` forcing periods from ``x0`` (calls of
   at most 10,000 periods, no variational equations) and the result is discarded, except for the
   magnitude of each state along it (the absolute tolerances) and its range (the unit of
   each state in the tangent space, below).
2. **Blocks.**  From the current state, one engine call integrates the state and its
   variational equations over one *block* (one forcing period by default): the engine
   returns ``M = d x(t + h) / d x(t)`` with the saltation matrix applied at every contact
   event (the same monodromy as shooting uses).  The tangent basis ``Q`` (``k``
   orthonormal columns) is propagated, ``M Q = Q' R``, ``Q <- Q'``, and ``log |R_ii|`` is the
   stretch of the ``i``-th direction in the block; the run continues from the block's end
   state (and surface sides).  ``align`` blocks first let ``Q`` settle on the most
   expanding directions; they are not counted.  The engine gives ``M`` only at the end of
   a run (not at a series of times), so a block is one call.  Its fixed cost (50-90 us
   measured on the benchmark oscillator, against 170-340 us for one period with the
   variational equations; through :meth:`System.flow` twice that, so the blocks call the
   engine directly) is why a block is not shorter than a period unless it has to be; it
   is not longer by default because the windowed average (step 4) converges with the
   number of blocks:
3. **Block length.**  Within a block the directions separate by ``exp((lambda_1 - lambda_k) h)``;
   the QR recovers the weakest one from columns that the strongest dominates, with a
   rounding error of about ``eps * exp(growth)``.  A block in which ``log R_11 - log R_kk``
   exceeds :data:`GROWTH_LIMIT` (``log 1e6``) is halved (``block=None``, the default: from one
   forcing period down to ``2**-10`` of it) during the alignment blocks.
4. **Estimate.**  Exponent ``i`` is the time average of ``log |R_ii|``, with a smooth window
   (:func:`window`: 1 in the middle, C-infinity ramps over the first and last quarter of the
   blocks that vanish with all their derivatives), a weighted Birkhoff average (S. Das, J. A.
   Yorke, Super convergence of ergodic averages for quasiperiodic orbits, Nonlinearity 31,
   2018, who weight with the bump ``exp(-1/(s(1-s)))``; the plateau here has 1.25 instead of
   1.96 times the variance of the plain average for independent stretches).  For a periodic
   or quasi-periodic response it converges faster than any power of ``1/N`` (the plain
   running average converges like ``1/N``: on the benchmark oscillator's stable orbit it is
   1e-5 off after 1000 periods, the windowed one at the integration error, 1e-10); for a
   chaotic one at the usual ``1/sqrt(N)`` rate.  :attr:`LyapunovResult.running` is the
   plain running average, for plots.
5. **Convergence.**  The blocks are split into ``batches`` (8) consecutive batches and the
   windowed average is taken in each; the error of exponent ``i`` is the 95 % half-width of
   their mean, ``t_{0.975, B-1} s_i / sqrt(B)`` (``s_i``: the batches' standard deviation), plus
   the integration error ``100 rtol / h`` of a block's stretch.  Exponent ``i`` has converged
   when its error is at most ``abs_tol + rel_tol * max_j |lambda_j|``; a run whose exponents
   have not all converged says which, by how much, and about how many periods would do
   (:attr:`LyapunovResult.reason`).  The batches cannot see a bias they all share: a
   periodic response sampled by blocks that nearly repeat its cycle every few blocks (an
   autonomous model's ``block_time`` near 3/2 of its cycle: 6e-4 off after 200 blocks on van der
   Pol, against 1e-5 at other lengths) converges like ``1/N`` only.  Forced models' blocks are
   whole forcing periods, where a periodic response's stretches repeat exactly.

Conventions
-----------
* Exponents are per unit of the system's time (seconds for SI models; for a system that
  simulates in dimensionless time, per unit of it: divide by :meth:`System.time_scale`
  for per second), largest first (the order of the QR's columns).
* **Forced (non-autonomous) models**: the state space is the model's states; the forcing
  phase is not a state, so the time direction adds no zero exponent.  The ``n`` exponents
  are those of the period map divided by the period.  The Kaplan-Yorke dimension is that
  of the attractor of the period map (its Poincare section); the attractor of the flow in
  the extended phase space (state, forcing phase) has one dimension more.
* **Autonomous models** (no forcing period): a block is ``block_time`` long (required), the
  counts ``periods``, ``transient`` and ``align`` are in blocks, and the flow direction of a
  non-stationary attractor gives one exponent zero among the ``n`` (it is not removed).
* **Rigid-body modes** (free gear trains): their subspace ``V`` (two directions per mode,
  :func:`~gearsym.analysis.periodic.floquet.rigid_state_basis`) is invariant, and on it the tangent
  map is the Jordan block ``[[1, h], [0, 1]]``: its exponents are exactly zero (the growth is
  linear in time).  They are reported apart (:attr:`LyapunovResult.trivial`) and the
  exponents are those of the quotient by ``V`` (the relative motion).
* **DAE models** (algebraic variables): the exponents of the differential states.
* The tangent space is measured in states divided by half their range along the transient
  (the exponents do not depend on a constant scaling; the QR does numerically: in SI units
  a displacement and a velocity differ by orders of magnitude).

The sum of all ``n`` exponents is the time average of the divergence of the vector field
plus ``log |det S|`` of the saltation matrices at the events, and it is exact in every block up
to the integration error (``det M``), so it converges much faster than the exponents
themselves: on the benchmark oscillator ``sum = -2 zeta`` to 1e-9 in any run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...display import LyapunovDisplay
from ...errors import ParameterError, SimulationError
from ...integrators import INTEGRATION_METHODS, default_method
from ...progress import progress_bar
from .._options import resolve_options
from ..periodic import ERROR_FACTOR, rigid_state_basis
from ._scales import sample_scale

if TYPE_CHECKING:  # pragma: no cover
    from ...system import CompiledSystem

__all__ = ["GROWTH_LIMIT", "LyapunovOptions", "LyapunovResult", "batch_errors", "format_estimate", "kaplan_yorke",
           "lyapunov_exponents", "weighted_average", "window"]

#: Largest ``log R_11 - log R_kk`` (the separation of the tangent directions) of one block
#: before the automatic block length halves it: the weakest direction is recovered from
#: columns that the strongest dominates by ``exp(growth)``, so its rounding error is about
#: ``eps * exp(growth)``; at ``exp(growth) = 1e6`` that is 2e-10 per block.  (Measured on the
#: benchmark oscillator's chaotic orbit: blocks with growth ``exp(18)`` gave the second
#: exponent to 1e-9, ``exp(35)`` lost it.)
GROWTH_LIMIT = math.log(1e6)
#: Shortest automatic block, in forcing periods (or ``block_time``).
MIN_BLOCK = 2.0 ** -10
#: Fraction of the blocks over which the window ramps up (and down, at the end).
RAMP = 0.25
#: Blocks per batch at least (the convergence estimate needs ``batches`` of them).
MIN_BATCH_BLOCKS = 4
#: Most values of the per-block history (blocks x exponents, 8 bytes each).
MAX_HISTORY = 50_000_000
#: The transient is integrated in calls of at most this many forcing periods (or blocks).
TRANSIENT_CHUNK = 10_000.0
#: Limit on ``periods``, ``transient`` (forcing periods or blocks).
MAX_PERIODS = 1e9


@dataclass(frozen=True)
class LyapunovOptions:
    """Settings of :func:`lyapunov_exponents`.

    Attributes
    ----------
    periods : float
        Forcing periods over which the stretches are averaged (autonomous models: blocks).
    transient : float
        Forcing periods integrated first and discarded (autonomous models: blocks).
    exponents : int or None
        How many exponents, largest first (``None``: all; 1: the largest only).
    block : float or None
        Forcing periods per QR block; ``None``: one, halved while the directions separate by
        more than :data:`GROWTH_LIMIT` in a block.  A block cannot be longer than
        ``periods / (MIN_BATCH_BLOCKS * batches)``.
    block_time : float or None
        Autonomous models (no forcing period): the length of a block in the system's time;
        required there, refused for forced models.  A fraction of a limit cycle's period (not
        near a small rational multiple of it: module docstring, step 5).
    align : int
        Blocks integrated before the averaging, for the tangent basis to settle (not counted).
    rtol, atol : float
        Integrator tolerances; ``atol=None``: ``1e-2 * rtol`` times each state's magnitude
        along the transient (the variational entry ``d x_i / d x0_j`` gets ``atol_i`` divided by
        the magnitude of ``x_j``).
    method : str or None
        Integrator (default: the scene's).
    rel_tol, abs_tol : float
        Convergence rule: each exponent's error at most ``abs_tol + rel_tol * max_j |lambda_j|``;
        ``abs_tol=None``: ``1e-4`` per forcing period (``1e-4 / T``; autonomous: per block).
    batches : int
        Batches of the convergence estimate (at least 2).
    """

    periods: float = 2000
    transient: float = 200
    exponents: int | None = None
    block: float | None = None
    block_time: float | None = None
    align: int = 16
    rtol: float = 1e-9
    atol: float | None = None
    method: str | None = None
    rel_tol: float = 0.05
    abs_tol: float | None = None
    batches: int = 8

    def __post_init__(self) -> None:
        _number("periods", self.periods, 0.0, MAX_PERIODS, low_open=True)
        _number("transient", self.transient, 0.0, MAX_PERIODS)
        _integer("exponents", self.exponents, 1, None)
        _integer("align", self.align, 0, 1_000_000)
        _integer("batches", self.batches, 2, 1000)
        if self.block is not None:
            _number("block", self.block, 0.0, MAX_PERIODS, low_open=True)
        if self.block_time is not None:
            _number("block_time", self.block_time, 0.0, math.inf, low_open=True)
        _number("rtol", self.rtol, 1e-15, 1.0, high_open=True)
        if self.atol is not None:
            _number("atol", self.atol, 0.0, math.inf, low_open=True)
        _number("rel_tol", self.rel_tol, 0.0, math.inf)
        if self.abs_tol is not None:
            _number("abs_tol", self.abs_tol, 0.0, math.inf)
        if self.method is not None and self.method not in INTEGRATION_METHODS:
            raise ParameterError(f"method must be one of {', '.join(INTEGRATION_METHODS)}, got {self.method!r}")
        b = 1.0 if self.block is None else float(self.block)
        n_min = MIN_BATCH_BLOCKS * self.batches
        if self.periods / b < n_min:
            raise ParameterError(f"periods={self.periods:g}: the convergence estimate needs at least {n_min} blocks "
                                 f"({self.batches} batches of {MIN_BATCH_BLOCKS}); give periods >= {n_min * b:g}"
                                 + (" or a shorter block" if self.block is not None else ""))


def _number(name: str, v: Any, lo: float, hi: float, low_open: bool = False, high_open: bool = False) -> None:
    """Refuse a non-finite or out-of-range option (ParameterError naming it)."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {v!r}") from None
    bad = not math.isfinite(x) or x < lo or x > hi or (low_open and x == lo) or (high_open and x == hi)
    if bad:
        rng = f"{'(' if low_open else '['}{lo:g}, {hi:g}{')' if high_open else ']'}"
        raise ParameterError(f"{name} must be finite and in {rng}, got {v!r}")


def _integer(name: str, v: Any, lo: int, hi: int | None) -> None:
    if v is None:
        return
    ok = isinstance(v, (int, np.integer)) and not isinstance(v, bool)
    if not ok or v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi:,}]"
        raise ParameterError(f"{name} must be an integer {rng}, got {v!r}")


@dataclass(frozen=True, repr=False)
class LyapunovResult(LyapunovDisplay):
    """Lyapunov exponents of one run of :func:`lyapunov_exponents`.

    ``repr`` is one line; ``to_dataframe()`` one row per exponent (:mod:`gearsym.display`).

    Attributes
    ----------
    exponents : ndarray
        The exponents, per unit of the system's time (windowed time averages), in the order of the
        QR's columns: largest first once converged (equal ones, e.g. of a complex pair of
        multipliers, in either order within their errors).
    errors : ndarray
        The 95 % half-width of each (module docstring, step 5).
    converged : bool
        Every exponent's error within ``abs_tol + rel_tol * max_j |lambda_j|``.
    reason : str
        Why not (empty when converged).
    periods : float
        Forcing periods averaged over (autonomous models: blocks of ``block_time``).
    time : float
        Time averaged over (``periods`` times the period).
    kaplan_yorke : float
        Kaplan-Yorke dimension ``j + (lambda_1 + ... + lambda_j) / |lambda_{j+1}|`` (``j`` the
        largest index with a non-negative partial sum; 0 if ``lambda_1 < 0``); NaN when all
        partial sums of fewer than all exponents are non-negative (more are needed).  For a
        forced model, that of the period map's attractor (module docstring); for an autonomous
        one the exponent nearest 0 counts as 0 (the flow direction) when it is within its error
        (``info["kaplan_yorke_zero"]`` is then its index).
    trivial : ndarray
        The exponents of the rigid-body directions: zeros, two per rigid-body mode (empty
        without them), not part of :attr:`exponents`.
    block : float
        Forcing periods per block (autonomous models: blocks of ``block_time``).
    block_time : float
        Length of a block in the system's time.
    stretches : ndarray
        ``log |R_ii|`` of every averaged block, shape (blocks, k).
    tolerance : float
        ``abs_tol + rel_tol * max_j |lambda_j|`` of the convergence rule.
    params : dict
        Run-time parameter values (declared units).
    x_final : ndarray
        The state at the end of the run.
    t_final : float
        The time at the end of the run.
    stats : dict
        ``n_calls`` (engine calls), ``wall_s``, ``periods_per_second`` (all periods with
        variational equations, alignment included, per second of wall time), ``n_events``,
        ``n_steps``, ``max_growth`` (the largest ``log R_11 - log R_kk`` of a block).
    info : dict
        ``forced`` (bool), ``period``, ``tangent_scales`` (the unit of each state in the tangent
        space), ``rigid_split`` (how the rigid-body modes were handled), ``invariance_defect``,
        ``dimension`` (directions the exponents are of).
    """

    exponents: np.ndarray
    errors: np.ndarray
    converged: bool
    reason: str
    periods: float
    time: float
    kaplan_yorke: float
    trivial: np.ndarray
    block: float
    block_time: float
    stretches: np.ndarray
    tolerance: float
    params: dict[str, float] = field(default_factory=dict)
    x_final: np.ndarray = field(default_factory=lambda: np.zeros(0))
    t_final: float = 0.0
    stats: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def largest(self) -> float:
        """The largest exponent."""
        return float(self.exponents[0])

    @property
    def exponent_sum(self) -> float:
        """Sum of the computed exponents (of all ``n``: the mean phase-space contraction rate)."""
        return float(np.sum(self.exponents))

    @property
    def running(self) -> np.ndarray:
        """The plain running averages ``sum_{m <= j} log |R_ii| / t_j`` after each block, shape (blocks, k)."""
        n = self.stretches.shape[0]
        t = self.block_time * np.arange(1, n + 1)
        return np.cumsum(self.stretches, axis=0) / t[:, None]

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no per-block history but the running averages at 200 points).

        Returns
        -------
        dict
            ``exponents``, ``errors``, ``converged``, ``reason``, ``sum``, ``kaplan_yorke``,
            ``trivial``, ``periods``, ``time``, ``block``, ``block_time``, ``tolerance``,
            ``params``, ``stats``, ``info`` and ``running`` (``t`` and ``values``).
        """
        run = self.running
        n = run.shape[0]
        idx = np.unique(np.linspace(0, n - 1, min(n, 200)).round().astype(int)) if n else np.zeros(0, int)
        return {
            "exponents": self.exponents.tolist(), "errors": self.errors.tolist(), "converged": bool(self.converged),
            "reason": self.reason, "sum": self.exponent_sum, "kaplan_yorke": self.kaplan_yorke,
            "trivial": self.trivial.tolist(), "periods": self.periods, "time": self.time, "block": self.block,
            "block_time": self.block_time, "tolerance": self.tolerance, "params": dict(self.params),
            "x_final": self.x_final.tolist(), "t_final": self.t_final, "stats": dict(self.stats),
            "info": dict(self.info),
            "running": {"t": ((idx + 1) * self.block_time).tolist(), "values": run[idx].tolist()},
        }

    def plot(self, ax: Any = None) -> Any:
        """Draw the running averages against time, and each final exponent with its error band.

        Parameters
        ----------
        ax
            A matplotlib axes (default: a new figure's).

        Returns
        -------
        matplotlib.axes.Axes
        """
        if ax is None:
            import matplotlib.pyplot as plt

            ax = plt.figure(figsize=(7, 4.2)).add_subplot()
        run = self.running
        t = self.block_time * np.arange(1, run.shape[0] + 1)
        for i in range(run.shape[1]):
            text = format_estimate(float(self.exponents[i]), float(self.errors[i])).replace("+-", "$\\pm$")
            line, = ax.plot(t, run[:, i], lw=1, label=f"$\\lambda_{{{i + 1}}}$ = {text}")
            ax.axhline(self.exponents[i], color=line.get_color(), ls="--", lw=0.8)
            ax.axhspan(self.exponents[i] - self.errors[i], self.exponents[i] + self.errors[i],
                       color=line.get_color(), alpha=0.15, lw=0)
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set_xlabel("time averaged over")
        ax.set_ylabel("running average of log-stretch rate")
        ax.legend(fontsize=8, loc="best")
        return ax

    def __repr__(self) -> str:
        ex = ", ".join(f"{v:.6g}" for v in self.exponents)
        return (f"LyapunovResult([{ex}], periods={self.periods:g}, "
                f"{'converged' if self.converged else 'NOT converged'})")


# ------------------------------------------------------------------ statistics
def format_estimate(value: float, error: float) -> str:
    """``"value +- error"`` with the digits the error allows (the error to two significant digits).

    Parameters
    ----------
    value, error
        An estimate and its error.

    Returns
    -------
    str
    """
    if not math.isfinite(value):
        return f"{value}"
    if not (math.isfinite(error) and error > 0):
        return f"{value:.6g} +- {error:.2g}"
    decimals = min(max(0, 1 - math.floor(math.log10(error))), 15)
    return f"{value:.{decimals}f} +- {error:.2g}"


def window(n: int, ramp: float = RAMP) -> np.ndarray:
    """Weights of ``n`` consecutive blocks: 1 in the middle, ``C^inf`` ramps over the first and
    last ``ramp`` of them that vanish with all derivatives at both ends.

    Parameters
    ----------
    n
        Number of blocks.
    ramp
        Fraction of the blocks in each ramp, in (0, 0.5].

    Returns
    -------
    ndarray
        Shape (n,), positive, at the block midpoints ``s = (j + 1/2) / n``.
    """
    s = (np.arange(n) + 0.5) / n

    def step(u: np.ndarray) -> np.ndarray:  # the smooth step exp(-1/u) / (exp(-1/u) + exp(-1/(1-u)))
        u = np.clip(u, 0.0, 1.0)
        with np.errstate(divide="ignore", over="ignore"):
            a = np.where(u > 0, np.exp(-1.0 / np.where(u > 0, u, 1.0)), 0.0)
            b = np.where(u < 1, np.exp(-1.0 / np.where(u < 1, 1.0 - u, 1.0)), 0.0)
        return a / (a + b)

    return step(s / ramp) * step((1.0 - s) / ramp)


def weighted_average(stretches: np.ndarray, h: float) -> np.ndarray:
    """Windowed time average of per-block stretches: ``sum_j w_j L_ji / (h sum_j w_j)``.

    Parameters
    ----------
    stretches
        ``log |R_ii|`` per block, shape (blocks, k).
    h
        Length of a block.

    Returns
    -------
    ndarray
        Shape (k,).
    """
    L = np.asarray(stretches, float)
    w = window(L.shape[0])
    return (w @ L) / (h * float(np.sum(w)))


def batch_errors(stretches: np.ndarray, h: float, batches: int) -> np.ndarray:
    """95 % half-width of the windowed averages of ``batches`` consecutive batches of blocks.

    Parameters
    ----------
    stretches
        ``log |R_ii|`` per block, shape (blocks, k), at least ``MIN_BATCH_BLOCKS * batches`` rows
        (else the number of batches is reduced, to 2 at least).
    h
        Length of a block.
    batches
        Number of batches ``B``.

    Returns
    -------
    ndarray
        ``t_{0.975, B-1} * std(batch averages) / sqrt(B)``, shape (k,); infinite with fewer
        than ``2 * MIN_BATCH_BLOCKS`` blocks.
    """
    from scipy.stats import t as student_t

    L = np.asarray(stretches, float)
    B = min(int(batches), L.shape[0] // MIN_BATCH_BLOCKS)
    if B < 2:
        return np.full(L.shape[1], math.inf)
    means = np.array([weighted_average(part, h) for part in np.array_split(L, B)])
    return float(student_t.ppf(0.975, B - 1)) * np.std(means, axis=0, ddof=1) / math.sqrt(B)


def kaplan_yorke(exponents: Sequence[float], complete: bool = True) -> float:
    """Kaplan-Yorke dimension of a spectrum.

    Parameters
    ----------
    exponents
        The exponents (sorted here, largest first).
    complete
        Whether these are all the exponents; if not and every partial sum is non-negative,
        the dimension is not known (NaN).

    Returns
    -------
    float
        ``j + (lambda_1 + ... + lambda_j) / |lambda_{j+1}|`` with ``j`` the largest index whose
        partial sum is >= 0; 0 if ``lambda_1 < 0``; the number of exponents if every partial
        sum is >= 0 and the spectrum is complete.
    """
    lam = sorted((float(v) for v in exponents), reverse=True)
    if not lam or not all(math.isfinite(v) or v == -math.inf for v in lam):
        return math.nan
    partial, j = 0.0, 0
    for v in lam:
        if partial + v < 0:
            break
        partial += v
        j += 1
    if j == len(lam):
        return float(j) if complete else math.nan
    return j + partial / abs(lam[j]) if math.isfinite(lam[j]) else float(j)


# ------------------------------------------------------------------ the run
@dataclass
class _Run:
    """The moving parts of one run: state, time, surface sides, tangent basis, counters."""

    system: CompiledSystem
    p: np.ndarray
    kw: dict[str, Any]
    x: np.ndarray
    t: float = 0.0
    sigma: np.ndarray | None = None
    n_calls: int = 0
    n_events: int = 0
    n_steps: int = 0
    scales: np.ndarray | None = None
    W: np.ndarray | None = None   # orthonormal basis of the quotient by the rigid-body subspace (scaled)
    Qv: np.ndarray | None = None  # ... and of the rigid-body subspace
    nd: int = 0
    defect: float = 0.0
    engine_kw: dict[str, Any] = field(default_factory=dict)

    def advance(self, h: float, monodromy: bool, samples: int = 2) -> Any:
        """One :meth:`System.flow` over ``[t, t + h]`` (``samples`` states); the run continues from its end."""
        fl = self.system.flow(self.x, self.t, self.t + h, self.p, monodromy=monodromy, sigma0=self.sigma,
                              n_samples=samples, **self.kw)
        self.x, self.sigma, self.t = fl.x_final, fl.sigma_final, self.t + h
        self.n_calls += 1
        self.n_events += int(fl.stats.get("n_events", 0))
        self.n_steps += int(fl.stats.get("n_steps", 0))
        if not np.all(np.isfinite(self.x)):
            raise SimulationError(f"the state is not finite at t = {self.t:.6g}")
        return fl

    def engine_setup(self, magnitude: np.ndarray) -> None:
        """The arguments of the blocks' engine calls, made once: what :meth:`System.flow` would pass
        (method, ``max_step = T/8``, the variational entries' absolute tolerances ``atol_i / magnitude_j``)."""
        system, nx = self.system, self.system.generated.nx
        method = self.kw.get("method") or default_method(system.generated.implicit, system.defaults.get("method"))
        T = system.period_of(self.p)
        ax = np.broadcast_to(np.asarray(self.kw["atol"], float), (nx,))
        sc = np.maximum(np.asarray(magnitude, float), np.finfo(float).tiny)
        self.engine_kw = {
            "method": method, "rtol": float(self.kw["rtol"]), "atol": float(np.min(ax)),
            "atol_vec": np.concatenate([ax, (ax[:, None] / sc[None, : self.nd]).T.ravel()]),
            "max_step": T / 8 if T else 0.0, "max_steps": int(system.defaults.get("max_steps", 0)),
            "want_monodromy": True}

    def tangent_map(self, h: float) -> np.ndarray:
        """One block: one engine call (directly: :meth:`System.flow`'s checks and output grid cost
        about as much again as the call, 180 against 90 us), its tangent map in scaled coordinates
        on the quotient by the rigid-body subspace."""
        res = self.system.engine.run(self.x, self.p, self.t, self.t + h, None, sigma0=self.sigma, **self.engine_kw)
        self.x, self.sigma, self.t = res.x_final, res.sigma_final, self.t + h
        self.n_calls += 1
        self.n_events += int(res.stats.get("n_events", 0))
        self.n_steps += int(res.stats.get("n_steps", 0))
        M = np.asarray(res.monodromy, float)[: self.nd, : self.nd]
        if not np.all(np.isfinite(self.x)):
            raise SimulationError(f"the state is not finite at t = {self.t:.6g}")
        if not np.all(np.isfinite(M)):
            raise SimulationError(f"the variational equations are not finite at t = {self.t:.6g}")
        D = self.scales
        Ms = M * (D[None, :] / D[:, None])  # diag(1/D) M diag(D)
        if self.W is None:
            return Ms
        self.defect = max(self.defect, float(np.linalg.norm(self.W.T @ Ms @ self.Qv, 2))
                          / max(1.0, float(np.linalg.norm(Ms, 2))))
        return self.W.T @ Ms @ self.W


def _qr_step(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A = Q R``: the new basis and ``log |R_ii|``."""
    Q, R = np.linalg.qr(A)
    with np.errstate(divide="ignore"):
        return Q, np.log(np.abs(np.diagonal(R)))


def lyapunov_exponents(system: CompiledSystem, params: Mapping[str, float] | None = None,
                       options: LyapunovOptions | None = None, *, x0: Sequence[float] | None = None,
                       progress: bool | None = False, **overrides: Any) -> LyapunovResult:
    """Lyapunov exponents of a compiled system at a parameter point (module docstring).

    Parameters
    ----------
    system
        The compiled system.
    params
        Parameter overrides (declared units), as a map quantity passes them.
    options
        Settings (:class:`LyapunovOptions`; default: its defaults).
    x0
        Initial state at ``t = 0`` (default: the scene's).
    progress
        A progress bar of the blocks (:func:`gearsym.progress.progress_bar`: ``tqdm.auto``;
        ``None``: in a terminal or a notebook).  Default ``False``: a map that computes the
        exponents at its points calls this once per point.
    **overrides
        Fields of :class:`LyapunovOptions` overriding ``options`` (e.g. ``periods=500``).

    Returns
    -------
    LyapunovResult
        Also when it has not converged (``converged`` False, ``reason`` says why).

    Raises
    ------
    ParameterError
        A bad option or parameter, ``block_time`` missing for an autonomous model (or given for
        a forced one), more exponents than directions, too few blocks for the estimate.
    SimulationError
        The integration failed (event storm, too much work, non-finite state).
    """
    opts = resolve_options(options, LyapunovOptions, overrides, "lyapunov_exponents")
    wall = time.perf_counter()
    p = system.param_vector(params)
    unit, forced = _time_unit(system, params, opts)
    k_most = opts.exponents if opts.exponents is not None else system.differential_states
    if opts.periods / (1.0 if opts.block is None else float(opts.block)) * k_most > MAX_HISTORY:
        raise ParameterError(f"periods={opts.periods:g} with {k_most} exponents keeps more than {MAX_HISTORY:.3g} "
                             "stretches: use fewer periods, fewer exponents or a longer block")
    run = _setup(system, p, params, opts, x0, unit)
    m = run.W.shape[1] if run.W is not None else run.nd
    k = opts.exponents if opts.exponents is not None else m
    if k > m:
        raise ParameterError(f"exponents={k}: the system has {m} directions"
                             + (f" besides its {run.nd - m} rigid-body ones" if m < run.nd else ""))
    b = 1.0 if opts.block is None else float(opts.block)
    Q = np.eye(m)[:, :k]
    t_phase, t_start = time.perf_counter(), run.t
    Q, b, growth = _align(run, Q, b, unit, opts)
    n_blocks = int(round(opts.periods / b))  # (the block may have been halved)
    if n_blocks * k > MAX_HISTORY:
        raise ParameterError(f"the tangent directions separate so fast that a block is {b:g} period(s): "
                             f"{opts.periods:g} periods need {n_blocks:,} blocks; compute fewer exponents")
    h = b * unit
    L = np.empty((n_blocks, k))
    step = max(n_blocks // 200, 1)
    with progress_bar(progress, n_blocks, "Lyapunov blocks", unit="block") as bar:
        for j in range(n_blocks):
            Q, L[j] = _qr_step(run.tangent_map(h) @ Q)
            if k > 1:
                growth = max(growth, float(L[j, 0] - L[j, -1]))
            if (j + 1) % step == 0:
                bar(step)
    rate = (run.t - t_start) / unit / max(time.perf_counter() - t_phase, 1e-300)
    return _result(system, params, opts, run, L, b, unit, forced, k, m, growth, wall, rate)


def _time_unit(system: CompiledSystem, params: Mapping[str, float] | None, opts: LyapunovOptions) -> tuple[float, bool]:
    """The length of one "period" of the counts: the forcing period, or ``block_time``."""
    T = system.period(params)
    if T is not None:
        if opts.block_time is not None:
            raise ParameterError(f"block_time={opts.block_time:g}: this model has a forcing period (T = {T:g}); "
                                 "give the block in forcing periods (block=...)")
        return T, True
    if system.has_forcing_period:
        system.require_period(params, "the Lyapunov exponents")  # raises, saying why there is none
    if opts.block_time is None:
        raise ParameterError("this model has no forcing period: give block_time (the length of a block in the "
                             "system's time; periods and transient then count blocks)")
    return float(opts.block_time), False


def _setup(system: CompiledSystem, p: np.ndarray, params: Mapping[str, float] | None, opts: LyapunovOptions,
           x0: Sequence[float] | None, unit: float) -> _Run:
    """The transient, the state scales, the tolerances and the rigid-body split."""
    nx = system.generated.nx
    x = np.array(system.x0 if x0 is None else x0, dtype=float).reshape(-1)
    if x.shape != (nx,) or not np.all(np.isfinite(x)):
        raise ParameterError(f"x0 must be {nx} finite numbers ({', '.join(system.state_names)}), got {x0!r}")
    kw: dict[str, Any] = {"rtol": opts.rtol, "atol": opts.atol if opts.atol is not None else 1e-12}
    if opts.method is not None:
        kw["method"] = opts.method
    run = _Run(system, p, kw, x, nd=system.differential_states)
    span = opts.transient if opts.transient > 0 else 1.0
    while span > TRANSIENT_CHUNK:  # (one call's step budget: the magnitudes come from the last piece)
        run.advance(TRANSIENT_CHUNK * unit, False)
        span -= TRANSIENT_CHUNK
    fl = run.advance(span * unit, False, int(min(max(16 * span, 2), 20_001)))
    amp = np.max(np.abs(np.vstack([fl.samples, x[None, :]])), axis=0)
    if opts.transient <= 0:  # the run only measured the magnitudes: start again from x0
        run.x, run.t, run.sigma = x, 0.0, None
    run.scales = _tangent_scales(fl.samples)[: run.nd]
    top = float(np.max(amp)) if amp.size else 1.0
    magnitude = np.maximum(amp, max(1e-6 * top, 1e-300)) if top > 0 else np.ones(nx)
    if opts.atol is None:
        kw["atol"] = 1e-2 * opts.rtol * magnitude
    run.engine_setup(magnitude)
    V = rigid_state_basis(system, params) if run.nd == nx else None
    if V is not None and V.shape[1]:
        Qf, _ = np.linalg.qr(V / run.scales[:, None], mode="complete")
        r = int(np.linalg.matrix_rank(V))
        run.Qv, run.W = Qf[:, :r], Qf[:, r:]
    return run


def _tangent_scales(samples: np.ndarray) -> np.ndarray:
    """The unit of each state in the tangent space: half its scale along the transient
    (:func:`~gearsym.analysis.sweeps._scales.sample_scale`: its peak-to-peak, at least 1e-3 of its
    magnitude), so that for an oscillation ``x`` and ``v = x'`` trace a circle, not a flat ellipse."""
    return 0.5 * sample_scale(samples)


def _align(run: _Run, Q: np.ndarray, b: float, unit: float, opts: LyapunovOptions) -> tuple[np.ndarray, float, float]:
    """The alignment blocks; halve an automatic block while the directions separate too fast in it."""
    growth = 0.0
    done = 0
    while done < opts.align:
        Qn, logs = _qr_step(run.tangent_map(b * unit) @ Q)
        g = float(logs[0] - logs[-1]) if len(logs) > 1 else 0.0
        if opts.block is None and g > GROWTH_LIMIT and b > MIN_BLOCK and math.isfinite(g):
            b /= 2.0
            done = 0  # the alignment starts over with the shorter block (from where the run is)
            Q = Qn
            continue
        Q = Qn
        growth = max(growth, g) if done >= opts.align // 2 else growth
        done += 1
    return Q, b, growth


def _result(system: CompiledSystem, params: Mapping[str, float] | None, opts: LyapunovOptions, run: _Run,
            L: np.ndarray, b: float, unit: float, forced: bool, k: int, m: int, growth: float, wall: float,
            rate: float) -> LyapunovResult:
    """The estimates, the convergence verdict and the bookkeeping of a finished run."""
    h = b * unit
    lam = weighted_average(L, h)
    err = batch_errors(L, h, opts.batches) + ERROR_FACTOR * opts.rtol / h
    abs_tol = opts.abs_tol if opts.abs_tol is not None else 1e-4 / unit
    finite = lam[np.isfinite(lam)]
    scale = float(np.max(np.abs(finite))) if finite.size else 0.0
    need = abs_tol + opts.rel_tol * scale
    reason = _verdict(lam, err, need, L.shape[0] * b, forced)
    n_triv = run.nd - m
    defect_note = "none"
    if run.W is not None:
        defect_note = f"split off {n_triv} rigid-body directions (invariance defect {run.defect:.2g})"
    stats = {"n_calls": run.n_calls, "wall_s": time.perf_counter() - wall, "periods_per_second": rate,
             "n_events": run.n_events, "n_steps": run.n_steps, "max_growth": growth}
    info = {"forced": forced, "period": unit if forced else None, "tangent_scales": run.scales.tolist(),
            "rigid_split": defect_note,
            "invariance_defect": run.defect, "dimension": m, "estimator": "windowed time average",
            "batches": min(opts.batches, L.shape[0] // MIN_BATCH_BLOCKS)}
    if growth > GROWTH_LIMIT:
        rounding = np.finfo(float).eps * math.exp(min(growth, 700.0))
        info["growth_note"] = (f"the tangent directions separated by up to exp({growth:.3g}) in a block: the "
                               f"rounding error of the weakest one is about {rounding:.2g} per block (a shorter "
                               "block lowers it)")
    ky = lam.copy()
    if not forced and len(ky):  # the flow direction's exponent is 0: count it as 0 when it is within its error
        i = int(np.argmin(np.abs(ky)))
        if abs(ky[i]) <= err[i]:
            ky[i] = 0.0
            info["kaplan_yorke_zero"] = i
    return LyapunovResult(
        exponents=lam, errors=err, converged=not reason, reason=reason, periods=L.shape[0] * b,
        time=L.shape[0] * h, kaplan_yorke=kaplan_yorke(ky, complete=(k == m)), trivial=np.zeros(n_triv),
        block=b, block_time=h, stretches=L, tolerance=need, params=system.run_params(params),
        x_final=run.x.copy(), t_final=run.t, stats=stats, info=info)


def _verdict(lam: np.ndarray, err: np.ndarray, need: float, periods: float, forced: bool) -> str:
    """Empty when every exponent converged, else which did not and about how long a run would."""
    if not np.all(np.isfinite(lam)):
        return "an exponent is not finite (a direction collapsed to zero: a zero multiplier)"
    bad = [i for i in range(len(lam)) if not err[i] <= need]
    if not bad:
        return ""
    worst = max(err[i] / need for i in bad) if need > 0 else math.inf
    what = "periods" if forced else "blocks"
    parts = ", ".join(f"lambda_{i + 1} = {lam[i]:.4g} +- {err[i]:.2g}" for i in bad)
    more = (f"; about {periods * worst ** 2:.3g} {what} would do (the error of a chaotic response falls like "
            f"1/sqrt({what}), of a periodic or quasi-periodic one faster)" if math.isfinite(worst) else "")
    return f"not converged after {periods:g} {what}: {parts} (95 %), needed +- {need:.2g}{more}"
