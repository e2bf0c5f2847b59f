"""Occluders for a whole game level: its objects, one occluder per mesh and method, engine files.

Objects as glTF 2.0 [1]_ (sec. 3) places them; files as the Godot 4 engine [2]_
reads them.

References
----------
.. [1] The Khronos 3D Formats Working Group. "glTF 2.0 Specification",
   version 2.0.1. The Khronos Group, 2021.
   https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html
.. [2] Godot Engine documentation, class references "OccluderInstance3D" and
   "ArrayOccluder3D", and "Node type customization using name suffixes",
   https://docs.godotengine.org/en/stable/ (Godot 4).
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import os
import re
import shutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import trimesh

import viscore
from viscore import InputError, OccluderInstance, cpu_cores, occonly_glb_bytes, tscn_text
from viscore._atomic import FileSet, write_atomic
from viscore._jobs import run_jobs
from viscore._validate import as_positive_int, as_seed
from viscore.exchange.file_access import PARSE_BYTES_PER_FILE_BYTE, read_regular
from viscore.exchange.mesh_io import ply_bytes
from viscore.level.objects import FLAT_RATIO, LevelObjects
from viscore.level.scene_graph import geometry_digest

from .._held_logs import call_held, report_parts
from ..registry import REGISTRY, generate, parse_method
from .runtimes import _guaranteed

__all__ = ["MeshOccluder", "LevelOccluders", "occluder_of_mesh", "occlude_level", "MANIFEST_NAME",
           "JOB_DIR", "default_methods", "check_occlude_folder"]

_log = logging.getLogger(__name__)


#: Files of an output folder.
MANIFEST_NAME, JOB_DIR = "occlude.json", "occluders"
#: Peak bytes of memory per byte of a JSON record while it is parsed.
_JSON_BYTES_PER_BYTE = 20
#: Longest file stem made from an object, mesh or method name.
_STEM_CHARS = 80
#: A job's work, for the time estimate: its mesh's triangles plus this many. Per-job
#: seconds of surface-patches and aabb-skins grow about linearly with the triangles,
#: with a fixed part worth about this many. Replaying the jobs' seconds of six levels
#: (the city, cs-dust, quake-e1m1, kyan-deathmatch, sauer-zdm2, tesseract-complex),
#: elapsed x work left / work done stays within 0.46-1.93 of the time the run took
#: once its first job is done; counting jobs was up to 87x too long (the biggest
#: meshes run first).
JOB_WORK_TRIANGLES = 100


# --------------------------------------------------------------------------- the jobs
@dataclass(frozen=True, eq=False)
class MeshOccluder:
    """One (mesh, method) job's result: a local-space occluder, or why there is none.

    Attributes
    ----------
    mesh : str
        Mesh name (the level's distinct geometry).
    method : str
        Canonical method label (:func:`viscore.generators.parse_method`).
    vertices : (v, 3) float64
        Occluder vertices in the mesh's local frame, world units; ``(0, 3)``
        when refused.
    faces : (t, 3) int64
        Triangles; ``(0, 3)`` when refused.
    triangles : int
        ``len(faces)``.
    conservative_guaranteed : bool
        Whether the occluder carries its method's guarantee (the generator's
        word, or the registry's flag and a closed occluder).
    seconds : float
        Wall time of the generation.
    refused : str or None
        Why no occluder was made: the generator's :class:`InputError`, or an
        empty occluder. None when made.
    key : str
        Hash of the mesh, method, budget, seed and viscore version.
    logs : tuple of (int, str, str)
        The level, logger name and text of each record the generation logged,
        held back for the run to say once per distinct text
        (:func:`viscore.generators._held_logs.report_parts`); empty for a job
        read back from a folder.
    """

    mesh: str
    method: str
    vertices: np.ndarray
    faces: np.ndarray
    triangles: int
    conservative_guaranteed: bool
    seconds: float
    refused: str | None
    key: str
    logs: tuple = ()

    def record(self) -> dict:
        """The JSON record of the job (everything but the geometry)."""
        return {"key": self.key, "mesh": self.mesh, "method": self.method,
                "triangles": self.triangles,
                "conservative_guaranteed": self.conservative_guaranteed,
                "seconds": self.seconds, "refused": self.refused}


def _job_key(vertices: np.ndarray, faces: np.ndarray, method: str, budget: int | None,
             seed: int) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(vertices, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(faces, dtype="<i8").tobytes())
    h.update(json.dumps([method, budget, seed, viscore.__version__]).encode())
    return h.hexdigest()


def occluder_of_mesh(mesh: trimesh.Trimesh, method: str, *, name: str = "mesh",
                     budget: int | None = None, seed: int = 0) -> MeshOccluder:
    """One job: the occluder of one distinct mesh by one method, in the mesh's frame.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The geometry, local frame.
    method : str
        A registered method or variant (``planar-sections:chain=greedy``).
    name : str, optional
        The mesh's name, kept in the result (default ``'mesh'``).
    budget : int, optional
        Triangle budget (default: the method's own).
    seed : int, optional
        Passed to the generator (default 0).

    Returns
    -------
    MeshOccluder
        ``refused`` says why when the generator raised :class:`InputError` on
        this mesh or made an occluder without triangles.

    Raises
    ------
    InputError
        An unknown method, or a budget or option the method refuses
        (checked before the generator runs).

    Examples
    --------
    >>> import trimesh
    >>> job = occluder_of_mesh(trimesh.creation.box(), "bbox")
    >>> job.triangles, job.refused
    (12, None)
    """
    variant = parse_method(method, "method")
    seed = as_seed(seed)
    variant.spec.check_params({"budget": budget, "seed": seed})
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    key = _job_key(vertices, faces, variant.label, budget, seed)
    start = time.perf_counter()
    empty_v, empty_f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    try:
        occ = generate(variant.label, mesh, budget=budget, seed=seed)
    except InputError as exc:
        seconds = time.perf_counter() - start
        return MeshOccluder(name, variant.label, empty_v, empty_f, 0, False, seconds,
                            f"no occluder possible with {variant.label}: "
                            f"{' '.join(str(exc).split())}", key)
    seconds = time.perf_counter() - start
    if occ.triangles == 0:
        return MeshOccluder(name, variant.label, empty_v, empty_f, 0, False, seconds,
                            f"no occluder possible with {variant.label}: it made an empty "
                            "occluder", key)
    return MeshOccluder(name, variant.label, np.asarray(occ.mesh.vertices, dtype=np.float64),
                        np.asarray(occ.mesh.faces, dtype=np.int64), int(occ.triangles),
                        bool(_guaranteed(occ, variant.label)), seconds, None, key)


def _run_job(vertices: np.ndarray, faces: np.ndarray, name: str, method: str,
             budget: int | None, seed: int) -> MeshOccluder:
    """A job as a process pool or a dask worker runs it (arrays in, no trimesh pickled);
    what the generator logs comes back in the result (``logs``), said once by the run."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.metadata["name"] = name  # the generators' messages name it as the run does
    job, records = call_held(occluder_of_mesh, mesh, method, name=name, budget=budget,
                             seed=seed)
    return replace(job, logs=tuple((r.levelno, r.name, r.getMessage()) for r in records))


def _say_logs(jobs: Sequence[MeshOccluder], meshes: Sequence[str], labels: Sequence[str]
              ) -> None:
    """The jobs' held records, each distinct text once per method with how many of the
    level's ``meshes`` gave it (``aabb-skins: 42 of 96 meshes: ...``)."""
    index = {name: k for k, name in enumerate(meshes)}
    for label in labels:
        held = [(index[job.mesh], logging.makeLogRecord(
                    {"name": name, "levelno": level, "levelname": logging.getLevelName(level),
                     "msg": text}))
                for job in jobs if job.method == label for level, name, text in job.logs]
        if held:
            report_parts(held, len(meshes), what="meshes", label=label, one="mesh",
                         names=dict(enumerate(meshes)))


def _stem(name: str) -> str:
    """A file stem for an object, mesh or method name (unsafe characters to ``_``)."""
    safe = re.sub(r"[^A-Za-z0-9._=+-]", "_", name)[:_STEM_CHARS].lstrip(".") or "_"
    if safe != name:
        safe += "-" + hashlib.sha256(name.encode()).hexdigest()[:8]
    return safe


def _job_paths(out: Path, method: str, mesh: str) -> tuple[Path, Path]:
    folder = out / JOB_DIR / _stem(method)
    return folder / f"{_stem(mesh)}.ply", folder / f"{_stem(mesh)}.json"


def _stored(out: Path, method: str, mesh: str, key: str) -> MeshOccluder | None:
    """The finished job kept in the folder, or None (missing, damaged or stale)."""
    ply, rec = _job_paths(out, method, mesh)
    try:  # regular files only (a FIFO in their place is recomputed, never read)
        record = json.loads(read_regular(rec, str(rec), bytes_per_byte=_JSON_BYTES_PER_BYTE))
        if not isinstance(record, dict) or record.get("key") != key:
            return None
        if record["refused"] is not None:
            v, f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
        else:
            data = read_regular(ply, str(ply), bytes_per_byte=PARSE_BYTES_PER_FILE_BYTE)
            back = trimesh.load(io.BytesIO(data), file_type="ply", process=False)
            v = np.asarray(back.vertices, dtype=np.float64)  # type: ignore[attr-defined]
            f = np.asarray(back.faces, dtype=np.int64).reshape(-1, 3)  # type: ignore[attr-defined]
            if len(f) != record["triangles"]:
                return None
        return MeshOccluder(mesh, method, v, f, int(record["triangles"]),
                            bool(record["conservative_guaranteed"]), float(record["seconds"]),
                            record["refused"], key)
    except (OSError, ValueError, KeyError, TypeError, IndexError):  # InputError included
        return None


def _keep(out: Path, job: MeshOccluder) -> None:
    """Write a finished job: the occluder, then its record (which marks it done); both
    or neither (a record that cannot be written takes its occluder with it)."""
    ply, rec = _job_paths(out, job.method, job.mesh)
    if job.refused is None:
        write_atomic(ply, ply_bytes(trimesh.Trimesh(job.vertices, job.faces, process=False)),
                     parents=True)
    try:
        write_atomic(rec, json.dumps(job.record(), indent=1).encode(), parents=True)
    except BaseException:
        if job.refused is None:
            ply.unlink(missing_ok=True)
        raise


def check_occlude_folder(out: str | os.PathLike) -> None:
    """Refuse an output folder whose ``occluders/`` (or a method folder in it) is a
    symbolic link: ``occlude`` writes only inside its folder, as a study does.

    Raises
    ------
    InputError
        One line naming the link and its target.
    """
    out = Path(out)
    jobs = out / JOB_DIR
    links = [jobs] if jobs.is_symlink() else (
        [p for p in jobs.iterdir() if p.is_symlink()] if jobs.is_dir() else [])
    if links:
        raise InputError(f"{out}: {links[0]} is a symbolic link (to "
                         f"{os.readlink(links[0])!r}); occlude writes only inside its folder "
                         "(replace the link by a folder or choose another -o)")
    if os.path.lexists(jobs) and not jobs.is_dir():
        raise InputError(f"{out}: {jobs} is not a folder")


# --------------------------------------------------------------------------- the level run
@dataclass(frozen=True)
class LevelOccluders:
    """What :func:`occlude_level` made: the manifest and the files.

    Attributes
    ----------
    manifest : dict
        The document written to ``DIR/occlude.json`` (see :func:`occlude_level`).
    files : tuple of str
        The files written, relative to ``DIR``, ``occlude.json`` last.
    reused : int
        Jobs found finished in the folder (a resumed run).
    computed : int
        Jobs run now.
    """

    manifest: dict
    files: tuple
    reused: int
    computed: int


def _check_methods(methods: Sequence[str] | None, budget: int | None) -> list[str]:
    labels = list(dict.fromkeys(parse_method(m, "methods").label
                                for m in (default_methods() if methods is None else methods)))
    if not labels:
        raise InputError("methods: expected at least one method")
    if budget is not None:
        budget = as_positive_int(budget, "budget")
        for label in labels:
            parse_method(label).spec.check_params({"budget": budget})
    return labels


def occlude_level(level: LevelObjects, out_dir: str | os.PathLike, *,
                  methods: Sequence[str] | None = None, budget: int | None = None,
                  seed: int = 0, jobs: int = 1, scheduler=None,
                  progress: Callable[..., None] | None = None) -> LevelOccluders:
    """Occluders of a level's chosen objects by each method, written as engine files.

    Parameters
    ----------
    level : LevelObjects
        From :func:`level_objects`.
    out_dir : path
        The output folder; must exist. The caller holds it alone (two runs
        writing one folder at once would mix their jobs).
    methods : sequence of str, optional
        Registered methods or variants; default :func:`default_methods`.
    budget : int, optional
        Triangle budget per distinct mesh (default: each method's own);
        checked against each method's ``min_budget`` before any work.
    seed : int, optional
        Passed to every generator (default 0).
    jobs : int, optional
        Local worker processes (default 1: this process).
    scheduler : str or distributed.Client, optional
        Run the jobs on that dask.distributed cluster instead; the files are
        the same.
    progress : callable, optional
        ``progress(done, total, label, work=(work_done, work_total))``: once
        before the jobs run (label ``''``; ``done`` counts the jobs found
        finished) and after each job. ``work`` measures the jobs to run in
        triangles plus :data:`JOB_WORK_TRIANGLES` each, so that elapsed time
        x work left / work done estimates the time left.

    Returns
    -------
    LevelOccluders

    Raises
    ------
    InputError
        An unknown method, a budget a method cannot meet, a bad ``jobs`` or
        ``seed``, a missing folder.
    OSError
        A file cannot be written.

    Notes
    -----
    Writes, per method that covered at least one object, ``DIR/<method>.tscn``
    (Godot 4 text scene, one ``OccluderInstance3D`` per object instance with
    its transform, one ``ArrayOccluder3D`` sub-resource per distinct mesh in
    its local frame, shared by its instances; meshes of identical vertices and
    faces, such as copies a file stores once per node, are one job and one
    sub-resource) and ``DIR/<method>.glb`` (nodes
    ``<object>-occonly``), both in Godot's +Y-up frame; a method that covered
    nothing gets neither (files of an earlier run under those names are
    removed). Then ``DIR/occlude.json``: the level, up axis, settings, per
    object its size, whether chosen and per method its occluder file, node,
    triangles, ``conservative_guaranteed``, seconds or why it was refused,
    and per method a summary. All after every job has finished, as one set
    (:class:`viscore._atomic.FileSet`: all of them or, when a write fails, none,
    the files of an earlier run left as they were). Each finished job is kept
    under ``occluders/`` as it finishes, its occluder and record both or
    neither, for a rerun to resume from; an ``occluders/`` (or a method folder
    in it) that is a symbolic link is refused before anything is written.
    Deterministic given the level, methods, budget and seed (``seconds``
    aside), whatever ``jobs`` or ``scheduler``.

    Examples
    --------
    >>> import tempfile, trimesh
    >>> from viscore.level.objects import level_objects
    >>> level = level_objects(trimesh.creation.box(), up="z")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     made = occlude_level(level, tmp, methods=["bbox"])
    >>> made.files
    ('bbox.tscn', 'bbox.glb', 'occlude.json')
    """
    out = Path(out_dir)
    if not out.is_dir():
        raise InputError(f"out_dir: {out} is not an existing folder")
    check_occlude_folder(out)
    labels = _check_methods(methods, budget)
    seed = as_seed(seed)
    jobs = as_positive_int(jobs, "jobs")
    objects = level.objects
    chosen = level.chosen
    mesh_ids = sorted(set(objects.mesh_ids[chosen].tolist()))
    for stale in [*out.glob(".*.tmp"), *(out / JOB_DIR).glob("*/.*.tmp")]:
        if stale.is_dir() and not stale.is_symlink():  # a killed run's file set
            shutil.rmtree(stale, ignore_errors=True)
        else:
            stale.unlink(missing_ok=True)  # a killed run's half-written file
    # meshes of identical geometry (copies placed by node transforms) share one job,
    # one stored file and one sub-resource: the first of them by mesh index
    canonical: dict[int, int] = {}
    first: dict[bytes, int] = {}
    for m in mesh_ids:  # (load_scene_objects stores such copies once already)
        canonical[m] = first.setdefault(geometry_digest(objects.meshes[m]), m)
    results: dict[tuple[str, int], MeshOccluder] = {}
    pending = []
    # a method for height fields (GeneratorSpec.inputs) runs on the flat objects only: a
    # job's mesh is flat when every chosen object placing it or a copy of it is
    flat = np.asarray(level.flat)[chosen]
    job_of = np.array([canonical[int(m)] for m in np.asarray(objects.mesh_ids)[chosen]])
    flat_job = {m: bool(flat[job_of == m].all()) for m in set(canonical.values())}
    reused = 0
    for label in labels:
        fields_only = parse_method(label).spec.inputs == "height-fields"
        for m in sorted(set(canonical.values())):
            mesh = objects.meshes[m]
            v = np.asarray(mesh.vertices, dtype=np.float64)
            f = np.asarray(mesh.faces, dtype=np.int64)
            name = objects.mesh_names[m]
            key = _job_key(v, f, label, budget, seed)
            if fields_only and not flat_job[m]:
                results[(label, m)] = MeshOccluder(
                    name, label, np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), 0, False,
                    0.0, f"not run: {label} is for height fields, and this object is not flat "
                    f"(its extent along the up axis is at least {FLAT_RATIO:g} of its width)",
                    key)
                continue
            found = _stored(out, label, name, key)
            if found is not None:
                results[(label, m)] = found
                reused += 1
            else:
                pending.append((v, f, name, label, budget, seed))
    # the biggest meshes first: the pool's last job is a small one
    pending.sort(key=lambda a: -len(a[1]))
    index = {(objects.mesh_names[m], label): m for m in mesh_ids for label in labels}
    total = len(results) + len(pending)
    work = {(a[2], a[3]): len(a[1]) + JOB_WORK_TRIANGLES for a in pending}
    work_total, work_done = float(sum(work.values())), [0.0]
    if progress is not None:
        progress(len(results), total, "", work=(0.0, work_total))

    computed: list[MeshOccluder] = []

    def commit(job: MeshOccluder) -> None:
        _keep(out, job)
        results[(job.method, index[(job.mesh, job.method)])] = job
        computed.append(job)
        work_done[0] += work[(job.mesh, job.method)]
        if progress is not None:
            progress(len(results), total, f"{job.method} {job.mesh}",
                     work=(work_done[0], work_total))

    try:
        run_jobs(_run_job, pending, commit, jobs=jobs, scheduler=scheduler,
                 threads=max(1, cpu_cores() // max(1, min(jobs, len(pending)))))
    finally:  # what the finished jobs logged, said once per text, even on an interruption
        _say_logs(computed, [objects.mesh_names[m] for m in mesh_ids], labels)
    for label in labels:
        for m in mesh_ids:
            results[(label, m)] = results[(label, canonical[m])]
    return _write_level(level, out, labels, results, budget=budget, seed=seed,
                        reused=reused, computed=len(pending))


def _write_level(level: LevelObjects, out: Path, labels: list[str],
                 results: dict[tuple[str, int], MeshOccluder], *, budget: int | None,
                 seed: int, reused: int, computed: int) -> LevelOccluders:
    objects = level.objects
    chosen = set(level.chosen.tolist())
    rows: dict[str, dict] = {}
    for i, name in enumerate(objects.names):
        rows[name] = {"mesh": objects.mesh_names[objects.mesh_ids[i]],
                      "size": float(level.sizes[i]), "flat": bool(level.flat[i]),
                      "chosen": i in chosen, "refused": level.refused.get(name),
                      "occluders": {}}
    summary: dict[str, dict] = {}
    files: list[str] = []
    staged: dict[str, bytes] = {}  # written as one set, the manifest with them
    stale: list[Path] = []
    for label in labels:
        stem = _stem(label)
        instances, meshes, covered, refused = [], {}, [], 0
        distinct = {id(job): job for (lab, _), job in results.items() if lab == label}
        seconds = float(sum(job.seconds for job in distinct.values()))
        for i in sorted(chosen):
            job = results[(label, int(objects.mesh_ids[i]))]
            name = objects.names[i]
            if job.refused is not None:
                rows[name]["occluders"][label] = {"refused": job.refused}
                refused += 1
                continue
            key = job.mesh
            meshes[key] = (job.vertices, job.faces)
            instances.append(OccluderInstance(name, key, level.to_godot @ objects.transforms[i]))
            covered.append(i)
            rows[name]["occluders"][label] = {
                "file": f"{stem}.tscn", "glb": f"{stem}.glb",
                "mesh_file": _job_paths(Path("."), label, job.mesh)[0].as_posix(),
                "method": label, "triangles": job.triangles,
                "conservative_guaranteed": job.conservative_guaranteed,
                "seconds": job.seconds}
        made = bool(instances)
        if made:
            staged[f"{stem}.tscn"] = tscn_text(instances, meshes).encode("utf-8")
            staged[f"{stem}.glb"] = occonly_glb_bytes(instances, meshes)
            files += [f"{stem}.tscn", f"{stem}.glb"]
        else:
            stale += [out / f"{stem}{suffix}" for suffix in (".tscn", ".glb")]
        summary[label] = {
            "objects": len(covered), "refused": refused,
            "meshes": len(meshes),
            "triangles": int(sum(len(meshes[inst.mesh_key][1]) for inst in instances)),
            "conservative_guaranteed": bool(made) and all(
                rows[objects.names[i]]["occluders"][label]["conservative_guaranteed"]
                for i in covered),
            "seconds": seconds,
            "files": [f"{stem}.tscn", f"{stem}.glb"] if made else []}
    manifest = {
        "level": objects.source, "kind": level.kind, "up": level.up,
        "up_guessed": level.up_guessed, "up_reason": level.up_reason,
        "to_godot": level.to_godot.tolist(), "components": level.components,
        "settings": {"methods": labels, "budget": budget, "seed": seed,
                     "min_size": level.min_size,
                     "occluders": None if level.names is None else list(level.names)},
        "objects_total": len(objects), "objects_chosen": len(chosen),
        "methods": summary, "objects": rows}
    staged[MANIFEST_NAME] = (json.dumps(manifest, indent=1) + "\n").encode()
    with FileSet(out) as fileset:  # every engine file and the manifest, or none of them
        for name, data in staged.items():
            fileset.write(name, data)
    for path in stale:  # files of an earlier run for a method that now covers nothing
        path.unlink(missing_ok=True)
    files.append(MANIFEST_NAME)
    return LevelOccluders(manifest=manifest, files=tuple(files), reused=reused,
                          computed=computed)


def default_methods() -> list[str]:
    """The methods ``viscore occlude`` runs by default.

    ``surface-patches, aabb-skins`` when ``surface-patches`` is registered
    (guaranteed occluders in the surface of thin, open game geometry, and
    boxes where parts are thick), else ``aabb-skins, planar-sections``.

    Examples
    --------
    >>> "aabb-skins" in default_methods()
    True
    """
    if "surface-patches" in REGISTRY:
        return ["surface-patches", "aabb-skins"]
    return ["aabb-skins", "planar-sections"]
