"""``viscore occlude``: levels as objects, occluders per mesh and method, Godot files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from viscore import InputError, load_occluder
from viscore.cli.main import main
from viscore.generators.levels import default_methods
from viscore.generators.levels.occlude import occlude_level, occluder_of_mesh
from viscore.level import LevelObjects, guess_up, level_objects

T = trimesh.transformations


def _glb_level(path: Path) -> Path:
    """Two instances of one crate (one rotated) and a wall; glTF, +Y up."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), geom_name="crate",
                       node_name="crate_a", transform=T.translation_matrix((0, 0.5, 0)))
    scene.graph.update(frame_to="crate_b", geometry="crate",
                       matrix=T.translation_matrix((3, 0.5, 0)) @ T.rotation_matrix(0.5, (0, 1, 0)))
    scene.add_geometry(trimesh.creation.box(extents=(6, 2, 0.3)), geom_name="wall",
                       node_name="wall", transform=T.translation_matrix((1, 1, 3)))
    scene.export(path)
    return path


def _obj_level(path: Path, *, up: int = 1) -> Path:
    """A +Y-up map as one mesh: a ground slab, three blocks, a detail and far debris."""
    boxes = [((-5, -0.2, -5), (5, 0, 5)),            # ground
             ((-4, 0, -4), (-3, 2, -3)), ((0, 0, 0), (1, 2.5, 1)), ((3, 0, 2), (4, 1.5, 3)),
             ((1.02, 1, 0.4), (1.08, 1.06, 0.46)),   # a detail beside the second block
             ((-4.9, 0, 8), (-4.85, 0.05, 8.05))]    # debris far from everything
    parts = [trimesh.creation.box(bounds=np.array(b, dtype=float)) for b in boxes]
    mesh = trimesh.util.concatenate(parts)
    if up == 2:  # the same map, +Z up
        mesh.apply_transform(T.rotation_matrix(np.pi / 2, (1, 0, 0)))
    mesh.export(path)
    return path


def _run(*argv: str) -> int:
    return main(["occlude", *map(str, argv)])


def _world_triangles(out: Path, method: str, level: LevelObjects, *,
                     float32_transform: bool = True) -> dict[str, np.ndarray]:
    """The occluders placed by the instances' transforms, float32 as Godot stores them.

    Vertices are float32 in both files; the ``.tscn`` stores transforms as
    float32 (Godot's ``real_t``), the glTF node matrices keep float64.
    """
    doc = json.loads((out / "occlude.json").read_text())
    objects = level.objects
    placed = {}
    for i, name in enumerate(objects.names):
        occ = doc["objects"][name]["occluders"].get(method)
        if not occ or "refused" in occ:
            continue
        local = trimesh.load(out / occ["mesh_file"], file_type="ply", process=False)
        v = np.asarray(local.vertices).astype(np.float32).astype(np.float64)
        m = level.to_godot @ objects.transforms[i]
        if float32_transform:
            m = m.astype(np.float32).astype(np.float64)
        placed[name] = ((v @ m[:3, :3].T + m[:3, 3])[np.asarray(local.faces)]).astype(np.float32)
    return placed


def _read_back(path: Path) -> dict[str, np.ndarray]:
    mesh = load_occluder(path)
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)].astype(np.float32)
    out, start = {}, 0
    for name, count in zip(mesh.metadata["object_names"], mesh.metadata["object_triangles"],
                           strict=True):
        out[Path(name).name.removesuffix("-occonly")] = tri[start:start + count]
        start += count
    return out


def _same_files(a: Path, b: Path) -> None:
    names = sorted(p.name for p in a.iterdir() if p.suffix in (".tscn", ".glb"))
    assert names == sorted(p.name for p in b.iterdir() if p.suffix in (".tscn", ".glb"))
    assert names
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name

    def strip(doc):
        if isinstance(doc, dict):
            return {k: strip(v) for k, v in doc.items() if k != "seconds"}
        return doc
    da, db = (json.loads((d / "occlude.json").read_text()) for d in (a, b))
    assert strip(da) == strip(db)


