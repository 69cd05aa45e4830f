"""What an exported model needs to know about its scene, gathered once at export time.

:func:`collect` compiles the scene (reusing gearsym's build cache), evaluates everything
Python computes today (parameter values in SI units, bound functions such as the fractal
backlash height ``wm_mean_height``, the forcing period, the scene's simulation
defaults) and returns an :class:`ExportModel`, which :func:`data_header` writes as
``gs_export_data.h``: the sizes, names, units, default values and value references the
C program (``main.c``) and the FMU runtime (``fmu.c``, ``fmu_access.c``) are compiled with.
"""

from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

from ..errors import GearsymError
from ..integrators import EXPLICIT, IMPLICIT, INTEGRATION_METHODS, NONLINEAR, default_method, method_names
from ..spec.units import UnitSyntaxError, parse_unit

__all__ = ["OPTION_NAMES", "RESERVED_PROGRAM_NAMES", "ExportError", "ExportModel", "Quantity", "c_string",
           "collect", "data_header", "program_name"]

#: Names main.c reads as options; a parameter or state may not be called so.
OPTION_NAMES = ("periods", "t_end", "t0", "n_out", "points_per_period", "rtol", "atol", "method", "max_step",
                "max_steps")
_ANGLES = {"rad", "deg", "rev"}


class ExportError(GearsymError):
    """The scene or the target cannot be exported (bad input: exit code 2)."""

    exit_code = 2


@dataclass(frozen=True)
class Quantity:
    """A named number of the exported model (state, parameter, output, constant).

    Attributes
    ----------
    name
        C identifier used in the program, the CSV header and the FMU.
    value
        Default value in SI units (0 for outputs).
    unit
        SI unit (``"kg*m^2*s^-2"``, ``"rad"``), ``""`` for dimensionless.
    base
        Exponents of the SI base units ``{"kg": 1, "m": 2, "s": -2}`` (FMI BaseUnit), or
        ``None`` when an exponent is not an integer.
    description
        Meaning from the model file (with the declared unit when it is not SI).
    locked
        Why the value cannot change in the exported model (``""``: it can).
    """

    name: str
    value: float
    unit: str = ""
    base: dict[str, int] | None = None
    description: str = ""
    locked: str = ""


@dataclass
class ExportModel:
    """Everything the C project and the FMU writers need (see :func:`collect`)."""

    scene: str
    model: str
    description: str
    program: str
    generated_dir: Path
    states: list[Quantity]
    params: list[Quantity]
    extras: list[Quantity]
    outputs: list[Quantity]
    surfaces: list[tuple[str, str]]
    schedule_breaks: list[int]
    period: float | None
    implicit: bool
    defaults: dict[str, float | int | str]
    effects: dict[str, object]
    bound_notes: list[str] = field(default_factory=list)
    gearsym_version: str = ""
    time_unit: str = "s"
    #: per mesh element: its dynamic deflection ``mesh_deflection[NAME]`` (``gs_mesh``), then
    #: its force ``mesh_force[NAME]`` (``gs_mesh_force``): outputs of the FMU
    mesh_outputs: list[Quantity] = field(default_factory=list)
    #: the generated functions behind the FMU's outputs, in output order
    output_functions: tuple[str, ...] = ()

    @property
    def fmu_outputs(self) -> list[Quantity]:
        """The FMU's continuous outputs: the model's ``[outputs]``, then :attr:`mesh_outputs`."""
        return self.outputs + self.mesh_outputs

    @property
    def nx(self) -> int:
        """Number of states."""
        return len(self.states)

    @property
    def nominal(self) -> float:
        """Nominal magnitude of the states for importers' absolute tolerances
        (``atol = rtol * nominal``): the scene's ``atol / rtol``."""
        return float(self.defaults["atol"]) / float(self.defaults["rtol"])


