"""Hostile input: property tests over mesh loading and every subcommand.

The contract checked on every generated case: the library either returns a
valid mesh or raises :class:`viscore.InputError` (never another exception);
every subcommand (``measure``, ``evaluate``, ``validate``, ``generate`` with
every registered method, ``compare``, ``uncertainty`` and ``uncertainty
ablation``, ``bench`` (argument errors only: no benchmark runs), ``data
export``, ``cull``) either succeeds (exit 0, or 1 for a ``validate`` check that ran and
failed) or exits 2 with exactly one stderr line starting ``viscore: error:``
under ``--quiet`` (without it, ``viscore:`` log lines may come first, never a
traceback or a raw Python warning), nothing on stdout, and nothing at the
output path (an occluder file, a study folder, an uncertainty folder): never
exit 3. Valid but odd meshes (flat, a single triangle, cubes at 1e-12 and
1e12) must succeed or be refused with one line. Cases run in-process through
``viscore.cli.main.main``, with and without ``--quiet``.

Classes of input tried
----------------------
Files, under every extension (.obj .ply .stl .off .glb .gltf .zip):
    empty; a valid file truncated at a random byte; random bytes; a valid
    file with random bytes overwritten; random text in UTF-8, UTF-16 and
    Latin-1.
Coordinates (OBJ, full float64 digits): NaN, +-inf, 1e30, 1e-30, subnormal
    (5e-320), 1e95, 1e-95, mixed with ordinary values, whole meshes scaled by
    1e-60..1e60 and shifted far from the origin; faces with index 0,
    negative (relative) and out-of-range indices.
Shapes: all-degenerate faces (collinear, repeated indices), a single random
    triangle, flat meshes (random triangles in a plane), point clouds (PLY and
    OBJ without faces), line-only OBJ, quads and convex n-gons (n = 4..12) in
    OBJ and OFF, GLB scenes with many nodes and instancing, GLTF with its
    external buffer missing.
Paths given as meshes: a directory, a dangling symbolic link, a FIFO, a path
    through a regular file (``file.ply/x.ply``: unreadable even for root),
    ``/dev/urandom``, ``/proc/self/status``, a missing file.
    All of the above as the mesh of ``measure``, ``generate`` (every method),
    as either mesh of ``evaluate`` and ``validate``, as a mesh of ``compare``
    (first or second of two), as the mesh, the occluder or ``--versus`` of
    ``uncertainty``, and (refused ones) as ``bench rays|voxels|evaluate --mesh``.
Output paths: ``data export -o`` and ``generate -o``: a missing folder, a path
    through a file, a read-only location (``/proc``), an existing directory,
    an unknown suffix, STL/GLB for a mesh float32 cannot hold, and a writable
    path (mode must be 0o666 & ~umask). ``compare --out`` and ``uncertainty
    --out``: a missing parent, a path through a file, an existing file (left
    unchanged), ``/proc``, a dangling link, a FIFO.
Options: 0, negative, NaN, +-inf, ``1e5``, 10^5 and 16385 pixels, 10^12,
    2^64, 2^70 (``validate --rays``: over its cap of 10^10), non-numbers and
    empty strings for every numeric option of
    measure, evaluate, validate, compare, uncertainty (and its ablation),
    bench rays|voxels|evaluate; every option a generator's registry entry
    declares, plus ``--budget`` and ``--seed``, with those values and
    ``none``, 1e300, 1e-300, 5e-324, 11 (below aabb-skins' one box) and
    misspelt choices, the expected outcome taken from the registry;
    malformed comma lists (``,``, ``12;24``, ``1,,x``, ``10,0``) for
    ``--budget``, ``--methods``, ``--quads-list``, ``--views-list``,
    ``--spacings``, ``--factors``, ``bench voxels --res``; unknown methods,
    ``--versus`` not among the methods, unknown protocols; ``compare
    --scheduler`` malformed or not answering; options ``uncertainty
    ablation`` does not use; method variants whose options conflict
    (``planar-sections:pixel-error=1``, ``:voxels=32:voxel-size=0.1``,
    ``:close=2:conservative=true``, ``:hierarchy=true:dilate=1``) for
    ``compare --methods`` and ``cull --methods`` / ``--frusta-method``, refused
    before any folder; seeds beyond 64 bits (valid: must run); wrong
    item counts; names that are not built-in scenes for ``data export``;
    ``bench generate --models`` missing, a file, an empty folder.
Culling (``cull``, at 1 frame of 16 x 9 pixels with bbox occluders): every
    hostile file, coordinate, shape and path class above as SCENE; glTF
    scenes with a NaN translation, an infinite, zero or 1e300 node scale, a
    NaN matrix, no mesh node, a JSON list, a GLB with zero meshes; ``--path``
    camera files: empty, not JSON, not a list, an empty list, nesting 10^5
    deep, cameras not objects, missing keys, unknown keys, NaN/inf vectors,
    zero forward, up zero or parallel to forward, fov 0, negative, 180, 1e9,
    NaN, a string or a boolean, vectors of 2 or 4 numbers, nested, a string,
    booleans, null, an integer of 400 digits, a camera at 1e300, random
    text; the camera file a directory, a FIFO, missing; absurd ``--frames``,
    ``--width``, ``--height`` (8193, 2^70), ``--buffer-scale``, ``--active``,
    ``--size-threshold``, ``--seed``, ``--cap``, ``--rank``, unknown
    ``--methods`` and ``--frusta-method``, ``--occluders`` naming no object;
    every ``--out`` kind of ``compare``; and odd valid scenes (one object,
    flat objects, degenerate faces beside good ones, 1e12 and 1e-9 scenes,
    30 instances), which run and write their three files or are refused.

The default run derandomises hypothesis (the same cases every run) and keeps
under about a minute; ``-m slow`` runs ten times as many random cases, and
runs ``compare`` and ``uncertainty`` on the valid hostile meshes too. Every
property asserts that it ran the number of cases it asks for (its
``max_examples``, or all the cases of a search space smaller than that): a
case that does not apply is rejected with ``hypothesis.assume`` and replaced,
never returned from untested. The number of generated cases run is printed at
the end of the module (``pytest -s``).

The error-line contract is checked on both ``sys.stderr`` (redirected
in-process) and file descriptor 2 (``capfd``): Embree and numba write to the
descriptor directly, bypassing ``sys.stderr``; likewise descriptor 1 joins
stdout.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import os
import stat
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from viscore import InputError, Scene, load_mesh
from viscore.cli.main import main

EXTENSIONS = ("obj", "ply", "stl", "off", "glb", "gltf", "zip")

#: Generated cases run, by property (printed at the end of the module).
CASES: dict[str, int] = {}

#: The fixed cheap options that make a successful run take ~0.05 s.
_CHEAP = {
    "measure": ["--directions", "2", "--res", "16"],
    "evaluate": ["--views", "2", "--quads", "50", "--res", "16"],
    "validate": ["--rays", "500"],
}


def _examples(examples: int, slow: bool) -> int:
    return examples * (10 if slow else 1)


def _settings(examples: int, slow: bool, suppress: tuple[HealthCheck, ...] = ()):
    """Hypothesis settings of a property; health checks on unless ``suppress`` names one."""
    return settings(max_examples=_examples(examples, slow), deadline=None, database=None,
                    derandomize=not slow, print_blob=True, suppress_health_check=list(suppress))


def run_property(prop, examples: int, slow: bool, *, space: int | None = None) -> int:
    """Run a hypothesis property and assert it ran every case it asked for.

    ``examples`` is the default run's ``max_examples`` (ten times that under
    ``slow``); ``space`` the number of distinct cases its strategies can draw,
    when that is finite and may be smaller (hypothesis then runs each once).
    """
    before = sum(CASES.values())
    prop()
    ran = sum(CASES.values()) - before
    expected = _examples(examples, slow) if space is None else min(space,
                                                                  _examples(examples, slow))
    assert ran == expected, f"ran {ran} cases, expected {expected}"
    return ran


#: capfd of the running test: :func:`run_cli` reads file descriptors 1 and 2 through it.
_FD: dict = {}


@pytest.fixture(autouse=True)
def _fd_capture(capfd):
    _FD["capfd"] = capfd
    yield
    _FD.pop("capfd", None)


@pytest.fixture(scope="module")
def workdir():
    with tempfile.TemporaryDirectory(prefix="viscore-hostile-") as d:
        yield Path(d)
    total = sum(CASES.values())
    print(f"\nhostile-input cases run: {total} ({', '.join(f'{k} {v}' for k, v in CASES.items())})")


_names = itertools.count()


def _fresh(workdir: Path, suffix: str) -> Path:
    return workdir / f"case{next(_names)}.{suffix}"


def _count(name: str) -> None:
    CASES[name] = CASES.get(name, 0) + 1


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of one in-process run: ``sys.stdout`` / ``sys.stderr``
    and, after them, what reached file descriptors 1 and 2 directly (C libraries)."""
    capfd = _FD.get("capfd")
    if capfd is not None:
        capfd.readouterr()  # drop what came before this run
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse usage errors
            rc = exc.code
    fd_out = fd_err = ""
    if capfd is not None:
        fd_out, fd_err = capfd.readouterr()
    return rc, out.getvalue() + fd_out, err.getvalue() + fd_err


