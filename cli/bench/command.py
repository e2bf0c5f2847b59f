"""``viscore bench rays|voxels|evaluate|generate|cull|walks|godot-bake``: figures, never assertions.

The parser and the formatting of the bench command; each benchmark lives in
its own module of :mod:`viscore.cli.bench`.
"""

from __future__ import annotations

import sys
from pathlib import Path

from viscore import InputError, provenance
from viscore._validate import as_positive_int

from .._common import emit, parse_list
from .aabb_skins import bench_generate_aabb_skins
from .core import bench_evaluate, bench_rays, bench_voxels
from .models import BUILTIN_FALLBACK, MODELS_ENV, models_folder


def add_parser(sub, common) -> None:
    p = sub.add_parser("bench", help="print speed figures against same-run references")
    bsub = p.add_subparsers(dest="bench_command", metavar="TARGET")
    bsub.required = True
    r = bsub.add_parser("rays", parents=[common],
                        help="first-hit rays/s of Scene vs bare embreex and Open3D, same rays")
    r.add_argument("--mesh", default="bunny",
                   help="mesh file or built-in scene (default bunny: pymeshlab's, 56k triangles)")
    r.add_argument("--rays", type=int, default=1_000_000,
                   help="incoherent rays, from inside the bounding box (default 1000000)")
    r.add_argument("--res", type=int, default=1024,
                   help="pixels per side of each of the 4 orthographic views of the coherent "
                        "rays (default 1024)")
    r.add_argument("--repeats", type=int, default=7,
                   help="interleaved repeats, the median of each counts (default 7)")
    r.set_defaults(run=run_rays)
    v = bsub.add_parser("voxels", parents=[common], help="voxelization time at 64^3 and 128^3")
    v.add_argument("--mesh", default="bunny")
    v.add_argument("--res", default="64,128",
                   help="voxel resolutions, comma-separated (default 64,128)")
    v.add_argument("--repeats", type=int, default=2, help="best of this many runs (default 2)")
    v.set_defaults(run=run_voxels)
    e = bsub.add_parser("evaluate", parents=[common],
                        help="orbit protocol, bunny vs 64-triangle QEM (target < 15 s)")
    e.add_argument("--mesh", default="bunny")
    e.add_argument("--views", type=int, default=256, help="orbit views (default 256)")
    e.add_argument("--quads", type=int, default=32000, help="quads per view (default 32000)")
    e.add_argument("--res", type=int, default=256, help="pixels per side (default 256)")
    e.add_argument("--budget", type=int, default=64,
                   help="triangles of the first QEM occluder; the next has 4x (default 64)")
    e.add_argument("--rays", type=int, default=500_000,
                   help="rays of the same-run bench rays reference (default 500000)")
    e.set_defaults(run=run_evaluate)
    g = bsub.add_parser("generate", parents=[common], help="generator speed and coverage")
    g.add_argument("method", choices=["aabb-skins", "planar-sections", "hybrid",
                                      "surface-patches", "terrain-drape"])
    g.add_argument("--ablation", default=None, metavar="DIR",
                   help="also run the method's ablations and write their PNGs into this "
                        "existing folder: planar-sections, occlusion measure vs surface area "
                        "(Silvennoinen et al. Fig. 11) and voxel resolution (Fig. 9); hybrid, "
                        "the candidate sets with and without enforcement and the "
                        "metric-guided step (Wu et al. Fig. 11)")
    g.add_argument("--models", default=None, metavar="DIR",
                   help=f"folder of extra benchmark meshes (spot.obj, fandisk.obj, ...); default "
                   f"${MODELS_ENV}, else only the built-in scenes")
    g.add_argument("--table1", action="store_true",
                   help="planar-sections: the paper's Table 1 instead, its five rows beside "
                        "ours, qem's and godot's on stand-ins made here (million-triangle ones "
                        "included: minutes)")
    g.add_argument("--scale", action="store_true",
                   help="planar-sections: its cost against the triangle count instead, an "
                        "open scan at 56k and 16x the triangles beside qem in the same run "
                        "(minutes)")
    g.add_argument("--no-fill-holes", action="store_true",
                   help="hybrid: run it with hole filling off (the hybrid option fill_holes); "
                        "by default the bench also scores filling on against off")
    g.set_defaults(run=run_generate)
    k = bsub.add_parser("cull", parents=[common],
                        help="culling runtimes per frame on one core (targets: frusta < 2 ms, "
                             "depth buffer at 320 x 180 < 5 ms)")
    k.add_argument("--scene", default="city",
                   help="culling scene: city, city-dense or a glTF/GLB file (default city)")
    k.add_argument("--frames", type=int, default=60, help="cameras on the path (default 60)")
    k.add_argument("--repeats", type=int, default=3,
                   help="times each frame is timed, best counts (default 3)")
    k.add_argument("--method", default=None,
                   help="generator of the occluders (default solid-frusta)")
    k.set_defaults(run=run_cull)
    cs = bsub.add_parser("cull-scale", parents=[common],
                         help="cull's time and peak memory on the city tiled n x n "
                              "(n = 1, 2; 4 with --large), as ratios to 1 x 1")
    cs.add_argument("--large", action="store_true",
                    help="also the city tiled 4 x 4 (29,184 objects, 7.5M triangles)")
    cs.add_argument("--frames", type=int, default=4,
                    help="cameras of each walk (default 4)")
    cs.set_defaults(run=run_cull_scale)
    w = bsub.add_parser("walks", parents=[common],
                        help="per level: where the walk stands (eye height, frames standing), "
                             "and with --cull the truth's hidden share and the best "
                             "guaranteed culled share")
    w.add_argument("levels", nargs="+", metavar="LEVEL",
                   help="level files (glTF/GLB, or a single mesh split into objects) or "
                        "built-in culling scenes, as 'viscore cull' takes them")
    w.add_argument("--frames", type=int, default=20,
                   help="frames asked of each walk (default 20)")
    w.add_argument("--up", choices=["x", "y", "z"], default=None,
                   help="up axis of every level (default: guessed for a single mesh, +Y for "
                        "glTF)")
    w.add_argument("--eye-height", type=float, default=None, metavar="H",
                   help="eye height of every level, in its units (default: guessed per level)")
    w.add_argument("--cull", action="store_true",
                   help="also run cull's default runtimes along each walk (minutes per level)")
    w.add_argument("--bounds", default=None,
                   metavar="triangles|meshlets[:T]|auto|box|clusters[:N]",
                   help="with --cull: the occludee bounds, as 'viscore cull --bounds' "
                        "(default as cull's, triangles)")
    w.add_argument("--buffer-scale", type=int, default=None, metavar="N",
                   help="with --cull: depth buffer's screen pixels per buffer pixel along each "
                        "side, as 'viscore cull --buffer-scale' (default 2)")
    w.add_argument("--gap", action="store_true",
                   help="with --cull: sort the best guaranteed runtime's misses (hidden, not "
                        "culled) by cause, against depth buffers of the level's own triangles "
                        "(several times the work)")
    w.set_defaults(run=run_walks)
    gb = bsub.add_parser("godot-bake", parents=[common],
                         help="our godot baseline against Godot's own bake of its occlusion "
                              "demo, triangle for triangle")
    gb.add_argument("--models", default=None, metavar="DIR",
                    help=f"folder holding godot-occlusion-demo/ (or that folder itself); "
                         f"default ${MODELS_ENV}, else ../shared/models beside the repository")
    gb.add_argument("--views", type=int, default=128,
                    help="orbit views of the precision/recall evaluation (default 128)")
    gb.set_defaults(run=run_godot_bake)


