"""Comparison studies: every registered method on every mesh, evaluated and stored.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (orbit protocol, sec. 6.1;
   occlusion measure, sec. 3).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (volume protocol, sec. 3.2).
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import re
import shutil
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from viscore import InputError, cpu_cores
from viscore._jobs import (
    JOBS_PER_CORE,
    SCHEDULER_PROBE_SECONDS,
    check_scheduler,
    connect_scheduler,
    process_pool,
    stop_pool,
)
from viscore.exchange import mesh_bytes, refuse_path
from viscore.metrics import study_bytes

from .._common import dumps, write_atomic
from .store import StudyFolder

__all__ = ["StudySettings", "Job", "OccluderFile", "study_jobs", "occluder_file_jobs",
           "resolve_occluder_files", "file_digest", "view_settings", "study_memory",
           "build_views", "views_from_file", "run_job", "run_study", "check_scheduler",
           "connect_scheduler",
           "TIMING_FIELDS", "JOBS_PER_CORE", "KEPT_BYTES_PER_JOB", "SCHEDULER_PROBE_SECONDS",
           "OCCLUDER_SUFFIXES"]

#: Fields of a row that are wall times (they differ between runs; everything
#: else in a row is deterministic given the settings).
TIMING_FIELDS = ("seconds", "seconds_evaluate", "seconds_measure", "seconds_validate")


#: Suffixes of the occluder files looked for in an ``--occluder-files`` folder: those
#: :func:`viscore.load_occluder` reads as Godot or glTF files, and the usual mesh files.
OCCLUDER_SUFFIXES = ("tscn", "tres", "occ", "res", "glb", "gltf", "obj", "ply", "off", "stl")

#: Longest ``--occluder-files`` NAME: it is part of each row's occluder file name (with
#: the mesh's stem, the budget and a key), which a filesystem caps at 255 bytes.
MAX_FILE_ROW_NAME = 64
#: Most files an ``--occluder-files`` folder may hold for one mesh (one study row and
#: one assessment each; a folder of thousands would queue thousands of jobs).
MAX_FILES_PER_MESH = 256
#: Names an ``--occluder-files`` row may take (no ``:`` or ``,``: never a method variant).
_FILE_ROW_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")

#: Bytes a worker keeps between the budgets of a method, beyond what
#: :func:`viscore.metrics.estimates.study_bytes` counts: about 190 MB for planar sections'
#: candidates per voxel solid, hybrid's candidate set and volume views and the precision
#: check's views (a worker's peak on the default study), and 194 MiB for hybrid's
#: metric-guided state on the bunny kept with its copy where the recall step stopped
#: (96 + 98 MiB, the arrays' bytes after budgets 256 and 64), and 80 MiB for planar
#: sections' voxel solids kept by mesh and options (building-house's 11 solids; at most
#: 12 a process).
KEPT_BYTES_PER_JOB = 464 * 2**20

#: Expected cost of one job of a method (generation and assessment), seconds: the mean
#: over the default study's three meshes (fat-torus, bunny, building-house) of its rows'
#: ``seconds`` + ``seconds_evaluate`` on main at 1b0eb5e (``viscore compare``, 2 cores).
#: Only the order matters: a local study starts its tasks longest first, so that the
#: cores finish together instead of one waiting on a long task started last (the
#: results never depend on the order).
_METHOD_COST = {"planar-sections": 32.0, "hybrid": 29.6, "solid-frusta": 5.8,
                "surface-patches": 4.7, "aabb-skins": 3.0, "qem": 1.8}
#: Cost of a job of any other method (godot, bbox, original: 1.0 to 1.6 s) or an occluder
#: file's, in the units of :data:`_METHOD_COST`.
_OTHER_COST = 1.5


@dataclass(frozen=True)
class StudySettings:
    """Evaluation settings shared by every job of a study."""

    protocol: str = "orbit"
    views: int = 128
    quads: int = 16000
    resolution: int = 256
    directions: int = 32
    rays: int = 100_000
    budgets: tuple = (64, 256)
    seed: int = 0

    def key(self, mesh: str, method: str, budget: int | None, digest: str | None = None
            ) -> str:
        """The row key of a job; an occluder file's row adds its content ``digest``."""
        d = {k: v for k, v in asdict(self).items() if k != "budgets"}
        if digest is not None:  # (generated rows keep their keys of before)
            d["occluder_digest"] = digest
        text = json.dumps({"mesh": mesh, "method": method, "budget": budget, **d},
                          sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


@dataclass(frozen=True)
class Job:
    """One row of a study: a method's occluder, or an occluder file's (``source``)."""

    mesh: str
    method: str
    budget: int | None
    settings: StudySettings = field(repr=False)
    #: An occluder file made by another tool (``--occluder-files``): assessed, not generated.
    source: str | None = None
    #: SHA-256 of that file's content, part of the row key (a changed file is redone).
    digest: str | None = None

    @property
    def key(self) -> str:
        return self.settings.key(self.mesh, self.method, self.budget, self.digest)

    @property
    def occluder_file(self) -> str:
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in Path(self.mesh).stem)
        method = "".join(c if c.isalnum() or c in "-_" else "_" for c in self.method)
        return f"{safe}__{method}__{self.budget or 'any'}__{self.key[:8]}.ply"


