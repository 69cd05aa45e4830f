"""``gearsym lyapunov``: Lyapunov exponents of a scene (variational equations with saltation, QR blocks).

Registered by :mod:`gearsym.cli.parser`.  Exit 0 when every exponent converged, 1 when not
(the numbers are still printed and written, with their errors, and the reason goes to
stderr), 2 on bad input.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ..errors import ParameterError
from ..integrators import method_names
from .checks import emit, float_list, load, scene_args
from .helptext import examples

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from typing import Any

    from ..analysis.sweeps import LyapunovOptions, LyapunovResult

__all__ = ["add_lyapunov_parser", "cmd_lyapunov"]

#: option field -> its flag
_FLAGS = {"periods": "--periods", "transient": "--transient", "exponents": "--exponents", "block": "--block",
          "block_time": "--block-time", "align": "--align", "rtol": "--rtol", "atol": "--atol",
          "rel_tol": "--rel-tol", "abs_tol": "--abs-tol", "method": "--method"}


def add_lyapunov_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``lyapunov`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "lyapunov", help="Lyapunov exponents (variational equations with saltation at every event, QR blocks)",
        description="Lyapunov exponents of a scene: the state is integrated --transient forcing periods, then "
                    "the variational equations (with the saltation matrix at every contact event) block by "
                    "block, one forcing period each, with QR re-orthonormalisation; exponent i is the windowed "
                    "time average of log|R_ii|, its error the 95 % half-width from 8 batches.  Forced models: "
                    "the forcing phase is not a state (no zero exponent for it); autonomous models: give "
                    "--block-time (counts are then in blocks).  Rigid-body directions of free models are "
                    "reported apart (their exponents are 0).  Exit 1 if an exponent has not converged "
                    "(its error above --abs-tol + --rel-tol * max|lambda|).",
        epilog=examples(
            ("gearsym lyapunov kahraman_singh --set Omega=0.6 --periods 200 --transient 50",
             "a periodic response without impacts: both exponents negative"),
            ("gearsym lyapunov kahraman_singh --set Omega=0.6 --periods 100 --transient 20 --exponents 1 --json",
             "the largest exponent only, as JSON (a chaotic response, e.g. Omega=0.8 Fa=0.6, needs some "
             "thousand periods)")))
    scene_args(p)
    p.add_argument("--periods", type=float, help="forcing periods averaged over (default 2000)")
    p.add_argument("--transient", type=float, help="forcing periods integrated first and discarded (default 200)")
    p.add_argument("--exponents", type=int, metavar="K", help="how many exponents, largest first (default: all)")
    p.add_argument("--block", type=float, help="forcing periods per QR block (default: 1, halved automatically "
                   "while the directions separate by more than 1e6 in a block)")
    p.add_argument("--block-time", type=float, help="autonomous models: length of a block in the system's time")
    p.add_argument("--align", type=int, help="blocks before the averaging, for the tangent basis (default 16)")
    p.add_argument("--rtol", type=float, help="integrator relative tolerance (default 1e-9)")
    p.add_argument("--atol", type=float, help="integrator absolute tolerance (default: 1e-2 * rtol * each "
                   "state's magnitude)")
    p.add_argument("--method", choices=method_names(), help="integrator (default: the scene's)")
    p.add_argument("--rel-tol", type=float, help="convergence: error at most abs-tol + rel-tol * max|lambda| "
                   "(default 0.05)")
    p.add_argument("--abs-tol", type=float, help="convergence: see --rel-tol (default 1e-4 per forcing period)")
    p.add_argument("--x0", help="initial state, comma-separated (default: the scene's)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--out", help="folder for lyapunov.json and lyapunov.png (the running estimates)")
    p.set_defaults(func=cmd_lyapunov)


def options_from(args: argparse.Namespace) -> LyapunovOptions:
    """The :class:`~gearsym.analysis.sweeps.LyapunovOptions` of a command line, checked (exit 2
    naming the option)."""
    from ..analysis.sweeps import LyapunovOptions

    given = {name: getattr(args, name) for name in _FLAGS if getattr(args, name, None) is not None}
    try:
        return LyapunovOptions(**given)
    except ParameterError as exc:
        raise flagged(exc) from None


def flagged(exc: ParameterError) -> ParameterError:
    """The error with the option's flag in front when its message starts with an option's name."""
    msg = str(exc)
    for name, flag in _FLAGS.items():
        if msg.startswith((f"{name} ", f"{name}=")):
            return ParameterError(f"{flag}: {msg}")
    return exc


def cmd_lyapunov(args: argparse.Namespace) -> int:
    """Lyapunov exponents of a scene; exit 1 when they have not converged."""
    from ..analysis.sweeps import lyapunov_exponents

    opts = options_from(args)  # before any work: bad options and a bad --out are bad input
    x0 = float_list(args.x0, "--x0") if args.x0 else None
    if args.out:
        from ..extras import require
        from ..files import check_out_dir

        check_out_dir(args.out)
        require("plots", "gearsym lyapunov --out (figures)")
    scene = load(args)
    system = scene.compile()
    try:
        res = lyapunov_exponents(system, options=opts, x0=x0, progress=False if args.no_progress else None)
    except ParameterError as exc:
        raise flagged(exc) from None
    info: dict[str, Any] = {"scene": scene.name, **res.as_dict()}
    if args.out:
        info["files"] = [str(f) for f in write_outputs(res, Path(args.out), scene.name, info)]
    if args.json:
        emit(info)
    else:
        _print(scene.name, res, info.get("files", []))
    if not res.converged:
        print(f"gearsym: error: {res.reason}", file=sys.stderr)
        return 1
    return 0


def write_outputs(res: LyapunovResult, out: Path, name: str, info: dict[str, Any]) -> list[Path]:
    """``lyapunov.json`` (``info``) and ``lyapunov.png`` (the running estimates) in ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..files import save_figure, write_json

    out.mkdir(parents=True, exist_ok=True)
    files = [out / "lyapunov.json", out / "lyapunov.png"]
    write_json(files[0], {**info, "files": [str(f) for f in files]})
    fig, ax = plt.subplots(figsize=(7, 4.2))
    res.plot(ax)
    ax.set_title(f"{name}: Lyapunov exponents ({'converged' if res.converged else 'NOT converged'})")
    fig.tight_layout()
    save_figure(fig, files[1], dpi=110)
    plt.close(fig)
    return files