#: Labels of the timed variants of ``bench rays``, by key of its ``mrays``.
_RAY_LABELS = {"bare_1": "bare embreex, 1 thread, one run",
               "bare_chunked_1": "bare embreex, 1 thread, {chunk}-ray runs",
               "scene_1": "Scene, 1 worker",
               "scene_all": "Scene, {workers} workers",
               "scene_embreex_1": "Scene on embreex per ray, 1 worker",
               "scene_embreex_all": "Scene on embreex per ray, {workers} workers",
               "open3d_1": "Open3D {version}, 1 thread",
               "open3d_all": "Open3D {version}, {workers} threads"}

#: How Scene traces, by ``scene_tracer`` of ``bench rays``.
_TRACERS = {"packets": "Scene traces Embree packets of 16 rays",
            "embreex": "Scene traces with embreex, one ray at a time"}


def _agreement_text(name: str, a: dict) -> str:
    """One tracer's agreement with Scene (see ``viscore.cli.bench.core._agreement``)."""
    return (f"{name}: max |dt| {a['max_abs_t']:.3g}, {a['hit_miss']:,} hit/miss and "
            f"{a['triangle']:,} triangle differences")


def _paired_text(p: dict | None) -> str:
    """`` [paired x1.02, x0.95-1.10]``: a ratio repeat by repeat (median, min-max), or ''."""
    if not p:
        return ""
    return f" [paired x{p['median']:.2f}, x{p['min']:.2f}-{p['max']:.2f}]"


