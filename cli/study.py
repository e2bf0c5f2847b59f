"""Comparison studies: every registered method on every mesh, evaluated and stored.

The orchestration of ``viscore compare`` (the data flow: metrics -> cli for
tables, plots, studies). The original's views
(:class:`viscore.metrics.ReferenceViews`) are built once per mesh and settings
and handed to every job of that mesh; each (mesh, method, budget, settings,
seed) job generates its occluder with :func:`viscore.generators.generate` and
assesses it with :func:`viscore.metrics.assess_occluder` (precision/recall,
occlusion measure, conservativeness). Jobs run in a local process pool, or on
a dask.distributed cluster with ``scheduler``; each job is deterministic given
its settings, so both give identical rows.

Crash safety. A study folder is opened by one process at a time
(:class:`StudyFolder`: an advisory ``flock`` on ``DIR/.lock``; a second
``compare`` on the same folder is refused with one line). Each job's occluder
file is written atomically under ``occluders/``, then its row is committed to
``DIR/results.sqlite`` in one transaction, as soon as the job finishes: a
re-run resumes, and a killed run (SIGKILL included) loses only the jobs that
were running. On Ctrl-C the pending jobs are cancelled and the worker
processes killed at once, after committing every job already finished; the
workers ignore SIGINT (the parent stops them) and die with their parent
(``PR_SET_PDEATHSIG``), so no orphan keeps computing. A store that is not a
study store (another file, another schema, a row that is not JSON) is refused
with one line naming the file, before any work.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (orbit protocol, sec. 6.1;
   occlusion measure, sec. 3; Figures 7 and 11, drawn by
   :mod:`viscore.metrics.plots`).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (volume protocol, sec. 3.2).
.. [3] Efron, B. "Better Bootstrap Confidence Intervals". Journal of the
   American Statistical Association 82(397), 1987.
   :DOI:`10.1080/01621459.1987.10478410` (the paired bootstrap of
   :func:`paired_rows`).
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import signal
import sqlite3
import threading
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path

from viscore import InputError, cpu_cores, stream_seed

from ._common import _mesh_bytes, check_output_folder, dumps, write_atomic

#: Columns of the printed and written table, in order.
TABLE_COLUMNS = ["mesh", "method", "budget", "triangles", "precision", "precision_ci", "recall",
                 "recall_ci", "occlusion_measure", "occlusion_measure_se",
                 "violation_upper_bound", "seconds"]

#: File names inside a study folder.
STORE_NAME, LOCK_NAME, OCCLUDER_DIR = "results.sqlite", ".lock", "occluders"

#: Columns of the store's one table, in order.
STORE_COLUMNS = ("key", "mesh", "method", "row")

#: Fields of a row that are wall times (they differ between runs; everything
#: else in a row is deterministic given the settings).
TIMING_FIELDS = ("seconds", "seconds_evaluate", "seconds_measure", "seconds_validate")

#: Local jobs allowed per core (``--jobs`` beyond ``JOBS_PER_CORE`` x cores is refused).
JOBS_PER_CORE = 4

# Memory of one local job, measured as peak RSS (``resource.getrusage``) of a
# worker running the bunny at compare's defaults (128 views, 16,000 quads,
# 256 px, 100,000 rays) on 2 cores: 226 MB after the imports, 367 MB with
# the views, 441 MB at the end of an aabb-skins job; the pickled views are
# 35 MiB (= 128 x 16,000 x 18 B).
#: Resident bytes of a worker process before any job (the imports).
_PROCESS_BYTES = 256 * 2**20
#: Bytes per stored quad of the reference views (corners, counts, depth level).
_BYTES_PER_QUAD = 18
#: Bytes per view of the reference views besides its quads.
_BYTES_PER_VIEW = 200
#: Bytes per ray of one ray-casting batch (origins, directions, float32
#: copies, distances, triangle ids) and rays per batch (eight 256 x 256 images).
_BYTES_PER_BATCH_RAY, _RAYS_PER_BATCH = 88, 8 * 256 * 256
#: Peak bytes per conservativeness ray (``validate --rays``, measured).
_BYTES_PER_CHECK_RAY = 160
#: Peak bytes per pixel of one occlusion-measure image (measured).
_BYTES_PER_MEASURE_PIXEL = 128
#: Bytes per triangle of the mesh in a worker (trimesh caches, the Embree
#: BVH, the generators' copies): the bunny's 56k faces add about 56 MB.
_BYTES_PER_FACE = 1024


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

    def key(self, mesh: str, method: str, budget: int | None) -> str:
        d = {k: v for k, v in asdict(self).items() if k != "budgets"}
        text = json.dumps({"mesh": mesh, "method": method, "budget": budget, **d},
                          sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


@dataclass(frozen=True)
class Job:
    mesh: str
    method: str
    budget: int | None
    settings: StudySettings = field(repr=False)

    @property
    def key(self) -> str:
        return self.settings.key(self.mesh, self.method, self.budget)

    @property
    def occluder_file(self) -> str:
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in Path(self.mesh).stem)
        method = "".join(c if c.isalnum() or c in "-_" else "_" for c in self.method)
        return f"{safe}__{method}__{self.budget or 'any'}__{self.key[:8]}.ply"


def view_settings(settings: StudySettings) -> dict:
    """Keywords of :class:`viscore.metrics.ReferenceViews` for a study's settings."""
    kw = {"protocol": settings.protocol, "seed": settings.seed, "quads": settings.quads,
          "resolution": settings.resolution}
    if settings.protocol == "orbit":
        kw["views"] = settings.views
    return kw


