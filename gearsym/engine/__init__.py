"""Simulation engine: generic C driver over SUNDIALS 7 (CVODE, IDA) for compiled
hybrid models, its build helpers and its ctypes binding.

The engine never sees sympy: it works on a compiled shared object that follows
``gs_model_abi.h`` (model functions) and ``gs_driver.h`` (driver API).
"""

from gearsym.engine.build import (
    build_shared_object,
    content_hash,
    driver_sources,
    find_sundials_libs,
    preload_sundials,
    toolchain_identity,
)
from gearsym.engine.driver import Engine, RunResult, load_engine

__all__ = [
    "Engine",
    "RunResult",
    "build_shared_object",
    "content_hash",
    "driver_sources",
    "find_sundials_libs",
    "load_engine",
    "preload_sundials",
    "toolchain_identity",
]
