"""Generated models outside Python: a standalone C project and an FMI 2.0 FMU (Model Exchange
and Co-Simulation).

``gearsym export SCENE --c DIR`` writes a C project (generated model, gearsym's driver, a
command-line ``main.c``, a Makefile, and the SUNDIALS libraries it links in ``lib/``, found
through the run path ``$ORIGIN/lib``) that builds and runs without Python and without the
environment that exported it; ``gearsym export SCENE --fmu FILE.fmu`` writes an FMU whose
runtime applies gearsym's mode-switch rule in the FMI event update (Model Exchange) or
integrates each communication step with gearsym's driver (Co-Simulation), with the mesh
deflections and mesh forces as outputs.  Everything Python computes for a simulation
(parameters in SI units, bound functions such as the fractal backlash height, the scene's
defaults) is evaluated at export time; the forcing period and the outputs are generated C.

>>> import gearsym                                                   # doctest: +SKIP
>>> from gearsym.export import export_scene                          # doctest: +SKIP
>>> export_scene(gearsym.load_scene("scenes/kahraman_singh.toml"),
...              c_dir="out/ks_c", fmu="out/ks.fmu")                 # doctest: +SKIP
"""

from __future__ import annotations

import time
from pathlib import Path

from .c_project import write_c_project
from .fmu import model_description, write_fmu
from .model_info import ExportError, ExportModel, collect
from .targets import check_target_dir, check_target_file

__all__ = ["ExportError", "ExportModel", "collect", "export_scene", "model_description", "write_c_project",
           "write_fmu"]


def export_scene(scene, c_dir: str | Path | None = None, fmu: str | Path | None = None, *,
                 force: bool = False, generated_dir: str | Path | None = None) -> dict:
    """Export a scene as a C project and/or an FMU.

    Parameters
    ----------
    scene
        A :class:`gearsym.Scene` (effects and parameter overrides included).
    c_dir
        Folder of the C project (``None``: none).
    fmu
        Path of the ``.fmu`` file (``None``: none).
    force
        Write into an existing non-empty folder / over an existing file.
    generated_dir
        Build root of the compile (default: gearsym's).

    Returns
    -------
    dict
        ``{"scene", "c": {...}, "fmu": {...}, "collect_seconds"}``.

    Raises
    ------
    ExportError
        Nothing to export, a bad target, or a model feature that cannot be exported.
    CompileError
        The compiler failed building the FMU binary.
    """
    if c_dir is None and fmu is None:
        raise ExportError("nothing to export: give --c DIR and/or --fmu FILE.fmu")
    # targets first: a bad target is bad input, found before the (slow) compile
    if c_dir is not None:
        check_target_dir(c_dir, force)
    if fmu is not None:
        check_target_file(fmu, ".fmu", force)
    t0 = time.perf_counter()
    em = collect(scene, generated_dir)
    out: dict = {"scene": em.scene, "collect_seconds": time.perf_counter() - t0}
    if c_dir is not None:
        out["c"] = write_c_project(em, c_dir, force)
    if fmu is not None:
        out["fmu"] = write_fmu(em, fmu, force)
    return out
