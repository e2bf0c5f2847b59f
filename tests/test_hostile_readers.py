"""Hostile input, third round (issue 46): bounded readers of meshes, levels and engine files.

Every case is built from the issue's recipe, on the fly in ``tmp_path`` (files of
gigabytes are sparse: ``os.truncate``), and run through the command line or the
reader it names. The contract: exit 2 with one stderr line naming the file and the
rule (or, for a valid file the issue found slow, success), nothing left behind.

The cases that once hung, ran quadratic or took gigabytes (issue items 1-9) run in
a child process under a CPU-time and an address-space limit (``resource.setrlimit``:
a read that hangs, goes quadratic or allocates gigabytes again dies there instead
of passing), one batch per family, each case reporting its exit code and stderr;
the CPU seconds and peak memory of each case are printed (``pytest -s``), not
asserted. The message cases (items 11, 14, 18-22) run in-process.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import re
import resource
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import trimesh

from viscore import InputError, OccluderInstance, load_mesh, load_occluder, tres_text, tscn_text
from viscore.cli.main import main
from viscore.exchange.gltf_scene import MAX_NODES
from viscore.exchange.mesh_io import MAX_OBJ_FACE_VERTICES

#: CPU seconds a batch of cases may spend (its imports included): the bounded readers
#: need a few seconds a case; the readers of before spent 70 s on one OBJ line of zeros,
#: 43 s on a scene of 10^4 nodes and 77 s on a chain of 10^5.
BATCH_CPU_SECONDS = 300
#: Address space of a batch, bytes: a command uses ~1.2 GB of it (imports, threads); the
#: readers of before took 3-5 GB on these files.
BATCH_ADDRESS_SPACE = 4 << 30
#: Memory limit the batch's commands plan within (``VISCORE_MEMORY_FRACTION`` is set so
#: that the limit is this, whatever the machine's free memory).
BATCH_MEMORY_LIMIT = 2 << 30
#: Wall-clock guard of a batch (a hang fails the test instead of stopping the suite).
BATCH_TIMEOUT = 1200

TET = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
#: A cull as small as it runs: one frame of 16 x 9 pixels, the bbox runtime.
CULL = ["--frames", "1", "--width", "16", "--height", "9", "--methods", "bbox",
        "--frusta-method", "bbox"]
MEASURE = ["--directions", "2", "--res", "16"]
QUAD = ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], [0, 1, 2, 0, 2, 3])


# ----------------------------------------------------------------------------- files
def glb(doc: dict, binary: bytes = b"") -> bytes:
    """A GLB of a glTF JSON document and its binary chunk."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text
    if binary:
        body += struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def box_bin() -> bytes:
    """A unit box: float32 positions, then uint32 indices."""
    box = trimesh.creation.box()
    return (np.asarray(box.vertices, np.float32).tobytes()
            + np.asarray(box.faces, np.uint32).tobytes())


