"""Scenes: a model, the effects switched on, parameter values, what to compute.

A scene file (``scenes/*.toml``)::

    [scene]
    name = "kahraman_singh"
    model = "../models/kahraman_singh.toml"   # relative to this file
    description = "..."

    [effects]            # compile-time: off effects leave no code behind
    backlash = true
    sliding_friction = "B"   # a variant

    [parameters]         # run-time, in the units the model declares
    Omega = 0.9

    [initial]            # initial state (state names): numbers (SI) or expressions
    x = "F/k + b"        # of the parameters; static = true: the static equilibrium

    [simulate]           # defaults of `gearsym simulate`
    periods = 200
    rtol = 1e-8

:func:`resolve_scene` combines a scene with its model and the caller's overrides,
checks effect dependencies and parameter overrides, and works out which terms and
parameters are active.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import OverrideError, SpecError
from . import expressions as ex
from .elements import element_type
from .fields import did_you_mean, unknown_key
from .files import read_toml
from .initial import evaluate_initial, read_initial
from .model import ModelSpec, Term, load_model
from .names import check_label, sanitize_label
from .rules import ParameterRules, parameter_rules
from .settings import SETTINGS, read_settings
from .units import ParameterUnits

#: The sections of a scene file: ``[figures]`` is free (kept for scripts, never read by gearsym).
_SECTIONS = ("scene", "effects", "parameters", "initial", *SETTINGS, "figures")


@dataclass(frozen=True)
class SceneSpec:
    """A parsed scene file (not yet combined with its model)."""

    path: str
    name: str
    description: str
    model_path: str
    effects: dict[str, bool | str]
    parameters: dict[str, float]
    initial: dict[str, float | str]
    simulate: dict[str, Any]
    extra: dict[str, Any] = field(default_factory=dict)
    #: ``[initial] static``: start from the static equilibrium (``None``: the model's choice)
    static: bool | None = None


@dataclass(frozen=True)
class ResolvedScene:
    """A scene combined with its model: effects, active terms, parameter values.

    Attributes
    ----------
    model
        The model spec.
    scene
        The scene spec.
    effects
        Every effect of the model mapped to ``False`` (off), ``True`` (on) or the
        chosen variant name.
    values
        Value of every model parameter, in SI units, after scene and overrides.
    active_parameters
        Names of the parameters that active terms use (the others belong only to
        switched-off effects and are not inputs of the compiled system).
    initial
        Initial state by state name (SI units), unspecified states are 0; with ``static``
        the coordinates' values are the starting guess of the static solve.
    static
        Whether the scene starts from the static equilibrium (``[initial] static``).
    rules
        The physical ranges of the parameter values (backlash >= 0, inertia > 0, schedule
        breaks in (0, 1), declared ``min``/``max``), checked here for the scene's values and by
        the compiled system for every other value (:mod:`gearsym.spec.rules`).
    """

    model: ModelSpec
    scene: SceneSpec
    effects: dict[str, bool | str]
    values: dict[str, float]
    active_parameters: tuple[str, ...]
    initial: dict[str, float]
    static: bool = False
    #: the physical ranges of the parameter values (:mod:`gearsym.spec.rules`)
    rules: ParameterRules = field(default_factory=ParameterRules, compare=False)

    def effect_active(self, effect: str | None, variant: str | None = None) -> bool:
        """Whether an effect (and variant, if given) is on; ``None`` means always on."""
        if effect is None:
            return True
        state = self.effects.get(effect, False)
        if state is False:
            return False
        return variant is None or state == variant

    def is_active(self, term: Term, element_effect: str | None = None,
                  element_variant: str | None = None) -> bool:
        """Whether a term contributes under the scene's effects."""
        return (self.effect_active(element_effect, element_variant)
                and self.effect_active(term.effect, term.variant))

    def coordinate_active(self, name: str) -> bool:
        """Whether a coordinate exists in this scene (its ``effect``, if any, is on)."""
        return self.effect_active(self.model.coordinates[name].effect)

    def state_names(self) -> list[str]:
        """Names of the first-order states of this scene (coordinates of switched-off
        effects removed)."""
        red = self.model.reduction
        if red is not None:
            kept = [(self.model.coordinates[k].name, self.model.coordinates[k].velocity)
                    for k in red.keep if self.coordinate_active(k)]
            return red.state_names(lambda c: self.effect_active(c.effect, c.variant), kept)
        tied = {c.coordinate for c in self.model.constraints.values()}  # not states: [constraints]
        coords = [c for c in self.model.coordinates.values() if self.coordinate_active(c.name) and c.name not in tied]
        return [c.name for c in coords] + [c.velocity for c in coords] + list(self.model.algebraic)

    def coordinate_states(self) -> tuple[list[str], list[str]]:
        """The states that are coordinates, and their velocities (same order).

        Returns
        -------
        coordinates, velocities : list of str
        """
        if self.model.reduction is not None:  # every reduced coordinate and every kept one
            names = self.state_names()
            half = len(names) // 2
            return names[:half], names[half:]
        tied = {c.coordinate for c in self.model.constraints.values()}
        coords = [c for c in self.model.coordinates.values() if self.coordinate_active(c.name) and c.name not in tied]
        return [c.name for c in coords], [c.velocity for c in coords]

    @property
    def on_effects(self) -> dict[str, bool | str]:
        """The effects that are on, with their variant (or ``True``)."""
        return {k: v for k, v in self.effects.items() if v is not False}