def assert_contract(rc: int, out: str, err: str, *, ok=(0,), output: Path | None = None,
                    json_out: bool = False) -> None:
    """Success, or exit 2 with one error line, nothing on stdout, nothing written."""
    if rc in ok:
        if json_out and rc in (0, 1):
            json.loads(out)
        return
    lines = err.strip().splitlines()
    assert rc == 2, f"exit {rc}: {err[-2000:]}"
    assert len(lines) == 1, f"{len(lines)} stderr lines: {err[-2000:]}"
    assert lines[0].startswith("viscore: error:"), lines[0]
    assert out == "", out
    if output is not None:
        assert not os.path.lexists(output), f"{output} left behind"
        assert not list(output.parent.glob(f".{output.name}.*")), "temporary file left behind"


def check_load(path: Path) -> trimesh.Trimesh | None:
    """The library side: a valid mesh or InputError, nothing else."""
    try:
        mesh = load_mesh(path)
    except InputError as exc:
        assert "\n" not in str(exc)
        return None
    assert len(mesh.faces) > 0 and np.isfinite(mesh.vertices).all()
    return mesh


def check_measure(path: Path, quiet: bool) -> int:
    rc, out, err = run_cli(["measure", str(path), *_CHEAP["measure"], "--json"]
                           + (["--quiet"] if quiet else []))
    assert_contract(rc, out, err, json_out=True)
    return rc


# --------------------------------------------------------------------------- file bytes
def _obj_text(vertices, faces) -> str:
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(int(i)) for i in f) for f in faces]
    return "\n".join(lines) + "\n"


def _valid_bytes() -> dict[str, bytes]:
    box = trimesh.creation.box()
    box.apply_translation([0.25, 0, 0])
    data = {ext: box.export(file_type=ext) for ext in ("ply", "stl", "off", "glb")}
    data["obj"] = _obj_text(box.vertices, box.faces + 1)
    data["gltf"] = box.export(file_type="gltf", embed_buffers=True)["model.gltf"]
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("box.obj", data["obj"])
    data["zip"] = buf.getvalue()
    return {k: v if isinstance(v, bytes) else v.encode() for k, v in data.items()}


VALID = _valid_bytes()


FILE_KINDS = ["empty", "truncated", "random", "flipped", "text"]


@st.composite
def hostile_bytes(draw, ext: str, kind: str) -> bytes:
    valid = VALID[ext]
    if kind == "empty":
        return b""
    if kind == "truncated":
        return valid[:draw(st.integers(1, len(valid) - 1))]
    if kind == "random":
        return draw(st.binary(min_size=1, max_size=3000))
    if kind == "flipped":
        data = bytearray(valid)
        for pos, byte in draw(st.lists(st.tuples(st.integers(0, len(data) - 1),
                                                 st.integers(0, 255)), min_size=1, max_size=8)):
            data[pos] = byte
        return bytes(data)
    text = draw(st.text(max_size=400))
    return text.encode(draw(st.sampled_from(["utf-8", "utf-16", "latin-1"])), errors="replace")


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("kind", FILE_KINDS)
@pytest.mark.parametrize("ext", EXTENSIONS)
def test_hostile_file_bytes(workdir, ext, kind, slow):
    @_settings(1 if kind == "empty" else 5, slow)
    @given(data=hostile_bytes(ext, kind), quiet=st.booleans())
    def prop(data, quiet):
        _count(f"files.{kind}")
        path = _fresh(workdir, ext)
        path.write_bytes(data)
        mesh = check_load(path)
        rc = check_measure(path, quiet)
        assert (rc == 0) == (mesh is not None)

    run_property(prop, 1 if kind == "empty" else 5, slow,
                 space=2 if kind == "empty" else None)  # empty: only --quiet varies


# --------------------------------------------------------------------------- coordinates
SPECIAL = [np.nan, np.inf, -np.inf, 1e30, -1e30, 1e-30, 5e-320, 1e95, 1e-95, 0.0, 1.0, -1.0]


@st.composite
def hostile_obj(draw) -> tuple[str, str]:
    kind = draw(st.sampled_from(["special", "scaled", "indices"]))
    if kind == "scaled":
        box = trimesh.creation.box()
        scale = 10.0 ** draw(st.integers(-60, 60))
        shift = 10.0 ** draw(st.integers(-3, 12)) * scale * draw(st.sampled_from([0, 1]))
        return kind, _obj_text(box.vertices * scale + shift, box.faces + 1)
    n = draw(st.integers(3, 8))
    values = st.one_of(st.sampled_from(SPECIAL), st.floats(-10, 10))
    vertices = draw(st.lists(st.tuples(values, values, values), min_size=n, max_size=n))
    if kind == "special":
        faces = draw(st.lists(st.tuples(*[st.integers(1, n)] * 3), min_size=1, max_size=6))
    else:  # 0, negative (relative, valid when >= -n) and out-of-range indices
        index = st.integers(-n - 2, n + 2)
        faces = draw(st.lists(st.tuples(index, index, index), min_size=1, max_size=6))
    return kind, _obj_text(vertices, faces)


def _fat_face_hit(mesh: trimesh.Trimesh) -> None:
    """A ray along the normal of a well-shaped face towards its centroid hits it (float32)."""
    lo, hi = mesh.bounds
    diag = float(np.linalg.norm((hi - lo) / max(hi - lo))) * float(max(hi - lo))
    tri = (mesh.triangles - lo) / diag  # unit size: no overflow in the shape tests below
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)  # twice the area
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    fat = (area2 > 2e-4) & (area2 > 1e-3 * longest)  # area and height well above float32
    if not fat.any():
        return
    k = int(np.flatnonzero(fat)[0])
    normal = cross[k] / area2[k]
    centre = mesh.triangles[k].mean(axis=0)
    t, _ = Scene(mesh).first_hit(centre + normal * diag, -normal)
    assert np.isfinite(t[0]) and t[0] <= diag * (1 + 1e-5), (t[0], diag)


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_hostile_coordinates_and_indices(workdir, slow):
    @_settings(60, slow)
    @given(case=hostile_obj(), quiet=st.booleans())
    def prop(case, quiet):
        kind, text = case
        _count(f"coordinates.{kind}")
        path = _fresh(workdir, "obj")
        path.write_text(text)
        mesh = check_load(path)
        if mesh is not None:
            _fat_face_hit(mesh)
        rc = check_measure(path, quiet)
        assert (rc == 0) == (mesh is not None)
        face_indices = [int(t) for line in text.splitlines() if line.startswith("f ")
                        for t in line.split()[1:]]
        if 0 in face_indices:
            assert mesh is None  # OBJ counts from 1: index 0 is refused, never wrapped

    run_property(prop, 60, slow)


def test_scaled_box_always_measured(workdir):
    # every scale in 1e-60..1e60 at a small shift is a valid mesh: exit 0
    for exponent in (-60, -30, -12, 0, 12, 17, 30, 60):
        box = trimesh.creation.box()
        path = _fresh(workdir, "obj")
        path.write_text(_obj_text(box.vertices * 10.0**exponent, box.faces + 1))
        _count("coordinates.scaled-fixed")
        assert check_measure(path, quiet=True) == 0, exponent


# --------------------------------------------------------------------------- shapes
SHAPE_KINDS = ["degenerate", "triangle", "flat", "cloud-ply", "cloud-obj", "lines", "ngon-obj",
               "ngon-off", "instances"]


@st.composite
def hostile_shape(draw, kind: str) -> tuple[str, str, bytes, object]:
    """(kind, extension, bytes, expected): expected is a face count, 'error' or 'ok'."""
    coord = st.floats(-5, 5, allow_nan=False)
    if kind == "degenerate":
        a, b = np.array(draw(st.tuples(coord, coord, coord))), np.array([1.0, 2.0, 3.0])
        v = [a, a + b, a + 2 * b, a + 0.5 * b]  # collinear
        faces = [[1, 2, 3], [1, 1, 2], [2, 3, 4], [4, 4, 4]]
        return kind, "obj", _obj_text(v, faces).encode(), "error"
    if kind == "triangle":
        v = draw(st.lists(st.tuples(coord, coord, coord), min_size=3, max_size=3))
        return kind, "obj", _obj_text(v, [[1, 2, 3]]).encode(), "ok-or-error"
    if kind == "flat":
        n = draw(st.integers(3, 12))
        xy = draw(st.lists(st.tuples(coord, coord), min_size=n, max_size=n))
        v = [(x, y, 0.0) for x, y in xy]
        faces = draw(st.lists(st.tuples(*[st.integers(1, n)] * 3), min_size=1, max_size=10))
        return kind, "obj", _obj_text(v, faces).encode(), "ok-or-error"
    if kind in ("cloud-ply", "cloud-obj", "lines"):
        n = draw(st.integers(1, 20))
        pts = np.array(draw(st.lists(st.tuples(coord, coord, coord), min_size=n, max_size=n)))
        if kind == "cloud-ply":
            return kind, "ply", trimesh.PointCloud(pts).export(file_type="ply"), "error"
        text = _obj_text(pts, [])
        if kind == "lines":
            text += "l " + " ".join(str(i + 1) for i in range(n)) + "\n"
        return kind, "obj", text.encode(), "error"
    if kind in ("ngon-obj", "ngon-off"):
        k = draw(st.integers(4, 12))
        radius = draw(st.floats(0.01, 100))
        ang = 2 * np.pi * np.arange(k) / k
        v = np.column_stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(k)])
        if kind == "ngon-obj":
            text = _obj_text(v, []) + "f " + " ".join(str(i + 1) for i in range(k)) + "\n"
            return kind, "obj", text.encode(), k - 2
        rows = "".join(f"{float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
        text = f"OFF\n{k} 1 0\n{rows}{k} " + " ".join(map(str, range(k))) + "\n"
        return kind, "off", text.encode(), k - 2
    count = draw(st.integers(1, 60))  # instances of one box in a GLB
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(), geom_name="box", node_name="n0")
    for i in range(1, count):
        scene.graph.update(frame_to=f"n{i}", frame_from=scene.graph.base_frame, geometry="box",
                           matrix=trimesh.transformations.translation_matrix([2.0 * i, 0, 0]))
    return kind, "glb", scene.export(file_type="glb"), 12 * count


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("shape", SHAPE_KINDS)
def test_hostile_shapes(workdir, shape, slow):
    @_settings(6, slow)
    @given(case=hostile_shape(shape), quiet=st.booleans())
    def prop(case, quiet):
        kind, ext, data, expected = case
        _count(f"shapes.{kind}")
        path = _fresh(workdir, ext)
        path.write_bytes(data)
        mesh = check_load(path)
        if expected == "error":
            assert mesh is None
        elif isinstance(expected, int):
            assert mesh is not None and len(mesh.faces) == expected
        rc = check_measure(path, quiet)
        assert (rc == 0) == (mesh is not None)

    run_property(prop, 6, slow)