def rays_text(r: dict) -> str:
    """The human-readable report of :func:`viscore.cli.bench.core.bench_rays`."""
    from .core import BARE_CHUNK_RAYS, RAY_SETS

    w = r["workers"]
    lines = [f"{r['mesh']}: {r['faces']:,} triangles, {w} workers; first-hit Mrays/s, median of "
             f"{r['repeats']} interleaved repeats (fastest in brackets), on the same rays; "
             f"{_TRACERS[r['scene_tracer']]}; ratios of the medians, and [paired: the "
             f"median and range of the ratios repeat by repeat]"]
    what = {"coherent": f"{r['views']} orthographic views of {r['resolution']} x "
                        f"{r['resolution']} px, orbit framing",
            "incoherent": "uniform points in the bounding box, uniform directions"}
    for name in RAY_SETS:
        s = r["sets"][name]
        mr, best, ratio = s["mrays"], s["best_mrays"], s["ratios"]
        notes = {
            "scene_1": f"x{ratio['scene_1_vs_bare_1']:.2f} of bare one run (target >= 0.95)"
                       + (f", x{ratio['scene_1_vs_bare_chunked_1']:.2f} of chunked runs"
                          if "scene_1_vs_bare_chunked_1" in ratio else ""),
            "scene_all": f"x{ratio['scene_all_vs_scene_1']:.2f} of 1 worker (target >= 1.70 "
                         f"on 2 cores)",
        }
        if "scene_embreex_all" in mr:
            notes["scene_1"] += f", x{ratio['scene_1_vs_scene_embreex_1']:.2f} of embreex's"
            notes["scene_all"] += f", x{ratio['scene_all_vs_scene_embreex_all']:.2f} of embreex's"
            notes["scene_embreex_all"] = (f"x{ratio['scene_embreex_all_vs_scene_embreex_1']:.2f}"
                                          f" of 1 worker")
        paired = s.get("paired", {})
        if "scene_all_vs_scene_1" in paired:
            notes["scene_all"] += _paired_text(paired["scene_all_vs_scene_1"])
        if "open3d_all" in mr:
            notes["open3d_1"] = (f"Scene x{ratio['scene_1_vs_open3d_1']:.2f} of it"
                                 + _paired_text(paired.get("scene_1_vs_open3d_1")))
            notes["open3d_all"] = (f"x{ratio['open3d_all_vs_open3d_1']:.2f} of 1 thread; Scene "
                                   f"x{ratio['scene_all_vs_open3d_all']:.2f} of it (target "
                                   f">= 1.00 on 2 cores)"
                                   + _paired_text(paired.get("scene_all_vs_open3d_all")))
        lines.append(f"{name}: {s['rays']:,} rays ({what[name]}, seed {r['seed']}), "
                     f"{s['hit_share']:.1%} hit")
        for key, value in mr.items():
            label = _RAY_LABELS[key].format(chunk=BARE_CHUNK_RAYS, workers=w,
                                            version=r["open3d"])
            note = f"  {notes[key]}" if key in notes else ""
            lines.append(f"  {label:<40} {value:6.2f}  ({best[key]:.2f}){note}")
        if "open3d_1" not in mr:
            lines.append(f"  open3d: {r['open3d']}")
        agree = s["agreement"]
        lines.append("  same hits? " + "; ".join(
            _agreement_text(f"Scene vs {'bare' if k == 'bare' else 'Open3D'}", a)
            for k, a in agree.items()))
    return "\n".join(lines)


def run_rays(args) -> int:
    r = bench_rays(args.mesh, rays=args.rays, resolution=args.res, repeats=args.repeats,
                   seed=args.seed)
    emit({**r, "provenance": provenance()}, args.json, rays_text(r))
    return 0