@dataclass(frozen=True)
class OccluderFile:
    """An occluder file of one mesh, assessed as the study row ``name``.

    ``budget`` is the budget its file name states (``<mesh>.<budget>.<ext>``),
    else None; ``digest`` the SHA-256 of its content (:func:`file_digest`).
    """

    name: str
    mesh: str
    budget: int | None
    path: str
    digest: str


def file_digest(path: str | os.PathLike) -> str:
    """SHA-256 (hex) of a file's content (of a ``.gltf``: the JSON file, not its buffers)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _folder_files(folder: Path, stem: str) -> dict:
    """``<stem>.<ext>`` (budget None) and ``<stem>.<budget>.<ext>`` in a folder: budget -> paths."""
    found: dict = {}
    prefix = stem + "."
    for entry in sorted(folder.iterdir()):
        name = entry.name
        if not name.startswith(prefix) or name.startswith(".") or not entry.is_file():
            continue
        parts = name[len(prefix):].split(".")
        if parts[-1].lower() not in OCCLUDER_SUFFIXES:
            continue
        if len(parts) == 1:
            found.setdefault(None, []).append(entry)
        elif len(parts) == 2 and parts[0].isdigit() and int(parts[0]) > 0:
            found.setdefault(int(parts[0]), []).append(entry)
    return found


def resolve_occluder_files(specs: list[tuple[str, str]], meshes: list[str], *,
                           methods: list[str] = (), check: bool = True
                           ) -> list[OccluderFile]:
    """The occluder files of ``--occluder-files NAME=PATH`` for each mesh, checked.

    Parameters
    ----------
    specs : list of (str, str)
        ``(NAME, PATH)``: PATH a file (every mesh's occluder) or a folder
        holding ``<mesh>.<ext>`` and/or ``<mesh>.<budget>.<ext>`` per mesh
        (``<mesh>`` the mesh's file stem or built-in name; ``<ext>`` one of
        :data:`OCCLUDER_SUFFIXES`), one row per file found.
    meshes : list of str
        The study's meshes.
    methods : list of str, optional
        The methods run: a NAME among them is refused.
    check : bool, optional
        Read each file (:func:`viscore.generators.levels.occluders.file_occluder`)
        so that a bad one is refused now, before any work (default True).

    Returns
    -------
    list of OccluderFile
        In mesh, NAME, budget order (budget None first).

    Raises
    ------
    InputError
        One line: a NAME that is not a plain name, is a registered method or
        a method run, or is given twice; a PATH that does not exist; a folder
        without a file for a mesh (naming NAME, the mesh and the paths looked
        for), or with two for one mesh and budget; a file that cannot be read.
    """
    from viscore.generators import REGISTRY
    from viscore.generators.levels import file_occluder

    seen: set[str] = set()
    for name, path in specs:
        where = f"--occluder-files {name}={path}"
        if not _FILE_ROW_NAME.fullmatch(name):
            raise InputError(f"{where}: NAME must be letters, digits and _ . + - (starting "
                             "with a letter or digit)")
        if len(name) > MAX_FILE_ROW_NAME:
            raise InputError(f"--occluder-files {name[:40]}...={path}: NAME has {len(name)} "
                             f"characters, at most {MAX_FILE_ROW_NAME} (it names the study's "
                             "occluder files)")
        if name in REGISTRY or name in methods:
            raise InputError(f"{where}: {name} is a registered method; name the occluder "
                             "files otherwise")
        if name in seen:
            raise InputError(f"{where}: {name} is given twice")
        seen.add(name)
        try:
            os.stat(path)
        except FileNotFoundError:
            if not os.path.islink(path):
                raise InputError(f"{where}: no such file or folder") from None
            raise refuse_path(path, where, FileNotFoundError()) from None
        except OSError as exc:  # a loop of links, a path through a file, no permission
            raise refuse_path(path, where, exc) from None
    out: list[OccluderFile] = []
    for mesh in meshes:
        stem = Path(mesh).stem
        for name, path in specs:
            where = f"--occluder-files {name}={path}"
            p = Path(path)
            if not p.is_dir():
                out.append(OccluderFile(name, mesh, None, str(p), ""))
                continue
            found = _folder_files(p, stem)
            if sum(len(paths) for paths in found.values()) > MAX_FILES_PER_MESH:
                raise InputError(f"{where}: {sum(map(len, found.values())):,} occluder files for "
                                 f"mesh {mesh} (budgets {min(b or 0 for b in found):,}.."
                                 f"{max(b or 0 for b in found):,}), more than the "
                                 f"{MAX_FILES_PER_MESH} rows a study takes per mesh and NAME")
            if not found:
                raise InputError(
                    f"{where}: no occluder file for mesh {mesh}; looked for "
                    f"{p / stem}.<ext> and {p / stem}.<budget>.<ext> "
                    f"(<ext>: {', '.join(OCCLUDER_SUFFIXES)})")
            for budget in sorted(found, key=lambda b: -1 if b is None else b):
                paths = found[budget]
                if len(paths) > 1:
                    raise InputError(f"{where}: {len(paths)} files for mesh {mesh}"
                                     + (f" at budget {budget}" if budget else "")
                                     + f" ({', '.join(q.name for q in paths)}); keep one")
                out.append(OccluderFile(name, mesh, budget, str(paths[0]), ""))
    digests: dict[str, str] = {}
    resolved = []
    for f in out:
        if f.path not in digests:
            if check:
                try:
                    file_occluder(f.path)
                except InputError as exc:
                    raise InputError(f"--occluder-files {f.name}: {exc}") from None
            try:
                digests[f.path] = file_digest(f.path)
            except OSError as exc:
                raise InputError(f"--occluder-files {f.name}: {f.path}: cannot read "
                                 f"({exc.strerror or exc})") from None
        resolved.append(OccluderFile(f.name, f.mesh, f.budget, f.path, digests[f.path]))
    return resolved


def occluder_file_jobs(files: list[OccluderFile], settings: StudySettings) -> list[Job]:
    """One job per occluder file (:func:`resolve_occluder_files`)."""
    return [Job(f.mesh, f.name, f.budget, settings, source=f.path, digest=f.digest)
            for f in files]


def view_settings(settings: StudySettings) -> dict:
    """Keywords of :class:`viscore.metrics.ReferenceViews` for a study's settings."""
    kw = {"protocol": settings.protocol, "seed": settings.seed, "quads": settings.quads,
          "resolution": settings.resolution}
    if settings.protocol == "orbit":
        kw["views"] = settings.views
    return kw


def study_memory(settings: StudySettings, meshes: dict, jobs: int) -> float:
    """Estimated peak bytes of a local study, from its settings and meshes alone.

    :func:`viscore.metrics.estimates.study_bytes` for the study's settings:
    each of ``jobs`` workers holds a process, the reference views of its mesh,
    one ray-casting batch, the conservativeness rays, a measure image and the
    mesh, plus one copy of every mesh's views; and each worker the work its
    tasks keep between a method's budgets (:data:`KEPT_BYTES_PER_JOB`).

    Parameters
    ----------
    settings : StudySettings
    meshes : dict of str -> trimesh.Trimesh
        The study's meshes, loaded.
    jobs : int
        Local worker processes.

    Returns
    -------
    float
        Bytes (a float: it may exceed int64 for absurd settings).
    """
    return study_bytes(settings.protocol, views=settings.views, quads=settings.quads,
                       resolution=settings.resolution, rays=settings.rays, meshes=meshes,
                       jobs=jobs) + jobs * KEPT_BYTES_PER_JOB


def build_views(mesh: str, settings: StudySettings, workers: int | None = None,
                original=None):
    """The original's views of one mesh, built once and shared by all its jobs.

    ``original`` is the mesh already loaded (by the parent); default: loaded here.
    """
    from viscore import load_mesh, set_workers
    from viscore.metrics import ReferenceViews

    set_workers(workers)
    return ReferenceViews(load_mesh(mesh) if original is None else original,
                          **view_settings(settings))


#: In a worker process: the views file it read last, and its views (one mesh's at a time).
_WORKER_VIEWS: dict[str, object] = {}


def _write_views(mesh: str, settings: StudySettings, workers: int | None, original,
                 path: str) -> str:
    """In a worker: build one mesh's views and pickle them once to ``path``."""
    data = pickle.dumps(build_views(mesh, settings, workers, original),
                        protocol=pickle.HIGHEST_PROTOCOL)
    with open(path, "wb") as fh:
        fh.write(data)
    return path


def views_from_file(path: str):
    """The views pickled in ``path``, read once per process (the last file's are kept)."""
    views = _WORKER_VIEWS.get(path)
    if views is None:
        _WORKER_VIEWS.clear()  # one mesh's views per worker, as the memory estimate counts
        with open(path, "rb") as fh:
            views = pickle.load(fh)
        _WORKER_VIEWS[path] = views
    return views


def _held_job(job: Job, workers: int | None = None, views=None
              ) -> tuple[dict, bytes, list[dict]]:
    """In a worker: :func:`run_job` with the log records it made held back, handed to the
    parent as plain values (:func:`viscore.generators._held_logs.portable`), which says
    them once for the whole study (:func:`run_study`)."""
    from viscore.generators import call_held, portable

    (row, ply), records = call_held(run_job, job, workers, views)
    return row, ply, portable(records)


def _run_jobs_on_file(jobs: list[Job], workers: int | None, path: str
                      ) -> list[tuple[dict, bytes, list[dict]]]:
    """In a worker: :func:`_held_job` of each job in turn on the views of ``path``.

    ``jobs`` are the budgets of one mesh and method (:func:`_tasks`): run in one
    process, one after the other, they share what does not depend on the
    budget (the check views, planar sections' candidates and greedy search),
    each made once; every row is the one its job gives alone.
    """
    from viscore.generators.hybrid import shared_budgets

    views = views_from_file(path)
    with shared_budgets():  # hybrid's budgets go on from one state, released at the end
        return [_held_job(job, workers, views) for job in jobs]


def _file_occluder(job: Job):
    """The occluder of a file job, named after its row; the file must be unchanged."""
    import dataclasses

    from viscore.generators.levels import file_occluder

    occ = file_occluder(job.source)
    if file_digest(job.source) != job.digest:
        raise InputError(f"--occluder-files {job.method}: {job.source} changed while the "
                         "study ran; run compare again")
    info = {**occ.info, "digest": job.digest}
    if job.budget is not None:
        info["over_budget"] = occ.triangles > job.budget
    return dataclasses.replace(occ, method=job.method,
                               params={"file": job.source, "digest": job.digest}, info=info)


def run_job(job: Job, workers: int | None = None, views=None) -> tuple[dict, bytes]:
    """Generate one occluder and assess it; returns the row and the occluder PLY.

    The occluder comes from :func:`viscore.generators.generate` (parameters
    checked against the registry; ``info["over_budget"]`` set), or for a
    file job (``job.source``) from the file
    (:func:`viscore.generators.levels.occluders.file_occluder`: double-sided,
    ``info["conservative_guaranteed"]`` False unless the file says so,
    ``seconds`` NaN; the file's content must still match ``job.digest``).
    ``views`` are the mesh's :class:`viscore.metrics.ReferenceViews` for the
    job's settings (built here when not given).
    """
    from viscore import set_workers
    from viscore.generators import generate
    from viscore.metrics import assess_occluder

    s = job.settings
    set_workers(workers)
    views = views if views is not None else build_views(job.mesh, s, workers)
    if job.source is not None:
        occ = _file_occluder(job)
    else:
        params = {"seed": s.seed} | ({"budget": job.budget} if job.budget else {})
        occ = generate(job.method, views.mesh, **params)
    assessed = assess_occluder(views, occ, directions=s.directions, rays=s.rays)
    row = {"key": job.key, "mesh": job.mesh, "budget": job.budget, **assessed.to_json(),
           "method": job.method, "occluder_file": job.occluder_file, "settings": asdict(s)}
    if job.source is not None:
        row["occluder_source"] = job.source
    # float64 PLY (trimesh writes float32 vertices): the occluder file is the occluder
    ply = mesh_bytes(occ.mesh, "ply") if occ.triangles else b""
    return json.loads(dumps(row)), ply


def _row_is_current(row: dict) -> bool:
    """Whether a stored row holds a whole assessment of today's schema (others are redone)."""
    from dataclasses import fields

    from viscore.metrics import OccluderAssessment

    if not all(f.name in row for f in fields(OccluderAssessment)):
        return False
    try:
        OccluderAssessment.from_json(row)
    except Exception:  # noqa: BLE001 - a row that does not read back is recomputed
        return False
    return True


def _by_mesh(pending: list[Job]) -> dict:
    """Pending jobs grouped by (mesh, settings): one set of reference views each."""
    groups: dict = {}
    for job in pending:
        groups.setdefault((job.mesh, job.settings), []).append(job)
    return groups


def _tasks(group: list[Job]) -> list[list[Job]]:
    """One mesh's jobs as worker tasks: a method's budgets together, the largest first
    (they share work in one process: :func:`_run_jobs_on_file`; hybrid's recall step
    goes on for a smaller budget from where a larger one stopped); each occluder file
    alone."""
    tasks: dict = {}
    for job in group:
        tasks.setdefault((job.method, job.source), []).append(job)
    return [sorted(task, key=lambda j: -(j.budget or 0)) for task in tasks.values()]


def _task_cost(task: list[Job]) -> float:
    """Expected cost of a worker task (:func:`_tasks`), in :data:`_METHOD_COST`'s units:
    its method's cost per budget (a variant ``NAME:option=value`` costs as ``NAME``;
    an occluder file or an unknown method :data:`_OTHER_COST`) times its budgets."""
    job = task[0]
    method = job.method.split(":", 1)[0]
    per_job = _OTHER_COST if job.source is not None else _METHOD_COST.get(method, _OTHER_COST)
    return per_job * len(task)


def study_jobs(meshes: list[str], methods: list[str], settings: StudySettings,
               files: list[OccluderFile] = ()) -> list[Job]:
    """One job per mesh, method and budget (one budget-less job for unbudgeted methods).

    Each mesh's methods are followed by its occluder files' jobs
    (:func:`occluder_file_jobs`), in the order given.
    """
    from viscore.generators import get_generator

    jobs = []
    for mesh in meshes:
        for method in methods:
            budgets = settings.budgets if get_generator(method).budgeted else (None,)
            jobs += [Job(mesh, method, b, settings) for b in budgets]
        jobs += occluder_file_jobs([f for f in files if f.mesh == mesh], settings)
    return jobs


@dataclass(frozen=True)
class Unit:
    """Work of another kind a local study's pool runs beside its jobs (compare's culling
    column, :func:`run_study`'s ``extra``).

    ``fn(*args)`` runs in a worker; ``done(result)`` in this process when it
    finishes, returning the units it makes ready (a column's simulation once
    its last piece of occluders is in). ``cost`` orders it among the jobs'
    tasks, in :data:`_METHOD_COST`'s units: the time it keeps the work after
    it waiting (its own and its followers'), so that a chain starts early.
    """

    cost: float
    fn: Callable
    args: tuple
    done: Callable[[Any], list]


def _local(pending: list[Job], jobs: int, per_job: int, commit: Callable, *,
           scratch: str | os.PathLike, originals: dict | None = None,
           extra: Sequence[Unit] = ()) -> None:
    """Each mesh's views built once in the pool and written once, then its jobs.

    A worker builds a mesh's views (from ``originals[mesh]`` when given, else
    loading it) and pickles them to a file in a temporary folder made in
    ``scratch``; each task of that mesh (a method's budgets, :func:`_tasks`)
    carries the file's path and each worker reads a file once
    (:func:`views_from_file`). The views are built first; then, each time a
    worker is free, it is given the costliest task whose views are ready
    (:func:`_task_cost`; ties in the order of ``pending``), or the costliest
    of the ``extra`` units (:class:`Unit`) when that costs more: the longest
    tasks start first and the short ones fill in at the end. ``commit(job,
    result)`` is called in this process as each job finishes. On any
    exception (Ctrl-C included) the jobs that finished are committed, the
    others cancelled and the workers killed, then the exception goes on; the
    temporary folder is removed in every case.
    """
    import heapq

    groups = _by_mesh(pending)
    originals = originals or {}
    folder = tempfile.mkdtemp(prefix=".views-", suffix=".tmp", dir=scratch)
    try:
        workers = max(1, min(jobs, len(pending) + len(extra)))
        pool = process_pool(workers)
        running: dict = {}
        # (-cost, order, task or Unit, views file or None): what a free worker may take
        ready: list = []
        order = 0
        for unit in extra:
            heapq.heappush(ready, (-unit.cost, order, unit, None))
            order += 1
        try:
            building = {pool.submit(_write_views, mesh, settings, per_job, originals.get(mesh),
                                    os.path.join(folder, f"{k}.pickle")): (mesh, settings)
                        for k, (mesh, settings) in enumerate(groups)}
            while building or running or ready:
                # a free worker takes the costliest ready task (none queue behind a busy one)
                while ready and len(building) + len(running) < workers:
                    _, _, task, path = heapq.heappop(ready)
                    if isinstance(task, Unit):
                        running[pool.submit(task.fn, *task.args)] = task
                    else:
                        running[pool.submit(_run_jobs_on_file, task, per_job, path)] = task
                done, _ = wait([*building, *running], return_when=FIRST_COMPLETED)
                for fut in done:
                    if fut in building:
                        path = fut.result()
                        for task in _tasks(groups[building.pop(fut)]):
                            heapq.heappush(ready, (-_task_cost(task), order, task, path))
                            order += 1
                        continue
                    task = running.pop(fut)
                    if isinstance(task, Unit):
                        for unit in task.done(fut.result()):
                            heapq.heappush(ready, (-unit.cost, order, unit, None))
                            order += 1
                    else:
                        for job, result in zip(task, fut.result(), strict=True):
                            commit(job, result)
        except BaseException:
            try:
                for fut, task in list(running.items()):  # keep what finished meanwhile
                    if (not isinstance(task, Unit) and fut.done() and not fut.cancelled()
                            and fut.exception() is None):
                        for job, result in zip(task, fut.result(), strict=True):
                            commit(job, result)
            finally:
                stop_pool(pool)
            raise
        pool.shutdown(wait=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _dask(pending: list[Job], scheduler, commit: Callable) -> None:
    """As :func:`_local` on a dask cluster: the views move to the jobs' workers once."""
    from distributed import as_completed as dask_completed

    with connect_scheduler(scheduler) as client:
        futures: dict = {}
        try:
            for (mesh, settings), group in _by_mesh(pending).items():
                views = client.submit(build_views, mesh, settings, None, pure=False)
                futures |= {client.submit(_held_job, j, None, views, pure=False): j
                            for j in group}
            for fut in dask_completed(list(futures)):
                commit(futures.pop(fut), fut.result())
        except BaseException:
            if futures:
                client.cancel(list(futures))
            raise


def run_study(meshes: list[str], methods: list[str], settings: StudySettings,
              out_dir: str | os.PathLike | StudyFolder, *, jobs: int = 1,
              workers: int | None = None, scheduler=None, progress: bool = True,
              on_row: Callable[[dict], None] | None = None,
              originals: dict | None = None,
              files: list[OccluderFile] = (),
              on_records: Callable[[list], None] | None = None,
              extra: Sequence[Unit] = (),
              on_jobs_done: Callable[[list[dict]], None] | None = None) -> list[dict]:
    """Run (or resume) every job; returns the rows in mesh, method, budget order.

    The log records a job makes are held in its worker and come back with its
    row. With ``--verbose`` (the ``viscore`` logger at DEBUG) they are said as
    each job finishes; otherwise the study's progress bar is all that moves
    until the end, where each kind of warning is said once with its count
    (:func:`viscore.generators._held_logs.report_kinds`), or handed to
    ``on_records`` to say with others.

    Parameters
    ----------
    meshes, methods : list of str
        Mesh files or built-in scenes; registered method names.
    settings : StudySettings
    out_dir : path-like or StudyFolder
        The study folder, opened (and locked) here; or one the caller holds open.
    jobs : int, optional
        Local worker processes (default 1; never more than the pending jobs).
    workers : int, optional
        Ray-casting threads per job; default the cores divided among the jobs.
    scheduler : str or distributed.Client, optional
        Run the jobs on that dask.distributed cluster instead.
    progress : bool, optional
        A progress bar on stderr.
    on_row : callable, optional
        Called with each new row after it is committed.
    originals : dict of str -> trimesh.Trimesh, optional
        The meshes already loaded (by name): the local workers build the views
        from them instead of loading the files again.
    files : list of OccluderFile, optional
        Occluder files made by other tools (:func:`resolve_occluder_files`),
        each a row of its own after the mesh's methods; its key holds the
        file's content digest, so a changed file is assessed again on resume.
    on_records : callable, optional
        Called once, at the end, with the jobs' held records (``logging.LogRecord``,
        in the order the jobs finished) instead of saying their warnings here;
        not called with ``--verbose``, where each job's records were said already.
    extra : sequence of Unit, optional
        Other work for the local pool, run beside the jobs, costliest first
        among them (:func:`_local`); refused with a scheduler. Its results go
        to each unit's ``done``.
    on_jobs_done : callable, optional
        Called once, in this process, with the rows (as returned) as soon as
        every job is in, while ``extra`` work may still run: the rows' figures
        can be drawn meanwhile.
    """
    if not isinstance(out_dir, StudyFolder):
        with StudyFolder(out_dir) as study:
            return run_study(meshes, methods, settings, study, jobs=jobs, workers=workers,
                             scheduler=scheduler, progress=progress, on_row=on_row,
                             originals=originals, files=files, on_records=on_records,
                             extra=extra, on_jobs_done=on_jobs_done)
    import logging

    from tqdm import tqdm

    from viscore.generators import release, report_kinds, restored

    study = out_dir
    store = study.store
    todo = study_jobs(meshes, methods, settings, files)
    rows: dict[str, dict] = {}
    pending = []
    for job in dict.fromkeys(todo):
        found = store.get(job.key)
        if found is not None and _row_is_current(found) and (
                not found.get("triangles") or (study.occluders / job.occluder_file).is_file()):
            rows[job.key] = found
        else:
            pending.append(job)
    per_job = workers or max(1, cpu_cores() // max(1, min(jobs, len(pending) or 1)))
    bar = tqdm(total=len(rows) + len(pending), initial=len(rows), disable=not progress,
               desc="compare", unit="job")

    verbose = logging.getLogger("viscore").isEnabledFor(logging.DEBUG)
    held: list = []

    def commit(job: Job, result: tuple) -> None:
        row, ply, records = result
        if verbose:
            release(restored(records))
        else:
            held.extend(restored(records))
        if ply:  # the file first: a stored row always has its occluder
            write_atomic(study.occluders / job.occluder_file, ply)
        store.put(job.key, row)
        rows[job.key] = row
        bar.set_postfix_str(f"{job.mesh}/{job.method}/{job.budget or '-'}")
        bar.update(1)
        if on_row:
            on_row(row)
        if on_jobs_done is not None and len(rows) == len(todo_keys):
            on_jobs_done([rows[j.key] for j in todo])

    todo_keys = list(dict.fromkeys(j.key for j in todo))
    if on_jobs_done is not None and not pending:
        on_jobs_done([rows[j.key] for j in todo])
    try:
        if scheduler is not None and extra:
            raise InputError("run_study: extra work runs in the local pool only, not on a "
                             "scheduler")
        if not pending and not extra:
            pass
        elif scheduler is not None:
            _dask(pending, scheduler, commit)
        else:
            _local(pending, jobs, per_job, commit, scratch=study.path, originals=originals,
                   extra=extra)
    finally:
        bar.close()
        if not verbose:
            if on_records is not None:
                on_records(held)
            else:
                report_kinds(held, labels=methods)
    return [rows[j.key] for j in todo]


