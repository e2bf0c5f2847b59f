"""viscore.generators: occluder generators, one folder per method family, plus baselines.

Every generator is ``function(mesh, *, budget=..., seed=..., **options) -> Occluder``
and is registered by its CLI name in :data:`REGISTRY`, with its options
declared (:class:`GeneratorSpec`, :class:`GeneratorOption`; beside the
generator, which checks its own arguments by them, where it has an ``OPTIONS``
table). Run one by name with :func:`generate`, which checks the options first
and flags an occluder over its budget. ``Occluder.parts`` follows the schema documented in
:mod:`viscore.generators.occluder` (:func:`check_parts`). Other packages add
methods under the ``viscore.generators`` entry points (plugins, see
:mod:`viscore.generators.registry`); :func:`check_generator`
(:mod:`viscore.generators.testing`) checks a method against the contract.
"""

from ._held_logs import UNHELD, call_held, portable, release, report_kinds, restored
from ._kernels import prepare_kernels
from .aabb_skins import boxes_mesh, generate_aabb_skins
from .baselines import generate_bbox, generate_godot, generate_original, generate_qem
from .hybrid import generate_hybrid, metric_guided_simplify
from .levels import (
    JOINED_METHODS,
    culling_column,
    culling_runtimes,
    default_methods,
    file_occluder,
    frusta_method,
    joined_occluder,
    occlude_level,
    occluder_objects,
    scene_occluders,
)
from .occluder import Occluder, check_parts
from .planar_hierarchy import (
    HierarchyIndex,
    build_hierarchy,
    cut_hierarchy,
    generate_planar_hierarchy,
    hierarchy_files,
    hierarchy_from_json,
    hierarchy_to_json,
    index_hierarchy,
)
from .planar_sections import generate_planar_sections
from .registry import (
    PLUGIN_GROUP,
    REGISTRY,
    GeneratorOption,
    GeneratorSpec,
    MethodVariant,
    PluginError,
    check_method,
    generate,
    get_generator,
    parse_method,
    plugin_versions,
)
from .solid_frusta import generate_solid_frusta
from .surface_patches import generate_surface_patches
from .testing import check_generator

__all__ = ["Occluder", "check_parts", "REGISTRY", "GeneratorSpec", "GeneratorOption",
           "generate", "get_generator", "parse_method", "check_method", "MethodVariant",
           "generate_aabb_skins", "boxes_mesh", "generate_qem",
           "generate_bbox", "generate_original", "generate_godot", "generate_planar_sections",
           "generate_solid_frusta", "generate_surface_patches", "build_hierarchy", "cut_hierarchy",
           "index_hierarchy",
           "HierarchyIndex", "generate_planar_hierarchy", "hierarchy_to_json",
           "hierarchy_files", "hierarchy_from_json", "generate_hybrid", "metric_guided_simplify",
           "occluder_objects", "scene_occluders", "file_occluder", "culling_runtimes",
           "frusta_method", "JOINED_METHODS", "joined_occluder", "occlude_level",
           "culling_column", "default_methods", "occlude_level",
           "culling_column", "default_methods",
           "PluginError", "PLUGIN_GROUP", "plugin_versions", "check_generator",
           "call_held", "portable", "restored", "release", "report_kinds", "UNHELD",
           "prepare_kernels"]
