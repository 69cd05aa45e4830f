"""
Your LTCA table in gearsym
==========================

Loaded tooth contact analysis (LTCA), a finite-element model or a test rig gives the mesh
stiffness as *data*: a table over the mesh cycle, often at several loads.  gearsym reads such a
table as it is -- a CSV file beside the model, with its unit and its domain -- and writes it
into the equations exactly: the integrator stops at every knot of the table (its kinks are
scheduled breakpoints), and the generated C evaluates the same interpolant as
:func:`numpy.interp` or :class:`scipy.interpolate.CubicSpline`.

This guide takes a table over (mesh phase, torque), writes a model around it, checks what
gearsym makes of it, simulates the pair and finds its periodic orbit at two torques without
recompiling.  The :doc:`../spec` chapter (*Tables*) lists every key.
"""

# %%
# The table
# ---------
# An LTCA program writes the stiffness over one mesh cycle at a few torques.  The layout gearsym
# reads: a header row whose cells after the first are the torques, then one row per phase
# sample.  The shipped ``models/ltca_pair_k.csv`` has this layout (64 phases x 5 torques; it is
# LTCA-*like*: ``examples/make_ltca_table.py`` makes it from the potential-energy stiffness of
# a 26/39-tooth pair with tip relief and a quasi-static load sharing).  Here it plays the part of
# your LTCA output: we copy it into a working folder.
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import gearsym

shipped = Path(gearsym.__file__).resolve().parent.parent / "models" / "ltca_pair_k.csv"
if not shipped.is_file():  # an installed gearsym carries the shipped models as package data
    shipped = Path(gearsym.__file__).resolve().parent / "data" / "models" / "ltca_pair_k.csv"
work = Path(tempfile.mkdtemp(prefix="gearsym-ltca-"))
shutil.copyfile(shipped, work / "k_ltca.csv")
print((work / "k_ltca.csv").read_text().splitlines()[:3])

# %%
# The model
# ---------
# The table is a ``[tables.NAME]`` section: the unit of the values, the domain of each axis
# (``"phase"``: the phase of a schedule, in cycles; ``"N*m"``: a torque), the file, the
# interpolation.  ``arguments`` says what the bare name ``k_ltca`` means in an element field:
# the stiffness at the mesh phase of the schedule ``mesh`` and at the torque ``T1``, a
# parameter -- so the torque can change at run time.
MODEL = """
[model]
name = "my_ltca_pair"
[coordinates.th1]
unit = "rad"
velocity = "w1"
[coordinates.th2]
unit = "rad"
velocity = "w2"
[parameters]
J1   = { value = 2.70e-3,  unit = "kg*m^2" }
J2   = { value = 1.367e-2, unit = "kg*m^2" }
rb1  = { value = 48.864,   unit = "mm" }
rb2  = { value = 73.296,   unit = "mm" }
T1   = { value = 200.0,    unit = "N*m", min = 50, max = 700 }
c_m  = { value = 1900.0,   unit = "N*s/m" }
b_m  = { value = 40.0,     unit = "um" }
n1   = { value = 8000.0,   unit = "rpm" }
[derived]
t_m = { value = "2*pi/(26*n1)", unit = "s" }
[schedules.mesh]
period = "t_m"
[forcing]
period = "t_m"

[tables.k_ltca]
unit = "N/m"
domain = ["phase", "N*m"]
file = "k_ltca.csv"
interpolation = "linear"
arguments = ["mesh_phase", "T1"]

[elements.pinion]
type = "inertia"
coordinate = "th1"
value = "J1"
[elements.wheel]
type = "inertia"
coordinate = "th2"
value = "J2"
[elements.mesh]
type = "mesh"
deflection = "rb1*th1 - rb2*th2"
stiffness = "k_ltca"
damping = "c_m"
backlash = "b_m"
[elements.input]
type = "force"
coordinate = "th1"
value = "T1"
[elements.load]
type = "force"
coordinate = "th2"
value = "-T1*rb2/rb1"
[reduction]
coordinate = "x"
velocity = "v"
definition = "rb1*th1 - rb2*th2"
unit = "m"
[initial]
static = true
"""
(work / "my_ltca_pair.toml").write_text(MODEL)
(work / "scene.toml").write_text('[scene]\nmodel = "my_ltca_pair.toml"\n')
scene = gearsym.load_scene(work / "scene.toml")

