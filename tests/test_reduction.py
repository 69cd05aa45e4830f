"""Rigid-body modes and the three [reduction] forms (one coordinate, several named ones,
mode = "deflections"), on a small free train: a pinion-gear mesh and a shaft.

References: the kinematics of the train (a rigid rotation turns the gear by r1/r2 of the
pinion and twists no shaft); the equations written by hand in the deflections.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest
import sympy as sp

import gearsym
from gearsym.errors import SpecError

CHAIN = """
[model]
name = "chain"
time_unit = "s"

[coordinates.a]
unit = "rad"
[coordinates.b]
unit = "rad"
[coordinates.c]
unit = "rad"

[parameters]
Ja = { value = 0.01, unit = "kg*m^2" }
Jb = { value = 0.02, unit = "kg*m^2" }
Jc = { value = 0.05, unit = "kg*m^2" }
r1 = { value = 0.03, unit = "m" }
r2 = { value = 0.06, unit = "m" }
km = { value = 3e8, unit = "N/m" }
cm = { value = 500.0, unit = "N*s/m" }
bh = { value = 20.0, unit = "um" }
ea = { value = 2.0, unit = "um" }
w  = { value = 5000.0, unit = "rad/s" }
ks = { value = 1e5, unit = "N*m/rad" }
cs = { value = 3.0, unit = "N*m*s/rad" }
T  = { value = 50.0, unit = "N*m" }

[forcing]
period = "2*pi/w"