def box_doc(nodes: list, roots: list, *, uri: str | None = None) -> dict:
    """A glTF document whose one mesh is :func:`box_bin`'s box."""
    box = trimesh.creation.box()
    nv, nf = len(box.vertices), len(box.faces)
    buffer = {"byteLength": len(box_bin())}
    if uri is not None:
        buffer["uri"] = uri
    return {
        "asset": {"version": "2.0"}, "buffers": [buffer],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 12 * nv},
                        {"buffer": 0, "byteOffset": 12 * nv, "byteLength": 12 * nf}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
                       "min": [-0.5] * 3, "max": [0.5] * 3},
                      {"bufferView": 1, "componentType": 5125, "count": 3 * nf,
                       "type": "SCALAR"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": nodes, "scenes": [{"nodes": roots}], "scene": 0}


def level(count: int = 3, edit=None) -> bytes:
    """A GLB level of ``count`` boxes 3 apart (nodes ``bld0``, ...), ``edit`` applied."""
    nodes = [{"name": f"bld{i}", "mesh": 0, "translation": [3.0 * i, 0, 0]}
             for i in range(count)]
    doc = box_doc(nodes, list(range(count)))
    if edit is not None:
        edit(doc)
    return glb(doc, box_bin())


def ext_scene(ref: str) -> str:
    """A ``.tscn`` whose one OccluderInstance3D uses the external occluder ``ref``."""
    return ('[gd_scene format=3]\n\n[ext_resource type="ArrayOccluder3D" '
            f'path="res://{ref}" id="1"]\n\n[node name="Root" type="Node3D"]\n\n'
            '[node name="Wall" type="OccluderInstance3D" parent="."]\n'
            'occluder = ExtResource("1")\n')


def occ_bytes(vertices, indices) -> bytes:
    """A Godot 4 binary ``ArrayOccluder3D`` (format 6) with its closing ``RSRC``."""
    def string(s: str) -> bytes:
        raw = s.encode() + b"\0"
        return struct.pack("<I", len(raw)) + raw

    v = np.asarray(vertices, "<f4").reshape(-1)
    i = np.asarray(indices, "<i4").reshape(-1)
    head = (b"RSRC" + struct.pack("<IIIII", 0, 0, 4, 3, 6) + string("ArrayOccluder3D")
            + struct.pack("<QIQ", 0, 0, 0) + b"\0" * 44)
    strings = struct.pack("<I", 2) + string("vertices") + string("indices")
    props = (string("ArrayOccluder3D") + struct.pack("<I", 2)
             + struct.pack("<II", 0, 35) + struct.pack("<I", len(v) // 3) + v.tobytes()
             + struct.pack("<II", 1, 32) + struct.pack("<I", len(i)) + i.tobytes())
    table_end = len(head) + len(strings) + 4 + 4 + len(string("")) + 8
    internal = struct.pack("<I", 0) + struct.pack("<I", 1) + string("") + struct.pack(
        "<Q", table_end)
    return head + strings + internal + props + b"RSRC"


def padded(path: Path, data: bytes, size: int = 3 << 30) -> Path:
    """``data`` at ``path``, the file then extended (sparse) to ``size`` bytes."""
    path.write_bytes(data)
    os.truncate(path, size)
    return path


# ----------------------------------------------------------------------------- running
def run(argv: list[str]) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of one in-process command."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def one_error(rc: int, err: str, *words: str) -> str:
    """Exit 2 and exactly one stderr line, ``viscore: error:``, holding every word."""
    lines = err.strip().splitlines()
    assert rc == 2, f"exit {rc}: {err[-1500:]}"
    assert len(lines) == 1, f"{len(lines)} stderr lines: {err[-1500:]}"
    assert lines[0].startswith("viscore: error:"), lines[0]
    for word in words:
        assert word in lines[0], f"{word!r} not in {lines[0]!r}"
    return lines[0]


_BATCH = textwrap.dedent('''
    import contextlib, io, json, os, resource, sys
    from viscore._validate import available_memory
    os.environ["VISCORE_MEMORY_FRACTION"] = str(min(0.75, {limit} / available_memory()))
    from viscore import InputError, load_occluder
    from viscore.cli.main import main
    results = []
    for kind, args in json.load(open(sys.argv[1])):
        before = resource.getrusage(resource.RUSAGE_SELF)
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            if kind == "cli":
                rc = main(args + ["--quiet"])
            else:
                try:
                    rc, err = 0, str(len(load_occluder(args[0]).faces))
                except InputError as exc:
                    rc, err = 2, "viscore: error: " + str(exc)
        after = resource.getrusage(resource.RUSAGE_SELF)
        results.append([rc, err if isinstance(err, str) else err.getvalue(),
                        after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
                        after.ru_maxrss // 1024])
        print(json.dumps(results[-1]), file=sys.stderr, flush=True)
    json.dump(results, open(sys.argv[2], "w"))
''')


def _limits() -> None:  # in the child, before it runs
    resource.setrlimit(resource.RLIMIT_CPU, (BATCH_CPU_SECONDS, BATCH_CPU_SECONDS + 5))
    resource.setrlimit(resource.RLIMIT_AS, (BATCH_ADDRESS_SPACE, BATCH_ADDRESS_SPACE))


def run_bounded(tmp_path: Path, cases: list[tuple[str, list[str]]]) -> list[tuple[int, str]]:
    """Run cases (``("cli", argv)`` or ``("load_occluder", [path])``) in one child process
    under :data:`BATCH_CPU_SECONDS` of CPU and :data:`BATCH_ADDRESS_SPACE`; returns each
    case's exit code and stderr (the InputError line for ``load_occluder``; its face count
    on success)."""
    spec, result = tmp_path / "batch.json", tmp_path / "results.json"
    spec.write_text(json.dumps([[kind, [str(a) for a in args]] for kind, args in cases]))
    env = dict(os.environ, VISCORE_NO_PLUGINS="1")
    proc = subprocess.run(
        [sys.executable, "-c", _BATCH.format(limit=BATCH_MEMORY_LIMIT), str(spec), str(result)],
        env=env, capture_output=True, text=True, timeout=BATCH_TIMEOUT, preexec_fn=_limits)
    assert proc.returncode == 0 and result.exists(), (
        f"the batch died (exit {proc.returncode}) after "
        f"{proc.stderr.count(chr(10))} of {len(cases)} cases: {proc.stderr[-3000:]}")
    out = json.loads(result.read_text())
    for (kind, args), (rc, _, cpu, rss) in zip(cases, out, strict=True):
        print(f"{kind} {' '.join(map(str, args))[:90]}: exit {rc}, {cpu:.1f} s CPU, "
              f"{rss} MB peak")
    return [(rc, err) for rc, err, _, _ in out]


# ----------------------------------------------------------------------------- items 1-2, 6
def test_obj_readers_bounded(tmp_path):
    """Items 1, 2, 6: a FIFO material library, lines of zeros, CR-only lines, a face of
    10^7 indices: each refused with its rule, within the batch's CPU and memory."""
    fifo_dir = tmp_path / "fifo"
    fifo_dir.mkdir()
    os.mkfifo(fifo_dir / "m.mtl")
    (fifo_dir / "l.obj").write_text("mtllib m.mtl\n" + TET)
    zeros = tmp_path / "zeros.obj"
    zeros.write_text("v 1 1 1\n" + " 0" * 10**6 + "\n")
    cr = tmp_path / "cr.obj"  # 10^6 records separated by CR alone, the last a face with 0
    cr.write_text("\r".join([f"v {i} {i % 7} 1" for i in range(10**6 - 1)] + ["f 0 1 2"]))
    face = tmp_path / "face.obj"
    face.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf "
                    + " ".join(["1 2 3 4"] * 2_500_000) + "\n")
    outs = [tmp_path / "o-zeros", tmp_path / "o-face"]
    results = run_bounded(tmp_path, [
        ("cli", ["measure", fifo_dir / "l.obj", *MEASURE]),
        ("cli", ["occlude", zeros, "-o", outs[0], "--methods", "bbox"]),
        ("cli", ["measure", cr, *MEASURE]),
        ("cli", ["occlude", face, "-o", outs[1], "--methods", "bbox"])])
    one_error(*results[0], "l.obj", "m.mtl", "named pipe (FIFO)")
    one_error(*results[1], "zeros.obj", "holds no triangles")
    one_error(*results[2], "cr.obj", "OBJ index 0", "'f 0 1 2'")
    one_error(*results[3], "face.obj", "line 5", "a face of 10,000,000 vertices",
              f"{MAX_OBJ_FACE_VERTICES:,}")
    assert not any(p.exists() for p in outs)


def test_obj_lone_cr_lines_read_as_lines(tmp_path):
    """Classic Mac line ends: the same tetrahedron as with LF (trimesh splits at LF only)."""
    (tmp_path / "cr.obj").write_text(TET.replace("\n", "\r"))
    (tmp_path / "lf.obj").write_text(TET)
    cr, lf = load_mesh(tmp_path / "cr.obj"), load_mesh(tmp_path / "lf.obj")
    np.testing.assert_array_equal(cr.faces, lf.faces)
    np.testing.assert_array_equal(cr.vertices, lf.vertices)


def test_obj_face_census_counts_fans():
    from viscore.exchange.mesh_io import _obj_face_census

    text = b"v 0 0 0\n  f 1 2 3\nf\t1 2 3 4 5\nvt 1 2\nfo 1 2\nf 1/1/1 2/2/2 3/3/3 4/4/4\n"
    # a triangle (1), a pentagon (3), a quad with slashes (2); 'fo' and 'vt' are no faces
    assert _obj_face_census(text) == (6, 5, 3)
    assert _obj_face_census(b"") == (0, 0, 0)


# ----------------------------------------------------------------------------- items 3, 8
def test_godot_text_readers_bounded(tmp_path):
    """Items 3 and 8: scenes of 10^4 and 10^5 OccluderInstance3D nodes read linearly (the
    10^4 one through ``cull --occluder-files`` too); one occluder of 3 x 10^5 vertices
    placed by 1,000 nodes refused before anything is placed."""
    rng = np.random.default_rng(0)
    scenes = {}
    for n in (10**4, 10**5):
        insts = [OccluderInstance(f"o{i}", "q", _moved(i)) for i in range(n)]
        scenes[n] = tmp_path / f"nodes{n}.tscn"
        scenes[n].write_text(tscn_text(insts, {"q": QUAD}))
    big = tmp_path / "instanced.tscn"
    v = rng.random((300_000, 3))
    big.write_text(tscn_text([OccluderInstance(f"o{i}", "big", _moved(i)) for i in range(1000)],
                             {"big": (v, np.arange(300_000))}))
    (tmp_path / "level.glb").write_bytes(level())
    outs = [tmp_path / "cull-nodes", tmp_path / "cull-big"]
    results = run_bounded(tmp_path, [
        ("load_occluder", [scenes[10**5]]),
        ("cli", ["cull", tmp_path / "level.glb", "--occluder-files", scenes[10**4], *CULL,
                 "--out", outs[0]]),
        ("cli", ["cull", tmp_path / "level.glb", "--occluder-files", big, *CULL,
                 "--out", outs[1]])])
    assert results[0] == (0, str(2 * 10**5))
    assert results[1][0] == 0, results[1][1][-2000:]
    assert (outs[0] / "cull.json").is_file()
    one_error(*results[2], "instanced.tscn", "100,000,000 triangles with its 1,000 instances "
              "placed", "memory")
    assert not outs[1].exists()


def _moved(i: int) -> np.ndarray:
    m = np.eye(4)
    m[0, 3] = float(i)
    return m


def test_godot_text_line_numbers_still_counted():
    from viscore.exchange.godot_text import text_sections

    data = b"[gd_scene format=3]\n\n; a comment\n[node name=\"A\"]\nx = 1\n\n[node name=\"B\"]\n"
    sections = text_sections(data)
    assert [s[1].get("name") for s in sections] == [None, "A", "B"]
    with pytest.raises(InputError, match=r"line 7: not a section header"):
        text_sections(b"[gd_scene format=3]\n\n; c\n[node name=\"A\"]\nx = 1\n\n[ 1x ]\n")


# ----------------------------------------------------------------------------- items 4, 7
def test_gltf_hierarchies_bounded(tmp_path):
    """Items 4 and 7: a 10^5-deep chain of -occonly nodes is refused by the occluder reader
    as by the level loader (one walker); a GLB of 10^6 nodes (a 100 x 100 x 100 tree
    instancing one box) before its JSON is parsed; 3 x 10^5 nodes by the node count."""
    n = 10**5
    chain = [{"name": f"n{i}-occonly", "children": [i + 1]} for i in range(n - 1)]
    chain.append({"name": "leaf-occonly", "mesh": 0})
    (tmp_path / "chain.glb").write_bytes(glb(box_doc(chain, [0]), box_bin()))
    (tmp_path / "tree.glb").write_bytes(_tree_glb())
    flat = [{"mesh": 0, "translation": [3.0 * (i % 500), 0.0, 3.0 * (i // 500)]}
            for i in range(MAX_NODES + 50_000)]
    (tmp_path / "flat.glb").write_bytes(glb(box_doc(flat, list(range(len(flat)))), box_bin()))
    (tmp_path / "level.glb").write_bytes(level())
    outs = [tmp_path / f"out{k}" for k in range(5)]
    results = run_bounded(tmp_path, [
        ("cli", ["cull", tmp_path / "level.glb", "--occluder-files", tmp_path / "chain.glb",
                 *CULL, "--out", outs[0]]),
        ("cli", ["cull", tmp_path / "chain.glb", *CULL, "--out", outs[1]]),
        ("cli", ["cull", tmp_path / "tree.glb", *CULL, "--out", outs[2]]),
        ("cli", ["occlude", tmp_path / "tree.glb", "-o", outs[3], "--methods", "bbox"]),
        ("cli", ["cull", tmp_path / "flat.glb", *CULL, "--out", outs[4]])])
    deep = "the node hierarchy is 100,000 levels deep"
    one_error(*results[0], "chain.glb", deep, "1,000 levels")
    one_error(*results[1], "chain.glb", deep)
    for rc, err in results[2:4]:
        one_error(rc, err, "tree.glb", "JSON holds 1,010,112 objects, more than the 1,000,000")
    one_error(*results[4], "flat.glb", f"{MAX_NODES + 50_000:,} nodes, more than the "
              f"{MAX_NODES:,}")
    assert not any(p.exists() for p in outs)


def _tree_glb() -> bytes:
    """A root, 100 children, 100 grandchildren each, 100 box nodes under each (10^6 + 10101
    nodes, 80 MB of JSON), written as text."""
    parts = ['{"name":"root","children":[' + ",".join(map(str, range(1, 101))) + "]}"]
    for a in range(100):
        first = 101 + 100 * a
        parts.append('{"children":[' + ",".join(map(str, range(first, first + 100))) + "]}")
    for b in range(10_000):
        first = 10_101 + 100 * b
        parts.append('{"children":[' + ",".join(map(str, range(first, first + 100))) + "]}")
    parts += [f'{{"mesh":0,"translation":[{3 * (k % 100)},{3 * (k // 10_000)},'
              f'{3 * (k // 100 % 100)}]}}' for k in range(10**6)]
    text = json.dumps(box_doc([], [0])).replace('"nodes": []',
                                                '"nodes": [' + ",".join(parts) + "]")
    text += " " * (-len(text) % 4)
    binary = box_bin()
    body = (struct.pack("<I4s", len(text), b"JSON") + text.encode()
            + struct.pack("<I4s", len(binary), b"BIN\0") + binary)
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


# ----------------------------------------------------------------------------- item 9
def test_padded_references_refused_unread(tmp_path):
    """Item 9: a glTF buffer, an image, a binary .occ and a .tscn's external .tres or .occ,
    each padded to 3 GB (sparse), refused by the size their referrer declares or their
    content needs, under occlude, cull, compare and load_occluder."""
    from PIL import Image

    nodes = [{"name": f"bld{i}", "mesh": 0, "translation": [3.0 * i, 0, 0]} for i in range(3)]
    buf = tmp_path / "buffer"
    buf.mkdir()
    padded(buf / "b.bin", box_bin())
    (buf / "l.gltf").write_text(json.dumps(box_doc(nodes, [0, 1, 2], uri="b.bin")))
    img = tmp_path / "image"
    img.mkdir()
    (img / "b.bin").write_bytes(box_bin())
    Image.new("RGBA", (4, 4), (255, 0, 0, 255)).save(img / "t.png")
    os.truncate(img / "t.png", 3 << 30)
    doc = box_doc(nodes, [0, 1, 2], uri="b.bin")
    doc.update(images=[{"uri": "t.png"}], textures=[{"source": 0}],
               materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])
    doc["meshes"][0]["primitives"][0]["material"] = 0
    (img / "l.gltf").write_text(json.dumps(doc))
    godot = tmp_path / "godot"
    godot.mkdir()
    padded(godot / "wall.occ", occ_bytes(*QUAD))
    padded(godot / "wall.tres", tres_text(*QUAD).encode())
    (godot / "occ.tscn").write_text(ext_scene("wall.occ"))
    (godot / "tres.tscn").write_text(ext_scene("wall.tres"))
    (tmp_path / "level.glb").write_bytes(level())
    outs = [tmp_path / f"out{k}" for k in range(5)]
    results = run_bounded(tmp_path, [
        ("cli", ["occlude", buf / "l.gltf", "-o", outs[0], "--methods", "bbox"]),
        ("cli", ["cull", buf / "l.gltf", *CULL, "--out", outs[1]]),
        ("cli", ["cull", img / "l.gltf", *CULL, "--out", outs[2]]),
        ("cli", ["compare", "fat-torus", "--methods", "bbox", "--views", "2", "--quads", "50",
                 "--res", "16", "--rays", "100", "--no-culling",
                 "--occluder-files", f"baked={godot / 'wall.occ'}", "--out", outs[3]]),
        ("load_occluder", [godot / "wall.occ"]),
        ("load_occluder", [godot / "tres.tscn"]),
        ("cli", ["cull", tmp_path / "level.glb", "--occluder-files", godot / "occ.tscn", *CULL,
                 "--out", outs[4]])])
    for rc, err in results[:2]:
        one_error(rc, err, "l.gltf", "'b.bin'", "3.0 GiB", "declares 240 bytes", "not read")
    one_error(*results[2], "l.gltf", "'t.png'", "a 4 x 4 image in a 3.0 GiB file", "not read")
    for rc, err in (results[3], results[4]):
        one_error(rc, err, "wall.occ", "bytes after the main resource", "not read")
    one_error(*results[5], "tres.tscn -> res://wall.tres", "NUL bytes at its end", "padded")
    one_error(*results[6], "occ.tscn -> res://wall.occ", "bytes after the main resource")
    assert not any(p.exists() for p in outs)


def test_occ_writer_of_these_tests_reads_back(tmp_path):
    """The test's own .occ writer: Godot's layout, read back exactly (not padded)."""
    (tmp_path / "wall.occ").write_bytes(occ_bytes(*QUAD))
    mesh = load_occluder(tmp_path / "wall.occ")
    np.testing.assert_array_equal(mesh.vertices, np.asarray(QUAD[0], float))
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3]])


