"""``viscore compare [MESH ...]``: every registered method on every mesh, with intervals.

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (orbit protocol, sec. 6.1).
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (volume protocol, sec. 3.2).
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
import os
from dataclasses import asdict
from pathlib import Path

from viscore import InputError, cpu_cores, load_mesh, provenance
from viscore._validate import as_positive_int, as_seed, check_memory
from viscore.generators import (
    REGISTRY,
    check_method,
    get_generator,
    parse_method,
    plugin_versions,
    prepare_kernels,
    report_kinds,
)

from ._common import check_jobs, check_utf8_name, dumps, emit, parse_list, write_atomic
from .study.report import CULLING_COLUMNS, write_occluder_glbs, write_report
from .study.runner import (
    JOBS_PER_CORE,
    StudySettings,
    connect_scheduler,
    resolve_occluder_files,
    run_study,
    study_memory,
)
from .study.store import StudyFolder, check_study_dir
from .study.tables import paired_markdown, paired_rows, table_csv, table_markdown

_log = logging.getLogger(__name__)

#: Pixels per side accepted by ``--res``.
MAX_RESOLUTION = 4096

#: Meshes of a study given none: a closed solid with a hole, a scan and a game building,
#: so that ``viscore compare`` runs every method in about two minutes: 128 s on an idle
#: 2-core machine, 247 CPU-s (median of 2, paired with b42f7fb's 156 s, 286 CPU-s: x0.82
#: wall), and 174 s, 334 CPU-s, on a fresh venv's first run (numba compiling), at 2cee924;
#: at 1b0eb5e 255 s, 464 CPU-s, and 309 s, 575 CPU-s. At 188aa8b, first runs 104 s, 195
#: CPU-s (paired with eae0d7e's 108 s: x0.96), warm runs about 80 s, 150 CPU-s.
DEFAULT_SCENES = ("fat-torus", "bunny", "building-house")

#: Frames of the culling column's walk through the built-in city.
CULLING_FRAMES = 24

#: Most jobs run at once given no ``--jobs``: one per core up to this, fewer when the
#: memory estimate does not fit. On 2 cores the default study keeps both busy (the
#: culling column's pieces among the jobs, :class:`_CullingInPool`).
DEFAULT_JOBS = 4


def _default_jobs(settings: StudySettings, originals: dict, pending: int) -> int:
    """Jobs given no ``--jobs``: one per core, at most :data:`DEFAULT_JOBS` and the
    pending jobs, fewer while the study's memory estimate would not fit (one at least:
    its refusal then names ``--jobs 1``)."""
    jobs = max(1, min(cpu_cores(), DEFAULT_JOBS, pending))
    while jobs > 1:
        try:
            check_memory(study_memory(settings, originals, jobs), "")
        except InputError:
            jobs -= 1
        else:
            break
    return jobs


def add_parser(sub, common) -> None:
    c = sub.add_parser("compare", parents=[common],
                       help="run every method on every mesh and compare (the main job)")
    c.add_argument("meshes", nargs="*", metavar="MESH",
                   help="mesh files or built-in scenes (default: "
                        + ", ".join(DEFAULT_SCENES) + "; 'viscore data list' names them all)")
    default_methods = [n for n, s in REGISTRY.items() if s.inputs == "any"]
    c.add_argument("--methods", default=",".join(default_methods),
                   help=f"comma-separated (default: all of {', '.join(default_methods)}; "
                        "methods for height fields only when named: "
                        + (", ".join(n for n, s in REGISTRY.items() if s.inputs != "any")
                           or "none") + "); a method with options fixed, "
                        "NAME:option=value[:option=value...], runs as a method of its own "
                        "(planar-sections:chain=greedy:reduce=area)")
    c.add_argument("--budget", default="64,256",
                   help="triangle budget(s), comma-separated (default 64,256)")
    c.add_argument("--protocol", choices=["orbit", "volume"], default="orbit")
    c.add_argument("--views", type=int, default=128, help="orbit views (default 128)")
    c.add_argument("--quads", type=int, default=16000, help="quads per view (default 16000)")
    c.add_argument("--res", type=int, default=256,
                   help=f"pixels per side, at most {MAX_RESOLUTION} (default 256)")
    c.add_argument("--rays", type=int, default=100_000,
                   help="conservativeness rays (default 100000)")
    c.add_argument("--jobs", type=int, default=None,
                   help=f"parallel jobs (processes), at most {JOBS_PER_CORE} per core "
                        f"(default one per core, at most {DEFAULT_JOBS}, fewer when the "
                        "memory needed would not fit)")
    c.add_argument("--versus", default=None,
                   help="reference method of the paired comparisons, one of --methods "
                        "(default: qem when it runs, else no paired table)")
    c.add_argument("--scheduler", default=None,
                   help="dask.distributed scheduler address: run the jobs on that cluster")
    c.add_argument("--culling", action=argparse.BooleanOptionalAction, default=True,
                   help="culling column: each method's occluders feed a conservative depth "
                        "buffer along the built-in city's camera path (default on)")
    c.add_argument("--culling-methods", default=None,
                   help="methods of the culling column, comma-separated (default: the "
                        "compared methods except heavy ones: "
                        + (", ".join(n for n, s in REGISTRY.items() if s.heavy) or "none")
                        + ")")
    c.add_argument("--culling-frames", type=int, default=CULLING_FRAMES,
                   help=f"frames of that walk (default {CULLING_FRAMES})")
    c.add_argument("--occluder-files", action="append", default=[], metavar="NAME=PATH",
                   help="occluders made by other tools, assessed as the method row NAME "
                        "(repeatable): PATH a file every mesh uses (any format "
                        "viscore.load_occluder reads: .tscn, .tres, .occ, -occonly .glb, a "
                        "mesh), or a folder holding <mesh>.<ext> per mesh, or "
                        "<mesh>.<budget>.<ext> per budget; double-sided, not conservative "
                        "unless the file says so")
    c.add_argument("--out", default="viscore-study",
                   help="study folder; its parent must exist (default ./viscore-study)")
    c.set_defaults(run=run_compare)


def _methods(text: str, flag: str = "--methods") -> list[str]:
    """Canonical method labels: registered names, or variants ``name:option=value:...``
    (:func:`viscore.generators.parse_method`), each once, and each checked as its
    generator checks its options (:func:`viscore.generators.check_method`)."""
    names = [m.strip() for m in str(text).split(",") if m.strip()]
    if not names:
        raise InputError(f"{flag}: expected comma-separated methods, got {text!r} "
                         f"(registered: {', '.join(REGISTRY)})")
    return list(dict.fromkeys(check_method(m, flag).label for m in names))


def _file_specs(items: list[str]) -> list[tuple[str, str]]:
    """``--occluder-files NAME=PATH`` items as (NAME, PATH) pairs."""
    specs = []
    for item in items:
        name, sep, path = str(item).partition("=")
        if not sep or not name.strip() or not path.strip():
            raise InputError(f"--occluder-files {item!r}: expected NAME=PATH")
        specs.append((name.strip(), path.strip()))
    return specs


def _versus(text: str | None, methods: list[str], files: list[str] = ()) -> str | None:
    if text is None:
        return "qem" if "qem" in methods else None
    if text in files:  # an occluder-files row is a reference like any method
        return text
    text = parse_method(text, "--versus").label
    if text not in methods:
        raise InputError(f"--versus: {text} is not among the methods run "
                         f"({', '.join([*methods, *files])}); add it to --methods")
    return text


def _budgets(text: str, methods: list[str]) -> tuple[int, ...]:
    """The budgets, each checked against every budgeted method's registry entry.

    :meth:`viscore.generators.GeneratorSpec.check_params` refuses what a
    method cannot meet (``aabb-skins`` needs 12 triangles, one box), here
    rather than in a worker after the study started.
    """
    budgets = tuple(sorted(set(parse_list(text, int, "--budget"))))
    for method in methods:
        spec = get_generator(method)
        if not spec.budgeted:
            continue
        for budget in budgets:
            spec.check_params({"budget": budget}, flags=True)
    return budgets



def run_compare(args) -> int:
    # 1. every argument, before any work and before the study folder is touched
    methods = _methods(args.methods)
    seed = as_seed(args.seed, "--seed")
    specs = _file_specs(getattr(args, "occluder_files", None) or [])
    versus = _versus(args.versus, methods, [name for name, _ in specs])
    views = as_positive_int(args.views, "--views")
    quads = as_positive_int(args.quads, "--quads")
    res = as_positive_int(args.res, "--res", maximum=MAX_RESOLUTION)
    rays = as_positive_int(args.rays, "--rays")
    jobs = None if args.jobs is None else check_jobs(args.jobs, args.scheduler)
    workers = getattr(args, "workers", None)
    workers = None if workers is None else as_positive_int(workers, "--workers")
    culling_frames = as_positive_int(args.culling_frames, "--culling-frames", maximum=10_000)
    culling_methods = ([m for m in methods if not get_generator(m).heavy]
                       if args.culling_methods is None
                       else _methods(args.culling_methods, "--culling-methods"))
    out = check_study_dir(args.out)
    budgets = _budgets(args.budget, methods)
    settings = StudySettings(protocol=args.protocol, views=views, quads=quads, resolution=res,
                             rays=rays, budgets=budgets, seed=seed)
    meshes = list(dict.fromkeys(args.meshes or DEFAULT_SCENES))
    for m in meshes:  # the study stores its rows by the name (SQLite: UTF-8 text)
        check_utf8_name(m, "MESH")
    originals = {m: load_mesh(m) for m in meshes}
    # every occluder file found and read now: a missing or bad one leaves no folder behind
    files = resolve_occluder_files(specs, meshes, methods=methods)
    pending = len(meshes) * len(methods) * len(budgets) + len(files)
    if jobs is None:
        jobs = 1 if args.scheduler is not None else _default_jobs(settings, originals, pending)
    if args.scheduler is None:
        n_jobs = min(jobs, pending)
        check_memory(study_memory(settings, originals, n_jobs),
                     f"--jobs {jobs} --views {views} --quads {quads} --res {res} --rays {rays}")
    # 2. the study, in a folder this process alone writes (the cluster reached first)
    if args.scheduler is None:  # the kernels compiled once, before the processes fork
        prepare_kernels()
    held: list = []  # the jobs' and the culling column's log records, said once at the end
    with connect_scheduler(args.scheduler) as client, StudyFolder(out) as study:
        figures = _Figures(out, meshes, seed, originals)
        # the culling column: work of the local pool, or beside a cluster's jobs
        column: _CullingInPool | _CullingBeside | None = None
        if args.culling and culling_methods:
            column_kind = _CullingInPool if args.scheduler is None else _CullingBeside
            column = column_kind(culling_methods, out, frames=culling_frames, seed=seed,
                                 quiet=args.quiet or args.json)
        try:
            rows = run_study(meshes, methods, settings, study, jobs=jobs, workers=workers,
                             scheduler=client, progress=not (args.quiet or args.json),
                             originals=originals, files=files, on_records=held.extend,
                             extra=column.units() if column is not None else (),
                             on_jobs_done=figures.start)
            paired = paired_rows(rows, versus) if versus else []
            culling = column.result() if column is not None else []
            held.extend(column.records if column is not None else [])
        finally:  # each kind of warning once, with its count (all of them with --verbose)
            if column is not None:
                column.stop()
            report_kinds(held, labels=list(dict.fromkeys([*methods, *culling_methods])))
        # plugin methods: their distribution and version beside the toolkit's
        plugins = plugin_versions(methods)
        doc = {"settings": asdict(settings), "rows": rows, "paired": paired,
               "provenance": provenance() | ({"plugins": plugins} if plugins else {})}
        md = table_markdown(rows)
        if paired:
            md += (f"\nPaired against {versus} on the same views (difference, 95% bootstrap "
                   "interval, bootstrap probability of being better):\n\n"
                   + paired_markdown(paired))
        if culling:
            doc["culling"] = {"scene": "city", "frames": culling_frames, "bounds": "auto",
                              "rows": culling}
            md += (f"\nCulling on the built-in city ({culling_frames} frames at 640 x 360; each "
                   "method's occluders feed a conservative depth buffer; objects are tested as "
                   "`viscore cull` tests them by default, `--bounds auto`; false culls are "
                   "objects culled yet visible in the ray-cast object-id image):\n\n"
                   + _culling_markdown(culling))
        write_atomic(out / "results.json", dumps(doc).encode())
        write_atomic(out / "results.csv", table_csv(rows).encode())
        write_atomic(out / "results.md", md.encode())
        images = figures.result(rows)
        write_report(out, rows, paired_rows=paired, settings=asdict(settings),
                     provenance=doc["provenance"], images=images, culling_rows=culling)
    emit(doc, args.json, md + f"\nintervals: 95% bootstrap over views; wrote {out}/results."
         "{csv,json,md}, report.html (open it in a browser), recall.png, budget.png, "
         f"silhouettes_*.png, and a .glb beside each occluder in {out}/occluders/ "
         "(original grey, occluder coloured)")
    return 0


class _Figures:
    """The study's figures and occluder GLBs, drawn in a thread as soon as every job is in
    (the culling column's last work may still run in the pool meanwhile)."""

    def __init__(self, out: Path, meshes: list[str], seed: int, originals: dict) -> None:
        self.out, self.meshes, self.seed, self.originals = out, meshes, seed, originals
        self._thread = None
        self._answer: tuple = ("none", None)

    def start(self, rows: list[dict]) -> None:
        """Begin drawing ``rows`` (called once, by the study, when its jobs are in)."""
        import threading

        def draw() -> None:
            try:
                self._answer = ("done", self._draw(rows))
            except BaseException as exc:  # raised in the main thread by result()
                self._answer = ("error", exc)

        self._thread = threading.Thread(target=draw, name="viscore-figures", daemon=True)
        self._thread.start()

    def _draw(self, rows: list[dict]) -> dict[str, str]:
        images = _plots(rows, self.out, self.meshes, self.seed)
        write_occluder_glbs(rows, self.out, self.originals)
        return images

    def result(self, rows: list[dict]) -> dict[str, str]:
        """The figures' captions and files (drawn now if they were not started)."""
        if self._thread is None:
            return self._draw(rows)
        self._thread.join()
        kind, value = self._answer
        if kind == "error":
            raise value
        return value


def _plots(rows: list[dict], out: Path, meshes: list[str], seed: int) -> dict[str, str]:
    """The study's figures (:mod:`viscore.metrics.plots`); returns caption -> file in ``out``."""
    from viscore.metrics import budget_plot, recall_plot, silhouette_plot

    recall_plot(rows, out / "recall.png")
    budget_plot(rows, out / "budget.png")
    images = {"Recall per view, each method at its largest budget": "recall.png",
              "Recall (top) and precision as 1 - P on a log axis (bottom) against occluder "
              "triangles": "budget.png"}
    for mesh in meshes[:2]:
        name = f"silhouettes_{Path(mesh).stem}.png"
        silhouette_plot(rows, out, mesh, out / name, seed=seed)
        images[f"Silhouettes of {Path(mesh).stem}: black original only, yellow both, "
               "blue occluder only"] = name
    return images


def _culling_key(methods: list[str], frames: int, seed: int) -> dict:
    """What ``out/culling.json`` is kept for: a column of other settings is computed again."""
    return {"methods": methods, "frames": frames, "seed": seed, "bounds": "auto",
            "version": provenance().get("viscore")}


def _cached_culling(methods: list[str], out: Path, *, frames: int, seed: int
                    ) -> list[dict] | None:
    """The rows kept in ``out/culling.json`` for these settings, else None."""
    try:
        cached = json.loads((out / "culling.json").read_text())
        if cached.get("key") == _culling_key(methods, frames, seed):
            return cached["rows"]
    except (OSError, ValueError, AttributeError, KeyError, TypeError):
        pass
    return None


def _culling_rows(methods: list[str], column: dict) -> list[dict]:
    return [{"method": m, **{k: column[m][k] for k in ("culled_share", "false_culls",
                                                       "conservative", "overhead_ms")}}
            for m in methods]


def _culling_child(conn, parent: int, methods: list[str], frames: int, seed: int,
                   hold: bool) -> None:
    """In the culling column's own process: the column, its progress and its held records
    sent up ``conn`` (:class:`_CullingBeside`)."""
    from viscore._jobs import worker_init
    from viscore.generators import call_held, portable
    from viscore.generators.levels import culling_column

    worker_init(parent)
    try:
        def progress(done: int, total: int, what: str) -> None:
            conn.send(("progress", done, total, what))

        if hold:
            column, records = call_held(culling_column, methods, frames=frames, seed=seed,
                                        progress=progress)
        else:
            column, records = culling_column(methods, frames=frames, seed=seed,
                                             progress=progress), []
        conn.send(("done", column, portable(records)))
    except BaseException as exc:  # handed to the parent, which raises it
        try:
            conn.send(("error", exc))
        except Exception:  # an exception that does not pickle: its text
            conn.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))
    finally:
        conn.close()


