"""Regenerate the procedural built-in scenes of viscore (deterministic).

Run from anywhere: ``python data/make_scenes.py``. Every scene is made from
fixed parameters and fixed seeds, so the PLY files come out byte-identical.

The ``building_<style>(seed=...)`` functions make game-style buildings (loose wall
panels, thin walls, open doors and windows, interiors, decorations covering seams,
duplicated and intersecting faces), the hard case of occluder generation described
by Wu et al. (2022, sec. 1, Fig. 3). Importing this module has no side effects.

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in Digital
   Games". Computer Graphics Forum 41(7) (Pacific Graphics), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from viscore.voxel.grid import VoxelGrid, voxel_boundary_mesh

HERE = Path(__file__).resolve().parent


def _voxel_solid(solid: np.ndarray, size: float) -> trimesh.Trimesh:
    """Closed mesh of a boolean voxel solid scaled to ``size``, centred at 0."""
    pitch = size / max(solid.shape)
    origin = -0.5 * pitch * np.array(solid.shape, dtype=float)
    return voxel_boundary_mesh(solid, VoxelGrid(origin, pitch, solid.shape))


def fat_torus() -> trimesh.Trimesh:
    return trimesh.creation.torus(major_radius=1.0, minor_radius=0.6, major_sections=48,
                                  minor_sections=24)


def box_with_hole() -> trimesh.Trimesh:
    n = 20
    solid = np.zeros((n, n, n), bool)
    solid[:] = True
    solid[1:-1, 1:-1, 1:-1] = False  # hollow, wall one cell thick
    solid[9:11, 0, 9:11] = False  # 2 x 2 cell hole in the -Y wall
    return _voxel_solid(solid, 2.0)


def sponge() -> trimesh.Trimesh:
    n = 27
    i = np.arange(n)
    digits = np.stack([(i // 9) % 3, (i // 3) % 3, i % 3])  # base-3 digits
    mid = digits == 1  # (3 levels, n)
    cx, cy, cz = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    holes = np.zeros((n, n, n), bool)
    for level in (1, 2):  # level-2 sponge: keep the coarsest level fully solid per cell
        mx, my, mz = mid[level][cx], mid[level][cy], mid[level][cz]
        holes |= (mx & my) | (my & mz) | (mx & mz)
    coarse = np.repeat(np.repeat(np.repeat(np.ones((1, 1, 1), bool), n, 0), n, 1), n, 2)
    return _voxel_solid(coarse & ~holes, 2.0)


def terrain() -> trimesh.Trimesh:
    n = 64
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    z = (0.15 * np.sin(3 * x) * np.cos(2 * y) + 0.4 * np.exp(-((x - 0.3) ** 2 + y**2) / 0.1)
         + 0.25 * np.exp(-((x + 0.5) ** 2 + (y + 0.4) ** 2) / 0.05))
    vertices = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def _tubes(paths: np.ndarray, radius: float, sections: int) -> trimesh.Trimesh:
    """Closed tubes along polylines.

    Parameters
    ----------
    paths : (P, K, 3) float
        P polylines of K >= 2 points each.
    radius : float
    sections : int
        Sides of the cross-section (>= 3).

    Returns
    -------
    trimesh.Trimesh
        P closed tubes, ``2 s (K - 1) + 2 (s - 2)`` triangles each, outward normals.
    """
    paths = np.asarray(paths, dtype=np.float64)
    n_paths, k, _ = paths.shape
    s = int(sections)
    seg = np.diff(paths, axis=1)
    seg /= np.linalg.norm(seg, axis=2, keepdims=True)
    tan = np.empty_like(paths)
    tan[:, 0], tan[:, -1] = seg[:, 0], seg[:, -1]
    tan[:, 1:-1] = seg[:, :-1] + seg[:, 1:]
    tan /= np.linalg.norm(tan, axis=2, keepdims=True)
    # parallel-transport frames (a loop over the K points, vectorized over the strands)
    u = np.empty_like(paths)
    a = np.where(np.abs(tan[:, 0, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u0 = a - (a * tan[:, 0]).sum(1, keepdims=True) * tan[:, 0]
    u[:, 0] = u0 / np.linalg.norm(u0, axis=1, keepdims=True)
    for i in range(1, k):
        v = u[:, i - 1] - (u[:, i - 1] * tan[:, i]).sum(1, keepdims=True) * tan[:, i]
        u[:, i] = v / np.linalg.norm(v, axis=1, keepdims=True)
    w = np.cross(tan, u)
    ang = 2 * np.pi * np.arange(s) / s
    ring = (np.cos(ang)[:, None] * u[:, :, None, :] + np.sin(ang)[:, None] * w[:, :, None, :])
    verts = (paths[:, :, None, :] + radius * ring).reshape(-1, 3)  # (P*K*s, 3)
    # faces of one tube, then offset per tube
    j = np.arange(s)
    jn = (j + 1) % s
    i = np.arange(k - 1)[:, None]
    a0, a1 = i * s + j, i * s + jn
    b0, b1 = (i + 1) * s + j, (i + 1) * s + jn
    side = np.concatenate([np.stack([a0, a1, b1], -1), np.stack([a0, b1, b0], -1)],
                          axis=1).reshape(-1, 3)
    fan = np.arange(1, s - 1)
    cap0 = np.stack([np.zeros_like(fan), fan + 1, fan], -1)
    cap1 = (k - 1) * s + np.stack([np.zeros_like(fan), fan, fan + 1], -1)
    one = np.concatenate([side, cap0, cap1])
    faces = (one[None] + (np.arange(n_paths) * k * s)[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(verts, faces, process=False)


def _unit(rng: np.random.Generator, n: int) -> np.ndarray:
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def hairball(count: int = 550, *, steps: int = 12, step: float = 0.3, turn: float = 0.35,
             ball: float = 0.7, fuzz: float = 0.35, radius: float = 0.012, sections: int = 3,
             seed: int = 20261122) -> trimesh.Trimesh:
    """A dense tangle of curly strands, a stand-in for the HAIRBALL of Silvennoinen et al.

    The paper's Figure 1 hairball (about 2.9M triangles) is opaque in its core
    with a fuzzy rim. Each of ``count`` strands is a closed tube along a
    persistent random walk: it starts uniformly inside the ball of radius
    ``ball``, takes ``steps`` steps of length ``step`` whose direction turns by
    about ``turn`` radians per step, and is steered back inward when it leaves
    the ball of radius ``ball + fuzz`` (the wandering ends make the rim fuzzy).
    The scene is scaled to fit the unit ball. With the defaults: 40,700
    triangles; from orbit views the mesh hides 48% of the quads (an opaque
    ball of its size about 72%).
    """
    rng = np.random.default_rng(seed)
    pos = _unit(rng, count) * ball * rng.uniform(0, 1, (count, 1)) ** (1 / 3)
    d = _unit(rng, count)
    pts = [pos]
    for _ in range(steps):
        d = d + turn * rng.normal(size=d.shape) / np.sqrt(3)
        r = np.linalg.norm(pos, axis=1, keepdims=True)
        radial = (d * pos).sum(1, keepdims=True)
        out = (r > ball + fuzz * rng.uniform(0, 1, (count, 1))) & (radial > 0)
        d = np.where(out, d - 1.5 * pos / r * np.abs(radial) / r, d)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        pos = pos + step * d
        pts.append(pos)
    paths = np.stack(pts, axis=1)
    paths /= np.linalg.norm(paths, axis=2).max()
    return _tubes(paths, radius, sections)


def city_block() -> trimesh.Trimesh:
    rng = np.random.default_rng(7)
    parts = []
    for i in range(5):
        for j in range(5):
            h = float(rng.uniform(0.5, 3.0))
            box = trimesh.creation.box(
                extents=(0.7, 0.7, h),
                transform=trimesh.transformations.translation_matrix((i - 2.0, j - 2.0, h / 2)))
            keep = box.face_normals[:, 2] > -0.5  # open bottom, as game buildings are
            parts.append(trimesh.Trimesh(box.vertices, box.faces[keep], process=False))
    for k in range(4):  # free-standing walls between the rows
        parts.append(trimesh.creation.box(
            extents=(4.5, 0.05, 0.8),
            transform=trimesh.transformations.translation_matrix((0, k - 1.5, 0.4))))
    return trimesh.util.concatenate(parts)


# ----------------------------------------------------------------------------- buildings
# Game-style buildings (Wu et al. 2022, sec. 1 and Fig. 3 describe what game building
# meshes look like): every wall is cut into separate loose panels (closed boxes, or boxes
# open at the bottom), walls are 0.5-2% of the building thick, doors and windows are real
# openings, some framed; rooms, floors and stairs are reachable through the doors;
# decorations (corner pillars, ledges, window frames, sills, railings) cover the seams
# between panels, so removing one opens a hole; blind windows, niches and vents are
# recessed into walls with a back face, and plaques set into them (the wall's face then
# has a hole with the input just behind it, the case of Wu et al. 2022 Fig. 6); panels
# overlap and intersect, and every
# building holds an exactly duplicated panel and a coincident decal. Units are metres,
# +z is up, the ground is z = 0 and the footprint is centred on the origin.
#
# Each ``building_<style>(seed=...)`` returns a ``trimesh.Trimesh`` (process=False) whose
# ``metadata`` records, by construction: "doors" (every outside door as (centre, inward
# unit direction, width): the centre lies in the wall's mid-plane), "rooms" (points at
# standing height inside rooms, clear of every panel), "wall_thickness" (m),
# "open_bottom" (no geometry on or under the ground), "split_faces" (each flat side of
# a part has its own vertices, as in exported game kits) and "openings" (every opening,
# recess and plaque of a wall: kind "through", "recess" or "plaque", centre in the wall's
# mid-plane, outward unit normal, the wall's thickness, size along the run and up).
# The seed varies the details
# (window rhythm, which windows are framed, small dimensions); the defaults make the
# shipped files.

_EPS = 1e-9
#: Depth of a recess's back face behind the wall's outer face, fraction of the wall's
#: thickness; a plaque stands this far (m) proud of the outer face.
RECESS_DEPTH = 0.4
PLAQUE_PROUD = 0.03
#: Corner indices of each box side (corner bit 0: x, bit 1: y, bit 2: z at the upper end).
_BOX_SIDES = {"-x": (0, 2, 6, 4), "+x": (1, 3, 7, 5), "-y": (0, 1, 5, 4),
              "+y": (2, 3, 7, 6), "-z": (0, 1, 3, 2), "+z": (4, 5, 7, 6)}


def _outward(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces of a convex part wound so their normals point away from its vertex centroid."""
    tri = vertices[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normal, tri.mean(axis=1) - vertices.mean(axis=0)) < 0
    out = faces.copy()
    out[flip] = out[flip][:, ::-1]
    return out


