"""The culling runtimes a level's occluders feed, and compare's culling column.

Shadow frusta (Papaioannou et al. 2006 [1]_), a depth buffer per method
(occluder skins [2]_, secs. 5-6), fed by a hierarchy's cut (Silvennoinen et al.
2014 [3]_, sec. 5).

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8.
.. [2] "Occluder Skins" (occluder generation from axis-aligned boxes for a
   hierarchical-occlusion-map culler; authors and venue not in the text we
   have), sec. 5-6.
.. [3] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
"""

from __future__ import annotations

import functools
import logging
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from viscore import InputError
from viscore._validate import as_positive_int
from viscore.constants import DEFAULT_REDUCTION
from viscore.level.scene_graph import SceneObjects
from viscore.metrics.culling import Runtime, depth_buffer_runtime, frusta_runtime, no_culling

from .._held_logs import release
from ..occluder import Occluder
from ..registry import REGISTRY, get_generator, parse_method
from .occluders import (
    _JOINED,
    _UNIT_BOX,
    JOINED_METHODS,
    generate_held,
    joined_occluder,
    scene_hierarchy,
    scene_occluders,
)

__all__ = ["culling_runtimes", "frusta_method", "method_indices", "culling_column",
           "column_pieces", "column_piece", "guaranteed_methods"]

_log = logging.getLogger(__name__)

#: Distinct hierarchy cuts whose occluder scenes are kept between frames.
_CUT_CACHE = 8


def guaranteed_methods() -> list[str]:
    """The registered methods that carry the conservativeness guarantee (``viscore cull``'s
    default runtimes), in the registry's order; ``["aabb-skins"]`` if none does.

    Examples
    --------
    >>> "aabb-skins" in guaranteed_methods()
    True
    """
    return [m for m, spec in REGISTRY.items() if spec.conservative] or ["aabb-skins"]


def frusta_method() -> str:
    """The method whose solids feed the frusta runtimes: ``solid-frusta`` if registered,
    else ``aabb-skins`` (its boxes are convex solids)."""
    return "solid-frusta" if "solid-frusta" in REGISTRY else "aabb-skins"


def _guaranteed(occluder: Occluder, method: str) -> bool:
    """Whether one occluder carries the conservativeness guarantee.

    The generator's own word when it gives one (``info["conservative_guaranteed"]``:
    aabb-skins, solid-frusta and planar-sections say False for an open or
    inconsistently oriented mesh, where nothing is guaranteed); otherwise the
    registry's flag, which promises conservativeness on closed meshes only, so
    the occluder's own mesh must be closed and consistently oriented too.
    """
    said = occluder.info.get("conservative_guaranteed")
    if said is not None:
        return bool(said)
    if not get_generator(method).conservative:
        return False
    mesh = occluder.mesh
    return bool(len(mesh.faces)) and mesh.is_watertight and mesh.is_winding_consistent


def _solids(occluders: Sequence[Occluder]) -> list[tuple[np.ndarray, np.ndarray]]:
    solids: list[tuple[np.ndarray, np.ndarray]] = []
    for occ in occluders:
        if len(occ.parts.get("solids", [])):
            solids.extend((np.asarray(v), np.asarray(f)) for v, f in occ.parts["solids"])
        elif len(occ.parts.get("boxes", [])):
            for lo, hi in np.asarray(occ.parts["boxes"], dtype=np.float64):
                solids.append((lo + np.asarray(_UNIT_BOX.vertices) * (hi - lo),
                               np.asarray(_UNIT_BOX.faces)))
    return solids


def _hierarchy_source(occluders: list[Occluder], width_of: Callable) -> Callable:
    """Per-frame occluders from the hierarchies' cuts (others always drawn), cached by cut."""
    from viscore.culling.depth_buffer import OccluderScene

    from ..planar_hierarchy import cut_hierarchy, index_hierarchy

    trees = [index_hierarchy(o.parts["hierarchy"]) for o in occluders if "hierarchy" in o.parts]
    static = [o for o in occluders if "hierarchy" not in o.parts]
    cache: OrderedDict = OrderedDict()

    def per_frame(camera):
        chosen, key = list(static), []
        for t, tree in enumerate(trees):
            nodes = cut_hierarchy(tree, camera.position, fov_degrees=camera.fov,
                                  screen_pixels=width_of(camera))
            for node in nodes:
                if len(node["occluder"].faces):
                    chosen.append(node["occluder"])
                    key.append((t, id(node)))
        key = tuple(key)
        if key not in cache:
            cache[key] = OccluderScene(chosen)
            if len(cache) > _CUT_CACHE:
                cache.popitem(last=False)
        else:
            cache.move_to_end(key)
        return cache[key]

    return per_frame