def test_shipped_godot_bake_layout_ends_with_rsrc():
    """Godot's own bake (the demo's node_3d.occ layout, rebuilt): the reader stops at the
    main resource's end, 4 bytes (``RSRC``) before the file's; a byte more of padding is
    within the slack, 5 kB more is refused."""
    from viscore.exchange.file_access import DECLARED_SLACK
    from viscore.exchange.godot_binary import _load_occ

    data = occ_bytes(*QUAD)
    assert len(_load_occ(data, "wall.occ")[1]) == 2
    assert len(_load_occ(data + b"\0" * DECLARED_SLACK, "wall.occ")[1]) == 2
    with pytest.raises(InputError, match=r"wall\.occ: 4,101 bytes after the main resource"):
        _load_occ(data + b"\0" * (DECLARED_SLACK + 1), "wall.occ")


# ----------------------------------------------------------------------------- items 1, 9, 11
def test_referenced_files_regular_only(tmp_path):
    """A FIFO, a folder or a loop of links where a glTF's buffer or image is: refused by
    kind, never opened for reading (a FIFO would block)."""
    nodes = [{"name": "a", "mesh": 0}]
    for kind in ("fifo", "folder", "loop"):
        d = tmp_path / kind
        d.mkdir()
        target = d / "b.bin"
        if kind == "fifo":
            os.mkfifo(target)
        elif kind == "folder":
            target.mkdir()
        else:
            os.symlink("b.bin", target)
        (d / "l.gltf").write_text(json.dumps(box_doc(nodes, [0], uri="b.bin")))
        expect = {"fifo": "named pipe (FIFO)", "folder": "a directory",
                  "loop": "a loop of symbolic links"}[kind]
        for reader in (load_mesh, load_occluder):
            with pytest.raises(InputError, match=rf"l\.gltf: .b\.bin.: .*{re.escape(expect)}"):
                reader(d / "l.gltf")


