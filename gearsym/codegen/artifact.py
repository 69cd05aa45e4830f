"""The product of code generation: :class:`GeneratedModel` (metadata, serialised functions).

Kept apart from :mod:`gearsym.codegen.generate` (which needs sympy) so that the build
cache (:mod:`gearsym.codegen.cache`) can load a cached build without importing the
generator; :mod:`gearsym.codegen.generate` re-exports both names.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field

import casadi as ca
import numpy as np

__all__ = ["CODEGEN_VERSION", "GeneratedModel", "decode_schedules", "generated_map"]

#: Bump when the generated code's layout changes (invalidates caches).
CODEGEN_VERSION = "4"

@dataclass
class GeneratedModel:
    """What the compiler produced, and everything needed to run it without sympy.

    Attributes
    ----------
    directory, so_path
        Where the sources and the shared object are.
    state_names, param_names
        Order of the state and parameter vectors of the generated functions.
    surfaces
        One dict per switching function: ``name``, ``kind`` (drive/back/switch),
        ``contact_sign``, ``meaning``, ``expr``, ``field`` (the spec field it is written in, if known).
    schedules
        One dict per schedule: ``name``, ``n_breaks``.
    implicit
        True for mass-matrix (IDA) models.
    n_ops
        Operation counts of the generated functions.
    functions
        Serialized CasADi functions (for evaluation from Python).
    """

    scene: str
    key: str
    directory: str
    so_path: str
    state_names: list[str]
    param_names: list[str]
    surfaces: list[dict]
    schedules: list[dict]
    implicit: bool
    n_ops: dict[str, int]
    effects: dict[str, object]
    compile_seconds: float = 0.0
    cached: bool = False
    functions: dict[str, str] = field(default_factory=dict, repr=False)
    #: parameters that are numeric functions of other parameters, evaluated at bind
    #: time (:mod:`gearsym.bound_functions`): name -> [function name, [argument names]]
    bound: dict[str, list] = field(default_factory=dict)
    #: names of the model's [outputs] (evaluated by ``gs_out``), with their units
    outputs: list[str] = field(default_factory=list)
    output_units: dict[str, str] = field(default_factory=dict)
    #: mesh elements (``gs_mesh`` gives their dynamic deflections) and rigid-body modes
    #: (``gs_rigid``; coefficients as text), see :mod:`gearsym.codegen.extras`
    meshes: list[str] = field(default_factory=list)
    rigid_modes: list[dict] = field(default_factory=list)
    #: the full build key (64 hex digits; ``key`` is its first 16), compiled into the
    #: object as ``gs_build_key()`` (:func:`gearsym.codegen.cache.build_key`)
    build_key: str = ""
    #: SHA-256 of the shared object, checked before it is loaded
    so_sha256: str = ""
    #: what the key was computed from (versions, toolchain, model hash, effects)
    key_parts: dict = field(default_factory=dict)
    model: str = ""
    built: float = 0.0
    #: the generated functions are in dimensionless variables (``gs_scales`` converts)
    dimensionless: bool = False
    #: algebraic variables of a DAE model (the last states; IDA's id vector is 0 there)
    algebraic: list[str] = field(default_factory=list)

    @property
    def input_names(self) -> list[str]:
        """Parameters a caller sets: ``param_names`` without the bound ones, plus the
        arguments of the bound ones."""
        out = [p for p in self.param_names if p not in self.bound]
        for _, args in self.bound.values():
            out += [a for a in args if a not in out]
        return out

    @property
    def nx(self) -> int:
        """Number of states."""
        return len(self.state_names)

    @property
    def nsw(self) -> int:
        """Number of switching functions."""
        return len(self.surfaces)

    @functools.cached_property
    def contact_surfaces(self) -> tuple[tuple[int, str, str, str, int], ...]:
        """``(index, name, mesh, kind, contact_sign)`` of every drive / back contact surface
        (``kind`` as the symbolic layer names it; ``mesh`` the name before the last dot)."""
        return tuple((j, s["name"], s["name"].rsplit(".", 1)[0], s.get("kind"), int(s.get("contact_sign", 0)))
                     for j, s in enumerate(self.surfaces) if s.get("kind") in ("drive", "back"))

    def casadi_function(self, name: str) -> ca.Function:
        """A generated function as a CasADi Function (e.g. ``gs_rhs``), for Python-side use."""
        if name not in self._fn_cache:
            if name not in self.functions:
                raise KeyError(f"no generated function '{name}' (have: {', '.join(self.functions)})")
            self._fn_cache[name] = ca.Function.deserialize(self.functions[name])
        return self._fn_cache[name]

    def __post_init__(self) -> None:
        self._fn_cache: dict[str, ca.Function] = {}

    def to_json(self) -> str:
        """Serialise (for the compile cache)."""
        d = asdict(self)
        return json.dumps(d, indent=1)

    @classmethod
    def from_json(cls, text: str) -> GeneratedModel:
        """Load from :meth:`to_json` output (a build's ``meta.json``; its ``signature``, added
        by :mod:`gearsym.codegen.cache` when the build is installed, is not a field)."""
        d = json.loads(text)
        d.pop("signature", None)
        return cls(**d)


_MAPPED: dict[tuple[str, str, int], object] = {}


def generated_map(generated: GeneratedModel, name: str, n: int):
    """``generated.casadi_function(name).map(n)``, cached by build, function and size."""
    key = (generated.so_path, name, int(n))
    f = _MAPPED.get(key)
    if f is None:
        if len(_MAPPED) > 256:
            _MAPPED.clear()
        fn = generated.casadi_function(name)
        f = _MAPPED[key] = fn if n == 1 else fn.map(int(n))
    return f


def decode_schedules(s: Sequence[float] | np.ndarray, schedules: Sequence[Mapping]) -> list[tuple[float, np.ndarray]]:
    """The one decoder of the ``gs_sched`` vector: ``[(period, break fractions), ...]`` per schedule.

    Parameters
    ----------
    s
        The vector ``[P_0, c_0..., P_1, c_1..., ...]`` of the generated ``gs_sched``.
    schedules
        The model's schedules (``GeneratedModel.schedules``: ``n_breaks`` of each).

    Returns
    -------
    list of (float, ndarray)
    """
    v = np.asarray(s, float).ravel()
    out = []
    i = 0
    for sch in schedules:
        k = int(sch["n_breaks"])
        out.append((float(v[i]), v[i + 1: i + 1 + k].copy()))
        i += 1 + k
    return out
