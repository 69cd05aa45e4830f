"""``gearsym map``: two-parameter stability / response maps."""

from __future__ import annotations

import argparse

from ..errors import ConvergenceError
from . import checks
from .checks import emit, load

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

__all__ = ["cmd_map"]


def cmd_map(args: argparse.Namespace) -> int:
    """Two-parameter stability / response map (netCDF + heat-map PNG)."""
    import numpy as np

    from ..analysis.sweeps import save_map, stability_map

    xa, ya = checks.check_map(args)
    scene = load(args)
    opts: dict[str, Any] = {}
    if args.harmonics is not None:
        opts["harmonics"] = args.harmonics
    if args.rtol is not None:
        opts["rtol"] = args.rtol
    # only the options the user typed: stability_map resolves the rest from the scene's [map]
    ds = stability_map(scene, xa, ya, quantity=args.quantity, method=args.method, periods=args.periods,
                       dask=args.dask, workers=args.workers, orbit_options=opts)
    quantity = str(ds.attrs["quantity"])
    if int(ds.attrs["n_failed"]) >= int(ds.attrs["n_points"]):
        # nothing computed: no all-NaN map files, exit 1 with the first errors
        first = str(ds.attrs.get("errors", "")).splitlines()[:1]
        raise ConvergenceError(f"every one of the {int(ds.attrs['n_points'])} points of the map failed"
                               + (f"; first error at {first[0]}" if first else ""))
    files = save_map(ds, args.out)
    q = ds[quantity].values.astype(float)
    if quantity != "max_multiplier":
        q[ds["response"].values != 1] = np.nan  # a response quantity: of stable responses only
    mm = ds["max_multiplier"].values
    info = {
        "scene": scene.name,
        "x": {"name": xa[0], "lo": xa[1], "hi": xa[2], "n": xa[3]},
        "y": {"name": ya[0], "lo": ya[1], "hi": ya[2], "n": ya[3]},
        "quantity": quantity,
        "min": float(np.nanmin(q)) if np.isfinite(q).any() else None,
        "max": float(np.nanmax(q)) if np.isfinite(q).any() else None,
        "fraction_unstable": float(np.mean(ds["stable"].values[np.isfinite(mm)] == 0))
        if np.isfinite(mm).any() else None,
        "n_points": int(ds.attrs["n_points"]),
        "n_failed": int(ds.attrs["n_failed"]),
        "n_no_stable_response": int(ds.attrs["n_no_stable_response"]),
        "methods_used": ds.attrs["methods_used"],
        "runner": ds.attrs["runner"],
        "wall_s": float(ds.attrs["wall_s"]),
        "files": [str(f) for f in files],
    }
    if args.json:
        emit(info)
    else:
        print(f"{scene.name}: {quantity} on {xa[3]} x {ya[3]} points ({info['methods_used']}, "
              f"{info['runner']}) in {info['wall_s']:.2f} s; range [{info['min']}, {info['max']}], "
              f"unstable fraction {info['fraction_unstable']}, failed {info['n_failed']}, no stable periodic "
              f"response at {info['n_no_stable_response']} point(s) (hatched, no {args.quantity} shown there"
              f"{'' if quantity != 'max_multiplier' else ' as a response'})")
        for f in info["files"]:
            print(f"wrote {f}")
    return 0