def test_ext_resource_symlink_loop_one_line(tmp_path):
    """Item 11: ``res://loop.occ`` a link to itself: exit 2 'a loop of symbolic links' under
    cull and compare --occluder-files, and as an --occluder-files path itself."""
    os.symlink("loop.occ", tmp_path / "loop.occ")
    (tmp_path / "s.tscn").write_text(ext_scene("loop.occ"))
    (tmp_path / "level.glb").write_bytes(level())
    rc, _, err = run(["cull", tmp_path / "level.glb", "--occluder-files", tmp_path / "s.tscn",
                      *CULL, "--out", tmp_path / "c1"])
    one_error(rc, err, "s.tscn -> res://loop.occ", "a loop of symbolic links")
    for spec in (f"baked={tmp_path / 's.tscn'}", f"baked={tmp_path / 'loop.occ'}"):
        rc, _, err = run(["compare", "fat-torus", "--methods", "bbox", "--occluder-files", spec,
                          "--out", tmp_path / "c2"])
        one_error(rc, err, "--occluder-files", "loop.occ", "a loop of symbolic links")
    rc, _, err = run(["cull", tmp_path / "level.glb", "--occluder-files",
                      tmp_path / "loop.occ", *CULL, "--out", tmp_path / "c3"])
    one_error(rc, err, "loop.occ", "a loop of symbolic links")
    assert not any((tmp_path / c).exists() for c in ("c1", "c2", "c3"))