def test_gltf_missing_buffer_one_line(workdir):
    files = trimesh.Scene([trimesh.creation.box()]).export(file_type="gltf")
    folder = workdir / "gltf-missing"
    folder.mkdir()
    for name, data in files.items():
        if not name.endswith(".bin"):
            (folder / name).write_bytes(data)
    _count("shapes.gltf-missing-buffer")
    assert check_load(folder / "model.gltf") is None
    assert check_measure(folder / "model.gltf", quiet=False) == 2


# --------------------------------------------------------------------------- paths
def _bad_path(workdir: Path, kind: str) -> Path:
    base = workdir / f"p{next(_names)}"
    if kind == "directory":
        base.mkdir()
        return base
    if kind == "dangling":
        link = base.with_suffix(".obj")
        link.symlink_to(workdir / "gone.obj")
        return link
    if kind == "fifo":
        fifo = base.with_suffix(".ply")
        os.mkfifo(fifo)
        return fifo
    if kind == "through-file":
        f = base.with_suffix(".ply")
        f.write_bytes(VALID["ply"])
        return f / "x.ply"
    if kind == "missing":
        return base.with_suffix(".stl")
    return Path({"urandom": "/dev/urandom", "proc": "/proc/self/status"}[kind])


PATH_KINDS = ["directory", "dangling", "fifo", "through-file", "missing", "urandom", "proc"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("kind", PATH_KINDS)
def test_hostile_paths_as_meshes(workdir, kind, slow):
    @_settings(5, slow)
    @given(command=st.sampled_from(["measure", "evaluate", "validate"]),
           slot=st.integers(0, 1), quiet=st.booleans())
    def prop(command, slot, quiet):
        _count(f"paths.{kind}")
        bad = _bad_path(workdir, kind)
        if kind in ("urandom", "proc"):  # Linux has both: the case is never skipped
            assert os.path.lexists(bad), bad
        with pytest.raises(InputError):
            load_mesh(bad)
        meshes = [str(bad)] if command == "measure" else (
            [str(bad), "fat-torus"] if slot == 0 else ["fat-torus", str(bad)])
        rc, out, err = run_cli([command, *meshes, *_CHEAP[command]]
                               + (["--quiet"] if quiet else []))
        assert rc == 2
        assert_contract(rc, out, err)

    run_property(prop, 5, slow, space=3 * 2 * 2)  # command x slot x quiet


# --------------------------------------------------------------------------- outputs
OUTPUT_KINDS = ["missing-folder", "through-file", "read-only", "directory", "bad-suffix", "ok"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("kind", OUTPUT_KINDS)
def test_hostile_output_paths(workdir, kind, slow):
    from viscore._atomic import _umask

    @_settings(4, slow)
    @given(fmt=st.sampled_from(["ply", "obj", "stl", "off", "glb"]), quiet=st.booleans())
    def prop(fmt, quiet):
        _count(f"outputs.{kind}")
        base = workdir / f"o{next(_names)}"
        if kind == "missing-folder":
            out = base / "a" / "b" / f"x.{fmt}"
        elif kind == "through-file":
            base.write_text("x")
            out = base / f"x.{fmt}"
        elif kind == "read-only":
            out = Path(f"/proc/viscore-{next(_names)}.{fmt}")  # root cannot write there either
        elif kind == "directory":
            out = base.with_suffix(f".{fmt}")
            out.mkdir()
        elif kind == "bad-suffix":
            out = base.with_suffix(".xyz")
        else:
            out = base.with_suffix(f".{fmt}")
        rc, stdout, err = run_cli(["data", "export", "fat-torus", "-o", str(out)]
                                  + (["--quiet"] if quiet else []))
        if kind == "ok":
            assert rc == 0, err
            assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~_umask()
            assert len(load_mesh(out).faces) == 2304
            return
        assert rc == 2
        assert_contract(rc, stdout, err, output=None if kind == "directory" else out)
        assert ".tmp" not in err and str(out) in err  # the user's path, not a temporary file
        if kind == "missing-folder":
            assert not (base / "a").exists()  # no tree created
        if kind == "directory":
            assert out.is_dir() and not any(out.iterdir())

    run_property(prop, 4, slow, space=5 * 2)  # format x quiet


# --------------------------------------------------------------------------- options
ABSURD = ["0", "-1", "-5", "nan", "inf", "-inf", "1e5", "1.5", "abc", "", str(10**12),
          str(2**64), str(2**70)]
OPTIONS = {
    "measure": ["--directions", "--res", "--seed"],
    "evaluate": ["--views", "--quads", "--res", "--seed", "--spacing"],
    "validate": ["--rays", "--confidence", "--max-rate", "--seed"],
}


def _absurd_value_valid(option: str, value: str) -> bool:
    """Whether measure / evaluate / validate accept ``option=value`` (their documented ranges).

    ``--seed``: any non-negative integer. ``--confidence``: a number in (0, 1).
    ``--max-rate``: a fraction in [0, 1]. ``--spacing`` (volume): a finite number > 0,
    in world units (1e5 or 2^70 leaves one view position: valid). The counts
    (``--directions``, ``--views``, ``--quads``, ``--rays``, ``--res``) take none of
    :data:`ABSURD` (each is 0, negative, not an integer or beyond memory).
    """
    if option == "--seed":
        return value.isdigit()
    try:
        number = float(value)
    except ValueError:
        return False
    if option == "--confidence":
        return 0 < number < 1
    if option == "--max-rate":
        return 0 <= number <= 1
    if option == "--spacing":
        return bool(np.isfinite(number)) and number > 0
    return False


def _absurd_values(command: str, option: str) -> list[str]:
    return ABSURD + (["100000", "16385"] if option == "--res" else [])


@st.composite
def absurd_option(draw, command: str) -> list[str]:
    option = draw(st.sampled_from(OPTIONS[command]))
    values = _absurd_values(command, option)
    value = draw(st.sampled_from(values))
    meshes = ["fat-torus"] if command == "measure" else ["fat-torus", "fat-torus"]
    extra = ["--protocol", "volume", "--quads", "50", "--res", "8"] if option == "--spacing" else []
    cheap = [] if option == "--spacing" else _CHEAP[command]
    return [command, *meshes, *cheap, *extra, f"{option}={value}"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("command", sorted(OPTIONS))
def test_absurd_options(command, slow):
    @_settings(30, slow)
    @given(argv=absurd_option(command), quiet=st.booleans())
    def prop(argv, quiet):
        _count(f"options.{argv[0]}")
        rc, out, err = run_cli([*argv, "--json"] + (["--quiet"] if quiet else []))
        option, value = argv[-1].split("=", 1)
        if _absurd_value_valid(option, value):
            # a valid value runs: measure and evaluate exit 0; validate 0 when the bound
            # passes --max-rate, else 1 (the documented failed check), as its JSON says
            if argv[0] == "validate":
                assert rc in (0, 1), err
                assert json.loads(out)["passed"] == (rc == 0)
            else:
                assert rc == 0, err
        else:
            assert rc == 2, f"{argv}: exit {rc}"
        assert_contract(rc, out, err, ok=(0, 1), json_out=True)

    space = 2 * sum(len(_absurd_values(command, option)) for option in OPTIONS[command])
    run_property(prop, 30, slow, space=space)


class _Started(BaseException):
    """Raised by a stand-in for the main ray cast: the command got that far."""


@pytest.mark.parametrize("rays", [10**12, 2**64, 2**70])
def test_validate_huge_rays_refused_with_their_time(monkeypatch, rays):
    """``validate --rays 10^12`` (39 days at the measured rate) is over the cap: one line."""
    import viscore.cli.metrics_cmd as metrics_cmd

    def never(*args, **kwargs):
        raise _Started

    monkeypatch.setattr(metrics_cmd, "check_conservative", never)
    rc, out, err = run_cli(["validate", "fat-torus", "fat-torus", f"--rays={rays}"])
    assert rc == 2 and f"--rays {rays}: at most {metrics_cmd.MAX_RAYS}" in err, err
    assert_contract(rc, out, err)


def test_seed_rule_in_the_samplers():
    from viscore import directions_fibonacci, directions_uniform, grid_positions, rays_between

    big = 2**70
    assert directions_uniform(3, seed=big).shape == (3, 3)
    assert directions_fibonacci(3, seed=big).shape == (3, 3)
    assert rays_between([[0, 0, 0], [1, 1, 1]], [[2, 2, 2], [3, 3, 3]], 2, seed=big)[0].shape \
        == (2, 3)
    for bad in (-1, 1.5, None, "3", True):
        with pytest.raises(InputError, match="seed"):
            directions_uniform(3, seed=bad)
        with pytest.raises(InputError, match="seed"):
            rays_between([[0, 0, 0], [1, 1, 1]], [[2, 2, 2], [3, 3, 3]], 2, seed=bad)
    with pytest.raises(InputError, match="grid positions"):
        grid_positions((0, 0, 0), (1, 1, 1), 1e-9)  # 1e27 positions, no int64 overflow
    with pytest.raises(InputError, match="needs about"):
        directions_uniform(10**13)


@pytest.mark.parametrize("scale", [1e-60, 1e-30, 1.0, 1e17, 1e60])
def test_write_mesh_keeps_float64_or_refuses(workdir, scale):
    from viscore.cli._common import write_mesh

    box = trimesh.creation.box()
    mesh = trimesh.Trimesh(box.vertices * scale + 0.1 * scale, box.faces, process=False)
    for fmt in ("obj", "off", "ply"):  # float64 coordinates: exact at any accepted scale
        path = _fresh(workdir, fmt)
        write_mesh(path, mesh)
        back = load_mesh(path)
        np.testing.assert_array_equal(np.unique(back.vertices, axis=0),
                                      np.unique(mesh.vertices, axis=0))
    for fmt in ("stl", "glb"):  # float32 by specification: refused where it cannot hold
        path = _fresh(workdir, fmt)
        if 1e-30 <= scale <= 1e17:
            write_mesh(path, mesh)
            np.testing.assert_allclose(load_mesh(path).bounds, mesh.bounds, rtol=1e-6)
        else:
            with pytest.raises(InputError, match="float32"):
                write_mesh(path, mesh)
            assert not path.exists()


# --------------------------------------------------------------------------- generate
def test_aabb_skins_extreme_voxel_size_and_fill(tmp_path):
    from viscore.generators import generate_aabb_skins

    box = trimesh.creation.box()
    # a voxel far larger than the mesh: no inner voxel, no box, no OverflowError (was exit 3)
    occ = generate_aabb_skins(box, voxel_size=1e300)
    assert occ.info["boxes"] == 0 and occ.info["volume_share"] == 0.0
    # any fill > 0 places at least one box (1e-300 x 343 inner voxels rounded to none)
    occ = generate_aabb_skins(box, voxels=8, fill=1e-300)
    assert occ.info["boxes"] == 1 and occ.info["covered_voxels"] == occ.info["inner_voxels"]
    path = tmp_path / "x.ply"
    rc, out, err = run_cli(["generate", "aabb-skins", "fat-torus", "-o", str(path),
                            "--voxel-size", "1e300", "--quiet"])
    assert rc == 2 and "produced no triangles" in err
    assert_contract(rc, out, err, output=path)
    rc, out, err = run_cli(["generate", "aabb-skins", "fat-torus", "-o", str(path),
                            "--voxels", "8", "--fill", "1e-300", "--quiet"])
    assert rc == 0 and len(load_mesh(path).faces) == 12


# --------------------------------------------------------------------------- compare
#: Settings that make a study of one mesh take about a second.
_TINY_COMPARE = ["--views", "2", "--quads", "20", "--rays", "200", "--res", "16",
                 "--methods", "bbox,original", "--budget", "12"]


def _odd_valid_meshes(workdir: Path) -> dict[str, Path]:
    """Valid but odd meshes: cubes at 1e-12 and 1e12, a flat square, a single triangle."""
    box = trimesh.creation.box()
    shapes = {"cube-1e-12": (box.vertices * 1e-12, box.faces + 1),
              "cube-1e12": (box.vertices * 1e12, box.faces + 1),
              "square": ([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[1, 2, 3], [1, 3, 4]]),
              "triangle": ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 2, 3]])}
    paths = {}
    for name, (v, f) in shapes.items():
        paths[name] = workdir / f"{name}.obj"
        paths[name].write_text(_obj_text(v, f))
    return paths


