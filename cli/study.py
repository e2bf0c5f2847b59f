"""Comparison studies: every registered method on every mesh, evaluated and stored.

The orchestration of ``viscore compare`` (the data flow: metrics ->
cli for tables, plots, studies). The original's views
(:class:`viscore.metrics.ReferenceViews`) are built once per mesh and
settings and handed to every job of that mesh; each (mesh, method, budget,
settings, seed) job generates its occluder and assesses it with
:func:`viscore.metrics.assess_occluder` (precision/recall, occlusion measure,
conservativeness). Its row is committed to the study's SQLite file, and its occluder written
under ``occluders/``, when it finishes: a re-run resumes, and a killed run
loses nothing that finished. Jobs run in a local process pool, or on a
dask.distributed cluster with ``scheduler``; each job is deterministic given
its settings, so both give identical rows.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ._common import dumps, write_atomic

#: Columns of the printed and written table, in order.
TABLE_COLUMNS = ["mesh", "method", "budget", "triangles", "precision", "precision_ci", "recall",
                 "recall_ci", "occlusion_measure", "occlusion_measure_se",
                 "violation_upper_bound", "seconds"]

#: Views shown in the silhouette plots (seed 000, Figure 7).
SILHOUETTE_VIEWS = 3


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
        return f"{safe}__{self.method}__{self.budget or 'any'}__{self.key[:8]}.ply"


def view_settings(settings: StudySettings) -> dict:
    """Keywords of :class:`viscore.metrics.ReferenceViews` for a study's settings."""
    kw = {"protocol": settings.protocol, "seed": settings.seed, "quads": settings.quads,
          "resolution": settings.resolution}
    if settings.protocol == "orbit":
        kw["views"] = settings.views
    return kw


def build_views(mesh: str, settings: StudySettings, workers: int | None = None):
    """The original's views of one mesh, built once and shared by all its jobs."""
    from viscore.metrics import ReferenceViews

    from viscore import load_mesh, set_workers

    set_workers(workers)
    return ReferenceViews(load_mesh(mesh), **view_settings(settings))


def run_job(job: Job, workers: int | None = None, views=None) -> tuple[dict, bytes]:
    """Generate one occluder and assess it; returns the row and the occluder PLY.

    ``views`` are the mesh's :class:`viscore.metrics.ReferenceViews` for the
    job's settings (built here when not given).
    """
    import trimesh
    from viscore.generators import get_generator
    from viscore.metrics import assess_occluder

    from viscore import set_workers

    s = job.settings
    set_workers(workers)
    views = views if views is not None else build_views(job.mesh, s, workers)
    params = {"seed": s.seed} | ({"budget": job.budget} if job.budget else {})
    occ = get_generator(job.method).function(views.mesh, **params)
    assessed = assess_occluder(views, occ, directions=s.directions, rays=s.rays)
    row = {"key": job.key, "mesh": job.mesh, "budget": job.budget, **assessed.to_json(),
           "method": job.method, "occluder_file": job.occluder_file, "settings": asdict(s)}
    ply = trimesh.exchange.ply.export_ply(occ.mesh, encoding="binary") if occ.triangles else b""
    return json.loads(dumps(row)), ply


def _row_is_current(row: dict) -> bool:
    """Whether a stored row holds every field of today's assessment (older rows are redone)."""
    from dataclasses import fields

    from viscore.metrics import OccluderAssessment

    return all(f.name in row for f in fields(OccluderAssessment))


def _by_mesh(pending: list[Job]) -> dict:
    """Pending jobs grouped by (mesh, settings): one set of reference views each."""
    groups: dict = {}
    for job in pending:
        groups.setdefault((job.mesh, job.settings), []).append(job)
    return groups


