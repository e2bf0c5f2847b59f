"""Mesh and engine files: any mesh in as a validated soup, engines' occluders in and out."""

from .file_access import refuse_path
from .glb_targets import with_buffer_view_targets
from .gltf_meshopt import decode_meshopt_glb
from .godot_text import GODOT_DEFAULT_MASK, tscn_instances
from .mesh_io import SAVE_FORMATS, load_mesh, mesh_bytes, mesh_format, ply_bytes, save_mesh
from .mesh_validation import validate_mesh
from .occluder_files import (
    OccluderInstance,
    load_occluder,
    occonly_glb_bytes,
    tres_text,
    tscn_text,
    write_occluders,
)

__all__ = ["load_mesh", "save_mesh", "mesh_bytes", "mesh_format", "SAVE_FORMATS", "ply_bytes",
           "validate_mesh", "decode_meshopt_glb", "OccluderInstance", "load_occluder",
           "occonly_glb_bytes", "tres_text", "tscn_text", "write_occluders", "tscn_instances",
           "GODOT_DEFAULT_MASK", "refuse_path",
           "with_buffer_view_targets"]
