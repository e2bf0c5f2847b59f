"""Every public name keeps importing from where it lived before the redesign.

The packages were split into family folders and modules by job (issue 19);
their faces re-export what they always exported. This table is each name of
``viscore.__all__``, ``viscore.metrics.__all__`` and ``viscore.generators.__all__``
with the public module that defined it before the move (names that lived in a
private module are listed under their package). A user's ``from
viscore.generators.planar_hierarchy import build_hierarchy`` must keep working.
"""

from __future__ import annotations

import importlib
import importlib.util

import pytest

#: Public module -> names it exported before the redesign (read off the release
#: before the move: each name's ``__module__``, or its package where that was private).
OLD_PATHS = {
    "viscore": ["InputError"],
    "viscore.builtin_scenes": ["scene_descriptions", "scene_group", "scene_names", "scene_path"],
    "viscore.cameras": ["OrthoCamera", "PerspectiveCamera", "camera_basis", "cube_cameras"],
    "viscore.depth_buffer": ["ConservativeDepthBuffer", "OccluderScene"],
    "viscore.frusta": ["Frustum", "FrustumCuller", "polygon_frustum", "solid_frustum"],
    "viscore.generators": ["REGISTRY", "metric_guided_simplify"],
    "viscore.generators.aabb_skins": ["boxes_mesh", "generate_aabb_skins"],
    "viscore.generators.baselines": ["generate_bbox", "generate_original", "generate_qem"],
    "viscore.generators.godot": ["generate_godot"],
    "viscore.generators.hybrid": ["generate_hybrid"],
    "viscore.generators.occluder": ["Occluder", "check_parts"],
    "viscore.generators.planar_hierarchy": [
        "HierarchyIndex", "build_hierarchy", "cut_hierarchy", "generate_planar_hierarchy",
        "hierarchy_from_json", "hierarchy_to_json", "index_hierarchy"],
    "viscore.generators.planar_sections": ["generate_planar_sections"],
    "viscore.generators.registry": [
        "GeneratorOption", "GeneratorSpec", "MethodVariant", "generate", "get_generator",
        "parse_method"],
    "viscore.generators.solid_frusta": ["generate_solid_frusta"],
    "viscore.images": ["coverage_image", "depth_image"],
    "viscore.mesh_io": ["load_mesh", "validate_mesh"],
    "viscore.metrics": ["PROTOCOLS", "SILHOUETTE_COLOURS", "evaluate"],
    "viscore.metrics.ablation": ["AblationResult", "convergence_ablation"],
    "viscore.metrics.assessment": ["OccluderAssessment", "assess_occluder"],
    "viscore.metrics.bayes": ["BetaModelSummary", "hierarchical_beta_model"],
    "viscore.metrics.bootstrap": ["bootstrap_ratio"],
    "viscore.metrics.conservativeness": [
        "ConservativenessReport", "assert_conservative", "check_conservative",
        "clopper_pearson_upper"],
    "viscore.metrics.culling": [
        "CullingResult", "Runtime", "camera_path", "culling_plot", "depth_buffer_runtime",
        "frusta_runtime", "no_culling", "read_camera_path", "simulate_culling"],
    "viscore.metrics.erosion": [
        "OcclusionMeasure", "directional_occlusion_measure", "erosion_curve",
        "occlusion_measure"],
    "viscore.metrics.orbit": ["orbit_precision_recall"],
    "viscore.metrics.paired": ["PairedDifference", "paired_difference"],
    "viscore.metrics.plots": ["ablation_plot", "distribution_plot"],
    "viscore.metrics.precision_recall": ["PrecisionRecall"],
    "viscore.metrics.quads": ["QuadCounts", "classify_quads", "classify_quads_depth",
                              "sample_quads"],
    "viscore.metrics.reference_views": ["ReferenceViews"],
    "viscore.metrics.silhouettes": ["silhouette_image"],
    "viscore.metrics.uncertainty": ["uncertainty_report"],
    "viscore.metrics.volume": ["volume_precision_recall"],
    "viscore.run_provenance": ["provenance"],
    "viscore.samplers": [
        "directions_fibonacci", "directions_uniform", "directions_uniform_batches",
        "grid_positions", "rays_between", "stream_seed"],
    "viscore.scene": ["AllHits", "Scene", "cpu_cores", "get_workers", "set_workers"],
    "viscore.scene_graph": ["SceneObjects", "load_scene_objects"],
    "viscore.voxels": [
        "VoxelGrid", "Voxelization", "inner_voxels_six_direction", "inside_voxels_parity",
        "outside_voxels", "points_inside_parity", "surface_voxels", "voxel_boundary_mesh",
        "voxel_grid", "voxelize"],
    "viscore.winding": ["points_inside", "winding_numbers"],
}

_PAIRS = [(module, name) for module, names in OLD_PATHS.items() for name in names]


