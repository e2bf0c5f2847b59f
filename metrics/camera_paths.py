"""Camera paths of the culling simulation: generated walks through a scene, and JSON files.

The kind of viewpoint path along which Papaioannou et al. 2006 [1]_ (sec. 4,
Figs. 5-6) count the primitives rendered per frame.

References
----------
.. [1] Papaioannou, G., Gaitatzes, A., Christopoulos, D. "Efficient Occlusion
   Culling using Solid Occluders". WSCG 2006 (Plzen), UNION Agency,
   ISBN 80-86943-03-8 (sec. 4, Tables 1-2, Figures 5-6).
"""

from __future__ import annotations

import dataclasses
import json
import os
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from viscore import InputError, PerspectiveCamera
from viscore._validate import as_positive, as_positive_int, as_seed, as_vector
from viscore.ray.cameras import horizontal_basis

if TYPE_CHECKING:  # pragma: no cover - hints only
    from viscore.level.scene_graph import SceneObjects

__all__ = ["PathCamera", "camera_path", "camera_walk", "Walk", "Stance", "EyeHeight",
           "camera_stances", "guess_eye_height", "read_camera_path", "camera_path_json",
           "check_camera_path", "DEFAULT_FOV", "EYE_HEIGHT", "MIN_FOV", "MAX_FOV"]

#: Horizontal field of view of generated and JSON cameras without ``fov``, degrees.
DEFAULT_FOV = 90.0

#: Narrowest horizontal field of view accepted, degrees. A pixel of the widest
#: image (8192 pixels) then spans 2.1e-7 rad, so two neighbouring pixels' hit
#: points at distance D are 2.1e-7 D apart: still beyond float32's resolution
#: of D (1.2e-7 D), in which Embree casts. Narrower, neighbouring pixels fall on
#: one float32 point (at 1e-300 degrees, every ray of the image is the same ray).
MIN_FOV = 0.1

#: Widest horizontal field of view accepted, degrees. A planar projection has
#: none at 180; at 179, tan(fov / 2) is already 115 and an edge pixel covers a
#: millionth of a centre pixel's solid angle: wider views are all periphery.
MAX_FOV = 179.0

#: Eye height above the floor of the street-level frames in a level whose units are
#: metres (glTF's unit), world units; other levels get theirs from
#: :func:`guess_eye_height`.
EYE_HEIGHT = 1.7

#: The eye height guessed from a level's rooms, as a share of the lower quartile of the
#: headroom of its floors under their ceilings. Players' eyes in games stand at about a
#: third of the low rooms' height: Doom 41 under 128, Cube 2 maps 14 under 32-48, Hammer
#: 64 under 144, Quake maps (units / 32) 1.4 under 3.5, a hangar 1.7 under 4.4.
_EYE_PER_HEADROOM = 0.35

#: A level's rooms set its eye height only when at least this share of the map's
#: columns find a floor under a ceiling (a town with a few awnings keeps the default).
_ROOFED_COLUMNS = 0.02

#: A headroom of the level read turned over counts only when under this share of the
#: level's height (the inside of a solid block as tall as the level is no room).
_ROOM_OF_LEVEL = 0.5

#: A headroom under this share of the median headroom is a cavity between two layers (a
#: floor slab's thickness, the gap under a platform), not a room: when the lower quartile
#: is one, it is taken over the others. Sauerbraten's fdm6: 4,353 of its 22,402 floors
#: under a ceiling have a 4-unit gap over them, and its eye stood at 1.4 where the game's
#: is 14 (10.8 without them). Levels whose quartile is a room keep it (leaving the
#: cavities out always moved 11 of the 37 measured levels' eyes, as many away from their
#: game's eye as towards it).
_THIN_ROOM = 1.0 / 6.0

#: A guess from a glTF level's rooms replaces the metre default only when it is this
#: many times larger (a level in centimetres, eye about 170): a glTF's unit is the metre
#: by its specification, and the gaps under furniture, cars and kerbs read as low rooms.
_METRE_DOUBT = 30.0

#: A level without ceilings lower than :data:`EYE_HEIGHT` (no person stands in it: a
#: blockout or a model in other units than metres) gets an eye at this share of its
#: height: game levels of several storeys are about 20 eye heights tall (Quake's E1M1
#: 28 units of 1.44, Doom's E1M1 704 of 41, Sauerbraten's zdm2 324 of 14).
_LEVEL_EYES = 20.0

#: A level is read with its faces turned over (the file's winding inward) when the
#: lower quartile of its headroom so read is over this many times the one as wound:
#: read as wound, the rooms of such a level are the insides of its walls' brushes.
_FLIP_RATIO = 4.0


#: Free-space map of :func:`camera_path`: cells along the longest horizontal side.
_GRID_CELLS = 512

#: Half-window, in cells of the free-space map, over which the walking direction
#: of the street-level cameras is smoothed.
_TANGENT_CELLS = 12.0

#: Horizontal clearance, in cells of the free-space map, kept between the
#: street-level cameras and anything that reaches eye height.
_MIN_CLEARANCE_CELLS = 1.0

#: Street-level free space: a cell is free when nothing in it rises above this
#: fraction of the eye height over the ground (a parked car's roof, 1.4-1.5 m,
#: stays below a 1.7 m eye; a van does not).
_HEAD_ROOM = 0.9

#: A walkable floor faces up: the cosine of its normal with the up axis is at least this
#: (a slope of at most 60 degrees).
_WALKABLE = 0.5

#: Headroom a floor needs to be stood on, in eye heights (a door's lintel at 2.04 m over
#: its threshold passes a 1.7 m eye).
_STAND_ROOM = 1.2

#: Largest height step between the floors of neighbouring cells walked across, in eye
#: heights (a stair, a kerb; not a car's roof).
_STEP = 0.5

#: The street map is walked only when at least this share of its free cells stands on an
#: upward-facing surface (an indoor level seen from above is roofs and ceilings seen from
#: behind, and its free cells are the void around it), and under this share of the
#: level's floors (:func:`_floors`) is under a ceiling (a building with a roof, whose
#: street map is the roof); otherwise the walk goes on the floors.
_ON_FLOOR = 0.5

#: The floors are walked only when their largest connected region covers at least this
#: share of the map's cells that hold anything (not the tops of loose boxes on nothing;
#: a Quake map's largest floor joined within a step is 12% of its cells).
_FLOOR_SHARE = 0.05

#: Highest an elevated camera stands over its floor, in eye heights (a player on a
#: crate, a ledge or a jump, looking down): higher, it stands where no player does.
_ELEVATED_EYES = 2.0

#: A camera stands well when the floor under it (an upward-facing surface, the first
#: thing straight down) is within this many eye heights.
_FLOOR_EYES = 3.0

#: ... with at least this much headroom over the eye, in eye heights (the first thing
#: straight up; its head is under a ceiling, not in it).
_HEADROOM_EYES = 0.1

#: ... when under this share of what it sees are back faces (a camera behind a wall, in
#: solid geometry or outside a level's shell sees the backs of its faces).
_MAX_BACK_FACES = 0.3

#: ... and when at least this share of its view rays hit something.
_MIN_IN_VIEW = 0.05

#: Rays of the view check, across x down (a 16:9 grid).
_VIEW_RAYS = (32, 18)

#: How far the elevated cameras (and a camera turned to see a level under its eye) look
#: down, degrees below the horizon.
_LOOK_DOWN = 25.0

#: Candidate cameras made along the walk per camera kept: a camera that does not stand
#: well is replaced by the nearest candidate of its stretch that does, or dropped.
_CANDIDATES = 4