def _rect_minus(u0: float, u1: float, v0: float, v1: float,
                holes: list[tuple[float, float, float, float]]) -> list[tuple]:
    """Rectangle [u0, u1] x [v0, v1] minus axis-aligned holes, as column pieces (u, v)."""
    cuts = sorted({u0, u1} | {min(max(h[i], u0), u1) for h in holes for i in (0, 1)})
    pieces = []
    for ua, ub in zip(cuts[:-1], cuts[1:], strict=True):
        if ub - ua < 1e-6:
            continue
        mid = 0.5 * (ua + ub)
        blocked = sorted((max(h[2], v0), min(h[3], v1)) for h in holes
                         if h[0] < mid < h[1] and h[3] > v0 and h[2] < v1)
        v = v0
        for ba, bb in blocked:
            if ba - v > 1e-6:
                pieces.append((ua, ub, v, ba))
            v = max(v, bb)
        if v1 - v > 1e-6:
            pieces.append((ua, ub, v, v1))
    return pieces


class _Builder:
    """Collects loose convex parts (each with its own vertices) and construction data."""

    def __init__(self, *, split: bool = False) -> None:
        self.parts: list[tuple[np.ndarray, np.ndarray]] = []
        self.doors: list[tuple[list[float], list[float], float]] = []
        self.rooms: list[list[float]] = []
        self.openings: list[dict] = []
        self.split = split  # every flat side its own vertices, as exported game kits are

    def add(self, vertices: np.ndarray, faces: np.ndarray) -> int:
        vertices, faces = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
        if not self.split or len(faces) <= 2:
            self.parts.append((vertices, faces))
            return len(self.parts) - 1
        tri = vertices[faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal = np.round(normal / np.linalg.norm(normal, axis=1)[:, None], 6)
        _, side = np.unique(normal, axis=0, return_inverse=True)
        for k in range(side.max() + 1):
            used, inverse = np.unique(faces[side.ravel() == k], return_inverse=True)
            self.parts.append((vertices[used], inverse.reshape(-1, 3)))
        return len(self.parts) - 1

    def sheet(self, corners, up) -> int:
        """One-sided flat quad (4, 3), wound so its normal points along ``up``."""
        corners = np.asarray(corners, float)
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        if normal @ np.asarray(up, float) < 0:
            faces = faces[:, ::-1]
        return self.add(corners, faces)

    def box(self, lo, hi, open_sides: str = "") -> int:
        """Axis-aligned box; ``open_sides`` lists sides left open, e.g. "-z"."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
        vertices = np.where(bits == 1, hi, lo)
        quads = [q for side, q in _BOX_SIDES.items() if side not in open_sides]
        faces = np.array([f for a, b, c, d in quads for f in ((a, b, c), (a, c, d))])
        return self.add(vertices, _outward(vertices, faces))

    def prism(self, poly, axis: int, lo: float, hi: float) -> int:
        """Convex polygon ``poly`` (k, 2) in the other two axes (increasing order), extruded
        along ``axis`` from ``lo`` to ``hi``."""
        poly = np.asarray(poly, float)
        k = len(poly)
        others = [a for a in range(3) if a != axis]
        vertices = np.zeros((2 * k, 3))
        vertices[:, others[0]] = np.tile(poly[:, 0], 2)
        vertices[:, others[1]] = np.tile(poly[:, 1], 2)
        vertices[:, axis] = np.repeat([lo, hi], k)
        i = np.arange(k)
        j = (i + 1) % k
        fan = np.stack([np.zeros(k - 2, int), i[1:-1], i[2:]], axis=1)
        faces = np.concatenate([fan, fan + k, np.stack([i, j, j + k], 1),
                                np.stack([i, j + k, i + k], 1)])
        return self.add(vertices, _outward(vertices, faces))

    def pyramid(self, lo, hi, apex) -> int:
        """Pyramid on the rectangle lo..hi (x, y) at height lo[2], apex (x, y, z)."""
        (x0, y0, z0), (x1, y1) = lo, hi
        vertices = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0], apex])
        faces = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
        return self.add(vertices, _outward(vertices, faces))

    def column(self, cx: float, cy: float, radius: float, z0: float, z1: float,
               sides: int = 8) -> int:
        angle = 2 * np.pi * (np.arange(sides) + 0.5) / sides
        return self.prism(np.stack([cx + radius * np.cos(angle),
                                    cy + radius * np.sin(angle)], 1), 2, z0, z1)

    def duplicate(self, part: int) -> int:
        """An exact copy of a part: every face of it twice, coincident."""
        vertices, faces = self.parts[part]
        return self.add(vertices.copy(), faces.copy())

    def decal(self, part: int, normal) -> int:
        """The faces of ``part`` facing ``normal``, copied as an open sheet (coincident)."""
        vertices, faces = self.parts[part]
        tri = vertices[faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        keep = faces[n @ np.asarray(normal, float) > 0.9 * np.linalg.norm(n, axis=1)]
        used, inverse = np.unique(keep, return_inverse=True)
        return self.add(vertices[used], inverse.reshape(-1, 3))

    # walls along x ("x": the wall runs in x at y = at) or along y ("y": x = at)
    def wbox(self, run: str, u, w, z, open_sides: str = "") -> int:
        if run == "x":
            return self.box((u[0], w[0], z[0]), (u[1], w[1], z[1]), open_sides)
        return self.box((w[0], u[0], z[0]), (w[1], u[1], z[1]), open_sides)

    def wall(self, run: str, at: float, u0: float, u1: float, z0: float, z1: float, t: float,
             openings=(), *, out: int = 1, open_bottom: bool = False, gap: float = 0.05,
             frame: float = 0.12, depth: float = 0.04) -> list[int]:
        """Wall of loose panels around openings (a0, a1, b0, b1, kind), a along the run.

        ``kind`` True: a framed opening, cut ``gap`` wider than its frame's inside on
        every side but a door's sill, so the frame bars (``frame`` wide, proud of both
        faces by ``depth``) cover the slot and overlap the panels: removing a frame opens
        a hole. Framed windows also get a sill on the outer side (``out``: +1 or -1 along
        the normal). False: an opening cut to size. "recess": a blind window, niche or
        vent: the panels are cut round it and a back block fills the wall from
        :data:`RECESS_DEPTH` x ``t`` behind the outer face to the inner face (the
        outer face has a hole with the input just behind it, Wu et al. 2022 Fig. 6).
        "plaque": a plaque set into the wall, through its thickness and
        :data:`PLAQUE_PROUD` proud of the outer face. Every opening is recorded in
        ``openings`` (kind "through" for True and False).
        """
        cuts = []
        for a0, a1, b0, b1, framed in openings:
            g = gap if framed is True else 0.0
            cuts.append((a0 - g, a1 + g, b0 - g if b0 > z0 + _EPS else z0 - 1.0, b1 + g))
        ids = []
        half = 0.5 * t
        for ua, ub, za, zb in _rect_minus(u0, u1, z0, z1, cuts):
            sides = "-z" if open_bottom and za <= z0 + _EPS else ""
            ids.append(self.wbox(run, (ua, ub), (at - half, at + half), (za, zb), sides))
        face = at + out * half  # the outer face
        normal = [0.0, float(out), 0.0] if run == "x" else [float(out), 0.0, 0.0]
        for a0, a1, b0, b1, kind in openings:
            if kind == "recess":
                self.wbox(run, (a0, a1), sorted((face - out * RECESS_DEPTH * t, at - out * half)),
                          (b0, b1))
            elif kind == "plaque":
                self.wbox(run, (a0, a1), sorted((at - out * half, face + out * PLAQUE_PROUD)),
                          (b0, b1))
            mid = 0.5 * (a0 + a1)
            centre = [mid, at, 0.0] if run == "x" else [at, mid, 0.0]
            centre[2] = 0.5 * (max(b0, z0) + b1)
            self.openings.append({"kind": kind if isinstance(kind, str) else "through",
                                  "centre": centre, "normal": normal, "thickness": t,
                                  "size": [a1 - a0, b1 - max(b0, z0)]})
        w = (at - half - depth, at + half + depth)
        for a0, a1, b0, b1, framed in openings:
            if framed is not True:
                continue
            door = b0 <= z0 + _EPS
            zlo = b0 if door else b0 - frame
            sides = "-z" if door and open_bottom else ""
            self.wbox(run, (a0 - frame, a0), w, (zlo, b1 + frame), sides)
            self.wbox(run, (a1, a1 + frame), w, (zlo, b1 + frame), sides)
            self.wbox(run, (a0, a1), w, (b1, b1 + frame))
            if not door:
                self.wbox(run, (a0, a1), w, (b0 - frame, b0))
                face = at + out * half
                sill = sorted((face - out * 0.02, face + out * 0.16))
                self.wbox(run, (a0 - frame - 0.05, a1 + frame + 0.05), sill,
                          (b0 - frame - 0.06, b0 - frame + 0.02))
        return ids

    def storey(self, x0: float, x1: float, y0: float, y1: float, z0: float, z1: float,
               t: float, openings: dict, *, corner: str = "overlap", pillar: float = 0.0,
               open_bottom: bool = False, skip: tuple = (), **wall_options) -> dict:
        """Four walls on the rectangle's centre lines; ``openings``: side -> list.

        Sides are "front" (y = y0), "back" (y = y1), "left" (x = x0), "right" (x = x1).
        ``corner``: "overlap" (walls run through each other's corners), "butt" (the side
        walls end on the faces of the front and back walls, coincident faces) or "pillar"
        (walls stop inside a corner pillar ``pillar`` wide that the caller adds).
        """
        half = 0.5 * t
        if corner == "overlap":
            ex, ey = half, half
        elif corner == "butt":
            ex, ey = half, -half
        else:
            ex = ey = -(0.5 * pillar - 0.03)
        spec = {"front": ("x", y0, x0 - ex, x1 + ex, -1), "back": ("x", y1, x0 - ex, x1 + ex, 1),
                "left": ("y", x0, y0 - ey, y1 + ey, -1), "right": ("y", x1, y0 - ey, y1 + ey, 1)}
        out = {}
        for side, (run, at, u0, u1, sign) in spec.items():
            if side in skip:
                continue
            out[side] = self.wall(run, at, u0, u1, z0, z1, t, openings.get(side, ()),
                                  out=sign, open_bottom=open_bottom, **wall_options)
        return out

    def corner_pillars(self, x0, x1, y0, y1, z0, z1, size) -> None:
        h = 0.5 * size
        for x in (x0, x1):
            for y in (y0, y1):
                self.box((x - h, y - h, z0), (x + h, y + h, z1))

    def ledge(self, x0, x1, y0, y1, z0, z1, t, proud) -> None:
        """Band round the rectangle's walls, from inside the wall to ``proud`` outside."""
        a = 0.5 * t + proud
        b = 0.5 * t - 0.04  # stops inside the wall: overlaps the panels
        self.box((x0 - a, y0 - a, z0), (x1 + a, y0 + b, z1))
        self.box((x0 - a, y1 - b, z0), (x1 + a, y1 + a, z1))
        self.box((x0 - a, y0 + b, z0), (x0 + b, y1 - b, z1))
        self.box((x1 - b, y0 + b, z0), (x1 + a, y1 - b, z1))

    def slab(self, x0, x1, y0, y1, z0, z1, holes=()) -> None:
        for xa, xb, ya, yb in _rect_minus(x0, x1, y0, y1, list(holes)):
            self.box((xa, ya, z0), (xb, yb, z1))

    def stairs(self, x0, x1, y0, z0, rise: float, steps: int, going: float = 0.25,
               sign: int = 1, open_bottom: bool = False) -> None:
        """Straight flight along y (``sign``), each step a floating block."""
        step = rise / steps
        for i in range(steps):
            ya, yb = sorted((y0 + sign * i * going, y0 + sign * (i + 1) * going))
            self.box((x0, ya, z0 + i * step), (x1, yb, z0 + (i + 1) * step),
                     "-z" if open_bottom and i == 0 else "")

    def railing(self, p0, p1, z0: float, height: float = 1.0, spacing: float = 1.2,
                post: float = 0.06) -> None:
        """Posts and two rails along the axis-aligned segment p0 -> p1 (x, y) at z0."""
        p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
        n = max(1, int(np.ceil(np.linalg.norm(p1 - p0) / spacing - 1e-9)))
        h = 0.5 * post
        for s in np.linspace(0.0, 1.0, n + 1):
            c = p0 + s * (p1 - p0)
            self.box((c[0] - h, c[1] - h, z0), (c[0] + h, c[1] + h, z0 + height))
        lo, hi = np.minimum(p0, p1) - 0.6 * h, np.maximum(p0, p1) + 0.6 * h
        for za in (z0 + height - 0.05, z0 + 0.45 * height):
            self.box((lo[0], lo[1], za), (hi[0], hi[1], za + 0.05))

    def gable_roof(self, x0, x1, y0, y1, zt, rise, t, *, over: float = 0.45,
                   thick: float = 0.15, ridge: str = "x", gables: bool = True) -> None:
        """Two sloped slabs meeting (and crossing) at the ridge, gable ends and a ridge cap."""
        if ridge == "y":  # the same roof with x and y swapped
            a0, a1, b0, b1, axis = y0, y1, x0, x1, 1
        else:
            a0, a1, b0, b1, axis = x0, x1, y0, y1, 0
        mid = 0.5 * (b0 + b1)
        slope = rise / (0.5 * (b1 - b0))
        for edge, sign in ((b0, 1), (b1, -1)):
            def zb(b, edge=edge, sign=sign):
                return zt - 0.03 + slope * sign * (b - (edge - sign * 0.5 * t))
            ba, bb = edge - sign * over, mid + sign * 0.15
            ends = (a0 - 0.5 * t - over, a1 + 0.5 * t + over)
            if thick <= 0:  # a single one-sided sheet, as game kits make roofs
                quad = [(a, b, zb(b)) for a, b in ((ends[0], ba), (ends[1], ba), (ends[1], bb),
                                                   (ends[0], bb))]
                quad = np.array(quad)[:, [0, 1, 2] if axis == 0 else [1, 0, 2]]
                self.sheet(quad, (0.0, 0.0, 1.0))
                continue
            poly = [(ba, zb(ba)), (bb, zb(bb)), (bb, zb(bb) + thick), (ba, zb(ba) + thick)]
            self.prism(poly, axis, *ends)
        top = zt + slope * (0.5 * (b1 - b0) + 0.5 * t)
        if gables:
            tri = [(b0 - 0.5 * t, zt), (b1 + 0.5 * t, zt), (mid, top)]
            for a in (a0, a1):
                self.prism(tri, axis, a - 0.5 * t, a + 0.5 * t)
        cap = [(mid - 0.12, top + thick - 0.1), (mid + 0.12, top + thick - 0.1),
               (mid + 0.12, top + thick + 0.06), (mid - 0.12, top + thick + 0.06)]
        self.prism(cap, axis, a0 - 0.5 * t - over, a1 + 0.5 * t + over)

    def mesh(self, *, wall_thickness: float, open_bottom: bool) -> trimesh.Trimesh:
        offsets = np.cumsum([0] + [len(v) for v, _ in self.parts])
        vertices = np.concatenate([v for v, _ in self.parts])
        faces = np.concatenate([f + o for (_, f), o in zip(self.parts, offsets[:-1], strict=True)])
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        mesh.metadata.update(doors=self.doors, rooms=self.rooms, wall_thickness=wall_thickness,
                             open_bottom=open_bottom, split_faces=self.split,
                             openings=self.openings)
        return mesh


