"""The parts of ``gearsym inspect`` beyond the equations: Jacobian structure, the symbolic
Jacobian (``--jacobian``) and the dimensionless form with its groups and scales."""

from __future__ import annotations

from typing import Any

import sympy as sp


def jacobian_structure(m) -> dict[str, Any]:
    """Structural sparsity of the Jacobian of a symbolic model.

    Entry ``(i, j)`` is ``*`` when row ``i`` of the right-hand side depends on state ``j``
    in some mode (for an implicit model: the residual on the state or its derivative,
    i.e. ``dr/dx + cj dr/dx'``), ``.`` otherwise.

    Parameters
    ----------
    m
        A :class:`~gearsym.symbolic.model.SymbolicModel`.

    Returns
    -------
    dict
        ``form``, ``states``, ``pattern`` (one string per row), ``nnz``, ``size``.
    """
    states = list(m.states)
    n = len(states)
    if m.form == "explicit":
        rows = list(m.modal.rhs)
        xd: list[sp.Symbol] = []
        form = "d f / d x"
    else:
        xd = [sp.Dummy(f"{s}_dot") for s in states]
        rows = list(m.residual(xd))
        form = "d r / d x + cj d r / d x'"
    pattern, nnz = [], 0
    for r in rows:
        free = r.free_symbols
        row = ""
        for j, s in enumerate(states):
            on = s in free or (bool(xd) and xd[j] in free)
            nnz += on
            row += "*" if on else "."
        pattern.append(row)
    return {"form": form, "states": [str(s) for s in states], "pattern": pattern, "nnz": nnz, "size": n * n}


def symbolic_jacobian(m) -> dict[str, str]:
    """The non-zero entries of the Jacobian, written with the model's derived quantities.

    Parameters
    ----------
    m
        A :class:`~gearsym.symbolic.model.SymbolicModel`.

    Returns
    -------
    dict
        ``"J[row state, column state]"`` -> expression (``cj`` multiplies ``dr/dx'`` in an
        implicit model).
    """
    sm = m.structured_model
    if sm.form == "explicit":
        J = sm.modal.rhs.jacobian(sm.states)
    else:
        xd = [sp.Symbol(f"{s}'", real=True) for s in sm.states]
        r = sm.residual(xd)
        J = r.jacobian(sm.states) + sp.Symbol("cj") * r.jacobian(xd)
    return {f"J[{sm.states[i]}, {sm.states[j]}]": sp.sstr(J[i, j])
            for i in range(J.shape[0]) for j in range(J.shape[1]) if J[i, j] != 0}


def inspect_details(m, jacobian: bool = False) -> dict[str, Any]:
    """The ``inspect --json`` keys of the Jacobian and the dimensionless form.

    Parameters
    ----------
    m
        A :class:`~gearsym.symbolic.model.SymbolicModel`.
    jacobian
        Also the symbolic Jacobian (key ``jacobian``).
    """
    info: dict[str, Any] = {"jacobian_structure": jacobian_structure(m)}
    if jacobian:
        info["jacobian"] = symbolic_jacobian(m)
    if m.table_display:  # not derived for tables (SymbolicModel.dimensionless says why)
        info["dimensionless_form"] = "not derived: the equations use tables (their values carry units)"
        return info
    d = m.dimensionless()
    info.update({
        "dimensionless_groups": {k: sp.sstr(v) for k, v in d.definitions.items()},
        "dimensionless_group_values": dict(d.values),
        "dimensionless_equations": d.equations(),
        "dimensionless_switching_functions": [sp.sstr(g) for g in d.switching],
        "dimensionless_scales": {k: sp.sstr(v) for k, v in d.scales.items()},
        "dimensionless_scale_values": dict(d.scale_values),
        "dimensionless_scale_origin": dict(d.origin),
        "dimensionless_seconds": d.seconds,
    })
    return info


def print_details(info: dict[str, Any], surfaces: list[str]) -> None:
    """Print what :func:`inspect_details` returned (text form of ``inspect``)."""
    js = info["jacobian_structure"]
    print(f"Jacobian structure ({js['form']}: {js['nnz']} of {js['size']} entries depend on the state):")
    width = max(len(n) for n in js["states"])
    print(f"  {'':>{width}s}   {' '.join(s[:1] for s in js['states'])}")
    for name, row in zip(js["states"], js["pattern"]):
        print(f"  {name:>{width}s} | {' '.join(row)}")
    if "jacobian" in info:
        print("Jacobian (non-zero entries):")
        for k, v in info["jacobian"].items():
            print(f"  {k} = {v}")
    if "dimensionless_form" in info:
        print(f"dimensionless form: {info['dimensionless_form']}")
        return
    print(f"dimensionless form (t = t_ref*tau, each coordinate its reference times the dimensionless one; "
          f"derived in {info['dimensionless_seconds']:.2f} s):")
    for eq in info["dimensionless_equations"]:
        print(f"  {eq}")
    for name, g in zip(surfaces, info["dimensionless_switching_functions"]):
        print(f"  g[{name}] = {g}")
    print("  groups (definition = value at the scene's parameters):")
    for k, v in info["dimensionless_groups"].items():
        print(f"    {k} = {v} = {info['dimensionless_group_values'][k]:.6g}")
    print("  reference scales (= SI value; how chosen):")
    for k, v in info["dimensionless_scales"].items():
        print(f"    {k}: {v} = {info['dimensionless_scale_values'][k]:.6g}  "
              f"({info['dimensionless_scale_origin'].get(k, '')})")
