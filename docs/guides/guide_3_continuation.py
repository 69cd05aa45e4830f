"""
Continuation with bifurcations
==============================

``gearsym.continuation`` follows a periodic orbit while one parameter changes
(pseudo-arclength continuation of the shooting residual), reports the stability of every
point, and locates the special points between them: folds (where the response jumps),
grazings (where a contact starts or ends), period doublings, Neimark-Sacker points.  At
a period doubling it can switch onto the doubled orbit.
"""

# %%
# A frequency response with jumps
# -------------------------------
# The benchmark oscillator continued in the mesh frequency ``Omega``: near resonance the
# single-sided impacts bend the response over, so the branch folds twice and three
# orbits coexist between the folds (the middle one unstable).
import matplotlib.pyplot as plt
import numpy as np

import gearsym

system = gearsym.load_scene("kahraman_singh").compile()
branch = gearsym.continuation(system, "Omega", 0.6, 1.4, progress=False)
print(len(branch.points), "points, complete:", branch.complete, "|", branch.stop_reason)
for b in branch.bifurcations:
    print(f"{b.type:12s} Omega = {b.value:.6f}")

# %%
# A brute-force sweep (at each frequency 200 periods of transient from the last state,
# then the largest x over 10 periods; up and then down) lands on the stable parts of the
# branch only, and jumps at the folds: sweeping up follows the lower branch to the right
# fold and jumps up; sweeping down follows the upper branch to the left fold and jumps down.
sweep = np.linspace(0.75, 1.0, 26)


def steady_max(x, om):
    x = system.simulate(periods=200, x0=x, params={"Omega": om}, n_out=2).final_state
    tr = system.simulate(periods=10, x0=x, params={"Omega": om}, n_out=4001)
    return tr.final_state, tr["x"].max()


x = system.x0
up, down = [], []
for om in sweep:
    x, peak = steady_max(x, om)
    up.append(peak)
for om in sweep[::-1]:
    x, peak = steady_max(x, om)
    down.append(peak)

fig = branch.plot_figure(title="kahraman_singh: continuation in Omega")
ax = fig.axes[0]
ax.plot(sweep, up, "^", color="C2", ms=4, label="sweep up")
ax.plot(sweep[::-1], down, "v", color="C4", ms=4, label="sweep down")
ax.legend(fontsize=7, loc="upper left")

# %%
# A period-doubling cascade, with branch switching
# ------------------------------------------------
# With ``Fa = 0.4`` the period-1 orbit loses stability through a period doubling;
# ``switch=2`` continues the period-2 orbit born there, and the period-4 orbit born on
# that.  ``branch.all_branches()`` returns the tree.
pd = gearsym.continuation(system, "Omega", 0.58, 0.70, params={"Fa": 0.4}, switch=2, progress=False)
for br in pd.all_branches():
    events = ", ".join(f"{b.type} at {b.value:.5f}" for b in br.bifurcations)
    print(f"period-{br.periods:g} branch: {len(br.points)} points; {events}")
first = [b.value for b in pd.all_branches()[0].of_type("period_doubling")]
second = [b.value for b in pd.all_branches()[1].of_type("period_doubling")]
print("first doublings at Omega =", first, "and", second)

fig, ax = plt.subplots(figsize=(7, 4.2))
pd.plot(ax, quantity="max")
ax.set_title("Fa = 0.4: period 1 -> 2 -> 4")
fig.tight_layout()

# %%
# Every point carries its orbit: ``branch.points[i].x0``, ``.multipliers``, ``.stable``,
# ``.rattle_state``; ``branch.to_dict()`` (or ``gearsym continue --json``) gives all of
# it as JSON.
pt = branch.points[len(branch.points) // 2]
print(f"Omega = {pt.value:.4f}: x0 = {pt.x0}, |mu| = {np.abs(pt.multipliers)}, stable = {pt.stable}")