def study_memory(settings: StudySettings, meshes: dict, jobs: int) -> float:
    """Estimated peak bytes of a local study, from its settings and meshes alone.

    Each of ``jobs`` workers holds a process (:data:`_PROCESS_BYTES`), the
    reference views of its mesh (quads and per-view data), one ray-casting
    batch, the conservativeness rays, a measure image and the mesh; the
    parent holds every mesh's views until its jobs are done. The volume
    protocol's positions are estimated per mesh; its views are cached only
    where they fit (:class:`viscore.metrics.ReferenceViews`), so they are not
    counted.

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
    res2 = float(settings.resolution) ** 2
    batch = max(1.0, _RAYS_PER_BATCH // res2) * res2 * _BYTES_PER_BATCH_RAY
    fixed = (_PROCESS_BYTES + batch + float(settings.rays) * _BYTES_PER_CHECK_RAY
             + res2 * _BYTES_PER_MEASURE_PIXEL)
    views_bytes = {}
    for name, mesh in meshes.items():
        if settings.protocol == "orbit":
            views_bytes[name] = float(settings.views) * (settings.quads * _BYTES_PER_QUAD
                                                         + _BYTES_PER_VIEW)
        else:
            from viscore.metrics.volume import volume_positions_bytes

            views_bytes[name] = volume_positions_bytes(mesh)
    worst = max(views_bytes[n] + len(m.faces) * _BYTES_PER_FACE for n, m in meshes.items())
    return jobs * (fixed + worst) + sum(views_bytes.values())


def build_views(mesh: str, settings: StudySettings, workers: int | None = None):
    """The original's views of one mesh, built once and shared by all its jobs."""
    from viscore.metrics import ReferenceViews

    from viscore import load_mesh, set_workers

    set_workers(workers)
    return ReferenceViews(load_mesh(mesh), **view_settings(settings))


def run_job(job: Job, workers: int | None = None, views=None) -> tuple[dict, bytes]:
    """Generate one occluder and assess it; returns the row and the occluder PLY.

    The occluder comes from :func:`viscore.generators.generate` (parameters
    checked against the registry; ``info["over_budget"]`` set). ``views`` are
    the mesh's :class:`viscore.metrics.ReferenceViews` for the job's settings
    (built here when not given).
    """
    from viscore.generators import generate
    from viscore.metrics import assess_occluder

    from viscore import set_workers

    s = job.settings
    set_workers(workers)
    views = views if views is not None else build_views(job.mesh, s, workers)
    params = {"seed": s.seed} | ({"budget": job.budget} if job.budget else {})
    occ = generate(job.method, views.mesh, **params)
    assessed = assess_occluder(views, occ, directions=s.directions, rays=s.rays)
    row = {"key": job.key, "mesh": job.mesh, "budget": job.budget, **assessed.to_json(),
           "method": job.method, "occluder_file": job.occluder_file, "settings": asdict(s)}
    # float64 PLY (trimesh writes float32 vertices): the occluder file is the occluder
    ply = _mesh_bytes(occ.mesh, "ply", job.occluder_file) if occ.triangles else b""
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


def _not_a_store(path: Path, problem: str) -> InputError:
    return InputError(f"{path}: {problem}; not a viscore study store (move it away or choose "
                      "another --out)")


