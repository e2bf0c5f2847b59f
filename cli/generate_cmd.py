"""``viscore generate METHOD MESH -o OUT``: run one registered generator."""

from __future__ import annotations

import logging

from viscore.generators import REGISTRY, get_generator

from viscore import InputError, load_mesh, provenance

from ._common import check_mesh_path, emit, write_mesh

_log = logging.getLogger("viscore")


def add_parser(sub, common) -> None:
    g = sub.add_parser("generate", parents=[common], help="generate an occluder")
    g.add_argument("method", help=f"one of: {', '.join(REGISTRY)}")
    g.add_argument("mesh", help="mesh file or built-in scene name")
    g.add_argument("-o", "--output", required=True, help="occluder mesh file (.ply, .obj, ...)")
    g.add_argument("--budget", type=int, default=None, help="triangle budget")
    g.add_argument("--voxels", type=int, default=None,
                   help="voxels along the longest bounding-box side")
    g.add_argument("--voxel-size", type=float, default=None, help="voxel side, world units")
    g.add_argument("--max-boxes", type=int, default=None, help="aabb-skins: box limit")
    g.add_argument("--fill", type=float, default=None,
                   help="aabb-skins: stop at this share of the inner volume")
    g.add_argument("--min-volume", type=float, default=None,
                   help="aabb-skins: smallest box volume, world units^3")
    g.add_argument("--seed-voxel", choices=["max-volume", "densest"], default=None,
                   help="aabb-skins: largest box over all voxels, or grow from the densest")
    g.set_defaults(run=run_generate)


def run_generate(args) -> int:
    spec = get_generator(args.method)
    check_mesh_path(args.output)
    if spec.experimental:
        _log.warning("%s is experimental: not yet validated", spec.name)
    names = {"budget": "budget", "voxels": "voxels", "voxel_size": "voxel_size",
             "max_boxes": "max_boxes", "fill": "fill", "min_volume": "min_volume",
             "seed_voxel": "seed_voxel"}
    params = {k: getattr(args, a) for a, k in names.items() if getattr(args, a) is not None}
    params["seed"] = args.seed
    mesh = load_mesh(args.mesh)
    try:
        occ = spec.function(mesh, **params)
    except TypeError as exc:  # an option the method does not take
        raise InputError(f"{args.method}: {exc}") from exc
    if occ.triangles == 0:
        raise InputError(f"{args.mesh}: {args.method} produced no triangles "
                         f"({', '.join(f'{k}={v}' for k, v in occ.info.items())})")
    write_mesh(args.output, occ.mesh)
    doc = {"mesh": args.mesh, "output": args.output, **occ.summary(), "seed": args.seed,
           "provenance": provenance()}
    emit(doc, args.json, f"{args.method}: {occ.triangles} triangles in {occ.seconds:.2f} s -> "
         f"{args.output}" + (f" ({occ.info['boxes']} boxes, {occ.info['inside']} inside, "
                             f"fill {occ.info['fill']:.3f})" if "boxes" in occ.info else ""))
    return 0