# %%
# What gearsym made of it
# -----------------------
# The table object evaluates the interpolant in Python (SI units; the phase in cycles): the
# reference of what the generated C computes.  Between the knots it is ``numpy.interp`` along
# the phase (periodic) and across the torques.
table = scene.model_spec.tables["k_ltca"]
print(table.to_dict(data=False))
phase = np.linspace(0.0, 1.0, 1001)
raw = np.loadtxt(work / "k_ltca.csv", delimiter=",", skiprows=1)
torques = np.array(table.axes[1].knots)
column = [np.interp(phase, raw[:, 0], raw[:, 1 + j], period=1.0) for j in range(len(torques))]
by_hand = np.array([np.interp(300.0, torques, [c[i] for c in column]) for i in range(len(phase))])
print("table(phase, 300 N m) - numpy.interp, largest:", np.max(np.abs(table(phase, 300.0) - by_hand)), "N/m")

fig, ax = plt.subplots(figsize=(6.5, 3.6))
for T in torques:
    ax.plot(phase, table(phase, T) / 1e8, lw=1, label=f"{T:g} N m")
ax.set_xlabel("mesh phase (cycles)")
ax.set_ylabel("k (1e8 N/m)")
ax.legend(fontsize=8, title="torque")
fig.tight_layout()

# %%
# In the equations the table is its call, ``k_ltca(mesh_phase, T1)``; its 64 knots are the
# breaks of a hidden schedule ``k_ltca@mesh`` with the mesh period, at which the integrator
# stops.
model = scene.model
print(model.equations()[0])
print([(s.name, len(s.breaks)) for s in model.schedules])

# %%
# Simulate, and the periodic orbit at two torques
# -----------------------------------------------
# The torque is a run-time parameter: the table is interpolated across its torques in the
# generated C, so ``T1 = 500`` needs no new compile.
system = scene.compile()
traj = system.simulate(periods=100)
print("steps:", traj.stats["n_steps"], "| scheduled breaks:", traj.stats["n_breaks"],
      "| contact events:", traj.stats["n_events"])
fig, ax = plt.subplots(figsize=(6.5, 3.6))
for T in (200.0, 500.0):
    tr = system.simulate(periods=100, params={"T1": T})
    orbit = system.periodic_orbit(x0=tr.final_state, params={"T1": T})
    one = orbit.trajectory()
    print(f"T1 = {T:g} N m: orbit {orbit.stability}, multipliers", np.round(orbit.multipliers, 4),
          "| rattle state", orbit.rattle_state, "| peak-to-peak", f"{np.ptp(one['x']) * 1e6:.2f} um")
    ax.plot(one.t / system.period(), one["x"] * 1e6, label=f"T1 = {T:g} N m")
ax.axhline(40.0, color="k", ls=":", lw=0.8)
ax.set_xlabel("t / mesh period")
ax.set_ylabel("DTE x (um)")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# A bad table is refused with its file, row and column
# -----------------------------------------------------
# Tables are read strictly: a ragged row, a cell that is not a number, a domain that does not
# increase, a path outside the model's folder or a file larger than 4 MB is bad input (exit 2
# on the command line), before anything is compiled.
text = (work / "k_ltca.csv").read_text().splitlines()
cells = text[5].split(",")
cells[2] = "abc"                                   # row 6, column 3: not a number
text[5] = ",".join(cells)
(work / "k_ltca.csv").write_text("\n".join(text) + "\n")
try:
    gearsym.load_scene(work / "scene.toml")
except gearsym.SpecError as exc:
    print(exc)
shutil.rmtree(work)
