"""Occluders for a whole level: per distinct mesh and method, the runtimes they feed, engine files.

:func:`occlude_level` makes the occluders of a level's chosen objects
(:func:`viscore.level.level_objects`) and writes them as engine files;
:func:`culling_runtimes` builds the culling simulation's runtimes from them,
and :func:`culling_column` is ``compare``'s culling column.
"""

from viscore.level.objects import (
    FALLBACK_SHARE,
    FLAT_RATIO,
    LEVEL_SPAN,
    MIN_SIZE,
    PART_FRACTION,
    SEE_THROUGH_REFUSAL,
    SIZE_FACTOR,
    UP_AXES,
    LevelObjects,
    guess_up,
    level_objects,
    occluder_objects,
)

from .occlude import (
    JOB_DIR,
    MANIFEST_NAME,
    LevelOccluders,
    MeshOccluder,
    check_occlude_folder,
    default_methods,
    occlude_level,
    occluder_of_mesh,
)
from .occluders import (
    JOINED_METHODS,
    OCCLUDE_MANIFEST,
    file_occluder,
    generate_held,
    joined_occluder,
    scene_hierarchy,
    scene_occluders,
    transform_occluder,
)
from .runtimes import (
    column_piece,
    column_pieces,
    culling_column,
    culling_runtimes,
    frusta_method,
    guaranteed_methods,
    method_indices,
)

__all__ = ["occlude_level", "occluder_of_mesh", "LevelOccluders", "MeshOccluder",
           "default_methods", "check_occlude_folder", "MANIFEST_NAME", "JOB_DIR", "scene_occluders",
           "scene_hierarchy", "transform_occluder", "joined_occluder", "generate_held",
           "file_occluder", "JOINED_METHODS", "OCCLUDE_MANIFEST", "culling_runtimes",
           "culling_column", "column_pieces", "column_piece", "frusta_method",
           "method_indices", "guaranteed_methods",
           # the level's objects (viscore.level), for the old paths of this face's modules
           "LevelObjects", "level_objects", "occluder_objects", "guess_up", "MIN_SIZE",
           "SIZE_FACTOR", "PART_FRACTION", "FLAT_RATIO", "FALLBACK_SHARE", "LEVEL_SPAN",
           "UP_AXES", "SEE_THROUGH_REFUSAL"]
