"""The criteria that turn a row's numbers into its verdict (docs/reproduction.md).

Used by ``examples/reproduce.py`` and ``examples/yu_readings.py``; numpy only (no gearsym), so
that ``tests/test_reproduction_verdicts.py`` can feed it numbers and check the verdicts.

A row is a list of :class:`Claim` -- one per statement of the paper, each decided by a
criterion below from the row's own numbers, with those numbers in its ``because`` -- and
:func:`verdict` combines them: **reproduced** when every claim that can be checked holds
(**qualitatively** instead when the row says its comparison rests on chosen parameters or the
paper gives no numbers), **qualitatively** when some hold, **not reproduced** when none does.
So a verdict never claims a feature its numbers do not show.

Criteria (the constants are the thresholds, stated on the page by :func:`criteria_text`):

* **transition** (a change of rattle state): located between the two nearest samples whose
  states differ, or at a located grazing of the continued branch; it *holds* against the
  paper's value when within :data:`TRANSITION_REL` of it.
* **succession** (e.g. "no rattle, unilateral, then bilateral"): the sequence of states met
  along the parameter, repeated states merged, is the paper's.
* **jump** at a transition: a discontinuity of the continued branch there, i.e. a fold (or
  another located bifurcation that changes the stable response: period doubling,
  Neimark-Sacker, the end of the branch at a located point) within :data:`JUMP_WINDOW` of the
  transition value.  A steep but continuous rise is not a jump, and a rise somewhere before
  the transition is not a jump *at* it: :func:`steepest_change` reports where the largest
  change between neighbouring samples is and in which state.  A sampled sweep without a
  continued branch through the transition cannot show a discontinuity.
* **trend** ("rises", "falls" over a few values): every step changes by more than
  :data:`TREND_REL` in that direction; "no effect" is a relative spread below it.  **tendency**
  of a longer, noisy series (:func:`tendency`): Spearman rank correlation of at least 0.8 and a
  change of more than :data:`TREND_REL` end to end.
* **response kind**: periodic when the Poincare points (one per forcing period) coincide to
  :data:`POINCARE_TOL` of the response's range, ``P k`` when they fall on ``k <= 16`` such
  points; otherwise the rule of ``gearsym sweep`` (:mod:`gearsym.analysis.sweeps`, issue 28):
  with the zero band ``max(error, LYAPUNOV_FLOOR / T)`` (:data:`LYAPUNOV_FLOOR` per forcing
  period ``T``), chaotic when the largest Lyapunov exponent is positive beyond the band,
  quasi-periodic when it is within the band, its error is at most :data:`LYAPUNOV_FLOOR` per
  forcing period and the Poincare points lie on one closed curve
  (:func:`gearsym.analysis.sweeps.closed_curve`), "converging" when negative beyond the band (a
  stable response whose orbit was not found), else "unclassified".
* **numbers**: a value *agrees* with the paper's when within the row's stated tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gearsym.analysis.sweeps._attractor_id import ZERO_RATE

#: a located transition holds within this fraction of the paper's value
TRANSITION_REL = 0.05
#: a fold or bifurcation counts as a jump *at* a transition within this fraction of its value
JUMP_WINDOW = 0.01
#: a trend needs more than this relative change per step ("no effect": spread below it)
TREND_REL = 0.01
#: Poincare points coincide within this fraction of the response's range
POINCARE_TOL = 1e-3
#: a Lyapunov exponent is zero within max(its error, this per forcing period) (gearsym sweep's rule: its constant)
LYAPUNOV_FLOOR = ZERO_RATE

REPRODUCED = "reproduced"
QUALITATIVELY = "qualitatively"
NOT_REPRODUCED = "not reproduced"
PENDING = "pending"


@dataclass(frozen=True)
class Claim:
    """One statement of the paper and whether the row's numbers show it."""

    text: str
    holds: bool | None          # None: the numbers cannot decide (no paper value, not computed)
    because: str = ""

    def render(self) -> str:
        word = {True: "holds", False: "does not hold", None: "not checkable"}[self.holds]
        return f"{self.text}: {word}" + (f" ({self.because})" if self.because else "")