# ----------------------------------------------------------------------------- item 14
def test_projective_matrix_refused_when_the_level_is_read(tmp_path):
    """Item 14: a node matrix with a projective row: occlude and cull refuse it alike,
    before any job, naming the file and the node; load_occluder too."""
    def projective(doc):
        del doc["nodes"][0]["translation"]
        doc["nodes"][0]["matrix"] = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1]

    path = tmp_path / "l.glb"
    path.write_bytes(level(edit=projective))
    words = ("l.glb", "node 0 ('bld0')", "'matrix' is not affine", "last row is 0, 0, 5, 1")
    rc, _, err = run(["occlude", path, "-o", tmp_path / "occ", "--methods", "bbox"])
    one_error(rc, err, *words)
    rc, _, err = run(["cull", path, *CULL, "--out", tmp_path / "cull"])
    one_error(rc, err, *words)
    with pytest.raises(InputError, match="'matrix' is not affine"):
        load_occluder(path)
    with pytest.raises(InputError, match="'matrix' is not affine"):
        load_mesh(path)
    assert not (tmp_path / "occ").exists() and not (tmp_path / "cull").exists()


def test_projective_world_transform_of_a_trimesh_scene_refused():
    from viscore.level import load_scene_objects

    scene = trimesh.Scene()
    matrix = np.eye(4)
    matrix[3, 2] = 5.0
    scene.add_geometry(trimesh.creation.box(), node_name="bld0", transform=matrix)
    with pytest.raises(InputError, match=r"node 'bld0' has a transform that is not affine"):
        load_scene_objects(scene)