class _CullingColumn:
    """What both ways of running the culling column share: its settings, the rows kept
    in ``out/culling.json`` for them (None until computed) and its held log records."""

    def __init__(self, methods: list[str], out: Path, *, frames: int, seed: int) -> None:
        self.methods, self.out, self.frames, self.seed = methods, out, frames, seed
        self.rows = _cached_culling(methods, out, frames=frames, seed=seed)
        self.records: list = []

    def units(self) -> list:
        """Work for the study's own pool (none unless the column runs there)."""
        return []

    def _keep(self, column: dict, records: list) -> None:
        """The column's rows and records, from a worker's answer; written to
        ``out/culling.json``."""
        from viscore.generators import restored

        self.records = restored(records)
        self.rows = _culling_rows(self.methods, column)
        write_atomic(self.out / "culling.json",
                     dumps({"key": _culling_key(self.methods, self.frames, self.seed),
                            "rows": self.rows}).encode())


class _CullingBeside(_CullingColumn):
    """The culling column beside a cluster's jobs (``--scheduler``), one row per method,
    kept in ``out/culling.json``. A local study runs it in its own pool instead
    (:class:`_CullingInPool`).

    Computed once per (methods, frames, seed, viscore version): running the
    study again reuses the file, as the study store reuses finished jobs.
    Otherwise it is computed in a process of its own, started here (before the
    study's pool, so nothing but this thread runs when it forks) and running
    beside the study's jobs: the column is the same call on the same seed, so
    the same rows (its ``overhead_ms`` is a time, as the study's seconds are);
    the two share the cores instead of waiting for each other. Its log
    records come back held (:func:`viscore.generators.call_held`), to be said
    once with the study's at the end, unless ``--verbose`` says them as they
    come; its progress is a bar of its own under the study's.
    """

    def __init__(self, methods: list[str], out: Path, *, frames: int, seed: int,
                 quiet: bool) -> None:
        super().__init__(methods, out, frames=frames, seed=seed)
        self._process = None
        if self.rows is not None:
            return
        import multiprocessing
        import threading

        from tqdm import tqdm

        if not quiet:
            _log.info("culling column: %s on the built-in city, %d frames, beside the "
                      "study's jobs", ", ".join(methods), frames)
        hold = not logging.getLogger("viscore").isEnabledFor(logging.DEBUG)
        ctx = multiprocessing.get_context("fork")
        receive, send = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_culling_child, name="viscore-culling-column",
                                    args=(send, os.getpid(), methods, frames, seed, hold),
                                    daemon=True)
        self._process.start()
        send.close()
        self._bar = tqdm(desc="culling column", unit="step", disable=quiet, position=1,
                         leave=False)
        self._answer: tuple = ("error", RuntimeError(
            "the culling column's process ended without an answer"))
        self._reader = threading.Thread(target=self._read, args=(receive,), daemon=True)
        self._reader.start()

    def _read(self, receive) -> None:
        """In a thread: the child's progress onto the bar, then its answer."""
        try:
            while True:
                message = receive.recv()
                if message[0] != "progress":
                    self._answer = message
                    return
                _, done, total, what = message
                self._bar.total = total
                self._bar.set_postfix_str(what)
                self._bar.update(done - self._bar.n)
        except (EOFError, OSError):
            return
        finally:
            receive.close()

    def result(self) -> list[dict]:
        """The rows (waiting for the process), kept in ``out/culling.json``."""
        if self.rows is not None:
            return self.rows
        self._reader.join()
        self._process.join()
        self._bar.close()
        kind, *payload = self._answer
        if kind == "error":
            raise payload[0]
        self._keep(*payload)
        return self.rows

    def stop(self) -> None:
        """End the process now (the study failed or was interrupted); idempotent."""
        if self._process is not None and self._process.is_alive():
            self._process.kill()
            self._process.join(timeout=2)
            self._bar.close()


