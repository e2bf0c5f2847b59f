"""viscore: the ray-cast core of the toolkit. Geometry in, rays and images out.

In folders by job: :mod:`viscore.ray` (the Embree :class:`Scene`, cameras,
coverage and depth images, seeded samplers), :mod:`viscore.exchange` (mesh
and engine files), :mod:`viscore.level` (a glTF level as objects),
:mod:`viscore.voxel` (voxels and winding numbers) and :mod:`viscore.culling`
(shadow frusta, the conservative depth buffer). The names most used are
re-exported here; the old flat module paths (``viscore.scene``,
``viscore.voxels``, ...) keep working through one alias table.
"""

from . import _moved
from ._validate import InputError
from .builtin_scenes import scene_descriptions, scene_group, scene_names, scene_path
from .culling import (
    ConservativeDepthBuffer,
    Frustum,
    FrustumCuller,
    OccluderScene,
    polygon_frustum,
    solid_frustum,
)
from .exchange import (
    OccluderInstance,
    load_mesh,
    load_occluder,
    occonly_glb_bytes,
    tres_text,
    tscn_text,
    validate_mesh,
)
from .level import SceneObjects, load_scene_objects
from .ray import (
    AllHits,
    OrthoCamera,
    PerspectiveCamera,
    Scene,
    camera_basis,
    coverage_image,
    cpu_cores,
    cube_cameras,
    depth_image,
    directions_fibonacci,
    directions_uniform,
    directions_uniform_batches,
    get_workers,
    grid_positions,
    rays_between,
    set_workers,
    stream_seed,
)
from .run_provenance import package_version, provenance
from .voxel import (
    VoxelGrid,
    Voxelization,
    inner_voxels_six_direction,
    inside_voxels_parity,
    outside_voxels,
    points_inside,
    points_inside_parity,
    surface_voxels,
    voxel_boundary_mesh,
    voxel_grid,
    voxelize,
    winding_numbers,
)

_moved.install()

#: The installed version of viscore ("unknown" in a bare checkout).
__version__ = package_version("viscore") or "unknown"

__all__ = [
    "points_inside", "winding_numbers",
    "InputError", "load_mesh", "validate_mesh", "load_occluder", "OccluderInstance", "tscn_text",
    "tres_text", "occonly_glb_bytes",
    "Scene", "AllHits", "set_workers", "get_workers", "OrthoCamera", "PerspectiveCamera",
    "cube_cameras", "camera_basis", "coverage_image", "depth_image", "directions_uniform",
    "directions_fibonacci", "grid_positions", "rays_between", "stream_seed", "provenance",
    "directions_uniform_batches", "cpu_cores",
    "scene_names", "scene_group", "ConservativeDepthBuffer", "OccluderScene", "Frustum",
    "FrustumCuller", "polygon_frustum", "solid_frustum", "SceneObjects", "load_scene_objects",
    "scene_path", "scene_descriptions", "VoxelGrid", "Voxelization", "voxel_grid",
    "surface_voxels", "outside_voxels", "inner_voxels_six_direction", "inside_voxels_parity",
    "points_inside_parity", "voxelize", "voxel_boundary_mesh",
]