# ----------------------------------------------------------------------------- items 18-21
def test_transform3d_beyond_float32_one_line(tmp_path):
    """Item 18: a Transform3D value of 1e300: one error line, no RuntimeWarning before it
    (without --quiet, warnings go through logging)."""
    (tmp_path / "t.tscn").write_text(
        '[gd_scene format=3]\n\n[sub_resource type="ArrayOccluder3D" id="a"]\n'
        "vertices = PackedVector3Array(0, 0, 0, 1, 0, 0, 0, 1, 0)\n"
        "indices = PackedInt32Array(0, 1, 2)\n\n[node name=\"R\" type=\"Node3D\"]\n\n"
        '[node name="O" type="OccluderInstance3D" parent="."]\n'
        "transform = Transform3D(1e300, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0)\n"
        'occluder = SubResource("a")\n')
    (tmp_path / "level.glb").write_bytes(level())
    rc, _, err = run(["cull", tmp_path / "level.glb", "--occluder-files", tmp_path / "t.tscn",
                      *CULL, "--out", tmp_path / "c"])
    one_error(rc, err, "t.tscn", "node 'O' transform", "1e+300", "beyond float32's range")
    assert not (tmp_path / "c").exists()


def test_shear_is_not_called_a_zero_scale(tmp_path):
    """Item 19: a shear of determinant 1 with an entry 1e6 is refused as what it is."""
    def shear(doc):
        del doc["nodes"][0]["translation"]
        doc["nodes"][0]["matrix"] = [1, 0, 0, 0, 1e6, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]

    def zero(doc):
        doc["nodes"][0]["scale"] = [1, 0, 1]

    (tmp_path / "shear.glb").write_bytes(level(edit=shear))
    (tmp_path / "zero.glb").write_bytes(level(edit=zero))
    rc, _, err = run(["cull", tmp_path / "shear.glb", *CULL, "--out", tmp_path / "c"])
    line = one_error(rc, err, "shear.glb", "node 'bld0'", "volume scale 1 is under 1e-12 x its "
                     "largest entry 1e+06 cubed", "shear")
    assert "zero scale" not in line
    rc, _, err = run(["cull", tmp_path / "zero.glb", *CULL, "--out", tmp_path / "c"])
    one_error(rc, err, "zero.glb", "node 'bld0'", "singular transform (a zero scale")


