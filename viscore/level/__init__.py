"""Levels: a glTF scene graph or a split mesh as objects, the ones that get occluders,
the nodes a game does not draw, ground and up axis."""

from .ground import UP_AXES, guess_up
from .hidden_nodes import hidden_reason
from .objects import MIN_SIZE, SPLIT_RULES, LevelObjects, level_objects, occluder_objects
from .scene_graph import (
    SceneObjects,
    culling_scene_descriptions,
    culling_scene_names,
    culling_scene_path,
    load_scene_objects,
)

__all__ = ["LevelObjects", "level_objects", "occluder_objects", "MIN_SIZE", "SceneObjects",
           "load_scene_objects", "culling_scene_names",
           "culling_scene_descriptions", "culling_scene_path", "hidden_reason", "UP_AXES",
           "guess_up", "SPLIT_RULES"]