def _snap(x, step: float = 0.05):
    """Round to a multiple of ``step`` (keeps coordinates tidy and files reproducible)."""
    return np.round(np.asarray(x, float) / step) * step


def _windows(rng, a0: float, a1: float, count: int, width: float, b0: float, b1: float,
             framed_share: float = 1.0, jitter: float = 0.0) -> list[tuple]:
    """``count`` windows evenly spread on [a0, a1]; some framed (rng)."""
    centres = a0 + (a1 - a0) * (np.arange(count) + 0.5) / count
    centres = centres + _snap(rng.uniform(-jitter, jitter, count))
    framed = rng.random(count) < framed_share
    return [(float(c - width / 2), float(c + width / 2), b0, b1, bool(f))
            for c, f in zip(centres, framed, strict=True)]


def building_house(seed: int = 1) -> trimesh.Trimesh:
    """Two-storey house: gable roof, chimney, porch canopy, stairs, rooms on both floors."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t, h = 0.2, 3.0
    x0, x1, y0, y1 = -5.0, 5.0, -4.0, 4.0
    b.slab(x0 - 0.1, x1 + 0.1, y0 - 0.1, y1 + 0.1, -0.15, 0.0)  # ground floor on a slab
    top = 2 * h - 0.15
    for level in range(2):
        z0 = level * h
        z1 = z0 + h - 0.15  # the ledge covers the seam to the next storey
        sill, head = z0 + 0.9, z0 + 2.1
        front = _windows(rng, x0 + 0.5, x1 - 0.5, 3, 1.2, sill, head, 0.8, 0.15)
        if level == 0:
            front[1] = (-0.5, 0.5, z0, z0 + 2.1, True)  # the front door
        back = _windows(rng, x0 + 0.5, x1 - 0.5, 2, 1.1, sill, head, 0.5, 0.2)
        if level == 0:
            back[1] = (2.6, 3.5, z0, z0 + 2.05, False)  # back door, no frame
        side = _windows(rng, y0 + 1.0, y1 - 1.0, 1, 1.0, sill, head, 0.5)
        if level == 0:
            front.append((1.0, 1.5, z0 + 1.3, z0 + 1.7, "plaque"))  # name plate
        left = side + [(1.8, 2.8, sill, head, "recess")]  # a blind window
        right = side + [(2.0, 2.3, z0 + 2.3, z0 + 2.6, "recess")]  # a vent
        b.storey(x0, x1, y0, y1, z0, z1 if level == 0 else top, t,
                 {"front": front, "back": back, "left": left, "right": right})
        # partition with a door between the two rooms of the storey
        b.wall("y", 1.0, y0 + 0.1, y1 - 0.1, z0, z1 if level == 0 else top, 0.12,
               [(1.0, 1.9, z0, z0 + 2.0, False)])
        b.rooms.append([-2.0, -2.0, z0 + 1.2])
        b.rooms.append([3.0, -2.0, z0 + 1.2])
    b.ledge(x0, x1, y0, y1, h - 0.2, h + 0.05, t, 0.1)
    b.slab(x0, x1, y0, y1, h - 0.15, h, holes=[(-4.9, -3.9, -0.6, 3.3)])  # stairwell
    b.stairs(-4.85, -3.95, -0.5, 0.0, h, 15)
    b.slab(x0, x1, y0, y1, top, top + 0.12)  # attic floor
    b.gable_roof(x0, x1, y0, y1, top, 2.6, t, ridge="x")
    b.box((2.5, 1.0, top - 1.0), (3.1, 1.6, top + 3.6))  # chimney through the roof
    b.box((-1.0, -4.95, 2.35), (1.0, y0, 2.45))  # porch canopy
    for x in (-0.95, 0.85):
        b.box((x, -4.95, 0.0), (x + 0.1, -4.85, 2.35))  # its posts
    b.doors.append(([0.0, y0, 1.05], [0.0, 1.0, 0.0], 1.0))
    b.doors.append(([3.05, y1, 1.0], [0.0, -1.0, 0.0], 0.9))
    b.decal(b.box((-3.0, y1 + 0.1, 0.3), (-2.4, y1 + 0.14, 0.7)), (0, 1, 0))  # house number
    b.duplicate(5)  # an exactly duplicated wall panel
    return b.mesh(wall_thickness=t, open_bottom=False)


def building_apartment(seed: int = 2) -> trimesh.Trimesh:
    """Four-storey block: corner pillars, ledges, balconies, stair hall, roof railing."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t, h, p = 0.25, 3.0, 0.5
    x0, x1, y0, y1 = -8.0, 8.0, -5.0, 5.0
    levels = 4
    top = levels * h - 0.15
    b.slab(x0, x1, y0, y1, -0.15, 0.0)
    for level in range(levels):
        z0 = level * h
        z1 = z0 + h - 0.15 if level < levels - 1 else top
        sill, head = z0 + 0.9, z0 + 2.2
        front = _windows(rng, x0 + 0.5, x1 - 0.5, 5, 1.2, sill, head, 0.7)
        back = _windows(rng, x0 + 0.5, x1 - 0.5, 5, 1.2, sill, head, 0.7)
        if level == 0:
            front[2] = (-0.7, 0.7, z0, z0 + 2.4, True)  # entrance
        else:
            for k, c in ((0, -6.0), (4, 6.0)):  # balcony doors
                back[k] = (c - 0.5, c + 0.5, z0, z0 + 2.2, True)
                b.box((c - 1.3, y1 + 0.1, z0 - 0.2), (c + 1.3, y1 + 1.4, z0))
                b.railing((c - 1.25, y1 + 1.35), (c + 1.25, y1 + 1.35), z0)
                for s in (-1.25, 1.25):
                    b.railing((c + s, y1 + 0.2), (c + s, y1 + 1.35), z0)
        sides = _windows(rng, y0 + 1.0, y1 - 1.0, 2, 1.0, sill, head, 0.7)
        if level == 0:
            front.append((1.0, 1.5, 1.2, 1.7, "plaque"))  # bell plate by the entrance
        b.storey(x0, x1, y0, y1, z0, z1, t,
                 {"front": front, "back": back,
                  "left": sides + [(-0.5, 0.5, sill, head, "recess")],
                  "right": sides + [(-0.3, 0.3, z0 + 2.4, z0 + 2.7, "recess")]},
                 corner="pillar", pillar=p)
        for x in (-1.8, 1.8):  # the stair hall between two flats
            b.wall("y", x, y0 + 0.12, y1 - 0.12, z0, z1, 0.12,
                   [(-2.5, -1.5, z0, z0 + 2.0, False)])
        b.stairs(0.55, 1.55, 0.0, z0, h, 15)
        b.rooms.extend([[-5.0, -2.0, z0 + 1.2], [5.0, -2.0, z0 + 1.2], [-0.8, -3.0, z0 + 1.2]])
        if level < levels - 1:
            b.ledge(x0, x1, y0, y1, z0 + h - 0.2, z0 + h + 0.05, t, 0.12)
            b.slab(x0, x1, y0, y1, z0 + h - 0.15, z0 + h, holes=[(0.45, 1.65, 0.8, 3.9)])
    b.corner_pillars(x0, x1, y0, y1, 0.0, top + 0.3, p)
    b.ledge(x0, x1, y0, y1, top - 0.1, top + 0.25, t, 0.2)  # cornice over the roof seam
    b.slab(x0, x1, y0, y1, top, top + 0.15)
    r = 0.35
    corners = [(x0 + r, y0 + r), (x1 - r, y0 + r), (x1 - r, y1 - r), (x0 + r, y1 - r)]
    for a, c in zip(corners, corners[1:] + corners[:1], strict=True):
        b.railing(a, c, top + 0.15)
    b.storey(-1.0, 1.5, 1.0, 3.0, top + 0.15, top + 2.6, 0.15,
             {"front": [(-0.3, 0.5, top + 0.15, top + 2.2, True)]})  # roof access
    b.box((-1.2, 0.8, top + 2.6), (1.7, 3.2, top + 2.75))
    b.box((-0.8, 0.4, 3.3), (0.8, y0, 3.4))  # entrance canopy
    b.doors.append(([0.0, y0, 1.2], [0.0, 1.0, 0.0], 1.4))
    sign = b.box((-1.2, y0 - 0.2, 3.5), (1.2, y0 - 0.12, 4.1))
    b.decal(sign, (0, -1, 0))
    b.duplicate(3)
    return b.mesh(wall_thickness=t, open_bottom=False)


