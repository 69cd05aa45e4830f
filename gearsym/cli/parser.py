"""The argument parser of the ``gearsym`` command: every subcommand, its options and help."""

from __future__ import annotations

import argparse
from typing import Any

from ..integrators import method_names
from ..spec.settings import MAP_QUANTITIES
from .basins import add_basins_parser
from .benchmark import cmd_bench
from .cache import add_cache_parser
from .catalog import add_catalog_parsers
from .checks import GearsymArgumentParser, scene_args
from .curves import add_curve_arguments
from .helptext import HelpFormatter, examples
from .inspect_model import cmd_inspect
from .lyapunov import add_lyapunov_parser
from .maps import cmd_map
from .modes import cmd_modes
from .orbits import cmd_continue, cmd_orbit
from .quantities import QUANTITY_HELP
from .runup import add_runup_parser
from .simulate import cmd_compile, cmd_export, cmd_simulate
from .stiffness import add_stiffness_parser
from .sweep import add_sweep_parser
from .verbosity import add_verbosity_options

__all__ = ["build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``gearsym`` command."""
    parser = GearsymArgumentParser(
        prog="gearsym",
        description="Symbolic model compiler for gear-transmission dynamics.",
        epilog="Exit codes: 0 success, 2 bad input, 1 internal or numerical failure.  Every command's --help "
               "ends with examples on shipped scenes.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"gearsym {_version()}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors (and the "
                        "debug log, as -vv)")
    add_verbosity_options(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=GearsymArgumentParser)
    _add_inspect(sub)
    _add_compile(sub)
    _add_simulate(sub)
    _add_bench(sub)
    _add_continue(sub)
    _add_orbit(sub)
    _add_export(sub)
    _add_modes(sub)
    _add_map(sub)
    add_sweep_parser(sub)
    add_stiffness_parser(sub)
    add_lyapunov_parser(sub)
    add_basins_parser(sub)
    add_runup_parser(sub)
    add_cache_parser(sub)
    add_catalog_parsers(sub)
    for p in sub.choices.values():  # every subcommand, whoever registered it
        add_verbosity_options(p, dest_prefix="sub_")
        p.formatter_class = HelpFormatter  # filled paragraphs, the examples kept as written
    return parser


def _add_inspect(sub: Any) -> None:
    """The ``gearsym inspect`` subcommand."""
    p = sub.add_parser("inspect", help="show derived equations, states, parameters, effects, modes",
                       epilog=examples(
                           ("gearsym inspect kahraman_singh", "the derived equations, states, parameters, effects and "
                            "contact modes of a shipped scene"),
                           ("gearsym inspect spur_pair_torsional --latex", "a shipped model by name, its equations "
                            "also as LaTeX")))
    p.add_argument("path", help="scene or model file, or the name of a shipped scene or model")
    p.add_argument("--latex", action="store_true", help="also print the equations as LaTeX")
    p.add_argument("--jacobian", action="store_true", help="also print the symbolic Jacobian")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--set", action="append", metavar="NAME=VALUE", help="override a parameter")
    p.add_argument("--effect", action="append", metavar="NAME[=VARIANT]", help="switch an effect on")
    p.add_argument("--no-effect", action="append", metavar="NAME", help="switch an effect off")
    p.set_defaults(func=cmd_inspect)


def _add_compile(sub: Any) -> None:
    """The ``gearsym compile`` subcommand."""
    p = sub.add_parser("compile", help="generate C and compile it (cached by content)",
                       epilog=examples(
                           ("gearsym compile kahraman_singh", "generate C and compile (a verified build of the same "
                            "sources is reused)"),
                           ("gearsym compile kahraman_singh --json -v", "the build as JSON; -v logs the cache hit or "
                            "miss and the compile time on stderr")))
    scene_args(p)
    p.add_argument("--force", action="store_true", help="rebuild even if cached")
    p.set_defaults(func=cmd_compile)


def _add_simulate(sub: Any) -> None:
    """The ``gearsym simulate`` subcommand."""
    p = sub.add_parser("simulate", help="simulate a scene with the C engine",
                       epilog=examples(
                           ("gearsym simulate kahraman_singh --periods 50 --json", "50 forcing periods of the "
                            "backlash oscillator; one JSON object on stdout"),
                           ("gearsym simulate kahraman_singh --set Omega=0.9 --periods 100 --out ks_sim",
                            "single-sided impacts: ks_sim/trajectory.npz and figures (gearsym[plots])"),
                           ("gearsym simulate kahraman_singh --set Omega=0.9 --periods 100 --quantity "
                            "dynamic_factor,contact_loss_ratio", "the dynamic factor and the fraction of the mesh "
                            "cycle in contact loss over the steady part")))
    scene_args(p)
    p.add_argument("--periods", type=float, help="number of forcing periods (default: the scene's [simulate] "
                   "periods or t_end, else 100)")
    p.add_argument("--t-end", type=float, help="final time (instead of --periods)")
    p.add_argument("--rtol", type=float, help="relative tolerance (default: the scene's [simulate], else 1e-8)")
    p.add_argument("--atol", type=float, help="absolute tolerance (default: the scene's [simulate], else 1e-10)")
    p.add_argument("--method", choices=method_names(), help="integrator (default: the scene's "
                   "[simulate], else adams; ida for implicit models)")
    p.add_argument("--x0", help="initial state, comma-separated")
    p.add_argument("--max-steps", type=int, help="limit on internal integrator steps (default: the scene's, "
                   "else 10,000,000)")
    p.add_argument("--out", help="folder for trajectory.npz and PNG plots")
    p.add_argument("--plot-states", metavar="NAMES", help="comma-separated states the time-history figure "
                   "shows (default: every state)")
    p.add_argument("--gear-quantities", action="store_true", help="every gear quantity of every mesh over the "
                   "steady part (whole forcing periods after the scene's transient_periods, else the second half)")
    p.add_argument("--quantity", action="append", metavar="NAME", help=QUANTITY_HELP + "; repeatable or "
                   "comma-separated")
    p.set_defaults(func=cmd_simulate)


def _add_bench(sub: Any) -> None:
    """The ``gearsym bench`` subcommand."""
    p = sub.add_parser("bench", help="work-precision benchmark: error vs wall time, gearsym vs peer integrators",
                       epilog=examples(
                           ("gearsym bench kahraman_singh --rtols 1e-4,1e-6 --periods 5 --methods 'gearsym,scipy "
                            "LSODA' --rounds 0 --no-compile-times --no-analyses", "a quick look: two integrators at "
                            "two tolerances, each timed by one run (the full benchmark: gearsym bench kahraman_singh "
                            "--out bench)")))
    scene_args(p)
    p.add_argument("--out", help="folder for work_precision_<scene>.json and .png (written at the end)")
    p.add_argument("--rtols", help="comma-separated relative tolerances (default 1e-3 .. 1e-10, and 1e-11, "
                   "1e-12 where the reference allows)")
    p.add_argument("--periods", type=float, help="horizon in forcing periods (default: the scene's)")
    p.add_argument("--points-per-period", type=int, default=32, help="output grid density (default 32)")
    p.add_argument("--methods", help="comma-separated subset of the methods (default: all)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (default 3)")
    p.add_argument("--no-compile-times", action="store_true", help="skip the cold/cached compile timing")
    p.add_argument("--no-analyses", action="store_true", help="skip the shooting / continuation costs")
    p.set_defaults(func=cmd_bench)


def _add_continue(sub: Any) -> None:
    """The ``gearsym continue`` subcommand."""
    p = sub.add_parser("continue", help="continue periodic orbits in one parameter (branch, folds, period "
                       "doubling, Neimark-Sacker, grazing), or a bifurcation curve in two (--follow, --param2)",
                       epilog=examples(
                           ("gearsym continue kahraman_singh --param Omega --from 0.5 --to 1.5 --no-progress",
                            "the frequency response of the backlash oscillator through its jump: folds and "
                            "grazings located"),
                           ("gearsym continue kahraman_singh --param Omega --from 0.5 --to 0.8 --json",
                            "the branch (points, multipliers, special points) as JSON"),
                           ("gearsym continue kahraman_singh --param Omega --from 0.5 --to 1.3 --param2 Fa --from2 0 "
                            "--to2 0.2 --follow fold --guess 0.8356,0.05 --x0 1.11,0.193", "the fold curve of the "
                            "frequency response in (Omega, Fa) from a guess near its fold: both folds and the cusp "
                            "where they meet (--start-from BRANCH.json:INDEX starts at a branch's special point)")))
    scene_args(p)
    p.add_argument("--param", required=True, help="the parameter to vary")
    p.add_argument("--from", dest="start", type=float, required=True,
                   help="start value (in the model's declared unit)")
    p.add_argument("--to", dest="stop", type=float, required=True, help="end value")
    p.add_argument("--periods", type=float, help="forcing periods per orbit (default: the scene's [continue], "
                   "else 1)")
    p.add_argument("--method", choices=["shooting", "hbm"], help="periodic-orbit residual (default: the scene's "
                   "[continue], else shooting)")
    p.add_argument("--segments", type=int, help="shooting segments (default: the scene's [continue], else 1)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm)")
    p.add_argument("--switch", type=int, help="branch switching depth at period doublings (default: the scene's "
                   "[continue], else 0: none)")
    p.add_argument("--ds-max", type=float, help="largest step in scaled arclength (default: the scene's "
                   "[continue], else 0.02)")
    p.add_argument("--max-points", type=int, help="limit on branch points (default: the scene's [continue], "
                   "else 5000)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default: the scene's [continue], "
                   "else 1e-10)")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default: rtol * 1e-2 * the smallest "
                   "state magnitude on the first orbit; for the orbit x = 0 the scene's scale)")
    p.add_argument("--x0", help="initial guess of the orbit's state at t = 0, comma-separated")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--quantity", metavar="NAME", help="plot this gear quantity along the branch (response.png) and "
                   "give each point's gear quantities in the JSON (one more integration per point): " + QUANTITY_HELP)
    p.add_argument("--out", help="folder for branch.json, response.png, multipliers.png (a curve: curve.json, "
                   "curve.png)")
    add_curve_arguments(p)
    p.set_defaults(func=cmd_continue)


