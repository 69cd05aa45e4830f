"""``gearsym inspect``: a model's derived equations, states, parameters, effects, modes."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import SpecError
from ..inspection import inspect_structure, print_structure
from .checks import emit, parse_effects, parse_set, set_errors

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["cmd_inspect"]


def cmd_inspect(args: argparse.Namespace) -> int:
    """Show a model's derived equations, states, parameters, effects, modes."""
    import sympy as sp

    from ..catalog import find_spec_file
    from ..facade import Scene
    from ..spec.files import read_toml
    from ..spec.model import load_model
    from ..spec.units import ParameterUnits
    from .details import inspect_details, print_details

    path = find_spec_file(args.path)
    head = read_toml(path, "file")  # regular file, size limit, before reading
    if "scene" in head:
        with set_errors():
            scene = Scene(path, parse_effects(args.effect, args.no_effect) or None, parse_set(args.set))
    elif "model" in head:
        model_spec = load_model(path)
        with set_errors():
            scene = _model_scene(path, model_spec, args)
    else:
        raise SpecError("neither a scene ([scene]) nor a model ([model]) file", file=str(path))
    m = scene.model
    ms = scene.model_spec
    # the values in effect (model, scene, --set), in the declared units
    values = ParameterUnits.of_model(ms).to_declared(scene.resolved.values)
    info: dict[str, Any] = {
        "model": ms.name,
        "scene": scene.name if "scene" in head else None,
        "description": ms.description,
        "states": m.state_names,
        "parameters": {
            name: {"value": values[name], "unit": p.unit, "meaning": p.meaning,
                   "active": name in m.parameter_names
                   or any(name in args for _, args in m.bound_parameters.values())}
            for name, p in ms.parameters.items()
        },
        "effects": {
            name: {"on": scene.resolved.effects[name] is not False,
                   "variant": scene.resolved.effects[name] if isinstance(scene.resolved.effects[name], str)
                   else None,
                   "variants": list(e.variants), "requires": list(e.requires), "meaning": e.meaning}
            for name, e in ms.effects.items()
        },
        "modes": [{"name": mo.name, "condition": mo.condition} for mo in m.modes],
        "switching_functions": [
            {"name": s.name, "expr": sp.sstr(s.expr), "meaning": s.meaning, "kind": s.kind, "field": s.origin}
            for s in m.switching
        ],
        "breakpoints": [
            {"schedule": s.name, "period": sp.sstr(s.period), "breaks": [sp.sstr(b) for b in s.breaks]}
            for s in m.schedules
        ],
        "forcing_period": sp.sstr(m.forcing_period) if m.forcing_period is not None else None,
        "tables": {name: t.to_dict(data=True) for name, t in ms.tables.items()},
        "equations": [sp.sstr(e.lhs) + " = " + sp.sstr(e.rhs) for e in m.equations()],
        **inspect_structure(m),
    }
    info.update(inspect_details(m, jacobian=args.jacobian))
    if args.latex:
        info["latex"] = m.latex()
    if args.json:
        emit(info)
        return 0
    print(f"model {ms.name}: {ms.description}")
    if ms.reference:
        print(f"  reference: {ms.reference}")
    print(f"states: {', '.join(info['states'])}")
    print("parameters:")
    for name, p in info["parameters"].items():
        mark = "" if p["active"] else "   (not used: effect off)"
        print(f"  {name:10s} = {p['value']:<12g} [{p['unit']}]  {p['meaning']}{mark}")
    print("effects:")
    for name, e in info["effects"].items():
        state = ("on" + (f" ({e['variant']})" if e["variant"] else "")) if e["on"] else "off"
        print(f"  {name:28s} {state:10s} {e['meaning']}")
    print_structure(info)
    print("equations of motion:")
    for eq in info["equations"]:
        print(f"  {eq}")
    if info["switching_functions"]:
        print("switching functions:")
        for s in info["switching_functions"]:
            print(f"  g[{s['name']}] = {s['expr']}   ({s['meaning']})")
        print("modes:")
        for mo in info["modes"]:
            print(f"  {mo['name']}: {mo['condition']}")
    _print_tables(info["tables"])
    for b in info["breakpoints"]:
        breaks = b["breaks"] if len(b["breaks"]) <= 8 else [*b["breaks"][:4], "...", b["breaks"][-1]]
        print(f"breakpoints: schedule {b['schedule']}, period {b['period']}, {len(b['breaks'])} breaks at "
              f"{breaks}")
    if info["forcing_period"]:
        print(f"forcing period: {info['forcing_period']}")
    print_details(info, [s.name for s in m.switching])
    if args.latex:
        print(info["latex"])
    return 0


def _print_tables(tables: dict) -> None:
    """One block per table: domain, interpolation, knots, source, range (and what gear geometry gave)."""
    if not tables:
        return
    print("tables:")
    for name, t in tables.items():
        domain = ", ".join(t["domain"])
        knots = " x ".join(map(str, t["knots"]))
        source = {"file": f"file {t['file']}", "gears": "gear geometry", "inline": "inline"}[t["source"]]
        extra = f", {t['harmonics']} harmonics" if "harmonics" in t else ""
        print(f"  {name}({domain}) [{t['unit']}]: {t['interpolation']}{extra}, {knots} knots, from {source}, "
              f"values {t['min']:.6g} .. {t['max']:.6g}" + (f"  {t['meaning']}" if t["meaning"] else ""))
        g = t.get("gears")
        if g:
            print(f"    gears {g['teeth'][0]}/{g['teeth'][1]}, module {g['module_m'] * 1e3:g} mm, face width "
                  f"{g['face_width_m'] * 1e3:g} mm: contact ratio {g['contact_ratio']:.6g}, mean {g['mean_N_per_m']:.6g} "
                  f"N/m (ISO 6336 c_gamma {g['iso6336_c_gamma_N_per_m']:.6g} N/m, ratio "
                  f"{g['mean_over_iso_c_gamma']:.4f})")


def _model_scene(path: Path, model_spec, args):
    """A scene with the model's defaults, for ``inspect MODEL``.

    The scene file lives in a temporary folder only while the scene is read (the scene keeps
    its parsed content, not the file): the folder is removed before this returns.
    """
    import json
    import tempfile

    from ..facade import Scene

    with tempfile.TemporaryDirectory(prefix="gearsym-") as tmp_dir:
        tmp = Path(tmp_dir) / f"{model_spec.name}.toml"
        tmp.write_text(f'[scene]\nname = "{model_spec.name}"\nmodel = {json.dumps(str(path.resolve()))}\n')
        return Scene(tmp, parse_effects(args.effect, args.no_effect) or None, parse_set(args.set),
                     model_spec=model_spec)
