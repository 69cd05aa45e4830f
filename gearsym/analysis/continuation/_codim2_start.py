"""Where a bifurcation curve starts: :class:`CurveStart` and :class:`CurveOptions`.

A curve starts from a special point located on a one-parameter branch (a :class:`Branch`, or
its JSON as written by ``gearsym continue --json`` / :meth:`Branch.save_json`) or from a user's
guess of the two parameter values (and optionally the orbit's state).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...budget import check_counts
from ...errors import ParameterError

__all__ = ["CurveOptions", "CurveStart"]

#: directions of a curve from its start: "both", or "forward" / "backward" (the first parameter
#: increasing / decreasing at the start)
DIRECTIONS = ("both", "forward", "backward")


@dataclass(frozen=True)
class CurveOptions:
    """Settings of :func:`~gearsym.analysis.continuation.continue_bifurcation` (each with its default).

    Attributes
    ----------
    periods : float or None
        Forcing periods per orbit.  Default: the start's (the branch's), else 1.
    t0 : float or None
        Phase of the orbit's reference state.  Default: the start's, else 0.
    ds, ds_min, ds_max : float
        Initial, smallest and largest step in scaled arclength (the parameters scaled by their
        ranges, the states by their magnitudes).  Default 0.01, 1e-6, 0.05.
    max_angle : float
        Largest angle (rad) between consecutive tangents before a step is refused.  Default 0.3.
    max_points : int
        Points per direction.  Default 400.
    tol : float
        Corrector tolerance on the scaled residual (the orbit's rows by the state magnitudes,
        the test functions by theirs).  Default 1e-10.
    rtol, atol : float or None
        Integrator tolerances.  ``rtol`` default 1e-10; ``atol`` default ``rtol * 1e-2`` times the
        smallest state magnitude on the first orbit (an orbit ``x = 0``: the scene's scale, as
        :class:`~gearsym.analysis.continuation.ContinuationOptions`).
    max_newton : int
        Newton steps per correction.  Default 8.
    fd_step : float or None
        Relative step of the central differences of the test functions.  Default ``rtol ** (1/3)``
        in [1e-6, 1e-3].
    direction : str
        ``"both"`` (default), ``"forward"`` or ``"backward"`` (the first parameter increasing or
        decreasing at the start).
    detect, locate : bool
        Detect the codimension-2 points (test functions changing sign between two points) and
        locate them (bisection / secant on the curve).  Default True, True.
    n_dense : int
        Samples per orbit for the extrema of the switching functions (intersections with grazing
        curves).  Default 512.
    scale2 : float or None
        Magnitude of the second parameter in the arclength.  Default: the width of its range when
        finite, else ``max(|value2|, 1)`` at the start.
    surface, side : str or None
        Grazing curves: the switching surface and the extremum (``"min"``: the orbit touches
        ``g = 0`` from ``g > 0``; ``"max"``).  Default: the start's (a grazing point of a branch);
        with a guess, the surface and side whose extremum is nearest zero.
    transient : float or None
        Forcing periods integrated from the scene's initial state when a guess gives no state.
        Default: the scene's ``transient_periods``, else 50.
    method : str or None
        Integrator.  Default: the scene's.
    """

    periods: float | None = None
    t0: float | None = None
    ds: float = 0.01
    ds_min: float = 1e-6
    ds_max: float = 0.05
    max_angle: float = 0.3
    max_points: int = 400
    tol: float = 1e-10
    rtol: float = 1e-10
    atol: float | None = None
    max_newton: int = 8
    fd_step: float | None = None
    direction: str = "both"
    detect: bool = True
    locate: bool = True
    n_dense: int = 512
    scale2: float | None = None
    surface: str | None = None
    side: str | None = None
    transient: float | None = None
    method: str | None = None

    def __post_init__(self) -> None:
        check_counts(max_points=self.max_points, max_newton=self.max_newton, n_dense=self.n_dense)
        if self.direction not in DIRECTIONS:
            raise ParameterError(f"direction must be one of {', '.join(DIRECTIONS)}, got '{self.direction}'")
        if not (0 < self.ds_min <= self.ds <= self.ds_max <= 1) or self.max_points < 2 or not 0 < self.max_angle:
            raise ParameterError("need 0 < ds_min <= ds <= ds_max <= 1, max_points >= 2, max_angle > 0")
        for name in ("tol", "rtol", "atol", "fd_step", "scale2", "periods"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a positive finite number, got {v}")
        if self.side is not None and self.side not in ("min", "max"):
            raise ParameterError(f"side must be 'min' or 'max', got '{self.side}'")


@dataclass(frozen=True)
class CurveStart:
    """The first point of a bifurcation curve (before it is corrected onto the curve).

    Attributes
    ----------
    values : dict
        ``{name: value}`` of parameters at the start (declared units): the branch's fixed ones
        and the special point's value of the branch's parameter, or the guess.
    x0 : ndarray or None
        The orbit's state at ``t0`` (``None``: from a transient).
    type : str or None
        The special point's type on its branch (``None`` for a guess).
    varied : str or None
        The parameter the branch varied (the start is corrected with the other one held).
    periods, t0 : float or None
        The branch's forcing periods per orbit and phase.
    surface, side : str or None
        A grazing point's surface and side.
    info : dict
        Where the start came from (``from``: ``"branch"`` with the special point's ``index``,
        ``type`` and ``value``, or ``"guess"``); the curve's ``info["start"]``.
    """

    values: dict[str, float]
    x0: np.ndarray | None = None
    type: str | None = None
    varied: str | None = None
    periods: float | None = None
    t0: float | None = None
    surface: str | None = None
    side: str | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def guess(cls, values: Mapping[str, float], x0: Sequence[float] | None = None) -> CurveStart:
        """A start from a guess.

        Parameters
        ----------
        values
            ``{param: value, param2: value2}`` near the curve (declared units).
        x0
            The orbit's state at ``t0`` near the curve (default: a transient from the scene's
            initial state).

        Returns
        -------
        CurveStart
        """
        vals = {str(k): float(v) for k, v in values.items()}
        for k, v in vals.items():
            if not math.isfinite(v):
                raise ParameterError(f"guess: non-finite value of '{k}': {v}")
        return cls(vals, None if x0 is None else np.asarray(x0, float), info={"from": "guess"})

    @classmethod
    def from_branch(cls, branch: Any, index: int = 0) -> CurveStart:
        """A start at a special point of a branch.

        Parameters
        ----------
        branch
            A :class:`~gearsym.analysis.continuation.Branch`, or its JSON object (a mapping as
            written by ``gearsym continue --json``).
        index
            Index of the special point in the branch's ``bifurcations``.

        Returns
        -------
        CurveStart

        Raises
        ------
        ParameterError
            No such special point, or a branch without the keys a start needs.
        """
        d = branch.to_dict(children=False) if hasattr(branch, "to_dict") else dict(branch)
        bifs = d.get("bifurcations")
        if not isinstance(bifs, list) or "param" not in d:
            raise ParameterError("the branch has no 'param' and 'bifurcations' (a JSON of gearsym continue?)")
        if not bifs:
            raise ParameterError("the branch has no located special point to start a curve from")
        if not -len(bifs) <= int(index) < len(bifs):
            have = ", ".join(f"{i}: {b.get('type')}" for i, b in enumerate(bifs))
            raise ParameterError(f"special point index {index} out of range: the branch has {len(bifs)} ({have})")
        b = bifs[int(index)]
        if b.get("located") is False:
            raise ParameterError(f"special point {index} ({b.get('type')}) was detected but not located "
                                 f"({b.get('reason', '')}): no point to start from")
        try:
            values = {str(k): float(v) for k, v in (d.get("params") or {}).items()}
            values[str(d["param"])] = float(b["value"])
            x0 = np.asarray(b["x0"], float)
        except (KeyError, TypeError, ValueError) as exc:
            raise ParameterError(f"special point {index} of the branch lacks its value or state: {exc}") from None
        period_count = d.get("periods")
        return cls(values, x0, type=str(b.get("type")), varied=str(d["param"]),
                   periods=None if period_count is None else float(period_count),
                   t0=None if d.get("t0") is None else float(d["t0"]),
                   surface=b.get("surface"), side=b.get("side"),
                   info={"from": "branch", "index": int(index), "type": b.get("type"), "value": float(b["value"])})
