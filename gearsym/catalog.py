"""The models and scenes shipped with gearsym, addressable by name.

The shipped files live in the repository's top-level ``models/`` and ``scenes/``
folders; the wheel carries them as package data under ``gearsym/data/models`` and
``gearsym/data/scenes`` (``setup.py`` maps the folders into the package), so a scene's
``model = "../models/NAME.toml"`` resolves the same way in a checkout and in an
installed package.

Every command that takes a scene goes through :func:`find_scene` (and ``inspect``,
which also takes models, through :func:`find_spec_file`): an argument that names an
existing file, or ends in ``.toml``, is a path; anything else is the name of a shipped
scene (``gearsym simulate kahraman_singh``).

This module belongs to the spec layer: it reads TOML headers, never sympy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .errors import SpecError

__all__ = ["ShippedModel", "ShippedScene", "data_root", "find_scene", "find_spec_file", "shipped_models",
           "shipped_scenes"]

_PACKAGE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class ShippedScene:
    """A scene shipped with gearsym.

    Attributes
    ----------
    name
        The name it is addressed by (its file name without ``.toml``).
    path
        The scene file.
    description
        The scene's ``[scene] description``.
    model
        The name of its model file (without ``.toml``).
    """

    name: str
    path: Path
    description: str
    model: str


@dataclass(frozen=True)
class ShippedModel:
    """A model shipped with gearsym, with the paper it comes from.

    Attributes
    ----------
    name
        The name it is addressed by (its file name without ``.toml``).
    path
        The model file.
    description
        The model's ``[model] description``.
    reference
        The model's ``[model] reference`` (the paper), ``""`` if none.
    scenes
        Names of the shipped scenes that use it.
    """

    name: str
    path: Path
    description: str
    reference: str
    scenes: tuple[str, ...] = field(default=())


def data_root() -> Path:
    """The folder that holds the shipped ``models/`` and ``scenes/``.

    Returns
    -------
    Path
        ``gearsym/data`` of an installed wheel, else the top of the source checkout
        (an editable install or a ``PYTHONPATH`` checkout).

    Raises
    ------
    SpecError
        If neither exists (a broken install).
    """
    for root in (_PACKAGE / "data", _PACKAGE.parent):
        if (root / "scenes").is_dir() and (root / "models").is_dir():
            return root
    raise SpecError(f"the shipped models and scenes are missing (looked in {_PACKAGE / 'data'} and "
                    f"{_PACKAGE.parent}); reinstall gearsym")


def _files(kind: str) -> dict[str, Path]:
    return {p.stem: p for p in sorted((data_root() / kind).glob("*.toml")) if p.is_file()}


def _header(path: Path, section: str) -> dict:
    from .spec.files import read_toml

    head = read_toml(path, f"shipped {section} file")
    table = head.get(section, {})
    return table if isinstance(table, dict) else {}


def shipped_scenes() -> dict[str, ShippedScene]:
    """The shipped scenes by name.

    Returns
    -------
    dict
        Scene name -> :class:`ShippedScene`, sorted by name.
    """
    out = {}
    for name, path in _files("scenes").items():
        sc = _header(path, "scene")
        model = Path(str(sc.get("model", ""))).stem
        out[name] = ShippedScene(name, path, str(sc.get("description", "")).strip(), model)
    return out


def shipped_models() -> dict[str, ShippedModel]:
    """The shipped models by name, with their references and scenes.

    Returns
    -------
    dict
        Model name -> :class:`ShippedModel`, sorted by name.
    """
    scenes = shipped_scenes()
    out = {}
    for name, path in _files("models").items():
        m = _header(path, "model")
        uses = tuple(s.name for s in scenes.values() if s.model == name)
        out[name] = ShippedModel(name, path, " ".join(str(m.get("description", "")).split()),
                                 " ".join(str(m.get("reference", "")).split()), uses)
    return out


def _looks_like_path(text: str) -> bool:
    return text.endswith(".toml") or "/" in text or "\\" in text or text.startswith(".")


def find_scene(arg: str | Path) -> Path:
    """Resolve a scene argument: a scene file, or the name of a shipped scene.

    Parameters
    ----------
    arg
        A path (an existing file, or anything ending in ``.toml`` or containing a
        folder separator) or a shipped scene's name (``gearsym models`` lists them).

    Returns
    -------
    Path
        The scene file.  A path is returned as given (a missing file is reported by
        whoever reads it, with its name).

    Raises
    ------
    SpecError
        ``arg`` is neither an existing file nor the name of a shipped scene.
    """
    path = Path(arg)
    if isinstance(arg, Path) or path.exists() or _looks_like_path(str(arg)):
        return path
    scenes = _files("scenes")
    if str(arg) in scenes:
        return scenes[str(arg)]
    raise SpecError(f"no scene file '{arg}' and no shipped scene of that name (shipped scenes: "
                    f"{', '.join(scenes)}; `gearsym models` lists them)")


def find_spec_file(arg: str | Path) -> Path:
    """Resolve a scene *or model* argument (for ``gearsym inspect``).

    A name is looked up among the shipped scenes first, then the shipped models.

    Parameters
    ----------
    arg
        A path, or the name of a shipped scene or model.

    Returns
    -------
    Path
        The file.

    Raises
    ------
    SpecError
        ``arg`` is neither an existing file nor a shipped scene or model.
    """
    path = Path(arg)
    if isinstance(arg, Path) or path.exists() or _looks_like_path(str(arg)):
        return path
    scenes, models = _files("scenes"), _files("models")
    if str(arg) in scenes:
        return scenes[str(arg)]
    if str(arg) in models:
        return models[str(arg)]
    raise SpecError(f"no file '{arg}' and no shipped scene or model of that name (scenes: "
                    f"{', '.join(scenes)}; models: {', '.join(models)})")