# ----------------------------------------------------------------------------- the files
def test_occlude_glb_files_read_back_in_world_space(tmp_path, capsys):
    glb = _glb_level(tmp_path / "level.glb")
    out = tmp_path / "out"
    assert _run(glb, "-o", out, "--methods", "aabb-skins,bbox", "--json") == 0
    doc = json.loads(capsys.readouterr().out)
    level = level_objects(glb)
    for method in ("aabb-skins", "bbox"):
        assert doc["methods"][method]["objects"] == 3
        for suffix in (".tscn", ".glb"):
            expected = _world_triangles(out, method, level, float32_transform=suffix == ".tscn")
            back = _read_back(out / f"{method}{suffix}")
            assert sorted(back) == sorted(expected) == ["crate_a", "crate_b", "wall"]
            for name in expected:
                np.testing.assert_array_equal(back[name], expected[name])
    row = doc["objects"]["crate_b"]["occluders"]["aabb-skins"]
    assert row["file"] == "aabb-skins.tscn" and row["triangles"] == 12
    assert row["conservative_guaranteed"] is True
    assert doc["objects"]["crate_b"]["occluders"]["bbox"]["conservative_guaranteed"] is False


def test_occlude_instancing_one_sub_resource_many_nodes(tmp_path):
    glb = _glb_level(tmp_path / "level.glb")
    out = tmp_path / "out"
    assert _run(glb, "-o", out, "--methods", "bbox", "--quiet") == 0
    text = (out / "bbox.tscn").read_text()
    assert text.count('[sub_resource type="ArrayOccluder3D"') == 2  # crate, wall
    assert text.count('type="OccluderInstance3D"') == 3
    crate_ref = [line for line in text.splitlines() if line.startswith("occluder =")]
    assert len(set(crate_ref)) == 2 and len(crate_ref) == 3
    # one job per distinct mesh and method
    assert sorted(p.name for p in (out / "occluders" / "bbox").glob("*.json")) == \
        ["crate.json", "wall.json"]


def test_occlude_identical_meshes_share_a_job(tmp_path):
    scene = trimesh.Scene()
    for k in range(3):  # three copies of one geometry, each its own glTF mesh
        scene.add_geometry(trimesh.creation.box(), geom_name=f"copy{k}", node_name=f"n{k}",
                           transform=T.translation_matrix((3 * k, 0, 0)))
    level = level_objects(scene)
    made = occlude_level(level, tmp_path, methods=["bbox"])
    assert made.computed == 1 and made.manifest["methods"]["bbox"]["objects"] == 3
    assert (tmp_path / "bbox.tscn").read_text().count("[sub_resource") == 1


def test_occlude_progress_counts_work_in_triangles_biggest_first(tmp_path):
    """The bar fills with triangles plus a fixed part per job, not with jobs: a 1,280-
    triangle sphere and two 12-triangle boxes are 1,380 / 1,604 of the work, not 1/3."""
    from viscore.generators.levels.occlude import JOB_WORK_TRIANGLES

    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.icosphere(subdivisions=3), geom_name="ball",
                       node_name="ball")
    for k, size in enumerate((1.0, 1.5)):
        scene.add_geometry(trimesh.creation.box(extents=(size, 1, 1)), geom_name=f"box{k}",
                           node_name=f"box{k}", transform=T.translation_matrix((4 + 3 * k, 0, 0)))
    calls = []
    occlude_level(level_objects(scene), tmp_path, methods=["bbox"],
                  progress=lambda done, total, label, work: calls.append((done, label, work)))
    per_job = JOB_WORK_TRIANGLES
    assert [c[0] for c in calls] == [0, 1, 2, 3]
    assert calls[0][2] == (0.0, 1280 + 12 + 12 + 3 * per_job)
    assert calls[1][1] == "bbox ball" and calls[1][2][0] == 1280 + per_job
    assert calls[-1][2][0] == calls[-1][2][1]


