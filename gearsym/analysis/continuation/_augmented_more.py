"""Minimally augmented systems of Neimark-Sacker and grazing curves (see :mod:`._augmented`).

**Neimark-Sacker**: a pair ``exp(+-i omega)`` on the unit circle.  The extra unknown is
``omega`` (in ``(0, pi)``), the test function the complex ``g`` of the bordered system of
``A = M - exp(i omega) I`` with complex borders (BifurcationKit's ``MinAugNS``), two real
equations ``Re g = Im g = 0``; ``kappa = cos omega`` is reported.  ``dg/domega = i exp(i omega)
w^H v`` is exact; the derivatives in the state and the parameters are central differences of
the monodromy (the directional trick of :mod:`._augmented` with the complex ``v = v_r + i v_i``:
four integrations, and four for the parameters).  The curve ends at a 1:1 resonance
(``omega`` through 0: the pair meets at +1) or a 1:2 resonance (``omega`` through ``pi``: at -1),
where the pair leaves the circle as a real pair and the formulation retraces the curve.

**Grazing**: the orbit touches a switching surface ``g_j = 0`` tangentially.  The extra unknown
is the phase ``theta`` of the touching time ``t* = t0 + theta P``; the equations are
``g_j(t*, x(t*)) = 0`` and ``dg_j/dt (t*, x(t*)) = 0`` (the extremum of ``g_j`` over the orbit is
zero), with ``x(t*)`` from integrating the first part of the period.  The period is integrated
in two parts (``t0 .. t*``, ``t* .. t0 + P``; the residual does not depend on ``theta``), the
first part with its monodromy ``Phi_1`` and parameter sensitivity ``S_1``, so the rows of the
two equations are exact chains through them: ``d h / d x0 = grad h . Phi_1``, ``d h / d lambda =
grad h . S_1 + dh/dt theta dP/dlambda + partial h / partial lambda``, ``d h / d theta = P dh/dt``.
Only the point functions ``g_j`` and ``dg_j/dt = grad g_j . f + partial_t g_j`` are
differenced (central differences of the generated C functions at one point: no integration).
"""

from __future__ import annotations

import cmath
import math
from typing import Any

import numpy as np

from ...errors import ConvergenceError, ParameterError
from ._augmented import SECTION_MARGIN, AugEval, Augmented, _carry, bordered, null_vectors
from ._bifurcation import tau_branch_point, tau_neimark_sacker, tau_period_doubling
from ._orbit_map import MapRun, OrbitMap

__all__ = ["GrazingSystem", "NeimarkSackerSystem"]


class NeimarkSackerSystem(Augmented):
    """Neimark-Sacker: unknowns ``(x0, lambda_1, lambda_2, omega)``."""

    kind = "neimark_sacker"
    extras = ("omega",)

    def __init__(self, omap: OrbitMap, fd: float):
        super().__init__(omap, fd)
        self.b = np.zeros(self.nx, complex)
        self.c = np.zeros(self.nx, complex)

    def _A(self, M: np.ndarray, omega: float) -> np.ndarray:
        return M - cmath.exp(1j * omega) * np.eye(self.nx)

    def start(self, y: np.ndarray) -> np.ndarray:
        x, lam, ext = self.split(y)
        M = self.omap.monodromy(x, lam)
        if len(ext):
            omega = float(ext[0])
        else:
            mu = np.linalg.eigvals(M)
            pair = mu[mu.imag > 1e-9 * np.maximum(1.0, np.abs(mu))]
            if not len(pair):
                raise ConvergenceError("no complex pair of multipliers at the start of a Neimark-Sacker curve "
                                       f"(multipliers {np.round(mu, 6).tolist()})")
            m = pair[np.argmin(np.abs(np.abs(pair) - 1.0))]
            omega = float(abs(np.angle(m)))
        right, left = null_vectors(self._A(M, omega))
        self.c, self.b = right[:, 0], left[:, 0]
        return np.concatenate([x, lam, [omega]])

    def _test(self, M, x, lam, ext, data) -> np.ndarray:
        V, G, w = bordered(self._A(M, float(ext[0])), self.b, self.c)
        data["v"], data["w"] = V[:, 0], w
        g = complex(G[0, 0])
        return np.array([g.real, g.imag])

    def _test_rows(self, M, x, lam, ext, data) -> np.ndarray:
        v, w = data["v"], data["w"]
        mono = self.omap.monodromy
        rows = np.zeros((2, self.n), complex)
        zero = np.zeros(2)
        Mtw = [self._dir_deriv(lambda xx, ll: mono(xx, ll).T @ w.conj(), x, lam, d, zero) for d in (v.real, v.imag)]
        rows[0, :self.nx] = -(Mtw[0] + 1j * Mtw[1])
        for k in range(2):
            e = np.zeros(2)
            e[k] = 1.0
            dM = self._dir_deriv(lambda xx, ll: mono(xx, ll), x, lam, np.zeros(self.nx), e)
            rows[0, self.nx + k] = -(w.conj() @ dM @ v)
        rows[0, -1] = 1j * cmath.exp(1j * float(ext[0])) * (w.conj() @ v)
        out = np.vstack([rows[0].real, rows[0].imag])
        return out

    def accept(self, y, ev) -> None:
        v, w = ev.data["v"], ev.data["w"]
        self.c = v / np.linalg.norm(v)
        self.b = w / np.linalg.norm(w)

    def transform(self, Phi: np.ndarray) -> None:
        self.c, self.b = _carry(Phi.astype(complex), self.c, self.b)

    def tests(self, y, ev, multipliers) -> dict[str, float]:
        omega = float(self.split(y)[2][0])
        others = _without_pair(multipliers, omega)
        return {"resonance_1_1": omega, "resonance_1_2": math.pi - omega,
                "fold_neimark_sacker": tau_branch_point(others),
                "flip_neimark_sacker": tau_period_doubling(others)}

    def describe(self, y, ev) -> dict[str, float]:
        omega = float(self.split(y)[2][0])
        return {"omega": omega, "kappa": math.cos(omega)}