# --------------------------------------------------------------------------- units
def si_unit(declared: str | None) -> tuple[str, dict[str, int] | None]:
    """The SI unit of a value declared in ``declared``: ``(name, base exponents)``.

    Angles keep ``rad`` (FMI has a base unit for it); other dimensionless units give ``""``.
    """
    if not declared:
        return "", None
    try:
        u = parse_unit(declared)
    except UnitSyntaxError:
        return "", None
    names = set(re.findall(r"[A-Za-z_]+", declared))
    rad = 1 if (names & _ANGLES or "rpm" in names) else 0
    if u.dimensionless and not rad:
        return "", None
    base: dict[str, int] | None = {}
    parts = []
    if rad:
        parts.append("rad")
        base["rad"] = 1
    for bname, d in zip(("kg", "m", "s"), u.dims):
        if d == 0:
            continue
        if Fraction(d).denominator != 1:
            base = None
        elif base is not None:
            base[bname] = int(d)
        parts.append(bname if d == 1 else f"{bname}^{d}")
    return "*".join(parts), base


def _describe(meaning: str, declared: str | None, si: str) -> str:
    d = meaning or ""
    if declared and declared not in ("1", "") and declared != si:
        d += f" (declared in {declared}; SI here)"
    return d.strip()


def _state_quantities(scene, names: list[str], x0) -> list[Quantity]:
    ms = scene.model_spec
    time_s = (getattr(ms, "time_unit", "s") or "s") == "s"
    decl: dict[str, tuple[str, str]] = {}
    for c in ms.coordinates.values():
        decl[c.name] = (c.unit, c.meaning)
        vel_unit = f"({c.unit})/s" if time_s and c.unit not in ("", "1") else ("1/s" if time_s else c.unit)
        decl[c.velocity] = (vel_unit, f"velocity of {c.name}")
    red = ms.reduction
    if red is not None:
        decl[red.coordinate] = (red.unit, red.meaning)
        vel_unit = f"({red.unit})/s" if time_s and red.unit not in ("", "1") else ("1/s" if time_s else red.unit)
        decl[red.velocity] = (vel_unit, f"velocity of {red.coordinate}")
    out = []
    for name, v in zip(names, x0):
        unit_decl, meaning = decl.get(name, ("", ""))
        si, base = si_unit(unit_decl)
        out.append(Quantity(name, float(v), si, base, meaning))
    return out


# ------------------------------------------------------------------------- collect
def _c_name(text: str) -> str:
    name = re.sub(r"\W+", "_", text).strip("_")
    return name if name and not name[0].isdigit() else f"p_{name}"


#: Names the exported program may not have: the files ``make`` reads as a makefile and the
#: Makefile's own targets (a program named ``Makefile`` would be built over the Makefile).
#: Compared case-insensitively (case-insensitive file systems).  The C project's other files
#: all have a suffix, which a program name (a C identifier) never has.
RESERVED_PROGRAM_NAMES = ("makefile", "gnumakefile", "all", "check", "clean")


def program_name(scene_name: str) -> str:
    """The exported program's name: the scene name as a C identifier, with ``_model`` appended
    when it would collide with a file or target of the exported project
    (:data:`RESERVED_PROGRAM_NAMES`)."""
    name = _c_name(scene_name)
    return f"{name}_model" if name.lower() in RESERVED_PROGRAM_NAMES else name


