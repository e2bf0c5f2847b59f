"""The folder of extra benchmark meshes of ``viscore bench generate``.

The extra meshes (spot, fandisk, rocker-arm, stanford-bunny, teapot, as
``NAME.obj``) come from a folder given with ``--models DIR`` or the
``VISCORE_MODELS`` environment variable (:func:`models_folder`). Without
either, the benchmarks use the built-in scenes.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from viscore import InputError

__all__ = ["models_folder", "MODELS_ENV", "MODEL_NAMES", "BUILTIN_FALLBACK"]

#: Environment variable naming the folder of extra benchmark meshes.
MODELS_ENV = "VISCORE_MODELS"

#: Meshes looked for (as ``NAME.obj``) in the models folder: the peer's benchmark set.
MODEL_NAMES = ("spot", "fandisk", "rocker-arm", "stanford-bunny", "teapot")

#: Built-in scenes benchmarked when no models folder is given.
BUILTIN_FALLBACK = ("bunny", "cow")


def models_folder(option: str | os.PathLike | None,
                  environ: Mapping[str, str] | None = None) -> Path | None:
    """The folder of extra benchmark meshes: ``--models``, else ``$VISCORE_MODELS``, else None.

    Parameters
    ----------
    option : str or path-like or None
        The ``--models`` value; takes precedence over the environment.
    environ : mapping, optional
        Environment to read :data:`MODELS_ENV` from. Default ``os.environ``.
        An empty value counts as unset.

    Returns
    -------
    folder : Path or None
        None when neither names a folder (the caller then uses the built-in
        scenes and says so).

    Raises
    ------
    InputError
        If the folder named is not an existing directory (a folder given
        explicitly is never silently replaced by other meshes).
    """
    environ = os.environ if environ is None else environ
    if option is not None and str(option) != "":
        value, where = option, "--models"
    elif environ.get(MODELS_ENV):
        value, where = environ[MODELS_ENV], MODELS_ENV
    else:
        return None
    folder = Path(value).expanduser()
    if not folder.is_dir():
        raise InputError(f"{where} {value}: no such folder of benchmark meshes")
    return folder


def building_sources(models: str | os.PathLike | None, *, demo_room: bool = False) -> dict:
    """Benchmark buildings by name: the built-in ones, and those in ``models``.

    From ``models``: ``kenney/*.glb`` as ``kenney/<stem>``, ``building*.glb`` by
    stem and, with ``demo_room``, ``godot-occlusion-demo/room.glb`` as
    ``godot-demo/room``. A folder that is missing or holds none of them is
    refused.
    """
    from viscore import scene_group

    sources: dict = {name: name for name in scene_group("buildings")}
    if models is None:
        return sources
    folder = Path(models)
    if not folder.is_dir():
        raise InputError(f"models {folder}: no such folder of benchmark meshes")
    found = {f"kenney/{p.stem}": p for p in sorted((folder / "kenney").glob("*.glb"))}
    found |= {p.stem: p for p in sorted(folder.glob("building*.glb"))}
    room = folder / "godot-occlusion-demo" / "room.glb"
    if demo_room and room.is_file():
        found["godot-demo/room"] = room
    if not found:
        extra = ", godot-occlusion-demo/room.glb" if demo_room else ""
        raise InputError(f"models {folder}: holds no kenney/*.glb, building*.glb{extra}")
    return sources | found