class ResultStore:
    """One SQLite file per study directory; a row per finished job, committed at once."""

    def __init__(self, path: Path) -> None:
        self._db = sqlite3.connect(path)
        self._db.execute("CREATE TABLE IF NOT EXISTS results (key TEXT PRIMARY KEY, "
                         "mesh TEXT, method TEXT, row TEXT NOT NULL)")
        self._db.commit()

    def get(self, key: str) -> dict | None:
        found = self._db.execute("SELECT row FROM results WHERE key = ?", (key,)).fetchone()
        return json.loads(found[0]) if found else None

    def put(self, key: str, row: dict) -> None:
        with self._db:  # one transaction: the row is there whole or not at all
            self._db.execute("INSERT OR REPLACE INTO results VALUES (?, ?, ?, ?)",
                             (key, row["mesh"], row["method"], dumps(row)))

    def close(self) -> None:
        self._db.close()


def study_jobs(meshes: list[str], methods: list[str], settings: StudySettings) -> list[Job]:
    """One job per mesh, method and budget (one budget-less job for unbudgeted methods)."""
    from viscore.generators import get_generator

    jobs = []
    for mesh in meshes:
        for method in methods:
            budgets = settings.budgets if get_generator(method).budgeted else (None,)
            jobs += [Job(mesh, method, b, settings) for b in budgets]
    return jobs


def _local(pending: list[Job], jobs: int, per_job: int) -> Iterator[tuple[Job, tuple]]:
    """Each mesh's views built once in the pool, then its jobs, each given the views."""
    groups = _by_mesh(pending)
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        building = {pool.submit(build_views, mesh, settings, per_job): (mesh, settings)
                    for mesh, settings in groups}
        running: dict = {}
        while building or running:
            done, _ = wait([*building, *running], return_when=FIRST_COMPLETED)
            for fut in done:
                if fut in building:
                    views = fut.result()
                    for job in groups[building.pop(fut)]:
                        running[pool.submit(run_job, job, per_job, views)] = job
                else:
                    yield running.pop(fut), fut.result()


def _dask(pending: list[Job], scheduler) -> Iterator[tuple[Job, tuple]]:
    """As :func:`_local` on a dask cluster: the views move to the jobs' workers once."""
    from distributed import Client
    from distributed import as_completed as dask_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        futures = {}
        for (mesh, settings), group in _by_mesh(pending).items():
            views = client.submit(build_views, mesh, settings, None, pure=False)
            futures |= {client.submit(run_job, j, None, views, pure=False): j for j in group}
        for fut in dask_completed(list(futures)):
            yield futures[fut], fut.result()
    finally:
        if not isinstance(scheduler, Client):
            client.close()