def _add_orbit(sub: Any) -> None:
    """The ``gearsym orbit`` subcommand."""
    p = sub.add_parser("orbit", help="periodic orbit by shooting or harmonic balance, Floquet multipliers",
                       epilog=examples(
                           ("gearsym orbit kahraman_singh --set Omega=0.6", "the periodic orbit without impacts "
                            "and its Floquet multipliers"),
                           ("gearsym orbit kahraman_singh --set Omega=0.9 --segments 4", "with impacts, by "
                            "multiple shooting (4 segments)"),
                           ("gearsym orbit kahraman_singh --set Omega=0.6 --method hbm --json", "the same orbit by "
                            "harmonic balance, as JSON")))
    scene_args(p)
    p.add_argument("--periods", type=float, help="forcing periods per orbit (default: the scene's [orbit], else 1)")
    p.add_argument("--method", choices=["shooting", "hbm"], help="periodic solver (default: the scene's [orbit], "
                   "else shooting)")
    p.add_argument("--segments", type=int, help="shooting segments (default: the scene's [orbit], else 1: single "
                   "shooting)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm; default: the scene's [orbit], else grown until "
                   "converged)")
    p.add_argument("--x0", help="initial guess of the state at t = 0, comma-separated")
    p.add_argument("--transient", type=float, help="forcing periods integrated before the solve (default: the "
                   "scene's [orbit], else the solver's)")
    p.add_argument("--tol", type=float, help="residual tolerance (default: the scene's [orbit], else 1e-10)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default: the scene's [orbit], "
                   "else 1e-11)")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default: the scene's [orbit], "
                   "else 1e-13)")
    p.add_argument("--quantity", action="append", metavar="NAME", help="print these gear quantities (the JSON "
                   "has them all, under gear_quantities): " + QUANTITY_HELP)
    p.add_argument("--out", help="folder for orbit.json, orbit_phase.png, orbit_multipliers.png")
    p.set_defaults(func=cmd_orbit)


