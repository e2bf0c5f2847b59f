"""viscore: the ray-cast core of the toolkit. Geometry in, rays and images out.

Meshes are triangle soups loaded and validated by :func:`load_mesh`; a
:class:`Scene` owns the Embree handle and answers batched ray queries;
cameras make ray bundles; :mod:`viscore.images` turns them into coverage and
depth images; :mod:`viscore.voxels` voxelizes; samplers are seeded.
"""

from ._validate import InputError
from .builtin_scenes import scene_descriptions, scene_group, scene_names, scene_path
from .cameras import OrthoCamera, PerspectiveCamera, camera_basis, cube_cameras
from .depth_buffer import ConservativeDepthBuffer, OccluderScene
from .frustum_culler import FrustumCuller
from .images import coverage_image, depth_image
from .mesh_io import load_mesh, validate_mesh
from .occluder_files import OccluderInstance, load_occluder, occonly_glb_bytes, tres_text, tscn_text
from .run_provenance import provenance
from .samplers import (
    directions_fibonacci,
    directions_uniform,
    directions_uniform_batches,
    grid_positions,
    rays_between,
    stream_seed,
)
from .scene import AllHits, Scene, cpu_cores, get_workers, set_workers
from .scene_graph import SceneObjects, load_scene_objects
from .shadow_frusta import Frustum, polygon_frustum, solid_frustum
from .voxels import (
    VoxelGrid,
    Voxelization,
    inner_voxels_six_direction,
    inside_voxels_parity,
    outside_voxels,
    points_inside_parity,
    surface_voxels,
    voxel_boundary_mesh,
    voxel_grid,
    voxelize,
)
from .winding import points_inside, winding_numbers

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