#: Expected cost of a piece of the culling column's occluders (one method on one distinct
#: mesh of the city; a joined method's piece is all of them), in the units of the study's
#: task costs (seconds): ``culling_column`` profiled in one process on main at b42f7fb
#: (planar-sections 70 s, surface-patches 16.3 s, solid-frusta 15.7 s and aabb-skins
#: 7.6 s over the city's 17 meshes). Only the order matters.
_PIECE_COST = {"planar-sections": 4.1, "surface-patches": 16.3, "solid-frusta": 0.9,
               "aabb-skins": 0.45}
#: Cost of a piece of any other method (qem, godot, bbox, original).
_OTHER_PIECE_COST = 0.1
#: Cost of the column once its occluders are in: the depth buffers set up (22 s) and the
#: frames (14 s). Each piece counts it too: it waits for the last piece.
_SIMULATION_COST = 36.0


def _column_piece_task(method: str, mesh_ids: tuple[int, ...], seed: int) -> dict:
    """In a worker: one piece of the culling column's occluders, its records portable."""
    from viscore.generators import portable
    from viscore.generators.levels import column_piece

    return {key: (occ, portable(records))
            for key, (occ, records) in column_piece(method, mesh_ids, seed=seed).items()}


def _column_task(methods: list[str], frames: int, seed: int, made: dict) -> tuple:
    """In a worker: the culling column from its pieces' occluders, its records held."""
    from viscore.generators import call_held, portable, restored
    from viscore.generators.levels import culling_column

    made = {m: {key: (occ, restored(records)) for key, (occ, records) in pieces.items()}
            for m, pieces in made.items()}
    column, records = call_held(culling_column, methods, frames=frames, seed=seed, made=made)
    return column, portable(records)


