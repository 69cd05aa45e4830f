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
                       dask=args.dask, workers=args.workers, orbit_options=opts, search=args.search,
                       progress=False if args.no_progress else None)
    quantity = str(ds.attrs["quantity"])
    if int(ds.attrs["n_failed"]) >= int(ds.attrs["n_points"]):
        # nothing computed: no all-NaN map files, exit 1 with the first errors
        first = str(ds.attrs.get("errors", "")).splitlines()[:1]
        raise ConvergenceError(f"every one of the {int(ds.attrs['n_points'])} points of the map failed"
                               + (f"; first error at {first[0]}" if first else ""))
    files = save_map(ds, args.out)
    q = ds[quantity].values.astype(float)
    if quantity == "lyapunov":
        q[~np.isfinite(q)] = np.nan  # (also where the attractor is not an orbit: a chaotic one has one)
    elif quantity != "max_multiplier":
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
        "points_per_second": float(ds.attrs["points_per_second"]),
        "orbit_solves": int(ds.attrs["orbit_solves"]),
        "periods_integrated": int(ds.attrs["periods_integrated"]),
        "search": ds.attrs["coexist_search"],
        **_coexistence(ds),
        "files": [str(f) for f in files],
    }
    if args.json:
        emit(info)
    else:
        print(f"{scene.name}: {quantity} on {xa[3]} x {ya[3]} points ({info['methods_used']}, "
              f"{info['runner']}) in {info['wall_s']:.2f} s; range [{info['min']}, {info['max']}], "
              f"unstable fraction {info['fraction_unstable']}, failed {info['n_failed']}, no stable periodic "
              f"response at {info['n_no_stable_response']} point(s) (hatched, no {quantity} shown there"
              f"{'' if quantity != 'max_multiplier' else ' as a response'})")
        if "n_coexisting" in info:
            print(f"coexistence search ({info['search']}): {info['n_coexisting']} point(s) with coexisting stable "
                  f"responses (at most {info['max_stable']}), {info['n_chaotic']} with a chaotic and "
                  f"{info['n_quasi_periodic']} with a quasi-periodic attractor; {info['orbit_solves']} orbit "
                  f"solves, {info['periods_integrated']} forcing periods integrated")
        else:
            print("coexistence search off (--search all to list every stable response at each point)")
        for f in info["files"]:
            print(f"wrote {f}")
    return 0


def _coexistence(ds: Any) -> dict[str, Any]:
    """The coexistence summary of a map (empty without the search): counts and, per point with
    several stable responses, their rattle states and periods."""
    if "n_stable" not in ds:
        return {}
    yname, xname = ds["n_stable"].dims
    points = []
    n = ds["n_stable"].values
    for j, i in zip(*((n >= 2).nonzero()), strict=True):
        kinds = ds["attractor_kind"].values[j, i]
        per = kinds == 0
        points.append({xname: float(ds[xname].values[i]), yname: float(ds[yname].values[j]),
                       "rattle_states": ds["attractor_rattle_state"].values[j, i][per].tolist(),
                       "periods": ds["attractor_periods"].values[j, i][per].tolist(),
                       "max_multipliers": ds["attractor_max_multiplier"].values[j, i][per].tolist()})
    return {"n_coexisting": int(ds.attrs["n_coexisting"]), "max_stable": int(ds.attrs["max_stable"]),
            "n_chaotic": int(ds.attrs["n_chaotic"]), "n_quasi_periodic": int(ds.attrs["n_quasi_periodic"]),
            "coexisting": points[:200]}