def test_compare_odd_valid_meshes(workdir):
    # the silhouettes (of the first two meshes) reloaded each occluder with trimesh's vertex
    # merge at 1e-8: the cube's became one point, "zero extent", exit 2 after the study ran
    paths = [str(p) for p in _odd_valid_meshes(workdir).values()]
    out = workdir / "study-odd"
    _count("compare.odd-valid")
    rc, stdout, err = run_cli(["compare", *paths, *_TINY_COMPARE, "--out", str(out), "--json",
                               "--quiet"])
    assert rc == 0, err
    rows = json.loads(stdout)["rows"]
    assert sorted(r["mesh"] for r in rows) == sorted(paths * 2)
    for r in rows:  # the mesh itself: P = R = 1; its bounding box covers all of it (R = 1)
        assert r["recall"] == pytest.approx(1.0), r
        if r["method"] == "original" or "cube" in r["mesh"]:
            assert r["precision"] == pytest.approx(1.0), r
    for p in paths[:2]:
        assert (out / f"silhouettes_{Path(p).stem}.png").stat().st_size > 0


@pytest.mark.parametrize("address", ["", "nope", "tcp://127.0.0.1:1"])
def test_compare_bad_scheduler_leaves_no_folder(workdir, address):
    # a malformed address gave exit 3, an unreachable one exit 2 after 30 s; both had
    # created the study folder (the client was made inside the study)
    import dask
    import distributed  # noqa: F401 - its config defaults, before dask.config.set

    out = workdir / f"study-scheduler-{next(_names)}"
    _count("compare.scheduler")
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        rc, stdout, err = run_cli(["compare", "fat-torus", *_TINY_COMPARE, "--out", str(out),
                                   "--scheduler", address])
    assert rc == 2 and "--scheduler" in err
    assert_contract(rc, stdout, err, output=out)


# --------------------------------------------------------------------------- uncertainty
@pytest.mark.parametrize("extra", [["--quads-list", str(10**12)], ["--repeats", str(10**12)],
                                   ["--quads-list", str(2**70)], ["--res", "0"],
                                   ["--views", "-1"], ["--quads", "0"], ["--res", "100000"],
                                   ["--steps", "100"], ["--directions", "2"],
                                   ["--threshold", "0.5"], ["--protocol", "volume"]])
def test_uncertainty_ablation_refuses_before_work(workdir, extra):
    # --quads-list 1e12 raised MemoryError (exit 3), --repeats 1e12 ran unbounded, and
    # --views/--quads/--res/--steps/--directions/--threshold/--protocol were silently ignored
    out = workdir / f"ablation-{next(_names)}"
    _count("uncertainty.ablation-options")
    rc, stdout, err = run_cli(["uncertainty", "ablation", "fat-torus", "fat-torus",
                               "--factors", "quads", "--quads-list", "10", "--repeats", "2",
                               *extra, "--out", str(out)])
    assert rc == 2, err
    assert_contract(rc, stdout, err, output=out)


def test_uncertainty_ablation_uses_the_fixed_settings(monkeypatch, tmp_path):
    from viscore.cli import uncertainty_cmd

    seen = {}

    def fake(mesh, occ, **kwargs):
        seen.update(kwargs)
        raise InputError("stop")

    monkeypatch.setattr(uncertainty_cmd, "convergence_ablation", fake)
    assert run_cli(["uncertainty", "ablation", "fat-torus", "fat-torus", "--views", "4",
                    "--quads", "50", "--res", "16", "--out", str(tmp_path / "a")])[0] == 2
    assert (seen["views"], seen["quads"], seen["resolution"]) == (4, 50, 16)


# =========================================================================== every subcommand
# generate (every registered method), compare, uncertainty, bench (argument errors only) and
# data export, with the same hostile meshes and paths as above and absurd options.


def assert_refused_or_ok(rc: int, out: str, err: str, *, quiet: bool, ok=(0,),
                         output: Path | None = None, json_out: bool = False) -> None:
    """:func:`assert_contract`; without ``--quiet``, log lines may come before the error line.

    Under ``--quiet`` a failing command prints exactly its one error line. Without it, INFO
    and WARNING lines (``viscore: ...``, never a traceback or a raw Python warning) may come
    first; the error line is the last.
    """
    if rc in ok or quiet:
        assert_contract(rc, out, err, ok=ok, output=output, json_out=json_out)
        return
    lines = err.strip().splitlines()
    assert rc == 2, f"exit {rc}: {err[-2000:]}"
    assert lines and all(line.startswith("viscore: ") for line in lines), err[-2000:]
    assert lines[-1].startswith("viscore: error:") and not any(
        line.startswith(("viscore: error:", "viscore: internal")) for line in lines[:-1]), err
    assert_contract(rc, out, lines[-1], output=output)


