"""Switching surfaces are named after the spec, and a model compiles to the same thing for every
hash seed (gearsym issue 24, item 9).

Before: the surfaces of a ``Piecewise`` were ``surface0``, ``surface1``, ... in an order that
changed with ``PYTHONHASHSEED`` (the relations of an ``and`` condition were taken from a set),
so ``inspect`` and a later run could disagree about which surface is which, the generated C
changed from run to run, and a user could not name a surface.  Now a surface is
``OWNER.CONDITION`` (the condition as written), or ``OWNER.NAME`` with the ``surface`` key of
its term.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gearsym
from gearsym.errors import SpecError

ROOT = Path(__file__).resolve().parents[1]
#: the folder of the gearsym being tested (the subprocesses import the same one)
PACKAGE_ROOT = Path(gearsym.__file__).resolve().parents[1]

#: two coordinates, several state-dependent conditions (and/or, Min of 3, Max of 4, abs, sign),
#: a Piecewise in a derived quantity and a term that names its surfaces
MODEL = """
[model]
name = "pw"
time_unit = "1"

[coordinates.x]
unit = "1"
velocity = "v"

[coordinates.y]
unit = "1"
velocity = "w"

[parameters]
k = { value = 1.0 }
c = { value = 0.1 }
m = { value = 1.0 }
a = { value = 0.5 }
F = { value = 0.2 }
Om = { value = 1.0 }

[forcing]
period = "2*pi/Om"

[derived]
stop = "Piecewise((k*(x - 3*a), x > 3*a), (0, True))"

[elements.mx]
type = "inertia"
coordinate = "x"
value = "m"

[elements.my]
type = "inertia"
coordinate = "y"
value = "m"

[elements.sx]
type = "spring"
deflection = "x"
stiffness = "k"

[elements.sy]
type = "spring"
deflection = "y - x"
stiffness = "k"

[elements.fx]
type = "force"
coordinate = "x"
value = [
  "F*cos(Om*t) - stop",
  "-k*Piecewise((x - a, (x > a) and (y < a)), (x + a, (x < -a) or (y > 2*a)), (0, True))",
  "-c*Max(0, y - 2*a, x - a, w)",
  "-c*Min(v, w, x)",
  "-k*abs(x - y)",
  { expr = "-c*Piecewise((v, (y > 4*a) and (v > 0)), (0, True))", surface = ["far", "moving"] },
]

[elements.fy]
type = "force"
coordinate = "y"
value = "-c*sign(w + a)*F"

[initial]
x = 0.1
v = 0.0
y = 0.0
w = 0.0
"""

#: the names, in the order of the generated C (the order the equations meet the conditions)
NAMES = ["stop.x>3*a", "fx.moving", "fx.far", "fx.v=w", "fx.v=x", "fx.w=x", "fx.0=w", "fx.x>a", "fx.y>2*a",
         "fx.y-2*a=w", "fx.x-a=w", "fx.y-2*a=x-a", "fx.x-y=0", "fx.y<a", "fx.x<-a", "fy.w+a=0"]

#: the same model without the ``surface`` key (it runs on a gearsym that does not know the key)
PLAIN = MODEL.replace('{ expr = "-c*Piecewise((v, (y > 4*a) and (v > 0)), (0, True))", surface = ["far", "moving"] }',
                      '"-c*Piecewise((v, (y > 4*a) and (v > 0)), (0, True))"')
PLAIN_NAMES = [{"fx.moving": "fx.v>0", "fx.far": "fx.y>4*a"}.get(n, n) for n in NAMES]


def _write(tmp_path: Path, model: str = MODEL) -> Path:
    (tmp_path / "pw.toml").write_text(model)
    scene = tmp_path / "s.toml"
    scene.write_text('[scene]\nname = "pw"\nmodel = "pw.toml"\n')
    return scene


def test_surfaces_are_named_after_the_spec(tmp_path):
    m = gearsym.load_scene(_write(tmp_path)).model
    assert [s.name for s in m.switching] == NAMES
    by = {s.name: s for s in m.switching}
    x, y, v, w, a = sp.symbols("x y v w a", real=True)
    # oriented as written: g > 0 where the condition holds (the first argument is the larger)
    assert by["fx.x>a"].expr == x - a and by["fx.y<a"].expr == a - y
    assert by["stop.x>3*a"].expr == x - 3 * a and by["fy.w+a=0"].expr == w + a
    assert by["fx.y-2*a=x-a"].expr == (y - 2 * a) - (x - a)
    assert by["fx.x>a"].origin == "elements.fx.value[1]" and by["stop.x>3*a"].origin == "derived.stop.value"
    # the surface key names the term's surfaces in the order they are written
    assert (by["fx.far"].expr, by["fx.moving"].expr) == (y - 4 * a, v)
    assert by["fx.far"].given and not by["fx.x>a"].given
    assert [mo.name for mo in m.modes][:2] == ["stop.x>3*a: g > 0", "stop.x>3*a: g < 0"]


def test_a_condition_on_a_contact_surface_keeps_the_contact_name():
    """The contact-damping term of the KS model switches on the mesh's own contact surfaces."""
    m = gearsym.load_scene(ROOT / "scenes" / "kahraman_singh.toml", effects={"contact_damping": True}).model
    assert sorted(s.name for s in m.switching) == ["mesh.back", "mesh.drive"]