def building_tower(seed: int = 3) -> trimesh.Trimesh:
    """Eight-storey tower, open at the bottom: full-height corner pillars, ledges on every
    floor, stairs, roof railing, water tank and mast."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t, h, p = 0.25, 3.2, 0.7
    x0, x1, y0, y1 = -4.0, 4.0, -4.0, 4.0
    levels = 8
    top = levels * h - 0.15
    for level in range(levels):
        z0 = level * h
        z1 = z0 + h - 0.15 if level < levels - 1 else top
        sill, head = z0 + 0.9, z0 + 2.3
        walls = {s: _windows(rng, -3.5, 3.5, 2, 1.4, sill, head, 0.7)
                 for s in ("front", "back", "left", "right")}
        if level == 0:
            walls["front"].append((-0.6, 0.6, z0, z0 + 2.3, True))
        walls["left"].append((-0.4, 0.4, sill, head, "recess"))
        walls["right"].append((-0.2, 0.2, z0 + 2.5, z0 + 2.8, "recess"))
        b.storey(x0, x1, y0, y1, z0, z1, t, walls, corner="pillar", pillar=p,
                 open_bottom=level == 0)
        b.rooms.append([-1.5, 0.0, z0 + 1.2])
        if level < levels - 1:
            b.stairs(2.2, 3.2, -2.0, z0, h, 16, open_bottom=level == 0)
            b.ledge(x0, x1, y0, y1, z0 + h - 0.2, z0 + h + 0.05, t, 0.15)
            b.slab(x0, x1, y0, y1, z0 + h - 0.15, z0 + h, holes=[(2.1, 3.3, -1.0, 2.1)])
    hp = 0.5 * p
    for x in (x0, x1):
        for y in (y0, y1):
            b.box((x - hp, y - hp, 0.0), (x + hp, y + hp, top + 0.6), "-z")
    b.ledge(x0, x1, y0, y1, top - 0.1, top + 0.3, t, 0.25)
    b.slab(x0, x1, y0, y1, top, top + 0.15)
    r = 0.45
    corners = [(x0 + r, y0 + r), (x1 - r, y0 + r), (x1 - r, y1 - r), (x0 + r, y1 - r)]
    for a, c in zip(corners, corners[1:] + corners[:1], strict=True):
        b.railing(a, c, top + 0.15, height=1.1)
    z = top + 0.15
    for dx in (-0.9, 0.9):  # water tank on legs
        for dy in (-0.9, 0.9):
            b.box((-1.5 + dx - 0.08, 1.5 + dy - 0.08, z), (-1.5 + dx + 0.08, 1.5 + dy + 0.08,
                                                          z + 1.6))
    b.column(-1.5, 1.5, 1.2, z + 1.5, z + 3.5, sides=12)
    b.pyramid((-2.7, 0.3, z + 3.5), (-0.3, 2.7), (-1.5, 1.5, z + 4.2))
    b.box((2.0, -2.0, z), (2.1, -1.9, z + float(_snap(rng.uniform(4.0, 6.0)))))  # mast
    b.doors.append(([0.0, y0, 1.15], [0.0, 1.0, 0.0], 1.2))
    b.decal(b.box((-0.6, y0 - 0.2, 2.7), (0.6, y0 - 0.16, 3.0)), (0, -1, 0))
    b.duplicate(0)
    return b.mesh(wall_thickness=t, open_bottom=True)


def building_warehouse(seed: int = 4) -> trimesh.Trimesh:
    """Hall open at the bottom: roller-door opening, columns, roof trusses, mezzanine with
    stairs and railing, crates on the floor."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t = 0.3
    x0, x1, y0, y1 = -12.0, 12.0, -7.0, 7.0
    zt = 7.0
    high = (4.5, 6.0)
    front = [(-3.0, 3.0, 0.0, 5.0, True), (6.0, 7.0, 0.0, 2.2, True),
             (-10.0, -7.0) + high + (False,), (8.5, 9.1, 1.5, 2.1, "recess"),
             (-5.5, -4.5, 2.5, 3.2, "plaque")]
    back = [(-1.0, 1.0, 0.0, 2.2, False)]
    back += [(c - 1.5, c + 1.5) + high + (bool(f),)
             for c, f in zip((-8.0, -4.0, 4.0, 8.0), rng.random(4) < 0.5, strict=True)]
    sides = [(c - 1.0, c + 1.0) + high + (bool(f),)
             for c, f in zip((-4.5, -1.5, 1.5, 4.5), rng.random(4) < 0.5, strict=True)]
    b.storey(x0, x1, y0, y1, 0.0, zt, t, {"front": front, "back": back, "left": sides,
                                          "right": sides}, open_bottom=True, frame=0.25)
    for x in (-8.0, -4.0, 4.0, 8.0):  # steel columns against the long walls
        for y in (y0 + 0.15, y1 - 0.45):
            b.box((x - 0.15, y, 0.0), (x + 0.15, y + 0.3, zt + 0.1), "-z")
    b.gable_roof(x0, x1, y0, y1, zt, 2.0, t, ridge="x", over=0.6, thick=0.12)
    slope = 2.0 / 7.0
    for x in np.arange(-8.0, 8.5, 4.0):  # trusses under the roof
        b.box((x - 0.08, y0, zt - 0.2), (x + 0.08, y1, zt))
        for sign in (-1, 1):
            ya, yb = (y0, 0.0) if sign < 0 else (0.0, y1)
            za = zt if sign < 0 else zt + 7.0 * slope
            zb = zt + 7.0 * slope if sign < 0 else zt
            chord = [(ya, za - 0.25), (yb, zb - 0.25), (yb, zb - 0.05), (ya, za - 0.05)]
            b.prism(chord, 0, x - 0.08, x + 0.08)
            yv = 0.5 * sign * 7.0
            b.box((x - 0.06, yv - 0.06, zt), (x + 0.06, yv + 0.06, zt + 1.0 - 0.2))
        b.box((x - 0.06, -0.06, zt), (x + 0.06, 0.06, zt + 2.0 - 0.2))
    zm = 3.5  # mezzanine
    b.box((7.5, y0 + 0.15, zm - 0.2), (x1 - 0.15, y1 - 0.15, zm))
    for y in (-6.0, -2.0, 2.0, 6.0):
        b.box((7.5, y - 0.1, 0.0), (7.7, y + 0.1, zm - 0.2), "-z")
    b.stairs(6.4, 7.4, -1.0, 0.0, zm, 14, going=0.28, open_bottom=True)
    b.box((6.4, 2.92, zm - 0.2), (7.5, 3.9, zm))  # landing
    b.railing((7.55, y0 + 0.2), (7.55, 2.9), zm)
    b.railing((7.55, 3.9), (7.55, y1 - 0.2), zm)
    for _ in range(int(rng.integers(10, 15))):  # crates and pallets, away from the aisle
        cx = float(_snap(rng.uniform(-11.0, -5.0)))
        cy = float(_snap(rng.uniform(-6.0, 5.5)))
        s = float(_snap(rng.uniform(0.6, 1.4)))
        hh = float(_snap(rng.uniform(0.5, 1.6)))
        b.box((cx - s / 2, cy - s / 2, 0.15), (cx + s / 2, cy + s / 2, 0.15 + hh))
        b.box((cx - s / 2 - 0.05, cy - s / 2 - 0.05, 0.0), (cx + s / 2 + 0.05,
                                                            cy + s / 2 + 0.05, 0.15), "-z")
    b.rooms.extend([[-2.0, 2.0, 1.5], [10.0, 0.0, zm + 1.2]])
    b.doors.append(([0.0, y0, 2.5], [0.0, 1.0, 0.0], 6.0))
    b.doors.append(([6.5, y0, 1.1], [0.0, 1.0, 0.0], 1.0))
    b.doors.append(([0.0, y1, 1.1], [0.0, -1.0, 0.0], 2.0))
    b.decal(b.box((-2.0, y0 - 0.2, 5.4), (2.0, y0 - 0.15, 6.4)), (0, -1, 0))
    b.duplicate(1)
    return b.mesh(wall_thickness=t, open_bottom=True)


