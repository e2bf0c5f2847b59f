"""Hierarchical occluders (Silvennoinen et al. 2014, sec. 5): BVH, per-node occluders, tree cut.

Built with the quick ``qem`` node builder on small voxel grids: the properties
tested here (nesting, objects per leaf, error order, the cut, files) do not
depend on which builder makes each node's occluder.
"""

import json
import logging

import numpy as np
import pytest
import trimesh

import viscore
from viscore import InputError
from viscore.generators.occluder import check_parts
from viscore.generators.planar_hierarchy import (
    build_hierarchy,
    cut_hierarchy,
    dilated_voxel_mesh,
    generate_planar_hierarchy,
    hierarchy_files,
    hierarchy_from_json,
    hierarchy_to_json,
    index_hierarchy,
)


def _walk(root):
    out, stack = [], [root]
    while stack:
        n = stack.pop()
        out.append(n)
        stack.extend(reversed(n["children"]))
    return out


def _leaves(root):
    return [n for n in _walk(root) if not n["children"]]


@pytest.fixture(scope="module")
def city():
    mesh = viscore.load_mesh("city-block")
    return mesh, build_hierarchy(mesh, node_occluder="qem", budget=32, voxels=12, max_leaves=8)


@pytest.fixture(scope="module")
def boxes_row():
    """Six unit boxes along X, 0.5 apart: six objects."""
    boxes = [trimesh.creation.box(bounds=[[1.5 * i, 0, 0], [1.5 * i + 1, 1, 1]])
             for i in range(6)]
    return boxes, build_hierarchy(boxes, node_occluder="qem", budget=12, voxels=8)


def _components(mesh):
    return len(mesh.split(only_watertight=False))


def test_build_hierarchy_bounds_nest(city):
    _, root = city
    assert check_parts({"hierarchy": root}) == {"hierarchy": len(_walk(root))}
    for node in _walk(root):
        for key in ("bounds", "geometry_bounds"):
            for child in node["children"]:
                assert (child[key][0] >= node[key][0]).all()
                assert (child[key][1] <= node[key][1]).all()
        # bounds hold the geometry grown by the error and the node's occluder
        assert (node["bounds"][0] <= node["geometry_bounds"][0] - node["error"]).all()
        assert (node["bounds"][1] >= node["geometry_bounds"][1] + node["error"]).all()
        assert (node["bounds"][0] <= node["occluder"].bounds[0]).all()
        assert (node["bounds"][1] >= node["occluder"].bounds[1]).all()


def test_build_hierarchy_every_object_in_exactly_one_leaf(city):
    mesh, root = city
    leaves = _leaves(root)
    assert len(leaves) == 8  # max_leaves
    objects = np.concatenate([leaf["objects"] for leaf in leaves])
    assert sorted(objects.tolist()) == list(range(_components(mesh)))
    for node in _walk(root):
        if node["children"]:
            below = np.concatenate([c["objects"] for c in node["children"]])
            assert sorted(below.tolist()) == sorted(node["objects"].tolist())


def test_build_hierarchy_one_object_per_leaf_without_a_cap(boxes_row):
    _, root = boxes_row
    leaves = _leaves(root)
    assert sorted(int(leaf["objects"][0]) for leaf in leaves) == list(range(6))
    assert all(len(leaf["objects"]) == 1 for leaf in leaves)
    assert len(_walk(root)) == 11  # a binary tree: 2 * leaves - 1
    # median split along X: the left child holds the three left boxes
    assert sorted(root["children"][0]["objects"].tolist()) == [0, 1, 2]


def test_build_hierarchy_error_monotone_down_the_tree(city):
    _, root = city
    for node in _walk(root):
        assert node["error"] >= node["voxel_size"] > 0
        for child in node["children"]:
            assert child["error"] <= node["error"]
            assert child["voxel_size"] <= node["voxel_size"]
        # inner nodes are dilated once, leaves not
        assert node["dilation"] == (1 if node["children"] else 0)


