"""Regenerate the built-in culling scenes ``city`` and ``city-dense`` (deterministic).

Run from anywhere: ``python data/make_city.py``. Writes ``city.glb`` and
``city_dense.glb`` beside this script, byte-identical on every run (fixed
parameters, fixed seeds).

A street grid of blocks. Buildings are the occluders: closed, 2-manifold
multi-panel meshes (one 3 m panel per storey and bay: the boundary of a voxel
solid, :func:`viscore.voxel.grid.voxel_boundary_mesh`) with setbacks, L shapes
and courtyards. The occludees are small instanced props with realistic
triangle counts: cars (3 models, 300-1,000 triangles), trees (2 models,
200-600), street lamps (50-100) and benches (50-150), placed on the roads,
along the sidewalks, in yards and parks, in courtyards and behind buildings.
Every distinct mesh is stored once in the GLB and referenced by one node per
instance (glTF instancing), so the files stay small. A thin ground slab is one
more object.

glTF is +Y up: the geometry is modelled +Z up and every node's transform
turns it to +Y up ((x, y, z) -> (x, z, -y)).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from viscore.voxel.grid import VoxelGrid, voxel_boundary_mesh

HERE = Path(__file__).resolve().parent

#: Storey height and panel width of the buildings, metres.
PANEL = 3.0

#: +Z up (modelling) to +Y up (glTF): (x, y, z) -> (x, z, -y).
Z_TO_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])


# --------------------------------------------------------------------------- props
def _box(lo, hi) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=np.array([lo, hi], dtype=float))


def _subdivided_box(lo, hi, times: int = 1) -> trimesh.Trimesh:
    box = _box(lo, hi)
    v, f = box.vertices, box.faces
    for _ in range(times):
        v, f = trimesh.remesh.subdivide(v, f)
    return trimesh.Trimesh(v, f, process=False)


def _cylinder(radius, height, sections, center, axis="z") -> trimesh.Trimesh:
    cyl = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
    if axis == "y":
        cyl.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0)))
    cyl.apply_translation(center)
    return cyl


def _join(parts) -> trimesh.Trimesh:
    mesh = trimesh.util.concatenate(parts)
    return trimesh.Trimesh(np.round(mesh.vertices, 6), mesh.faces, process=False)


def car(length=4.3, width=1.8, height=1.45, wheel_sections=24, subdivisions=1):
    """A car: body and cabin (subdivided boxes), four wheels, lights; origin at the base."""
    hl, hw = length / 2, width / 2
    body = _subdivided_box((-hl, -hw, 0.3), (hl, hw, 0.3 + 0.45 * height), subdivisions)
    cabin = _subdivided_box((-0.3 * length, -0.45 * width, 0.3 + 0.45 * height),
                            (0.2 * length, 0.45 * width, height), subdivisions)
    parts = [body, cabin]
    r = 0.33
    for x in (-0.32 * length, 0.32 * length):
        for y in (-hw + 0.1, hw - 0.1):
            parts.append(_cylinder(r, 0.22, wheel_sections, (x, y, r), axis="y"))
    for y in (-0.3 * width, 0.3 * width):
        parts.append(_box((hl - 0.02, y - 0.15, 0.6), (hl + 0.03, y + 0.15, 0.75)))
        parts.append(_box((-hl - 0.03, y - 0.15, 0.6), (-hl + 0.02, y + 0.15, 0.75)))
    return _join(parts)


def deciduous_tree(height=7.0, crown=2.4, subdivisions=2):
    trunk = _cylinder(0.2, 0.55 * height, 10, (0, 0, 0.275 * height))
    canopy = trimesh.creation.icosphere(subdivisions=subdivisions, radius=crown)
    canopy.apply_scale((1.0, 1.0, 1.15))
    canopy.apply_translation((0, 0, height - 1.1 * crown))
    return _join([trunk, canopy])


def conifer(height=9.0, radius=2.0):
    parts = [_cylinder(0.22, 0.3 * height, 10, (0, 0, 0.15 * height))]
    for k in range(3):
        cone = trimesh.creation.cone(radius=radius * (1 - 0.22 * k), height=0.45 * height,
                                     sections=32)
        cone.apply_translation((0, 0, 0.22 * height + 0.22 * k * height))
        parts.append(cone)
    return _join(parts)


def lamp(height=5.0):
    pole = _cylinder(0.08, height, 10, (0, 0, height / 2))
    arm = _box((0.0, -0.05, height - 0.12), (1.0, 0.05, height - 0.02))
    head = _box((0.7, -0.18, height - 0.3), (1.3, 0.18, height - 0.1))
    base = _cylinder(0.18, 0.4, 8, (0, 0, 0.2))
    return _join([pole, arm, head, base])


def bench(length=1.8):
    hl = length / 2
    parts = [_box((-hl, -0.25, 0.42), (hl, 0.25, 0.48)),  # seat
             _box((-hl, 0.2, 0.5), (hl, 0.26, 0.9))]  # back
    for x in (-hl + 0.1, hl - 0.1):
        parts.append(_box((x - 0.04, -0.22, 0.0), (x + 0.04, -0.14, 0.42)))
        parts.append(_box((x - 0.04, 0.14, 0.0), (x + 0.04, 0.24, 0.9)))
        parts.append(_box((x - 0.04, -0.25, 0.6), (x + 0.04, 0.2, 0.66)))  # armrest
    return _join(parts)


def props() -> dict[str, trimesh.Trimesh]:
    """The instanced occludee models, name -> mesh (+Z up, origin at the base centre)."""
    return {
        "car_sedan": car(),
        "car_van": car(length=5.0, width=2.0, height=2.1, wheel_sections=32),
        "car_small": car(length=3.6, width=1.65, height=1.4, wheel_sections=16, subdivisions=0),
        "tree_round": deciduous_tree(),
        "tree_conifer": conifer(),
        "lamp": lamp(),
        "bench": bench(),
    }


# --------------------------------------------------------------------------- buildings
def building(footprint: np.ndarray, floors: np.ndarray) -> trimesh.Trimesh:
    """Closed multi-panel building: each footprint cell rises ``floors[i, j]`` storeys.

    ``footprint`` and ``floors`` are (a, b) arrays over 3 m cells; the mesh is
    centred on the footprint's box and stands on z = 0.
    """
    a, b = floors.shape
    top = int(floors.max())
    solid = np.zeros((a, b, top), bool)
    k = np.arange(top)
    solid[:] = (k[None, None, :] < floors[:, :, None]) & footprint[:, :, None]
    origin = np.array([-a * PANEL / 2, -b * PANEL / 2, 0.0])
    mesh = voxel_boundary_mesh(solid, VoxelGrid(origin, PANEL, solid.shape))
    return trimesh.Trimesh(np.round(mesh.vertices, 6), mesh.faces, process=False)


def building_floors(rng: np.random.Generator, a: int, b: int, low: int, high: int
                    ) -> tuple[str, np.ndarray, np.ndarray]:
    """A random building of one of five styles on a x b cells: (style, footprint, floors)."""
    style = ["block", "setback", "l-shape", "courtyard", "stepped"][int(rng.integers(5))]
    if style == "courtyard" and min(a, b) < 5:
        style = "setback"
    footprint = np.ones((a, b), bool)
    h = int(rng.integers(low, high + 1))
    floors = np.full((a, b), h)
    if style == "setback" and min(a, b) >= 3:
        floors[:] = max(1, int(0.6 * h))
        floors[1:-1, 1:-1] = h
    elif style == "l-shape":
        ca, cb = max(1, a // 2), max(1, b // 2)
        footprint[:ca, :cb] = False
    elif style == "courtyard":
        footprint[2:-2, 2:-2] = False
    elif style == "stepped":
        for ring in range(1, min(a, b) // 2):
            floors[ring:a - ring, ring:b - ring] = h + 2 * ring
    floors = np.where(footprint, np.maximum(floors, 1), 0)
    return style, footprint, floors


# --------------------------------------------------------------------------- layout
def _yaw(angle: float, x: float, y: float, z: float = 0.0) -> np.ndarray:
    m = trimesh.transformations.rotation_matrix(angle, (0, 0, 1))
    m[:3, 3] = (x, y, z)
    return m


class _Placer:
    """Collects (mesh name, node name, +Z-up transform) and keeps props apart."""

    def __init__(self) -> None:
        self.nodes: list[tuple[str, str, np.ndarray]] = []
        self.points: list[tuple[float, float, float]] = []
        self.counts: dict[str, int] = {}

    def add(self, mesh: str, kind: str, transform: np.ndarray) -> None:
        self.counts[kind] = self.counts.get(kind, 0) + 1
        self.nodes.append((mesh, f"{kind}_{self.counts[kind]:04d}", transform))

    def free(self, x: float, y: float, radius: float) -> bool:
        for px, py, pr in self.points:
            if (px - x) ** 2 + (py - y) ** 2 < (pr + radius) ** 2:
                return False
        self.points.append((x, y, radius))
        return True


def city(*, blocks: int, block: float, street: float, lots: int, low: int, high: int,
         park_share: float, variants: int, seed: int) -> trimesh.Scene:
    """A city of ``blocks`` x ``blocks`` blocks of ``lots`` x ``lots`` lots, as a glTF scene.

    Lengths in metres. Each lot holds one building (or is a park, with
    probability ``park_share``), one of ``variants`` distinct buildings turned
    by a multiple of 90 degrees; buildings rise ``low``..``high`` storeys.
    """
    rng = np.random.default_rng(seed)
    models = props()
    place = _Placer()
    buildings: dict[str, trimesh.Trimesh] = {}
    pitch = block + street
    size = blocks * pitch + street
    lot = block / lots
    cells = int(lot // PANEL)
    sidewalk = 3.0
    # a pool of distinct buildings, each instanced in several lots (glTF instancing)
    footprints: dict[str, np.ndarray] = {}
    for k in range(variants):
        a = int(rng.integers(max(2, cells - 3), cells + 1))
        b = int(rng.integers(max(2, cells - 3), cells + 1))
        style, footprint, floors = building_floors(rng, a, b, low, high)
        name = f"building_{k:02d}_{style}"
        buildings[name] = building(footprint, floors)
        footprints[name] = footprint
    pool = list(buildings)

    def yard_props(x0, y0, x1, y1, mask_fn, count, kinds):
        for _ in range(count * 4):
            if count == 0:
                break
            x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
            if mask_fn(x, y):
                continue
            kind = kinds[int(rng.integers(len(kinds)))]
            radius = 2.2 if kind.startswith("tree") else 1.0
            if not place.free(x, y, radius):
                continue
            family = kind.split("_")[0]
            place.add(kind, family, _yaw(rng.uniform(0, 2 * np.pi), x, y))
            count -= 1

    for bi in range(blocks):
        for bj in range(blocks):
            bx, by = street + bi * pitch, street + bj * pitch  # block's lower corner
            for li in range(lots):
                for lj in range(lots):
                    lx, ly = bx + li * lot, by + lj * lot
                    if rng.random() < park_share:  # a park: trees and benches
                        yard_props(lx + 1, ly + 1, lx + lot - 1, ly + lot - 1,
                                   lambda x, y: False, int(rng.integers(4, 8)),
                                   ["tree_round", "tree_round", "tree_conifer", "bench"])
                        continue
                    name = pool[int(rng.integers(len(pool)))]
                    footprint = footprints[name]
                    turn = int(rng.integers(4))  # quarter turns: the lot is square
                    a, b = footprint.shape
                    wa, wb = (a * PANEL, b * PANEL) if turn % 2 == 0 else (b * PANEL, a * PANEL)
                    # building centred in its lot, shifted towards a random corner:
                    # the yard it leaves lies behind it for some streets
                    cx = lx + lot / 2 + rng.uniform(-1, 1) * (lot - wa) / 2
                    cy = ly + lot / 2 + rng.uniform(-1, 1) * (lot - wb) / 2
                    place.add(name, "building", _yaw(turn * np.pi / 2, cx, cy))

                    def inside(x, y, cx=cx, cy=cy, turn=turn, footprint=footprint):
                        # the point in the building's own frame (undo the quarter turns)
                        c, s_ = np.cos(-turn * np.pi / 2), np.sin(-turn * np.pi / 2)
                        u = c * (x - cx) - s_ * (y - cy) + footprint.shape[0] * PANEL / 2
                        v = s_ * (x - cx) + c * (y - cy) + footprint.shape[1] * PANEL / 2
                        margin = 1.5  # metres kept free around the walls
                        i0 = int(np.floor((u - margin) / PANEL))
                        i1 = int(np.floor((u + margin) / PANEL))
                        j0 = int(np.floor((v - margin) / PANEL))
                        j1 = int(np.floor((v + margin) / PANEL))
                        i0, j0 = max(i0, 0), max(j0, 0)
                        i1, j1 = min(i1, footprint.shape[0] - 1), min(j1, footprint.shape[1] - 1)
                        if i0 > i1 or j0 > j1:
                            return False
                        # courtyards and L gaps are yards
                        return bool(footprint[i0:i1 + 1, j0:j1 + 1].any())

                    yard_props(lx + 1, ly + 1, lx + lot - 1, ly + lot - 1, inside,
                               int(rng.integers(1, 4)),
                               ["tree_round", "tree_conifer", "bench", "bench", "car_small"])

    # streets: lamps and trees along the sidewalks, cars on the roads
    for k in range(blocks + 1):
        s0 = k * pitch  # street k spans [s0, s0 + street] across
        for seg in range(blocks):
            a0 = street + seg * pitch
            for along in np.arange(a0 + 4.0, a0 + block - 2.0, 12.0):
                for side, offset in ((0, s0 + sidewalk - 0.6), (1, s0 + street - sidewalk + 0.6)):
                    for horizontal in (True, False):
                        x, y = (along, offset) if horizontal else (offset, along)
                        face = (np.pi / 2 if side == 0 else -np.pi / 2) + (
                            0.0 if horizontal else np.pi / 2)
                        if place.free(x, y, 0.4):
                            place.add("lamp", "lamp", _yaw(face, x, y))
                        tx = x + (6.0 if horizontal else 0.0)
                        ty = y + (0.0 if horizontal else 6.0)
                        if rng.random() < 0.45 and place.free(tx, ty, 1.5):
                            kind = "tree_round" if rng.random() < 0.7 else "tree_conifer"
                            place.add(kind, "tree", _yaw(rng.uniform(0, 2 * np.pi), tx, ty))
                        bx_, by_ = (x + 3.0, y) if horizontal else (x, y + 3.0)
                        if rng.random() < 0.15 and place.free(bx_, by_, 1.0):
                            place.add("bench", "bench", _yaw(face + np.pi, bx_, by_))
            # cars: parked along both curbs and driving in both lanes
            for lane, share in ((sidewalk + 1.1, 0.55), (sidewalk + 3.4, 0.2),
                                (street - sidewalk - 3.4, 0.2), (street - sidewalk - 1.1, 0.55)):
                for horizontal in (True, False):
                    along = a0 + rng.uniform(0, 6)
                    while along < a0 + block - 3:
                        if rng.random() < share:
                            kind = ["car_sedan", "car_sedan", "car_van", "car_small"][
                                int(rng.integers(4))]
                            heading = 0.0 if lane < street / 2 else np.pi
                            x, y = (along, s0 + lane) if horizontal else (s0 + lane, along)
                            angle = heading if horizontal else heading + np.pi / 2
                            if place.free(x, y, 2.2):
                                place.add(kind, "car", _yaw(angle, x, y))
                        along += rng.uniform(6.0, 12.0)

    scene = trimesh.Scene()
    # top 2 cm below the street level: no face coplanar with the buildings' floors
    ground = _box((-20.0, -20.0, -0.5), (size + 20.0, size + 20.0, -0.02))
    meshes = {"ground": ground, **buildings, **models}
    center = _yaw(0.0, -size / 2, -size / 2)  # the city centred on the origin
    added: set[str] = set()
    for mesh_name, node_name, transform in [("ground", "ground", np.eye(4)), *place.nodes]:
        matrix = Z_TO_Y_UP @ center @ transform
        if mesh_name not in added:
            scene.add_geometry(meshes[mesh_name], geom_name=mesh_name, node_name=node_name,
                               transform=matrix)
            added.add(mesh_name)
        else:
            scene.graph.update(frame_to=node_name, frame_from=scene.graph.base_frame,
                               matrix=matrix, geometry=mesh_name)
    return scene


#: The two built-in culling scenes: sparse (6 x 6 blocks of 2 x 2 lots, 3-12
#: storeys, a quarter of the lots parks) and dense (8 x 8 blocks, narrower
#: streets, 6-30 storeys, few parks).
SCENES = {
    "city.glb": dict(blocks=6, block=48.0, street=16.0, lots=2, low=3, high=12,
                     park_share=0.25, variants=16, seed=20261123),
    "city_dense.glb": dict(blocks=8, block=42.0, street=12.0, lots=2, low=6, high=30,
                           park_share=0.08, variants=24, seed=20261124),
}


def main() -> None:
    for filename, params in SCENES.items():
        scene = city(**params)
        data = scene.export(file_type="glb")
        (HERE / filename).write_bytes(data)
        nodes = len(scene.graph.nodes_geometry)
        print(f"{filename}: {nodes} objects, {len(scene.geometry)} meshes, "
              f"{len(data) / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
