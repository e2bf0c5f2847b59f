"""Regenerate the procedural built-in scenes of viscore (deterministic).

Run from anywhere: ``python data/make_scenes.py``. Every scene is made from
fixed parameters and fixed seeds, so the PLY files come out byte-identical.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from viscore.voxels import VoxelGrid, voxel_boundary_mesh

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
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def hairball() -> trimesh.Trimesh:
    rng = np.random.default_rng(20261122)
    parts = []
    for _ in range(120):
        p = rng.normal(size=(2, 3))
        p /= np.linalg.norm(p, axis=1)[:, None]
        if np.linalg.norm(p[1] - p[0]) < 0.2:
            continue
        parts.append(trimesh.creation.cylinder(radius=0.012, segment=p, sections=6))
    return trimesh.util.concatenate(parts)


def buildings() -> trimesh.Trimesh:
    parts = [trimesh.creation.box(extents=(4.0, 4.0, 0.1),
                                  transform=trimesh.transformations.translation_matrix(
                                      (0, 0, -0.05)))]
    for (x, y, w, d, h) in [(-1.0, -1.0, 1.2, 1.0, 2.5), (1.0, -1.0, 1.0, 1.4, 1.2),
                            (-1.0, 1.0, 1.4, 1.2, 1.6), (1.0, 1.1, 0.8, 0.8, 3.0)]:
        parts.append(trimesh.creation.box(
            extents=(w, d, h), transform=trimesh.transformations.translation_matrix(
                (x, y, h / 2))))
    return trimesh.util.concatenate(parts)


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


SCENES = {
    "fat_torus.ply": fat_torus,
    "box_with_hole.ply": box_with_hole,
    "sponge.ply": sponge,
    "terrain.ply": terrain,
    "hairball.ply": hairball,
    "buildings.ply": buildings,
    "city_block.ply": city_block,
}


def main() -> None:
    for name, make in SCENES.items():
        mesh = make()
        data = trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=False)
        (HERE / name).write_bytes(data)
        print(f"{name}: {len(mesh.faces)} faces, watertight={mesh.is_watertight}")


if __name__ == "__main__":
    main()