def building_church(seed: int = 5) -> trimesh.Trimesh:
    """Chapel open at the bottom: nave with buttresses covering the wall seams, tall framed
    windows, pews, altar; a bell tower with a door, a bell floor, a ladder and a spire."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t = 0.4
    x0, x1, y0, y1 = -4.5, 4.5, -8.0, 10.0
    zt = 7.5
    b.wall("x", y0, x0 - 0.2, x1 + 0.2, 0.0, zt, t,
           [(-1.0, 1.0, 0.0, 3.2, True), (-3.0, -2.2, 2.0, 2.8, "plaque"),
            (2.2, 3.0, 2.0, 2.8, "plaque")], out=-1, open_bottom=True)
    b.wall("x", y1, x0 - 0.2, x1 + 0.2, 0.0, zt, t,
           [(-1.0, 1.0, 4.0, 6.5, True), (-3.0, -2.0, 1.0, 3.0, "recess")], out=1,
           open_bottom=True)
    seams = [-6.0, -2.0, 2.0, 6.0]
    edges = [y0 + 0.2] + seams + [y1 - 0.2]
    width = float(_snap(rng.uniform(0.8, 1.1)))
    for x, sign in ((x0, -1), (x1, 1)):
        for ya, yb in zip(edges[:-1], edges[1:], strict=True):  # wall segments, a slot at each seam
            ua, ub = ya + (0.05 if ya in seams else 0.0), yb - (0.05 if yb in seams else 0.0)
            c = 0.5 * (ya + yb)
            b.wall("y", x, ua, ub, 0.0, zt, t, [(c - width / 2, c + width / 2, 2.5, 6.0, True)],
                   out=sign, open_bottom=True)
        for y in seams:  # buttresses cover the slots
            xa, xb = sorted((x - sign * 0.1, x + sign * 1.1))
            b.box((xa, y - 0.3, 0.0), (xb, y + 0.3, 4.5), "-z")
            top = [(x + sign * 0.1, 4.5), (x + sign * 1.1, 4.5), (x + sign * 0.1, 6.0)]
            b.prism(top, 1, y - 0.3, y + 0.3)
    b.gable_roof(x0, x1, y0, y1, zt, 4.5, t, ridge="y", over=0.5, gables=True)
    b.box((x0 + 0.2, 7.0, 0.0), (x1 - 0.2, y1 - 0.2, 0.3), "-z")  # chancel step
    b.box((-1.0, 8.0, 0.3), (1.0, 9.0, 1.0))  # altar
    for k in range(int(rng.integers(9, 12))):  # pews either side of the aisle
        y = -5.5 + 1.1 * k
        for xa, xb in ((-3.8, -0.9), (0.9, 3.8)):
            b.box((xa, y, 0.42), (xb, y + 0.4, 0.47))
            b.box((xa, y + 0.4, 0.3), (xb, y + 0.45, 0.95))
            b.box((xa, y + 0.05, 0.0), (xa + 0.05, y + 0.4, 0.42), "-z")
    tx0, tx1, ty0 = -2.2, 2.2, -12.4  # the tower against the nave front
    tt = 16.0
    b.storey(tx0, tx1, ty0, y0, 0.0, tt, t,
             {"front": [(-0.8, 0.8, 0.0, 2.8, True), (-0.6, 0.6, 13.0, 15.0, False)],
              "left": [(-10.8, -9.6, 13.0, 15.0, False)],
              "right": [(-10.8, -9.6, 13.0, 15.0, False)]},
             skip=("back",), open_bottom=True)
    b.slab(tx0, tx1, ty0, y0 - 0.2, 12.3, 12.5, holes=[(-1.9, -1.1, -12.1, -11.3)])
    for x in (-1.85, -1.15):  # ladder up to the bell floor
        b.box((x - 0.03, -12.0, 0.0), (x + 0.03, -11.94, 13.3), "-z")
    for z in np.arange(0.3, 13.0, 0.35):
        b.box((-1.85, -11.99, z), (-1.15, -11.95, z + 0.04))
    b.column(0.0, -10.2, 0.5, 13.5, 14.3, sides=10)  # the bell
    b.ledge(tx0, tx1, ty0, y0, tt - 0.2, tt + 0.2, t, 0.2)
    b.pyramid((tx0 - 0.35, ty0 - 0.35, tt + 0.2), (tx1 + 0.35, y0 + 0.35), (0.0, -10.2, 23.0))
    b.doors.append(([0.0, ty0, 1.4], [0.0, 1.0, 0.0], 1.6))
    b.rooms.extend([[0.0, 2.0, 1.5], [0.0, -10.2, 1.5], [1.0, -9.2, 13.3]])
    b.decal(b.box((-0.5, ty0 - 0.24, 3.2), (0.5, ty0 - 0.2, 4.2)), (0, -1, 0))
    b.duplicate(2)
    return b.mesh(wall_thickness=t, open_bottom=True)


def building_shop(seed: int = 6) -> trimesh.Trimesh:
    """Shop with an arcade: upper storeys carried on columns over a recessed shop front,
    a sign board with letters, counter and shelves, stairs, parapet and roof railing."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t, h = 0.25, 3.5
    x0, x1, y0, y1 = -7.0, 7.0, -5.0, 5.0
    ys = -3.0  # the recessed shop front
    b.slab(x0, x1, ys, y1, -0.15, 0.0)
    b.wall("x", ys, x0 - 0.125, x1 + 0.125, 0.0, h - 0.2, t,
           [(-6.0, -2.2, 0.5, 2.6, False), (2.2, 6.0, 0.5, 2.6, False),
            (-0.8, 0.8, 0.0, 2.5, True), (-1.6, -1.1, 1.4, 1.9, "plaque")], out=-1)
    b.wall("x", y1, x0 - 0.125, x1 + 0.125, 0.0, h - 0.2, t,
           [(-4.0, -2.6, 1.0, 2.4, True), (-0.5, 0.5, 0.0, 2.2, True),
            (2.0, 3.0, 1.0, 2.4, "recess")], out=1)
    for x, sign in ((x0, -1), (x1, 1)):
        extra = [(2.8, 3.6, 1.2, 2.2, "recess")] if sign < 0 else []
        b.wall("y", x, ys + 0.125, y1 - 0.125, 0.0, h - 0.2, t,
               [(0.5, 1.7, 1.0, 2.4, bool(rng.random() < 0.5))] + extra, out=sign)
    for x in (-6.5, -3.9, -1.3, 1.3, 3.9, 6.5):  # the arcade
        b.column(x, -4.6, 0.25, 0.0, h - 0.5, sides=8)
        b.box((x - 0.32, -4.92, h - 0.5), (x + 0.32, -4.28, h - 0.35))  # capital
    b.box((x0 - 0.125, y0 - 0.125, h - 0.35), (x1 + 0.125, -4.25, h - 0.15))  # beam
    b.slab(x0, x1, y0, y1, h - 0.2, h, holes=[(5.3, 6.5, 0.5, 3.9)])
    b.stairs(5.4, 6.4, 0.0, 0.0, h, 17, going=0.23)
    b.box((-5.0, 1.0, 0.0), (-2.0, 1.6, 1.0))  # counter
    for x in (-6.6, -5.0, -3.4, -1.8, 1.4, 3.0):  # shelves along the back wall, door clear
        for z in (0.4, 1.1, 1.8):
            b.box((x, 4.4, z), (x + 1.4, 4.8, z + 0.04))
        b.box((x, 4.8, 0.0), (x + 0.04, 4.84, 2.2))
    top = 3 * h - 0.2
    for level in (1, 2):
        z0 = level * h
        z1 = z0 + h - 0.2 if level == 1 else top
        sill, head = z0 + 0.9, z0 + 2.3
        walls = {"front": _windows(rng, x0 + 0.5, x1 - 0.5, 4, 1.3, sill, head, 0.8),
                 "back": _windows(rng, x0 + 0.5, x1 - 0.5, 3, 1.2, sill, head, 0.8),
                 "left": _windows(rng, y0 + 1.0, y1 - 1.0, 2, 1.0, sill, head, 0.8),
                 "right": _windows(rng, y0 + 1.0, y1 - 1.0, 2, 1.0, sill, head, 0.8)}
        b.storey(x0, x1, y0, y1, z0, z1, t, walls, corner="butt")
        b.wall("y", -1.0, y0 + 0.125, y1 - 0.125, z0, z1, 0.12,
               [(-1.0, -0.1, z0, z0 + 2.1, False)])
        b.rooms.append([-3.0, 0.0, z0 + 1.2])
        b.ledge(x0, x1, y0, y1, z0 - 0.25, z0 + 0.05, t, 0.12)
        if level == 1:
            b.slab(x0, x1, y0, y1, z0 + h - 0.2, z0 + h)
    b.slab(x0 - 0.3, x1 + 0.3, y0 - 0.3, y1 + 0.3, top, top + 0.2)
    b.storey(x0, x1, y0, y1, top + 0.2, top + 0.8, 0.15, {})  # parapet
    for a, c in (((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)),
                 ((x0, y1), (x0, y0))):
        b.railing(a, c, top + 0.8, height=0.5, spacing=1.5)
    sign = b.box((-4.0, y0 - 0.3, h + 0.1), (4.0, y0 - 0.2, h + 0.7))  # sign board
    for k in range(8):  # letters: coincident with the board's face
        b.decal(b.box((-3.6 + 0.9 * k, y0 - 0.34, h + 0.2), (-3.0 + 0.9 * k, y0 - 0.3,
                                                              h + 0.6)), (0, 1, 0))
    b.decal(sign, (0, -1, 0))
    b.rooms.append([-2.5, -1.0, 1.2])
    b.doors.append(([0.0, ys, 1.25], [0.0, 1.0, 0.0], 1.6))
    b.doors.append(([0.0, y1, 1.1], [0.0, -1.0, 0.0], 1.0))
    b.duplicate(4)
    return b.mesh(wall_thickness=t, open_bottom=False)


