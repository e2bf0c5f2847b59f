"""Comparison studies: every registered method on every mesh, evaluated and stored.

The orchestration of ``viscore compare`` (DESIGN.md data flow: metrics ->
cli for tables, plots, studies). Each (mesh, method, parameters, seed) job
runs generate -> precision/recall -> occlusion measure -> conservativeness,
and its row is committed to the study's SQLite file when it finishes, so a
re-run resumes and a killed run loses nothing that finished.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._common import dumps

#: Columns of the printed and written table, in order.
TABLE_COLUMNS = ["mesh", "method", "triangles", "precision", "precision_ci", "recall",
                 "recall_ci", "occlusion_measure", "occlusion_measure_se",
                 "violation_upper_bound", "seconds"]


@dataclass(frozen=True)
class StudySettings:
    """Evaluation settings shared by every job of a study."""

    protocol: str = "orbit"
    views: int = 128
    quads: int = 16000
    resolution: int = 256
    directions: int = 32
    rays: int = 100_000
    budget: int = 256
    seed: int = 0

    def key(self, mesh: str, method: str) -> str:
        text = json.dumps({"mesh": mesh, "method": method, **self.__dict__}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:24]


def run_job(mesh_name: str, method: str, settings: StudySettings, workers: int | None) -> dict:
    """Generate, evaluate and check one occluder; returns the result row."""
    from generators import get_generator
    from metrics import check_conservative, evaluate, occlusion_measure
    from viscore import load_mesh, set_workers

    set_workers(workers)
    mesh = load_mesh(mesh_name)
    occ = get_generator(method).function(mesh, budget=settings.budget, seed=settings.seed)
    target = occ.mesh if occ.triangles else None
    params = dict(seed=settings.seed, quads=settings.quads, resolution=settings.resolution)
    if settings.protocol == "orbit":
        params["views"] = settings.views
    pr = evaluate(mesh, target, protocol=settings.protocol, **params)
    om = (occlusion_measure(target, directions=settings.directions, resolution=settings.resolution,
                            seed=settings.seed) if target is not None else None)
    cons = check_conservative(mesh, target, rays=settings.rays, seed=settings.seed)
    return {
        "mesh": mesh_name, "method": method, "triangles": occ.triangles,
        "precision": pr.precision, "precision_ci": pr.precision_ci,
        "recall": pr.recall, "recall_ci": pr.recall_ci,
        "occlusion_measure": om.occlusion_measure if om else 0.0,
        "occlusion_measure_se": om.occlusion_measure_se if om else 0.0,
        "violation_rate": cons.violation_rate,
        "violation_upper_bound": cons.violation_upper_bound,
        "seconds": occ.seconds, "seconds_evaluate": pr.seconds,
        "params": occ.params, "info": occ.info,
        "per_view": {"precision": pr.per_view["precision"], "recall": pr.per_view["recall"]},
        "settings": settings.__dict__,
    }


class ResultStore:
    """One SQLite file per study directory; a row per finished job, committed at once."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._db = sqlite3.connect(path)
        self._db.execute("CREATE TABLE IF NOT EXISTS results (key TEXT PRIMARY KEY, "
                         "mesh TEXT, method TEXT, row TEXT NOT NULL)")
        self._db.commit()

    def get(self, key: str) -> dict | None:
        cur = self._db.execute("SELECT row FROM results WHERE key = ?", (key,))
        found = cur.fetchone()
        return json.loads(found[0]) if found else None

    def put(self, key: str, row: dict) -> None:
        with self._db:  # one transaction: the row is there whole or not at all
            self._db.execute("INSERT OR REPLACE INTO results VALUES (?, ?, ?, ?)",
                             (key, row["mesh"], row["method"], dumps(row)))

    def close(self) -> None:
        self._db.close()


def run_study(meshes: list[str], methods: list[str], settings: StudySettings, out_dir: Path, *,
              jobs: int = 1, progress: bool = True) -> list[dict]:
    """Run (or resume) every (mesh, method) job; returns the rows in mesh, method order."""
    from tqdm import tqdm

    out_dir.mkdir(parents=True, exist_ok=True)
    store = ResultStore(out_dir / "results.sqlite")
    todo = [(m, k) for m in meshes for k in methods]
    rows: dict[tuple[str, str], dict] = {}
    pending = []
    for mesh, method in todo:
        found = store.get(settings.key(mesh, method))
        if found is not None:
            rows[(mesh, method)] = found
        else:
            pending.append((mesh, method))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    per_job = max(1, (cores or 1) // jobs)
    bar = tqdm(total=len(todo), initial=len(todo) - len(pending), disable=not progress,
               desc="compare", unit="job")
    try:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = {pool.submit(run_job, m, k, settings, per_job): (m, k) for m, k in pending}
            for fut in as_completed(futures):
                mesh, method = futures[fut]
                row = json.loads(dumps(fut.result()))
                store.put(settings.key(mesh, method), row)
                rows[(mesh, method)] = row
                bar.set_postfix_str(f"{mesh}/{method}")
                bar.update(1)
    finally:
        bar.close()
        store.close()
    return [rows[t] for t in todo]


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


def recall_plot(rows: list[dict], path: Path) -> None:
    """Per-method distribution of per-view recall, one panel per mesh (seed 000 Fig. 11)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    fig, axes = plt.subplots(1, len(meshes), figsize=(3.2 * len(meshes), 3.2), squeeze=False)
    for ax, mesh in zip(axes[0], meshes, strict=True):
        sub = [r for r in rows if r["mesh"] == mesh]
        data = [np.array([v for v in r["per_view"]["recall"] if v is not None]) for r in sub]
        data = [d if len(d) else np.array([np.nan]) for d in data]
        ax.boxplot(data, showfliers=False)
        ax.set_xticks(range(1, len(sub) + 1), [r["method"] for r in sub], rotation=45,
                      fontsize=8)
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(mesh, fontsize=9)
        ax.set_ylabel("recall per view")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    os.replace(tmp, path)
