"""One element interface (issue 26): every element type is one spec module and one symbolic
module, registered under its type name; nothing else in gearsym asks an element its type.

* an AST scan of gearsym/ finds no element type name used as a type (compared with a
  ``.type``, a key of a table of types, a member of a list of types, an index of a
  registry) outside the two element packages;
* the two registries name the same types;
* a ``gear_mesh`` reports its mesh deflection and mesh force, checked against the hand
  formula of ``models/yu_6dof.toml`` (eqs. 13-16) in the unreduced model, and in the
  compiled ``yu_dynamic_D14`` scene against the reduced coordinate and the model's own
  ``[outputs] mesh_force``.
"""

from __future__ import annotations

import ast
import math
import tomllib
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest
import sympy as sp

import gearsym

ROOT = Path(__file__).resolve().parents[1]
PKG = Path(gearsym.__file__).resolve().parent  # the gearsym under test
#: the element packages (and their registries): the only places a type name may be used as one
ELEMENT_PACKAGES = (PKG / "spec" / "elements", PKG / "symbolic" / "elements")
TYPE_NAMES = frozenset({"inertia", "force", "spring", "damper", "mesh", "bearing", "gear_mesh"})
REGISTRIES = frozenset({"ELEMENT_TYPES", "ASSEMBLERS"})


def _type_names() -> frozenset[str]:
    try:
        from gearsym.spec.elements import ELEMENT_TYPES
    except ImportError:  # (main before the element packages)
        return TYPE_NAMES
    return TYPE_NAMES | frozenset(ELEMENT_TYPES)


# ------------------------------------------------------------------------- the AST scan


def _reads_a_type(node: ast.AST) -> bool:
    """Whether an expression reads an element's type (``el.type``, ``x.type_name``, ``etype``)."""
    for n in ast.walk(node):
        if isinstance(n, ast.Attribute) and n.attr in ("type", "type_name"):
            return True
        if isinstance(n, ast.Name) and "type" in n.id.lower():
            return True
    return False


def _constants(node: ast.AST, names: frozenset[str]) -> list[ast.Constant]:
    """``node`` itself or the members of a tuple / list / set literal that are type names."""
    items = node.elts if isinstance(node, (ast.Tuple, ast.List, ast.Set)) else [node]
    return [c for c in items if isinstance(c, ast.Constant) and c.value in names]


def type_name_uses(source: str, names: frozenset[str] = TYPE_NAMES) -> list[tuple[int, str, str]]:
    """``(line, name, how)`` of every use of an element type name as a type in ``source``:

    * ``compare``: a type name compared with an expression that reads a type
      (``el.type == "mesh"``, ``etype in ("inertia", "force")``);
    * ``table``: a key of a dict literal, or a member of a tuple / list / set literal, that
      holds two or more type names (a table or list of types: ``{"spring": ..., "mesh": ...}``,
      ``("spring", "mesh")``);
    * ``registry``: a registry indexed by a type name (``ELEMENT_TYPES["mesh"]``);
    * ``match``: a ``case "mesh":`` pattern.

    A type name as an ordinary word is not a use: ``"mesh"`` as an effect, a function or a
    surface name (``function == "mesh"``, ``{"sw": 0, "mesh": 5}``), ``"mesh_phase"``, text.
    """
    out: list[tuple[int, str, str]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            for i, op in enumerate(operands):
                others = operands[:i] + operands[i + 1:]
                if any(_reads_a_type(o) for o in others):
                    out += [(c.lineno, c.value, "compare") for c in _constants(op, names)]
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if isinstance(k, ast.Constant) and k.value in names]
            if len({k.value for k in keys}) >= 2:
                out += [(k.lineno, k.value, "table") for k in keys]
        elif isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            members = _constants(node, names)
            if len({c.value for c in members}) >= 2:
                out += [(c.lineno, c.value, "table") for c in members]
        elif isinstance(node, ast.Subscript):
            base = node.value
            label = base.id if isinstance(base, ast.Name) else base.attr if isinstance(base, ast.Attribute) else ""
            if label in REGISTRIES:
                out += [(c.lineno, c.value, "registry") for c in _constants(node.slice, names)]
        elif isinstance(node, ast.MatchValue):
            out += [(c.lineno, c.value, "match") for c in _constants(node.value, names)]
    return sorted(set(out))