def test_build_hierarchy_soup_components_over_merged_vertices():
    # 40 boxes as an unmerged soup (three vertices per triangle, as STL gives): 40 objects,
    # not 480; capped at 4 leaves of 10 neighbouring boxes
    boxes = [trimesh.creation.box(bounds=[[2.0 * i, 0, 0], [2.0 * i + 1, 1, 1]])
             for i in range(40)]
    merged = trimesh.util.concatenate(boxes)
    tri = merged.vertices[merged.faces].reshape(-1, 3)
    soup = trimesh.Trimesh(tri, np.arange(len(tri)).reshape(-1, 3), process=False)
    root = build_hierarchy(soup, node_occluder="qem", budget=12, voxels=4, max_leaves=4)
    leaves = _leaves(root)
    assert len(root["objects"]) == 40 and len(leaves) == 4
    assert sorted(len(leaf["objects"]) for leaf in leaves) == [10, 10, 10, 10]
    for leaf in leaves:  # spatially compact: ten consecutive boxes along X
        lo, hi = leaf["geometry_bounds"][:, 0]
        assert hi - lo == pytest.approx(19.0)


def test_build_hierarchy_builder_contract():
    calls = []

    def with_dilation(mesh, *, budget, seed, voxel_size, dilation):
        calls.append(("dilation", len(mesh.faces), voxel_size, dilation))
        return trimesh.creation.box(bounds=mesh.bounds)

    def without(mesh, *, budget, seed, voxels):
        calls.append(("plain", bool(mesh.is_watertight), voxels, len(mesh.faces)))
        return trimesh.creation.box(bounds=mesh.bounds)

    pair = [trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]),
            trimesh.creation.box(bounds=[[1.1, 0, 0], [2.1, 1, 1]])]
    build_hierarchy(pair, node_occluder=with_dilation, budget=12, voxels=10)
    # children first: two leaves (12 triangles each, no dilation), then the root (both boxes)
    assert [c[3] for c in calls] == [0, 0, 1]
    assert [c[1] for c in calls] == [12, 12, 24]
    assert calls[2][2] == pytest.approx(0.21)  # longest side 2.1 / 10 voxels
    calls.clear()
    root = build_hierarchy(pair, node_occluder=without, budget=12, voxels=10)
    # the root gets the closed voxel mesh of its dilated solid: glued, one component
    kind, watertight, voxels, _ = calls[2]
    assert kind == "plain" and watertight and voxels == 10 + 2 + 1  # grown by 1.5 voxels a side
    assert root["error"] == pytest.approx(0.21 * 2.5)


def test_dilated_voxel_mesh_glues_near_objects_only():
    a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    near = trimesh.creation.box(bounds=[[1.15, 0, 0], [2.15, 1, 1]])
    far = trimesh.creation.box(bounds=[[1.55, 0, 0], [2.55, 1, 1]])
    for other, parts in ((near, 1), (far, 2)):
        m = dilated_voxel_mesh(trimesh.util.concatenate([a, other]), voxel_size=0.1)
        assert m.is_watertight and _components(m) == parts
    one = dilated_voxel_mesh(a, voxel_size=0.1, dilation=1)
    plain = dilated_voxel_mesh(a, voxel_size=0.1, dilation=0)
    # one dilation step grows the solid by one voxel layer on every side (6-neighbourhood)
    assert plain.extents[0] + 0.2 == pytest.approx(one.extents[0])


def test_cut_hierarchy_far_camera_takes_the_root_near_takes_leaves(city):
    _, root = city
    assert [n["id"] for n in cut_hierarchy(root, (1e7, 0, 0))] == [0]
    # a camera inside a leaf's bounds descends to that leaf
    leaf = _leaves(root)[3]
    inside = leaf["bounds"].mean(axis=0)
    assert any(n is leaf for n in cut_hierarchy(root, inside))
    # an error tolerance of almost nothing takes every leaf
    cut = cut_hierarchy(root, (50.0, 0, 0), pixel_error=1e-12)
    assert [n["id"] for n in cut] == [n["id"] for n in _leaves(root)]


