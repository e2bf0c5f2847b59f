"""Hostile input, third round (issue 46, items 15-17, 22): outputs all or nothing, and
inside their folder.

- ``occlude`` on a disk that fills midway: a job's occluder and its record are both
  written or neither (a ``.ply`` without its ``.json`` was left), and the engine files
  and the manifest are one set, all or none;
- ``compare --occluder-files NAME=...`` with a NAME too long for a file name: refused
  before the study folder is made;
- ``occlude -o DIR`` whose ``DIR/occluders`` is a symbolic link: refused before anything
  is read or written (it wrote through the link and resumed from there);
- a folder of 10^4 occluder files for one mesh: refused instead of queuing 10^4 jobs.
"""

from __future__ import annotations

import errno
import json
import os

import pytest
from test_hostile_readers import one_error, run

from viscore import tres_text
from viscore._atomic import FileSet
from viscore.cli.study.runner import MAX_FILE_ROW_NAME, MAX_FILES_PER_MESH
from viscore.generators.levels import occlude as occlude_module

QUAD = ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [0, 1, 2, 0, 2, 3])
#: compare as small as it runs
TINY = ["--views", "2", "--quads", "50", "--res", "16", "--rays", "100", "--no-culling"]
#: Two methods, two meshes (the built-in city's street is one level of several meshes).
METHODS = "bbox,original"


def _level(tmp_path):
    """A level of two distinct meshes (a box and a taller box): two jobs per method."""
    import trimesh

    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(2, 2, 2)), node_name="a", geom_name="a")
    scene.add_geometry(trimesh.creation.box(extents=(2, 4, 2)), node_name="b", geom_name="b",
                       transform=trimesh.transformations.translation_matrix((5, 0, 0)))
    path = tmp_path / "level.glb"
    path.write_bytes(scene.export(file_type="glb"))
    return path


def _disk_full(after: int):
    """A write_atomic that fails with ENOSPC from its ``after``-th call on."""
    calls = []
    real = occlude_module.write_atomic

    def write(path, data, **kw):
        calls.append(path)
        if len(calls) > after:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, data, **kw)

    return write


@pytest.mark.parametrize("after", [0, 1, 2, 3])
def test_occlude_disk_full_leaves_whole_job_pairs(tmp_path, monkeypatch, after):
    """Item 15: a disk that fills after ``after`` writes: exit 2 naming the file; every
    occluder kept has its record (a rerun resumes from whole pairs), no engine file."""
    level = _level(tmp_path)
    out = tmp_path / "out"
    monkeypatch.setattr(occlude_module, "write_atomic", _disk_full(after))
    rc, _, err = run(["occlude", level, "-o", out, "--methods", METHODS])
    one_error(rc, err, "No space left on device")
    plys = {p.relative_to(out).with_suffix("") for p in out.rglob("*.ply")}
    records = {p.relative_to(out).with_suffix("") for p in out.rglob("*.json")}
    assert plys <= records, f"occluders without their record: {plys - records}"
    assert not list(out.glob("*.tscn")) and not list(out.glob("*.glb"))
    assert not (out / "occlude.json").exists()
    assert not list(out.rglob("*.tmp"))
    # the rerun on a disk with room resumes from the whole pairs and finishes
    monkeypatch.undo()
    rc, out_text, err = run(["occlude", level, "-o", out, "--methods", METHODS, "--json"])
    assert rc == 0, err
    assert json.loads(out_text)["objects_chosen"] == 2


def test_occlude_final_files_all_or_none(tmp_path, monkeypatch):
    """Item 15: the engine files and the manifest are one set: a write failing at the
    last of them leaves none of them, and an earlier run's set as it was."""
    level = _level(tmp_path)
    out = tmp_path / "out"
    rc, _, err = run(["occlude", level, "-o", out, "--methods", METHODS])
    assert rc == 0, err
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert set(before) == {"bbox.tscn", "bbox.glb", "original.tscn", "original.glb",
                           "occlude.json", "preview.png", "report.html"}
    real = FileSet.write

    def full(self, name, data):
        if name == "occlude.json":
            raise OSError(errno.ENOSPC, "No space left on device", str(self.folder / name))
        return real(self, name, data)

    monkeypatch.setattr(FileSet, "write", full)
    rc, _, err = run(["occlude", level, "-o", out, "--methods", METHODS, "--seed", "1"])
    one_error(rc, err, "No space left on device", "occlude.json")
    after = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert after == before
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_occlude_through_a_linked_occluders_folder_refused(tmp_path):
    """Item 17: ``DIR/occluders`` a symbolic link: refused before the level is read; the
    link's target stays empty (compare refuses the same setup)."""
    level = _level(tmp_path)
    out = tmp_path / "out"
    elsewhere = tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    os.symlink(elsewhere, out / "occluders")
    rc, _, err = run(["occlude", level, "-o", out, "--methods", "bbox"])
    one_error(rc, err, "occluders is a symbolic link", "writes only inside its folder")
    assert list(elsewhere.iterdir()) == [] and sorted(os.listdir(out)) == ["occluders"]
    # a method folder inside it that is a link, the same
    os.unlink(out / "occluders")
    (out / "occluders").mkdir()
    os.symlink(elsewhere, out / "occluders" / "bbox")
    rc, _, err = run(["occlude", level, "-o", out, "--methods", "bbox"])
    one_error(rc, err, "bbox is a symbolic link")
    assert list(elsewhere.iterdir()) == []


def test_compare_long_occluder_files_name_refused_before_the_folder(tmp_path):
    """Item 16: a 240-character NAME passed the check, ran a job, then failed on 'File name
    too long' without naming the option, leaving a study behind."""
    (tmp_path / "x.tres").write_text(tres_text(*QUAD))
    out = tmp_path / "study"
    name = "n" * 240
    rc, _, err = run(["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
                      f"{name}={tmp_path / 'x.tres'}", "--out", out])
    one_error(rc, err, "--occluder-files", "NAME has 240 characters",
              f"at most {MAX_FILE_ROW_NAME}")
    assert not out.exists()
    # the longest NAME allowed makes file names the filesystem takes
    name = "n" * MAX_FILE_ROW_NAME
    rc, _, err = run(["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
                      f"{name}={tmp_path / 'x.tres'}", "--out", out])
    assert rc == 0, err


def test_compare_folder_of_ten_thousand_occluder_files_refused(tmp_path):
    """Item 22: a folder of 10^4 files for one mesh queued 10,001 jobs; refused with the
    count, before the study folder."""
    folder = tmp_path / "files"
    folder.mkdir()
    for budget in range(1, 10_001):
        (folder / f"fat-torus.{budget}.tres").touch()
    out = tmp_path / "study"
    rc, _, err = run(["compare", "fat-torus", "--methods", "bbox", *TINY, "--occluder-files",
                      f"baked={folder}", "--out", out])
    one_error(rc, err, "--occluder-files baked=", "10,000 occluder files for mesh fat-torus",
              "budgets 1..10,000", f"more than the {MAX_FILES_PER_MESH}")
    assert not out.exists()