class ResultStore:
    """One SQLite file per study directory; a row per finished job, committed at once.

    Opening checks the whole file before any work: a file that is not SQLite,
    a folder, another schema, a failed integrity check or a row that is not a
    JSON object of its key raises :class:`InputError` naming the file (no
    ``sqlite3`` or JSON traceback). An empty or missing file becomes a new
    store. Rows are read once, at opening.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        path = Path(path)
        self.path = path
        if os.path.lexists(path) and not path.is_file():
            kind = "a folder" if path.is_dir() else "not a regular file"
            raise _not_a_store(path, f"is {kind}, expected the study's SQLite file")
        self._db = None
        try:
            self._db = sqlite3.connect(path)
            self._rows = self._check()
        except sqlite3.DatabaseError as exc:
            self.close()
            raise _not_a_store(path, f"sqlite: {exc}") from None
        except BaseException:
            self.close()
            raise

    def _check(self) -> dict[str, dict]:
        db, path = self._db, self.path
        tables = [r[0] for r in db.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        if "results" not in tables:
            if tables:
                raise _not_a_store(path, f"holds other tables ({', '.join(tables)})")
            db.execute("CREATE TABLE results (key TEXT PRIMARY KEY, mesh TEXT, method TEXT, "
                       "row TEXT NOT NULL)")
            db.commit()
            return {}
        columns = tuple(r[1] for r in db.execute("PRAGMA table_info(results)"))
        if columns != STORE_COLUMNS:
            raise _not_a_store(path, f"its results table has the columns {', '.join(columns)}"
                                     f", expected {', '.join(STORE_COLUMNS)}")
        status = db.execute("PRAGMA quick_check").fetchone()[0]
        if status != "ok":
            raise _not_a_store(path, f"the integrity check failed ({status})")
        rows = {}
        for key, text in db.execute("SELECT key, row FROM results"):
            try:
                row = json.loads(text)
            except (TypeError, ValueError):
                raise _not_a_store(path, f"the row {key!r} is not JSON") from None
            if not isinstance(row, dict) or row.get("key") != key:
                raise _not_a_store(path, f"the row {key!r} is not a study row of that key")
            rows[key] = row
        return rows

    def get(self, key: str) -> dict | None:
        return self._rows.get(key)

    def put(self, key: str, row: dict) -> None:
        try:
            with self._db:  # one transaction: the row is there whole or not at all
                self._db.execute("INSERT OR REPLACE INTO results VALUES (?, ?, ?, ?)",
                                 (key, row["mesh"], row["method"], dumps(row)))
        except sqlite3.DatabaseError as exc:  # disk full, read-only: exit 2 naming the file
            raise OSError(errno.EIO, f"cannot write the study store ({exc})",
                          str(self.path)) from None
        self._rows[key] = row

    def __len__(self) -> int:
        return len(self._rows)

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None


def check_study_dir(path: str | os.PathLike) -> Path:
    """Refuse, before any work, a study folder that cannot be used.

    The folder may exist (a study to resume) or not; if not, its parent must
    exist (only the study folder itself is created, never a tree). Nothing is
    created or locked here (a temporary folder probes that files can be made).

    Raises
    ------
    InputError
        One line naming the path and the problem.
    """
    path = check_output_folder(path)
    store = path / STORE_NAME
    if os.path.lexists(store) and not store.is_file():
        raise _not_a_store(store, "is a folder" if store.is_dir() else "is not a file")
    return path


class StudyFolder:
    """A study folder opened for writing by this process alone.

    ``with StudyFolder(path) as study:`` checks the path
    (:func:`check_study_dir`), creates the folder if missing, takes an
    exclusive advisory lock on ``path/.lock`` (``fcntl.flock``, released when
    the block ends or the process dies), opens and checks the store
    (:class:`ResultStore`, as ``study.store``), creates ``occluders/`` and
    removes temporary files a killed run left behind.

    Raises
    ------
    InputError
        If another process holds the lock ("another compare is writing
        ...") or the store is damaged: one line, and the folder is left as
        it was (but for the lock file).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.store: ResultStore | None = None
        self._lock_fd: int | None = None

    @property
    def occluders(self) -> Path:
        return self.path / OCCLUDER_DIR

    def __enter__(self) -> StudyFolder:
        import fcntl

        check_study_dir(self.path)
        try:
            self.path.mkdir(exist_ok=True)
            fd = os.open(self.path / LOCK_NAME, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(exc.filename or self.path)) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise InputError(f"--out {self.path}: another compare is writing this study "
                             f"(it holds {self.path / LOCK_NAME}); wait for it to finish or "
                             "choose another --out") from None
        except OSError as exc:
            os.close(fd)
            raise OSError(exc.errno, f"cannot lock the study ({exc.strerror})",
                          str(self.path / LOCK_NAME)) from None
        self._lock_fd = fd
        try:
            self.store = ResultStore(self.path / STORE_NAME)
            self.occluders.mkdir(exist_ok=True)
            for stale in [*self.path.glob(".*.tmp"), *self.occluders.glob(".*.tmp")]:
                stale.unlink(missing_ok=True)  # a killed run's half-written file
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc) -> None:
        if self.store is not None:
            self.store.close()
            self.store = None
        if self._lock_fd is not None:
            os.close(self._lock_fd)  # releases the flock
            self._lock_fd = None