def run_study(meshes: list[str], methods: list[str], settings: StudySettings, out_dir: Path, *,
              jobs: int = 1, scheduler=None, progress: bool = True,
              on_row: Callable[[dict], None] | None = None) -> list[dict]:
    """Run (or resume) every job; returns the rows in mesh, method, budget order.

    ``scheduler`` is a dask.distributed address (or Client); None runs a local
    process pool of ``jobs`` processes.
    """
    from tqdm import tqdm

    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "occluders").mkdir(exist_ok=True)  # write_atomic creates no folders
    store = ResultStore(out_dir / "results.sqlite")
    todo = study_jobs(meshes, methods, settings)
    rows: dict[str, dict] = {}
    pending = []
    for job in todo:
        found = store.get(job.key)
        if found is not None and _row_is_current(found) and (
                not found.get("triangles")
                or (out_dir / "occluders" / job.occluder_file).is_file()):
            rows[job.key] = found
        else:
            pending.append(job)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    per_job = max(1, (cores or 1) // jobs)
    bar = tqdm(total=len(todo), initial=len(todo) - len(pending), disable=not progress,
               desc="compare", unit="job")
    results = _dask(pending, scheduler) if scheduler is not None else _local(pending, jobs,
                                                                            per_job)
    try:
        for job, (row, ply) in results:
            if ply:  # the file first: a stored row always has its occluder
                write_atomic(out_dir / "occluders" / job.occluder_file, ply)
            store.put(job.key, row)
            rows[job.key] = row
            if on_row:
                on_row(row)
            bar.set_postfix_str(f"{job.mesh}/{job.method}/{job.budget or '-'}")
            bar.update(1)
    finally:
        results.close()  # stops the pool or the dask client now, not at garbage collection
        bar.close()
        store.close()
    return [rows[j.key] for j in todo]


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
        d = paired_difference(_as_result(r), _as_result(ref), seed=r["settings"]["seed"])
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


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    write_atomic(path, buf.getvalue())


def _largest_budget(rows: list[dict]) -> list[dict]:
    """One row per (mesh, method): the largest budget."""
    best: dict = {}
    for r in rows:
        k = (r["mesh"], r["method"])
        if k not in best or (r["budget"] or 0) > (best[k]["budget"] or 0):
            best[k] = r
    return list(best.values())


def _panels(plt, count: int, size: float = 3.0):
    cols = min(3, count)
    rows = -(-count // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(size * cols + 0.4, size * rows), squeeze=False)
    for ax in axes.flat[count:]:
        ax.set_axis_off()
    return fig, axes.flat


def recall_plot(rows: list[dict], path: Path) -> None:
    """Per-method distribution of per-view recall, one panel per mesh (seed 000 Fig. 11)."""
    plt = _pyplot()
    rows = _largest_budget(rows)
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    fig, axes = _panels(plt, len(meshes))
    for ax, mesh in zip(axes, meshes, strict=False):
        sub = [r for r in rows if r["mesh"] == mesh]
        data = [np.array([v for v in r["per_view"]["recall"] if v is not None]) for r in sub]
        data = [d if len(d) else np.array([np.nan]) for d in data]
        ax.boxplot(data, showfliers=False)
        ax.set_xticks(range(1, len(sub) + 1), [r["method"] for r in sub], fontsize=7)
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(Path(mesh).stem, fontsize=9)
        ax.set_ylabel("recall per view", fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def budget_plot(rows: list[dict], path: Path) -> None:
    """Recall (solid) and precision (dashed) against occluder triangles, a panel per mesh."""
    plt = _pyplot()
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig, axes = _panels(plt, len(meshes))
    for ax, mesh in zip(axes, meshes, strict=False):
        for c, method in enumerate(methods):
            sub = sorted((r for r in rows if r["mesh"] == mesh and r["method"] == method),
                         key=lambda r: r["triangles"])
            if not sub:
                continue
            x = [max(1, r["triangles"]) for r in sub]
            for key, style in (("recall", "o-"), ("precision", "s--")):
                y = [np.nan if r[key] is None else r[key] for r in sub]
                ax.plot(x, y, style, ms=3, color=f"C{c}",
                        label=method if key == "recall" else None)
        ax.set_xscale("log")
        ax.minorticks_off()
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(Path(mesh).stem, fontsize=9)
        ax.set_xlabel("occluder triangles", fontsize=8)
    axes[0].legend(fontsize=7, title="recall -, precision --", title_fontsize=7)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def silhouette_plot(rows: list[dict], out_dir: Path, mesh: str, path: Path, *,
                    resolution: int = 160, seed: int = 0) -> None:
    """Seed 000 Figure 7 colour coding for a few views of one mesh, one row per method."""
    import trimesh
    from viscore.metrics import silhouette_image

    from viscore import directions_uniform, load_mesh

    plt = _pyplot()
    sub = [r for r in _largest_budget(rows) if r["mesh"] == mesh]
    original = load_mesh(mesh)
    dirs = directions_uniform(SILHOUETTE_VIEWS, seed=seed)
    fig, axes = plt.subplots(len(sub), SILHOUETTE_VIEWS, figsize=(2.2 * SILHOUETTE_VIEWS,
                                                                 2.2 * len(sub)), squeeze=False)
    for i, r in enumerate(sub):
        file = out_dir / "occluders" / r["occluder_file"]
        occ = trimesh.load(file, force="mesh") if r["triangles"] and file.is_file() else None
        for j, d in enumerate(dirs):
            axes[i, j].imshow(silhouette_image(original, occ, d, resolution=resolution))
            axes[i, j].set_axis_off()
        axes[i, 0].set_title(f"{r['method']} ({r['triangles']} tris)", fontsize=8, loc="left")
    fig.suptitle(f"{Path(mesh).stem}: black original only, yellow both, blue occluder only",
                 fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