@pytest.mark.parametrize("source,found", [
    ('if el.type == "mesh": pass', [(1, "mesh", "compare")]),
    ('ok = etype in ("inertia", "force")', [(1, "force", "compare"), (1, "force", "table"),
                                            (1, "inertia", "compare"), (1, "inertia", "table")]),
    ('x = "gear_mesh" != part.type_name', [(1, "gear_mesh", "compare")]),
    ('T = {"spring": 1, "mesh": 2}', [(1, "mesh", "table"), (1, "spring", "table")]),
    ('D = ("spring", "mesh")', [(1, "mesh", "table"), (1, "spring", "table")]),
    ('k = ELEMENT_TYPES["bearing"]', [(1, "bearing", "registry")]),
    ('match kind:\n    case "damper": pass', [(2, "damper", "match")]),
    # ordinary words: not uses of a type name
    ('if function == "mesh": pass', []),
    ('E = {"sw": 0, "out": 1, "mesh": 5}', []),
    ('only_keys(ctx, where, eq, {"mass", "force"})', []),
    ('if effect == "mesh_stiffness_variation" or name == "mesh_phase": pass', []),
    ('"""a mesh, a spring and a damper"""', []),
])
def test_the_scan_finds_type_names_used_as_types_and_nothing_else(source, found):
    assert type_name_uses(source) == found


def test_no_element_type_name_outside_the_element_modules():
    """Before: ``inertia``, ``force``, ``spring``, ``damper`` and ``mesh`` were an if/elif in
    SymbolicModel._assemble and in validate_model, with tables of types in spec/model.py,
    spec/reduction.py, spec/elements.py and checks in spec/rules.py and symbolic/scales.py."""
    names = _type_names()
    found = []
    for f in sorted(PKG.rglob("*.py")):
        if any(f.is_relative_to(p) for p in ELEMENT_PACKAGES):
            continue
        found += [f"{f.relative_to(PKG.parent)}:{line}: '{name}' ({how})"
                  for line, name, how in type_name_uses(f.read_text(encoding="utf-8"), names)]
    assert found == []


def test_the_spec_and_symbolic_registries_name_the_same_types():
    from gearsym.spec.elements import ELEMENT_TYPES, ElementType
    from gearsym.symbolic.elements import ASSEMBLERS, SymbolicElement

    assert list(ELEMENT_TYPES) == list(ASSEMBLERS)
    assert set(ELEMENT_TYPES) >= TYPE_NAMES
    for name, t in ELEMENT_TYPES.items():
        assert isinstance(t, ElementType) and t.name == name
        assert ASSEMBLERS[name].type_name == name and issubclass(ASSEMBLERS[name], SymbolicElement)
        assert set(t.ranges) <= set(t.required) | set(t.optional), name
        assert not (t.takes_coordinate and t.coordinates), name
        assert t.deflection_default <= t.has_deflection, name


# ----------------------------------------------------------- gear_mesh: per-mesh results

#: Yu's pair (models/yu_6dof.toml), SI
YU = dict(I_p=1.15e-3, I_g=1.15e-3, R_p=0.094, R_g=0.094, k_m=3.0e8, xi=0.1, T_ah=0.019, b_n=1e-3,
          alpha0=math.radians(20.0), Omega=0.2, eps=0.2, phi0=0.0, b_0=20e-6)


