"""Generated functions for the analyses (not used by the C driver).

* ``gs_rigid(p)``: the rigid-body modes of the model's coordinates, one column per
  mode (``n_q x k``, see :mod:`gearsym.symbolic.rigid`), at the parameter values ``p``;
  only when the model has rigid-body modes.
* ``gs_mesh(t, x, p, m)``: the dynamic deflection (deflection - error) of every mesh
  element, in the order of ``GeneratedModel.meshes``; only when the model has meshes.
* ``gs_mesh_force(t, x, p, m)``: the force of every mesh element along its line of action,
  ``stiffness*f(delta) + damping*delta'`` (``f`` the backlash dead zone), in the same order
  (exported FMUs give it as outputs); only when every mesh's force is known.
"""

from __future__ import annotations

import casadi as ca

from ..symbolic.model import SymbolicModel
from .sx import SXTranslator

__all__ = ["DOCS", "analysis_functions"]

DOCS = {
    "gs_rigid": "rigid-body modes R(p) (columns, coordinates x modes): span{[R;0],[0;R]} of the state",
    "gs_mesh": "dynamic deflection (deflection - error) of every mesh element, for per-mesh results",
    "gs_mesh_force": "force k*f(delta) + c*delta' of every mesh element along its line of action",
}


def analysis_functions(model: SymbolicModel, tr: SXTranslator, t: ca.SX, x: ca.SX, p: ca.SX,
                       m: ca.SX) -> dict[str, ca.Function]:
    """``gs_rigid`` and ``gs_mesh`` of a model (see the module docstring)."""
    fns: dict[str, ca.Function] = {}
    R = getattr(model, "rigid_modes", None)
    if R is not None and R.cols:
        fns["gs_rigid"] = ca.Function("gs_rigid", [p], [ca.densify(tr.matrix(R))], ["p"], ["R"])
    meshes = getattr(model, "mesh_deflections", {})
    if meshes:
        d = ca.vertcat(*[tr(e) for e in meshes.values()])
        fns["gs_mesh"] = ca.Function("gs_mesh", [t, x, p, m], [d], ["t", "x", "p", "m"], ["delta"])
        forces = getattr(model, "mesh_forces", {})
        if list(forces) == list(meshes):  # every mesh's force is known in the final states
            w = ca.vertcat(*[tr(e) for e in forces.values()])
            fns["gs_mesh_force"] = ca.Function("gs_mesh_force", [t, x, p, m], [w], ["t", "x", "p", "m"], ["W"])
    return fns


def analysis_meta(model: SymbolicModel) -> dict[str, object]:
    """The ``GeneratedModel`` fields describing :func:`analysis_functions`."""
    import sympy as sp

    return {"meshes": list(getattr(model, "mesh_deflections", {})),
            "rigid_modes": [{k: sp.sstr(v) for k, v in mode.items()}
                            for mode in getattr(model, "rigid_body_modes", [])]}
