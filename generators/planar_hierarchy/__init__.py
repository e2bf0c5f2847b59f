"""The occluder hierarchy of planar sections: a BVH over the objects, an occluder per node,
a tree cut per camera (Silvennoinen et al. 2014, sec. 5)."""

from .cut import HierarchyIndex, cut_hierarchy, index_hierarchy
from .generator import generate_planar_hierarchy
from .tree import NODE_OCCLUDERS, build_hierarchy, dilated_voxel_mesh, register_node_occluder
from .tree_json import hierarchy_files, hierarchy_from_json, hierarchy_to_json

__all__ = ["build_hierarchy", "cut_hierarchy", "index_hierarchy", "HierarchyIndex",
           "hierarchy_to_json", "hierarchy_files", "hierarchy_from_json",
           "generate_planar_hierarchy", "dilated_voxel_mesh", "NODE_OCCLUDERS",
           "register_node_occluder"]