def _yu_hand(t, th_p, th_g, xp, yp, xg, yg):
    """``(delta, B, k(t), c)`` of Yu's gear_mesh by hand (models/yu_6dof.toml, eqs. 1-17: dynamic
    backlash, time-varying pressure angle, no fractal terms), in mpmath."""
    P = {k: mp.mpf(repr(v)) for k, v in YU.items()}
    c0 = mp.cos(P["alpha0"])
    Rpb, Rgb = P["R_p"] * c0, P["R_g"] * c0
    a0, ab = P["R_p"] + P["R_g"], Rpb + Rgb
    me = 1 / (Rpb**2 / P["I_p"] + Rgb**2 / P["I_g"])
    wh = P["Omega"] * mp.sqrt(P["k_m"] / me)
    a = mp.sqrt((a0 - (xp - xg)) ** 2 + (yp - yg) ** 2)
    alpha = mp.acos(ab / a)
    e = P["T_ah"] * P["b_n"] * mp.cos(wh * t + P["phi0"])
    delta = Rpb * th_p - Rgb * th_g + (xp - xg) * mp.sin(alpha) + (yp - yg) * mp.cos(alpha) - e
    kappa = Rpb * (a + a0) / (2 * ab**2)
    B = P["b_0"] + (a - a0) * mp.sqrt(max(0, 1 - kappa**2))
    k = P["k_m"] * (1 + P["eps"] * mp.sin(wh * t + P["phi0"]))
    c = 2 * P["xi"] * mp.sqrt(P["k_m"] * me)
    return delta, B, k, c


def _unreduced_yu():
    """models/yu_6dof.toml without its reduction (the rotations stay coordinates), fractal terms off."""
    from gearsym.spec.model import parse_model
    from gearsym.spec.scene import SceneSpec, resolve_scene
    from gearsym.symbolic.model import SymbolicModel

    doc = tomllib.loads((ROOT / "models" / "yu_6dof.toml").read_text())
    for key in ("reduction", "initial", "outputs"):
        del doc[key]
    for key in ("f_d", "F_m"):  # written in the reduced states x, v
        del doc["derived"][key]
    spec = parse_model(doc, "<unreduced yu_6dof>")
    scene = SceneSpec("<scene>", "u", "", "<unreduced yu_6dof>", {}, {}, {}, {})
    return SymbolicModel(resolve_scene(scene, spec, effects={"fractal_backlash": False}))


def test_gear_mesh_reports_its_deflection_and_force_unreduced():
    """Before: a gear_mesh had contact surfaces but no mesh deflection (``mesh_deflections ==
    {}``) and no mesh force."""
    m = _unreduced_yu()
    assert list(m.mesh_deflections) == ["mesh"] and list(m.mesh_forces) == ["mesh"]
    assert [g.name for g in m.switching if g.kind in ("drive", "back")] == ["mesh.drive", "mesh.back"]
    ns = m.ns
    values = {ns.params[n]: sp.Float(repr(v), 45) for n, v in YU.items()}  # the decimals mpmath reads
    names = ["th_p", "th_g", "xp", "yp", "xg", "yg"]
    q = [ns.coords[n] for n in names]
    assert list(ns.coords) == names
    v = list(ns.vels.values())  # w_p, w_g, xp_dot, ... in the order of the coordinates
    rng = np.random.default_rng(26)
    mp.mp.dps = 40
    seen = set()
    for trial in range(2):
        t = mp.mpf(repr(rng.uniform(0, 2e-3)))
        centres = [mp.mpf(repr(rng.uniform(-8e-6, 8e-6))) for _ in range(4)]
        rates = [mp.mpf(repr(rng.uniform(-0.3, 0.3))) for _ in range(2)] + \
                [mp.mpf(repr(rng.uniform(-0.02, 0.02))) for _ in range(4)]
        th_g = mp.mpf(repr(rng.uniform(-1e-3, 1e-3)))
        for region in (1.4, 0.3, -1.6):  # drive-side contact, separation, back-side contact
            _, B, _, _ = _yu_hand(t, 0, th_g, *centres)
            # th_p so that delta = region*B
            d0 = _yu_hand(t, 0, th_g, *centres)[0]
            Rpb = mp.mpf(repr(YU["R_p"])) * mp.cos(mp.mpf(repr(YU["alpha0"])))
            th_p = (region * B - d0) / Rpb
            state = [th_p, th_g, *centres]

            def along(s, t=t, state=state, rates=rates):
                return _yu_hand(t + s, *[x + s * r for x, r in zip(state, rates)])[0]

            delta, B, k, c = _yu_hand(t, *state)
            f = delta - B if delta > B else delta + B if delta < -B else mp.mpf(0)
            W = k * f + c * mp.diff(along, 0)
            sub = {**values, **{s_: sp.Float(str(x_), 45) for s_, x_ in [(m.t, t), *zip(q, state), *zip(v, rates)]}}
            got_d = sp.N(m.mesh_deflections["mesh"].xreplace(sub), 35)
            got_W = sp.N(m.mesh_forces["mesh"].xreplace(sub), 35)
            assert abs(mp.mpf(str(got_d)) - delta) <= mp.mpf("1e-30"), (trial, region)
            assert abs(mp.mpf(str(got_W)) - W) <= mp.mpf("1e-25") * (1 + abs(W)), (trial, region, got_W, W)
            seen.add(region)
    assert seen == {1.4, 0.3, -1.6}


