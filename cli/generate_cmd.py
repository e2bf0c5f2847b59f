"""``viscore generate METHOD MESH -o OUT [options]``: run one registered generator."""

from __future__ import annotations

import argparse
import json
import logging
import numbers
from pathlib import Path

from viscore import InputError, load_mesh, provenance
from viscore._atomic import FileSet
from viscore._validate import as_seed
from viscore.exchange import mesh_bytes
from viscore.generators import REGISTRY, generate, get_generator, hierarchy_files

from ._common import check_output_file, emit, occluder_bytes

_log = logging.getLogger("viscore")

_BUDGET_HELP = "triangle budget, a positive integer"


def _option_type(option):
    """argparse ``type`` that parses and range-checks one declared option."""
    def convert(text: str):
        try:
            return option.parse(text)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix(f"{option.flag}: ")) from None
    convert.__name__ = option.name  # argparse names the type in some messages
    return convert


def _budget(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def add_parser(sub, common) -> None:
    g = sub.add_parser(
        "generate", help="generate an occluder",
        description="Generate an occluder with one registered method; "
                    "'viscore generate METHOD --help' lists the method's options.")
    methods = g.add_subparsers(dest="method", metavar="METHOD", title="methods")
    methods.required = True
    for name, spec in REGISTRY.items():
        budget_help = (_BUDGET_HELP if spec.budgeted else
                       _BUDGET_HELP + "; this method does not take one, and warns when its "
                       "result exceeds it")
        plugin = f"{spec.plugin[0]} {spec.plugin[1]}" if spec.plugin else None
        m = methods.add_parser(
            name, parents=[common],
            help=(spec.description + (" [experimental]" if spec.experimental else "")
                  + (f" [plugin: {plugin}]" if plugin else "")).replace("%", "%%"),
            description=f"{name}: {spec.description}."
                        + (" Conservative on closed meshes." if spec.conservative else "")
                        + (" Experimental: not yet validated." if spec.experimental else "")
                        + (f" Plugin method from the {plugin} package." if plugin else ""))
        m.add_argument("mesh", help="mesh file or built-in scene name")
        m.add_argument("-o", "--output", required=True,
                       help="occluder file: a mesh (.ply, .obj, .off, .stl), Godot's .tres "
                            "(ArrayOccluder3D) or .tscn (one OccluderInstance3D), or .glb "
                            "(its node <MESH>-occonly)")
        m.add_argument("--budget", type=_budget, default=None, help=budget_help)
        for option in spec.options:
            if option.type is bool:  # a switch pair: --conservative / --no-conservative
                m.add_argument(option.flag, dest=option.name,
                               action=argparse.BooleanOptionalAction, default=argparse.SUPPRESS,
                               help=option.describe().replace("%", "%%"))
                continue
            m.add_argument(option.flag, dest=option.name, type=_option_type(option),
                           default=argparse.SUPPRESS, help=option.describe().replace("%", "%%"),
                           metavar="|".join(option.choices) if option.choices
                           else option.name.upper())
        m.set_defaults(run=run_generate)


def _format_info(info: dict) -> str:
    parts = []
    for key, value in info.items():
        if isinstance(value, bool):
            parts.append(f"{key}={str(value).lower()}")
        elif isinstance(value, numbers.Integral):
            parts.append(f"{key}={int(value)}")
        elif isinstance(value, numbers.Real):
            parts.append(f"{key}={float(value):.4g}")
        elif isinstance(value, str):
            parts.append(f"{key}={value}")
    return f" ({', '.join(parts)})" if parts else ""


def run_generate(args) -> int:
    spec = get_generator(args.method)
    check_output_file(args.output, "-o", occluder=True)  # OUT and the parts beside it, first
    params = {o.name: getattr(args, o.name) for o in spec.options if hasattr(args, o.name)}
    params["seed"] = as_seed(args.seed, "--seed")
    if args.budget is not None:
        params["budget"] = args.budget
    params = spec.check_params(params, flags=True)  # before any work
    spec.check_options(params)  # the generator's rules across options, before the mesh loads
    if spec.experimental:
        _log.warning("%s is experimental: not yet validated", spec.name)
    mesh = load_mesh(args.mesh)
    occ = generate(spec.name, mesh, **params)
    if occ.triangles == 0:
        raise InputError(f"{args.mesh}: {args.method} produced no triangles"
                         f"{_format_info(occ.info)}")
    output = Path(args.output)
    parts, extra = _part_files(occ, output)
    with FileSet(output.parent) as files:  # OUT and its parts: all or none
        for name, data in parts.items():
            files.write(name, data)
        files.write(output.name, occluder_bytes(output, occ.mesh, name=Path(args.mesh).stem))
    doc = {"mesh": args.mesh, "output": args.output, **occ.summary(), "seed": params["seed"],
           **extra, "provenance": provenance()}
    files = "".join(f"; {key}: {_files_text(value)}" for key, value in extra.items())
    emit(doc, args.json, f"{args.method}: {occ.triangles} triangles in {occ.seconds:.2f} s -> "
         f"{args.output}{_format_info(occ.info)}{files}")
    return 0


def _files_text(value) -> str:
    if isinstance(value, dict):
        return f"{value['file']} + {len(value['meshes'])} node meshes"
    return ", ".join(item["file"] for item in value)


def _part_files(occ, output: Path) -> tuple[dict[str, bytes], dict]:
    """The files of the parts an occluder carries, to write beside ``output``; their JSON entries.

    ``parts["hierarchy"]``: ``STEM.hierarchy.json`` and one PLY per node
    (:func:`hierarchy_files`). ``parts["lods"]``, a list of
    ``{"distance", "mesh", "voxels"}``: ``STEM.lod<i>.ply`` per entry.
    Returns ``({file name: bytes}, {"hierarchy": ..., "lods": ...})``.
    """
    files: dict[str, bytes] = {}
    extra = {}
    if "hierarchy" in occ.parts:
        tree = hierarchy_files(occ.parts["hierarchy"], output.stem)
        files.update(tree)
        path = output.parent / f"{output.stem}.hierarchy.json"
        nodes = json.loads(tree[path.name])["nodes"]
        extra["hierarchy"] = {"file": str(path), "nodes": len(nodes),
                              "meshes": [str(output.parent / n["mesh"]) for n in nodes
                                         if n["mesh"] is not None]}
    if "lods" in occ.parts:
        lods = []
        for i, lod in enumerate(occ.parts["lods"]):
            path = output.parent / f"{output.stem}.lod{i}.ply"
            files[path.name] = mesh_bytes(lod["mesh"], "ply", name=path)
            lods.append({"file": str(path), "distance": lod["distance"],
                         "voxels": lod.get("voxels"), "voxel_size": lod.get("voxel_size"),
                         "triangles": len(lod["mesh"].faces)})
        extra["lods"] = lods
    return files, extra