@pytest.mark.parametrize(("edit", "words"), [
    (lambda d: d["bufferViews"][1].update(byteLength=d["bufferViews"][1]["byteLength"] + 4),
     ("bufferView 1 runs past its buffer", "byteOffset 96 + byteLength 148 > buffer 0's 240")),
    (lambda d: d["bufferViews"][1].update(byteOffset=200),
     ("bufferView 1 runs past its buffer", "byteOffset 200")),
    (lambda d: d["bufferViews"][0].update(byteStride=16),
     ("accessor 0 runs past bufferView 0", "byteStride 16")),
    (lambda d: d["bufferViews"][0].update(byteStride=400), ("bufferView 0 byteStride 400",)),
    (lambda d: d["accessors"][1].update(byteOffset=8),
     ("accessor 1 runs past bufferView 1", "byteOffset 8")),
    (lambda d: d["buffers"][0].update(byteLength=4000),
     ("buffer 0 declares 4,000 bytes, but the GLB binary chunk holds 240",)),
])
def test_buffer_view_bounds_named(tmp_path, edit, words):
    """Item 20: views and accessors past their buffer: one line naming what and by how much
    (trimesh's reader said only 'AssertionError:')."""
    path = tmp_path / "l.glb"
    path.write_bytes(level(edit=edit))
    rc, _, err = run(["cull", path, *CULL, "--out", tmp_path / "c"])
    line = one_error(rc, err, "l.glb", *words)
    assert "AssertionError" not in line
    for reader in (load_mesh, load_occluder):
        with pytest.raises(InputError, match=words[0].replace("(", r"\(")):
            reader(path)