def test_cut_hierarchy_threshold_is_the_projected_error():
    leaf = {"bounds": np.array([[0.0, 0, 0], [1, 1, 1]]), "error": 0.01, "children": []}
    other = {"bounds": np.array([[2.0, 0, 0], [3, 1, 1]]), "error": 0.01, "children": []}
    root = {"bounds": np.array([[0.0, 0, 0], [3, 1, 1]]), "error": 0.1,
            "children": [leaf, other]}
    # 90 degrees over 100 pixels: at distance d the error spans 0.1 * 100 / (2 d) pixels,
    # below 1 pixel beyond d = 5
    for d, expect in ((4.9, 2), (5.1, 1)):
        cut = cut_hierarchy(root, (3 + d, 0.5, 0.5), fov_degrees=90, screen_pixels=100)
        assert len(cut) == expect


def test_cut_hierarchy_is_a_proper_cut(city):
    _, root = city
    index = index_hierarchy(root)
    nodes = list(index.nodes)
    pos = {id(n): i for i, n in enumerate(nodes)}
    leaves = np.flatnonzero(index.leaf)
    rng = np.random.default_rng(7)
    sizes = set()
    for _ in range(200):
        cam = rng.normal(size=3) * 10.0 ** rng.uniform(-1, 3)
        chosen = {pos[id(n)] for n in cut_hierarchy(index, cam, pixel_error=4.0)}
        sizes.add(len(chosen))
        for leaf in leaves:
            path, i = [], int(leaf)
            while i >= 0:
                path.append(i)
                i = int(index.parent[i])
            assert len(chosen.intersection(path)) == 1
    assert len(sizes) > 2  # cameras near and far give different cuts


def test_hierarchy_json_round_trip(city, tmp_path):
    _, root = city
    path = hierarchy_to_json(root, tmp_path, "city")
    assert path == tmp_path / "city.hierarchy.json"
    doc = json.loads(path.read_text())
    assert [r["id"] for r in doc["nodes"]] == list(range(len(_walk(root))))
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left
    back = hierarchy_from_json(path)
    assert check_parts({"hierarchy": back}) == check_parts({"hierarchy": root})
    for a, b in zip(_walk(root), _walk(back), strict=True):
        assert a["id"] == b["id"] and a["error"] == b["error"]
        np.testing.assert_array_equal(a["bounds"], b["bounds"])
        np.testing.assert_array_equal(a["objects"], b["objects"])
        np.testing.assert_array_equal(a["occluder"].vertices, b["occluder"].vertices)
        np.testing.assert_array_equal(a["occluder"].faces, b["occluder"].faces)
        assert [c["id"] for c in a["children"]] == [c["id"] for c in b["children"]]
    for cam in ((30.0, 0, 0), (2.0, 2.0, 1.0), (0.0, 0.0, 1.0)):
        assert ([n["id"] for n in cut_hierarchy(root, cam)]
                == [n["id"] for n in cut_hierarchy(back, cam)])


def test_hierarchy_files_are_the_written_set_json_last(boxes_row, tmp_path):
    _, root = boxes_row
    files = hierarchy_files(root, "row")
    assert list(files)[-1] == "row.hierarchy.json"
    assert list(files)[:-1] == [f"row.node{i:04d}.ply" for i in range(len(_walk(root)))]
    hierarchy_to_json(root, tmp_path, "row")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == files


def test_hierarchy_json_is_written_all_or_none(boxes_row, tmp_path, monkeypatch):
    """Issue 23: a disk error on the 5th file left the first four beside no JSON."""
    from viscore._atomic import FileSet

    _, root = boxes_row
    real, calls = FileSet.write, []

    def write(self, name, data):
        calls.append(name)
        if len(calls) == 5:
            raise OSError(28, "No space left on device", str(self.folder / name))
        return real(self, name, data)

    monkeypatch.setattr(FileSet, "write", write)
    with pytest.raises(OSError, match="No space"):
        hierarchy_to_json(root, tmp_path, "row")
    assert len(calls) == 5 and list(tmp_path.iterdir()) == []


