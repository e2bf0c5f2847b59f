"""Axis-aligned boxes as triangles: the box occluders of aabb-skins and solid-frusta."""

from __future__ import annotations

import numpy as np
import trimesh

__all__ = ["boxes_mesh"]


def boxes_mesh(boxes: np.ndarray) -> trimesh.Trimesh:
    """One closed 12-triangle box per ``(2, 3)`` lower/upper corner pair, concatenated.

    Examples
    --------
    >>> len(boxes_mesh(np.array([[[0, 0, 0], [1, 1, 1]]], float)).faces)
    12
    """
    if len(boxes) == 0:
        return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), process=False)
    unit = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    uv, uf = np.asarray(unit.vertices), np.asarray(unit.faces)
    lo, size = boxes[:, 0], boxes[:, 1] - boxes[:, 0]
    vertices = (lo[:, None, :] + uv[None] * size[:, None, :]).reshape(-1, 3)
    faces = (uf[None] + (np.arange(len(boxes)) * len(uv))[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(vertices, faces, process=False)
