"""A switched-off effect never makes the generated code bigger (issue 12, item 6).

For every shipped model, in its default configuration and in the configuration of every
shipped scene, each effect is switched off (with the effects that require it) and on
(with the effects it requires): the operation count of the generated right-hand side
(``gs_rhs``, CasADi instructions) with the effect off must not exceed the count with it
on.  Before the reduction kept parameter blocks whole, vaishya_singh with every effect
off had 787 operations against 122 with the mesh stiffness variation on.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import gearsym
from gearsym.codegen.generate import build_functions
from gearsym.spec.model import load_model

ROOT = Path(__file__).resolve().parents[1]
_OPS: dict[tuple, int] = {}


def _configs() -> list[tuple[Path, dict]]:
    """(scene file, effect choices): each model's defaults (via its first scene) and every scene."""
    out, seen = [], set()
    for sc in sorted((ROOT / "scenes").glob("*.toml")):
        s = gearsym.load_scene(sc)
        model = s.model_spec
        defaults = {e: eff.default for e, eff in model.effects.items()}
        for eff in (defaults, dict(s.resolved.effects)):
            key = (model.name, tuple(sorted((k, str(v)) for k, v in eff.items())))
            if key not in seen:
                seen.add(key)
                out.append((sc, eff))
    return out


def _ops(scene: Path, effects: dict) -> int:
    model = load_model(gearsym.load_scene(scene).spec.model_path)
    key = (model.name, tuple(sorted((k, str(v)) for k, v in effects.items())))
    if key not in _OPS:
        fns = build_functions(gearsym.load_scene(scene, effects=effects).model)
        _OPS[key] = int(fns["gs_rhs" if "gs_rhs" in fns else "gs_res"].n_instructions())
    return _OPS[key]


def _switch(model, effects: dict, name: str, on: bool) -> dict:
    out = dict(effects)
    if on:
        eff = model.effects[name]
        out[name] = eff.variants[0] if eff.variants and out[name] in (False, True) else (out[name] or True)
        todo = [name]
        while todo:
            for r in model.effects[todo.pop()].requires:
                if out[r] is False:
                    out[r] = model.effects[r].variants[0] if model.effects[r].variants else True
                    todo.append(r)
    else:
        out[name] = False
        changed = True
        while changed:
            changed = False
            for e, eff in model.effects.items():
                if out[e] is not False and any(out[r] is False for r in eff.requires):
                    out[e] = False
                    changed = True
    return out


CONFIGS = _configs()


@pytest.mark.parametrize("scene,effects", CONFIGS, ids=[f"{s.stem}-{i}" for i, (s, _) in enumerate(CONFIGS)])
def test_switching_an_effect_off_never_adds_operations(scene, effects):
    model = gearsym.load_scene(scene).model_spec
    checked = 0
    for name in model.effects:
        on = _switch(model, effects, name, True)
        off = _switch(model, effects, name, False)
        n_on, n_off = _ops(scene, on), _ops(scene, off)
        assert n_off <= n_on, f"{model.name}: {name} off has {n_off} operations, on {n_on} (config {effects})"
        checked += 1
    assert checked == len(model.effects)