def study_jobs(meshes: list[str], methods: list[str], settings: StudySettings) -> list[Job]:
    """One job per mesh, method and budget (one budget-less job for unbudgeted methods)."""
    from viscore.generators import get_generator

    jobs = []
    for mesh in meshes:
        for method in methods:
            budgets = settings.budgets if get_generator(method).budgeted else (None,)
            jobs += [Job(mesh, method, b, settings) for b in budgets]
    return jobs


def _die_with_parent(parent: int) -> None:
    """In a worker: ignore SIGINT (the parent stops the pool) and die when the parent dies."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, signal.SIGKILL, 0, 0, 0) != 0:  # 1 = PR_SET_PDEATHSIG
            raise OSError(ctypes.get_errno(), "prctl")
    except (OSError, AttributeError):  # not Linux: watch the parent instead
        def watch() -> None:
            import time

            while os.getppid() == parent:
                time.sleep(0.5)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent:  # the parent died before the prctl
        os._exit(1)


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel every pending job and kill this pool's worker processes now."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:  # our own children, by their handles
        if p.is_alive():
            p.kill()
    for p in processes:
        p.join(timeout=2)


def _local(pending: list[Job], jobs: int, per_job: int, commit: Callable) -> None:
    """Each mesh's views built once in the pool, then its jobs, each given the views.

    ``commit(job, result)`` is called in this process as each job finishes.
    On any exception (Ctrl-C included) the jobs that finished are committed,
    the others cancelled and the workers killed, then the exception goes on.
    """
    groups = _by_mesh(pending)
    pool = ProcessPoolExecutor(max_workers=max(1, min(jobs, len(pending))),
                               initializer=_die_with_parent, initargs=(os.getpid(),))
    running: dict = {}
    try:
        building = {pool.submit(build_views, mesh, settings, per_job): (mesh, settings)
                    for mesh, settings in groups}
        while building or running:
            done, _ = wait([*building, *running], return_when=FIRST_COMPLETED)
            for fut in done:
                if fut in building:
                    views = fut.result()
                    for job in groups[building.pop(fut)]:
                        running[pool.submit(run_job, job, per_job, views)] = job
                else:
                    commit(running[fut], fut.result())
                    del running[fut]
    except BaseException:
        try:
            for fut, job in list(running.items()):  # keep what finished meanwhile
                if fut.done() and not fut.cancelled() and fut.exception() is None:
                    commit(job, fut.result())
        finally:
            _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def _dask(pending: list[Job], scheduler, commit: Callable) -> None:
    """As :func:`_local` on a dask cluster: the views move to the jobs' workers once."""
    from distributed import Client
    from distributed import as_completed as dask_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    futures: dict = {}
    try:
        for (mesh, settings), group in _by_mesh(pending).items():
            views = client.submit(build_views, mesh, settings, None, pure=False)
            futures |= {client.submit(run_job, j, None, views, pure=False): j for j in group}
        for fut in dask_completed(list(futures)):
            commit(futures.pop(fut), fut.result())
    except BaseException:
        if futures:
            client.cancel(list(futures))
        raise
    finally:
        if not isinstance(scheduler, Client):
            client.close()


def run_study(meshes: list[str], methods: list[str], settings: StudySettings,
              out_dir: str | os.PathLike | StudyFolder, *, jobs: int = 1,
              workers: int | None = None, scheduler=None, progress: bool = True,
              on_row: Callable[[dict], None] | None = None) -> list[dict]:
    """Run (or resume) every job; returns the rows in mesh, method, budget order.

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
    """
    if not isinstance(out_dir, StudyFolder):
        with StudyFolder(out_dir) as study:
            return run_study(meshes, methods, settings, study, jobs=jobs, workers=workers,
                             scheduler=scheduler, progress=progress, on_row=on_row)
    from tqdm import tqdm

    study = out_dir
    store = study.store
    todo = study_jobs(meshes, methods, settings)
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

    def commit(job: Job, result: tuple) -> None:
        row, ply = result
        if ply:  # the file first: a stored row always has its occluder
            write_atomic(study.occluders / job.occluder_file, ply)
        store.put(job.key, row)
        rows[job.key] = row
        bar.set_postfix_str(f"{job.mesh}/{job.method}/{job.budget or '-'}")
        bar.update(1)
        if on_row:
            on_row(row)

    try:
        if not pending:
            pass
        elif scheduler is not None:
            _dask(pending, scheduler, commit)
        else:
            _local(pending, jobs, per_job, commit)
    finally:
        bar.close()
    return [rows[j.key] for j in todo]


