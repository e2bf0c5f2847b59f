"""numba kernels of the voxelization: exact triangle/box overlap, first cell per label.

The separating-axis triangle/box overlap test of Akenine-Moeller [1]_, in a
compiled loop over each triangle's bounding box.

References
----------
.. [1] Akenine-Moeller, T. "Fast 3D triangle-box overlap testing". Journal of
   Graphics Tools 6(1), 2001, pp. 29-33. :DOI:`10.1080/10867651.2001.10487535`
"""

from __future__ import annotations

import numpy as np

from .._jit import njit_cached


@njit_cached(inline="always")
def _axis_ok(p0, p1, p2, r):
    lo = min(p0, min(p1, p2))
    hi = max(p0, max(p1, p2))
    return lo <= r and hi >= -r


@njit_cached()
def mark_surface_voxels(vertices, faces, origin, pitch, slack, h, out):  # pragma: no cover
    """Set out[x, y, z] for every voxel (closed cube of half-size h) a triangle touches.

    One pass over the faces: each triangle's corners are read from ``vertices``,
    its voxel bounding box (widened by ``slack`` voxels, clipped to the grid)
    computed, and its voxels tested with the separating-axis test, the plane
    test first; voxels already marked are skipped. No ``(f, 3, 3)`` corner
    array or temporaries: a scan of a million triangles costs the test alone.
    """
    sx, sy, sz = out.shape[0] - 1, out.shape[1] - 1, out.shape[2] - 1
    ox, oy, oz = origin[0], origin[1], origin[2]
    for t in range(faces.shape[0]):
        fa, fb, fc = faces[t, 0], faces[t, 1], faces[t, 2]
        ax, ay, az = vertices[fa, 0], vertices[fa, 1], vertices[fa, 2]
        bx, by, bz = vertices[fb, 0], vertices[fb, 1], vertices[fb, 2]
        cx, cy, cz = vertices[fc, 0], vertices[fc, 1], vertices[fc, 2]
        # voxel bounding box: floor((min - origin) / pitch - slack), as numpy did, clipped
        i0 = min(max(int(np.floor((min(ax, bx, cx) - ox) / pitch - slack)), 0), sx)
        j0 = min(max(int(np.floor((min(ay, by, cy) - oy) / pitch - slack)), 0), sy)
        k0 = min(max(int(np.floor((min(az, bz, cz) - oz) / pitch - slack)), 0), sz)
        i1 = min(max(int(np.floor((max(ax, bx, cx) - ox) / pitch + slack)), 0), sx)
        j1 = min(max(int(np.floor((max(ay, by, cy) - oy) / pitch + slack)), 0), sy)
        k1 = min(max(int(np.floor((max(az, bz, cz) - oz) / pitch + slack)), 0), sz)
        e0x, e0y, e0z = bx - ax, by - ay, bz - az
        e1x, e1y, e1z = cx - bx, cy - by, cz - bz
        e2x, e2y, e2z = ax - cx, ay - cy, az - cz
        nx = e0y * e1z - e0z * e1y
        ny = e0z * e1x - e0x * e1z
        nz = e0x * e1y - e0y * e1x
        rn = h * (abs(nx) + abs(ny) + abs(nz))
        for i in range(i0, i1 + 1):
            px = ox + (i + 0.5) * pitch
            for j in range(j0, j1 + 1):
                py = oy + (j + 0.5) * pitch
                for k in range(k0, k1 + 1):
                    if out[i, j, k]:
                        continue
                    pz = oz + (k + 0.5) * pitch
                    vax, vay, vaz = ax - px, ay - py, az - pz
                    if abs(nx * vax + ny * vay + nz * vaz) > rn:
                        continue  # the triangle's plane misses the box
                    vbx, vby, vbz = bx - px, by - py, bz - pz
                    vcx, vcy, vcz = cx - px, cy - py, cz - pz
                    ok = True
                    for ex, ey, ez in ((e0x, e0y, e0z), (e1x, e1y, e1z), (e2x, e2y, e2z)):
                        # axis x cross e = (0, -ez, ey)
                        if not _axis_ok(-ez * vay + ey * vaz, -ez * vby + ey * vbz,
                                        -ez * vcy + ey * vcz, h * (abs(ez) + abs(ey))):
                            ok = False
                            break
                        # axis y cross e = (ez, 0, -ex)
                        if not _axis_ok(ez * vax - ex * vaz, ez * vbx - ex * vbz,
                                        ez * vcx - ex * vcz, h * (abs(ez) + abs(ex))):
                            ok = False
                            break
                        # axis z cross e = (-ey, ex, 0)
                        if not _axis_ok(-ey * vax + ex * vay, -ey * vbx + ex * vby,
                                        -ey * vcx + ex * vcy, h * (abs(ey) + abs(ex))):
                            ok = False
                            break
                    if ok:
                        out[i, j, k] = True
    return out


@njit_cached()
def first_index_of_labels(labels, n_labels):
    """Flat index of the first cell of each label 1..n_labels in a flat label array (-1: none)."""
    first = np.full(n_labels + 1, -1, np.int64)
    for i in range(labels.shape[0]):
        lab = labels[i]
        if lab > 0 and first[lab] < 0:
            first[lab] = i
    return first