def run_voxels(args) -> int:
    from viscore import set_workers

    set_workers(1)  # the targets are on one core
    r = bench_voxels(args.mesh, resolutions=parse_list(args.res, int, "--res"),
                     repeats=args.repeats)
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
    r = bench_evaluate(mesh=args.mesh, views=args.views, quads=args.quads, resolution=args.res,
                       budget=args.budget, reference_rays=args.rays, seed=args.seed)
    other = r["seconds"] - r["seconds_rays"] - r["seconds_quads"]
    text = (f"orbit protocol, bunny vs {r['occluder_triangles']}-triangle QEM, {r['views']} "
            f"views x {r['quads']:,} quads at {r['resolution']} px\n"
            f"  wall {r['seconds']:.2f} s (target < 15 s): rays {r['seconds_rays']:.2f} s, "
            f"quads {r['seconds_quads']:.2f} s, other {other:.2f} s\n"
            f"  {r['mrays_per_second']:.2f} Mrays/s in the evaluation vs "
            f"{r['bench_rays_mrays_all']:.2f} Mrays/s in bench rays (same run)\n"
            f"  precision {r['precision']:.4f}, recall {r['recall']:.4f}\n"
            f"  first occluder {r['seconds_first']:.2f} s (original's views + occluder), next "
            f"{r['next_occluder_triangles']}-triangle occluder {r['seconds_next']:.2f} s "
            f"(x{r['next_ratio']:.2f}, target <= 0.50)")
    emit({**r, "provenance": provenance()}, args.json, text)
    return 0


def run_godot_bake(args) -> int:
    from .godot_bake import bench_godot_bake, bench_godot_bake_text

    views = as_positive_int(args.views, "--views", maximum=100_000)
    r = bench_godot_bake(args.models, seed=args.seed, views=views)
    emit({**r, "provenance": provenance()}, args.json, bench_godot_bake_text(r))
    return 0


def run_table1(args) -> int:
    from .table1 import bench_table1, table1_lines

    rows = bench_table1(seed=args.seed)
    emit({"rows": rows, "provenance": provenance()}, args.json, "\n".join(table1_lines(rows)))
    return 0


def run_scale(args) -> int:
    from .scale import bench_scale, scale_lines

    rows = bench_scale(seed=args.seed)
    emit({"rows": rows, "provenance": provenance()}, args.json, "\n".join(scale_lines(rows)))
    return 0


def run_terrain_drape(args) -> int:
    from .terrain_drape import bench_terrain_drape, terrain_drape_lines

    rows = bench_terrain_drape(seed=args.seed)
    emit({"rows": rows, "provenance": provenance()}, args.json,
         "\n".join(terrain_drape_lines(rows)))
    return 0


def run_generate(args) -> int:
    if args.no_fill_holes and args.method != "hybrid":
        raise InputError("--no-fill-holes: only for hybrid (its hole filling)")
    if args.table1 and args.scale:
        raise InputError("--table1, --scale: one at a time")
    if args.table1:
        if args.method != "planar-sections":
            raise InputError("--table1: only for planar-sections (the paper's Table 1)")
        return run_table1(args)
    if args.scale:
        if args.method != "planar-sections":
            raise InputError("--scale: only for planar-sections")
        return run_scale(args)
    if args.method == "planar-sections":
        return _run_generate_planar(args)
    if args.method == "hybrid":
        return _run_generate_hybrid(args)
    if args.ablation is not None:
        raise InputError("--ablation: only for planar-sections and hybrid")
    if args.method == "surface-patches":
        return _run_generate_surface_patches(args)
    if args.method == "terrain-drape":
        return run_terrain_drape(args)
    folder = models_folder(args.models)  # a folder named but missing: InputError, exit 2
    if folder is None and not args.quiet:
        print(f"viscore: no --models and no ${MODELS_ENV}: benchmarking the built-in scenes "
              f"only ({', '.join(BUILTIN_FALLBACK)})", file=sys.stderr)
    r = bench_generate_aabb_skins(folder)
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


def run_cull(args) -> int:
    from .cull import bench_cull, bench_cull_text

    frames = as_positive_int(args.frames, "--frames", maximum=100_000)
    repeats = as_positive_int(args.repeats, "--repeats", maximum=100)
    r = bench_cull(scene=args.scene, frames=frames, repeats=repeats, seed=args.seed,
                   method=args.method)
    emit({**r, "provenance": provenance()}, args.json, bench_cull_text(r))
    return 0