def culling_runtimes(objects: SceneObjects, indices: Sequence[int] | np.ndarray,
                     methods: Sequence[str], *,
                     active: int = 15, reduction: int = DEFAULT_REDUCTION, seed: int = 0,
                     frusta: bool = True, frusta_source: str | None = None,
                     cap: str = "front-faces", rank: str = "faces",
                     params: dict[str, dict] | None = None,
                     progress: Callable[[int], None] | None = None,
                     files: Mapping[str, Occluder] | None = None,
                     joined: Sequence[str] | None = None,
                     flat: npt.ArrayLike | None = None,
                     made: Mapping[str, Mapping[int, tuple[Occluder, list]]] | None = None
                     ) -> tuple[dict[str, Runtime], dict]:
    """The runtimes of the culling simulation for a scene's occluder objects.

    Parameters
    ----------
    objects : SceneObjects
    indices : sequence of int
        Objects that get occluders (:func:`occluder_objects`).
    methods : sequence of str
        Registered generators; each gives a ``depth-buffer:<method>`` runtime.
    active : int, optional
        Active occluders per frame of the frusta runtimes (default 15).
    reduction : int, optional
        Depth buffer: screen pixels per buffer pixel along each side (default
        :data:`~viscore.constants.DEFAULT_REDUCTION`, 2: 640 x 360 for 1280 x 720).
    seed : int, optional
        Passed to every generator.
    frusta : bool, optional
        Build ``planar-frusta`` and ``solid-frusta`` from the solids of
        ``frusta_source`` (default True).
    frusta_source : str, optional
        The method whose solids (or boxes) feed the frusta runtimes; default
        :func:`frusta_method` (``solid-frusta`` when registered).
    cap, rank : str, optional
        Near cap and ranking of ``solid-frusta`` (default 'front-faces' and
        'faces'; the paper's are 'eq2' and 'eq4'): see
        :func:`viscore.metrics.culling.frusta_runtime`.
    params : dict of str -> dict, optional
        Generator options per method.
    progress : callable, optional
        Called with 1 after each distinct mesh generated (all methods).
    files : mapping of str -> Occluder, optional
        Occluders made by other tools (:func:`file_occluder`), by name; each
        gives a ``depth-buffer:<name>`` runtime after the methods' (a name
        that is also a method's is refused). The whole file's triangles are
        one occluder set in world space, prepared once as a method's
        occluders are; its guarantee is the file's
        ``info["conservative_guaranteed"]`` (False unless the file says so).
    joined : sequence of str, optional
        Methods generated once over all the objects together
        (:func:`joined_occluder`) instead of mesh by mesh; default those of
        :data:`JOINED_METHODS` among ``methods``, variants with options
        (``surface-patches:ground=auto``) included; ``()`` for none.
    flat : (n,) bool, optional
        Per object of ``objects``, whether it is flat (a level's terrain or
        ground: :attr:`viscore.level.objects.LevelObjects.flat`). A
        method for height fields (``GeneratorSpec.inputs``, such as
        ``terrain-drape``) then makes occluders for the flat objects among
        ``indices`` only, as ``viscore occlude`` does; without ``flat``, for
        all of them.

    Returns
    -------
    runtimes : dict of str -> Runtime
        ``none``, then ``planar-frusta`` and ``solid-frusta``, then
        ``depth-buffer:<method>`` per method, then ``depth-buffer:<name>``
        per file. A method whose occluders carry
        a joined method has one occluder over all the objects; one that carries
        a hierarchy (probed on the first mesh) gets one tree over all the
        objects (:func:`scene_hierarchy`), cut for each frame's camera
        (``cut_hierarchy`` with the camera's horizontal field of view and
        width in pixels); the cut's occluder scenes are cached by cut.
    info : dict
        Per runtime: the source method, occluder count, ``conservative``
        (True only when every occluder it uses carries the guarantee: the
        generator's ``info["conservative_guaranteed"]`` when it reports one,
        for example False for aabb-skins or solid-frusta on an open mesh;
        else the registry flag and a closed, consistently oriented occluder
        mesh) and ``not_guaranteed``, the names of the objects whose occluders
        lack it. A file's entry has ``method`` None, ``file``, ``triangles``
        and ``source_format`` instead.

    Raises
    ------
    InputError
        Unknown method, bad option, a file name that is also a method's.
    """
    active = as_positive_int(active, "active")
    reduction = as_positive_int(reduction, "reduction", maximum=1024)
    params = dict(params or {})
    methods = list(dict.fromkeys(methods))
    for m in methods:
        get_generator(m)
    files = dict(files or {})
    for name, occ in files.items():
        if name in methods:
            raise InputError(f"files: {name!r} is also a method; depth-buffer:{name} would "
                             "name two runtimes")
        if not isinstance(occ, Occluder):
            raise InputError(f"files[{name!r}]: expected an Occluder (file_occluder), got "
                             f"{type(occ).__name__}")
    source = (frusta_method() if frusta_source is None
              else parse_method(frusta_source, "frusta_source").label)
    joined = set(m for m in methods if get_generator(m).name in JOINED_METHODS) \
        if joined is None else set(joined)
    for m in joined:
        if m not in methods:
            raise InputError(f"joined: {m!r} is not one of the methods")
    cache: dict[str, dict[int, Occluder]] = {}

    indices = all_indices = np.asarray(indices, dtype=np.int64)
    is_flat = None if flat is None else np.asarray(flat, dtype=bool)
    if is_flat is not None and is_flat.shape != (len(objects),):
        raise InputError(f"flat: expected one flag per object ({len(objects)}), got shape "
                         f"{is_flat.shape}")

    def occluders(method: str) -> dict[int, Occluder]:
        if method not in cache:
            indices = method_indices(method, all_indices, is_flat)
            if not len(indices):
                _log.info("%s is for height fields, and none of the %d objects is flat",
                          method, len(all_indices))
                cache[method] = {}
                return cache[method]
            _log.debug("generating %s occluders for %d objects", method, len(indices))
            options = params.get(method, {})
            have = dict((made or {}).get(method, {}))
            if method in joined and len(indices):
                if _JOINED in have:
                    occ, records = have[_JOINED]
                    release(records)
                else:
                    occ = joined_occluder(objects, indices, method, seed=seed, **options)
                if progress is not None:
                    progress(len(set(objects.mesh_ids[indices].tolist())))
                cache[method] = {_JOINED: occ} if occ.triangles else {}
                return cache[method]
            # a probe on the first distinct mesh: a hierarchical method gets one
            # tree over all the occluder objects instead of one per mesh
            # (kept for the mesh by mesh generation: the first mesh is made once)
            first = int(objects.mesh_ids[indices[0]])
            probe, records = (have[first] if first in have
                              else generate_held(objects, first, method, seed=seed, **options))
            if "hierarchy" in probe.parts:
                release(records)
                cache[method] = {-1: scene_hierarchy(objects, indices, method, seed=seed,
                                                     **options)}
                if progress is not None:
                    progress(len(set(objects.mesh_ids[indices].tolist())))
            else:
                cache[method] = scene_occluders(objects, indices, method, seed=seed,
                                                progress=progress,
                                                made={**have, first: (probe, records)},
                                                **options)
        return cache[method]

    runtimes: dict[str, Runtime] = {"none": no_culling()}
    info: dict[str, dict] = {"none": {"method": None, "occluders": 0, "conservative": True}}
    if frusta:
        solids = _solids(list(occluders(source).values()))
        unsure = [i for i, o in occluders(source).items() if not _guaranteed(o, source)]
        conservative = not unsure
        for mode in ("planar", "solid"):
            name = f"{mode}-frusta"
            runtimes[name] = frusta_runtime(solids, mode=mode, active=active, cap=cap,
                                            rank=rank, conservative=conservative)
            info[name] = {"method": source, "occluders": runtimes[name].occluders,
                          "solids": len(solids), "conservative": conservative,
                          "not_guaranteed": _unsure_names(objects, unsure), "active": active}
            if mode == "solid":
                info[name].update(cap=cap, rank=rank)
    for m in methods:
        occ = list(occluders(m).values())
        name = f"depth-buffer:{m}"
        unsure = [i for i, o in occluders(m).items() if not _guaranteed(o, m)]
        conservative = not unsure  # no occluder: it culls nothing
        if not occ:
            _log.warning("%s made no occluder for the %s: %s culls nothing", m,
                         "object" if len(indices) == 1 else f"{len(indices):,} objects", name)
            runtimes[name] = Runtime(cull=no_culling().cull, conservative=conservative)
        elif any("hierarchy" in o.parts for o in occ):
            source_fn = _hierarchy_source(occ, lambda camera: camera.shape[1])
            runtimes[name] = depth_buffer_runtime(source_fn, reduction=reduction,
                                                  conservative=conservative, count=len(occ))
        else:
            runtimes[name] = depth_buffer_runtime(occ, reduction=reduction,
                                                  conservative=conservative)
        info[name] = {"method": m, "occluders": len(occ), "conservative": conservative,
                      "not_guaranteed": _unsure_names(objects, unsure),
                      "hierarchy": any("hierarchy" in o.parts for o in occ),
                      "joined": m in joined}
    for name, occ in files.items():
        runtime = f"depth-buffer:{name}"
        conservative = bool(occ.info.get("conservative_guaranteed", False))
        # the whole file is one occluder set in world space, prepared once
        runtimes[runtime] = depth_buffer_runtime([occ], reduction=reduction,
                                                 conservative=conservative)
        info[runtime] = {"method": None, "file": occ.info.get("file", occ.params.get("file")),
                         "source_format": occ.info.get("source_format"), "occluders": 1,
                         "triangles": occ.triangles, "conservative": conservative,
                         "not_guaranteed": [] if conservative else [f"(file {name})"],
                         "hierarchy": False}
    return runtimes, info


