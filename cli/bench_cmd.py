"""``viscore bench rays|voxels|evaluate|generate``: figures, never assertions."""

from __future__ import annotations

from viscore import provenance
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
    e = bsub.add_parser("evaluate", parents=[common],
                        help="orbit protocol, bunny vs 64-triangle QEM (target < 15 s)")
    e.set_defaults(run=run_evaluate)
    g = bsub.add_parser("generate", parents=[common], help="generator speed and coverage")
    g.add_argument("method", choices=["aabb-skins"])
    g.add_argument("--models", default="../shared/models",
                   help="folder of benchmark meshes (default ../shared/models)")
    g.set_defaults(run=run_generate)


def run_rays(args) -> int:
    r = bench_rays(args.mesh, rays=args.rays, seed=args.seed)
    text = (f"{r['mesh']}, {r['rays']:,} first-hit rays\n"
            f"  bare embreex, 1 thread : {r['bare_mrays_1']:.2f} Mrays/s\n"
            f"  Scene, 1 worker        : {r['scene_mrays_1']:.2f} Mrays/s  "
            f"(x{r['ratio_vs_bare']:.2f} of bare, target >= 0.90)\n"
            f"  Scene, {r['workers']} workers       : {r['scene_mrays_all']:.2f} Mrays/s  "
            f"(x{r['scaling']:.2f} of 1 worker, target >= 1.8 on 2 cores)")
    emit({**r, "provenance": provenance()}, args.json, text)
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
    emit({**r, "provenance": provenance()}, args.json, "\n".join(lines))
    return 0


def run_evaluate(args) -> int:
    from viscore.generators.benchmarks import bench_evaluate

    r = bench_evaluate(seed=args.seed)
    other = r["seconds"] - r["seconds_rays"] - r["seconds_quads"]
    text = (f"orbit protocol, bunny vs {r['occluder_triangles']}-triangle QEM, {r['views']} "
            f"views x {r['quads']:,} quads at {r['resolution']} px\n"
            f"  wall {r['seconds']:.2f} s (target < 15 s): rays {r['seconds_rays']:.2f} s, "
            f"quads {r['seconds_quads']:.2f} s, other {other:.2f} s\n"
            f"  {r['mrays_per_second']:.2f} Mrays/s in the evaluation vs "
            f"{r['bench_rays_mrays_all']:.2f} Mrays/s in bench rays (same run)\n"
            f"  precision {r['precision']:.4f}, recall {r['recall']:.4f}")
    emit({**r, "provenance": provenance()}, args.json, text)
    return 0


def run_generate(args) -> int:
    from viscore.generators.benchmarks import bench_generate_aabb_skins

    r = bench_generate_aabb_skins(args.models)
    lines = [f"aabb-skins on {r['source']}; peer (melt) at diag/128: "
             f"{r['peer_seconds_128'][0]}-{r['peer_seconds_128'][1]} s to 80%",
             f"{'mesh':<18} {'voxel':<9} {'boxes':>5} {'tris':>5} {'volume':>7} {'peer':>6} "
             f"{'fill':>6} {'inside':<10} {'seconds':>7}"]
    for row in r["rows"]:
        peer = "-" if row["peer_volume_share"] is None else f"{row['peer_volume_share']:.3f}"
        lines.append(f"{row['mesh']:<18} {row['voxel_size']:<9} {row['boxes']:>5} "
                     f"{row['triangles']:>5} {row['volume_share']:>7.3f} {peer:>6} "
                     f"{row['fill']:>6.3f} {row['inside']:<10} {row['seconds']:>7.3f}")
    emit({**r, "provenance": provenance()}, args.json, "\n".join(lines))
    return 0