#: Largest camera path file read, bytes (about a million cameras).
_MAX_PATH_BYTES = 256 << 20

# --------------------------------------------------------------------------- cameras
@dataclass(frozen=True, eq=False)
class PathCamera:
    """One camera of a path.

    Attributes
    ----------
    position : (3,) float64
        Eye point, world units.
    forward : (3,) float64
        Unit viewing direction.
    up : (3,) float64
        Approximate up vector (the scene's up axis by default).
    fov : float
        Horizontal field of view, degrees in [``MIN_FOV``, ``MAX_FOV``] = [0.1, 179].
    """

    position: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    fov: float = DEFAULT_FOV

    def camera(self, width: int, height: int) -> PerspectiveCamera:
        """The :class:`~viscore.PerspectiveCamera` of this pose, ``width`` x ``height`` pixels."""
        return PerspectiveCamera(self.position, self.forward, up=self.up, fov=self.fov,
                                 resolution=width, height=height)

    def to_json(self) -> dict:
        """``{"position", "forward", "up", "fov"}``, the format :func:`read_camera_path` reads."""
        return {"position": [float(x) for x in self.position],
                "forward": [float(x) for x in self.forward],
                "up": [float(x) for x in self.up], "fov": float(self.fov)}


def _pose(position, forward, up, fov: float, where: str) -> PathCamera:
    from viscore import camera_basis

    p = as_vector(position, f"{where}.position")
    f = as_vector(forward, f"{where}.forward")
    u = as_vector(up, f"{where}.up")
    try:
        f, _, _ = camera_basis(f, u)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    fov = _check_fov(fov, f"{where}.fov")
    for arr in (p, f, u):
        arr.flags.writeable = False
    return PathCamera(position=p, forward=f, up=u, fov=fov)


def _check_fov(fov: object, where: str) -> float:
    """A horizontal field of view in [MIN_FOV, MAX_FOV] degrees, or one line naming ``where``."""
    fov = as_positive(fov, where)
    if not MIN_FOV <= fov <= MAX_FOV:
        raise InputError(f"{where}: expected degrees in [{MIN_FOV:g}, {MAX_FOV:g}], got {fov:g}")
    return fov


def read_camera_path(path: str | os.PathLike, *, up: npt.ArrayLike = (0.0, 1.0, 0.0),
                     frames: int | None = None, maximum: int | None = None
                     ) -> list[PathCamera]:
    """Read a camera path from a JSON file.

    Format: a JSON list of cameras, each an object with ``position`` (3
    numbers, world units), ``forward`` (3 numbers, the viewing direction),
    optionally ``up`` (3 numbers; default ``up``) and ``fov`` (horizontal
    field of view in degrees, in [0.1, 179], :data:`MIN_FOV` and
    :data:`MAX_FOV`; default 90). For example::

        [{"position": [0, 1.7, -50], "forward": [0, 0, 1]},
         {"position": [0, 30, -80], "forward": [0, -0.4, 1], "up": [0, 1, 0], "fov": 70}]

    Parameters
    ----------
    path : str or path-like
        The JSON file.
    up : (3,) float, optional
        Up vector of the cameras without one (default +Y, glTF's up).
    frames : int, optional
        Keep the first ``frames`` cameras; the others are not checked
        (default: all).
    maximum : int, optional
        Refuse a path of more cameras than this (after ``frames``), before
        any camera is checked (default: no limit but the file size's).

    Returns
    -------
    list of PathCamera

    Raises
    ------
    InputError
        One line naming the file: missing or unreadable, not JSON, not a
        non-empty list of camera objects, more than ``maximum`` cameras, or a
        camera with a missing, non-finite or degenerate field (zero forward, up
        parallel to forward, fov out of range), naming the camera's index.
    """
    label = str(path)
    if frames is not None:
        frames = as_positive_int(frames, "frames")
    if maximum is not None:
        maximum = as_positive_int(maximum, "maximum")
    try:
        st = os.stat(path)
        if stat.S_ISDIR(st.st_mode):
            raise InputError(f"{label}: is a directory, expected a camera path JSON file")
        if not stat.S_ISREG(st.st_mode):  # a FIFO or device would block or never end
            raise InputError(f"{label}: not a regular file, expected a camera path JSON file")
        if st.st_size > _MAX_PATH_BYTES:
            raise InputError(f"{label}: {st.st_size:,} bytes, more than a camera path file "
                             f"may hold ({_MAX_PATH_BYTES:,})")
        with open(path, "rb") as fh:
            data = fh.read(_MAX_PATH_BYTES + 1)
    except FileNotFoundError:
        raise InputError(f"{label}: no such file") from None
    except OSError as exc:
        raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
    try:
        doc = json.loads(data.decode("utf-8-sig"))
    except RecursionError:
        raise InputError(f"{label}: not a valid camera path file (JSON nested too deeply)"
                         ) from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{label}: not a valid JSON file ({' '.join(str(exc).split())[:120]})"
                         ) from None
    if not isinstance(doc, list) or not doc:
        raise InputError(f"{label}: expected a non-empty JSON list of cameras "
                         "({\"position\": [x, y, z], \"forward\": [x, y, z], \"up\"?, \"fov\"?})")
    if frames is not None:
        doc = doc[:frames]
    if maximum is not None and len(doc) > maximum:
        raise InputError(f"{label}: {len(doc):,} cameras, more than the {maximum:,} a path "
                         "may have")
    cameras = []
    for i, cam in enumerate(doc):
        where = f"{label}: camera {i}"
        if not isinstance(cam, dict):
            raise InputError(f"{where}: expected an object with position and forward")
        missing = [k for k in ("position", "forward") if k not in cam]
        if missing:
            raise InputError(f"{where}: missing {', '.join(missing)}")
        unknown = sorted(set(cam) - {"position", "forward", "up", "fov"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} "
                             "(expected position, forward, up, fov)")
        fov = cam.get("fov", DEFAULT_FOV)
        if isinstance(fov, bool) or not isinstance(fov, (int, float)):
            raise InputError(f"{where}.fov: expected a number of degrees, got {fov!r:.40}")
        vectors = {k: _three_numbers(cam[k], f"{where}.{k}")
                   for k in ("position", "forward", "up") if k in cam}
        cameras.append(_pose(vectors["position"], vectors["forward"], vectors.get("up", up),
                             _finite(fov, f"{where}.fov"), where))
    return cameras


def _finite(value, where: str) -> float:
    """A JSON number as a float; an integer beyond float64 is refused, never an OverflowError."""
    try:
        return float(value)
    except OverflowError:
        raise InputError(f"{where}: {str(value)[:20]}... is beyond float64's range") from None


def _three_numbers(value, where: str) -> list[float]:
    """A JSON list of exactly three numbers (not booleans, not nested lists) as floats."""
    if (not isinstance(value, list) or len(value) != 3
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in value)):
        raise InputError(f"{where}: expected a list of 3 numbers, got {json.dumps(value)[:60]}")
    return [_finite(x, where) for x in value]


#: Farthest camera accepted, in scene diagonals from the scene's centre (float32
#: ray casting loses the scene long before Embree refuses, near 1e38 diagonals).
_MAX_CAMERA_DIAGONALS = 1e6


