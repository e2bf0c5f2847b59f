"""Levels: a glTF scene graph as objects, the nodes a game does not draw, ground and up axis."""

from .ground import UP_AXES, guess_up
from .hidden_nodes import hidden_reason
from .scene_graph import (
    SceneObjects,
    culling_scene_descriptions,
    culling_scene_names,
    culling_scene_path,
    load_scene_objects,
)

__all__ = ["SceneObjects", "load_scene_objects", "culling_scene_names",
           "culling_scene_descriptions", "culling_scene_path", "hidden_reason", "UP_AXES",
           "guess_up"]