# ----------------------------------------------------------------------------- single meshes
def test_level_objects_obj_split_and_up_guessed(tmp_path, caplog):
    obj = _obj_level(tmp_path / "map.obj")
    level = level_objects(obj)
    assert level.kind == "mesh" and level.up == "y" and level.up_guessed
    assert level.components == 6
    # the detail joined the block beside it; the far debris is a part of its own
    assert len(level.objects) == 5
    assert level.objects.triangles.tolist() == [12, 12, 24, 12, 12]
    assert level.flat.tolist() == [True, False, False, False, False]
    chosen = [level.objects.names[i] for i in level.chosen]
    assert chosen == ["map_part1", "map_part2", "map_part3", "map_part4"]
    assert "too small" in level.refused["map_part5"]
    # each part's mesh is named 'file:part', as a glTF level's meshes are 'file:node', so
    # the generators' messages about several parts say "each of them"
    assert [m.metadata["name"] for m in level.objects.meshes][:2] == [
        f"{obj}:map_part1", f"{obj}:map_part2"]
    np.testing.assert_array_equal(level.to_godot, np.eye(4))
    out = tmp_path / "out"
    with caplog.at_level("INFO"):
        assert _run(obj, "-o", out, "--methods", "bbox") == 0
    assert any("up axis guessed +Y" in r.getMessage() for r in caplog.records)
    assert any("refused map_part5: too small" in r.getMessage() for r in caplog.records)


def test_level_objects_z_up_written_in_godot_frame(tmp_path):
    obj = _obj_level(tmp_path / "map.obj", up=2)
    level = level_objects(obj)
    assert level.up == "z"
    out = tmp_path / "out"
    assert _run(obj, "-o", out, "--methods", "bbox", "--quiet") == 0
    back = load_occluder(out / "bbox.tscn")
    lo, hi = np.asarray(back.vertices).min(0), np.asarray(back.vertices).max(0)
    np.testing.assert_allclose([lo[1], hi[1]], [-0.2, 2.5], atol=1e-6)  # heights on Godot's Y


def test_level_objects_never_only_the_ground():
    ground = trimesh.creation.box(bounds=[[-50, -0.2, -50], [50, 0, 50]])
    blocks = [trimesh.creation.box(bounds=[[x, 0, 0], [x + 1, 1, 1]]) for x in (-30, 0, 30)]
    scene = trimesh.Scene()
    scene.add_geometry(ground, geom_name="ground", node_name="ground")
    for k, b in enumerate(blocks):
        scene.add_geometry(b, geom_name=f"block{k}", node_name=f"block{k}")
    level = level_objects(scene)
    assert [level.objects.names[i] for i in level.chosen] == ["block0", "block1", "block2",
                                                            "ground"]


def test_guess_up_open_geometry_faces_up():
    box = trimesh.creation.box()
    open_top = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] > -0.5])
    assert guess_up(open_top)[0] == "z"


def test_level_objects_invalid_input(tmp_path):
    glb = _glb_level(tmp_path / "level.glb")
    with pytest.raises(InputError, match="up"):
        level_objects(glb, up="w")
    with pytest.raises(InputError, match="min_size"):
        level_objects(glb, min_size=0)
    with pytest.raises(InputError, match="no object named"):
        level_objects(glb, names=["nosuch"])
    with pytest.raises(InputError, match="not both"):
        level_objects(glb, names=["wall"], min_size=0.1)


def test_occluder_of_mesh_invalid_input():
    with pytest.raises(InputError):
        occluder_of_mesh(trimesh.creation.box(), "nosuch")
    with pytest.raises(InputError, match="12"):
        occluder_of_mesh(trimesh.creation.box(), "aabb-skins", budget=5)


def test_default_methods_guaranteed():
    from viscore.generators import REGISTRY

    methods = default_methods()
    assert methods[0] == ("surface-patches" if "surface-patches" in REGISTRY else "aabb-skins")


# ----------------------------------------------------------------------------- refusals
def test_occlude_all_refused_exit_0_no_scene(tmp_path, capsys):
    """Open quads: aabb-skins makes nothing. Exit 0, each object refused (one line for the
    two, for one reason), no .tscn/.glb."""
    scene = trimesh.Scene()
    quad = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    for k in range(2):
        scene.add_geometry(quad, geom_name="quad", node_name=f"panel{k}",
                           transform=T.translation_matrix((2 * k, 0, 0)))
    glb = tmp_path / "panels.glb"
    scene.export(glb)
    out = tmp_path / "out"
    assert _run(glb, "-o", out, "--methods", "aabb-skins") == 0
    err = capsys.readouterr().err
    assert err.count("refused") == 1 and "empty occluder" in err
    assert "refused 2 objects for aabb-skins (panel0, panel1; listed in occlude.json)" in err
    assert not (out / "aabb-skins.tscn").exists() and not (out / "aabb-skins.glb").exists()
    doc = json.loads((out / "occlude.json").read_text())
    assert doc["methods"]["aabb-skins"]["objects"] == 0
    assert all("refused" in r["occluders"]["aabb-skins"] for r in doc["objects"].values())