[elements.ia]
type = "inertia"
coordinate = "a"
value = "Ja"
[elements.ib]
type = "inertia"
coordinate = "b"
value = "Jb"
[elements.ic]
type = "inertia"
coordinate = "c"
value = "Jc"
[elements.mesh]
type = "mesh"
deflection = "r1*a - r2*b"
error = "ea*cos(w*t)"
stiffness = "km"
damping = "cm"
backlash = "bh"
[elements.shaft]
type = "spring"
deflection = "b - c"
stiffness = "ks"
[elements.shaft_damping]
type = "damper"
deflection = "b - c"
coefficient = "cs"
[elements.drive]
type = "force"
coordinate = "a"
value = "T"
[elements.load]
type = "force"
coordinate = "c"
value = "-T*r2/r1"
"""

DEFLECTIONS = '\n[reduction]\nmode = "deflections"\n'
EXPLICIT = """
[reduction.coordinates.x_mesh]
definition = "r1*a - r2*b - ea*cos(w*t)"
unit = "m"
velocity = "v_mesh"
[reduction.coordinates.x_shaft]
definition = "b - c"
unit = "rad"
velocity = "v_shaft"
"""


def _scene(tmp_path: Path, model: str, name: str = "chain") -> gearsym.facade.Scene:
    m = tmp_path / f"{name}.toml"
    m.write_text(model)
    s = tmp_path / f"{name}_scene.toml"
    s.write_text(f'[scene]\nname = "{name}"\nmodel = "{m.name}"\n')
    return gearsym.load_scene(s)


def _acc(model, values):
    """Accelerations of a model at numeric states (every surface on its contact side)."""
    subs = {model.ns.params[k]: v for k, v in values.items() if k in model.ns.params}
    subs.update({s: 1.0 for s in model.modal.sigma})
    subs.update({sp.Symbol(k, real=True): v for k, v in values.items()})
    n = len(model.coordinates)
    return [float(sp.N(model.modal.rhs[n + i].xreplace(subs))) for i in range(n)]


def test_rigid_body_mode_of_a_free_train_and_none_when_grounded(tmp_path):
    m = _scene(tmp_path, CHAIN).model
    r1, r2 = sp.symbols("r1 r2", real=True)
    modes = m.rigid_body_modes
    assert len(modes) == 1
    assert {str(k) for k in modes[0]} == {"a", "b", "c"}
    assert modes[0]["a"] == 1
    for q in ("b", "c"):
        assert sp.simplify(modes[0][q] - r1 / r2) == 0
    grounded = CHAIN + '[elements.support]\ntype = "spring"\ndeflection = "a"\nstiffness = "ks"\n'
    assert _scene(tmp_path, grounded, "grounded").model.rigid_body_modes == []
    # a damper to the ground is enough to see the mode (its velocity part)
    damped = CHAIN + '[elements.motor]\ntype = "damper"\ndeflection = "a"\ncoefficient = "cs"\n'
    assert _scene(tmp_path, damped, "damped").model.rigid_body_modes == []


def test_deflections_and_explicit_forms_agree_with_the_hand_equations(tmp_path):
    auto = _scene(tmp_path, CHAIN + DEFLECTIONS, "auto").model
    expl = _scene(tmp_path, CHAIN + "\n[reduction]\n" + EXPLICIT.replace("[reduction.", "[reduction.", 1),
                  "expl").model
    assert auto.state_names == expl.state_names == ["x_mesh", "x_shaft", "v_mesh", "v_shaft"]
    assert auto.rigid_body_modes == expl.rigid_body_modes == []
    assert [str(q) for q in auto.reduction_result.kept] == ["c"]
    rng = random.Random(5)
    p = {"Ja": 0.01, "Jb": 0.02, "Jc": 0.05, "r1": 0.03, "r2": 0.06, "km": 3e8, "cm": 500.0, "bh": 20e-6,
         "ea": 2e-6, "w": 5000.0, "ks": 1e5, "cs": 3.0, "T": 50.0}
    for _ in range(3):
        st = {"x_mesh": rng.uniform(25e-6, 40e-6), "x_shaft": rng.uniform(-1e-3, 1e-3),
              "v_mesh": rng.uniform(-0.1, 0.1), "v_shaft": rng.uniform(-1, 1), "t": rng.uniform(0, 1e-3)}
        # by hand: W = km (x - bh) + cm v (drive contact), M_s = ks xs + cs vs
        W = p["km"] * (st["x_mesh"] - p["bh"]) + p["cm"] * st["v_mesh"]
        Ms = p["ks"] * st["x_shaft"] + p["cs"] * st["v_shaft"]
        acc_a = (p["T"] - p["r1"] * W) / p["Ja"]
        acc_b = (p["r2"] * W - Ms) / p["Jb"]
        acc_c = (Ms - p["T"] * p["r2"] / p["r1"]) / p["Jc"]
        e_dd = -p["ea"] * p["w"] ** 2 * sp.cos(p["w"] * st["t"])
        want = [p["r1"] * acc_a - p["r2"] * acc_b - float(e_dd), acc_b - acc_c]
        vals = dict(p, **st)
        for model in (auto, expl):
            got = _acc(model, vals)
            assert got == pytest.approx(want, rel=1e-12)
    # the contact surfaces are x_mesh -/+ bh
    g = {s.name: s.expr for s in auto.switching}
    assert sp.simplify(g["mesh.drive"] - (sp.Symbol("x_mesh", real=True) - sp.Symbol("bh", real=True))) == 0


@pytest.mark.parametrize("text, field, words", [
    (CHAIN + '\n[reduction]\nmode = "deflections"\nelements = ["mesh"]\n', "reduction",
     ["not closed", "'x_mesh'", "depend on b, b_dot, c, c_dot"]),
    (CHAIN + '\n[reduction]\nmode = "deflections"\nelements = ["mesh", "nope"]\n', "reduction.elements[1]",
     ["unknown element 'nope'"]),
    (CHAIN + '\n[reduction]\nmode = "deflections"\nelements = ["ia"]\n', "reduction.elements[0]",
     ["is a inertia", "deflection"]),
    (CHAIN + '\n[reduction]\nmode = "deflections"\nelements = ["shaft", "shaft_damping"]\n',
     "elements.shaft_damping.deflection", ["combination of the ones before"]),
    (CHAIN + '\n[reduction]\nmode = "bogus"\n', "reduction.mode", ["'explicit' or 'deflections'"]),
    (CHAIN + '\n[reduction]\nmode = "deflections"\ncoordinate = "x"\n', "reduction.coordinate",
     ["unknown field"]),
    (CHAIN.replace("T  = {", "x_mesh = { value = 1.0 }\nT  = {") + DEFLECTIONS, "elements.mesh",
     ["duplicate name 'x_mesh'"]),
    (CHAIN + "\n[reduction]\n" + EXPLICIT.replace('unit = "rad"', 'unit = "m"'),
     "reduction.coordinates.x_shaft.definition", ["unit mismatch"]),
    (CHAIN + "\n[reduction]\n" + EXPLICIT.replace('"b - c"', '"b*c"'),
     "reduction.coordinates.x_shaft.definition", ["linear in the coordinates"]),
    (CHAIN + "\n[reduction]\n" + EXPLICIT.replace('"b - c"', '"2*r1*a - 2*r2*b"').replace(
        'unit = "rad"', 'unit = "m"'), "reduction.coordinates.x_shaft.definition", ["combination"]),
    (CHAIN + DEFLECTIONS + "[initial]\na = 1.0\n", "initial.a", ["not a state"]),
])
def test_bad_reductions_name_the_field(tmp_path, text, field, words):
    with pytest.raises(SpecError) as info:
        _scene(tmp_path, text).model  # noqa: B018 - derives the equations
    assert info.value.field == field or info.value.field.startswith(field), (info.value.field, str(info.value))
    for w in words:
        assert w in str(info.value)


def test_bad_reduction_from_the_cli_exits_2_with_one_line(tmp_path, capsys):
    from gearsym.cli import main

    m = tmp_path / "m.toml"
    m.write_text(CHAIN + '\n[reduction]\nmode = "deflections"\nelements = ["mesh"]\n')
    assert main(["inspect", str(m)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "m.toml" in err[0] and "field 'reduction'" in err[0] and "not closed" in err[0]