def collect(scene, generated_dir: str | Path | None = None) -> ExportModel:
    """Compile a scene (cached) and gather what the exported model needs.

    Parameters
    ----------
    scene
        A :class:`gearsym.Scene` (with its effects and parameter overrides).
    generated_dir
        Build root (default: gearsym's, see :func:`gearsym.facade.default_generated_dir`).

    Returns
    -------
    ExportModel

    Raises
    ------
    ExportError
        A name collides with one of main.c's options or with another name.
    """
    from .._version import __version__
    from ..bound_functions import IMPLEMENTATIONS

    system = scene.compile(generated_dir)
    gen = system.generated
    ms = scene.model_spec
    pvec = system.param_vector()
    si_params = system.units.to_si(system.params)  # the C program and the FMU take SI values
    period = system.period()
    bound_names = {name: (fn, list(args)) for name, (fn, args) in gen.bound.items()}
    bound_args = {a for _, args in bound_names.values() for a in args}

    def param_quantity(name: str, value: float, locked: str = "") -> Quantity:
        spec = ms.parameters.get(name)
        declared = spec.unit if spec is not None else None
        si, base = si_unit(declared)
        meaning = spec.meaning if spec is not None else ""
        return Quantity(name, float(value), si, base, _describe(meaning, declared, si), locked)

    def arg_text(args: list[str]) -> str:
        return ", ".join(f"{a} = {si_params[a]!r}" for a in args)

    params: list[Quantity] = []
    notes: list[str] = []
    for name, value in zip(gen.param_names, pvec):
        if name in bound_names:
            fn, args = bound_names[name]
            from ..spec.expressions import BOUND_FUNCTIONS

            dims = BOUND_FUNCTIONS.get(fn, (None, (0, 0, 0)))[1]
            unit = "*".join(f"{b}^{d}" if d != 1 else b for b, d in zip(("kg", "m", "s"), dims) if d)
            base = {b: d for b, d in zip(("kg", "m", "s"), dims) if d} or None
            doc = (IMPLEMENTATIONS[fn].__doc__ or "").strip().splitlines()
            lock = (f"{fn}({arg_text(args)}) was evaluated by gearsym at export time; "
                    f"re-export (gearsym export --set NAME=VALUE) to change its arguments")
            notes.append(f"{_c_name(name)} = {fn}({arg_text(args)}) = {float(value)!r} "
                         f"(SI units), evaluated by gearsym {__version__} at export time")
            params.append(Quantity(_c_name(name), float(value), unit, base,
                                   f"{name}: {doc[0] if doc else fn} [recorded at export]", lock))
        elif name in bound_args:
            fns = sorted(f for f, a in bound_names.values() if name in a)
            lock = f"argument of {', '.join(fns)}, evaluated at export time; re-export to change it"
            params.append(param_quantity(name, value, lock))
        else:
            params.append(param_quantity(name, value))
    extras = []
    for a in sorted(bound_args - set(gen.param_names), key=lambda s: list(ms.parameters).index(s)
                    if s in ms.parameters else 0):
        fns = sorted(f for f, args in bound_names.values() if a in args)
        extras.append(param_quantity(a, si_params[a],
                                     f"argument of {', '.join(fns)}, evaluated at export time; "
                                     f"re-export to change it"))
    outputs = []
    for name in gen.outputs:
        declared = gen.output_units.get(name) or ""
        si, base = si_unit(declared)
        spec = ms.outputs.get(name)
        outputs.append(Quantity(name, 0.0, si, base, _describe(spec.meaning if spec else "", declared, si)))
    states = _state_quantities(scene, gen.state_names, system.x0)
    mesh_outputs, out_fns = _mesh_outputs(scene, gen)
    sim = scene.spec.simulate
    method = default_method(gen.implicit, sim.get("method"))
    defaults: dict[str, float | int | str] = {
        "periods": float(sim.get("periods", 100)),
        "t_end": float(sim.get("t_end", 100.0)),
        "rtol": float(sim.get("rtol", 1e-8)),
        "atol": float(sim.get("atol", 1e-10)),
        "points_per_period": int(sim.get("points_per_period", 64)),
        "method": method,
        "max_steps": int(sim.get("max_steps", 0)),
    }
    em = ExportModel(
        scene=scene.name, model=ms.name, description=scene.spec.description or ms.description or scene.name,
        program=program_name(scene.name), generated_dir=Path(gen.directory), states=states, params=params,
        extras=extras, outputs=outputs, surfaces=[(s["name"], s.get("meaning", "")) for s in gen.surfaces],
        schedule_breaks=[int(s["n_breaks"]) for s in gen.schedules], period=period, implicit=gen.implicit,
        defaults=defaults, effects={k: v for k, v in scene.resolved.effects.items() if v is not False},
        bound_notes=notes, gearsym_version=__version__, time_unit=getattr(ms, "time_unit", "s") or "s",
        mesh_outputs=mesh_outputs, output_functions=(("gs_out",) if outputs else ()) + out_fns)
    _check_names(em)
    return em