def method_indices(method: str, indices: npt.ArrayLike, flat: npt.ArrayLike | None
                   ) -> np.ndarray:
    """The occluder objects ``indices`` a method makes occluders for: the flat ones (per
    object of the scene, ``flat``) for a method for height fields
    (``GeneratorSpec.inputs``), all of them otherwise or without ``flat``."""
    indices = np.asarray(indices, dtype=np.int64)
    if flat is None or get_generator(method).inputs != "height-fields":
        return indices
    return indices[np.asarray(flat, dtype=bool)[indices]]


def _unsure_names(objects: SceneObjects, indices: Sequence[int]) -> list[str]:
    """Names of the objects whose occluders lack the guarantee (-1: a scene's hierarchy,
    -2: the joined occluder)."""
    return [objects.names[i] if i >= 0 else "(hierarchy over the occluder objects)"
            if i == -1 else "(the occluder objects joined)" for i in indices]


def culling_column(methods: Sequence[str], *, scene: str = "city", frames: int = 24,
                   width: int = 640, height: int = 360, seed: int = 0,
                   bounds: str = "auto",
                   progress: Callable[[int, int, str], None] | None = None,
                   made: Mapping[str, Mapping[int, tuple[Occluder, list]]] | None = None
                   ) -> dict[str, dict]:
    """Culled share and false culls of each method's occluders on a culling scene.

    Each method's occluders (for the scene's objects above the default size
    threshold) feed a conservative depth buffer (a quarter of the screen's
    side) along the scene's generated path; the ray-cast ground truth is
    ``width`` x ``height`` (sub-pixel objects are a limit of it). Objects are
    tested as ``viscore cull`` tests them by default (``bounds='auto'``: the
    chunks of the level, objects from ``AUTO_MIN_SIZE`` of its diagonal,
    through the boxes of their triangle clusters, the others through their
    box), or all through their box (``'box'``, the paper's test).

    Parameters
    ----------
    methods : sequence of str
        Registered generators.
    scene : str, optional
        Default the built-in ``city``.
    frames, width, height : int, optional
        Path length and ground-truth image size (default 24 frames at 640 x 360).
    seed : int, optional
        Seed of the path and the generators.
    bounds : {'auto', 'box'}, optional
        How occludees are tested (default ``'auto'``).
    progress : callable, optional
        Called as ``progress(done, total, what)`` after each distinct mesh
        generated (per method) and each frame simulated; ``total`` counts both.
    made : mapping, optional
        The methods' occluders made already, piece by piece
        (:func:`column_pieces`, :func:`column_piece`; see
        :func:`culling_runtimes`): the column is the same with or without.

    Returns
    -------
    dict of str -> dict
        Per method: ``culled_share`` (of the in-view objects, over the
        frames), ``false_culls`` (sum over the frames), ``conservative`` (its
        registry flag) and ``overhead_ms`` (mean per frame).

    Raises
    ------
    InputError
        Unknown method, bad sizes, unknown ``bounds``.
    """
    from viscore.culling.occludee_bounds import DEFAULT_CLUSTERS, occludee_boxes
    from viscore.level import load_scene_objects
    from viscore.level.objects import occluder_objects
    from viscore.metrics.culling import camera_path, simulate_culling

    if bounds not in ("auto", "box"):
        raise InputError(f"bounds: expected 'auto' or 'box', got {bounds!r}")
    objects = load_scene_objects(scene)
    indices = occluder_objects(objects)
    steps = len(set(objects.mesh_ids[indices].tolist())) * len(set(methods)) + frames
    done = [0]

    def step(what: str) -> Callable[[int], None]:
        def tick(n: int = 1) -> None:
            done[0] += n
            progress(done[0], steps, what)  # type: ignore[misc]
        return tick

    runtimes, _ = culling_runtimes(objects, indices, list(methods), seed=seed, frusta=False,
                                   progress=None if progress is None else step("occluders"),
                                   made=made)
    path = camera_path(objects, frames=frames, seed=seed)
    boxes, _, _ = occludee_boxes(objects, bounds, DEFAULT_CLUSTERS if bounds == "auto" else 1)
    result = simulate_culling(objects, runtimes, path, width=width, height=height,
                              bounds=boxes,
                              progress=None if progress is None else step("frames"))
    totals = result.totals()
    return {m: {key: totals[f"depth-buffer:{m}"][key]
                for key in ("culled_share", "false_culls", "conservative", "overhead_ms")}
            for m in dict.fromkeys(methods)}