def check_camera_path(objects: SceneObjects, cameras: Sequence[PathCamera]) -> None:
    """Refuse, before any work, cameras too far from the scene to see it.

    Parameters
    ----------
    objects : SceneObjects
    cameras : sequence of PathCamera

    Raises
    ------
    InputError
        No camera, or one farther than a million scene diagonals from the
        scene's centre, naming its index.
    """
    if not len(cameras):
        raise InputError("path: expected at least one camera")
    lo, hi = objects.bounds
    diagonal = float(np.linalg.norm(hi - lo))
    with np.errstate(over="ignore"):  # a camera at 1e300: inf, refused below
        far = np.array([np.linalg.norm(c.position - (lo + hi) / 2) for c in cameras])
    bad = np.flatnonzero(~(far <= _MAX_CAMERA_DIAGONALS * diagonal))
    if len(bad):
        raise InputError(f"path: camera {int(bad[0])} is {far[bad[0]]:.3g} from the scene's "
                         f"centre, more than {_MAX_CAMERA_DIAGONALS:.0e} x its diagonal "
                         f"({diagonal:.3g}): it cannot see the scene")


def camera_path_json(cameras: Sequence[PathCamera]) -> str:
    """The JSON text of a camera path (the format :func:`read_camera_path` reads)."""
    return json.dumps([c.to_json() for c in cameras], indent=1)


# --------------------------------------------------------------------------- path generation
def _height_map(objects: SceneObjects, up: np.ndarray):
    """Top heights of the scene seen from above on a horizontal grid, and the ground level.

    The grid spans the level's built part
    (:meth:`viscore.level.scene_graph.SceneObjects.built_bounds`), its heights the
    objects' but a sky's (:meth:`viscore.level.scene_graph.SceneObjects.sky`). Returns the grid
    frame (basis, origin, cell size, shape), the height along
    ``up`` of the first hit of one ray cast down through each cell centre (the
    scene's lowest point where the ray misses), and the ground level: the 5th
    percentile of those heights. The frame ends with ``top``, the height the
    rays start from, and the cosine of the first hit's normal with ``up``
    (NaN on a miss) comes last.
    """
    e1, e2 = horizontal_basis(up)

    def corners(box):
        return np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])

    # heights without a sky around the level: the rays start under its dome, and the
    # elevated frames rise over the level, not to the sky
    sky = objects.sky()
    keep = ~sky if sky.any() and not sky.all() else np.ones(len(sky), dtype=bool)
    h = corners(np.stack([objects.lower[keep].min(axis=0),
                          objects.upper[keep].max(axis=0)])) @ up
    # the map covers the level's built part: an outer ground plane or a sea far wider
    # than the town on it would make every street a few cells of empty ground
    built = corners(objects.built_bounds(up)[0])
    a, b = built @ e1, built @ e2
    cell = max(a.max() - a.min(), b.max() - b.min()) / _GRID_CELLS
    na = max(2, int(np.ceil((a.max() - a.min()) / cell)))
    nb = max(2, int(np.ceil((b.max() - b.min()) / cell)))
    top = h.max() + 0.01 * (h.max() - h.min() + cell)
    frame = (e1, e2, a.min(), b.min(), cell, (na, nb), top)
    origins = _column_origins(frame, up)
    scene, _ = objects.combined
    dist, tri = scene.first_hit(origins, np.broadcast_to(-up, origins.shape))
    # a miss is the scene's lowest level: nothing stands there (a scene without a
    # ground plane has its ground where its objects stand, not on their tops)
    height = np.where(np.isfinite(dist), top - dist, h.min()).reshape(na, nb)
    ground = float(np.percentile(height, 5))
    facing = np.full(len(tri), np.nan)
    facing[tri >= 0] = _unit_normals(scene, tri[tri >= 0]) @ up
    return frame, height, ground, facing.reshape(na, nb)


def _column_origins(frame, up: np.ndarray) -> np.ndarray:
    """``(na nb, 3)``: the map's cell centres at the height ``top`` its rays start from."""
    e1, e2, a0, b0, cell, (na, nb), top = frame
    aa, bb = np.meshgrid(a0 + (np.arange(na) + 0.5) * cell, b0 + (np.arange(nb) + 0.5) * cell,
                         indexing="ij")
    return aa.reshape(-1, 1) * e1 + bb.reshape(-1, 1) * e2 + top * up


def _unit_normals(scene, triangles: np.ndarray) -> np.ndarray:
    """Unit normals ``(k, 3)`` of some triangles of a :class:`viscore.Scene` (as wound)."""
    v = scene.vertices[scene.faces[triangles]]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