def building_lshaped(seed: int = 7) -> trimesh.Trimesh:
    """L-shaped, open at the bottom: a two-storey gabled wing and a three-storey flat-roofed
    wing joined through archways; stairs, partitions, roof railing."""
    rng = np.random.default_rng(seed)
    b = _Builder()
    t, h = 0.25, 3.2
    ax0, ax1, ay0, ay1 = -9.0, 3.0, -7.0, -1.0  # wing A
    bx0, bx1, by0, by1 = -3.0, 3.0, -1.0, 9.0  # wing B
    top_a = 2 * h - 0.15
    for level in range(2):
        z0 = level * h
        z1 = z0 + h - 0.15 if level == 0 else top_a
        sill, head = z0 + 0.9, z0 + 2.2
        front = _windows(rng, ax0 + 0.5, ax1 - 0.5, 4, 1.2, sill, head, 0.6)
        if level == 0:
            front[0] = (-6.5, -5.5, z0, z0 + 2.2, True)
        back = [(-2.4, 2.4, z0, z0 + 2.6, True), (-7.5, -6.3, sill, head, True)]
        left = _windows(rng, ay0 + 1.0, ay1 - 1.0, 1, 1.2, sill, head, 0.5)
        b.storey(ax0, ax1, ay0, ay1, z0, z1, t,
                 {"front": front, "back": back,
                  "left": left + [(-6.3, -5.5, sill, head, "recess")],
                  "right": _windows(rng, ay0 + 1.0, ay1 - 1.0, 1, 1.2, sill, head, 0.5)},
                 open_bottom=level == 0)
        b.wall("y", -3.0, ay0 + 0.125, ay1 - 0.125, z0, z1, 0.12,
               [(-3.0, -2.1, z0, z0 + 2.1, False)], open_bottom=level == 0)
        b.rooms.append([-6.0, -4.0, z0 + 1.2])
    b.ledge(ax0, ax1, ay0, ay1, h - 0.2, h + 0.05, t, 0.1)
    b.slab(ax0, ax1, ay0, ay1, h - 0.15, h)
    b.slab(ax0, ax1, ay0, ay1, top_a, top_a + 0.12)
    b.gable_roof(ax0, ax1, ay0, ay1, top_a, 2.2, t, ridge="x")
    top_b = 3 * h - 0.15
    for level in range(3):
        z0 = level * h
        z1 = z0 + h - 0.15 if level < 2 else top_b
        sill, head = z0 + 0.9, z0 + 2.2
        walls = {"back": _windows(rng, bx0 + 0.5, bx1 - 0.5, 2, 1.2, sill, head, 0.6),
                 "left": _windows(rng, by0 + 1.0, by1 - 1.0, 3, 1.2, sill, head, 0.6),
                 "right": _windows(rng, by0 + 1.0, by1 - 1.0, 3, 1.2, sill, head, 0.6)}
        if level == 0:
            walls["back"][0] = (-1.8, -0.8, z0, z0 + 2.2, True)  # back door
            walls["back"].append((0.0, 0.4, 1.3, 1.7, "plaque"))
        skip = ("front",) if level < 2 else ()
        if level == 2:
            walls["front"] = [(-0.6, 0.6, z0 + 1.4, head, True)]  # above wing A's roof
        b.storey(bx0, bx1, by0, by1, z0, z1, t, walls, skip=skip, open_bottom=level == 0)
        b.rooms.append([-1.0, 4.0, z0 + 1.2])
        if level < 2:
            b.stairs(1.7, 2.7, 2.0, z0, h, 16, open_bottom=level == 0)
            b.ledge(bx0, bx1, by0 + 0.3, by1, z0 + h - 0.2, z0 + h + 0.05, t, 0.1)
            b.slab(bx0, bx1, by0, by1, z0 + h - 0.15, z0 + h, holes=[(1.6, 2.8, 3.0, 6.1)])
    b.slab(bx0 - 0.2, bx1 + 0.2, by0 - 0.2, by1 + 0.2, top_b, top_b + 0.15)
    r = 0.3
    corners = [(bx0 + r, by0 + r), (bx1 - r, by0 + r), (bx1 - r, by1 - r), (bx0 + r, by1 - r)]
    for a, c in zip(corners, corners[1:] + corners[:1], strict=True):
        b.railing(a, c, top_b + 0.15)
    b.doors.append(([-6.0, ay0, 1.1], [0.0, 1.0, 0.0], 1.0))
    b.doors.append(([-1.3, by1, 1.1], [0.0, -1.0, 0.0], 1.0))
    b.decal(b.box((-8.0, ay0 - 0.17, 1.0), (-7.4, ay0 - 0.13, 1.6)), (0, -1, 0))
    b.duplicate(6)
    return b.mesh(wall_thickness=t, open_bottom=True)