@pytest.fixture(scope="module")
def yu_d14():
    return gearsym.load_scene(ROOT / "scenes" / "yu_dynamic_D14.toml").compile()


def test_gear_mesh_scene_reports_mesh_deflections_and_forces(yu_d14):
    """yu_dynamic_D14 (reduced to the dynamic transmission error x = delta, centres kept): the
    compiled mesh deflection is the state x (the model's reduction definition is Yu's eq. 15,
    the gear_mesh deflection), the mesh force the model's hand-written ``[outputs] mesh_force``
    (F_m = k_mt*f_d + c_m*v, eq. 13).  Before: ``generated.meshes == []``, no gs_mesh_force."""
    s = yu_d14
    assert s.generated.meshes == ["mesh"] and "gs_mesh_force" in s.generated.functions
    traj = s.simulate(periods=3, n_out=121)
    D = s.mesh_deflections(traj.t, traj.y)
    x = traj.y[:, s.state_names.index("x")]
    assert D.shape == (len(traj.t), 1)
    np.testing.assert_allclose(D[:, 0], x, rtol=0, atol=1e-15 * np.max(np.abs(x)))
    p = s.param_vector()
    m = s.modes(traj.t, traj.y, p).T
    W = np.asarray(s.generated.casadi_function("gs_mesh_force")(
        traj.t[None, :], traj.y.T, np.tile(p[:, None], (1, len(traj.t))), m)).ravel()
    ref = s.outputs(traj)["mesh_force"]
    assert np.ptp(ref) > 0.01 * np.max(np.abs(ref))  # the force varies over the cycle
    np.testing.assert_allclose(W, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))


def test_inspect_lists_the_gear_mesh():
    from gearsym.inspection import inspect_structure

    m = gearsym.load_scene(ROOT / "scenes" / "yu_constant_backlash.toml").model
    assert inspect_structure(m)["meshes"] == ["mesh"]


# ------------------------------------------------- the worked example of docs/contributing.md


def _doc_module(package: str, marker: str):
    """The python block of docs/contributing.md whose first line is ``# <marker>``, executed as a
    module of ``package`` (so its relative imports work)."""
    import re
    import types

    text = (ROOT / "docs" / "contributing.md").read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, re.S) if b.startswith(f"# {marker}\n")]
    assert len(blocks) == 1, marker
    mod = types.ModuleType(f"{package}.clutch")
    mod.__package__ = package
    exec(compile(blocks[0], marker, "exec"), mod.__dict__)  # noqa: S102 (our own documentation)
    return mod


@pytest.fixture
def clutch_registered(monkeypatch):
    """The clutch of docs/contributing.md, registered in both registries for one test."""
    from gearsym.spec.elements import ELEMENT_TYPES
    from gearsym.symbolic.elements import ASSEMBLERS

    spec_side = _doc_module("gearsym.spec.elements", "gearsym/spec/elements/clutch.py").Clutch
    symbolic_side = _doc_module("gearsym.symbolic.elements", "gearsym/symbolic/elements/clutch.py").Clutch
    monkeypatch.setitem(ELEMENT_TYPES, "clutch", spec_side())
    monkeypatch.setitem(ASSEMBLERS, "clutch", symbolic_side)


