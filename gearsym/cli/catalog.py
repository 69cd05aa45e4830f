"""``gearsym models`` (the shipped models, their papers and scenes) and ``gearsym init NAME``.

Registered by :mod:`gearsym.cli.parser`.  Neither command imports numpy, sympy or CasADi.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from ..errors import ParameterError, SpecError
from .helptext import examples

__all__ = ["add_catalog_parsers", "cmd_init", "cmd_models", "init_files"]

_TEMPLATES = Path(__file__).resolve().parent.parent / "templates"


def add_catalog_parsers(sub: argparse._SubParsersAction) -> None:
    """Register the ``models`` and ``init`` subcommands on the CLI's subparsers.

    Parameters
    ----------
    sub
        The subparsers of the ``gearsym`` parser.
    """
    p = sub.add_parser("models", help="list the shipped models (with their papers) and scenes",
                       description="The models and scenes shipped with gearsym.  Every command that takes a "
                                   "scene also takes a shipped scene's name: gearsym simulate kahraman_singh.",
                       epilog=examples(("gearsym models", "the shipped models, their papers and their scenes"),
                                       ("gearsym models --json", "the same as one JSON object")))
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=cmd_models)

    p = sub.add_parser("init", help="write a model and a scene to start from (models/NAME.toml, scenes/NAME.toml)",
                       description="Write DIR/models/NAME.toml and DIR/scenes/NAME.toml: a commented template "
                                   "(a spur pair with backlash, mesh stiffness variation and transmission error, "
                                   "starting from its static deflection), or a copy of a shipped scene and its "
                                   "model (--from).  Existing files are never overwritten.",
                       epilog=examples(("gearsym init mygear", "models/mygear.toml and scenes/mygear.toml: a "
                                        "commented template to edit"),
                                       ("gearsym init myks --from kahraman_singh", "a renamed copy of a shipped scene "
                                        "and its model")))
    p.add_argument("name", help="name of the new model and scene (an ASCII letter, then letters, digits, _ and -)")
    p.add_argument("--dir", default=".", help="folder to write models/ and scenes/ into (default: the current one)")
    p.add_argument("--from", dest="source", metavar="SCENE",
                   help="copy this shipped scene and its model instead of the template")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=cmd_init)


def cmd_models(args: argparse.Namespace) -> int:
    """Run ``gearsym models``: list the shipped models, their references and scenes.

    Parameters
    ----------
    args
        The parsed command line.

    Returns
    -------
    int
        The exit code (0).
    """
    import json

    from ..catalog import data_root, shipped_models, shipped_scenes

    models, scenes = shipped_models(), shipped_scenes()
    if args.json:
        print(json.dumps({
            "root": str(data_root()),
            "models": [{"name": m.name, "description": m.description, "reference": m.reference,
                        "path": str(m.path), "scenes": list(m.scenes)} for m in models.values()],
            "scenes": [{"name": s.name, "model": s.model, "description": s.description, "path": str(s.path)}
                       for s in scenes.values()],
        }, indent=1))
        return 0
    for m in models.values():
        print(f"{m.name}: {m.description}")
        if m.reference:
            print(f"  reference: {m.reference}")
        for s in m.scenes:
            desc = scenes[s].description
            print(f"  scene {s}" + (f": {' '.join(desc.split())}" if desc else ""))
    print(f"\n(in {data_root()}; run one with: gearsym simulate SCENE --json)")
    return 0


def _rename(text: str, section: str, name: str, extra: dict[str, str] | None = None) -> str:
    """Set ``name`` (and the ``extra`` string fields) in ``[section]`` of a TOML text, keeping comments."""
    import json

    head = re.search(rf"(?m)^\[{section}\][^\n]*\n", text)
    if head is None:
        raise SpecError(f"no [{section}] section to rename")
    start = head.end()
    nxt = re.search(r"(?m)^\[", text[start:])
    end = start + nxt.start() if nxt else len(text)
    body = text[start:end]
    for key, value in {"name": name, **(extra or {})}.items():
        line = f"{key} = {json.dumps(value)}"
        body, n = re.subn(rf"(?m)^{key}\s*=\s*\"[^\"\n]*\"", line.replace("\\", "\\\\"), body, count=1)
        if n == 0:
            body = line + "\n" + body
    return text[:start] + body + text[end:]


def init_files(name: str, source: str | None = None) -> tuple[str, str]:
    """The texts of the model and scene that ``gearsym init`` writes.

    Parameters
    ----------
    name
        Name of the new model and scene.
    source
        A shipped scene to copy (with its model), or ``None`` for the template.

    Returns
    -------
    model_text, scene_text : str
        TOML texts; the scene refers to ``../models/NAME.toml``.

    Raises
    ------
    ParameterError
        ``name`` is not a valid model name.
    SpecError
        ``source`` is not a shipped scene.
    """
    from ..spec.names import check_label

    problem = check_label(name, "model name")
    if problem:
        raise ParameterError(f"init: {problem}")
    if source is None:
        model = (_TEMPLATES / "model.toml").read_text(encoding="utf-8").replace("{{NAME}}", name)
        scene = (_TEMPLATES / "scene.toml").read_text(encoding="utf-8").replace("{{NAME}}", name)
        return model, scene
    from ..catalog import shipped_scenes

    scenes = shipped_scenes()
    if source not in scenes:
        raise SpecError(f"--from: '{source}' is not a shipped scene (shipped: {', '.join(scenes)})")
    sc = scenes[source]
    model_path = (sc.path.parent / f"../models/{sc.model}.toml").resolve()
    model = _rename(model_path.read_text(encoding="utf-8"), "model", name)
    scene = _rename(sc.path.read_text(encoding="utf-8"), "scene", name, {"model": f"../models/{name}.toml"})
    return model, scene


def _copy_table_files(source: str | None, folder: Path) -> list[Path]:
    """The table files a shipped model reads (``[tables.NAME] file``), copied beside the new model
    (an existing file of that name is kept: the model may have been written for it)."""
    if source is None:
        return []
    import shutil

    from ..catalog import shipped_scenes
    from ..spec.model import load_model

    sc = shipped_scenes()[source]
    spec = load_model((sc.path.parent / f"../models/{sc.model}.toml").resolve())
    out = []
    base = Path(spec.path).resolve().parent
    for t in spec.tables.values():
        if t.source == "file" and t.file:
            rel = Path(t.file).relative_to(base)
            dest = folder / rel
            if not dest.exists():
                dest.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(t.file, dest)
                out.append(dest)
    return out


def cmd_init(args: argparse.Namespace) -> int:
    """Run ``gearsym init NAME``: write a model and a scene to start from, never overwriting.

    Parameters
    ----------
    args
        The parsed command line.

    Returns
    -------
    int
        The exit code (0).

    Raises
    ------
    ParameterError
        A file to write exists already, or the name is not valid.
    """
    import json

    model_text, scene_text = init_files(args.name, args.source)
    root = Path(args.dir)
    targets = [root / "models" / f"{args.name}.toml", root / "scenes" / f"{args.name}.toml"]
    for t in targets:
        if t.exists() or t.is_symlink():
            raise ParameterError(f"init: {t} exists already; not overwriting it (choose another name or --dir)")
    written: list[Path] = []
    try:
        for t, text in zip(targets, (model_text, scene_text), strict=True):
            t.parent.mkdir(parents=True, exist_ok=True)
            with open(t, "x", encoding="utf-8") as fh:  # "x": fails rather than overwrite (a race)
                fh.write(text)
            written.append(t)
    except FileExistsError as exc:
        for t in written:
            t.unlink(missing_ok=True)
        raise ParameterError(f"init: {exc.filename} exists already; not overwriting it") from None
    except OSError as exc:
        for t in written:
            t.unlink(missing_ok=True)
        raise ParameterError(f"init: cannot write {exc.filename}: {exc.strerror}") from None
    written += _copy_table_files(args.source, targets[0].parent)
    if args.json:
        print(json.dumps({"model": str(targets[0]), "scene": str(targets[1]),
                          "tables": [str(p) for p in written[2:]]}, indent=1))
    else:
        for t in written[2:]:
            print(f"wrote {t} (a table the model reads)")
        print(f"wrote {targets[0]}\nwrote {targets[1]}\nnext: gearsym inspect {targets[1]}\n"
              f"      gearsym simulate {targets[1]} --out out/{args.name}")
    return 0