MESH_FAMILIES = ["file", "coordinates", "shape", "path"]

#: The shapes every command refuses (the others are valid meshes, some odd).
REFUSED_SHAPES = ["degenerate", "cloud-ply", "cloud-obj", "lines"]


@st.composite
def any_hostile_mesh(draw, family: str | None = None, shapes=tuple(SHAPE_KINDS)
                     ) -> tuple[str, str | None, object]:
    """(class, extension, bytes) of a hostile file, or (class, None, kind) of a hostile path."""
    family = family or draw(st.sampled_from(MESH_FAMILIES))
    if family == "file":
        ext, kind = draw(st.sampled_from(EXTENSIONS)), draw(st.sampled_from(FILE_KINDS))
        return f"files.{kind}", ext, draw(hostile_bytes(ext, kind))
    if family == "coordinates":
        kind, text = draw(hostile_obj())
        return f"coordinates.{kind}", "obj", text.encode()
    if family == "shape":
        kind, ext, data, _ = draw(hostile_shape(draw(st.sampled_from(list(shapes)))))
        return f"shapes.{kind}", ext, data
    kind = draw(st.sampled_from(PATH_KINDS))
    return f"paths.{kind}", None, kind


def refused_mesh():
    """Hostile meshes that are refused (mostly: a file may still hold a valid mesh)."""
    return any_hostile_mesh(shapes=REFUSED_SHAPES)


def _materialize(workdir: Path, case) -> Path | None:
    """The case as a path on disk (None: not available on this system)."""
    label, ext, data = case
    if ext is None:
        path = _bad_path(workdir, data)
        return path if os.path.lexists(path) or data not in ("urandom", "proc") else None
    path = _fresh(workdir, ext)
    path.write_bytes(data)
    return path


def _loads(path: Path) -> bool:
    """Whether the library loads the mesh (else InputError; nothing else is allowed)."""
    return check_load(path) is not None


# --------------------------------------------------------------------------- generate
from viscore.generators import REGISTRY  # noqa: E402 - after the helpers it is used with

#: Options that keep every method fast on the small meshes of these tests.
_FAST_GENERATE = {"aabb-skins": ["--voxels", "8"], "qem": ["--budget", "12"]}


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("family", MESH_FAMILIES)
def test_generate_hostile_meshes(workdir, family, slow):
    @_settings(24, slow)
    @given(case=any_hostile_mesh(family), method=st.sampled_from(list(REGISTRY)),
           quiet=st.booleans())
    def prop(case, method, quiet):
        path = _materialize(workdir, case)
        assert path is not None, case  # /dev/urandom and /proc/self/status exist on Linux
        _count(f"generate.{case[0]}")
        out = _fresh(workdir, "ply")
        rc, stdout, err = run_cli(["generate", method, str(path), "-o", str(out),
                                   *_FAST_GENERATE.get(method, []), "--json"]
                                  + (["--quiet"] if quiet else []))
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out, json_out=True)
        loaded = _loads(path)
        if not loaded:
            assert rc == 2
        elif method in ("bbox", "original"):
            assert rc == 0, err  # any mesh that loads has a bounding box and is itself
        if rc == 0:  # the file holds what the JSON says (a flat mesh's bbox: some degenerate)
            doc = json.loads(stdout)
            written = trimesh.load(out, process=False, force="mesh")
            assert doc["triangles"] == len(written.faces) >= len(load_mesh(out).faces) > 0

    space = len(PATH_KINDS) * len(REGISTRY) * 2 if family == "path" else None
    run_property(prop, 24, slow, space=space)


def _generate_value_valid(method: str, option: str, value: str) -> bool:
    """Whether the registry (or the budget and seed rules) accepts a command-line value."""
    spec = REGISTRY[method]
    if option == "--seed":
        return value.isdigit()
    if option == "--budget":
        try:
            budget = int(value)
        except ValueError:
            return False
        return budget >= (spec.min_budget if spec.budgeted else 1)
    try:
        spec.option(option[2:].replace("-", "_")).parse(value)
    except InputError:
        return False
    return True


GENERATE_VALUES = ABSURD + ["none", "None", "1e300", "1e-300", "5e-324", "100000", "11",
                            "max-volume", "MAX-VOLUME", "densest "]


@st.composite
def generate_option(draw, method: str) -> tuple[str, str]:
    flags = ["--budget", "--seed", *(o.flag for o in REGISTRY[method].options)]
    return draw(st.sampled_from(flags)), draw(st.sampled_from(GENERATE_VALUES))


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("method", list(REGISTRY))
def test_generate_absurd_options(workdir, method, slow):
    @_settings(30, slow)
    @given(choice=generate_option(method), quiet=st.booleans())
    def prop(choice, quiet):
        option, value = choice
        _count(f"generate.options.{method}")
        out = _fresh(workdir, "ply")
        base = ["--voxels", "8"] if method == "aabb-skins" and option != "--voxels" else []
        if method == "planar-sections" and option != "--min-precision":
            base = ["--min-precision", "0"]  # no check views: the options are under test
        scene = "terrain" if REGISTRY[method].inputs == "height-fields" else "fat-torus"
        rc, stdout, err = run_cli(["generate", method, scene, "-o", str(out), *base,
                                   f"{option}={value}", "--json"]
                                  + (["--quiet"] if quiet else []))
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out, json_out=True)
        if not _generate_value_valid(method, option, value):
            assert rc == 2, f"{option}={value} accepted"
        elif option == "--seed":
            assert rc == 0, err  # any non-negative integer is a seed

    flags = 2 + len(REGISTRY[method].options)
    run_property(prop, 30, slow, space=flags * len(GENERATE_VALUES) * 2)


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_generate_output_paths(workdir, slow):
    far = _fresh(workdir, "obj")  # extent 1 at 1e12: float32 (STL, GLB) cannot hold it
    far.write_text(_obj_text(trimesh.creation.box().vertices + 1e12,
                             trimesh.creation.box().faces + 1))

    @_settings(20, slow)
    @given(method=st.sampled_from(list(REGISTRY)),
           kind=st.sampled_from([*OUTPUT_KINDS, "float32"]),
           fmt=st.sampled_from(["ply", "obj", "stl", "off", "glb"]), quiet=st.booleans())
    def prop(method, kind, fmt, quiet):
        _count(f"generate.outputs.{kind}")
        base = workdir / f"g{next(_names)}"
        mesh = "fat-torus"
        if kind == "missing-folder":
            out = base / "a" / f"x.{fmt}"
        elif kind == "through-file":
            base.write_text("x")
            out = base / f"x.{fmt}"
        elif kind == "read-only":
            out = Path(f"/proc/viscore-{next(_names)}.{fmt}")
        elif kind == "directory":
            out = base.with_suffix(f".{fmt}")
            out.mkdir()
        elif kind == "bad-suffix":
            out = base.with_suffix(".xyz")
        elif kind == "float32":
            out, mesh = base.with_suffix(f".{'stl' if fmt in ('stl', 'ply') else 'glb'}"), far
        else:
            out = base.with_suffix(f".{fmt}")
        rc, stdout, err = run_cli(["generate", method, str(mesh), "-o", str(out),
                                   *_FAST_GENERATE.get(method, [])]
                                  + (["--quiet"] if quiet else []))
        if kind == "ok":
            assert rc == 0, err
            assert len(load_mesh(out).faces) > 0
            return
        if kind == "float32" and method == "aabb-skins":
            assert rc in (0, 2)  # its boxes may sit on float32 values; if not, refused
        else:
            assert rc == 2, (kind, err)
        assert_refused_or_ok(rc, stdout, err, quiet=quiet,
                             output=None if kind == "directory" else out)
        if rc == 2:
            assert ".tmp" not in err
        if kind == "directory":
            assert out.is_dir() and not any(out.iterdir())

    run_property(prop, 20, slow)


# --------------------------------------------------------------------------- compare
def _no_study(out: Path) -> None:
    assert not os.path.lexists(out), f"study folder {out} created"


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_compare_hostile_meshes(workdir, slow):
    @_settings(20, slow)
    @given(case=any_hostile_mesh() if slow else refused_mesh(), first=st.booleans(),
           quiet=st.booleans())
    def prop(case, first, quiet):
        path = _materialize(workdir, case)
        assert path is not None, case  # /dev/urandom and /proc/self/status exist on Linux
        loaded = _loads(path)
        # a valid mesh runs a whole study (seconds): replaced by another case in the default
        # run (test_compare_odd_valid_meshes runs valid ones)
        assume(slow or not loaded)
        _count(f"compare.{case[0]}")
        out = workdir / f"study{next(_names)}"
        meshes = [str(path), "fat-torus"] if first else ["fat-torus", str(path)]
        rc, stdout, err = run_cli(["compare", *meshes, *_TINY_COMPARE, "--out", str(out),
                                   "--json"] + (["--quiet"] if quiet else []))
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out, json_out=True)
        if not loaded:
            assert rc == 2
            _no_study(out)

    run_property(prop, 20, slow)