@pytest.mark.parametrize("surface,message", [
    ('["far"]', "1 surface name for 2 switching surfaces of the states ('y>4*a', 'v>0')"),
    ('"far"', "1 surface name for 2 switching surfaces"),
    ('["far", "far"]', "a surface name is given twice"),
    ('["far", "2x"]', "not a valid symbol name"),
])
def test_bad_surface_names(tmp_path, surface, message):
    bad = MODEL.replace('surface = ["far", "moving"]', f"surface = {surface}")
    with pytest.raises(SpecError, match=re.escape(message)) as info:
        _ = gearsym.load_scene(_write(tmp_path, bad)).model
    assert info.value.field.startswith("elements.fx.value[5].surface")


_PROBE = """
import hashlib, io, json, sys
from contextlib import redirect_stdout
from gearsym import cli, load_scene
from gearsym.codegen.generate import build_functions, model_c_sources
path = sys.argv[1]
out = io.StringIO()
with redirect_stdout(out):
    assert cli.main(["inspect", path, "--json"]) == 0
info = {k: v for k, v in json.loads(out.getvalue()).items() if not k.endswith("_seconds")}
model = load_scene(path).model
digests = {"inspect": hashlib.sha256(json.dumps(info, sort_keys=True).encode()).hexdigest()}
for form, m in (("plain", model), ("dimensionless", model.dimensionless_system())):
    c_text, h_text = model_c_sources(m, build_functions(m, derivatives=True), "pw", "0" * 64)
    digests[form] = hashlib.sha256((c_text + h_text).encode()).hexdigest()
print(json.dumps({"digests": digests, "names": [s["name"] for s in info["switching_functions"]],
                  "modes": [mo["name"] for mo in info["modes"]]}))
"""


def test_same_names_inspect_and_c_for_every_hash_seed(tmp_path):
    """``inspect --json`` and the generated C (with the sensitivity functions, and of the
    dimensionless form) are byte for byte the same for three hash seeds."""
    assert PLAIN != MODEL
    scene = _write(tmp_path, PLAIN)
    procs = [subprocess.Popen([sys.executable, "-c", _PROBE, str(scene)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                              env=dict(os.environ, PYTHONHASHSEED=str(seed), PYTHONPATH=str(PACKAGE_ROOT)))
             for seed in (0, 1, 2)]
    runs = []
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        runs.append(json.loads(out))
    for other in runs[1:]:
        assert other == runs[0]
    assert runs[0]["names"] == PLAIN_NAMES


def test_heaviside_and_sign_of_a_state_are_surfaces(tmp_path):
    """``Heaviside(x - 1.2)`` of a state was an internal error ("equality condition on states");
    now it is a surface whose crossings the integrator locates."""
    ks = (ROOT / "models" / "kahraman_singh.toml").read_text()
    model = ks.replace('value = ["Fm",', 'value = ["Fm + 0.05*Heaviside(x - 1.2)*sign(v)",', 1)
    (tmp_path / "m.toml").write_text(model)
    (tmp_path / "s.toml").write_text('[scene]\nname = "hv"\nmodel = "m.toml"\n')
    system = gearsym.load_scene(tmp_path / "s.toml").compile(generated_dir=tmp_path / "gen")
    assert system.surface_names == ["mesh.drive", "mesh.back", "load.x-1.2=0", "load.v=0"]
    traj = system.simulate(periods=20, rtol=1e-10, atol=1e-12)
    hits = [e for e in traj.events if e.surface == "load.x-1.2=0"]
    turns = [e for e in traj.events if e.surface == "load.v=0"]
    assert len(hits) >= 4 and len(turns) >= 4
    events = sorted(hits + turns, key=lambda e: e.t)
    at = system.simulate(periods=20, rtol=1e-10, atol=1e-12, t_out=np.array([e.t for e in events]))
    for e, x, v in zip(events, at["x"], at["v"]):
        assert abs(x - 1.2 if e.surface == "load.x-1.2=0" else v) < 1e-8, (e, x, v)


_GROUPS = """
import json, sys
import sympy as sp
from gearsym import load_scene
form = load_scene(sys.argv[1]).model.dimensionless()
print(json.dumps({k: sp.sstr(v) for k, v in form.definitions.items()}))
"""


def test_dimensionless_groups_for_every_hash_seed():
    """The groups of a dimensionless form (``inspect``, dimensionless builds) do not depend on the
    hash seed (before: the two-stage train's ``me2_hat`` was ``me2*rb1**2/J1`` or
    ``bh1**2*me2/J1`` depending on it)."""
    scene = ROOT / "scenes" / "two_stage_train.toml"
    procs = [subprocess.Popen([sys.executable, "-c", _GROUPS, str(scene)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True,
                              env=dict(os.environ, PYTHONHASHSEED=str(seed), PYTHONPATH=str(PACKAGE_ROOT)))
             for seed in (0, 1, 2)]
    runs = []
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        runs.append(json.loads(out))
    assert runs[1] == runs[0] and runs[2] == runs[0]
    assert runs[0]["me2_hat"] == "me2*rb1**2/J1"