def _add_export(sub: Any) -> None:
    """The ``gearsym export`` subcommand."""
    p = sub.add_parser("export", help="standalone C project (--c DIR, SUNDIALS libraries included) and/or "
                       "FMI 2.0 FMU for Model Exchange and Co-Simulation (--fmu FILE.fmu) of a scene",
                       epilog=examples(
                           ("gearsym export kahraman_singh --c ks_c", "a standalone C project in ks_c/: main.c, the "
                            "driver, a Makefile and the SUNDIALS libraries"),
                           ("gearsym export kahraman_singh --fmu ks.fmu", "an FMI 2.0 FMU (Model Exchange and "
                            "Co-Simulation)")))
    scene_args(p)
    p.add_argument("--c", metavar="DIR", help="folder for the C project (main.c, driver, Makefile, README, "
                   "lib/ with the SUNDIALS libraries)")
    p.add_argument("--fmu", metavar="FILE", help="FMU file to write (.fmu)")
    p.add_argument("--force", action="store_true", help="write into an existing non-empty folder / over a file")
    p.set_defaults(func=cmd_export)


def _add_modes(sub: Any) -> None:
    """The ``gearsym modes`` subcommand."""
    p = sub.add_parser("modes", help="natural frequencies and mode shapes about the static equilibrium "
                       "(mean mesh stiffness)",
                       epilog=examples(
                           ("gearsym modes spur_pair_torsional", "natural frequencies and mode shapes of a "
                            "torsional spur pair"),
                           ("gearsym modes kahraman_singh --json", "as JSON")))
    scene_args(p)
    p.add_argument("--samples", type=int, default=None,
                   help="equally spaced samples per forcing period for the mean stiffness and loads "
                        "(default: the exact mean, Gauss-Legendre refined until it settles)")
    p.set_defaults(func=cmd_modes)