def _mesh_units(scene, names: list[str]) -> dict[str, tuple[str, str]]:
    """SI units ``(deflection, force)`` of each mesh, from the dimensions of its expressions
    (``("", "")`` where they cannot be told)."""
    from ..spec.expressions import BOUND_FUNCTIONS
    from ..symbolic.dims import DimensionError, Dimensions

    sm = scene.model
    spec = sm.spec
    table = {}

    def dims(name: str):
        u = spec.units.get(name)
        return tuple(Fraction(d) for d in u.dims) if u is not None else (Fraction(0),) * 3

    for name, sym in sm.ns.params.items():
        table[sym] = dims(name)
    for sym in sm.ns.derived:
        table[sym] = dims(str(sym))
    for sym, (fname, _) in sm.ns.bound.items():  # a bound function's value (e.g. a mean flank height)
        table[sym] = tuple(Fraction(d) for d in BOUND_FUNCTIONS[fname][1])
    for sym in sm.states:
        table[sym] = dims(str(sym))
    table[sm.t] = tuple(Fraction(d) for d in spec.time_dims.dims)
    dz = Dimensions(table)

    def unit(e) -> str:
        try:
            d = dz(e)
        except DimensionError:
            return ""
        return "*".join(b if k == 1 else f"{b}^{k}" for b, k in zip(("kg", "m", "s"), d) if k)

    out = {}
    for name in names:
        defl = sm.mesh_deflections.get(name)
        force = sm.mesh_forces.get(name)
        out[name] = (unit(defl) if defl is not None else "", unit(force) if force is not None else "")
    return out


def _mesh_outputs(scene, gen) -> tuple[list[Quantity], tuple[str, ...]]:
    """The mesh deflections (``gs_mesh``) and mesh forces (``gs_mesh_force``) as outputs."""
    names = list(getattr(gen, "meshes", []) or [])
    if not names or "gs_mesh" not in gen.functions:
        return [], ()
    fns: tuple[str, ...] = ("gs_mesh",)
    has_force = "gs_mesh_force" in gen.functions
    if has_force:
        fns += ("gs_mesh_force",)
    units = _mesh_units(scene, names)
    out = []
    for name in names:
        si, base = si_unit(units[name][0])
        out.append(Quantity(f"mesh_deflection[{name}]", 0.0, si, base,
                            f"dynamic deflection of mesh {name} along its line of action (deflection - error)"))
    for name in names if has_force else ():
        si, base = si_unit(units[name][1])
        out.append(Quantity(f"mesh_force[{name}]", 0.0, si, base,
                            f"force of mesh {name} along its line of action: stiffness*f(delta) + damping*delta' "
                            f"(f the backlash dead zone)"))
    return out, fns


def _check_names(em: ExportModel) -> None:
    seen: dict[str, str] = {}
    for kind, items in (("state", em.states), ("parameter", em.params), ("parameter", em.extras),
                        ("output", em.outputs)):
        for q in items:
            if not q.name.isidentifier():
                raise ExportError(f"{kind} name '{q.name}' is not a C identifier")
            if q.name in OPTION_NAMES and kind != "output":
                raise ExportError(f"cannot export: the {kind} '{q.name}' has the name of an option of the "
                                  f"exported program ({', '.join(OPTION_NAMES)}); rename it in the model")
            if q.name in seen:
                raise ExportError(f"cannot export: '{q.name}' names both a {seen[q.name]} and a {kind}")
            seen[q.name] = kind


# ---------------------------------------------------------------------- C writing
def c_string(text: str) -> str:
    """``text`` as a C string literal (printable ASCII kept, everything else escaped)."""
    out = ['"']
    for ch in text:
        o = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif ch == "?":
            out.append("\\?")  # no trigraphs
        elif 32 <= o < 127:
            out.append(ch)
        else:
            for b in ch.encode("utf-8"):
                out.append(f"\\{b:03o}")
    out.append('"')
    return "".join(out)