def load_scene_spec(path: str | Path) -> SceneSpec:
    """Read and check a scene file.

    Raises
    ------
    SpecError
        Naming the scene file and the field.
    """
    path = Path(path)
    where_file = str(path)
    data = read_toml(path, "scene file")

    def err(fld: str | None, msg: str) -> SpecError:
        return SpecError(msg, file=where_file, field=fld)

    if "model" in data and "scene" not in data:
        raise err(None, "this is a model file; give a scene (or use `gearsym inspect` on the model)")

    for k in data:
        if k not in _SECTIONS:
            raise err(k, unknown_key(k, _SECTIONS, "section"))
    sc = data.get("scene")
    if not isinstance(sc, dict):
        raise err("scene", "missing section [scene]")
    for k in sc:
        if k not in ("name", "model", "description"):
            raise err(f"scene.{k}", unknown_key(k, ("name", "model", "description")))
    model_rel = sc.get("model")
    if not isinstance(model_rel, str):
        raise err("scene.model", "missing or not a string: the path of the model file")
    if not model_rel.strip() or "\x00" in model_rel or len(model_rel) > 4096:
        raise err("scene.model", "not a valid path of a model file")
    if "name" in sc:
        name = sc["name"]
        problem = check_label(name, "scene name")
        if problem:
            raise err("scene.name", problem)
    else:
        name = sanitize_label(path.stem)
    description = sc.get("description", "")
    if not isinstance(description, str):
        raise err("scene.description", f"wrong type: expected a string, got {type(description).__name__}")
    try:
        model_path = (path.parent / model_rel).resolve()
    except (OSError, RuntimeError) as exc:  # e.g. a symlink loop
        raise err("scene.model", f"cannot resolve the model path: {exc}") from None
    for section in ("effects", "parameters", "initial", "simulate"):
        if not isinstance(data.get(section, {}), dict):
            raise err(section, "wrong type: expected a table")
    effects = data.get("effects", {})
    for k, v in effects.items():
        if not isinstance(v, (bool, str)):
            raise err(f"effects.{k}", "must be true, false or a variant name")
    params: dict[str, float] = {}
    for k, v in data.get("parameters", {}).items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise err(f"parameters.{k}", f"wrong type: expected a number, got {type(v).__name__}")
        if not math.isfinite(v):
            raise err(f"parameters.{k}", f"non-finite value {v}")
        params[k] = float(v)
    initial, static = read_initial(data.get("initial", {}), err)
    settings = {k: read_settings(k, data.get(k, {}), err) for k in SETTINGS}
    sim = settings.pop("simulate")
    if "figures" in data and not isinstance(data["figures"], dict):
        raise err("figures", "wrong type: expected a table")
    extra = {k: v for k, v in settings.items() if k in data}
    if "figures" in data:
        extra["figures"] = data["figures"]
    return SceneSpec(where_file, name, description, str(model_path), dict(effects), params, initial,
                     dict(sim), extra, static)