def _add_map(sub: Any) -> None:
    """The ``gearsym map`` subcommand."""
    p = sub.add_parser("map", help="two-parameter stability / response map (netCDF + heat map)",
                       epilog=examples(
                           ("gearsym map meissner --x a 0 0.5 6 --y T 0.5 6 6 --out meissner_map", "a coarse "
                            "stability chart of the Meissner equation (exact matrix exponentials); map.nc and "
                            "map.png in meissner_map/ (gearsym[maps])"),
                           ("gearsym map kahraman_singh --x Omega 0.86 0.88 3 --y Fa 0.05 0.06 2 --quantity "
                            "rattle_state --workers 1 --out coexist", "the jump region of the benchmark oscillator: "
                            "two stable responses coexist (in contact and impacting), both listed and counted "
                            "(n_stable)"),
                           ("gearsym map kahraman_singh --x Omega 0.6 0.8 2 --y Fa 0.4 0.6 2 --quantity lyapunov "
                            "--workers 1 --out chaos", "the largest Lyapunov exponent of every response: negative on "
                            "the stable orbits, positive on the chaotic attractors (at Omega 0.8, one beside a "
                            "stable orbit)")))
    scene_args(p)
    p.add_argument("--x", nargs=4, required=True, metavar=("NAME", "LO", "HI", "N"),
                   help="horizontal axis: parameter (declared unit), range and number of points")
    p.add_argument("--y", nargs=4, required=True, metavar=("NAME", "LO", "HI", "N"), help="vertical axis")
    p.add_argument("--quantity", choices=list(MAP_QUANTITIES),
                   help="what the heat map shows (default: the scene's [map], else max_multiplier); a gear "
                        "quantity is of the worst mesh (the largest value over the meshes); lyapunov: the largest "
                        "Lyapunov exponent of the response (log max|mu| / T of a stable orbit, computed by the "
                        "variational equations for the attractor reached where there is none)")
    p.add_argument("--method", choices=["auto", "exact", "shooting", "hbm"],
                   help="auto: exact matrix exponentials for piecewise-constant LTV models, else shooting "
                        "(default: the scene's [map], else auto)")
    p.add_argument("--periods", type=float, help="forcing periods per orbit (default: the scene's [map], else 1)")
    p.add_argument("--harmonics", type=int, help="harmonics (hbm)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance")
    p.add_argument("--dask", metavar="ADDRESS", help="run on this Dask scheduler (default: local processes)")
    p.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--search", metavar="LIST", default="auto",
                   help="the search for coexisting responses: rows (continuation along each row, both ways), "
                        "columns (along each column, both ways), starts (from the initial state, the static "
                        "equilibrium, the rest state and states spread over the orbits found), as a comma-separated "
                        "list, or all, none; default auto: all on maps of at most 100 points of a nonlinear model, "
                        "none otherwise (the cost grows with rows x columns x directions)")
    p.add_argument("--no-coexist", dest="search", action="store_const", const="none",
                   help="no search for coexisting responses (--search none)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--out", required=True, help="folder for map.nc and map.png")
    p.set_defaults(func=cmd_map)


def _version() -> str:
    from .. import __version__

    return __version__