def test_generate_planar_hierarchy_returns_the_root(boxes_row):
    boxes, _ = boxes_row
    occ = generate_planar_hierarchy(boxes, budget=12, voxels=8, node_occluder="qem")
    root = occ.parts["hierarchy"]
    assert check_parts(occ.parts) == {"hierarchy": 11}
    assert occ.mesh is root["occluder"] and occ.triangles <= 12
    assert occ.info["nodes"] == 11 and occ.info["leaves"] == 6 and occ.info["objects"] == 6
    assert occ.info["node_triangles"] == sum(n["triangles"] for n in _walk(root))


def test_build_hierarchy_invalid_input():
    box = trimesh.creation.box()
    for bad, kwargs in (([], {}), ("city-block", {}), ([box, "x"], {}),
                        (box, {"budget": 0}), (box, {"voxels": 0}), (box, {"leaf_objects": 0}),
                        (box, {"max_leaves": -1}), (box, {"seed": -1}),
                        (box, {"node_occluder": "nope"}), (box, {"voxel_size": 0.1}),
                        (box, {"dilate": 1}), (box, {"inner_dilation": True})):
        with pytest.raises(InputError):
            build_hierarchy(bad, **kwargs)
    with pytest.raises(InputError):
        generate_planar_hierarchy(box, node_occluder="nope")


def test_cut_hierarchy_invalid_input(boxes_row):
    _, root = boxes_row
    for cam, kwargs in (((np.nan, 0, 0), {}), ((0, 0), {}), ((9, 9, 9), {"fov_degrees": 180}),
                        ((9, 9, 9), {"fov_degrees": 0}), ((9, 9, 9), {"screen_pixels": 0}),
                        ((9, 9, 9), {"pixel_error": 0})):
        with pytest.raises(InputError):
            cut_hierarchy(root, cam, **kwargs)
    for tree in ([], {"bounds": [[0, 0, 0], [1, 1, 1]]},
                 {"bounds": [[1, 0, 0], [0, 1, 1]], "error": 0.1, "children": []},
                 {"bounds": [[0, 0, 0], [1, 1, 1]], "error": -1.0, "children": []}):
        with pytest.raises(InputError):
            cut_hierarchy(tree, (9, 9, 9))


def test_hierarchy_json_invalid_input(boxes_row, tmp_path):
    _, root = boxes_row
    with pytest.raises(InputError):
        hierarchy_to_json(root, tmp_path / "missing", "x")
    with pytest.raises(InputError):
        hierarchy_to_json(root, tmp_path, "a/b")
    assert not list(tmp_path.iterdir())  # nothing written
    path = hierarchy_to_json(root, tmp_path, "row")
    doc = json.loads(path.read_text())
    cases = {
        "garbage": b"{not json",
        "format": json.dumps({**doc, "format": "other"}).encode(),
        "escape": json.dumps({**doc, "nodes": [{**doc["nodes"][0], "mesh": "../x.ply"}]
                              + doc["nodes"][1:]}).encode(),
        "cycle": json.dumps({**doc, "nodes": [{**doc["nodes"][0], "children": [0]}]
                             + doc["nodes"][1:]}).encode(),
    }
    for name, data in cases.items():
        bad = tmp_path / f"{name}.hierarchy.json"
        bad.write_bytes(data)
        with pytest.raises(InputError):
            hierarchy_from_json(bad)
    (tmp_path / "row.node0001.ply").unlink()
    with pytest.raises(InputError):
        hierarchy_from_json(path)
    with pytest.raises(InputError):
        hierarchy_from_json(tmp_path / "none.json")