_BAD_COUNTS = ["0", "-1", "nan", "inf", "1e5", "1.5", "abc", "", str(10**12), str(2**64),
               str(2**70)]
#: Method variants whose options are each valid but conflict (the generator's own rules
#: across options, checked before any folder or work).
METHOD_VARIANT_CONFLICTS = ["planar-sections:pixel-error=1",
                            "bbox,planar-sections:voxels=32:voxel-size=0.1",
                            "planar-sections:close=2:conservative=true",
                            "planar-sections:hierarchy=true:dilate=1"]
COMPARE_BAD = {
    "--views": _BAD_COUNTS, "--quads": _BAD_COUNTS, "--rays": _BAD_COUNTS,
    "--res": [*_BAD_COUNTS, "4097", "16385", "100000"],
    "--jobs": [*_BAD_COUNTS, "100000"],
    "--seed": ["-1", "-5", "nan", "1.5", "abc", "", "1e5"],
    "--budget": ["0", "-1", ",", "12;24", "abc", "1e3", "12,-4", "nan", "", "12,abc", "4,,x"],
    "--methods": ["", ",", "nope", "bbox,nope", "BBOX", "bbox;original", " , ",
                  *METHOD_VARIANT_CONFLICTS],
    "--versus": ["nope", "", "qem", "BBOX"],
    "--protocol": ["x", "", "ORBIT"],
}