def _without_pair(mu: np.ndarray, omega: float) -> np.ndarray:
    """The multipliers without the two nearest ``exp(+-i omega)``."""
    mu = np.asarray(mu, complex)
    for target in (cmath.exp(1j * omega), cmath.exp(-1j * omega)):
        if len(mu):
            mu = np.delete(mu, int(np.argmin(np.abs(mu - target))))
    return mu


class GrazingSystem(Augmented):
    """Grazing of one switching surface: unknowns ``(x0, lambda_1, lambda_2, theta)``.

    Parameters
    ----------
    omap, fd
        As :class:`Augmented`.
    surface
        The switching surface's name.
    side
        ``"min"``: the orbit touches ``g = 0`` from ``g > 0`` (its minimum is zero);
        ``"max"``: from ``g < 0``.
    """

    kind = "grazing"
    extras = ("theta",)

    def __init__(self, omap: OrbitMap, fd: float, surface: str, side: str):
        super().__init__(omap, fd)
        names = list(omap.system.surface_names)
        if surface not in names:
            raise ParameterError(f"surface '{surface}' is not a switching surface of this system (have: "
                                 f"{', '.join(names) or 'none'})")
        if side not in ("min", "max"):
            raise ParameterError(f"side must be 'min' or 'max' (the extremum of the switching function that "
                                 f"touches zero), got '{side}'")
        self.surface, self.side, self.j = surface, side, names.index(surface)
        self.g_scale = 1.0
        self.rate_scale = 1.0

    def residual_scales(self) -> np.ndarray:
        return np.concatenate([self.x_scale, [self.g_scale, self.rate_scale]])

    def start(self, y: np.ndarray) -> np.ndarray:
        x, lam, ext = self.split(y)
        n = 2048
        run = self.omap.run(x, lam, monodromy=False, sens=False, n_samples=n + 1)
        P = self.omap.period(lam)
        t = self.omap.t0 + P * np.arange(n + 1) / n
        p = self.omap.setup(lam)[0]
        G = self.omap.system.switching(t, run.samples, p=p)[:, self.j]
        i = int(np.argmin(G[:-1]) if self.side == "min" else np.argmax(G[:-1]))
        self.g_scale = max(float(np.ptp(G)), float(np.max(np.abs(G))) * 1e-3, 1e-300)
        self.rate_scale = self.g_scale * 2 * math.pi * self.omap.periods / P
        theta = float(ext[0]) if len(ext) else i / n
        return np.concatenate([x, lam, [theta]])

    def evaluate(self, y: np.ndarray, test_jac: bool) -> AugEval:
        x, lam, ext = self.split(y)
        theta = float(ext[0]) % 1.0
        first = self._part(x, lam, (0.0, theta), None)
        second = self._part(first.x_end, lam, (theta, 1.0), first.sigma_end)
        M = second.M @ first.M
        S = second.M @ first.S + second.S
        J = np.zeros((self.nx, self.n))
        J[:, :self.nx] = M - np.eye(self.nx)
        J[:, self.nx:self.nx + 2] = S
        P, dP = self.omap.period(lam), self.omap.setup(lam)[2]
        t_star = self.omap.t0 + theta * P
        h, grads = self._point(t_star, first.x_end, lam, first.sigma_end, want=test_jac)
        R = np.concatenate([second.x_end - x, h])
        data: dict[str, Any] = {"x_end": second.x_end, "n_events": first.n_events + second.n_events,
                                "t_star": t_star, "x_star": first.x_end, "t0": self.omap.t0,
                                "event_t": np.concatenate([first.event_t, second.event_t]),
                                "event_surface": np.concatenate([first.event_surface, second.event_surface])}
        Jt = None
        if test_jac:
            gx, gt, glam, f = grads
            Jt = np.zeros((2, self.n))
            Jt[:, :self.nx] = gx @ first.M
            Jt[:, self.nx:self.nx + 2] = gx @ first.S + np.outer(gt, theta * dP) + glam
            Jt[:, -1] = (gx @ f + gt) * P  # along the orbit: d/dt* h(t*, x(t*))
        return AugEval(R, J, Jt, M, data)

    def _part(self, x: np.ndarray, lam: np.ndarray, theta: tuple[float, float], sigma0: np.ndarray | None
              ) -> MapRun:
        """One part of the period (the identity where it is empty: a touch at ``t0``)."""
        if theta[1] - theta[0] > 1e-12:
            return self.omap.run(x, lam, theta=theta, sigma0=sigma0)
        t = self.omap.t0 + theta[0] * self.omap.period(lam)
        g = self.omap.system.switching(t, x, p=self.omap.setup(lam)[0])
        sigma = np.where(np.asarray(g) >= 0, 1.0, -1.0) if sigma0 is None else sigma0
        return MapRun(np.asarray(x, float), np.eye(self.nx), np.zeros((self.nx, 2)), 0, sigma)

    # ------------------------------------------------------------ point functions
    def _gq(self, t: np.ndarray, X: np.ndarray, p: np.ndarray, sigma: np.ndarray, dt: float) -> np.ndarray:
        """``(g_j, dg_j/dt)`` at many points (rows), by central differences of the switching functions
        (``dg/dt = grad g . f + partial_t g``, ``f`` in the mode ``sigma``; ``dt`` the time step)."""
        engine, j = self.omap.system.engine, self.j
        n, nx = X.shape
        dx = 1e-6 * self.x_scale
        T = np.concatenate([t, np.repeat(t, 2 * nx), t + dt, t - dt])
        shifts = np.concatenate([np.diag(dx), -np.diag(dx)])  # (2 nx, nx)
        XX = np.vstack([X, (X[:, None, :] + shifts[None, :, :]).reshape(-1, nx), X, X])
        G = engine.evaluate("sw", T, XX, p)[:, j]
        g = G[:n]
        Gs = G[n:n + 2 * nx * n].reshape(n, 2 * nx)
        grad = (Gs[:, :nx] - Gs[:, nx:]) / (2 * dx)
        gt = (G[n + 2 * nx * n:n + 2 * nx * n + n] - G[n + 2 * nx * n + n:]) / (2 * dt)
        f = engine.evaluate("rhs", t, X, p, np.repeat(sigma[None, :], n, axis=0))
        return np.stack([g, np.sum(grad * f, axis=1) + gt], axis=1)

    def _point(self, t: float, x: np.ndarray, lam: np.ndarray, sigma: np.ndarray, want: bool):
        """``(h, grads)``: ``h = (g_j, dg_j/dt)`` at ``(t, x)`` and, with ``want``, their gradients in
        the state, the time and the parameters (central differences of the point functions) and the
        vector field there."""
        sig = np.asarray(sigma, float).copy()
        sig[self.j] = 1.0 if self.side == "min" else -1.0
        p = self.omap.setup(lam)[0]
        T1 = self.omap.period(lam) / self.omap.periods
        dt = 1e-6 * T1
        if not want:
            return self._gq(np.array([t]), x[None, :], p, sig, dt)[0], None
        nx = self.nx
        ex = 1e-4 * self.x_scale
        et = 1e-4 * T1
        X = np.vstack([x, x + np.diag(ex), x - np.diag(ex), x, x])
        t_all = np.concatenate([[t], np.full(2 * nx, t), [t + et, t - et]])
        H = self._gq(t_all, X, p, sig, dt)
        h = H[0]
        gx = ((H[1:1 + nx] - H[1 + nx:1 + 2 * nx]) / (2 * ex[:, None])).T
        gt = (H[-2] - H[-1]) / (2 * et)
        glam = np.zeros((2, 2))
        for k in range(2):
            e = 1e-4 * float(self.lam_scale[k])
            q = []
            for s in (1.0, -1.0):
                lk = np.array(lam, float)
                lk[k] += s * e
                q.append(self._gq(np.array([t]), x[None, :], self.omap.setup(lk)[0], sig, dt)[0])
            glam[:, k] = (q[0] - q[1]) / (2 * e)
        f = self.omap.system.engine.evaluate("rhs", [t], x[None, :], p, sig[None, :])[0]
        return h, (gx, gt, glam, f)

    def tests(self, y, ev, multipliers) -> dict[str, float]:
        return {"fold_grazing": tau_branch_point(multipliers), "period_doubling_grazing": tau_period_doubling(
            multipliers), "neimark_sacker_grazing": tau_neimark_sacker(multipliers)}

    def describe(self, y, ev) -> dict[str, float]:
        theta = float(self.split(y)[2][0]) % 1.0
        return {"theta": theta, "t_touch": float(ev.data["t_star"])}

    def shift_extras(self, ext: np.ndarray, dtheta: float) -> np.ndarray:
        return np.array([(float(ext[0]) - dtheta) % 1.0])

    def reanchor(self, y: np.ndarray, ev: AugEval, margin: float = SECTION_MARGIN) -> np.ndarray | None:
        """As :meth:`Augmented.reanchor`, the touch counted as an event too (the period is split there)."""
        data = dict(ev.data)
        data["event_t"] = np.concatenate([np.asarray(data.get("event_t", []), float), [float(data["t_star"])]])
        return super().reanchor(y, AugEval(ev.R, ev.J_orbit, ev.J_test, ev.M, data), margin)
