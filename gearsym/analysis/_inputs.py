"""What every analysis takes: a compiled system, or a scene compiled on the way.

The analysis layer sits below the facade (:mod:`gearsym.facade`) and never imports it: a
scene is recognised by what it does (:class:`SceneLike`, it has ``compile()``), a compiled
system by its ``simulate``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

from ..errors import ParameterError

if TYPE_CHECKING:  # pragma: no cover
    from ..system import CompiledSystem

__all__ = ["SceneLike", "as_system", "is_scene"]


@runtime_checkable
class SceneLike(Protocol):
    """A scene as the analyses see it (:class:`gearsym.Scene`): it compiles to a system."""

    def compile(self) -> CompiledSystem:
        """The compiled system of the scene."""
        ...


def is_scene(target: object) -> bool:
    """Whether ``target`` is a scene (it compiles) rather than a compiled system (it simulates).

    Parameters
    ----------
    target
        A scene or a compiled system.

    Returns
    -------
    bool
    """
    return not hasattr(target, "simulate") and hasattr(target, "compile")


def as_system(target: CompiledSystem | SceneLike, what: str) -> CompiledSystem:
    """The compiled system of ``target`` (a compiled system, or a scene compiled here).

    Parameters
    ----------
    target
        A compiled system (``scene.compile()``) or a scene.
    what
        The analysis, for the error message.

    Returns
    -------
    CompiledSystem

    Raises
    ------
    ParameterError
        ``target`` is neither.
    """
    if hasattr(target, "simulate"):
        return target  # type: ignore[return-value]
    if hasattr(target, "compile"):
        return target.compile()
    raise ParameterError(f"{what} needs a compiled System (scene.compile()) or a Scene")