def building_cottage(seed: int = 8) -> trimesh.Trimesh:
    """Cottage made the way exported game kits are: every flat side of every part has its
    own vertices (no two faces of a box share an index), the roof is two one-sided
    sheets; open at the bottom, shutters, flower boxes, an attic reached by a ladder."""
    rng = np.random.default_rng(seed)
    b = _Builder(split=True)
    t, h = 0.12, 2.8
    x0, x1, y0, y1 = -3.0, 3.0, -2.5, 2.5
    framed = rng.random(4) < 0.6
    front = [(-0.45, 0.45, 0.0, 2.0, True), (-2.4, -1.4, 0.9, 1.9, True),
             (1.4, 2.4, 0.9, 1.9, True)]
    walls = {"front": front,
             "back": [(-1.5, -0.5, 0.9, 1.9, bool(framed[0])), (1.2, 2.2, 0.9, 1.9, False)],
             "left": [(-0.5, 0.5, 0.9, 1.9, bool(framed[1])), (1.2, 1.8, 0.9, 1.9, "recess")],
             "right": [(-0.5, 0.5, 0.9, 1.9, bool(framed[2])), (-1.8, -1.2, 1.2, 1.6, "plaque")]}
    b.storey(x0, x1, y0, y1, 0.0, h, t, walls, open_bottom=True, frame=0.08, depth=0.03)
    for a0, a1, *_ in front[1:]:  # shutters and flower boxes
        for u in (a0 - 0.08 - 0.45, a1 + 0.08):
            b.box((u, y0 - 0.12, 0.85), (u + 0.45, y0 - 0.08, 1.95))
        b.box((a0, y0 - 0.3, 0.6), (a1, y0 - 0.07, 0.78))
    b.wall("y", 0.8, y0 + 0.06, y1 - 0.06, 0.0, h, 0.1, [(0.6, 1.4, 0.0, 1.9, False)],
           open_bottom=True)
    b.slab(x0, x1, y0, y1, h, h + 0.1, holes=[(-2.65, -1.85, 1.3, 2.3)])  # attic floor
    for x in (-2.5, -2.0):  # ladder
        b.box((x - 0.03, 1.95, 0.0), (x + 0.03, 2.0, h + 0.6), "-z")
    for z in np.arange(0.3, h + 0.4, 0.3):
        b.box((-2.5, 1.96, z), (-2.0, 1.99, z + 0.04))
    b.gable_roof(x0, x1, y0, y1, h + 0.1, 2.4, t, ridge="x", over=0.35, thick=0.0)
    b.box((1.8, 0.6, 2.0), (2.3, 1.1, 6.0))  # chimney through the roof sheet
    b.box((-0.8, y0 - 0.5, 0.0), (0.8, y0 - 0.06, 0.15), "-z")  # door step
    b.box((-0.8, y0 - 0.6, 2.25), (0.8, y0 - 0.06, 2.32))  # door canopy
    b.box((-2.2, -0.9, 0.72), (-1.2, -0.1, 0.77))  # table and its legs
    for x in (-2.15, -1.3):
        for y in (-0.85, -0.2):
            b.box((x, y, 0.0), (x + 0.05, y + 0.05, 0.72), "-z")
    b.box((1.2, 1.0, 0.0), (2.8, 2.3, 0.5), "-z")  # bed
    # (the attic under the one-sided roof sheets reads as inside by winding number: 0.56)
    b.rooms.extend([[-1.0, 0.8, 1.2], [1.9, -0.6, 1.2]])
    b.doors.append(([0.0, y0, 1.0], [0.0, 1.0, 0.0], 0.9))
    b.decal(b.box((-0.2, y0 - 0.1, 2.05), (0.2, y0 - 0.065, 2.2)), (0, -1, 0))  # number
    b.duplicate(7)
    return b.mesh(wall_thickness=t, open_bottom=True)


