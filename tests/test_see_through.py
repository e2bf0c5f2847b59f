"""See-through objects (transparent glTF materials): read, seen through by the truth, unbaked."""

import dataclasses

import numpy as np
import pytest
import trimesh
from test_culling import _cull_all, _pose
from test_scene_graph import _glb, _write
from trimesh.visual.material import PBRMaterial

from viscore.level import occluder_objects
from viscore.level.objects import SEE_THROUGH_REFUSAL, level_objects
from viscore.level.scene_graph import load_scene_objects
from viscore.metrics.culling import Runtime, no_culling, simulate_culling

_PRIM = {"attributes": {"POSITION": 0}, "indices": 1}


def test_gltf_blend_and_mask_materials_are_see_through(tmp_path):
    def alpha(a):
        return {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, a]}}

    materials = [{"alphaMode": "OPAQUE", **alpha(0.2)},   # opaque whatever its alpha
                 {"alphaMode": "BLEND", **alpha(0.3)},    # glass
                 {"alphaMode": "BLEND"},                  # blended, but alpha 1: opaque
                 {"alphaMode": "MASK", **alpha(0.0)},     # cut away: an invisible wall
                 {"alphaMode": "MASK", **alpha(0.6)}]     # over the 0.5 cutoff: opaque
    names = ["a_plain", "b_opaque", "c_glass", "d_blended_opaque", "e_invisible", "f_kept"]
    meshes = [{"primitives": [_PRIM]}] + [{"primitives": [{**_PRIM, "material": k}]}
                                          for k in range(len(materials))]
    nodes = [{"name": n, "mesh": m, "translation": [3.0 * m, 0.0, 0.0]}
             for m, n in enumerate(names)]
    path = _write(tmp_path, "level.glb", _glb(nodes, range(len(nodes)), meshes=meshes,
                                              materials=materials))
    objects = load_scene_objects(path)
    assert objects.names == tuple(names)
    assert objects.see_through.tolist() == [False, False, True, False, True, False]
    # the same box geometry is stored once; the flag belongs to the object
    assert len(objects.meshes) == 1


def _glass_scene(panes: int):
    """``panes`` glass walls (z = -3, -2, ...) in front of a wall hiding a box."""
    scene = trimesh.Scene()
    for k in range(panes):
        glass = trimesh.creation.box(bounds=[[-5, 0, -3.05 + k], [5, 6, -2.95 + k]])
        glass.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
            alphaMode="BLEND", baseColorFactor=[0.8, 0.9, 1.0, 0.25]))
        scene.add_geometry(glass, geom_name=f"glass{k}", node_name=f"glass{k}")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    return load_scene_objects(scene)


@pytest.mark.parametrize("panes", [1, 3])
def test_truth_sees_through_glass_and_not_through_the_same_opaque(panes):
    objects = _glass_scene(panes)
    assert objects.see_through.tolist() == [False] + [True] * panes  # box, glass0, ...
    runtimes = {"none": no_culling(), "all": Runtime(cull=_cull_all, conservative=False)}
    front = [_pose((0, 0.5, -10), (0, 0, 1))]  # the glass fills the view, the box behind
    seen = simulate_culling(objects, runtimes, front, width=96, height=54)
    assert seen.visible.tolist() == [panes + 1]  # every pane and the box
    assert seen.runtimes["all"].false_culls.tolist() == [panes + 1]
    opaque = dataclasses.replace(objects, see_through=None)
    hidden = simulate_culling(opaque, runtimes, front, width=96, height=54)
    assert hidden.visible.tolist() == [1]  # the first pane only
    assert hidden.runtimes["all"].false_culls.tolist() == [1]


def test_see_through_objects_get_no_occluders():
    objects = _glass_scene(1)
    level = level_objects(_as_scene(objects))
    names = [level.objects.names[i] for i in level.chosen]
    assert "glass0" not in names and "box" in names
    assert level.refused["glass0"] == SEE_THROUGH_REFUSAL
    assert occluder_objects(objects, size_threshold=0.1).tolist() == [0]  # the box only
    # named with --occluders, the user's choice stands
    assert occluder_objects(objects, names=["glass0"]).tolist() == [1]


def _as_scene(objects):
    """The objects back as a trimesh.Scene (glass materials kept), for level_objects."""
    scene = trimesh.Scene()
    for i, name in enumerate(objects.names):
        mesh = objects.object_mesh(i)
        if objects.see_through[i]:
            mesh.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
                alphaMode="BLEND", baseColorFactor=[0.8, 0.9, 1.0, 0.25]))
        scene.add_geometry(mesh, geom_name=name, node_name=name)
    return scene


@pytest.mark.parametrize("least, clear", [(249, False), (10, True)])
def test_blended_texture_alpha_decides(least, clear):
    # a ground exported with blending on but every texel near opaque (alpha >= 249/255)
    # is drawn opaque; one clear texel makes the surface see-through
    from PIL import Image

    pixels = np.full((8, 8, 4), 255, dtype=np.uint8)
    pixels[..., 3] = 250
    pixels[3, 4, 3] = least
    ground = trimesh.creation.box(bounds=[[-5, -0.1, -5], [5, 0, 5]])
    ground.visual = trimesh.visual.TextureVisuals(
        uv=np.zeros((len(ground.vertices), 2)),
        material=PBRMaterial(alphaMode="BLEND", baseColorTexture=Image.fromarray(pixels)))
    scene = trimesh.Scene()
    scene.add_geometry(ground, geom_name="ground", node_name="ground")
    assert load_scene_objects(scene).see_through.tolist() == [clear]