def write_occluder_glbs(rows: list[dict], study_dir: Path, originals: dict) -> list[Path]:
    """A ``.glb`` beside each kept occluder file (original grey, occluder coloured).

    Written where missing (a resumed study gets those of its earlier rows);
    ``originals`` maps each row's mesh name to its loaded mesh.
    """
    import trimesh

    from .report import write_occluder_glb

    written = []
    for r in rows:
        if not r.get("triangles") or not r.get("occluder_file"):
            continue
        ply = Path(study_dir) / OCCLUDER_DIR / r["occluder_file"]
        glb = ply.with_suffix(".glb")
        if ply.is_file() and not glb.is_file():
            occ = trimesh.load(ply, force="mesh", process=False)
            write_occluder_glb(originals[r["mesh"]], occ, glb)
        if glb.is_file():
            written.append(glb)
    return written


def _as_result(row: dict):
    """The PrecisionRecall of a stored row (for paired comparisons)."""
    from viscore.metrics import OccluderAssessment

    return OccluderAssessment.from_json(row).precision_recall()


def paired_rows(rows: list[dict], reference: str = "qem") -> list[dict]:
    """Each method against ``reference`` on the same mesh and views (paired bootstrap).

    Budgeted methods are paired with the reference at the same budget; the
    others with the reference at its largest budget.
    """
    from viscore.metrics import paired_difference

    out = []
    refs = {(r["mesh"], r["budget"]): r for r in rows if r["method"] == reference}
    for r in rows:
        if r["method"] == reference:
            continue
        ref = refs.get((r["mesh"], r["budget"]))
        if ref is None:
            cands = [v for (m, _), v in refs.items() if m == r["mesh"]]
            ref = max(cands, key=lambda v: v["budget"] or 0, default=None)
        if ref is None or "nt" not in r["per_view"]:
            continue
        d = paired_difference(_as_result(r), _as_result(ref),
                              seed=stream_seed(r["settings"]["seed"], "paired-bootstrap"))
        out.append({"mesh": r["mesh"], "method": r["method"], "budget": r["budget"],
                    "versus": reference, "versus_budget": ref["budget"],
                    "recall_diff": d.recall_diff, "recall_diff_ci": d.recall_diff_ci,
                    "prob_better_recall": d.prob_a_better_recall,
                    "precision_diff": d.precision_diff,
                    "precision_diff_ci": d.precision_diff_ci,
                    "prob_better_precision": d.prob_a_better_precision})
    return out


def paired_markdown(rows: list[dict]) -> str:
    """Paired differences as Markdown."""
    cols = ["mesh", "method", "budget", "versus", "versus_budget", "recall_diff",
            "recall_diff_ci", "prob_better_recall", "precision_diff", "precision_diff_ci",
            "prob_better_precision"]
    head = "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols) + "\n"
    return head + "".join("| " + " | ".join(_fmt(r.get(c)) for c in cols) + " |\n"
                          for r in rows)


def _fmt(value, digits=4) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v, digits) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.{digits}g}" if abs(value) >= 1e4 or 0 < abs(value) < 1e-3 else (
            f"{value:.{digits}f}")
    return str(value)


def table_markdown(rows: list[dict]) -> str:
    """The study table as GitHub Markdown."""
    head = "| " + " | ".join(TABLE_COLUMNS) + " |\n|" + "---|" * len(TABLE_COLUMNS) + "\n"
    return head + "".join("| " + " | ".join(_fmt(r.get(c)) for c in TABLE_COLUMNS) + " |\n"
                          for r in rows)


def table_csv(rows: list[dict]) -> str:
    """The study table as CSV (intervals as two columns each)."""
    import csv
    import io

    cols = []
    for c in TABLE_COLUMNS:
        cols += [c + "_lo", c + "_hi"] if c.endswith("_ci") else [c]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        line = []
        for c in TABLE_COLUMNS:
            v = r.get(c)
            line += (list(v) if v else ["", ""]) if c.endswith("_ci") else [v]
        w.writerow(["" if x is None else x for x in line])
    return buf.getvalue()