def resolve_scene(scene: SceneSpec, model: ModelSpec | None = None,
                  effects: Mapping[str, bool | str] | None = None,
                  overrides: Mapping[str, float] | None = None) -> ResolvedScene:
    """Combine a scene with its model, effect choices and parameter overrides.

    Parameters
    ----------
    scene
        The scene spec.
    model
        The model spec; loaded from ``scene.model_path`` when omitted.
    effects
        Effect choices that replace the scene's (``True``/``False``/variant name).
    overrides
        Parameter values that replace the scene's: numbers in the model's declared units, or
        strings that are a number with a unit (``"50um"``, ``"2e13 N/m"``), converted to the
        declared unit after a check of the dimension.

    Raises
    ------
    SpecError
        For an effect not in the model, a bad variant, or an unmet requirement.
    ParameterError
        For an unknown parameter, a non-finite value, or a parameter that only
        switched-off effects use.
    """
    problem = check_label(scene.name, "scene name")
    if problem:  # a SceneSpec made in Python rather than read from a file
        raise SpecError(problem, file=scene.path, field="scene.name")
    if model is None:
        model = load_model(scene.model_path)
    state: dict[str, bool | str] = {name: e.default for name, e in model.effects.items()}

    def apply(src: Mapping[str, bool | str], origin: str, file: str | None) -> None:
        for name, v in src.items():
            if name not in model.effects:
                raise SpecError(f"effect '{name}' is not in model '{model.name}'"
                                f"{did_you_mean(name, model.effects)} (effects: "
                                f"{', '.join(model.effects) or 'none'})", file=file,
                                field=f"effects.{name}" if file else None)
            eff = model.effects[name]
            if isinstance(v, str):
                if v not in eff.variants:
                    raise SpecError(f"'{v}' is not a variant of effect '{name}' (variants: "
                                    f"{', '.join(eff.variants) or 'none'})", file=file,
                                    field=f"effects.{name}" if file else None)
            elif v is True and eff.variants:
                v = eff.default if isinstance(eff.default, str) else eff.variants[0]
            state[name] = v

    apply(scene.effects, "scene", scene.path)
    if effects:
        apply(effects, "override", None)
    for name, v in state.items():
        if v is False:
            continue
        for req in model.effects[name].requires:
            if state.get(req, False) is False:
                raise SpecError(f"effect '{name}' requires effect '{req}', which is off",
                                file=scene.path, field=f"effects.{name}")

    probe = ResolvedScene(model, scene, state, {}, (), {})
    used_active, used_inactive = _used_names(model, probe)
    active_params = tuple(p for p in model.parameters if p in used_active)

    units = ParameterUnits.of_model(model)
    values = _parameter_values(model, scene, overrides, units, used_active, used_inactive, state)
    rules = parameter_rules(probe)  # the physical ranges, checked before any value is used
    _check_rules(rules, values, model, scene, units, overrides)

    initial = {s: 0.0 for s in model.state_names()}
    params = {p: values[p] for p in model.parameters}
    for src, file in ((model.initial, model.path), (scene.initial, scene.path)):
        for k, v in src.items():
            if k not in initial:
                raise SpecError(f"'{k}' is not a state{did_you_mean(k, initial)} (states: {', '.join(initial)})",
                                file=file,
                                field=f"initial.{k}")
            initial[k] = evaluate_initial(k, v, params, model.units, model.units.get(k),
                                          lambda fld, msg, f=file: SpecError(msg, file=f, field=fld))
    static = bool(scene.static if scene.static is not None else model.static)
    rs = ResolvedScene(model, scene, state, values, active_params, initial, static, rules)
    if static:  # the static equilibrium is at rest: every velocity (of reduced and kept coordinates)
        for k in rs.coordinate_states()[1]:
            if initial.get(k, 0.0) != 0.0:
                raise SpecError(f"static = true starts at rest: the velocity '{k}' must be 0 (or left out)",
                                file=scene.path if k in scene.initial else model.path, field=f"initial.{k}")
    return rs


def _used_names(model: ModelSpec, probe: ResolvedScene) -> tuple[set[str], dict[str, set[str]]]:
    """The names the active terms use (transitively through derived quantities and schedules), and
    for the others the effects whose switched-off terms use them."""
    used_active: set[str] = set()
    used_inactive: dict[str, set[str]] = {}
    for term, el_eff, el_var in _terms_with_owner(model):
        names = ex.names_in(term.expr)
        if probe.is_active(term, el_eff, el_var):
            used_active |= names
        else:
            for n in names:
                for e in (el_eff, term.effect):
                    if e is not None:
                        used_inactive.setdefault(n, set()).add(e)
    for expr in _structural_exprs(model):
        used_active |= ex.names_in(expr)
    frontier = set(used_active)
    while frontier:
        new: set[str] = set()
        for n in frontier:
            if n in model.derived:
                for t in model.derived[n].terms:
                    if probe.is_active(t):
                        new |= ex.names_in(t.expr)
            if n in model.tables:  # a table's scale, and the arguments its bare name stands for
                tb = model.tables[n]
                for e in (*((tb.scale,) if tb.scale else ()), *tb.arguments):
                    new |= ex.names_in(e)
            if n.endswith("_phase") or n.endswith("_segment"):
                sname = n.rsplit("_", 1)[0]
                if sname in model.schedules:
                    s = model.schedules[sname]
                    for e in (s.period, *s.breaks):
                        new |= ex.names_in(e)
        frontier = new - used_active
        used_active |= new
    # names reached only through derived quantities of switched-off terms belong to those effects
    changed = True
    while changed:
        changed = False
        for dname, d in model.derived.items():
            for t in d.terms:
                effs = set(used_inactive.get(dname, ()))
                if t.effect is not None and not probe.is_active(t):
                    effs.add(t.effect)
                for n in ex.names_in(t.expr) if effs else ():
                    cur = used_inactive.setdefault(n, set())
                    if not effs <= cur:
                        cur |= effs
                        changed = True
    return used_active, used_inactive