def _floors(objects: SceneObjects, up: np.ndarray, frame, eye_height: float,
            sign: float = 1.0):
    """The level's walked floors: the cells that hold one, each cell's floor height and
    headroom (NaN and 0 elsewhere).

    Rays cast down through every cell centre find every surface in the cell's
    column (:meth:`viscore.Scene.all_hits`); a surface facing up
    (:data:`_WALKABLE`) with :data:`_STAND_ROOM` eye heights free above it
    (to the next surface up, or open sky) is a floor. Floors of neighbouring
    cells (four-connected) are joined when their heights differ by at most
    :data:`_STEP` eye heights, and the largest set so joined is walked (the
    lowest of those at least half its size): the floors under an indoor
    level's ceilings, a town's streets (a roof, a car's top, a ledge are sets
    of their own). A cell holds at most one floor of it (the lowest). None is
    walked when the largest set covers under :data:`_FLOOR_SHARE` of the cells
    that hold anything.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    shape, top = frame[5], frame[6]
    na, nb = shape
    held = np.zeros(na * nb, bool)
    floor = np.full(shape, np.nan)
    head = np.zeros(shape)
    origins = _column_origins(frame, up)
    scene, _ = objects.combined
    hits = scene.all_hits(origins, np.tile(-up, (len(origins), 1)))
    z = top - hits.t
    first = np.r_[True, hits.ray[1:] != hits.ray[:-1]]
    room = np.where(first, np.inf, np.r_[np.inf, z[:-1]] - z)
    stand = (sign * (_unit_normals(scene, hits.triangle) @ up) >= _WALKABLE) \
        & (room >= _STAND_ROOM * eye_height)
    ray, z, room = hits.ray[stand], z[stand], room[stand]
    n = len(ray)
    if n == 0:
        return held.reshape(shape), floor, head
    # join floors of neighbouring cells within a step: each floor to the nearest in height
    # of the next cell's floors (sorted by cell, then height)
    step = _STEP * eye_height
    span = float(z.max() - z.min()) + 4 * step + 1.0
    key = ray * span + (z - z.min())
    order = np.argsort(key, kind="stable")
    ia, ib = ray // nb, ray % nb
    pairs = []
    for da, db in ((1, 0), (0, 1)):
        na_, nb_ = ia + da, ib + db
        inside = (na_ < na) & (nb_ < nb)
        target = (na_ * nb + nb_)
        at = np.searchsorted(key[order], target * span + (z - z.min()))
        for c in (at - 1, at):
            m = order[np.clip(c, 0, n - 1)]
            good = inside & (ray[m] == target) & (np.abs(z[m] - z) <= step)
            pairs.append(np.stack([np.flatnonzero(good), m[good]], axis=1))
    pairs = np.concatenate(pairs)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    # the largest set, or the lowest of those at least half its size (a building's floors
    # rather than its roof, the streets rather than the rooftops)
    sizes = np.bincount(label)
    near = np.flatnonzero(sizes >= 0.5 * sizes.max())
    median = [float(np.median(z[label == k])) for k in near]
    main = label == int(near[int(np.argmin(median))])
    if main.sum() < _FLOOR_SHARE * np.count_nonzero(hits.count):
        return held.reshape(shape), floor, head
    # the lowest floor of the walked set in each cell (hits run top down: the last)
    r, z, room = ray[main], z[main], room[main]
    last = np.r_[r[1:] != r[:-1], True]
    floor.reshape(-1)[r[last]] = z[last]
    head.reshape(-1)[r[last]] = room[last]
    held[r] = True
    return held.reshape(shape), floor, head


def _floor_free(objects: SceneObjects, up: np.ndarray, frame, held: np.ndarray,
                floor: np.ndarray, head: np.ndarray, eye_height: float):
    """Free cells on the walked floors (:func:`_floors`), their clearance in cells, and the
    tall cells (the others): a cell with a floor is free unless something stands in it
    between a step over the floor and its ceiling (:func:`_edge_marks`: a fence thinner
    than a cell, whose edges are at its foot and its top, blocks its cells)."""
    from scipy import ndimage

    level = np.where(held, floor + _STEP * eye_height, np.inf)
    blocked = ~held | _edge_marks(objects, up, frame, level,
                                  np.where(held, floor + head, -np.inf))
    clearance = ndimage.distance_transform_edt(np.pad(~blocked, 1))[1:-1, 1:-1]
    return ~blocked, clearance, blocked


def _edge_marks(objects: SceneObjects, up: np.ndarray, frame, level: float | np.ndarray,
                ceiling: np.ndarray | None = None) -> np.ndarray:
    """Cells of the map holding a point of an edge higher than ``level`` along ``up``.

    One ray per cell centre misses things thinner than a cell (a pole, a
    fence, a thin wall between two centres); every triangle edge of the
    objects that reach above ``level`` is sampled at a quarter of a cell and
    the cells of its samples above ``level`` are marked. ``level`` may be one
    per cell, and a ``ceiling`` per cell then marks only the samples under
    it (something standing between a floor and the eye). Returns the
    ``(na, nb)`` bool mask.
    """
    e1, e2, a0, b0, cell, shape = frame[:6]
    marks = np.zeros(shape, dtype=bool)
    per_cell = np.ndim(level) > 0
    lowest = float(np.min(level)) if per_cell else float(level)
    corners = np.stack([objects.lower, objects.upper], axis=1)  # (n, 2, 3)
    reach = (np.where(up >= 0, corners[:, 1], corners[:, 0]) @ up)
    tall = np.flatnonzero(reach > lowest)
    step = cell / 4
    budget = 4_000_000  # samples per batch
    for mesh_id in np.unique(objects.mesh_ids[tall]):
        mesh = objects.meshes[mesh_id]
        edges = np.asarray(mesh.edges_unique, dtype=np.int64)
        v = np.asarray(mesh.vertices, dtype=np.float64)
        inst = tall[objects.mesh_ids[tall] == mesh_id]
        per = max(1, budget // max(1, 4 * len(edges)))
        for k in range(0, len(inst), per):
            mats = objects.transforms[inst[k:k + per]]
            w = (np.einsum("kij,nj->kni", mats[:, :3, :3], v) + mats[:, None, :3, 3])
            p0 = w[:, edges[:, 0]].reshape(-1, 3)
            p1 = w[:, edges[:, 1]].reshape(-1, 3)
            high = np.maximum(p0 @ up, p1 @ up) > lowest
            p0, p1 = p0[high], p1[high]
            d = p1 - p0
            flat = d - np.outer(d @ up, up)
            count = np.ceil(np.linalg.norm(flat, axis=1) / step).astype(np.int64) + 1
            for lo in range(0, len(count), max(1, budget // 8)):
                c = count[lo:lo + budget // 8]
                which = np.repeat(np.arange(len(c)), c)
                first = np.concatenate([[0], np.cumsum(c)[:-1]])
                t = (np.arange(len(which)) - first[which]) / np.maximum(c[which] - 1, 1)
                pts = p0[lo:][which] + t[:, None] * d[lo:][which]
                if not per_cell:
                    pts = pts[pts @ up > level]
                ia = np.clip(((pts @ e1 - a0) / cell).astype(np.int64), 0, shape[0] - 1)
                ib = np.clip(((pts @ e2 - b0) / cell).astype(np.int64), 0, shape[1] - 1)
                if per_cell:  # between each cell's floor (a step over it) and its ceiling
                    h = pts @ up
                    keep = (h > level[ia, ib]) & (h < ceiling[ia, ib])  # type: ignore[index]
                    ia, ib = ia[keep], ib[keep]
                marks[ia, ib] = True
    return marks


def _free_space(objects: SceneObjects, up: np.ndarray, frame, height: np.ndarray,
                ground: float, eye_height: float):
    """Free cells of the map at street level, and their clearance in cells.

    A cell is free when nothing in its column rises above ``_HEAD_ROOM`` x
    ``eye_height`` over the ground: neither the top surface found by the
    cell's centre ray nor any edge sample (:func:`_edge_marks`). The
    clearance of a free cell is its distance in cells to the nearest blocked
    one (beyond the grid counts as blocked).
    """
    from scipy import ndimage

    level = ground + _HEAD_ROOM * eye_height
    blocked = (height > level) | _edge_marks(objects, up, frame, level)
    # beyond the grid counts as blocked: the scene's rim is no wide open place
    clearance = ndimage.distance_transform_edt(np.pad(~blocked, 1))[1:-1, 1:-1]
    return ~blocked, clearance


def _route(free: np.ndarray, clearance: np.ndarray, tall: np.ndarray,
           rng: np.random.Generator, waypoints: int) -> np.ndarray:
    """A walk through the free cells visiting ``waypoints`` open places among tall things.

    Returns (m, 2) cell coordinates along the walk.
    """
    from scipy import ndimage
    from skimage.graph import route_through_array

    ok = free & (clearance >= _MIN_CLEARANCE_CELLS + 1)
    if not ok.any():
        ok = free
    labels, count = ndimage.label(ok)
    if count == 0:
        return np.zeros((0, 2))
    sizes = np.bincount(labels.ravel())[1:]
    main = labels == (int(np.argmax(sizes)) + 1)  # the largest connected free region
    # waypoints: open (clearance capped at its median, so that one wide square
    # does not take them all) and among the tall things (no closer to the scene's
    # rim than the median free cell is to something tall)
    to_tall = ndimage.distance_transform_edt(~tall) if tall.any() else np.zeros(tall.shape)
    among = main & (to_tall <= np.median(to_tall[main]))
    cells = np.argwhere(among if among.any() else main)
    open_ = clearance[tuple(cells.T)]
    weight = np.minimum(open_, np.median(open_)) ** 2
    picks = rng.choice(len(cells), size=min(waypoints, len(cells)), replace=False,
                       p=weight / weight.sum())
    points = cells[picks]
    # visit them in a greedy nearest-neighbour tour from the first
    order = [0]
    left = set(range(1, len(points)))
    while left:
        last = points[order[-1]]
        nxt = min(left, key=lambda k: float(np.sum((points[k] - last) ** 2)))
        order.append(nxt)
        left.remove(nxt)
    points = points[order]
    # least cost: short, off the walls, and among the tall things (not round the rim)
    med = max(float(np.median(to_tall[main])), 1.0)
    cost = 1.0 + 2.0 / (clearance + 0.5) + np.maximum(0.0, to_tall - med) / med
    cost = np.where(main, cost, -1.0)  # negative: impassable
    path = [points[:1]]
    for p, q in zip(points[:-1], points[1:], strict=True):
        route, _ = route_through_array(cost, tuple(p), tuple(q), fully_connected=True,
                                       geometric=True)
        path.append(np.asarray(route)[1:])
    return np.concatenate(path).astype(np.float64)


def _resample(polyline: np.ndarray, count: int, start: float = 0.0, stop: float = 1.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """``count`` points evenly spaced along a polyline between two arc-length fractions,
    and the unit tangents there (smoothed over a few cells)."""
    seg = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    if count <= 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    if total == 0:
        return np.repeat(polyline[:1], count, 0), np.tile([1.0, 0.0], (count, 1))
    t = np.linspace(start, stop, count, endpoint=count == 1) * total
    pts = np.stack([np.interp(t, s, polyline[:, k]) for k in (0, 1)], axis=1)
    w = _TANGENT_CELLS
    ahead = np.stack([np.interp(np.minimum(t + w, total), s, polyline[:, k]) for k in (0, 1)], 1)
    behind = np.stack([np.interp(np.maximum(t - w, 0), s, polyline[:, k]) for k in (0, 1)], 1)
    tangent = ahead - behind
    norm = np.linalg.norm(tangent, axis=1)
    tangent = np.where(norm[:, None] > 0, tangent / np.maximum(norm, 1e-12)[:, None], [1.0, 0.0])
    return pts, tangent


# --------------------------------------------------------------------------- eye height
@dataclass(frozen=True)
class EyeHeight:
    """The eye height of a level's walk and how it was set.

    Attributes
    ----------
    value : float
        Eye height over the floor, world units (the level's own).
    reason : str
        One line saying how ``value`` was set (given, metres, or from the rooms).
    sign : float
        +1 when the level's faces are read as wound, -1 when read turned over (a
        level wound inward: its rooms read as wound were the insides of its brushes).
    headroom : float
        Lower quartile of the headroom of the level's floors under their ceilings,
        world units (``nan`` when too few floors have a ceiling).
    """

    value: float
    reason: str
    sign: float = 1.0
    headroom: float = float("nan")

    def to_json(self) -> dict:
        """``{"eye_height", "eye_height_reason", "faces", "headroom_q25"}``."""
        return {"eye_height": float(self.value), "eye_height_reason": self.reason,
                "faces": "as wound" if self.sign > 0 else "turned over",
                "headroom_q25": None if not np.isfinite(self.headroom) else
                float(self.headroom)}


def _headroom(objects: SceneObjects, up: np.ndarray, frame) -> tuple[dict, int]:
    """Per sign (+1 as wound, -1 turned over): the headrooms ``(k,)`` of the map's
    floors under a ceiling (an upward-facing surface straight under a downward-facing
    one, as read with that sign; turned over, under :data:`_ROOM_OF_LEVEL` of the
    level's height); and the number of columns cast."""
    origins = _column_origins(frame, up)
    scene, _ = objects.combined
    hits = scene.all_hits(origins, np.tile(-up, (len(origins), 1)))
    z = frame[6] - hits.t
    first = np.r_[True, hits.ray[1:] != hits.ray[:-1]] if len(z) else np.zeros(0, bool)
    room = np.where(first, np.inf, np.r_[np.inf, z[:-1]] - z)
    facing = _unit_normals(scene, hits.triangle) @ up if len(z) else np.zeros(0)
    above = np.r_[0.0, facing[:-1]] if len(z) else np.zeros(0)
    lo, hi = objects.bounds
    tall = _ROOM_OF_LEVEL * float(np.abs(hi - lo) @ np.abs(up))
    rooms = {}
    for sign in (1.0, -1.0):
        pair = (sign * facing >= _WALKABLE) & (sign * above <= -_WALKABLE) & ~first
        r = room[pair]
        # turned over, the inside of a solid block as tall as the level reads as a room
        rooms[sign] = r[(r > 0) & ((r <= tall) | (sign > 0))]
    return rooms, len(origins)


def guess_eye_height(objects: SceneObjects, *, up: npt.ArrayLike | None = None,
                     metres: bool = False, eye_height: float | None = None) -> EyeHeight:
    """The eye height of a player in a level, in the level's own units.

    A game's rooms are built for its player: the eye stands at about a third
    (:data:`_EYE_PER_HEADROOM`) of the lower quartile of the headroom of its floors
    under their ceilings (Doom 41 units under 128, Cube 2 maps 14 under 32-48, a
    Hammer map 64 under 144, Quake maps in units / 32 1.4 under 3.5); when that quartile
    is a cavity between layers (under :data:`_THIN_ROOM` of the median headroom), it is
    taken over the rooms alone. A level in
    metres (glTF, by its specification) keeps :data:`EYE_HEIGHT` unless its rooms say
    the eye is :data:`_METRE_DOUBT` times higher (centimetres). A level with too few floors
    under a ceiling (a town, an open terrain) keeps :data:`EYE_HEIGHT`, unless it is lower
    than that (a blockout in other units): then 1/:data:`_LEVEL_EYES` of its height.

    Parameters
    ----------
    objects : SceneObjects
    up : (3,) float, optional
        The level's up axis (default ``objects.up``).
    metres : bool, optional
        Whether the level's unit is known to be the metre (glTF). Default False.
    eye_height : float, optional
        Given by the user: used as it is (the faces' reading is still found).

    Returns
    -------
    EyeHeight

    Raises
    ------
    InputError
        A non-positive ``eye_height`` or a zero ``up``.

    Notes
    -----
    One vertical ray per cell of the walk's map (:data:`_GRID_CELLS` along the
    longest side) finds every surface in the cell's column
    (:meth:`viscore.Scene.all_hits`); a headroom is the distance from an
    upward-facing surface to the downward-facing one straight above it. Read
    turned over, a level wound inward (Quake maps exported with their brushes'
    faces reversed) has its rooms there; it is read so when its headrooms as wound
    are :data:`_FLIP_RATIO` times lower (the thickness of its brushes), never when
    too few floors as wound have a ceiling (an open level: its boxes' insides,
    turned over, would read as thin rooms). A glTF
    level is read as wound (its specification fixes the winding). Deterministic.
    """
    if eye_height is not None:
        eye_height = as_positive(eye_height, "eye_height")
    up = np.asarray(objects.up if up is None else as_vector(up, "up"), dtype=np.float64)
    if np.linalg.norm(up) == 0:
        raise InputError("up: zero-length vector")
    up = up / np.linalg.norm(up)
    frame = _height_map(objects, up)[0]
    rooms, columns = _headroom(objects, up, frame)
    q25 = {k: float(np.percentile(r, 25)) if len(r) >= _ROOFED_COLUMNS * columns
           else float("nan") for k, r in rooms.items()}
    sign = 1.0
    # both readings must find rooms: a level whose floors as wound have no ceiling (an
    # open blockout of boxes, whose insides read turned over as thin rooms) is open, not
    # wound inward; a level wound inward reads as wound the insides of all its brushes
    if not metres and np.isfinite(q25[-1.0]) and np.isfinite(q25[1.0]) \
            and q25[1.0] * _FLIP_RATIO < q25[-1.0]:
        sign = -1.0
    headroom = q25[sign]
    if np.isfinite(headroom):  # a cavity between layers is no room: the rooms' quartile
        r = rooms[sign]
        thin = _THIN_ROOM * float(np.median(r))
        if headroom < thin:
            headroom = float(np.percentile(r[r >= thin], 25))
    guess = _EYE_PER_HEADROOM * headroom
    if eye_height is not None:
        return EyeHeight(eye_height, "given (--eye-height)", sign, headroom)
    if not np.isfinite(headroom):
        lo, hi = objects.built_bounds(up)[0]
        tall = float(np.abs(hi - lo) @ np.abs(up))
        if tall < EYE_HEIGHT:  # no person stands in it: not metres
            return EyeHeight(tall / _LEVEL_EYES, f"1/{_LEVEL_EYES:g} of the level's height "
                             f"({tall:.3g}, under the metre default {EYE_HEIGHT:g}: not "
                             f"metres); under {_ROOFED_COLUMNS:.0%} of its columns have a "
                             "floor under a ceiling to guess it from", sign, headroom)
        return EyeHeight(EYE_HEIGHT, f"{EYE_HEIGHT:g}, a metre default: under "
                         f"{_ROOFED_COLUMNS:.0%} of the level's columns have a floor under "
                         "a ceiling to guess it from", sign, headroom)
    said = (f"{_EYE_PER_HEADROOM:g} x the headroom of the lower quartile of its floors "
            f"under a ceiling ({headroom:.3g}"
            + (f"; cavities under {_THIN_ROOM:.2g} of the median left out)"
               if headroom != q25[sign] else ")")
            + ("; its faces read turned over" if sign < 0 else ""))
    if metres and guess < _METRE_DOUBT * EYE_HEIGHT:
        return EyeHeight(EYE_HEIGHT, f"{EYE_HEIGHT:g}: glTF units are metres (its rooms "
                         f"would say {guess:.3g})", sign, headroom)
    return EyeHeight(guess, said, sign, headroom)


# --------------------------------------------------------------------------- stances
@dataclass(frozen=True)
class Stance:
    """Where one camera stands, checked by ray casts.

    Attributes
    ----------
    kind : str
        ``'street'``, ``'close-up'`` (turned to the nearest wall), ``'elevated'``,
        ``'far'`` (outside the level, looking at it) or ``'given'`` (a path read from
        a file).
    height : float
        Distance down to the first surface under the eye, world units (``inf``
        when nothing is under it).
    floor : bool
        Whether that surface faces up (a floor, a step, a roof it stands on).
    headroom : float
        Distance up to the first surface over the eye, world units (``inf``: open).
    back_faces : float
        Share of the view's hits that are back faces (``nan`` when nothing is hit),
        floors seen from underneath not counted (the undersides of single-sided
        platforms and ramps over the eye).
    in_view : float
        Share of the view's rays that hit something.
    standing : bool
        A floor within :data:`_FLOOR_EYES` eye heights under the eye, headroom over
        :data:`_HEADROOM_EYES`, under :data:`_MAX_BACK_FACES` back faces and at least
        :data:`_MIN_IN_VIEW` of the view on something.
    moved : bool
        Whether the walk moved the camera from the place first planned (which did not
        stand well) to a nearby one that does.
    """

    kind: str
    height: float
    floor: bool
    headroom: float
    back_faces: float
    in_view: float
    standing: bool
    moved: bool = False

    def to_json(self) -> dict:
        """The fields, ``None`` for an infinite height or headroom or no view."""
        def num(x: float):
            return float(x) if np.isfinite(x) else None
        return {"kind": self.kind, "height_over_floor": num(self.height),
                "on_floor": bool(self.floor), "headroom": num(self.headroom),
                "back_faces": num(self.back_faces), "in_view": float(self.in_view),
                "standing": bool(self.standing), "moved": bool(self.moved)}


def _stance_arrays(objects: SceneObjects, cameras: Sequence[PathCamera], up: np.ndarray,
                   eye_height: float, sign: float) -> dict:
    """The ray casts of :func:`camera_stances`, as arrays over the cameras."""
    scene, _ = objects.combined
    n = len(cameras)
    eyes = np.array([c.position for c in cameras], dtype=np.float64).reshape(n, 3)
    out = {"height": np.full(n, np.inf), "floor": np.zeros(n, bool),
           "headroom": np.full(n, np.inf), "back": np.full(n, np.nan),
           "in_view": np.zeros(n)}
    if n == 0:
        return out
    t, tri = scene.first_hit(eyes, np.tile(-up, (n, 1)))
    out["height"] = t
    hit = tri >= 0
    out["floor"][hit] = sign * (_unit_normals(scene, tri[hit]) @ up) >= _WALKABLE
    out["headroom"], _ = scene.first_hit(eyes, np.tile(up, (n, 1)))
    w, h = _VIEW_RAYS
    origins, directions = [], []
    for c in cameras:
        o, d = c.camera(w, h).rays()
        origins.append(o)
        directions.append(d)
    o, d = np.concatenate(origins), np.concatenate(directions)
    t, tri = scene.first_hit(o, d)
    hit = tri >= 0
    back = np.zeros(len(tri), bool)
    normals = sign * _unit_normals(scene, tri[hit])
    # a floor seen from underneath (a single-sided platform or ramp over the eye) is
    # no wall the camera stands behind
    back[hit] = (np.einsum("ij,ij->i", normals, d[hit]) > 0) & (normals @ up < _WALKABLE)
    per = w * h
    hits = hit.reshape(n, per).sum(axis=1)
    out["in_view"] = hits / per
    with np.errstate(invalid="ignore", divide="ignore"):
        out["back"] = np.where(hits > 0, back.reshape(n, per).sum(axis=1) / hits, np.nan)
    return out


def _standing(a: dict, eye_height: float) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return (a["floor"] & (a["height"] <= _FLOOR_EYES * eye_height)
                & (a["headroom"] >= _HEADROOM_EYES * eye_height)
                & (a["back"] < _MAX_BACK_FACES) & (a["in_view"] >= _MIN_IN_VIEW))


def camera_stances(objects: SceneObjects, cameras: Sequence[PathCamera], *,
                   eye_height: float, up: npt.ArrayLike | None = None, sign: float = 1.0,
                   kinds: Sequence[str] | None = None) -> list[Stance]:
    """Where each camera stands: the floor under it, its headroom and what it sees.

    Parameters
    ----------
    objects : SceneObjects
    cameras : sequence of PathCamera
    eye_height : float
        The level's eye height, world units (:func:`guess_eye_height`).
    up : (3,) float, optional
        Default ``objects.up``.
    sign : float, optional
        +1 (default) reads the faces as wound, -1 turned over (:class:`EyeHeight`).
    kinds : sequence of str, optional
        Each camera's kind (default ``'given'``).

    Returns
    -------
    list of Stance

    Raises
    ------
    InputError
        A non-positive ``eye_height``, a zero ``up`` or ``kinds`` of another length.

    Notes
    -----
    Per camera: one ray straight down (the floor and the height over it), one
    straight up (headroom), and a 32 x 18 grid of rays through its view
    (:data:`_VIEW_RAYS`): the share that hit something, and the share of those hits
    on a back face (a face whose normal, as wound times ``sign``, points away from
    the eye) other than a floor seen from underneath (a walkable face: a
    single-sided platform over the eye hides no wall). Deterministic.

    Examples
    --------
    >>> import trimesh
    >>> from viscore.level.scene_graph import load_scene_objects
    >>> s = trimesh.Scene()
    >>> _ = s.add_geometry(trimesh.creation.box(bounds=[[-9, -1, -9], [9, 0, 9]]))
    >>> _ = s.add_geometry(trimesh.creation.box(bounds=[[-2, 0, 4], [2, 3, 5]]))
    >>> cam = PathCamera(np.array([0, 1.7, 0]), np.array([0, 0, 1.0]), np.array([0, 1.0, 0]))
    >>> st = camera_stances(load_scene_objects(s), [cam], eye_height=1.7)[0]
    >>> round(st.height, 6), st.standing
    (1.7, True)
    """
    eye_height = as_positive(eye_height, "eye_height")
    up = np.asarray(objects.up if up is None else as_vector(up, "up"), dtype=np.float64)
    if np.linalg.norm(up) == 0:
        raise InputError("up: zero-length vector")
    up = up / np.linalg.norm(up)
    kinds = ["given"] * len(cameras) if kinds is None else list(kinds)
    if len(kinds) != len(cameras):
        raise InputError(f"kinds: expected {len(cameras)}, got {len(kinds)}")
    a = _stance_arrays(objects, cameras, up, eye_height, float(np.sign(sign) or 1.0))
    ok = _standing(a, eye_height)
    return [Stance(kind=kinds[k], height=float(a["height"][k]), floor=bool(a["floor"][k]),
                   headroom=float(a["headroom"][k]), back_faces=float(a["back"][k]),
                   in_view=float(a["in_view"][k]), standing=bool(ok[k]))
            for k in range(len(cameras))]


# --------------------------------------------------------------------------- the walk
@dataclass(frozen=True, eq=False)
class Walk:
    """A generated camera walk, where each camera stands, and what was moved or dropped.

    Attributes
    ----------
    cameras : tuple of PathCamera
    stances : tuple of Stance
        One per camera.
    up : (3,) float64
        The level's up axis.
    eye : EyeHeight
        The eye height used and how it was set.
    asked : int
        Frames asked for.
    moved : int
        Cameras moved to a nearby candidate, or turned (to the middle of the walk,
        about, or down to a level under the eye), because the planned pose did not
        stand.
    dropped : int
        Frames dropped: no candidate of their stretch of the walk stands well.
    floors : bool
        Whether the walk went on the level's floors (else on the street map).
    """

    cameras: tuple
    stances: tuple
    up: np.ndarray
    eye: EyeHeight
    asked: int
    moved: int
    dropped: int
    floors: bool

    def to_json(self) -> dict:
        """The walk's summary for ``cull.json`` (the per-frame stances go per frame)."""
        kinds = [s.kind for s in self.stances]
        standing = [s.standing for s in self.stances]
        far = kinds.count("far")
        return {"up": [float(x) for x in self.up], **self.eye.to_json(),
                "frames_asked": self.asked, "frames": len(self.cameras),
                "standing": int(sum(standing)),
                "standing_share": (sum(standing) / len(standing)) if standing else 0.0,
                "moved": self.moved, "dropped": self.dropped, "far": far,
                "kinds": {k: kinds.count(k) for k in dict.fromkeys(kinds)},
                "on": "floors" if self.floors else "street map"}


def camera_path(objects: SceneObjects, *, frames: int = 120, seed: int = 0,
                eye_height: float | None = None, fov: float = DEFAULT_FOV,
                up: npt.ArrayLike | None = None, metres: bool = True) -> list[PathCamera]:
    """The cameras of :func:`camera_walk` (same parameters), as a list.

    Examples
    --------
    >>> import trimesh
    >>> from viscore.level.scene_graph import load_scene_objects
    >>> s = trimesh.Scene()
    >>> _ = s.add_geometry(trimesh.creation.box(bounds=[[-20, -1, -20], [20, 0, 20]]))
    >>> _ = s.add_geometry(trimesh.creation.box(bounds=[[-2, 0, 4], [2, 3, 5]]))
    >>> len(camera_path(load_scene_objects(s), frames=10)) <= 10
    True
    """
    return list(camera_walk(objects, frames=frames, seed=seed, eye_height=eye_height,
                            fov=fov, up=up, metres=metres).cameras)


def camera_walk(objects: SceneObjects, *, frames: int = 120, seed: int = 0,
                eye_height: float | None = None, fov: float = DEFAULT_FOV,
                up: npt.ArrayLike | None = None, metres: bool = True,
                eye: EyeHeight | None = None) -> Walk:
    """A deterministic camera walk where a player stands, each camera checked by rays.

    The walk the culling simulation follows: on the level's floors at eye height
    (looking ahead, and every fourth frame turned to the nearest wall for a
    close-up, where solid occluders beat planar ones: Papaioannou et al. 2006,
    Fig. 5, locations A-C), then an elevated pass back over the same floors,
    at most :data:`_ELEVATED_EYES` eye heights higher and under the ceilings,
    looking ahead and down.

    Parameters
    ----------
    objects : SceneObjects
        The scene (:func:`viscore.level.scene_graph.load_scene_objects`).
    frames : int, optional
        Number of cameras asked for, >= 1 (default 120): 80% on the floors (a
        quarter of them close-ups), 20% elevated. Frames whose stretch of the walk
        holds no place that stands well are dropped (``Walk.dropped``).
    seed : int, optional
        Seed of the waypoint choice (default 0): same scene and seed, same walk.
    eye_height : float, optional
        Eye height over the floor, world units. Default: :func:`guess_eye_height`
        (the metre default :data:`EYE_HEIGHT` when ``metres``).
    fov : float, optional
        Horizontal field of view of every camera, degrees in [0.1, 179]
        (:data:`MIN_FOV`, :data:`MAX_FOV`; default 90).
    up : (3,) float, optional
        The scene's up axis. Default ``objects.up`` (+Y for glTF).
    metres : bool, optional
        Whether the level's unit is the metre (glTF, the built-in scenes; default
        True): see :func:`guess_eye_height`.
    eye : EyeHeight, optional
        An eye height already found (:func:`guess_eye_height`); overrides
        ``eye_height`` and ``metres``.

    Returns
    -------
    Walk

    Raises
    ------
    InputError
        On a bad option.

    Notes
    -----
    The level's floors are found by casting rays down through every cell of a
    512-cell map over its built part (:func:`_floors`: every upward-facing
    surface with room to stand over it, joined across cells within a step; the
    largest such set walked, or the lowest of those half its size: the floors
    under an indoor level's ceilings, a town's streets rather than its roofs). A
    cell is free when nothing stands in it between a step over its floor and the
    eye, every edge of the objects sampled at a quarter of a cell so that thin
    things block their cells (:func:`_edge_marks`). Waypoints are free cells drawn
    with probability proportional to their squared clearance in the largest
    connected free region (so every camera is reachable from every other), visited
    in a nearest-neighbour tour and joined by least-cost routes that keep to the
    middle of the free space (:func:`skimage.graph.route_through_array`). A level
    without such floors is walked on its street map, an eye height over the map's
    ground (the 5th percentile of the heights seen from above).

    Every camera is then checked by rays (:func:`camera_stances`): a floor within
    :data:`_FLOOR_EYES` eye heights under it, headroom, under
    :data:`_MAX_BACK_FACES` back faces in view (not behind a wall, in solid
    geometry or outside the level's shell) and something in view. Each frame has
    :data:`_CANDIDATES` candidate places along its stretch of the walk; the
    planned one is kept when it stands well, else the nearest that does
    (``Walk.moved``), else the frame is dropped (``Walk.dropped``); a place that
    stands but sees nothing or back faces is first turned towards the middle of
    the walk, about, or towards the middle and :data:`_LOOK_DOWN` degrees down
    (moved too). A level with
    no route at all is looked at from outside, cameras of kind ``'far'``.
    """
    frames = as_positive_int(frames, "frames", maximum=100_000)
    seed = as_seed(seed)
    fov = _check_fov(fov, "fov")
    up = np.asarray(objects.up if up is None else as_vector(up, "up"), dtype=np.float64)
    if np.linalg.norm(up) == 0:
        raise InputError("up: zero-length vector")
    up = up / np.linalg.norm(up)
    if eye is None:
        eye = guess_eye_height(objects, up=up, metres=metres, eye_height=eye_height)
    eye_height, sign = float(eye.value), float(eye.sign)
    rng = np.random.default_rng(seed)
    frame, height, ground, facing = _height_map(objects, up)
    facing = sign * facing
    e1, e2, a0, b0, cell, shape = frame[:6]
    top = float(height.max())
    n_high = frames // 5
    n_street = frames - n_high
    on_floors = False
    held, on_floor, on_head = _floors(objects, up, frame, eye_height, sign)
    floor, head = np.full(shape, ground), np.full(shape, np.inf)
    extent = float(np.abs(objects.bounds[1] - objects.bounds[0]) @ np.abs(up))
    if extent < eye_height and not eye.reason.startswith("given"):
        # a scene lower than the eye (a model smaller than a person, or in other units):
        # on its street map, the eye down to half its height above the ground (a
        # twentieth of its width if that is more: a flat scene), so that the cameras look
        # at it, not over it
        eye_height = max(0.5 * (top - ground), 0.05 * cell * max(shape))
    elif held.any():
        walk = _floor_free(objects, up, frame, held, on_floor, on_head, eye_height)
        if walk[0].any():
            (free, clearance, tall), floor, head = walk, on_floor, on_head
            on_floors = True
    if not on_floors:  # the street map: an eye over the ground
        free, clearance = _free_space(objects, up, frame, height, ground, eye_height)
        tall = height > ground + max(min(3 * eye_height, 0.5 * (top - ground)),
                                     0.15 * (top - ground))
    route = _route(free, clearance, tall, rng, waypoints=max(3, min(12, frames // 8 + 2)))

    def world(cells: np.ndarray, level: np.ndarray | float) -> np.ndarray:
        a = a0 + (cells[:, 0] + 0.5) * cell
        b = b0 + (cells[:, 1] + 0.5) * cell
        return a[:, None] * e1 + b[:, None] * e2 + np.reshape(level, (-1, 1)) * up

    def horizontal(d2: np.ndarray) -> np.ndarray:
        return d2[:, :1] * e1 + d2[:, 1:] * e2

    def at(grid: np.ndarray, cells: np.ndarray) -> np.ndarray:
        i, j = np.clip(np.round(cells).astype(int), 0, np.array(shape) - 1).T
        return grid[i, j]

    cams: list[PathCamera] = []
    kinds: list[str] = []
    moved_flags: list[bool] = []
    moved = dropped = 0
    if len(route) >= 2:
        from scipy import ndimage

        _, (ia, ib) = ndimage.distance_transform_edt(~tall, return_indices=True)
        m = _CANDIDATES
        for part, count, start, stop in (("street", n_street, 0.0, 1.0),
                                         ("elevated", n_high, 1.0, 0.0)):
            if count == 0:
                continue
            pts, tangent = _resample(route, count * m, start, stop)
            forward = horizontal(tangent)
            kind = np.array([part] * len(pts), dtype=object)
            if part == "street":  # every fourth frame faces the nearest tall thing
                for k in range(2 * m, len(pts), 4 * m):
                    for c in range(k - m // 2, min(len(pts), k + m - m // 2)):
                        i, j = np.clip(np.round(pts[c]).astype(int), 0, np.array(shape) - 1)
                        to_wall = np.array([ia[i, j] - pts[c, 0], ib[i, j] - pts[c, 1]])
                        if np.linalg.norm(to_wall) > 0:
                            forward[c] = horizontal((to_wall / np.linalg.norm(to_wall))[None])[0]
                            kind[c] = "close-up"
                level = at(floor, pts) + eye_height
            else:  # raised over the floor, under the ceiling, looking ahead and down
                rise = np.linspace(0.5, _ELEVATED_EYES, len(pts)) * eye_height
                rise = np.clip(np.minimum(rise, at(head, pts) - _STAND_ROOM * eye_height),
                               0.0, None)
                level = at(floor, pts) + eye_height + rise
                forward = forward - np.tan(np.radians(_LOOK_DOWN)) * up
            positions = world(pts, level)
            cand = [_pose(p, f, up, fov, "camera")
                    for p, f in zip(positions, forward, strict=True)]
            ok = _standing(_stance_arrays(objects, cand, up, eye_height, sign), eye_height)
            turned = np.zeros(len(cand), dtype=bool)
            # a place that stands but looks at nothing or at back faces (off the edge of
            # a level of platforms, into a wall's back): turned towards the middle of the
            # walk, else about, else towards the middle and down
            middle = route.mean(axis=0)
            for towards, down in ((middle[None] - pts, part == "elevated"),
                                  (-tangent, part == "elevated"),
                                  (middle[None] - pts, True)):
                bad = np.flatnonzero(~ok)
                norm = np.linalg.norm(towards[bad], axis=1)
                bad = bad[norm > 0]
                if not len(bad):
                    break
                look = horizontal(towards[bad] / np.linalg.norm(towards[bad], axis=1)[:, None])
                if down:  # from a high platform, the level is under the eye
                    look = look - np.tan(np.radians(_LOOK_DOWN)) * up
                alt = [_pose(cand[c].position, f, up, fov, "camera")
                       for c, f in zip(bad, look, strict=True)]
                good = _standing(_stance_arrays(objects, alt, up, eye_height, sign),
                                 eye_height)
                for i in np.flatnonzero(good):
                    cand[bad[i]], ok[bad[i]], turned[bad[i]] = alt[i], True, True
            # frame k owns candidates [k m, (k + 1) m); planned: the middle one
            for k in range(count):
                own = np.arange(k * m, (k + 1) * m)
                planned = k * m + m // 2
                order = own[np.argsort(np.abs(own - planned), kind="stable")]
                good = order[ok[order]]
                if not len(good):
                    dropped += 1
                    continue
                pick = int(good[0])
                shifted = bool(pick != planned or turned[pick])
                moved += shifted
                cams.append(cand[pick])
                kinds.append(str(kind[pick]))
                moved_flags.append(shifted)
    if not cams:  # no route, or nowhere to stand: the level from outside, labelled far
        n_far = frames
        dropped = 0
        centre2 = np.array([(shape[0] - 1) / 2, (shape[1] - 1) / 2])
        radius = 0.75 * np.hypot(*shape)
        phase = rng.uniform(0, 2 * np.pi)
        angles = phase + 2 * np.pi * np.arange(n_far) / max(1, n_far)
        ring = centre2 + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        lift = ground + 0.3 * radius * cell + eye_height
        positions = world(ring, np.full(n_far, lift))
        targets = world(np.repeat(centre2[None], n_far, 0), np.full(n_far, ground))
        cams = [_pose(p, t - p, up, fov, "camera")
                for p, t in zip(positions, targets, strict=True)]
        kinds = ["far"] * n_far
        moved_flags = [False] * n_far
    stances = camera_stances(objects, cams, eye_height=eye_height, up=up, sign=sign,
                             kinds=kinds)
    stances = [dataclasses.replace(s, moved=f) for s, f in zip(stances, moved_flags,
                                                                strict=True)]
    if eye_height != eye.value:
        eye = dataclasses.replace(eye, value=eye_height,
                                  reason=eye.reason + f"; lowered to {eye_height:.3g} for a "
                                  "scene lower than an eye")
    return Walk(cameras=tuple(cams), stances=tuple(stances), up=up, eye=eye, asked=frames,
                moved=int(moved), dropped=int(dropped), floors=on_floors)