def verdict(claims: Sequence[Claim], *, note: str = "", cap: str = "") -> tuple[str, str]:
    """The verdict of a row and its reason from its claims.

    ``note``: what the reader must know about the comparison (parameters chosen where the paper
    gives none, ...), appended to the reason.  ``cap``: why the numbers cannot be compared
    (the paper has none): a row whose claims all hold is then *qualitatively*.
    """
    checked = [c for c in claims if c.holds is not None]
    n_ok = sum(1 for c in checked if c.holds)
    if not checked:
        v = NOT_REPRODUCED
    elif n_ok == len(checked):
        v = QUALITATIVELY if cap else REPRODUCED
    elif n_ok:
        v = QUALITATIVELY
    else:
        v = NOT_REPRODUCED
    why = "; ".join(c.render() for c in claims)
    for extra in (cap, note):
        if extra:
            why += f"; {extra}"
    return v, why


# ----------------------------------------------------------------------------- transitions
@dataclass(frozen=True)
class Transition:
    """A change of rattle state between two parameter values (``lo == hi`` when located)."""

    lo: float
    hi: float
    before: int
    after: int

    @property
    def at(self) -> float:
        return 0.5 * (self.lo + self.hi)

    def text(self, unit: str = "") -> str:
        where = f"{self.lo:g}" if self.lo == self.hi else f"{self.lo:g}-{self.hi:g}"
        return f"{self.before} -> {self.after} at {where}{(' ' + unit) if unit else ''}"


def transitions(values: Sequence[float], states: Sequence[int | None]) -> list[Transition]:
    """Every change of state between neighbouring samples (samples without a state skipped)."""
    pts = [(float(v), int(s)) for v, s in zip(values, states, strict=True) if s is not None]
    return [Transition(a, b, sa, sb) for (a, sa), (b, sb) in zip(pts, pts[1:]) if sa != sb]


def first_transition(trs: Sequence[Transition], before: int | None, after: int) -> Transition | None:
    """The first transition into ``after`` (from ``before`` when given)."""
    for t in trs:
        if t.after == after and (before is None or t.before == before):
            return t
    return None


def succession(states: Sequence[int | None], expected: Sequence[int]) -> bool:
    """The states met in order (repeats merged, missing samples skipped) are ``expected``."""
    seq: list[int] = []
    for s in states:
        if s is not None and (not seq or seq[-1] != s):
            seq.append(int(s))
    return seq == list(expected)


def transition_holds(found: float, paper: float, rel: float = TRANSITION_REL) -> bool:
    """A located transition agrees with the paper's value within ``rel`` of it."""
    return math.isfinite(found) and abs(found - paper) <= rel * abs(paper)


# ----------------------------------------------------------------------------- jumps
@dataclass(frozen=True)
class Change:
    """The largest change of an amplitude between neighbouring samples."""

    lo: float
    hi: float
    ratio: float
    state_lo: int | None
    state_hi: int | None

    def text(self, unit: str = "") -> str:
        u = f" {unit}" if unit else ""
        inside = (f"inside state {self.state_lo}" if self.state_lo == self.state_hi
                  else f"across states {self.state_lo} -> {self.state_hi}")
        return f"x{self.ratio:.2f} between {self.lo:g} and {self.hi:g}{u} ({inside})"


def steepest_change(values: Sequence[float], amps: Sequence[float], states: Sequence[int | None],
                    rising: bool = True) -> Change | None:
    """The neighbouring pair with the largest ratio of amplitudes (``rising``: amp_hi/amp_lo)."""
    best = None
    for i in range(len(values) - 1):
        a, b = float(amps[i]), float(amps[i + 1])
        if not (math.isfinite(a) and math.isfinite(b)) or a <= 0 or b <= 0:
            continue
        r = b / a if rising else a / b
        if best is None or r > best.ratio:
            best = Change(float(values[i]), float(values[i + 1]), r, states[i], states[i + 1])
    return best