def _c_double(v: float) -> str:
    if not math.isfinite(v):
        raise ExportError(f"cannot export the non-finite value {v}")
    r = repr(float(v))
    return r if ("." in r or "e" in r or "inf" in r) else r + ".0"


def _method_table(default: str) -> str:
    """The integration methods the exported program offers (:data:`gearsym.integrators.INTEGRATION_METHODS`):
    names, ``GS_METHOD_*`` and ``GS_NONLIN_*`` codes and the model forms of each, and the index of the
    scene's one (``GSX_DEFAULT_METHOD``)."""
    ms = list(INTEGRATION_METHODS.values())
    for m in ms:  # the names go into printf formats and C strings
        if not re.fullmatch(r"[a-z][a-z0-9_]*", m.name):
            raise ExportError(f"integration method name {m.name!r} is not a lower-case identifier")
    return "".join([
        "/* the integration methods (gearsym.integrators): name, GS_METHOD_* code, GS_NONLIN_* code, forms */\n",
        f"#define GSX_NMETHODS {len(ms)}\n",
        f"#define GSX_METHOD_CHOICES {c_string('|'.join(method_names()))}\n",
        f"#define GSX_METHOD_LIST {c_string(', '.join(method_names()))}\n",
        f"#define GSX_IMPLICIT_METHODS {c_string(' or '.join(method_names(IMPLICIT)))}\n",
        _arr("char* const", "gsx_method_names", [c_string(m.name) for m in ms]),
        _arr("int", "gsx_method_code", [str(m.code) for m in ms]),
        _arr("int", "gsx_method_nonlinear", [str(NONLINEAR[m.nonlinear[0]]) for m in ms]),
        _arr("int", "gsx_method_explicit", ["1" if EXPLICIT in m.forms else "0" for m in ms]),
        _arr("int", "gsx_method_implicit", ["1" if IMPLICIT in m.forms else "0" for m in ms]),
        f"#define GSX_DEFAULT_METHOD {list(INTEGRATION_METHODS).index(default)}\n",
    ])


def _arr(ctype: str, name: str, items: list[str]) -> str:
    body = ", ".join(items + ["0"])
    return f"static const {ctype} {name}[{len(items) + 1}] = {{{body}}};\n"


def guid_of(*texts: str) -> str:
    """A GUID ``{8-4-4-4-12}`` from the hash of the given texts."""
    h = hashlib.sha256("\0".join(texts).encode()).hexdigest()
    return "{" + f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}" + "}"


