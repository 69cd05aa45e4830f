"""
Writing your own model
======================

A model is a TOML file: coordinates, parameters with units, lumped elements and the
effects their terms belong to.  A scene picks a model, switches effects on, sets
parameter values and says what to compute.  This guide writes a two-inertia torsional
gear pair on shafts, lets sympy derive its equations, compiles it, starts it from its
static equilibrium and integrates it.

``gearsym init NAME`` writes a commented one-degree-of-freedom template to start from;
the :doc:`../spec` chapter describes every section and field.
"""

# %%
# The model
# ---------
# A pinion and a gear (rotations ``th1``, ``th2``) meshing along the line of action
# with a time-varying stiffness and backlash.  The input torque drives the pinion, the
# load torque brakes the gear.  Parameter values are written in the unit they are
# declared in (``um``, ``N*m``) and converted to SI once; the ``[reduction]`` section
# replaces the two rotations (a semi-definite system: the pair can turn as a whole) by
# the dynamic transmission error ``x``, whose equation sympy derives.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import gearsym

MODEL = """
[model]
name = "pair_on_shafts"
description = "Torsional gear pair with backlash and mesh stiffness variation"
time_unit = "s"

[coordinates.th1]
unit = "rad"
velocity = "w1"
[coordinates.th2]
unit = "rad"
velocity = "w2"

[parameters]
J1    = { value = 2.0e-3, unit = "kg*m^2", meaning = "pinion inertia" }
J2    = { value = 4.0e-3, unit = "kg*m^2", meaning = "gear inertia" }
rb1   = { value = 40.0,   unit = "mm",     meaning = "pinion base radius" }
rb2   = { value = 50.0,   unit = "mm",     meaning = "gear base radius" }
k_m   = { value = 3.0e8,  unit = "N/m",    meaning = "mean mesh stiffness" }
k_a   = { value = 6.0e7,  unit = "N/m",    meaning = "mesh stiffness variation" }
c_m   = { value = 1500.0, unit = "N*s/m",  meaning = "mesh damping" }
b_m   = { value = 50.0,   unit = "um",     meaning = "half backlash" }
T1    = { value = 60.0,   unit = "N*m",    meaning = "input torque" }
T2    = { value = 75.0,   unit = "N*m",    meaning = "load torque" }
omega = { value = 1.8e4,  unit = "rad/s",  meaning = "mesh frequency" }

[effects.backlash]
meaning = "dead zone of width 2*b_m (contact loss)"
[effects.mesh_stiffness_variation]
meaning = "k_a*cos(omega*t) on the mesh stiffness"

[forcing]
period = "2*pi/omega"

[elements.pinion]
type = "inertia"
coordinate = "th1"
value = "J1"
[elements.gear]
type = "inertia"
coordinate = "th2"
value = "J2"
[elements.mesh]
type = "mesh"
deflection = "rb1*th1 - rb2*th2"
stiffness = ["k_m", { expr = "k_a*cos(omega*t)", effect = "mesh_stiffness_variation" }]
damping = "c_m"
backlash = { expr = "b_m", effect = "backlash" }
drive_side = "positive"
[elements.input]
type = "force"
coordinate = "th1"
value = "T1"
[elements.load]
type = "force"
coordinate = "th2"
value = "-T2"            # the load torque brakes the gear

[reduction]
coordinate = "x"
velocity = "v"
definition = "rb1*th1 - rb2*th2"
unit = "m"
"""

# %%
# The scene
# ---------
# The scene switches both effects on and starts from the **static equilibrium**
# (``[initial] static = true``): the deflection at which the mean mesh force balances
# the mean load, in drive-side contact.  Initial values may also be expressions of the
# parameters, e.g. ``x = "T1/rb1/k_m + b_m"``.
SCENE = """
[scene]
name = "pair_on_shafts"
model = "../models/pair_on_shafts.toml"

[effects]
backlash = true
mesh_stiffness_variation = true

[initial]
static = true

[simulate]
periods = 100
rtol = 1e-9
atol = 1e-15
"""

folder = Path(tempfile.mkdtemp())
(folder / "models").mkdir()
(folder / "scenes").mkdir()
(folder / "models" / "pair_on_shafts.toml").write_text(MODEL)
(folder / "scenes" / "pair_on_shafts.toml").write_text(SCENE)
scene = gearsym.load_scene(folder / "scenes" / "pair_on_shafts.toml")

# %%
# The derived equations
# ---------------------
# ``scene.model`` is the symbolic model: sympy expressions you can inspect, print as
# LaTeX, or differentiate.  Shown here (and in a notebook) it typesets the equation of
# motion that sympy derived for the reduced coordinate ``x`` and the switching functions
# of the contact surfaces (``model.latex()`` gives the same as text).  The backlash is a
# ``Piecewise`` with two switching surfaces (drive flank ``mesh.drive``, back flank
# ``mesh.back``): the generated code evaluates one smooth branch per contact mode, and
# the integrator changes the mode exactly at a root of the surface.
print([s.name for s in scene.model.switching])
scene.model

# %%
# The dimensionless form
# ----------------------
# gearsym also derives the model's dimensionless form: time in units of the inverse
# natural frequency of the mean mesh stiffness, the deflection in units of the half
# backlash (the contact surfaces are at ``x = 1`` and ``x = -1``), and the groups that
# remain -- here the stiffness variation, the damping, the frequency ratio and the load
# -- each with its definition and its value at the scene's parameters.
scene.model.dimensionless()

# %%
# Compile, and the static start
# -----------------------------
# ``compile()`` generates C, compiles it (cached by content: a second run reuses the
# build) and solves for the static state.  With ``F = T1/rb1`` the static deflection is
# ``F/k_m + b_m``: the mean stiffness carries the load, the varying part averages out.
system = scene.compile()
x_static = 60.0 / 0.040 / 3.0e8 + 50e-6
print(f"x0 = {system.x0[0]:.6e} m, hand computation F/k_m + b_m = {x_static:.6e} m")

# %%
# Simulate
# --------
# One call into C integrates 100 mesh periods.  Parameters are run-time inputs: the
# second run, at a lower mesh frequency, does not recompile.
traj = system.simulate()
slow = system.simulate(params={"omega": 1.2e4}, periods=100)
print(traj.stats["n_steps"], "steps,", traj.stats["n_events"], "contact events")

fig, ax = plt.subplots(figsize=(7, 3))
for tr, label in ((traj, "omega = 1.8e4 rad/s"), (slow, "omega = 1.2e4 rad/s")):
    ax.plot(tr.t / tr.period, tr["x"] * 1e6, lw=0.7, label=label)
ax.axhline(50.0, color="0.6", ls="--", lw=0.6)
ax.set_xlabel("t / T")
ax.set_ylabel("x [um]")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# Effects are compile-time
# ------------------------
# Switching an effect off removes its terms before code generation: the generated C
# has no code for it, and the parameter ``k_a`` is no longer an input.  Without the
# stiffness variation nothing excites the pair: it stays at its static deflection.
rigid = gearsym.load_scene(folder / "scenes" / "pair_on_shafts.toml",
                           effects={"mesh_stiffness_variation": False}).compile()
still = rigid.simulate(periods=20)
print("k_a an input:", "k_a" in rigid.param_names,
      "| largest excursion from x0:", float(np.abs(still["x"] - rigid.x0[0]).max()), "m")