def _pair(spline: dict) -> dict:
    """Two rotations coupled by ``spline``: a driving torque on th1, th2 on a spring to the ground."""
    return {
        "model": {"name": "clutch_pair"},
        "coordinates": {"th1": {"unit": "rad", "velocity": "w1"}, "th2": {"unit": "rad", "velocity": "w2"}},
        "parameters": {"J1": {"value": 0.01, "unit": "kg*m^2"}, "J2": {"value": 0.03, "unit": "kg*m^2"},
                       "k_s": {"value": 1e4, "unit": "N*m/rad"}, "b_s": {"value": 0.01, "unit": "rad"},
                       "c_s": {"value": 0.5, "unit": "N*m*s/rad"}, "T0": {"value": 5.0, "unit": "N*m"},
                       "k1": {"value": 2e3, "unit": "N*m/rad"}},
        "elements": {"j1": {"type": "inertia", "coordinate": "th1", "value": "J1"},
                     "j2": {"type": "inertia", "coordinate": "th2", "value": "J2"},
                     "drive": {"type": "force", "coordinate": "th1", "value": "T0"},
                     "ground": {"type": "spring", "deflection": "th2", "stiffness": "k1"},
                     "spline": spline},
    }


def _symbolic(doc: dict, **overrides):
    from gearsym.spec.model import parse_model
    from gearsym.spec.scene import SceneSpec, resolve_scene
    from gearsym.symbolic.model import SymbolicModel

    spec = parse_model(doc, "<clutch_pair>")
    scene = SceneSpec("<scene>", "c", "", "<clutch_pair>", {}, {}, {}, {})
    return SymbolicModel(resolve_scene(scene, spec, overrides=overrides))


def test_the_documented_clutch_is_one_module_each_side_and_equals_a_hand_written_mesh(clutch_registered):
    """docs/contributing.md's worked example, registered as written: a clutch derives the same
    equations, contact surfaces and per-mesh results as the ``mesh`` element on
    ``deflection = "th1 - th2"`` that writes the same physics by hand."""
    clutch = _symbolic(_pair({"type": "clutch", "input": "th1", "output": "th2", "stiffness": "k_s",
                              "clearance": "b_s", "damping": "c_s"}))
    mesh = _symbolic(_pair({"type": "mesh", "deflection": "th1 - th2", "stiffness": "k_s", "backlash": "b_s",
                            "damping": "c_s"}))
    assert clutch.state_names == mesh.state_names == ["th1", "th2", "w1", "w2"]
    assert all(sp.simplify(a - b) == 0 for a, b in zip(clutch.rhs, mesh.rhs))
    assert [(g.name, g.kind, g.contact_sign) for g in clutch.switching] == \
        [(g.name, g.kind, g.contact_sign) for g in mesh.switching] == \
        [("spline.drive", "drive", 1), ("spline.back", "back", -1)]
    assert all(sp.simplify(a.expr - b.expr) == 0 for a, b in zip(clutch.switching, mesh.switching))
    assert list(clutch.mesh_deflections) == list(clutch.mesh_forces) == ["spline"]
    assert sp.simplify(clutch.mesh_deflections["spline"] - mesh.mesh_deflections["spline"]) == 0
    assert sp.simplify(clutch.mesh_forces["spline"] - mesh.mesh_forces["spline"]) == 0
    assert clutch.rigid_body_modes == mesh.rigid_body_modes == []


def test_the_documented_clutch_gets_its_checks_from_its_schema(clutch_registered):
    from gearsym.errors import SpecError

    good = {"type": "clutch", "input": "th1", "output": "th2", "stiffness": "k_s", "clearance": "b_s"}
    for change, field, message in [
        ({"inputs": "th1"}, "elements.spline.inputs", "unknown field 'inputs'"),
        ({"output": "th9"}, "elements.spline.output", "unknown coordinate 'th9'"),
        ({"clearance": "b_s*k_s"}, "elements.spline.clearance", "unit mismatch"),
        ({"coordinate": "th1"}, "elements.spline.coordinate", "names its coordinates in input, output"),
    ]:
        with pytest.raises(SpecError, match=message) as info:
            _symbolic(_pair({**good, **change}))
        assert info.value.field == field
    with pytest.raises(SpecError, match="missing field 'output' of clutch element"):
        _symbolic(_pair({k: v for k, v in good.items() if k != "output"}))
    with pytest.raises(gearsym.errors.GearsymError, match=r"half clearance of clutch 'spline'.*must be >= 0"):
        _symbolic(_pair(good), b_s=-0.1)
