"""A large level's joined occluder made district by district (``generators.levels.districts``)."""

import igl
import numpy as np
import trimesh

from viscore.generators.levels.districts import (
    DISTRICT_TRIANGLES,
    district_budgets,
    district_labels,
)
from viscore.generators.levels.occluders import joined_occluder
from viscore.level.scene_graph import load_scene_objects


def _town(blocks: int = 12, ground_cells: int = 48) -> trimesh.Scene:
    """A gently waved ground of ``ground_cells``^2 quads, 240 units across (y up), and
    ``blocks``^2 boxes on it, each a node."""
    scene = trimesh.Scene()
    x = np.linspace(-120, 120, ground_cells + 1)
    gx, gz = np.meshgrid(x, x)
    gy = 0.5 * np.sin(gx / 17.0) * np.cos(gz / 13.0)
    v = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    n = ground_cells + 1
    i, j = np.meshgrid(np.arange(ground_cells), np.arange(ground_cells), indexing="ij")
    a = (i * n + j).ravel()
    faces = np.concatenate([np.stack([a, a + n, a + 1], axis=1),
                            np.stack([a + 1, a + n, a + n + 1], axis=1)])
    scene.add_geometry(trimesh.Trimesh(v, faces, process=False), geom_name="ground",
                       node_name="ground")
    step = 200.0 / blocks
    for p in range(blocks):
        for q in range(blocks):
            lo = np.array([-100 + p * step + 2, 0.0, -100 + q * step + 2])
            box = trimesh.creation.box(bounds=[lo, lo + [step - 4, 6 + (p * q) % 5, step - 4]])
            scene.add_geometry(box, geom_name=f"b{p}_{q}", node_name=f"b{p}_{q}")
    return scene


def test_a_small_level_is_one_district():
    box = trimesh.creation.box()
    label, side = district_labels(box.vertices, box.faces, [0, 1, 0])
    assert side == 1 and (label == 0).all()


def test_districts_keep_planar_pieces_whole_and_cut_the_ground():
    """A ground quad of two triangles spanning the whole level lands in one district; the
    boxes' faces stay with their box's face; the side is sqrt(faces / 1000), at most 8."""
    town = _town()
    objects = load_scene_objects(town)
    v = np.concatenate([objects.object_vertices(i) for i in range(len(objects))])
    offsets = np.cumsum([0] + [len(objects.object_vertices(i)) for i in range(len(objects))])
    f = np.concatenate([np.asarray(objects.meshes[objects.mesh_ids[i]].faces) + offsets[i]
                        for i in range(len(objects))])
    # a flat quad under the whole level, two triangles
    big = len(v)
    v = np.concatenate([v, [[-130, -5, -130], [130, -5, -130], [130, -5, 130], [-130, -5, 130]]])
    f = np.concatenate([f, [[big, big + 2, big + 1], [big, big + 3, big + 2]]])
    label, side = district_labels(v, f, [0, 1, 0])
    assert side == min(8, int(np.sqrt(len(f) // DISTRICT_TRIANGLES))) and side >= 2
    assert label.min() >= 0 and label.max() < side * side
    assert label[-1] == label[-2]  # the quad's two triangles together
    assert len(np.unique(label[:-2])) > side  # the rest spread over the ground's squares
    # each box face (two coplanar triangles sharing an edge) in one district
    start = offsets[1]  # the first box's 12 faces
    box_faces = f[start:start + 12]
    normals = np.cross(v[box_faces[:, 1]] - v[box_faces[:, 0]],
                       v[box_faces[:, 2]] - v[box_faces[:, 0]])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    for k in range(12):
        mates = np.flatnonzero(np.abs(normals @ normals[k] - 1) < 1e-9)
        assert len(np.unique(label[start + mates])) == 1


def test_district_budgets_add_up_in_proportion_to_the_square_root_of_the_triangles():
    triangles = np.array([100, 400, 900, 1])
    share = district_budgets(triangles, 260)
    assert share.sum() == 260
    assert np.all(np.abs(share - 260 * np.array([10, 20, 30, 1]) / 61) < 1)


def test_a_large_levels_joined_occluder_is_made_by_districts_and_stays_on_the_surface():
    """The town above is cut into districts; the joined occluder keeps the budget, says it
    is guaranteed, and every one of its triangles lies on the level's own surface."""
    objects = load_scene_objects(_town(blocks=10, ground_cells=48))
    indices = np.arange(len(objects))
    occ = joined_occluder(objects, indices, "surface-patches", budget=600)
    assert occ.info["districts"] > 1
    assert occ.info["conservative_guaranteed"] is True
    assert 0 < occ.triangles <= 600 and not occ.info["over_budget"]
    level = trimesh.util.concatenate([objects.object_mesh(i) for i in indices])
    points = np.concatenate([occ.mesh.vertices, occ.mesh.triangles.mean(axis=1)])
    squared, _, _ = igl.point_mesh_squared_distance(
        np.ascontiguousarray(points), np.ascontiguousarray(level.vertices, dtype=np.float64),
        np.ascontiguousarray(level.faces, dtype=np.int64))
    assert np.sqrt(squared.max()) < 1e-5 * float(np.linalg.norm(np.ptp(level.vertices, axis=0)))
    whole = joined_occluder(objects, indices, "surface-patches", budget=None)
    assert whole.info["districts"] == 1  # no budget to share: made whole
