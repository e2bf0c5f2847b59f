"""Built-in scenes: names, one-line descriptions and file paths.

Procedural scenes are PLY files made by ``data/make_scenes.py`` (deterministic,
shipped inside the wheel as ``viscore._scenes``); the sample meshes that ship
inside the pymeshlab wheel are resolved from the installed pymeshlab.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from ._validate import InputError

__all__ = ["scene_names", "scene_path", "scene_descriptions"]

#: Procedural scenes: name -> (file in data/, description).
_PROCEDURAL = {
    "fat-torus": ("fat_torus.ply", "torus with tube radius 0.6 of its major radius; closed"),
    "box-with-hole": ("box_with_hole.ply", "closed hollow box whose front wall has a small hole"),
    "sponge": ("sponge.ply", "Menger sponge, level 2: closed, many through-holes"),
    "terrain": ("terrain.ply", "height field over a square, open (a sheet with hills)"),
    "hairball": ("hairball.ply", "120 thin random tubes through a sphere; many components"),
    "buildings": ("buildings.ply", "four box buildings of different heights on a ground slab"),
    "city-block": ("city_block.ply", "5 x 5 block of towers and walls, loose parts, open bottoms"),
}

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
    elif name in _PYMESHLAB and _pymeshlab_samples() is not None:
        path = _pymeshlab_samples() / _PYMESHLAB[name][0]
    else:
        raise InputError(f"{name}: not a built-in scene (built-in: {', '.join(scene_names())})")
    if not path.is_file():
        raise InputError(f"{name}: built-in scene file is missing at {path}; reinstall viscore")
    return path