class _CullingInPool(_CullingColumn):
    """The culling column, one row per method, as work of the study's own pool.

    Kept in ``out/culling.json`` as :class:`_CullingBeside` keeps it. Its
    occluders are made piece by piece (:func:`viscore.generators.levels.column_pieces`:
    a method on a distinct mesh) by the workers that run the study's jobs,
    each taken when its cost is the largest ready (:data:`_PIECE_COST`, the
    column's frames counted in: they wait for the last piece); then one
    worker runs the column's frames on them. Both cores stay busy to the end
    instead of a process of its own finishing alone; the rows are the ones
    :func:`culling_column` gives in one process.
    """

    def __init__(self, methods: list[str], out: Path, *, frames: int, seed: int,
                 quiet: bool) -> None:
        super().__init__(methods, out, frames=frames, seed=seed)
        self._made: dict = {m: {} for m in dict.fromkeys(methods)}
        self._left = 0
        self._bar = None
        if self.rows is not None:
            return
        from tqdm import tqdm

        from viscore.generators.levels import column_pieces

        self._pieces = column_pieces(methods)
        self._left = len(self._pieces)
        if not quiet:
            _log.info("culling column: %s on the built-in city, %d frames, in the study's "
                      "pool", ", ".join(methods), frames)
        self._bar = tqdm(desc="culling column", unit="step", disable=quiet, position=1,
                         leave=False, total=len(self._pieces) + 1)

    def units(self) -> list:
        """The pieces, as the pool's work (none when the rows were kept)."""
        from .study.runner import Unit

        if self.rows is not None:
            return []
        return [Unit(cost=_PIECE_COST.get(m.split(":", 1)[0], _OTHER_PIECE_COST)
                     + _SIMULATION_COST, fn=_column_piece_task, args=(m, ids, self.seed),
                     done=functools.partial(self._piece_done, m))
                for m, ids in self._pieces]

    def _piece_done(self, method: str, result: dict) -> list:
        from .study.runner import Unit

        self._made[method].update(result)
        self._left -= 1
        self._bar.set_postfix_str(method)
        self._bar.update(1)
        if self._left:
            return []
        self._bar.set_postfix_str("frames")
        return [Unit(cost=_SIMULATION_COST, fn=_column_task,
                     args=(self.methods, self.frames, self.seed, self._made),
                     done=self._column_done)]

    def _column_done(self, result: tuple) -> list:
        self._keep(*result)
        self._bar.update(1)
        return []

    def result(self) -> list[dict]:
        """The rows, once the pool ran the column."""
        if self.rows is None:
            raise RuntimeError("the culling column's work did not run")
        return self.rows

    def stop(self) -> None:
        """Close the progress bar; idempotent."""
        if self._bar is not None:
            self._bar.close()


def _culling_markdown(rows: list[dict]) -> str:
    head = ("| " + " | ".join(h for _, h in CULLING_COLUMNS) + " |\n|"
            + "---|" * len(CULLING_COLUMNS) + "\n")
    body = []
    for r in rows:
        cells = [r["method"], f"{r['culled_share']:.3f}", str(r["false_culls"]),
                 "yes" if r["conservative"] else "no", f"{r['overhead_ms']:.1f}"]
        body.append("| " + " | ".join(cells) + " |\n")
    return head + "".join(body)
