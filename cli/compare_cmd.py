"""``viscore compare [MESH ...]``: every registered method on every mesh, with intervals."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from viscore.generators import REGISTRY

from viscore import InputError, load_mesh, provenance, scene_names
from viscore._validate import as_positive_int

from ._common import dumps, emit, parse_list, write_atomic
from .study import (
    StudySettings,
    budget_plot,
    paired_markdown,
    paired_rows,
    recall_plot,
    run_study,
    silhouette_plot,
    table_csv,
    table_markdown,
)


def add_parser(sub, common) -> None:
    c = sub.add_parser("compare", parents=[common],
                       help="run every method on every mesh and compare (the main job)")
    c.add_argument("meshes", nargs="*", metavar="MESH",
                   help="mesh files or built-in scenes (default: the built-in scenes)")
    c.add_argument("--methods", default=",".join(REGISTRY),
                   help=f"comma-separated (default: all of {', '.join(REGISTRY)})")
    c.add_argument("--budget", default="64,256",
                   help="triangle budget(s), comma-separated (default 64,256)")
    c.add_argument("--protocol", choices=["orbit", "volume"], default="orbit")
    c.add_argument("--views", type=int, default=128, help="orbit views (default 128)")
    c.add_argument("--quads", type=int, default=16000, help="quads per view (default 16000)")
    c.add_argument("--res", type=int, default=256, help="pixels per side (default 256)")
    c.add_argument("--rays", type=int, default=100_000, help="conservativeness rays")
    c.add_argument("--jobs", type=int, default=1, help="parallel jobs (processes)")
    c.add_argument("--versus", default="qem",
                   help="reference method of the paired comparisons (default qem)")
    c.add_argument("--scheduler", default=None,
                   help="dask.distributed scheduler address: run the jobs on that cluster")
    c.add_argument("--out", default="viscore-study",
                   help="study directory (default ./viscore-study)")
    c.set_defaults(run=run_compare)


def run_compare(args) -> int:
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in REGISTRY]
    if unknown or not methods:
        raise InputError(f"--methods: unknown {', '.join(unknown) or '(none given)'} "
                         f"(registered: {', '.join(REGISTRY)})")
    meshes = args.meshes or scene_names()
    for m in meshes:  # refuse bad input before any work
        load_mesh(m)
    settings = StudySettings(protocol=args.protocol, views=as_positive_int(args.views, "views"),
                             quads=as_positive_int(args.quads, "quads"),
                             resolution=as_positive_int(args.res, "res", maximum=4096),
                             rays=as_positive_int(args.rays, "rays"),
                             budgets=tuple(sorted(set(parse_list(args.budget, int, "--budget")))),
                             seed=args.seed)
    out = Path(args.out)
    rows = run_study(meshes, methods, settings, out, jobs=as_positive_int(args.jobs, "jobs"),
                     scheduler=args.scheduler, progress=not (args.quiet or args.json))
    paired = paired_rows(rows, args.versus) if args.versus in methods else []
    doc = {"settings": asdict(settings), "rows": rows, "paired": paired,
           "provenance": provenance()}
    write_atomic(out / "results.json", dumps(doc).encode())
    write_atomic(out / "results.csv", table_csv(rows).encode())
    md = table_markdown(rows)
    if paired:
        md += (f"\nPaired against {args.versus} on the same views (difference, 95% bootstrap "
               "interval, bootstrap probability of being better):\n\n" + paired_markdown(paired))
    write_atomic(out / "results.md", md.encode())
    recall_plot(rows, out / "recall.png")
    budget_plot(rows, out / "budget.png")
    for mesh in meshes[:2]:
        silhouette_plot(rows, out, mesh, out / f"silhouettes_{Path(mesh).stem}.png",
                        seed=args.seed)
    emit(doc, args.json, md + f"\nintervals: 95% bootstrap over views; wrote {out}/results."
         "{csv,json,md}, recall.png, budget.png and silhouettes_*.png")
    return 0

