"""``gearsym export SCENE --c DIR``: a self-contained C project of a scene.

The folder holds the generated model (``gs_model.c/h``), gearsym's driver
(``gs_driver.c/h`` and the ``gs_*.c`` / ``gs_internal.h`` it is split into,
``gs_model_abi.h``, ``sundials7.h``, copied from :mod:`gearsym.engine`), the exported metadata (``gs_export_data.h``), a command-line
``main.c``, a ``Makefile`` with ``find_sundials.sh``, a ``README.md`` that says how to
build and run it without Python, and ``lib/``: the SUNDIALS libraries gearsym links (copied
from the scikit-sundae wheel with their licence, :mod:`gearsym.export.bundle`), which the
program finds through the run path ``$ORIGIN/lib``: it does not need the Python environment
that exported it, and the folder can be moved.
"""

from __future__ import annotations

import time
from importlib import resources
from pathlib import Path

from ..engine.build import ENGINE_DIR
from ..files import write_files
from ..integrators import EXPLICIT, IMPLICIT, method_names
from .bundle import sundials_bundle
from .model_info import ExportError, ExportModel, data_header
from .targets import check_target_dir

__all__ = ["write_c_project"]



def driver_files() -> list[str]:
    """The driver's C sources and headers (every ``*.c`` / ``*.h`` of :mod:`gearsym.engine`:
    ``gs_driver.c`` and the ``gs_*.c`` files it is split into, ``gs_driver.h``,
    ``gs_internal.h``, ``gs_model_abi.h``, ``sundials7.h``)."""
    return sorted(p.name for p in ENGINE_DIR.iterdir() if p.suffix in (".c", ".h"))


def template(name: str) -> str:
    """Text of a template shipped with :mod:`gearsym.export`."""
    return resources.files("gearsym.export").joinpath("templates", name).read_text(encoding="utf-8")


#: The folder of the C project that holds the bundled SUNDIALS libraries.
LIB_DIR = "lib"


def write_c_project(em: ExportModel, directory: str | Path, force: bool = False) -> dict:
    """Write the C project of ``em`` into ``directory``.

    Parameters
    ----------
    em
        From :func:`gearsym.export.model_info.collect`.
    directory
        Target folder (created; an existing non-empty one needs ``force``).
    force
        Write into an existing non-empty folder (files of the same name are replaced).

    Every file is written to a temporary file beside its target first and the files are
    renamed onto their names only when all are complete: a failure (a full disk) leaves the
    folder's files as they were.

    The SUNDIALS libraries are copied into ``lib/`` (:func:`gearsym.export.bundle.sundials_bundle`)
    and the Makefile links them with the run path ``$ORIGIN/lib``, unless ``make
    SUNDIALS_LIBDIR=...`` or ``SUNDIALS_DIR=...`` names others.

    Returns
    -------
    dict
        ``{"directory", "files", "program", "sundials_version", "bundled", "seconds"}``
        (``bundled``: the library files in ``lib/``).

    Raises
    ------
    ExportError
        The target cannot be written, or the SUNDIALS libraries cannot be found.
    """
    t0 = time.perf_counter()
    d = check_target_dir(directory, force)
    bundle = sundials_bundle()
    try:
        d.mkdir(parents=True, exist_ok=True)
        files = {
            "gs_model.c": (em.generated_dir / "gs_model.c").read_text(),
            "gs_model.h": (em.generated_dir / "gs_model.h").read_text(),
            "gs_export_data.h": data_header(em),
            "main.c": template("main.c"),
            "find_sundials.sh": template("find_sundials.sh"),
            "Makefile": makefile(em.program, bundle.linked),
            "README.md": readme(em, bundle.version),
            "params.txt": params_file(em),
        }
        for name in driver_files():
            files[name] = (ENGINE_DIR / name).read_text()
        clash = [n for n in [*files, LIB_DIR] if n.lower() == em.program.lower()]
        if clash:  # program_name() avoids it; a guard against a new file of the project
            raise ExportError(f"--c: the program '{em.program}' would be built over the project's '{clash[0]}'")
        # every file complete beside its target before any is renamed: a full disk or an
        # interrupt leaves the folder as it was (gearsym.files.write_files)
        libs = {f"{LIB_DIR}/{name}": content for name, content in bundle.files().items()}
        write_files(d, {**files, **libs}, executable=["find_sundials.sh"])
    except OSError as exc:
        raise ExportError(f"--c: cannot write into '{d}': {exc.strerror or exc}") from None
    return {"directory": str(d), "files": sorted(files) + sorted(libs), "program": em.program,
            "sundials_version": bundle.version, "bundled": sorted(f"{LIB_DIR}/{n}" for n in bundle.libs),
            "seconds": time.perf_counter() - t0}


