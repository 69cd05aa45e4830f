"""Independent reference for the two-stage train (no gearsym code).

The equations of ``models/two_stage_train.toml`` written by hand, with the parameters
read from the TOML file and converted to SI here (rpm, mm, um, deg)::

    J1 th1'' = T_in - rb1 W1
    J2 th2'' = rb2 W1 - M_s
    J3 th3'' = M_s - rb3 W2
    J4 th4'' = rb4 W2 - T_out,                    T_out = T_in (rb2/rb1) (rb4/rb3)
    W_i = k_i(t) f(delta_i, b_i) + c_i delta_i',   f the dead zone of half width b_i
    delta_1 = rb1 th1 - rb2 th2 - e1 cos(w_m1 t),  delta_2 = rb3 th3 - rb4 th4 - e2 cos(w_m2 t + phi2)
    M_s = k_s (th2 - th3) + c_s (w2 - w3)

``k_i(t)`` is ``r_k k_min`` for the first ``eps_i - 1`` of mesh cycle ``i`` and ``k_min``
after it.  :func:`reference_solution` integrates with scipy ``solve_ivp`` DOP853 on the
smooth right-hand side of one contact mode of each mesh at a time, stops at every
scheduled stiffness jump and at every contact event (terminal events on
``delta_i -/+ b_i``, only the crossings that leave the current mode armed), and restarts
there in the new mode.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
SURFACES = ("mesh1.drive", "mesh1.back", "mesh2.drive", "mesh2.back")
_UNIT = {"rpm": 2 * math.pi / 60, "mm": 1e-3, "um": 1e-6, "deg": math.pi / 180}


def parameters(overrides: dict[str, float] | None = None) -> dict[str, float]:
    """SI parameters of models/two_stage_train.toml (``overrides`` in the declared units)."""
    data = tomllib.loads((ROOT / "models" / "two_stage_train.toml").read_text())
    p = {}
    for name, d in data["parameters"].items():
        value = float((overrides or {}).get(name, d["value"]))
        p[name] = value * _UNIT.get(d.get("unit", "1"), 1.0)
    return p


class TwoStageTrain:
    """The hand-written model at one parameter set (SI)."""

    def __init__(self, overrides: dict[str, float] | None = None):
        p = parameters(overrides)
        self.p = p
        m, a = p["m_n"], p["alpha"]
        self.rb = [m * p[z] * math.cos(a) / 2 for z in ("z1", "z2", "z3", "z4")]
        disk = [math.pi * p["rho"] * b * (m * p[z] / 2) ** 4 / 2
                for z, b in (("z1", p["b1"]), ("z2", p["b1"]), ("z3", p["b2"]), ("z4", p["b2"]))]
        self.J = [p["J_mot"] + disk[0], disk[1], disk[2], p["J_load"] + disk[3]]
        rb1, rb2, rb3, rb4 = self.rb
        J1, J2, J3, J4 = self.J
        self.T_in = p["T_in"]
        self.T_out = p["T_in"] * (rb2 / rb1) * (rb4 / rb3)
        self.w1 = p["z1"] * p["n_in"]
        self.w2 = p["z3"] * p["n_in"] * p["z1"] / p["z2"]
        self.kmin = [p["c_s1"] * p["b1"], p["c_s1"] * p["b2"]]
        self.duty = [p["eps1"] - 1, p["eps2"] - 1]
        kmean = [km * (p["r_k"] * d + 1 - d) for km, d in zip(self.kmin, self.duty)]
        me = [1 / (rb1 ** 2 / J1 + rb2 ** 2 / J2), 1 / (rb3 ** 2 / J3 + rb4 ** 2 / J4)]
        self.c = [2 * p["zeta_m"] * math.sqrt(k * e) for k, e in zip(kmean, me)]
        self.ks = p["G_s"] * math.pi * p["d_s"] ** 4 / (32 * p["L_s"])
        Ja, Jb = J2 + J1 * (rb2 / rb1) ** 2, J3 + J4 * (rb3 / rb4) ** 2
        self.cs = 2 * p["zeta_s"] * math.sqrt(self.ks * Ja * Jb / (Ja + Jb))
        self.b = [p["bh1"], p["bh2"]]
        self.e = [p["e1"], p["e2"]]
        self.phase = [0.0, p["phi2"]]
        self.tm = [2 * math.pi / self.w1, 2 * math.pi / self.w2]
        self.period = 8 * self.tm[0]

    # ----------------------------------------------------------------- model
    def deflections(self, t: float, y: np.ndarray) -> tuple[list[float], list[float]]:
        """``(delta, delta')`` of both meshes."""
        rb1, rb2, rb3, rb4 = self.rb
        th, w = y[:4], y[4:]
        om = [self.w1, self.w2]
        d = [rb1 * th[0] - rb2 * th[1], rb3 * th[2] - rb4 * th[3]]
        dd = [rb1 * w[0] - rb2 * w[1], rb3 * w[2] - rb4 * w[3]]
        for i in range(2):
            d[i] -= self.e[i] * math.cos(om[i] * t + self.phase[i])
            dd[i] += self.e[i] * om[i] * math.sin(om[i] * t + self.phase[i])
        return d, dd

    def rhs(self, t: float, y: np.ndarray, modes: tuple[int, int], segs: tuple[int, int]) -> np.ndarray:
        """Right-hand side in contact modes ``modes`` (+1 drive, 0 free, -1 back) and
        stiffness segments ``segs`` (0 double contact, 1 single)."""
        rb1, rb2, rb3, rb4 = self.rb
        d, dd = self.deflections(t, y)
        W = []
        for i in range(2):
            k = self.kmin[i] * (self.p["r_k"] if segs[i] == 0 else 1.0)
            f = d[i] - self.b[i] if modes[i] > 0 else (d[i] + self.b[i] if modes[i] < 0 else 0.0)
            W.append(k * f + self.c[i] * dd[i])
        Ms = self.ks * (y[1] - y[2]) + self.cs * (y[5] - y[6])
        J1, J2, J3, J4 = self.J
        acc = [(self.T_in - rb1 * W[0]) / J1, (rb2 * W[0] - Ms) / J2, (Ms - rb3 * W[1]) / J3,
               (rb4 * W[1] - self.T_out) / J4]
        return np.concatenate([y[4:], acc])

    def breaks(self, t0: float, t1: float) -> list[float]:
        """Scheduled stiffness jumps in ``(t0, t1)``."""
        out = []
        for tm, d in zip(self.tm, self.duty):
            for n in range(int(math.floor(t0 / tm)) - 1, int(math.ceil(t1 / tm)) + 2):
                for c in (0.0, d):
                    tb = (n + c) * tm
                    if t0 < tb < t1:
                        out.append(tb)
        return sorted(out)

    def segment(self, t: float) -> tuple[int, int]:
        out = []
        for tm, d in zip(self.tm, self.duty):
            u = t / tm
            out.append(0 if (u - math.floor(u)) < d else 1)
        return tuple(out)

    def modes_of(self, t: float, y: np.ndarray) -> tuple[int, int]:
        d, dd = self.deflections(t, y)
        out = []
        for i in range(2):
            b = self.b[i]
            if d[i] > b or (d[i] == b and dd[i] > 0):
                out.append(1)
            elif d[i] < -b or (d[i] == -b and dd[i] < 0):
                out.append(-1)
            else:
                out.append(0)
        return tuple(out)


def reference_solution(model: TwoStageTrain, x0, t0: float, t1: float, t_eval=None, rtol: float = 1e-12,
                       atol: float = 1e-16):
    """Event-located DOP853 solution from ``x0`` at ``t0`` to ``t1``.

    Returns
    -------
    x_end : ndarray
    events : list of (t, surface, direction)
    y_eval : ndarray or None
        States at ``t_eval`` (dense output of the segment holding each time).
    """
    y = np.asarray(x0, float).copy()
    t = float(t0)
    modes = model.modes_of(t, y)
    stops = model.breaks(t0, t1) + [t1]
    events = []
    pieces = []
    max_step = model.tm[1] / 8
    fine_until = -math.inf  # after an event: small steps for a while (a quick re-contact would
    for stop in stops:      # otherwise fit inside one step and be missed)
        segs = model.segment(0.5 * (t + stop))
        while t < stop:
            end = min(stop, fine_until) if t < fine_until else stop
            armed = []
            for i in range(2):
                if modes[i] > 0:
                    armed.append((i, +1, -1))   # drive contact lost: delta - b goes + -> -
                elif modes[i] < 0:
                    armed.append((i, -1, +1))   # back contact lost: delta + b goes - -> +
                else:
                    armed += [(i, +1, +1), (i, -1, -1)]
            fns = []
            for i, side, direction in armed:
                def ev(tt, yy, i=i, side=side):
                    return model.deflections(tt, yy)[0][i] - side * model.b[i]
                ev.terminal = True
                ev.direction = direction
                fns.append(ev)
            sol = solve_ivp(lambda tt, yy, modes=modes, segs=segs: model.rhs(tt, yy, modes, segs), (t, end), y,
                            method="DOP853",
                            rtol=rtol, atol=atol, events=fns, dense_output=True,
                            max_step=max_step if end == stop else max_step / 500)
            if sol.status == -1:
                raise RuntimeError(sol.message)
            pieces.append((t, sol.sol))
            if sol.status == 1:
                hit = [(sol.t_events[k][0], k) for k in range(len(fns)) if len(sol.t_events[k])]
                te, k = min(hit)
                i, side, direction = armed[k]
                y = sol.y_events[k][0].copy()
                t = float(te)
                name = f"mesh{i + 1}.{'drive' if side > 0 else 'back'}"
                events.append((t, name, direction))
                new = list(modes)
                if side > 0:
                    new[i] = 1 if direction > 0 else 0
                else:
                    new[i] = 0 if direction > 0 else -1
                modes = tuple(new)
                fine_until = t + model.tm[0] / 10
            else:
                y = sol.y[:, -1].copy()
                t = end
    y_eval = None
    if t_eval is not None:
        t_eval = np.asarray(t_eval, float)
        starts = np.array([s for s, _ in pieces])
        idx = np.clip(np.searchsorted(starts, t_eval, side="right") - 1, 0, len(pieces) - 1)
        y_eval = np.array([pieces[k][1](tt) for k, tt in zip(idx, t_eval)])
    return y, events, y_eval