def ratio_across(values: Sequence[float], amps: Sequence[float], at: float, window: float) -> float:
    """Amplitude just after over just before ``at`` on a branch: the samples nearest to ``at`` on
    each side within ``window`` (a sample at ``at``, e.g. the located grazing, counts as before it;
    nan without one on each side).  Direction: increasing value."""
    v = np.asarray(values, float)
    a = np.asarray(amps, float)
    left = np.nonzero((v <= at) & (v >= at - window))[0]
    right = np.nonzero((v > at) & (v <= at + window))[0]
    if not len(left) or not len(right):
        return math.nan
    i = left[np.argmax(v[left])]
    j = right[np.argmin(v[right])]
    return float(a[j] / a[i]) if a[i] > 0 else math.nan


#: the bifurcations that change the stable response (a jump of the observed amplitude)
JUMP_TYPES = ("fold", "period_doubling", "neimark_sacker")


@dataclass(frozen=True)
class Jump:
    """Whether a continued branch jumps at a transition, and the numbers that decide it."""

    holds: bool
    at: float
    near: list[tuple[str, float]]
    ratio: float
    steepest: Change | None

    def text(self, unit: str = "") -> str:
        u = f" {unit}" if unit else ""
        parts = []
        if self.near:
            parts.append(", ".join(f"{k} at {v:g}{u}" for k, v in self.near) + f" within {JUMP_WINDOW:.0%}")
        else:
            parts.append(f"no fold or bifurcation within {JUMP_WINDOW:.0%} of {self.at:g}{u}")
        if math.isfinite(self.ratio):
            parts.append(f"ppv x{self.ratio:.2f} across it")
        if self.steepest is not None:
            parts.append(f"steepest change {self.steepest.text(unit)}")
        return "; ".join(parts)


def jump_at(at: float, bifurcations: Sequence[tuple[str, float]], values: Sequence[float], amps: Sequence[float],
            states: Sequence[int | None], rising: bool = True) -> Jump:
    """A jump of the continued branch at the transition ``at``: a fold (or a bifurcation of
    :data:`JUMP_TYPES`) within :data:`JUMP_WINDOW` of it."""
    w = JUMP_WINDOW * abs(at)
    near = [(k, float(v)) for k, v in bifurcations if k in JUMP_TYPES and abs(float(v) - at) <= w]
    return Jump(bool(near), at, near, ratio_across(values, amps, at, w), steepest_change(values, amps, states, rising))


# ----------------------------------------------------------------------------- trends and kinds
def trend(values: Sequence[float], rel: float = TREND_REL) -> str:
    """``"rises"`` / ``"falls"``: every step by more than ``rel``; ``"flat"``: spread below ``rel``;
    else ``"mixed"``."""
    v = [float(x) for x in values]
    if any(not math.isfinite(x) for x in v):
        return "mixed"
    if all(b > a + rel * abs(a) for a, b in zip(v, v[1:])):
        return "rises"
    if all(b < a - rel * abs(a) for a, b in zip(v, v[1:])):
        return "falls"
    if max(v) - min(v) <= rel * max(abs(x) for x in v):
        return "flat"
    return "mixed"


def tendency(values: Sequence[float], rel: float = TREND_REL, rank: float = 0.8) -> str:
    """The overall direction of a noisy series: ``"grows"`` when its Spearman rank correlation
    with the parameter is at least ``rank`` and the last value exceeds the first by more than
    ``rel``; ``"falls"`` likewise; else ``"none"``."""
    v = np.asarray([float(x) for x in values], float)
    v = v[np.isfinite(v)]
    if v.size < 2:
        return "none"
    r = np.argsort(np.argsort(v)).astype(float)
    i = np.arange(v.size, dtype=float)
    rho = float(np.corrcoef(i, r)[0, 1]) if v.size > 2 else float(np.sign(v[1] - v[0]))
    change = (v[-1] - v[0]) / abs(v[0]) if v[0] != 0 else math.inf
    if rho >= rank and change > rel:
        return "grows"
    if rho <= -rank and change < -rel:
        return "falls"
    return "none"


def spread(values: Sequence[float]) -> float:
    """``(max - min)/max|v|`` of a set of values (the relative effect of a parameter)."""
    v = np.asarray(values, float)
    return float(np.ptp(v) / np.max(np.abs(v))) if v.size and np.max(np.abs(v)) > 0 else 0.0