def makefile(program: str, bundled: tuple[str, ...] | list[str] = ()) -> str:
    """The project's Makefile: main.c, the model and every C file of the driver, linked
    against the SUNDIALS libraries ``bundled`` (file names in ``lib/``, link order) unless
    the user names others."""
    sources = " ".join(["main.c", "gs_model.c"] + [f for f in driver_files() if f.endswith(".c")])
    headers = " ".join(["gs_model.h", "gs_export_data.h"] + [f for f in driver_files() if f.endswith(".h")])
    return (template("Makefile.in").replace("@PROG@", program).replace("@SRCS@", sources)
            .replace("@HDRS@", headers).replace("@BUNDLED@", " ".join(bundled)))


def params_file(em: ExportModel) -> str:
    """An example ``--file`` input: every setting with the scene's value, commented out."""
    lines = [f"# Settings of {em.program} (NAME=VALUE, SI units); uncomment to change.", ""]
    lines.append("# parameters")
    for q in em.params:
        lock = "   # fixed: " + q.locked if q.locked else ""
        lines.append(f"# {q.name}={q.value!r}{lock}")
    lines.append("# initial state")
    for q in em.states:
        lines.append(f"# {q.name}={q.value!r}")
    lines.append("# options")
    dflt = em.defaults
    if em.period:
        lines.append(f"# periods={dflt['periods']!r}")
    else:
        lines.append(f"# t_end={dflt['t_end']!r}")
    lines += [f"# points_per_period={dflt['points_per_period']}", f"# rtol={dflt['rtol']!r}",
              f"# atol={dflt['atol']!r}", f"# method={dflt['method']}"]
    return "\n".join(lines) + "\n"


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def readme(em: ExportModel, sundials_version: str = "") -> str:
    """README.md of the exported C project (``sundials_version``: of the libraries in ``lib/``)."""
    dflt = em.defaults
    methods = " or ".join(f"`{n}`" for n in method_names(IMPLICIT if em.implicit else EXPLICIT))
    ex = "Omega=0.9 " if any(q.name == "Omega" for q in em.params) else ""
    rows = "\n".join(f"| `{q.name}` | {q.value:.10g} | {q.unit or '1'} | {_md(q.description)}"
                     f"{' **fixed**: ' + _md(q.locked) if q.locked else ''} |" for q in em.params + em.extras)
    srows = "\n".join(f"| `{q.name}` | {q.value:.10g} | {q.unit or '1'} | {_md(q.description)} |"
                      for q in em.states)
    orows = "\n".join(f"| `{q.name}` | {q.unit or '1'} | {_md(q.description)} |" for q in em.outputs)
    surf = "\n".join(f"* `{n}`: {_md(m)}" for n, m in em.surfaces) or "* (none)"
    bound = ""
    if em.bound_notes:
        bound = ("\n## Values recorded at export\n\n"
                 "These parameters are numeric functions of other parameters that gearsym evaluates in "
                 "Python; the export evaluated them once, for the scene's values, and the program refuses "
                 "to change them or their arguments (re-export with `gearsym export --set NAME=VALUE` to "
                 "get other values):\n\n" + "\n".join(f"* `{n}`" for n in em.bound_notes) + "\n")
    period = (f"The forcing period is computed in C from the parameters (`gs_period`, "
              f"{em.period:.10g} s at the scene's values); `periods=N` integrates N of them."
              if em.period else "The model has no forcing period: give `t_end=`.")
    effects = ", ".join(f"{k}={v}" if v is not True else k for k, v in em.effects.items()) or "(none)"
    return f"""# {em.program}: exported gearsym model

Scene `{em.scene}` (model `{em.model}`): {em.description}

Effects compiled in: {effects}.  Exported by gearsym {em.gearsym_version}.  This folder builds and
runs without Python: `gs_model.c` is the generated model (right-hand side, Jacobian, switching
functions, schedules, forcing period, outputs), `gs_driver.c` gearsym's integration driver
(SUNDIALS CVODE/IDA with root finding on the switching surfaces, the mode switch, exact stops at
scheduled breakpoints; the other `gs_*.c` files are its parts, sharing `gs_internal.h`), `main.c`
the command-line program.

## Build

```sh
make                                   # builds ./{em.program} with the SUNDIALS libraries in lib/
make SUNDIALS_DIR=/opt/sundials-7.2    # a SUNDIALS >= 7 installed under that prefix instead
make SUNDIALS_LIBDIR=/path/to/libs     # a folder with the libsundials_*.so libraries instead
```

Needs a C compiler only: `lib/` holds the SUNDIALS {sundials_version} shared libraries the program
links (core, cvode, ida, nvecserial, sunmatrixdense, sunlinsoldense), copied at export from the
scikit-sundae wheel gearsym uses.  The program finds them through its run path `$ORIGIN/lib`
(the `lib/` folder beside it): it runs without Python and without the environment that exported
it, and the folder can be moved or copied to another Linux x86-64 machine (glibc at least as
recent as the wheel's manylinux tag).  SUNDIALS is distributed under the BSD 3-Clause licence;
its text (`lib/LICENSE-SUNDIALS`, `lib/NOTICE-SUNDIALS`) goes with the libraries, and
`lib/README.md` lists them with their checksums.

Another SUNDIALS >= 7 (double precision, 32-bit `sunindextype`; no headers needed: the driver
declares what it uses in `sundials7.h`) can be named with `SUNDIALS_DIR` or `SUNDIALS_LIBDIR`;
without `lib/`, `find_sundials.sh` looks at pkg-config, CMake packages and the standard prefixes.
SUNDIALS 6 (e.g. Debian 12's `libsundials-dev`) is refused with a message: the driver uses the
SUNDIALS 7 API (`SUNContext_Create(SUNComm)`, the error-handler stack, `SUNLogger` file setters).
The program checks the version and the index size again when it starts.

## Run

```sh
./{em.program}                                       # scene defaults, CSV on stdout
./{em.program} {ex}periods=200 n_out=201 rtol=1e-10 --out run.csv   # events in run_events.csv
./{em.program} --file params.txt --out run.csv       # NAME=VALUE lines, '#' comments
./{em.program} --list                                # parameters, states, options, defaults
```

Every setting is `NAME=VALUE` on the command line or in a `--file` (a regular text file of at most
1 MiB, lines of any length; later settings win), with
NAME a parameter (**SI units**), a state (its initial value, SI units) or an option:
`periods` (default {dflt['periods']:g}), `t_end`, `t0` (0), `n_out` (default
`round(periods * points_per_period) + 1`), `points_per_period` ({dflt['points_per_period']}),
`rtol` ({dflt['rtol']:g}), `atol` ({dflt['atol']:g}), `method` ({methods}; default
`{dflt['method']}`), `max_step` (default: forcing period / 8), `max_steps`.  {period}

Output: CSV with the header `t,<states>,<outputs>` at `n_out` equally spaced times from `t0` to
`t_end`; events (surface crossings) as `t,surface,direction,speed` in `--events FILE` (default
with `--out X.csv`: `X_events.csv`); a one-line summary on stderr.  The outputs are evaluated
with the side of each surface taken from the sign of its switching function at the output time.
Exit codes: 0 success, 2 bad arguments, 1 integration or SUNDIALS failure.

## Parameters (scene values, SI units)

| name | value | unit | meaning |
|---|---|---|---|
{rows}

## States (initial values, SI units)

| name | x0 | unit | meaning |
|---|---|---|---|
{srows}

## Outputs

| name | unit | meaning |
|---|---|---|
{orows or '| (none) | | |'}

## Switching surfaces

{surf}
{bound}"""
