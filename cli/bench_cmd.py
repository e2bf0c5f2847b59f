"""``viscore bench rays|voxels|evaluate|generate``: figures, never assertions."""

from __future__ import annotations

from viscore.benchmarks import bench_rays, bench_voxels

from ._common import emit


def add_parser(sub, common) -> None:
    p = sub.add_parser("bench", help="print speed figures against same-run references")
    bsub = p.add_subparsers(dest="bench_command", metavar="TARGET")
    bsub.required = True
    r = bsub.add_parser("rays", parents=[common], help="first-hit rays/s vs bare embreex")
    r.add_argument("--mesh", default="bunny")
    r.add_argument("--rays", type=int, default=1_000_000)
    r.set_defaults(run=run_rays)
    v = bsub.add_parser("voxels", parents=[common], help="voxelization time at 64^3 and 128^3")
    v.add_argument("--mesh", default="bunny")
    v.set_defaults(run=run_voxels)


def run_rays(args) -> int:
    r = bench_rays(args.mesh, rays=args.rays, seed=args.seed)
    text = (f"{r['mesh']}, {r['rays']:,} first-hit rays\n"
            f"  bare embreex, 1 thread : {r['bare_mrays_1']:.2f} Mrays/s\n"
            f"  Scene, 1 worker        : {r['scene_mrays_1']:.2f} Mrays/s  "
            f"(x{r['ratio_vs_bare']:.2f} of bare, target >= 0.90)\n"
            f"  Scene, {r['workers']} workers       : {r['scene_mrays_all']:.2f} Mrays/s  "
            f"(x{r['scaling']:.2f} of 1 worker, target >= 1.8 on 2 cores)")
    emit(r, args.json, text)
    return 0


def run_voxels(args) -> int:
    from viscore import set_workers

    set_workers(1)  # the targets are on one core
    r = bench_voxels(args.mesh)
    lines = [f"{r['mesh']}: surface + flood fill + inner (1 core); parity votes"]
    targets = {64: 2.0, 128: 6.0}
    for row in r["per_resolution"]:
        tgt = targets.get(row["resolution"])
        lines.append(f"  {row['resolution']:>4}^3: {row['seconds_flood']:.2f} s flood"
                     + (f" (target < {tgt:.0f} s)" if tgt else "")
                     + f", {row['seconds_parity']:.2f} s parity; {row['surface_voxels']:,} "
                     f"surface, {row['solid_voxels']:,} solid voxels")
    emit(r, args.json, "\n".join(lines))
    return 0