# ----------------------------------------------------------------------------- runs
def test_occlude_jobs_1_and_2_identical(tmp_path):
    glb = _glb_level(tmp_path / "level.glb")
    for jobs in (1, 2):
        assert _run(glb, "-o", tmp_path / f"j{jobs}", "--methods", "aabb-skins,bbox",
                    "--jobs", jobs, "--quiet") == 0
    _same_files(tmp_path / "j1", tmp_path / "j2")


def _many_meshes_level(path: Path, count: int = 24) -> Path:
    scene = trimesh.Scene()
    for k in range(count):
        box = trimesh.creation.box(extents=(1 + 0.05 * k, 1, 1 + 0.03 * k))
        scene.add_geometry(box, geom_name=f"m{k:02d}", node_name=f"o{k:02d}",
                           transform=T.translation_matrix((3 * (k % 6), 0, 3 * (k // 6))))
    scene.export(path)
    return path


def test_occlude_resumes_after_sigkill(tmp_path):
    glb = _many_meshes_level(tmp_path / "many.glb")
    killed = tmp_path / "killed"
    args = ["occlude", str(glb), "-o", str(killed), "--methods", "aabb-skins,bbox", "--quiet"]
    proc = subprocess.Popen([sys.executable, "-m", "viscore.cli.main", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not list(killed.glob("occluders/*/*.json")):
            assert proc.poll() is None, "the run ended before a job finished"
            assert time.monotonic() < deadline
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    kept = len(list(killed.glob("occluders/*/*.json")))
    assert not (killed / "occlude.json").exists()  # killed before the final files
    assert _run(glb, "-o", killed, "--methods", "aabb-skins,bbox", "--quiet") == 0
    fresh = tmp_path / "fresh"
    assert _run(glb, "-o", fresh, "--methods", "aabb-skins,bbox", "--quiet") == 0
    _same_files(killed, fresh)
    assert 0 < kept < 48


def test_occlude_second_run_on_locked_folder_exit_2(tmp_path, capsys):
    from viscore.cli.study.store import lock_exclusive

    glb = _glb_level(tmp_path / "level.glb")
    out = tmp_path / "out"
    out.mkdir()
    fd = lock_exclusive(out, busy="held")
    try:
        assert _run(glb, "-o", out, "--methods", "bbox") == 2
    finally:
        os.close(fd)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another occlude" in err[0]
    # once the folder is free the run goes through and leaves no lock file behind
    assert _run(glb, "-o", out, "--methods", "bbox") == 0
    assert not (out / ".lock").exists() and (out / "occlude.json").is_file()


@pytest.mark.parametrize("argv, words", [
    (["--budget", "5", "--methods", "aabb-skins"], "12"),
    (["--methods", "nosuch"], "nosuch"),
    (["--methods", "planar-sections:nosuch=1"], "nosuch"),
    (["--jobs", "100000"], "--jobs"),
    (["--min-size", "0"], "--min-size"),
    (["--min-size", "1.5"], "--min-size"),
    (["--occluders", "nosuch"], "nosuch"),
    (["--min-size", "0.1", "--occluders", "wall"], "not allowed"),
    (["--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "not allowed"),
    (["--up", "w"], "--up"),
])
def test_occlude_bad_options_exit_2_one_line(tmp_path, capsys, argv, words):
    glb = _glb_level(tmp_path / "level.glb")
    out = tmp_path / "out"
    assert _run(glb, "-o", out, *argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert not out.exists()


def test_occlude_missing_parent_exit_2(tmp_path, capsys):
    glb = _glb_level(tmp_path / "level.glb")
    assert _run(glb, "-o", tmp_path / "no" / "out", "--methods", "bbox") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not exist" in err[0]


@pytest.mark.slow
def test_occlude_dask_local_cluster_same_files(tmp_path):
    distributed = pytest.importorskip("distributed")
    glb = _glb_level(tmp_path / "level.glb")
    assert _run(glb, "-o", tmp_path / "local", "--methods", "aabb-skins,bbox", "--quiet") == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        assert _run(glb, "-o", tmp_path / "dask", "--methods", "aabb-skins,bbox",
                    "--scheduler", cluster.scheduler_address, "--quiet") == 0
    _same_files(tmp_path / "local", tmp_path / "dask")


def test_level_scale_ignores_an_outer_ground_far_larger_than_the_town(monkeypatch):
    """Truck town's layout: 20 houses 9 x 4 x 9 and a grassy hill 120 x 16 x 100 on 200 x 200,
    inside a ground plane 2,000 across. Against the ground's diagonal the houses are 0.5%
    and get no occluder (the hill, not flat, passes: no fallback); the ground does not set
    the scale (its box is over LEVEL_SPAN x the others'), so they are 5% and get one."""
    import viscore.level.scene_graph as sg

    rng = np.random.default_rng(0)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-1000, -0.2, -1000], [1000, 0, 1000]]),
                       geom_name="ground", node_name="ground")
    scene.add_geometry(trimesh.creation.box(bounds=[[-60, 0, -50], [60, 16, 50]]),
                       geom_name="hill", node_name="hill")
    for k in range(20):
        x, z = rng.uniform(-95, 85, 2)
        scene.add_geometry(trimesh.creation.box(bounds=[[x, 0, z], [x + 9, 4, z + 9]]),
                           geom_name=f"house{k}", node_name=f"house{k}")
    level = level_objects(scene)
    assert len(level.chosen) == 22
    built = np.linalg.norm(level.objects.upper[1:].max(0) - level.objects.lower[1:].min(0))
    house = level.objects.names.index("house0")
    assert level.sizes[house] == pytest.approx(np.sqrt(9**2 + 4**2 + 9**2) / built)
    monkeypatch.setattr(sg, "LEVEL_SPAN", np.inf)
    assert {level_objects(scene).objects.names[i] for i in level_objects(scene).chosen} \
        == {"ground", "hill"}


def test_occlude_runs_a_height_field_method_on_the_flat_objects_only(tmp_path):
    """terrain-drape (GeneratorSpec.inputs == 'height-fields') gets the terrain sheet of a
    level and leaves the buildings, without running on them."""
    from viscore.cli.bench.table1 import height_field_sheet

    x, z = np.meshgrid(np.linspace(-1, 1, 41), np.linspace(-1, 1, 41), indexing="ij")
    hill = height_field_sheet(0.3 * np.exp(-3 * (x ** 2 + z ** 2)), 40.0, 40.0)
    hill.apply_transform(T.rotation_matrix(-np.pi / 2, (1, 0, 0)))  # z up -> y up (glTF)
    scene = trimesh.Scene()
    scene.add_geometry(hill, geom_name="hill", node_name="hill")
    for k, at in enumerate((5.0, 25.0)):
        scene.add_geometry(trimesh.creation.box(bounds=[[at, 0, -20], [at + 6, 8, -14]]),
                           geom_name=f"house{k}", node_name=f"house{k}")
    path = tmp_path / "level.glb"
    scene.export(path)
    level = level_objects(path)
    assert set(level.objects.names[i] for i in level.chosen) == {"hill", "house0", "house1"}
    out = tmp_path / "out"
    out.mkdir()
    made = occlude_level(level, out, methods=["terrain-drape"], budget=16)
    doc = json.loads((out / "occlude.json").read_text())
    hill_occ = doc["objects"]["hill"]["occluders"]["terrain-drape"]
    assert "refused" not in hill_occ and 0 < hill_occ["triangles"] <= 16
    for house in ("house0", "house1"):
        row = doc["objects"][house]["occluders"]["terrain-drape"]
        assert "refused" in row, (house, row, level.flat)
        why = row["refused"]
        assert why.startswith("not run:") and "not flat" in why
    assert not (out / "occluders" / "terrain-drape" / "house0.json").exists()
    assert made.reused == 0
    # the drape, placed in Godot's frame (+Y up, as the level), lies under the hill
    placed = _world_triangles(out, "terrain-drape", level)["hill"].reshape(-1, 3)
    sheet = trimesh.Trimesh(np.asarray(hill.vertices), np.asarray(hill.faces), process=False)
    from viscore.ray.embree_scene import Scene

    up = np.tile([0.0, 1.0, 0.0], (len(placed), 1))
    assert Scene(sheet).any_hit(placed.astype(np.float64) - [0, 1e-4, 0], up).all()


@pytest.mark.parametrize("jobs", [1, 2])
def test_occlude_says_a_warning_every_mesh_gives_once(tmp_path, caplog, jobs):
    """Six open boxes (no bottom face): aabb-skins warns for each that it is not closed.
    The run says it once with the count, whether the jobs ran here or in processes."""
    scene = trimesh.Scene()
    for k in range(6):
        box = trimesh.creation.box(extents=(2 + 0.1 * k, 2, 2))
        box.update_faces(box.face_normals[:, 1] > -0.5)  # open at the bottom
        scene.add_geometry(box, geom_name=f"m{k}", node_name=f"o{k}",
                           transform=T.translation_matrix((4 * k, 1, 0)))
    glb = tmp_path / "open.glb"
    scene.export(glb)
    level = level_objects(glb)
    with caplog.at_level("WARNING"):
        occlude_level(level, tmp_path, methods=["aabb-skins"], jobs=jobs)
    said = [r.getMessage() for r in caplog.records if "not closed" in r.getMessage()]
    assert said == [s for s in said if s.startswith("aabb-skins: 6 of 6 meshes: ")]
    assert len(said) == 1 and "aabb-skins: aabb-skins" not in said[0]


def test_gltf_written_z_up_takes_up_z(tmp_path):
    # three.js and Blender scenes written +Z up: --up z sets the level's up (camera path,
    # flat ground), while the occluders stay in the frame Godot reads the glTF in
    glb = _glb_level(tmp_path / "level.glb")
    level = level_objects(glb, up="z")
    assert level.up == "z" and not level.up_guessed and "over glTF's +Y" in level.up_reason
    assert level.objects.up.tolist() == [0.0, 0.0, 1.0]
    np.testing.assert_array_equal(level.to_godot, np.eye(4))
    assert level_objects(glb).objects.up.tolist() == [0.0, 1.0, 0.0]


def test_job_messages_name_the_mesh():
    # an open mesh (a box without its top): aabb-skins says it is not closed, naming the
    # mesh as the run does, so that the run can group the lines ("each of them ...")
    from viscore.generators.levels.occlude import _run_job

    box = trimesh.creation.box()
    top = box.face_normals[:, 2] > 0.5
    job = _run_job(np.asarray(box.vertices), np.asarray(box.faces[~top]), "wallA",
                   "aabb-skins", None, 0)
    texts = [text for _, _, text in job.logs]
    assert any("wallA is not closed" in t for t in texts), texts


@pytest.mark.parametrize("verbose", [False, True])
def test_occlude_says_each_kind_of_refusal_once_with_its_count(tmp_path, caplog, verbose):
    """--min-size 0.16 of the map's diagonal (16.6) refuses the two lower blocks (map_part2
    and map_part4: diagonals 2.45 and 2.06) and the debris as too small, and keeps the tall
    block (2.87) with the ground: one line with the count and their names; --verbose adds
    one line per object."""
    obj = _obj_level(tmp_path / "map.obj")
    with caplog.at_level("DEBUG" if verbose else "INFO"):
        assert main([*(["--verbose"] if verbose else []), "occlude", str(obj), "-o",
                     str(tmp_path / "out"), "--methods", "bbox", "--min-size", "0.16"]) == 0
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("refused")]
    grouped = [m for m in said if m.startswith("refused 3 objects as too small")]
    assert len(grouped) == 1
    assert grouped[0].endswith("map_part2, map_part4, map_part5")
    assert len([m for m in said if m.startswith("refused map_part")]) == (3 if verbose else 0)