def data_header(em: ExportModel, guid: str = "", outx: bool = False, fmu: bool = False) -> str:
    """The text of ``gs_export_data.h`` for this model.

    Parameters
    ----------
    em
        The collected model.
    guid
        The FMU's GUID (``""`` for the C project).
    outx
        Whether ``gsx_out`` / ``gsx_outx`` (the FMU's outputs and their Jacobian) are
        compiled in.
    fmu
        For the FMU: the outputs are :attr:`ExportModel.fmu_outputs` (the model's outputs and
        the mesh outputs); for the C program the model's ``[outputs]``.
    """
    outputs = em.fmu_outputs if fmu else em.outputs
    nx, np_, nsw = em.nx, len(em.params), len(em.surfaces)
    nsched = len(em.schedule_breaks)
    nsched_total = sum(1 + b for b in em.schedule_breaks)
    d = em.defaults
    lines = [
        "/*\n * gs_export_data.h -- sizes, names, units, defaults and value references of the\n"
        f" * exported gearsym model '{_c_comment(em.scene)}' (generated by gearsym {em.gearsym_version}"
        " export; do not edit).\n *\n * All values are in SI units.\n */\n",
        "#ifndef GS_EXPORT_DATA_H\n#define GS_EXPORT_DATA_H\n\n",
        f"#define GSX_PROGRAM {c_string(em.program)}\n",
        f"#define GSX_DESCRIPTION {c_string(em.description)}\n",
        f"#define GSX_GUID {c_string(guid)}\n",
        f"#define GSX_NX {nx}\n#define GSX_NP {np_}\n#define GSX_NSW {nsw}\n#define GSX_NSCHED {nsched}\n",
        "#define GSX_NM (GSX_NSW + 2 * GSX_NSCHED)\n",
        f"#define GSX_NSCHED_TOTAL {nsched_total}\n#define GSX_NOUT {len(outputs)}\n",
        f"#define GSX_NEXTRA {len(em.extras)}\n",
        f"#define GSX_HAS_PERIOD {1 if em.period else 0}\n#define GSX_HAS_OUTX {1 if outx else 0}\n",
        f"#define GSX_IMPLICIT {1 if em.implicit else 0}\n\n",
        "/* FMI value references: Real */\n",
        "#define GSX_VR_DER (GSX_NX)\n#define GSX_VR_PAR (2 * GSX_NX)\n",
        "#define GSX_VR_EXTRA (GSX_VR_PAR + GSX_NP)\n#define GSX_VR_PERIOD (GSX_VR_EXTRA + GSX_NEXTRA)\n",
        "#define GSX_VR_OUT (GSX_VR_PERIOD + GSX_HAS_PERIOD)\n#define GSX_VR_END (GSX_VR_OUT + GSX_NOUT)\n",
        "/* FMI value references: Integer (sides sigma_j, then the event count) */\n",
        "#define GSX_IVR_NEVENTS (GSX_NSW)\n\n",
        "/* the scene's simulation defaults */\n",
        f"#define GSX_DEFAULT_PERIODS {_c_double(float(d['periods']))}\n",
        f"#define GSX_DEFAULT_T_END {_c_double(float(d['t_end']))}\n",
        f"#define GSX_DEFAULT_T_END_STR {c_string(repr(float(d['t_end'])))}\n",
        f"#define GSX_DEFAULT_RTOL {_c_double(float(d['rtol']))}\n",
        f"#define GSX_DEFAULT_ATOL {_c_double(float(d['atol']))}\n",
        f"#define GSX_DEFAULT_PPP {int(d['points_per_period'])}\n",
        _method_table(str(d["method"])),
        f"#define GSX_DEFAULT_MAX_STEPS {int(d['max_steps'])}L\n\n",
        _arr("char* const", "gsx_state_names", [c_string(q.name) for q in em.states]),
        _arr("char* const", "gsx_state_units", [c_string(q.unit) for q in em.states]),
        _arr("double", "gsx_x0", [_c_double(q.value) for q in em.states]),
        _arr("double", "gsx_nominal", [_c_double(em.nominal) for _ in em.states]),
        _arr("char* const", "gsx_param_names", [c_string(q.name) for q in em.params]),
        _arr("char* const", "gsx_param_units", [c_string(q.unit) for q in em.params]),
        _arr("double", "gsx_p_default", [_c_double(q.value) for q in em.params]),
        _arr("int", "gsx_p_locked", ["1" if q.locked else "0" for q in em.params]),
        _arr("char* const", "gsx_p_lock_note", [c_string(q.locked) for q in em.params]),
        _arr("char* const", "gsx_extra_names", [c_string(q.name) for q in em.extras]),
        _arr("char* const", "gsx_extra_units", [c_string(q.unit) for q in em.extras]),
        _arr("double", "gsx_extra_value", [_c_double(q.value) for q in em.extras]),
        _arr("char* const", "gsx_extra_note", [c_string(q.locked) for q in em.extras]),
        _arr("char* const", "gsx_output_names", [c_string(q.name) for q in outputs]),
        _arr("char* const", "gsx_surface_names", [c_string(s) for s, _ in em.surfaces]),
        _arr("int", "gsx_sched_nb", [str(b) for b in em.schedule_breaks]),
        "\n#endif\n",
    ]
    return "".join(lines)


def _c_comment(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_ .,:;()+=-]", "_", text)