@pytest.mark.parametrize(("module", "name"), _PAIRS, ids=[f"{m}.{n}" for m, n in _PAIRS])
def test_old_import_path_gives_the_face_object(module, name):
    """The old path still imports, and it is the very object the package face exports."""
    old = getattr(importlib.import_module(module), name)
    face = module if module in ("viscore", "viscore.metrics", "viscore.generators") else (
        "viscore.metrics" if module.startswith("viscore.metrics") else
        "viscore.generators" if module.startswith("viscore.generators") else "viscore")
    assert getattr(importlib.import_module(face), name) is old


def test_every_face_name_is_importable_from_its_face():
    """Each name in a face's ``__all__`` (new names included) is an attribute of the face."""
    for face in ("viscore", "viscore.metrics", "viscore.generators"):
        package = importlib.import_module(face)
        missing = [name for name in package.__all__ if not hasattr(package, name)]
        assert not missing, f"{face}.__all__ names what it does not export: {missing}"


#: Modules of the flat core before it was sorted into folders by job, with a name
#: each defined: ``import viscore.scene`` must keep working after the move.
FLAT_CORE = {
    "viscore.scene": "Scene", "viscore.cameras": "OrthoCamera", "viscore.images": "depth_image",
    "viscore.samplers": "stream_seed", "viscore.enclosing_ball": "minimum_enclosing_ball",
    "viscore.mesh_io": "load_mesh", "viscore.mesh_validation": "validate_mesh",
    "viscore.gltf_meshopt": "decode_meshopt_glb", "viscore.godot_text": "tscn_text",
    "viscore.godot_binary": "_load_occ", "viscore.occonly_gltf": "occonly_glb_bytes",
    "viscore.occluder_files": "load_occluder", "viscore.scene_graph": "SceneObjects",
    "viscore.hidden_nodes": "hidden_reason", "viscore.ground": "guess_up",
    "viscore.voxels": "voxelize", "viscore.winding": "winding_numbers",
    "viscore.wall_thickness": "wall_thickness", "viscore.coverage_hull": "covered_voxels",
    "viscore.depth_buffer": "ConservativeDepthBuffer", "viscore.shadow_frusta": "solid_frustum",
    "viscore.frustum_culler": "FrustumCuller", "viscore.occludee_bounds": "cluster_boxes",
    "viscore.frusta": "FrustumCuller",
}


@pytest.mark.parametrize(("old", "name"), sorted(FLAT_CORE.items()))
def test_flat_core_path_is_the_moved_module(old, name):
    """``import viscore.<old>`` gives the very module at its new path (one alias table)."""
    import sys

    from viscore._moved import MOVED

    module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED[old])
    assert module.__spec__.name == MOVED[old]  # the module keeps its own spec
    assert sys.modules[old] is module
    assert getattr(module, name) is getattr(importlib.import_module(MOVED[old]), name)


def test_alias_table_points_at_existing_modules():
    from viscore._moved import MOVED

    for old, new in MOVED.items():
        assert importlib.util.find_spec(new) is not None, f"{old} -> {new}: no such module"
        assert old != new


#: Names that left the command line for the library (issue 42: no library code in the
#: CLI): (old module, old name) -> (the face that offers them now, its name). The old
#: path keeps giving the very object.
MOVED_OUT_OF_CLI = {
    ("viscore.cli.bench.godot_bake", "scene_instances"): ("viscore.exchange", "tscn_instances"),
    ("viscore.cli.bench.godot_bake", "GODOT_DEFAULT_MASK"):
        ("viscore.exchange", "GODOT_DEFAULT_MASK"),
    ("viscore.cli.bench.godot_bake", "match_triangles"): ("viscore.metrics", "match_triangles"),
    ("viscore.cli.bench.godot_bake", "surface_distance"):
        ("viscore.metrics", "surface_distance"),
    ("viscore.cli.study.store", "lock_exclusive"): ("viscore._atomic", "lock_exclusive"),
    ("viscore.cli.study.runner", "JOBS_PER_CORE"): ("viscore._jobs", "JOBS_PER_CORE"),
    ("viscore.cli.study", "JOBS_PER_CORE"): ("viscore._jobs", "JOBS_PER_CORE"),
}


@pytest.mark.parametrize(("old", "new"), sorted(MOVED_OUT_OF_CLI.items()),
                         ids=[f"{m}.{n}" for m, n in sorted(MOVED_OUT_OF_CLI)])
def test_name_moved_out_of_the_cli_keeps_its_old_path(old, new):
    moved = getattr(importlib.import_module(new[0]), new[1])
    assert getattr(importlib.import_module(old[0]), old[1]) is moved


#: The faces the command line imports through, beyond the three above: each name on their
#: ``__all__`` is there.
CLI_FACES = ("viscore.ray", "viscore.exchange", "viscore.level", "viscore.voxel",
             "viscore.culling", "viscore.generators.levels", "viscore.generators.baselines")


@pytest.mark.parametrize("face", CLI_FACES)
def test_every_name_of_a_subpackage_face_is_importable(face):
    package = importlib.import_module(face)
    missing = [name for name in package.__all__ if not hasattr(package, name)]
    assert not missing, f"{face}.__all__ names what it does not export: {missing}"