def test_generate_planar_hierarchy_refuses_per_object_sizing(boxes_row):
    boxes, _ = boxes_row
    for kwargs in ({"voxel_size": 0.1}, {"pixel_error": 1.0}, {"distance": 10.0},
                   {"lod_distances": "10,40"}, {"dilate": 1}, {"conservative": "yes"}):
        with pytest.raises(InputError, match=next(iter(kwargs))):
            generate_planar_hierarchy(boxes, node_occluder="qem", **kwargs)


def test_build_hierarchy_inner_dilation_option(boxes_row):
    boxes, dilated = boxes_row
    plain = build_hierarchy(boxes, node_occluder="qem", budget=12, voxels=8, inner_dilation=0)
    assert all(n["dilation"] == 0 for n in _walk(plain))
    # the same voxel sizes; the error drops the dilation's voxel at inner nodes
    for a, b in zip(_walk(plain), _walk(dilated), strict=True):
        assert a["voxel_size"] == b["voxel_size"]
        assert a["error"] <= b["error"]
    with pytest.raises(InputError):
        build_hierarchy(boxes, node_occluder="qem", inner_dilation=9)


@pytest.mark.slow
def test_generate_planar_hierarchy_with_planar_sections():
    pytest.importorskip("viscore.generators.planar_sections")
    boxes = [trimesh.creation.box(bounds=[[1.5 * i, 0, 0], [1.5 * i + 1, 1, 1]])
             for i in range(3)]
    # every option planar sections hands over for --hierarchy, at its defaults
    handed = {"voxel_size": None, "direction_bins": 16, "depth_bins": 4, "alpha": 1.0,
              "measure": "om", "reduce": "area", "conservative": False, "pixel_error": None,
              "distance": None, "fov": 60.0, "screen": 1920, "lod_distances": None, "dilate": 0}
    occ = generate_planar_hierarchy(boxes, budget=16, seed=0, voxels=12, **handed)
    root = occ.parts["hierarchy"]
    assert occ.info["builder"] == "planar-sections" and occ.double_sided
    assert check_parts(occ.parts) == {"hierarchy": 5}
    for node in _walk(root):
        assert 0 < node["triangles"] <= 16 and not node["note"]
        # planar sections takes the dilation itself: error = voxel * (1 + dilation)
        assert node["error"] == pytest.approx(node["voxel_size"] * (1 + node["dilation"]))
        # the occluder stays within about two voxels beyond the dilated solid (pixel
        # footprint and RDP tolerance of sec. 4.3)
        lo, hi = node["occluder"].bounds
        reach = node["error"] + 2 * node["voxel_size"]
        assert (lo >= node["geometry_bounds"][0] - reach).all()
        assert (hi <= node["geometry_bounds"][1] + reach).all()


def test_build_hierarchy_builder_refusals():
    def refuse_all(mesh, *, budget, seed):
        raise InputError("alpha: expected a percentage >= 0")

    def refuse_small(mesh, *, budget, seed):
        if mesh.extents.max() < 1.5:
            raise InputError("too small")
        return trimesh.creation.box(bounds=mesh.bounds)

    pair = [trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]]),
            trimesh.creation.box(bounds=[[2, 0, 0], [3, 1, 1]])]
    with pytest.raises(InputError, match="every node failed.*alpha"):
        build_hierarchy(pair, node_occluder=refuse_all, voxels=4)
    root = build_hierarchy(pair, node_occluder=refuse_small, voxels=4)
    assert root["triangles"] == 12 and not root["note"]
    assert all(leaf["triangles"] == 0 and leaf["note"] == "too small" for leaf in _leaves(root))


def _open_node_builder(mesh, *, budget, seed):
    """A builder that warns at every node and refuses the small ones."""
    logging.getLogger("viscore.generators.test_node_builder").warning("the node is open")
    if mesh.extents.max() < 1.5:
        raise InputError("too small")
    return trimesh.creation.box(bounds=mesh.bounds)