def test_bomless_utf16_obj_is_decoded(tmp_path):
    """Item 21: UTF-16 without a BOM (either byte order) reads as the UTF-8 file does."""
    (tmp_path / "utf8.obj").write_text(TET)
    expected = load_mesh(tmp_path / "utf8.obj")
    for codec in ("utf-16-le", "utf-16-be", "utf-32-le", "utf-32-be"):
        path = tmp_path / f"{codec}.obj"
        path.write_bytes(("# a comment\n" + TET).encode(codec))
        mesh = load_mesh(path)
        np.testing.assert_array_equal(mesh.faces, expected.faces)
        np.testing.assert_array_equal(mesh.vertices, expected.vertices)
    rc, out, err = run(["measure", tmp_path / "utf-16-le.obj", *MEASURE, "--json"])
    assert rc == 0, err
    assert json.loads(out)["occlusion_measure"] > 0


# ----------------------------------------------------------------------------- item 22
def test_sparse_positions_refused(tmp_path):
    def sparse(doc):
        doc["accessors"][0]["sparse"] = {"count": 1, "indices": {"bufferView": 1,
                                                                   "componentType": 5125},
                                         "values": {"bufferView": 0}}

    path = tmp_path / "l.glb"
    path.write_bytes(level(edit=sparse))
    rc, _, err = run(["cull", path, *CULL, "--out", tmp_path / "c"])
    one_error(rc, err, "l.glb", "mesh 0 primitive 0 reads its POSITION from accessor 0, which "
              "is sparse")
    for reader in (load_mesh, load_occluder):
        with pytest.raises(InputError, match="sparse"):
            reader(path)


def test_mesh_without_primitives_said(tmp_path, caplog):
    from viscore.level import load_scene_objects

    def empty_mesh(doc):
        doc["meshes"].append({"name": "nothing", "primitives": []})
        doc["nodes"].append({"name": "ghost", "mesh": 1})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)

    path = tmp_path / "l.glb"
    path.write_bytes(level(edit=empty_mesh))
    with caplog.at_level(logging.WARNING):
        objects = load_scene_objects(path)
    assert objects.names == ("bld0", "bld1", "bld2")
    said = [r.getMessage() for r in caplog.records if "without primitives" in r.getMessage()]
    assert len(said) == 1 and "1 mesh without primitives (1), used by 1 node" in said[0]


def test_load_occluder_refuses_node_cycles(tmp_path):
    nodes = [{"name": "a-occonly", "children": [1]}, {"name": "b-occonly", "mesh": 0,
                                                      "children": [0]}]
    path = tmp_path / "cycle.glb"
    path.write_bytes(glb(box_doc(nodes, [0]), box_bin()))
    with pytest.raises(InputError, match=r"cycle\.glb: node 0 \('a-occonly'\) is its own "
                                         r"descendant: the node hierarchy has a cycle"):
        load_occluder(path)


def test_occluder_instances_counted_before_placed(tmp_path, monkeypatch):
    """glTF -occonly nodes instancing one mesh are counted (each instance) before any is
    placed: a limit between one instance and all refuses the file."""
    from viscore.exchange import godot_binary

    nodes = [{"name": f"w{i}-occonly", "mesh": 0, "translation": [2.0 * i, 0, 0]}
             for i in range(50)]
    path = tmp_path / "walls.glb"
    path.write_bytes(glb(box_doc(nodes, list(range(50))), box_bin()))
    assert len(load_occluder(path).faces) == 600
    placed = []
    monkeypatch.setattr(godot_binary, "_occluder_mesh",
                        lambda *a, **k: placed.append(1) or pytest.fail("placed"))
    monkeypatch.setenv("VISCORE_MEMORY_FRACTION", str(
        599 * godot_binary._BYTES_PER_PLACED_TRIANGLE / _available()))
    with pytest.raises(InputError, match=r"walls\.glb \(600 triangles with instances placed\)"):
        load_occluder(path)
    assert not placed


def _available() -> float:
    from viscore._validate import available_memory

    return float(available_memory())


def test_many_objects_get_a_time_estimate(tmp_path, monkeypatch):
    """Item 22: a level of many objects says, once read, how long the work before the
    first frame takes (measured on the read); a small one says nothing."""
    from viscore.cli import cull_cmd

    (tmp_path / "l.glb").write_bytes(level(count=4))
    rc, _, err = run(["cull", tmp_path / "l.glb", *CULL, "--out", tmp_path / "a"])
    assert rc == 0 and "work before the first frame" not in err
    monkeypatch.setattr(cull_cmd, "MANY_OBJECTS", 4)
    rc, _, err = run(["cull", tmp_path / "l.glb", *CULL, "--out", tmp_path / "b"])
    assert rc == 0
    said = [line for line in err.splitlines() if "work before the first frame" in line]
    assert len(said) == 1 and said[0].startswith("viscore: cull: 4 objects, read in ")