@st.composite
def compare_bad_option(draw) -> list[str]:
    option = draw(st.sampled_from(sorted(COMPARE_BAD)))
    value = draw(st.sampled_from(COMPARE_BAD[option]))
    argv = list(_TINY_COMPARE)
    if option in argv:
        del argv[argv.index(option):argv.index(option) + 2]
    return [*argv, f"{option}={value}"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_compare_absurd_options(workdir, slow):
    @_settings(60, slow)
    @given(argv=compare_bad_option(), quiet=st.booleans())
    def prop(argv, quiet):
        _count("compare.options")
        out = workdir / f"study{next(_names)}"
        rc, stdout, err = run_cli(["compare", "fat-torus", *argv, "--out", str(out)]
                                  + (["--quiet"] if quiet else []))
        assert rc == 2, f"{argv[-1]}: exit {rc}"
        assert_contract(rc, stdout, err, output=out)

    run_property(prop, 60, slow, space=2 * sum(len(v) for v in COMPARE_BAD.values()))


def test_compare_budget_below_a_methods_minimum(workdir):
    out = workdir / "study-budget"
    for budget in ("11", "4", "12,11"):
        _count("compare.options")
        rc, stdout, err = run_cli(["compare", "fat-torus", *_TINY_COMPARE, "--methods",
                                   "aabb-skins", "--budget", budget, "--out", str(out)])
        assert rc == 2 and "at least 12" in err
        assert_contract(rc, stdout, err, output=out)


OUT_KINDS = ["missing-parent", "through-file", "existing-file", "read-only", "dangling", "fifo"]


def _bad_out(workdir: Path, kind: str) -> tuple[Path, bytes | None]:
    """A hostile output folder and, for a file already there, its content (kept unchanged)."""
    base = workdir / f"out{next(_names)}"
    if kind == "missing-parent":
        return base / "a" / "b", None
    if kind == "through-file":
        base.write_text("x")
        return base / "study", None
    if kind == "existing-file":
        base.write_bytes(b"keep")
        return base, b"keep"
    if kind == "read-only":
        return Path(f"/proc/viscore-{next(_names)}"), None
    if kind == "dangling":
        base.symlink_to(workdir / "gone")
        return base, None
    os.mkfifo(base)
    return base, None


@pytest.mark.parametrize("kind", OUT_KINDS)
@pytest.mark.parametrize("command", ["compare", "uncertainty"])
def test_hostile_output_folders(workdir, command, kind):
    out, kept = _bad_out(workdir, kind)
    _count(f"{command}.outputs.{kind}")
    before = os.path.lexists(out)
    argv = (["compare", "fat-torus", *_TINY_COMPARE] if command == "compare" else
            ["uncertainty", "fat-torus", "fat-torus", *_TINY_UNCERTAINTY])
    rc, stdout, err = run_cli([*argv, "--out", str(out), "--quiet"])
    assert rc == 2, err
    assert_contract(rc, stdout, err, output=None if before else out)
    if kept is not None:
        assert out.read_bytes() == kept
    if kind in ("dangling", "fifo"):
        assert not out.is_dir() and os.path.lexists(out)
    if kind == "missing-parent":
        assert not out.parent.exists()


# --------------------------------------------------------------------------- uncertainty
#: Settings that make an uncertainty report take about a second.
_TINY_UNCERTAINTY = ["--views", "4", "--quads", "50", "--res", "16", "--directions", "2",
                     "--steps", "100"]
#: And an ablation a few seconds.
_TINY_ABLATION = ["--views", "4", "--quads", "50", "--res", "16", "--repeats", "2",
                  "--quads-list", "10,20", "--views-list", "2,4", "--spacings", "0.5"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_uncertainty_hostile_meshes(workdir, slow):
    @_settings(20, slow)
    @given(case=any_hostile_mesh() if slow else refused_mesh(),
           slot=st.sampled_from(["mesh", "occluder", "versus"]), quiet=st.booleans())
    def prop(case, slot, quiet):
        path = _materialize(workdir, case)
        assert path is not None, case  # /dev/urandom and /proc/self/status exist on Linux
        loaded = _loads(path)
        # a valid mesh runs the report (a second): replaced by another case in the default
        # run (test_uncertainty_odd_valid_meshes runs valid ones)
        assume(slow or not loaded)
        _count(f"uncertainty.{case[0]}")
        items = {"mesh": [str(path), "fat-torus"], "occluder": ["fat-torus", str(path)],
                 "versus": ["fat-torus", "fat-torus", "--versus", str(path)]}[slot]
        out = workdir / f"unc{next(_names)}"
        rc, stdout, err = run_cli(["uncertainty", *items, *_TINY_UNCERTAINTY, "--out", str(out),
                                   "--json"] + (["--quiet"] if quiet else []))
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out, json_out=True)
        if not loaded:
            assert rc == 2

    run_property(prop, 20, slow)


def test_uncertainty_odd_valid_meshes(workdir):
    paths = _odd_valid_meshes(workdir)
    for mesh, occ, versus in [("square", "triangle", "cube-1e12"), ("cube-1e-12", "square", None)]:
        _count("uncertainty.odd-valid")
        out = workdir / f"unc-odd-{next(_names)}"
        extra = [] if versus is None else ["--versus", str(paths[versus])]
        rc, stdout, err = run_cli(["uncertainty", str(paths[mesh]), str(paths[occ]), *extra,
                                   *_TINY_UNCERTAINTY, "--out", str(out), "--json", "--quiet"])
        # valid meshes: a report, or one line (e.g. too few views inform a rate)
        assert_contract(rc, stdout, err, output=out, json_out=True)
        if rc == 0:
            assert sorted(os.listdir(out)) == ["per_view.png", "uncertainty.json"]


UNCERTAINTY_BAD = {
    "--views": _BAD_COUNTS, "--quads": _BAD_COUNTS, "--directions": _BAD_COUNTS,
    "--steps": _BAD_COUNTS, "--res": [*_BAD_COUNTS, "8193", "100000"],
    "--threshold": ["-1", "nan", "inf", "1.5", "abc", "", "2", "1e5"],
    "--seed": ["-1", "-5", "nan", "1.5", "abc", "", "1e5"],
    "--protocol": ["x", "", "orbti"],
}
ABLATION_BAD = {
    "--repeats": ["0", "1", "-1", "nan", "abc", "", "1.5", str(10**12)],
    "--factors": ["", ",", "pixels", "quads,x", "QUADS"],
    "--quads-list": ["", ",", "0", "-1", "1;2", "abc", "nan", "1.5", "10,0", str(10**12),
                     str(2**70)],
    "--views-list": ["", ",", "0", "-1", "1;2", "abc", "nan", "1.5", "10,0", str(2**70)],
    "--spacings": ["0", "-1", "2", "nan", "inf", "abc", "", ",", "0.1;0.2", "1e5"],
    "--views": ["0", "-1", "nan", "abc"], "--quads": ["0", "-1", "1.5"],
    "--res": ["0", "8193", "100000"],
    "--steps": ["100"], "--directions": ["2"], "--threshold": ["0.5"], "--protocol": ["orbit"],
    "--versus": ["fat-torus"],
}


@st.composite
def uncertainty_bad_option(draw) -> list[str]:
    ablation = draw(st.booleans())
    table = ABLATION_BAD if ablation else UNCERTAINTY_BAD
    option = draw(st.sampled_from(sorted(table)))
    value = draw(st.sampled_from(table[option]))
    argv = list(_TINY_ABLATION if ablation else _TINY_UNCERTAINTY)
    if option in argv:
        del argv[argv.index(option):argv.index(option) + 2]
    return [*(["ablation"] if ablation else []), "fat-torus", "fat-torus", *argv,
            f"{option}={value}"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_uncertainty_absurd_options(workdir, slow):
    @_settings(60, slow)
    @given(argv=uncertainty_bad_option(), quiet=st.booleans())
    def prop(argv, quiet):
        _count("uncertainty.options")
        out = workdir / f"unc{next(_names)}"
        rc, stdout, err = run_cli(["uncertainty", *argv, "--out", str(out), "--json"]
                                  + (["--quiet"] if quiet else []))
        assert rc == 2, f"{argv[0]} {argv[-1]}: exit {rc}"
        assert_contract(rc, stdout, err, output=out)

    space = 2 * sum(len(v) for table in (ABLATION_BAD, UNCERTAINTY_BAD) for v in table.values())
    run_property(prop, 60, slow, space=space)


def test_uncertainty_item_counts(workdir):
    for items in (["ablation"], ["ablation", "fat-torus"], ["fat-torus"],
                  ["fat-torus", "fat-torus", "fat-torus"], ["ablation", "a", "b", "c"]):
        _count("uncertainty.usage")
        out = workdir / f"unc{next(_names)}"
        rc, stdout, err = run_cli(["uncertainty", *items, "--out", str(out)])
        assert rc == 2
        assert_contract(rc, stdout, err, output=out)


# --------------------------------------------------------------------------- bench
#: Cheap settings: even a case wrongly accepted runs in well under a second.
_BENCH_BASE = {"rays": ["--rays", "10", "--repeats", "1"],
               "voxels": ["--res", "4", "--repeats", "1"],
               "evaluate": ["--views", "2", "--quads", "20", "--res", "16", "--rays", "100"]}
BENCH_BAD = {
    "rays": {"--rays": _BAD_COUNTS, "--repeats": _BAD_COUNTS[:8],
             "--seed": ["-1", "nan", "abc", ""]},
    "voxels": {"--res": [*_BAD_COUNTS, ",", "8;16", "64,0", "100000", "8,100000"],
               "--repeats": _BAD_COUNTS[:8]},
    "evaluate": {"--views": _BAD_COUNTS, "--quads": _BAD_COUNTS, "--rays": _BAD_COUNTS,
                 "--res": [*_BAD_COUNTS, "4097", "100000"], "--budget": _BAD_COUNTS[:8],
                 "--seed": ["-1", "nan", "abc", ""]},
}


@st.composite
def bench_bad_argv(draw, box: str) -> list[str]:
    target = draw(st.sampled_from(["rays", "voxels", "evaluate", "generate", "usage"]))
    if target == "generate":
        return ["bench", "generate", *draw(st.sampled_from([
            ["aabb-skins", "--models", "/nonexistent/models"], ["aabb-skins", "--models", box],
            ["qem"], [""], ["AABB-SKINS"], []]))]
    if target == "usage":
        return ["bench", *draw(st.sampled_from([[], ["nope"], ["rays", "extra"],
                                                ["rays", "--views", "2"]]))]
    option = draw(st.sampled_from(sorted(BENCH_BAD[target])))
    argv = list(_BENCH_BASE[target])
    if option in argv:
        del argv[argv.index(option):argv.index(option) + 2]
    value = draw(st.sampled_from(BENCH_BAD[target][option]))
    return ["bench", target, "--mesh", box, *argv, f"{option}={value}"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_bench_argument_errors(workdir, slow):
    box = _fresh(workdir, "obj")
    box.write_text(_obj_text(trimesh.creation.box().vertices, trimesh.creation.box().faces + 1))

    @_settings(45, slow)
    @given(argv=bench_bad_argv(str(box)), quiet=st.booleans())
    def prop(argv, quiet):
        _count("bench.options")
        rc, stdout, err = run_cli([*argv, "--json"] + (["--quiet"] if quiet else []))
        assert rc == 2, f"{argv}: exit {rc}"
        assert_contract(rc, stdout, err)

    space = 2 * (6 + 4 + sum(len(v) for t in BENCH_BAD.values() for v in t.values()))
    run_property(prop, 45, slow, space=space)


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_bench_hostile_meshes(workdir, slow):
    @_settings(15, slow)
    @given(case=refused_mesh(), target=st.sampled_from(["rays", "voxels", "evaluate"]),
           quiet=st.booleans())
    def prop(case, target, quiet):
        path = _materialize(workdir, case)
        assert path is not None, case  # /dev/urandom and /proc/self/status exist on Linux
        # a mesh that loads would run the benchmark: replaced by another case (argument
        # errors only here)
        assume(not _loads(path))
        _count(f"bench.{case[0]}")
        rc, stdout, err = run_cli(["bench", target, "--mesh", str(path), *_BENCH_BASE[target]]
                                  + (["--quiet"] if quiet else []))
        assert rc == 2
        assert_contract(rc, stdout, err)

    run_property(prop, 15, slow)


# --------------------------------------------------------------------------- data export
DATA_NAMES = ["nope", "", " ", "BUNNY", "bunny ", " bunny", "../bunny", "fat-torus/x",
              "fat-torus.ply", "a" * 300, "fat-torus;ls", "-", "list"]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_data_export_bad_names(workdir, slow):
    box = _fresh(workdir, "obj")  # a mesh file is not a built-in scene either
    box.write_text(_obj_text(trimesh.creation.box().vertices, trimesh.creation.box().faces + 1))

    @_settings(20, slow)
    @given(name=st.sampled_from([*DATA_NAMES, str(box)]) | st.text(max_size=30),
           fmt=st.sampled_from(["ply", "obj", "stl", "off", "glb"]), quiet=st.booleans())
    def prop(name, fmt, quiet):
        from viscore import scene_names

        # a real scene, or NUL (which cannot come from a shell): replaced by another case
        assume(name not in scene_names() and "\x00" not in name)
        _count("data-export.names")
        out = _fresh(workdir, fmt)
        rc, stdout, err = run_cli(["data", "export", "-o", str(out)]
                                  + (["--quiet"] if quiet else []) + ["--", name])
        assert rc == 2, f"{name!r}: exit {rc}"
        assert_contract(rc, stdout, err, output=out)

    run_property(prop, 20, slow)


@pytest.mark.parametrize("scale", [2.0**-280, 2.0**-100, 2.0**130, 2.0**290])
def test_godot_bake_beyond_float32(scale):
    # float32 positions overflowed to inf above 3.4e38 (and underflowed below 1e-38):
    # RuntimeWarnings on stderr and a bake of infinities; a power-of-two scale is exact
    import warnings

    from viscore.generators.baselines.godot import bake_surface

    sphere = trimesh.creation.icosphere(subdivisions=3)
    v0, f0, e0 = bake_surface(sphere.vertices, sphere.faces, 0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        v1, f1, e1 = bake_surface(sphere.vertices * scale, sphere.faces, 0.05 * scale)
        assert len(bake_surface(sphere.vertices, sphere.faces, 1e300)[1]) <= len(f0)
    np.testing.assert_array_equal(f1, f0)
    np.testing.assert_array_equal(v1, v0 * scale)
    assert e1 == pytest.approx(e0 * scale, rel=1e-6) and len(f0) < len(sphere.faces)


# --------------------------------------------------------------------------- cull
#: Cheap settings: a case wrongly accepted still runs in about a second.
_CULL_CHEAP = ["--frames", "1", "--width", "16", "--height", "9", "--methods", "bbox",
               "--frusta-method", "bbox"]


def _street_glb(workdir: Path) -> Path:
    """A GLB of a wall, a box behind it and a tree mesh instanced twice (a valid scene)."""
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(bounds=[[-5, 0, -0.5], [5, 6, 0.5]]),
                       geom_name="wall", node_name="wall")
    scene.add_geometry(trimesh.creation.box(bounds=[[-0.5, 0, 4.5], [0.5, 1, 5.5]]),
                       geom_name="box", node_name="box")
    tree = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    for i, x in enumerate((8.0, 10.0)):
        scene.add_geometry(tree, geom_name="tree", node_name=f"tree_{i}",
                           transform=trimesh.transformations.translation_matrix((x, 0.5, 5)))
    path = _fresh(workdir, "glb")
    path.write_bytes(scene.export(file_type="glb"))
    return path


def _gltf_with(workdir: Path, edit) -> Path:
    """The street scene as a self-contained .gltf, its JSON edited by ``edit(doc)``."""
    files = trimesh.load_scene(_street_glb(workdir)).export(file_type="gltf",
                                                             embed_buffers=True)
    doc = json.loads(files["model.gltf"])
    edit(doc)
    path = _fresh(workdir, "gltf")
    path.write_text(json.dumps(doc))
    return path


def _mesh_nodes(doc: dict) -> list[dict]:
    return [n for n in doc["nodes"] if "mesh" in n]


def _set_node(key: str, value) -> callable:
    def edit(doc):
        node = _mesh_nodes(doc)[0]
        node.pop("matrix", None)
        node[key] = value
    return edit


#: Scenes made for ``cull``: (class, maker) -> path; the refused ones give exit 2.
CULL_SCENES = {
    "nan-translation": lambda w: _gltf_with(w, _set_node("translation", [float("nan"), 0, 0])),
    "inf-scale": lambda w: _gltf_with(w, _set_node("scale", [float("inf"), 1, 1])),
    "zero-scale": lambda w: _gltf_with(w, _set_node("scale", [0, 0, 0])),
    "1e300-scale": lambda w: _gltf_with(w, _set_node("scale", [1e300, 1e300, 1e300])),
    "nan-matrix": lambda w: _gltf_with(w, _set_node("matrix", [float("nan")] * 16)),
    "no-mesh-nodes": lambda w: _gltf_with(w, lambda d: [n.pop("mesh") for n in _mesh_nodes(d)]),
    "json-list": lambda w: (p := _fresh(w, "gltf"), p.write_text("[]"))[0],
    "zero-meshes-glb": lambda w: (p := _fresh(w, "glb"), p.write_bytes(
        b"glTF\x02\x00\x00\x00\x3c\x00\x00\x00\x28\x00\x00\x00JSON"
        b'{"asset":{"version":"2.0"},"nodes":[{}]}'))[0],
}


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_cull_hostile_scenes(workdir, slow):
    # every hostile mesh file and path class above as the SCENE of cull (a file that
    # loads as a mesh is one object, refused for want of an occluder object, or runs)
    @_settings(25, slow)
    @given(case=any_hostile_mesh(), quiet=st.booleans())
    def prop(case, quiet):
        path = _materialize(workdir, case)
        assert path is not None, case  # /dev/urandom and /proc/self/status exist on Linux
        _count(f"cull.{case[0]}")
        out = workdir / f"cull{next(_names)}"
        rc, stdout, err = run_cli(["cull", str(path), *_CULL_CHEAP, "--out", str(out),
                                   "--json"] + (["--quiet"] if quiet else []))
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out, json_out=True)

    run_property(prop, 25, slow)


@pytest.mark.parametrize("kind", sorted(CULL_SCENES))
def test_cull_hostile_gltf_scenes(workdir, kind):
    _count(f"cull.scenes.{kind}")
    out = workdir / f"cull{next(_names)}"
    rc, stdout, err = run_cli(["cull", str(CULL_SCENES[kind](workdir)), *_CULL_CHEAP,
                               "--out", str(out)])
    assert rc == 2, err
    assert_contract(rc, stdout, err, output=out)


_CAMERA = {"position": [0, 1.5, -10], "forward": [0, 0, 1]}
CULL_BAD_PATHS = [
    "", "not json", "{}", "[]", "3", '"cams"', "[null]", "[[0, 1, 0]]", "[" * 50_000,
    "[" * 100_000 + "]" * 100_000,
    *(json.dumps([{**_CAMERA, **change}]) for change in [
        {"position": [float("nan"), 0, 0]}, {"forward": [float("inf"), 0, 0]},
        {"forward": [0, 0, 0]}, {"forward": [0, 1, 0]}, {"forward": [0, 1, 0], "up": [0, 3, 0]},
        {"up": [0, 0, 0]}, {"fov": 0}, {"fov": -5}, {"fov": 180}, {"fov": 1e9},
        {"fov": float("nan")}, {"fov": "90"}, {"fov": True}, {"position": [0, 1]},
        {"position": [0, 1, 2, 3]}, {"position": [[0, 1, 2]]}, {"position": "0,1,2"},
        {"position": [True, False, True]}, {"position": None}, {"position": [1e300, 0, 0]},
        {"forward": [1e-320, 0, 0]}, {"zoom": 2}]),
    json.dumps([{"forward": [0, 0, 1]}]), json.dumps([{"position": [0, 1, 0]}]),
    '[{"position": [1' + "0" * 400 + ', 0, 0], "forward": [0, 0, 1]}]',
]


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_cull_hostile_camera_paths(workdir, slow):
    scene = _street_glb(workdir)

    @_settings(25, slow)
    @given(text=st.sampled_from(CULL_BAD_PATHS) | st.text(max_size=200),
           kind=st.sampled_from(["file", "directory", "fifo", "missing"]), quiet=st.booleans())
    def prop(text, kind, quiet):
        _count(f"cull.path.{kind}")
        path = workdir / f"cams{next(_names)}.json"
        if kind == "file":
            path.write_text(text, errors="surrogatepass")
        elif kind == "directory":
            path.mkdir()
        elif kind == "fifo":
            os.mkfifo(path)
        out = workdir / f"cull{next(_names)}"
        rc, stdout, err = run_cli(["cull", str(scene), "--path", str(path), "--occluders",
                                   "wall", *_CULL_CHEAP, "--out", str(out)]
                                  + (["--quiet"] if quiet else []))
        assert rc == 2, f"{text[:80]!r}: exit {rc}"
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out)

    run_property(prop, 25, slow)


CULL_BAD_OPTIONS = {
    "--frames": ["0", "-1", "100001", str(10**12), "nan", "1e3", "abc", ""],
    "--width": ["0", "-5", "8193", "100000", "nan", ""],
    "--height": ["0", "-5", "8193", str(2**70), "1.5"],
    "--buffer-scale": ["0", "-1", "10", "nan"],
    "--active": ["0", "-1", "nan", "abc"],
    "--size-threshold": ["0", "-1", "nan", "inf", "1e308", "abc"],
    "--methods": ["nope", ",", "bbox,,nope", "BBOX", "", *METHOD_VARIANT_CONFLICTS],
    "--frusta-method": ["nope", "bbox,qem", ",", "planar-sections:close=1:conservative=yes"],
    "--occluders": ["nope", ",", "wall,nope", ""],
    "--seed": ["-1", "nan", "1e3", "abc"],
    "--cap": ["eq3", ""],
    "--rank": ["eq5", ""],
}


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_cull_absurd_options(workdir, slow):
    scene = _street_glb(workdir)

    @_settings(40, slow)
    @given(option=st.sampled_from(sorted(CULL_BAD_OPTIONS)), data=st.data(),
           quiet=st.booleans())
    def prop(option, data, quiet):
        value = data.draw(st.sampled_from(CULL_BAD_OPTIONS[option]))
        _count("cull.options")
        out = workdir / f"cull{next(_names)}"
        argv = ["cull", str(scene), *_CULL_CHEAP, "--out", str(out)]
        if option in argv:
            del argv[argv.index(option):argv.index(option) + 2]
        if option not in ("--occluders", "--size-threshold"):  # the threshold is unused then
            argv += ["--occluders", "wall"]
        rc, stdout, err = run_cli([*argv, f"{option}={value}", "--json"]
                                  + (["--quiet"] if quiet else []))
        assert rc == 2, f"{option}={value}: exit {rc}"
        assert_refused_or_ok(rc, stdout, err, quiet=quiet, output=out)

    run_property(prop, 40, slow, space=2 * sum(len(v) for v in CULL_BAD_OPTIONS.values()))


@pytest.mark.parametrize("kind", OUT_KINDS)
def test_cull_hostile_output_folders(workdir, kind):
    out, kept = _bad_out(workdir, kind)
    _count(f"cull.outputs.{kind}")
    before = os.path.lexists(out)
    rc, stdout, err = run_cli(["cull", str(_street_glb(workdir)), *_CULL_CHEAP, "--occluders",
                               "wall", "--out", str(out), "--quiet"])
    assert rc == 2, err
    assert_contract(rc, stdout, err, output=None if before else out)
    if kept is not None:
        assert out.read_bytes() == kept


def test_cull_valid_odd_scenes(workdir):
    # one object, flat objects, degenerate faces beside good ones, 1e12 and 1e-9 scenes,
    # many instances: each runs (exit 0, its three files) or is refused in one line
    box = trimesh.creation.box()
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], [[0, 1, 2], [0, 2, 3]])
    degenerate = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]],
                                 [[0, 1, 2], [0, 0, 3], [0, 1, 3]], process=False)
    scenes = {"one": [box], "flat": [flat, flat, flat], "degenerate": [degenerate, box],
              "huge": [box.copy().apply_scale(1e12)] * 2,
              "tiny": [box.copy().apply_scale(1e-9)] * 2, "instances": [box] * 30}
    for name, meshes in scenes.items():
        _count("cull.odd")
        scene = trimesh.Scene()
        size = float(np.ptp(meshes[0].bounds[:, 0])) or 1.0
        for k, mesh in enumerate(meshes):
            scene.add_geometry(mesh, geom_name=f"g{k % 2}", node_name=f"{name}{k}",
                               transform=trimesh.transformations.translation_matrix(
                                   (3 * k * size, 0, 0)))
        path = _fresh(workdir, "glb")
        path.write_bytes(scene.export(file_type="glb"))
        out = workdir / f"cull{next(_names)}"
        rc, stdout, err = run_cli(["cull", str(path), "--frames", "3", "--width", "32",
                                   "--height", "18", "--methods", "bbox", "--frusta-method",
                                   "bbox", "--occluders", f"{name}0", "--out", str(out),
                                   "--json", "--quiet"])
        assert_contract(rc, stdout, err, output=out, json_out=True)
        if rc == 0:
            assert sorted(p.name for p in out.iterdir()) == [
                "cameras.json", "cull.json", "report.html", "triangles.png"]


def test_a_mistyped_builtin_name_gets_a_suggestion(tmp_path):
    """The data folder's file names use underscores; the scenes' names hyphens."""
    from viscore import load_mesh

    with pytest.raises(InputError, match="did you mean 'building-church'"):
        load_mesh(str(tmp_path / "building_church.ply"))
    with pytest.raises(InputError, match="did you mean 'fat-torus'"):
        load_mesh("fat_torus")
    with pytest.raises(InputError) as err:
        load_mesh("nothing-like-it")
    assert "did you mean" not in str(err.value)