def _print(name: str, res: LyapunovResult, files: list[str]) -> None:
    from ..analysis.sweeps import format_estimate

    st = res.stats
    what = "forcing periods" if res.info.get("forced") else f"blocks of {res.block_time:g}"
    print(f"{name}: Lyapunov exponents over {res.periods:g} {what} (block {res.block:g}, {st['n_calls']} engine "
          f"calls, {st['wall_s']:.3g} s, {st['periods_per_second']:.4g} periods/s)")
    for i, (v, e) in enumerate(zip(res.exponents, res.errors, strict=True)):
        print(f"  lambda_{i + 1} = {format_estimate(float(v), float(e))}")
    if len(res.trivial):
        print(f"  {len(res.trivial)} rigid-body directions: exponents 0 (not listed above)")
    ky = "n/a (more exponents needed)" if math.isnan(res.kaplan_yorke) else f"{res.kaplan_yorke:.4g}"
    where = " (of the period map's attractor)" if res.info.get("forced") else ""
    print(f"  sum = {res.exponent_sum:.10g}; Kaplan-Yorke dimension {ky}{where}")
    verdict = "converged" if res.converged else "NOT CONVERGED"
    print(f"  {verdict} (errors: 95% half-widths; tolerance {res.tolerance:.2g})")
    for f in files:
        print(f"wrote {f}")
