"""
Periodic orbits and their stability
===================================

A forced gear pair settles on a periodic orbit (or does not: then it rattles
chaotically).  ``System.periodic_orbit`` finds the orbit by shooting (Newton on
``phi(T, x0) - x0`` with the exact monodromy from the variational equations and the
saltation matrices at every contact event) or by harmonic balance, and returns its
Floquet multipliers: the orbit is stable when all lie inside the unit circle.
"""

# %%
# The benchmark oscillator's orbit
# --------------------------------
# The shipped scene ``kahraman_singh`` (Kahraman & Singh 1990) at ``Omega = 0.9`` has
# single-sided impacts: the teeth separate once per period (rattle state 1).
import matplotlib.pyplot as plt
import numpy as np

import gearsym

system = gearsym.load_scene("kahraman_singh").compile()
orbit = system.periodic_orbit()
print("x0 =", orbit.x0, "| period =", orbit.period)
print("multipliers:", orbit.multipliers, "| stable:", orbit.stable, "| rattle state:", orbit.rattle_state)

# %%
# Two independent checks: harmonic balance (a different discretisation, its multipliers
# from the monodromy of its orbit) finds the same orbit, and one period integrated from
# ``x0`` comes back to ``x0``.
hbm = system.periodic_orbit(method="hbm")
back = system.simulate(periods=1, x0=orbit.x0, rtol=1e-12, atol=1e-14).final_state
print("HBM x0 - shooting x0:", hbm.x0 - orbit.x0)
print("HBM multipliers:", hbm.multipliers)
print("phi(T, x0) - x0:", back - orbit.x0)

# %%
# A long simulation from the scene's initial state converges onto the orbit; its
# Poincare points (one per forcing period) approach the orbit's ``x0``.
traj = system.simulate(periods=150)
one = orbit.trajectory()
pts = traj.poincare()
fig, ax = plt.subplots(figsize=(5.5, 4.2))
ax.plot(traj["x"], traj["v"], lw=0.3, color="0.7", label="simulation from x = 1.1")
ax.plot(one["x"], one["v"], lw=1.5, color="C0", label="periodic orbit")
ax.plot(pts[:, 0], pts[:, 1], ".", ms=3, color="C3", label="Poincare points")
ax.axvline(1.0, color="k", ls="--", lw=0.6)
ax.set_xlabel("x")
ax.set_ylabel("v")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# Losing stability: a period doubling
# -----------------------------------
# With a strong transmission-error excitation (``Fa = 0.4``) at ``Omega = 0.64`` the
# period-1 orbit still exists, but one multiplier has left the unit circle through
# -1: a flip.  The orbit of twice the period (``periods=2``) is stable, and a
# simulation started on the unstable orbit drifts onto it: its Poincare points
# alternate between two values.
p = {"Fa": 0.4, "Omega": 0.64}
p1 = system.periodic_orbit(params=p)
p2 = system.periodic_orbit(params=p, periods=2)
print("period 1:", p1.multipliers, "stable:", p1.stable)
print("period 2:", p2.multipliers, "stable:", p2.stable)
drift = system.simulate(periods=300, x0=p1.x0, params=p)
print("last Poincare points of x:", np.round(drift.poincare()[-4:, 0], 6))
half = system.simulate(periods=1, x0=p2.x0, params=p, rtol=1e-12, atol=1e-14).final_state
print("period-2 orbit, x at t = 0 and T:", np.round([p2.x0[0], half[0]], 6))

fig, ax = plt.subplots(figsize=(4.6, 4.2))
circle = np.exp(1j * np.linspace(0, 2 * np.pi, 200))
ax.plot(circle.real, circle.imag, color="0.5", lw=0.8)
for orb, label, mk in ((orbit, "Omega = 0.9", "o"), (p1, "period 1, Fa = 0.4", "x"), (p2, "period 2, Fa = 0.4", "s")):
    ax.plot(orb.multipliers.real, orb.multipliers.imag, mk, ms=7, mfc="none", label=label)
ax.set_aspect("equal")
ax.set_xlabel("Re mu")
ax.set_ylabel("Im mu")
ax.set_title("Floquet multipliers")
ax.legend(fontsize=8)
fig.tight_layout()
