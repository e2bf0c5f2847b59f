"""Built-in scenes: names, one-line descriptions and file paths.

Procedural scenes are PLY files made by ``data/make_scenes.py`` (deterministic,
shipped inside the wheel as ``viscore._scenes``); the sample meshes that ship
inside the pymeshlab wheel are resolved from the installed pymeshlab.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from ._validate import InputError

__all__ = ["scene_names", "scene_path", "scene_descriptions", "scene_group"]

#: Procedural scenes: name -> (file in data/, description).
_PROCEDURAL = {
    "fat-torus": ("fat_torus.ply", "torus with tube radius 0.6 of its major radius; closed"),
    "box-with-hole": ("box_with_hole.ply", "closed hollow box whose front wall has a small hole"),
    "sponge": ("sponge.ply", "Menger sponge, level 2: closed, many through-holes"),
    "terrain": ("terrain.ply", "height field over a square, open (a sheet with hills)"),
    "hairball": ("hairball.ply", "550 curly strands (thin closed tubes) in a ball: opaque "
                 "core, fuzzy rim (the paper's HAIRBALL); 40.7k triangles"),
    "city-block": ("city_block.ply", "5 x 5 block of towers and walls, loose parts, open bottoms"),
}

#: Game-style buildings (loose thin wall panels, open doors and windows, interiors):
#: name -> (file in data/, description). Made by ``building_<style>`` in make_scenes.py.
_BUILDINGS = {
    "building-house": ("building_house.ply", "two-storey house, gable roof, chimney, porch, "
                       "stairs; 1.4k triangles"),
    "building-apartment": ("building_apartment.ply", "four-storey block, corner pillars, "
                           "ledges, balconies, roof railing; 7.6k triangles"),
    "building-tower": ("building_tower.ply", "eight-storey tower open at the bottom, ledges, "
                       "stairs, water tank on the roof; 8.1k triangles"),
    "building-warehouse": ("building_warehouse.ply", "hall open at the bottom, roller-door "
                           "opening, trusses, mezzanine, crates; 2.1k triangles"),
    "building-church": ("building_church.ply", "chapel open at the bottom, buttresses, pews, "
                        "bell tower with ladder and spire; 2.8k triangles"),
    "building-shop": ("building_shop.ply", "shop with an arcade on columns, sign board, "
                      "shelves, parapet and railing; 4.0k triangles"),
    "building-lshaped": ("building_lshaped.ply", "L-shaped, open at the bottom, gabled and "
                         "flat-roofed wings joined by archways; 4.5k triangles"),
    "building-cottage": ("building_cottage.ply", "cottage as game kits export it: every flat "
                         "side its own vertices, one-sided roof sheets; 0.96k triangles"),
}
_PROCEDURAL.update(_BUILDINGS)

#: Sample meshes inside the pymeshlab wheel: name -> (file, description).
_PYMESHLAB = {
    "bunny": ("bunny.obj", "Stanford bunny, 56k faces (pymeshlab sample)"),
    "cow": ("cow.obj", "cow, 5.8k faces (pymeshlab sample)"),
    "airplane": ("airplane.obj", "airplane, thin open parts (pymeshlab sample)"),
    "bone": ("bone.ply", "bone scan (pymeshlab sample)"),
}


def _procedural_dir() -> Path:
    """Folder of the procedural scene files: inside the wheel, else the checkout's data/."""
    here = Path(__file__).resolve().parent
    packaged = here / "_scenes"  # the wheel maps data/ to viscore/_scenes/
    if (packaged / "make_scenes.py").is_file():
        return packaged
    return here.parent / "data"


def _pymeshlab_samples() -> Path | None:
    spec = importlib.util.find_spec("pymeshlab")
    if spec is None or spec.origin is None:
        return None
    folder = Path(spec.origin).parent / "tests" / "sample_meshes"
    return folder if folder.is_dir() else None


def scene_descriptions() -> dict[str, str]:
    """Name -> one-line description of every built-in scene, procedural first.

    Examples
    --------
    >>> "fat-torus" in scene_descriptions()
    True
    """
    out = {name: desc for name, (_, desc) in _PROCEDURAL.items()}
    if _pymeshlab_samples() is not None:
        out.update({name: desc for name, (_, desc) in _PYMESHLAB.items()})
    return out


def scene_names() -> list[str]:
    """Names of the built-in scenes, procedural first."""
    return list(scene_descriptions())


def scene_path(name: str) -> Path:
    """Path of the file behind a built-in scene.

    Raises
    ------
    InputError
        If ``name`` is not a built-in scene, or its file is missing.
    """
    if name in _PROCEDURAL:
        path = _procedural_dir() / _PROCEDURAL[name][0]
    elif name in _PYMESHLAB and (samples := _pymeshlab_samples()) is not None:
        path = samples / _PYMESHLAB[name][0]
    else:
        raise InputError(f"{name}: not a built-in scene (built-in: {', '.join(scene_names())})")
    if not path.is_file():
        raise InputError(f"{name}: built-in scene file is missing at {path}; reinstall viscore")
    return path


#: Named groups of built-in scenes.
_GROUPS = ("buildings", "procedural", "samples")


def scene_group(group: str) -> list[str]:
    """Names of the built-in scenes in a group, in a fixed order.

    Parameters
    ----------
    group : {'buildings', 'procedural', 'samples'}
        ``'buildings'``: the game-style buildings (loose thin wall panels, open
        doors and windows, interiors), the default scenes of building occluder
        methods; ``'procedural'``: every scene made by ``data/make_scenes.py``
        (buildings included); ``'samples'``: the pymeshlab sample meshes
        (empty if pymeshlab is not installed).

    Returns
    -------
    names : list of str
        Scene names accepted by :func:`scene_path` and :func:`viscore.load_mesh`.

    Raises
    ------
    InputError
        If ``group`` is not one of the groups above.

    Examples
    --------
    >>> scene_group("buildings")[0]
    'building-house'
    """
    if group == "buildings":
        return list(_BUILDINGS)
    if group == "procedural":
        return list(_PROCEDURAL)
    if group == "samples":
        return list(_PYMESHLAB) if _pymeshlab_samples() is not None else []
    raise InputError(f"group: expected one of {', '.join(_GROUPS)}, got {group!r}")
