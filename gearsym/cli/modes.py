"""``gearsym modes``: natural frequencies and mode shapes about the static equilibrium."""

from __future__ import annotations

import argparse

from ..budget import check_count
from .checks import emit, load

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = ["cmd_modes"]


def cmd_modes(args: argparse.Namespace) -> int:
    """Natural frequencies and mode shapes about the static equilibrium (mean mesh stiffness)."""
    from ..analysis.linear import classify_planetary, modal_analysis

    if args.samples is not None:
        check_count("--samples", args.samples)  # before any work (memory and time grow with it)
    scene = load(args)
    res = classify_planetary(modal_analysis(scene.compile(), samples=args.samples, where=(scene.spec.path, None)))
    if args.json:
        emit({"scene": scene.name, **res.to_dict()})
    else:
        print(res.table(scene.name, "Hz" if scene.model_spec.time_unit == "s" else "1/time"))
    return 0