@functools.lru_cache(maxsize=1)
def _piece_scene(scene: str) -> SceneObjects:
    """The scene of :func:`column_pieces` and :func:`column_piece`, loaded once per process
    (a worker makes many pieces of one scene, and workers forked after the pieces were
    listed start with it; loading the built-in city takes about 0.3 s)."""
    from viscore.level import load_scene_objects

    return load_scene_objects(scene)


def column_pieces(methods: Sequence[str], *, scene: str = "city"
                  ) -> list[tuple[str, tuple[int, ...]]]:
    """The occluder generation of :func:`culling_column` as independent pieces.

    One piece per method and distinct mesh of the scene's occluder objects,
    ``(method, (mesh_id,))``, and one ``(method, ())`` for a joined method
    (:data:`JOINED_METHODS`), generated over all the objects at once. Each
    piece is :func:`column_piece`'s work; any process can make it, and the
    pieces together, handed to :func:`culling_column` as ``made``, give the
    column it computes alone.

    Examples
    --------
    >>> pieces = column_pieces(["aabb-skins", "surface-patches"])
    >>> pieces[0][0], len(pieces[0][1]), pieces[-1]
    ('aabb-skins', 1, ('surface-patches', ()))
    """
    from viscore.level.objects import occluder_objects

    objects = _piece_scene(scene)
    distinct = np.unique(objects.mesh_ids[occluder_objects(objects)]).tolist()
    pieces: list[tuple[str, tuple[int, ...]]] = []
    for m in dict.fromkeys(methods):
        if get_generator(m).name in JOINED_METHODS:
            pieces.append((m, ()))
        else:
            pieces += [(m, (int(mesh),)) for mesh in distinct]
    return pieces


def column_piece(method: str, mesh_ids: Sequence[int], *, scene: str = "city", seed: int = 0
                 ) -> dict[int, tuple[Occluder, list[logging.LogRecord]]]:
    """One piece of :func:`culling_column`'s occluders (:func:`column_pieces`), with the log
    records each generation held: the meshes' occluders in their own frames by mesh id,
    or for ``mesh_ids`` empty, the method's joined occluder over all the scene's occluder
    objects under ``-2``, as :func:`culling_runtimes` takes them in ``made``."""
    from viscore.level.objects import occluder_objects

    from .._held_logs import call_held

    objects = _piece_scene(scene)
    if not mesh_ids:
        return {_JOINED: call_held(joined_occluder, objects, occluder_objects(objects),
                                   method, seed=seed)}
    return {int(m): generate_held(objects, int(m), method, seed=seed) for m in mesh_ids}