def run_cull_scale(args) -> int:
    from .cull_scale import DEFAULT_SIZES, bench_cull_scale, cull_scale_lines

    frames = as_positive_int(args.frames, "--frames", maximum=10_000)
    sizes = (*DEFAULT_SIZES, 4) if args.large else DEFAULT_SIZES
    r = bench_cull_scale(sizes=sizes, frames=frames, seed=args.seed)
    emit({**r, "provenance": provenance()}, args.json, "\n".join(cull_scale_lines(r)))
    return 0


def run_walks(args) -> int:
    from .walks import bench_walks, bench_walks_text, walk_row_text

    def say(row: dict) -> None:  # each level as it is done: a run of many takes long
        if not (args.quiet or args.json):
            print(walk_row_text(row), file=sys.stderr, flush=True)

    from viscore.culling import DEFAULT_BOUNDS

    if args.bounds is not None and not args.cull:
        raise InputError("--bounds: only with --cull")
    if args.gap and not args.cull:
        raise InputError("--gap: only with --cull")
    if args.buffer_scale is not None and not args.cull:
        raise InputError("--buffer-scale: only with --cull")
    r = bench_walks(args.levels, frames=args.frames, seed=args.seed, up=args.up,
                    eye_height=args.eye_height, cull=args.cull,
                    bounds=DEFAULT_BOUNDS if args.bounds is None else args.bounds,
                    gap=args.gap, progress=say,
                    **({} if args.buffer_scale is None else {"buffer_scale": args.buffer_scale}))
    emit({**r, "provenance": provenance()}, args.json, bench_walks_text(r))
    return 0


def _ablation_folder(text: str | None) -> Path | None:
    """The ``--ablation`` folder, which must exist (nothing is created), or None."""
    if text is None:
        return None
    if not Path(text).is_dir():
        raise InputError(f"--ablation {text}: not an existing folder")
    return Path(text)


def _run_generate_planar(args) -> int:
    from .planar import (
        bench_generate_planar_sections,
        measure_ablation,
        resolution_ablation,
    )

    folder = models_folder(args.models)
    ablation = _ablation_folder(args.ablation)
    r = bench_generate_planar_sections(folder, seed=args.seed)
    b = r["bunny"]
    p = b["paper"]
    lines = [f"planar-sections, bunny at {p['budget']} triangles, {p['voxels']}^3 voxels, "
             f"{r['views']} orbit views: {b['seconds']:.2f} s wall (target < 10 s), "
             f"{b['triangles']} triangles, precision {b['precision']:.4f} (target >= 0.995), "
             f"recall {b['recall']:.4f} (target >= 0.835; paper P {p['precision']} "
             f"R {p['recall']})",
             f"{'mesh':<20} {'planar tris':>11} {'P':>7} {'R':>7} {'godot tris':>10} "
             f"{'P':>7} {'R':>7} {'godot<=':>7} {'P':>7} {'R':>7} {'qem R':>7}"]
    for row in r["scenes"]:
        ps, gd, qm = row["planar_sections"], row["godot"], row["qem"]
        gw = row.get("godot_within")
        within = (f"{'-':>7} {'-':>7} {'-':>7}" if gw is None else
                  f"{gw['triangles']:>7} {gw['precision']:>7.4f} {gw['recall']:>7.4f}")
        lines.append(f"{row['mesh']:<20} {ps['triangles']:>11} {ps['precision']:>7.4f} "
                     f"{ps['recall']:>7.4f} {gd['triangles']:>10} {gd['precision']:>7.4f} "
                     f"{gd['recall']:>7.4f} {within} {qm['recall']:>7.4f}")
    lines.append("godot<=: godot's bake distance raised until it has no more triangles than "
                 "planar sections ('-': its locked borders never get that small)")
    if "hairball_16" in r:
        h = r["hairball_16"]
        g = h.get("godot_within")
        lines.append(f"hairball at 16 triangles (the mesh hides {h['quads_hidden']:.0%} of "
                     f"the quads): {h['triangles']} triangles, precision "
                     f"{h['precision']:.4f}, recall {h['recall']:.4f}; qem "
                     f"{h['qem']['triangles']} triangles R {h['qem']['recall']:.4f}; godot "
                     + ("cannot get to 16 triangles" if g is None else
                        f"{g['triangles']} triangles R {g['recall']:.4f}"))
    if ablation is not None:
        r["measure_ablation"] = measure_ablation(seed=args.seed,
                                                 path=ablation / "planar_measure.png")
        r["resolution_ablation"] = resolution_ablation(seed=args.seed,
                                                       path=ablation / "planar_voxels.png")
        lines.append("measure ablation (recall, OM vs area): " + ", ".join(
            f"{m} {v['om']['recall']:.3f} vs {v['area']['recall']:.3f}"
            for m, v in r["measure_ablation"]["meshes"].items()))
        lines.append("voxel resolution (voxels: P/R): " + ", ".join(
            f"{row['voxels']}: {row['precision']:.3f}/{row['recall']:.3f}"
            for row in r["resolution_ablation"]["rows"]))
        lines.append(f"wrote {ablation / 'planar_measure.png'} and "
                     f"{ablation / 'planar_voxels.png'}")
    emit({**r, "provenance": provenance()}, args.json, "\n".join(lines))
    return 0