def _three_boxes():
    return [trimesh.creation.box(bounds=[[2.0 * i, 0, 0], [2.0 * i + 1, 1, 1]])
            for i in range(3)]


def test_build_hierarchy_says_each_builder_line_once(caplog):
    """Issue 23: a warning per node (29 times on city-block) is one line with its count."""
    caplog.set_level(logging.INFO, logger="viscore")
    root = build_hierarchy(_three_boxes(), node_occluder=_open_node_builder, voxels=4)
    assert len(_walk(root)) == 5
    said = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert said == ["hierarchy: 5 of 5 nodes: the node is open",
                    "hierarchy: 3 of 5 nodes: no occluder: too small"]
    assert [leaf["note"] for leaf in _leaves(root)] == ["too small"] * 3


def test_build_hierarchy_every_node_refused_is_the_error_alone(caplog):
    def refuse_all(mesh, *, budget, seed):
        raise InputError("alpha: expected a percentage >= 0")

    caplog.set_level(logging.INFO, logger="viscore")
    with pytest.raises(InputError, match="every node failed"):
        build_hierarchy(_three_boxes(), node_occluder=refuse_all, voxels=4)
    assert [r.getMessage() for r in caplog.records] == []


def test_build_hierarchy_small_object_beside_a_large_one_keeps_its_faces():
    # a 1e-4 box beside a 1e3 box: its faces would be degenerate at the scene's scale
    big = trimesh.creation.box(extents=(1e3, 1e3, 1e3))
    small = trimesh.creation.box(extents=(1e-4,) * 3)
    small.apply_translation((2e3, 0, 0))
    root = build_hierarchy([big, small], node_occluder="qem", budget=12, voxels=8)
    assert [c["triangles"] for c in root["children"]] == [12, 12]
    assert root["children"][1]["voxel_size"] == pytest.approx(1e-4 / 8)


def test_build_hierarchy_default_builder_is_planar_sections():
    from viscore.generators.planar_hierarchy.tree import _resolve_builder
    from viscore.generators.planar_sections import generate_planar_sections

    assert _resolve_builder(None) == (generate_planar_sections, "planar-sections")


def test_build_hierarchy_in_two_processes_builds_the_same_tree(caplog):
    boxes = [trimesh.creation.box(bounds=[[1.5 * i, 0, 0], [1.5 * i + 1, 1, 1]])
             for i in range(4)]
    sheet = trimesh.Trimesh([[0, 3, 0], [4, 3, 0], [4, 4, 0]], [[0, 1, 2]])  # nothing to slice
    kw = dict(node_occluder="planar-sections", budget=8, voxels=8, direction_bins=4,
              depth_bins=1, min_precision=0)
    with caplog.at_level(logging.WARNING):
        one = build_hierarchy(boxes + [sheet], jobs=1, **kw)
        said_one = [r.getMessage() for r in caplog.records]
        caplog.clear()
        two = build_hierarchy(boxes + [sheet], jobs=2, **kw)
        said_two = [r.getMessage() for r in caplog.records]
    a, b = _walk(one), _walk(two)
    assert len(a) == len(b) == 9
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x["occluder"].vertices, y["occluder"].vertices)
        assert np.array_equal(x["occluder"].faces, y["occluder"].faces)
        assert np.array_equal(x["bounds"], y["bounds"]) and x["error"] == y["error"]
        assert x["note"] == y["note"]
    assert any(n["triangles"] for n in a)
    assert said_one == said_two and said_one  # the workers' log lines come back, once each


def test_hierarchy_jobs_refused_out_of_range_or_without_a_hierarchy():
    with pytest.raises(InputError, match="jobs"):
        build_hierarchy([trimesh.creation.box()], node_occluder="qem", jobs=0)
    from viscore.generators import generate_planar_sections

    with pytest.raises(InputError, match="jobs: only with hierarchy"):
        generate_planar_sections(trimesh.creation.box(), jobs=2)
