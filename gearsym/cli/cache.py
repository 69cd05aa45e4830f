"""``gearsym cache path|list|clear``: where builds go, what is there, and removing them.

Registered by :mod:`gearsym.cli.parser`.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

from ..errors import ParameterError
from .helptext import examples

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (`gearsym --version` stays light)
if TYPE_CHECKING:  # pragma: no cover
    from ..codegen.cache import BuildCache  # imports CasADi: only when the command runs

__all__ = ["add_cache_parser", "cmd_cache"]


def add_cache_parser(sub: argparse._SubParsersAction) -> None:
    """Register the ``cache`` subcommand on the CLI's subparsers."""
    p = sub.add_parser(
        "cache", help="where compiled builds go; list or remove them",
        description="Builds go to $GEARSYM_GENERATED if set, else to the user cache "
                    "(platformdirs' user cache: $XDG_CACHE_HOME/gearsym, else ~/.cache/gearsym); never to a "
                    "generated/ folder that happens to lie next to or above a scene (name a project's folder on purpose: "
                    "GEARSYM_GENERATED=generated).  A build is loaded only if this user's gearsym signed "
                    "it; 'clear' removes only such builds, never another folder.",
        epilog=examples(
            ("gearsym cache path kahraman_singh", "the folder of the scene's build"),
            ("gearsym cache list kahraman_singh --json", "its builds: size, date, key, whether this user's gearsym "
             "signed them"),
            note="gearsym cache clear --older-than 30 removes the builds older than 30 days."))
    p.add_argument("action", choices=["path", "list", "clear"],
                   help="path: print the build folder; list: the builds; clear: remove builds")
    p.add_argument("scene", nargs="?",
                   help="a scene file or shipped scene (its build folder; for list/clear only its builds) "
                        "or, for list/clear, a scene name")
    p.add_argument("--dir", help="the build cache folder (default: see above)")
    p.add_argument("--older-than", type=float, metavar="DAYS",
                   help="clear: only builds made more than DAYS days ago")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.set_defaults(func=cmd_cache)


def _root_and_scene(args: argparse.Namespace):
    from ..catalog import find_scene, shipped_scenes
    from ..codegen.cache import BuildCache
    from ..facade import default_generated_dir, load_scene

    scene = None
    name = None
    if args.scene:
        path = Path(args.scene)
        if path.suffix == ".toml" or path.exists() or (args.action == "path" and args.scene in shipped_scenes()):
            scene = load_scene(find_scene(args.scene))  # bad input gives the usual exit-2 message
            name = scene.name
        elif args.action == "path":
            raise ParameterError(f"cache path: '{args.scene}' is not a scene file or a shipped scene")
        else:
            name = args.scene
    if args.dir:
        root = Path(args.dir)
    else:
        root = default_generated_dir()
    return BuildCache(root), scene, name


def _size(n: int) -> str:
    return f"{n / 1024:.0f} KiB" if n < 1 << 20 else f"{n / (1 << 20):.1f} MiB"


def cmd_cache(args: argparse.Namespace) -> int:
    """Run ``gearsym cache ACTION``."""
    import json

    if args.older_than is not None:
        if args.action != "clear":
            raise ParameterError("--older-than applies to 'gearsym cache clear' only")
        if not (math.isfinite(args.older_than) and args.older_than >= 0):
            raise ParameterError(f"--older-than must be a number of days >= 0, got {args.older_than}")
    cache, scene, name = _root_and_scene(args)
    if args.action == "path":
        return _path(cache, scene, args.json)
    builds = [b for b in cache.builds() if name is None or b.scene == name]
    if args.action == "list":
        if args.json:
            print(json.dumps({"root": str(cache.root), "builds": [b.as_dict() for b in builds]}, indent=1))
            return 0
        print(f"{cache.root}: {len(builds)} build(s), {_size(sum(b.size for b in builds))}")
        for b in builds:
            when = time.strftime("%Y-%m-%d %H:%M", time.localtime(b.built))
            state = ("" if b.complete else "  (damaged: rebuilt when used)") if b.verified else \
                "  (not signed by your gearsym: never loaded, not removed by clear)"
            print(f"  {b.scene:28s} {b.model:24s} {_size(b.size):>10s}  {when}  {b.key[:16]}{state}")
        return 0
    removed = cache.clear(scene=name, older_than_days=args.older_than)
    freed = sum(b.size for b in removed)
    if args.json:
        print(json.dumps({"root": str(cache.root), "removed": [b.as_dict() for b in removed],
                          "freed_bytes": freed}, indent=1))
    else:
        print(f"{cache.root}: removed {len(removed)} build(s), {_size(freed)}")
    return 0


def _path(cache: BuildCache, scene, as_json: bool) -> int:
    import json

    info: dict[str, object] = {"root": str(cache.root),
                               "GEARSYM_GENERATED": os.environ.get("GEARSYM_GENERATED") or None}
    if scene is not None:
        from ..codegen.cache import build_key

        model_text = Path(scene.model_spec.path).read_text(encoding="utf-8")
        key, _ = build_key(model_text, scene.resolved.effects, scene.model_spec.form,
                           data=scene.model_spec.data_digest())
        entry = cache.entry(scene.name, key)
        info.update(scene=scene.name, build=str(entry.directory), key=key,
                    built=cache.lookup(entry, key) is not None)
    if as_json:
        print(json.dumps(info, indent=1))
    elif scene is None:
        print(cache.root)
    else:
        print(f"{info['build']}  ({'built' if info['built'] else 'not built yet'})")
    return 0