def _parameter_values(model: ModelSpec, scene: SceneSpec, overrides: Mapping[str, object] | None,
                      units: ParameterUnits, used_active: set[str], used_inactive: dict[str, set[str]],
                      state: Mapping[str, bool | str]) -> dict[str, float]:
    """SI value of every model parameter: the model's, then the scene's, then the overrides
    (numbers in the declared unit, or strings with a unit: :meth:`ParameterUnits.declared_value`)."""
    values = units.to_si({p.name: p.value for p in model.parameters.values()})
    for name, v in scene.parameters.items():
        if name not in model.parameters:
            raise SpecError(f"unknown parameter '{name}'{did_you_mean(name, model.parameters)} (model "
                            f"'{model.name}' has: {', '.join(model.parameters)})", file=scene.path,
                            field=f"parameters.{name}")
        values.update(units.to_si({name: float(v)}))  # the one conversion: declared -> SI
    for name, v in (overrides or {}).items():
        if name not in model.parameters:
            raise OverrideError(name, f"unknown parameter '{name}'{did_you_mean(name, model.parameters)} (model "
                                      f"'{model.name}' has: {', '.join(model.parameters)})", named=True)
        try:
            v = units.declared_value(name, v)
        except ValueError as exc:
            raise OverrideError(name, str(exc)) from None
        if not math.isfinite(v):
            raise OverrideError(name, f"non-finite value {v}")
        if name not in used_active and name in used_inactive:
            offs = ", ".join(sorted(e for e in used_inactive[name] if state.get(e) is False))
            raise OverrideError(name, f"parameter '{name}' is used only by switched-off effect(s) "
                                      f"{offs or ', '.join(sorted(used_inactive[name]))}; switch the effect "
                                      f"on to set it", named=True)
        values.update(units.to_si({name: v}))
    return values


class _OverrideRangeError(SpecError, OverrideError):
    """An override outside the physical range of the field that uses it: a :class:`SpecError`
    naming the model's field, and an :class:`OverrideError` naming the parameter (``--set NAME:``)."""

    def __init__(self, parameter: str, reason: str, message: str, file: str, field: str):
        spec = SpecError(message, file=file, field=field)  # its text and attributes, without the MRO's __init__ chain
        Exception.__init__(self, str(spec))
        self.message, self.file, self.field = spec.message, spec.file, spec.field
        named = OverrideError(parameter, reason)
        self.parameter, self.reason = named.parameter, named.reason


def _check_rules(rules: ParameterRules, values: Mapping[str, float], model: ModelSpec, scene: SceneSpec,
                 units: ParameterUnits, overrides: Mapping[str, object] | None) -> None:
    """The scene's parameter values against the physical ranges of the model (:mod:`gearsym.spec.rules`).

    A value set by an override is an :class:`OverrideError` naming it (``--set NAME: ...``);
    otherwise the model file and the field of the rule are named, and the scene file if a
    value comes from it.
    """
    broken = rules.violation(values)
    if broken is None:
        return
    rule, value = broken
    set_here = sorted(rule.names & set(overrides or {}))
    if set_here:
        raise _OverrideRangeError(set_here[0], rules.message(rule, value, values, units, file=model.path),
                                  rules.message(rule, value, values, units, with_field=False), model.path,
                                  rule.field)
    from_scene = sorted(rule.names & set(scene.parameters))
    note = f" (set in the scene {scene.path}: {', '.join(from_scene)})" if from_scene else ""
    raise SpecError(rules.message(rule, value, values, units, with_field=False) + note,
                    file=model.path, field=rule.field)


def _terms_with_owner(model: ModelSpec):
    for el in model.elements.values():
        owner, variant = el.effect, el.variant
        if owner is None:  # an element whose coordinates are all gated by one effect belongs to it
            effs = {model.coordinates[n].effect for n in element_type(el.type).acts_on(el) if n in model.coordinates}
            if len(effs) == 1 and None not in effs:
                owner = effs.pop()
        for terms in el.fields.values():
            for t in terms:
                yield t, owner, variant
    for eq in model.equations.values():
        for t in (*eq.mass, *eq.force):
            yield t, model.coordinates[eq.coordinate].effect, None
    if model.reduction is not None:
        for rc in model.reduction.coordinates:
            for t in rc.definition:
                yield t, rc.effect, rc.variant
    for o in model.outputs.values():
        for t in o.terms:
            yield t, None, None


def _structural_exprs(model: ModelSpec) -> list[str]:
    out = []
    if model.forcing_period:
        out.append(model.forcing_period)
    return out