def _run_generate_hybrid(args) -> int:
    from .hybrid import bench_generate_hybrid, hybrid_ablation

    folder = models_folder(args.models)
    ablation = _ablation_folder(args.ablation)
    # scored on views of seed --seed + 1; the hybrid fits its own views (seed 0)
    options = {"fill_holes": False} if args.no_fill_holes else {}
    r = bench_generate_hybrid(folder, seed=args.seed + 1, **options)
    st = r["settings"]
    lines = [f"hybrid on the built-in buildings{' and ' + str(folder) if folder else ''}; "
             f"scored on separate jittered volume views (spacing {st['spacing_fraction']:g} of "
             f"the diagonal, {st['resolution']} px, {st['quads']} quads per frustum, seed "
             f"{st['seed']})",
             f"{'mesh':<22} {'faces':>5} {'P':>7} {'R':>7} {'seconds':>7} {'qem R':>7} "
             f"{'godot faces':>11} {'godot R':>7}"]
    for row in r["rows"]:
        lines.append(f"{row['mesh']:<22} {row['faces']:>5} {row['precision']:>7.4f} "
                     f"{row['recall']:>7.4f} {row['seconds']:>7.1f} "
                     f"{row.get('qem_recall', float('nan')):>7.4f} "
                     f"{row.get('godot_faces', 0):>11} "
                     f"{row.get('godot_recall', float('nan')):>7.4f}")
    lines += _hybrid_holes_lines(r["rows"])
    m = r["means"]
    if m:
        faces, p, rec = r["paper"]["hybrid"]
        lines.append(f"means over the built-in buildings: {m['faces']:.1f} faces (target <= "
                     f"{faces}), precision {m['precision']:.4f} (target >= {p}), recall "
                     f"{m['recall']:.4f} (target >= {rec}), {m['seconds']:.1f} s per building "
                     "(target < 60 s)")
    if ablation is not None:
        r["ablation"], more = hybrid_ablation(ablation, args.seed + 1)
        lines += more
    emit({**r, "provenance": provenance()}, args.json, "\n".join(lines))
    return 0


def _hybrid_holes_lines(rows: list[dict]) -> list[str]:
    """The hole-filling table of ``bench generate hybrid``: holes per building, the effect."""
    if not rows:
        return []
    effect = all("patch_fill_recall" in row for row in rows)
    head = f"{'holes (Wu et al. Fig. 6)':<22} {'filled':>6} {'open':>5}  why open"
    if effect:
        head += ("   | patches at N_P: faces/R filled, faces/R not"
                 " | hybrid unfilled at the same budget: faces P R")
    lines = [head]
    for row in rows:
        why = row.get("holes_open_why", {})
        text = ", ".join(f"{v} {k}" for k, v in why.items() if v) or "-"
        line = f"{row['mesh']:<22} {row['holes_filled']:>6} {row['holes_open']:>5}  {text}"
        if effect:
            line += (f"   | {row['patch_fill_faces']}/{row['patch_fill_recall']:.4f}, "
                     f"{row['patch_nofill_faces']}/{row['patch_nofill_recall']:.4f}"
                     f" | {row['nofill_faces']} {row['nofill_precision']:.4f} "
                     f"{row['nofill_recall']:.4f}")
        lines.append(line)
    return lines


def _run_generate_surface_patches(args) -> int:
    from .surface_patches import bench_generate_surface_patches, bench_surface_patches_text

    folder = models_folder(args.models)  # a folder named but missing: InputError, exit 2
    # scored on views of seed --seed + 1, as bench generate hybrid
    r = bench_generate_surface_patches(folder, seed=args.seed + 1)
    emit({**r, "provenance": provenance()}, args.json, bench_surface_patches_text(r))
    return 0
