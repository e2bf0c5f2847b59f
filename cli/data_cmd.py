"""``viscore data list | export NAME -o FILE``: the built-in scenes."""

from __future__ import annotations

from viscore import InputError, load_mesh, scene_descriptions

from ._common import check_mesh_path, emit, write_atomic, write_mesh


def add_parser(sub, common) -> None:
    p = sub.add_parser("data", help="list or export the built-in scenes")
    dsub = p.add_subparsers(dest="data_command", metavar="ACTION")
    dsub.required = True
    lp = dsub.add_parser("list", parents=[common], help="name the built-in scenes")
    lp.set_defaults(run=run_list)
    ep = dsub.add_parser("export", parents=[common], help="write a built-in scene to a file")
    ep.add_argument("name")
    ep.add_argument("-o", "--output", required=True, help="output file (.ply, .obj, .stl, .glb)")
    ep.set_defaults(run=run_export)


def run_list(args) -> int:
    from viscore.level import culling_scene_descriptions

    scenes = scene_descriptions()
    culling = culling_scene_descriptions()
    width = max(map(len, [*scenes, *culling]))
    text = ("\n".join(f"{k:<{width}}  {v}" for k, v in scenes.items())
            + "\n\nculling scenes (viscore cull; glTF, every mesh node an object):\n"
            + "\n".join(f"{k:<{width}}  {v}" for k, v in culling.items()))
    emit({"scenes": [{"name": k, "description": v} for k, v in scenes.items()],
          "culling_scenes": [{"name": k, "description": v} for k, v in culling.items()]},
         args.json, text)
    return 0


def run_export(args) -> int:
    from viscore.level import culling_scene_names, culling_scene_path

    if args.name in culling_scene_names():  # a glTF scene of objects: the file as shipped
        if check_mesh_path(args.output) != "glb":
            raise InputError(f"{args.output}: {args.name} is a glTF scene of objects; "
                             "export it to a .glb file")
        data = culling_scene_path(args.name).read_bytes()
        write_atomic(args.output, data)
        emit({"name": args.name, "output": args.output, "bytes": len(data)}, args.json,
             f"wrote {args.output} ({len(data):,} bytes)")
        return 0
    if args.name not in scene_descriptions():
        raise InputError(f"{args.name}: not a built-in scene (see 'viscore data list')")
    check_mesh_path(args.output)
    mesh = load_mesh(args.name)
    write_mesh(args.output, mesh)
    emit({"name": args.name, "output": args.output, "triangles": len(mesh.faces)}, args.json,
         f"wrote {args.output} ({len(mesh.faces)} triangles)")
    return 0
