"""How results show themselves: short reprs, HTML and LaTeX for notebooks, xarray and pandas.

Every result class of gearsym takes its display from one mixin here (kept apart from the
classes, which hold the numbers): a ``__repr__`` of one or a few lines (never the arrays),
``_repr_html_`` for Jupyter, and the conversions ``to_xarray()`` / ``to_dataframe()``.

**Units in the conversions.**  Time and states are in coherent SI units (the unit of each
state is its coordinate's: ``m``, ``rad``, ``m/s``, ...; ``1`` for a model in dimensionless
variables), parameter values in the units the model declares (``b_m`` in ``um`` when the model
says so), as everywhere in gearsym's API.  An xarray variable or coordinate carries its unit in
``attrs["units"]``; the parameters are attributes ``param_<name>`` with ``param_<name>_units``;
``attrs["units_convention"]`` says this once more.  A pandas frame carries the same in
``df.attrs["units"]`` (column -> unit) and ``df.attrs["params"]``.

Every dataset written by a ``to_xarray()`` method (:meth:`TrajectoryDisplay.to_xarray`, ...)
has only netCDF-safe attributes (numbers, strings, 1-D number arrays: ``True``/``False`` as
1/0, ``None`` as ``""``, mappings as JSON), so ``ds.to_netcdf(path)`` works with every engine, scipy's netCDF-3 included
(:func:`netcdf_engine`).

xarray and pandas come with ``gearsym[maps]`` (:mod:`gearsym.extras`); the reprs need neither.

The mixins and helpers live in private modules by concern (``_text``: formatting, HTML and
conversions; ``_results``: trajectories, orbits, branches, modes; ``_sweeps``: Lyapunov
exponents, run-ups, basins; ``_model``: gear quantities, scenes, systems, the symbolic model);
this module is their face.
"""

from __future__ import annotations

from ._model import (
    DimensionlessDisplay,
    GearQuantitiesDisplay,
    MeshQuantitiesDisplay,
    SceneDisplay,
    SymbolicDisplay,
    SystemDisplay,
)
from ._results import (
    BifurcationDisplay,
    BranchDisplay,
    BranchPointDisplay,
    ModalDisplay,
    OrbitDisplay,
    TrajectoryDisplay,
)
from ._sweeps import BasinDisplay, LyapunovDisplay, RunupDisplay
from ._text import (
    UNITS_CONVENTION,
    fmt,
    html_card,
    names_list,
    netcdf_attrs,
    netcdf_engine,
    params_text,
)

__all__ = ["UNITS_CONVENTION", "BasinDisplay", "BifurcationDisplay", "BranchDisplay", "GearQuantitiesDisplay",
           "MeshQuantitiesDisplay", "BranchPointDisplay", "DimensionlessDisplay",
           "LyapunovDisplay", "ModalDisplay", "OrbitDisplay", "RunupDisplay", "SceneDisplay", "SymbolicDisplay",
           "SystemDisplay",
           "TrajectoryDisplay", "fmt", "html_card", "names_list", "netcdf_attrs", "netcdf_engine", "params_text"]