def kind_of(poincare_points: int, lyapunov: float | None = None, error: float | None = None,
            period: float | None = None, closed: bool | None = None) -> str:
    """The kind of a response (see the module docstring): ``periodic``, ``P<k>``, ``chaotic``,
    ``quasi-periodic``, ``converging``, ``unclassified`` or ``non-periodic`` (no exponent given).

    The non-periodic rule is ``gearsym sweep``'s (``gearsym.analysis.sweeps``): ``lyapunov`` and its
    ``error`` per unit time, ``period`` the forcing period, ``closed`` whether the Poincare points
    lie on one closed curve (:func:`gearsym.analysis.sweeps.closed_curve`; ``None``: not known).
    """
    if poincare_points == 1:
        return "periodic"
    if 2 <= poincare_points <= 16:
        return f"P{poincare_points}"
    if lyapunov is None or not math.isfinite(lyapunov):
        return "non-periodic"
    # gearsym.analysis.sweeps._attractor_id.classify_exponent, with the section's closed_curve given
    err = float(error or 0.0)
    floor = LYAPUNOV_FLOOR / period if period else 0.0
    band = max(err, floor)
    if lyapunov > band:
        return "chaotic"
    if abs(lyapunov) <= band:
        if err > floor:
            return "unclassified"   # zero within an error wider than the zero band says nothing
        return "quasi-periodic" if closed is not False else "unclassified"
    return "converging"


def poincare_count(points: np.ndarray, scale: np.ndarray, tol: float = POINCARE_TOL) -> int:
    """Distinct Poincare points: rows of ``points`` equal after rounding to ``tol * scale``."""
    s = np.maximum(np.asarray(scale, float), 1e-300)
    return int(len(np.unique(np.round(np.asarray(points, float) / (tol * s)), axis=0)))


def route_to_chaos(kinds: Sequence[str]) -> bool:
    """Periodic first, then multi-periodic, then chaotic (the paper's route, e.g. Yu Fig. 10)."""
    return (len(kinds) >= 3 and kinds[0] == "periodic" and any(k.startswith("P") for k in kinds[1:-1])
            and kinds[-1] == "chaotic")


def agrees(found: float, paper: float, rel: float) -> bool:
    """A number agrees with the paper's within ``rel`` of it."""
    return math.isfinite(found) and abs(found - paper) <= rel * abs(paper)


def criteria_text() -> list[str]:
    """The criteria as the page states them."""
    return [
        f"**transition** (a change of rattle state): between the two nearest samples whose states differ, or at a "
        f"located grazing of the continued branch; it holds when within {TRANSITION_REL:.0%} of the paper's value.",
        "**succession**: the states met along the parameter (repeats merged) are the paper's, in its order.",
        f"**jump** at a transition: a fold of the continued branch (or a period doubling or Neimark-Sacker "
        f"bifurcation, which changes the stable response) within {JUMP_WINDOW:.0%} of the transition value.  A steep "
        f"continuous rise is not a jump, and a rise before the transition is not a jump at it (the rows say where "
        f"the steepest change is); a sampled sweep without a branch through the transition cannot show one.",
        f"**trend** (rises / falls with D, G, ...): every step by more than {TREND_REL:.0%}; **no effect**: spread "
        f"below {TREND_REL:.0%}; **tendency** of a longer, noisy series (grows / falls with a parameter): Spearman "
        f"rank correlation of at least 0.8 in that direction and a change of more than {TREND_REL:.0%} end to end.",
        f"**response kind**: periodic when the Poincare points coincide to {POINCARE_TOL:g} of the range, P k for "
        f"k <= 16 points; otherwise the rule of `gearsym sweep`: chaotic when the largest Lyapunov "
        f"exponent is positive beyond its error and {LYAPUNOV_FLOOR:g} per forcing period, quasi-periodic when "
        f"zero within that, its error at most {LYAPUNOV_FLOOR:g} per forcing period and the Poincare points lie on "
        f"one closed curve, converging when negative beyond it, else unclassified.",
        "**verdict**: reproduced when every checkable claim holds (qualitatively when the comparison rests on "
        "chosen parameters or the paper has no numbers), qualitatively when some hold, not reproduced when none.",
    ]
