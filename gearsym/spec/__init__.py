"""Spec layer: parse and validate model and scene files (no sympy here)."""

from .model import ModelSpec, load_model
from .scene import ResolvedScene, SceneSpec, load_scene_spec, resolve_scene

__all__ = ["ModelSpec", "ResolvedScene", "SceneSpec", "load_model", "load_scene_spec", "resolve_scene"]