#: Building scenes: scene name -> (file, function); every function takes ``seed``.
BUILDINGS = {
    "building-house": ("building_house.ply", building_house),
    "building-apartment": ("building_apartment.ply", building_apartment),
    "building-tower": ("building_tower.ply", building_tower),
    "building-warehouse": ("building_warehouse.ply", building_warehouse),
    "building-church": ("building_church.ply", building_church),
    "building-shop": ("building_shop.ply", building_shop),
    "building-lshaped": ("building_lshaped.ply", building_lshaped),
    "building-cottage": ("building_cottage.ply", building_cottage),
}

SCENES = {
    "fat_torus.ply": fat_torus,
    "box_with_hole.ply": box_with_hole,
    "sponge.ply": sponge,
    "terrain.ply": terrain,
    "hairball.ply": hairball,
    "city_block.ply": city_block,
    **{file: make for file, make in BUILDINGS.values()},
}


def write_scenes(folder: Path = HERE, files=None) -> dict[str, trimesh.Trimesh]:
    """Write the scene files (all, or those named in ``files``) into ``folder``.

    Returns the meshes written, by file name. Binary PLY, no attributes.
    """
    out = {}
    for name, make in SCENES.items():
        if files is not None and name not in files:
            continue
        mesh = make()
        data = trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=False)
        (Path(folder) / name).write_bytes(data)
        out[name] = mesh
    return out


def main() -> None:
    for name, mesh in write_scenes().items():
        print(f"{name}: {len(mesh.faces)} faces, {mesh.body_count} parts, "
              f"watertight={mesh.is_watertight}")


if __name__ == "__main__":
    main()
