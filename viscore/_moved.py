"""Old module paths of moved modules, kept working by one alias table."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

#: Old dotted module path -> the module that holds its contents now.
MOVED = {
    "viscore.scene": "viscore.ray.embree_scene",
    "viscore.cameras": "viscore.ray.cameras",
    "viscore.images": "viscore.ray.images",
    "viscore.samplers": "viscore.ray.samplers",
    "viscore.enclosing_ball": "viscore.ray.enclosing_ball",
    "viscore.mesh_io": "viscore.exchange.mesh_io",
    "viscore.mesh_validation": "viscore.exchange.mesh_validation",
    "viscore.gltf_meshopt": "viscore.exchange.gltf_meshopt",
    "viscore.godot_text": "viscore.exchange.godot_text",
    "viscore.godot_binary": "viscore.exchange.godot_binary",
    "viscore.occonly_gltf": "viscore.exchange.occonly_gltf",
    "viscore.occluder_files": "viscore.exchange.occluder_files",
    "viscore.scene_graph": "viscore.level.scene_graph",
    "viscore.hidden_nodes": "viscore.level.hidden_nodes",
    "viscore.ground": "viscore.level.ground",
    "viscore.voxels": "viscore.voxel.grid",
    "viscore._sat_kernel": "viscore.voxel._sat_kernel",
    "viscore.winding": "viscore.voxel.winding",
    "viscore.wall_thickness": "viscore.voxel.wall_thickness",
    "viscore.coverage_hull": "viscore.voxel.coverage_hull",
    "viscore.depth_buffer": "viscore.culling.depth_buffer",
    "viscore._depth_kernel": "viscore.culling._depth_kernel",
    "viscore._patches": "viscore.culling._creases",
    "viscore.shadow_frusta": "viscore.culling.shadow_frusta",
    "viscore.frustum_culler": "viscore.culling.frustum_culler",
    "viscore._frusta_kernel": "viscore.culling._culler_kernel",
    "viscore.occludee_bounds": "viscore.culling.occludee_bounds",
    "viscore.frusta": "viscore.culling",
    "viscore.generators.level_objects": "viscore.generators.levels",
    "viscore.generators.level_occluders": "viscore.generators.levels",
    "viscore.generators.scene_occluders": "viscore.generators.levels",
}


#: Real module name -> its own spec, kept while an alias of it is loaded.
_OWN_SPECS: dict = {}


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old path in :data:`MOVED` and loads it as the module at its new path."""

    def find_spec(self, name, path=None, target=None):
        if name not in MOVED:
            return None
        return importlib.util.spec_from_loader(name, self)

    def create_module(self, spec):
        module = importlib.import_module(MOVED[spec.name])
        _OWN_SPECS[module.__name__] = module.__spec__
        return module

    def exec_module(self, module):
        # the import system set __spec__ to the alias's: give the module its own back
        module.__spec__ = _OWN_SPECS[module.__name__]


def install() -> None:
    """Put the alias finder on :data:`sys.meta_path` once."""
    if not any(isinstance(f, _Alias) for f in sys.meta_path):
        sys.meta_path.append(_Alias())
