"""The gear quantities on the command line: ``simulate --gear-quantities / --quantity``, ``orbit``,
``continue --quantity`` (definitions: :mod:`gearsym.quantities`)."""

from __future__ import annotations

import math

from ..errors import ParameterError

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

    from ..quantities import GearQuantities

__all__ = ["QUANTITY_HELP", "add_branch_quantity", "check_quantities", "print_quantities", "quantity_values"]

#: The help of the ``--quantity`` options.
QUANTITY_HELP = ("a gear quantity per mesh: dynamic_factor, dynamic_factor_rms, dte_rms, dte_mean, dte_peak_to_peak, "
                 "dte_harmonic_<h>, static_deflection, static_force, force_max, force_rms, contact_loss_ratio, "
                 "back_contact_ratio, impact_count, impacts_per_period, impact_velocity_max, load_sharing_factor; "
                 "NAME[MESH] for one mesh (definitions: gearsym.quantities)")


def check_quantities(values: list[str] | None, flag: str) -> list[str]:
    """The names of a repeatable, comma-separated ``--quantity`` option, each checked (exit 2 before
    any work on an unknown one).

    Parameters
    ----------
    values
        The option's values (``None``: not given).
    flag
        The option, for the message.

    Returns
    -------
    list of str
    """
    from ..quantities import parse_quantity

    names = [n.strip() for v in (values or []) for n in v.split(",") if n.strip()]
    for n in names:
        try:
            parse_quantity(n)
        except ParameterError as exc:
            raise ParameterError(f"{flag}: {exc}") from None
    return names


def quantity_values(gq: GearQuantities, names: list[str]) -> dict[str, dict[str, float | None]]:
    """``{name: {mesh: value}}`` (JSON-ready: NaN as ``None``) of the named quantities.

    Parameters
    ----------
    gq
        The gear quantities.
    names
        Quantity names (a mesh in brackets restricts to it).

    Returns
    -------
    dict
    """
    from ..quantities import parse_quantity

    out: dict[str, dict[str, float | None]] = {}
    for name in names:
        base, mesh = parse_quantity(name)
        meshes = [mesh] if mesh else list(gq.meshes)
        out[name] = {m: _json(gq[m].value(base)) for m in meshes}
    return out


def _json(v: float) -> float | None:
    return None if math.isnan(v) else float(v)


def print_quantities(gq: GearQuantities, names: list[str] | None = None) -> None:
    """Print the gear quantities per mesh: the named ones, else a summary line per mesh.

    Parameters
    ----------
    gq
        The gear quantities.
    names
        Quantity names (default: the summary).
    """
    print(f"gear quantities over t = {gq.t_start:.8g} .. {gq.t_end:.8g} ({gq.periods:g} forcing periods):")
    if names:
        for name, per_mesh in quantity_values(gq, names).items():
            print(f"  {name}: " + ", ".join(f"{m} {_fmt(v)}" for m, v in per_mesh.items()))
    else:
        for m, q in gq.meshes.items():
            parts = [f"dynamic factor {_fmt(q.dynamic_factor)} (RMS {_fmt(q.dynamic_factor_rms)})",
                     f"static force {_fmt(q.static_force)}", f"DTE RMS {_fmt(q.dte_rms)}",
                     f"order 1 {_fmt(q.dte_harmonics[0] if len(q.dte_harmonics) else math.nan)}"]
            if q.contact_loss_ratio is not None:
                parts += [f"contact loss {_fmt(q.contact_loss_ratio)}", f"back contact {_fmt(q.back_contact_ratio)}",
                          f"impacts {q.impact_count} (max speed {_fmt(q.impact_velocity_max)})"]
            if q.load_sharing_factor is not None:
                parts.append(f"load sharing {_fmt(q.load_sharing_factor)}")
            print(f"  {m}: " + ", ".join(parts))
    for note in gq.notes:
        print(f"  note: {note}")


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    v = float(v)
    return "nan" if math.isnan(v) else f"{v:.6g}"


def add_branch_quantity(branch: Any, data: dict[str, Any], name: str) -> None:
    """Add ``continue --quantity NAME`` to the branch's JSON: ``quantity`` (the name) at the top of
    every branch, and per point ``quantity_value`` and ``gear_quantities`` (each mesh's scalars).

    Parameters
    ----------
    branch
        The :class:`~gearsym.Branch` (with its children, as in ``data``).
    data
        Its :meth:`~gearsym.Branch.to_dict`, changed in place.
    name
        The quantity.
    """
    data["quantity"] = name
    values = branch.quantity(name)
    for pd, gq, v in zip(data["points"], branch.gear_quantities(), values, strict=True):
        pd["quantity_value"] = _json(float(v))
        pd["gear_quantities"] = None if gq is None else gq.to_dict(events=False)["meshes"]
    for child, cd in zip(branch.children, data.get("children", [])):
        add_branch_quantity(child, cd, name)
