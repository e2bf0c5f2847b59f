"""numba kernels of the greedy maximal-box growth of the AABB-skins generator.

The box growth of Leone et al. [1]_, sec. 4, and the maximal-box expansion of
Naaji's box-filling note [2]_.

References
----------
.. [1] Leone, M. N., Barbagallo, L. R., Banquiero, M. M., Agromayor, D.,
   Bursztyn, A. P. M. "Implementing software occlusion culling for real-time
   applications". XVIII Congreso Argentino de Ciencias de la Computacion
   (CACIC 2012), Workshop de Computacion Grafica, Imagenes y Visualizacion,
   2012. http://sedici.unlp.edu.ar/handle/10915/23640
.. [2] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 November 2019. http://karim.naaji.fr/automatic_occluder_geneneration.html
"""

from __future__ import annotations

import numpy as np

from viscore._jit import njit_cached


@njit_cached()
def runs_along_x(avail):
    """Run length of available voxels along +X from each voxel (0 if unavailable)."""
    nx, ny, nz = avail.shape
    d = np.zeros((nx, ny, nz), np.int32)
    for y in range(ny):
        for z in range(nz):
            run = 0
            for x in range(nx - 1, -1, -1):
                if avail[x, y, z]:
                    run += 1
                else:
                    run = 0
                d[x, y, z] = run
    return d


@njit_cached()
def _runs_along_y_z(avail):
    """Run lengths of available voxels along +Y and along +Z from each voxel (0 if
    unavailable), as :func:`runs_along_x` along +X.

    Loops of their own rather than ``runs_along_x`` of a transposed copy: numba's
    ``transpose(axes)`` alone took some 6 s to compile (its error messages).
    """
    nx, ny, nz = avail.shape
    dy = np.zeros((nx, ny, nz), np.int32)
    dz = np.zeros((nx, ny, nz), np.int32)
    for x in range(nx):
        for z in range(nz):
            run = 0
            for y in range(ny - 1, -1, -1):
                if avail[x, y, z]:
                    run += 1
                else:
                    run = 0
                dy[x, y, z] = run
        for y in range(ny):
            run = 0
            for z in range(nz - 1, -1, -1):
                if avail[x, y, z]:
                    run += 1
                else:
                    run = 0
                dz[x, y, z] = run
    return dy, dz


@njit_cached()
def _best_box_at(dx, x, y, z, ymax, zmax):
    """Largest box with lower corner (x, y, z): returns volume, X, Y, Z (voxels)."""
    ny = dx.shape[1]
    nz = dx.shape[2]
    ylim = min(ymax, ny - y)
    zlim = min(zmax, nz - z)
    colmin = np.full(ylim, 2**30, np.int64)
    best, bx, by, bz = 0, 0, 0, 0
    for zz in range(zlim):
        run = 2**30
        for yy in range(ylim):
            v = dx[x, y + yy, z + zz]
            if v < colmin[yy]:
                colmin[yy] = v
            if colmin[yy] < run:
                run = colmin[yy]
            if run == 0:
                ylim = yy
                break
            vol = (yy + 1) * (zz + 1) * run
            if vol > best:
                best, bx, by, bz = vol, run, yy + 1, zz + 1
        if ylim == 0:
            break
    return best, bx, by, bz


@njit_cached()
def _less(keys, vals, i, j):
    """Heap order: entry i before entry j (lexicographic on (key, value))."""
    return keys[i] < keys[j] or (keys[i] == keys[j] and vals[i] < vals[j])


@njit_cached()
def _swap(keys, vals, i, j):
    keys[i], keys[j] = keys[j], keys[i]
    vals[i], vals[j] = vals[j], vals[i]


@njit_cached()
def _sift_down(keys, vals, pos, n):
    """Move entry ``pos`` down a binary min-heap of ``n`` entries to its place."""
    while True:
        child = 2 * pos + 1
        if child >= n:
            return
        if child + 1 < n and _less(keys, vals, child + 1, child):
            child += 1
        if not _less(keys, vals, child, pos):
            return
        _swap(keys, vals, child, pos)
        pos = child


@njit_cached()
def _sift_up(keys, vals, pos):
    """Move entry ``pos`` up a binary min-heap to its place."""
    while pos > 0:
        parent = (pos - 1) // 2
        if not _less(keys, vals, pos, parent):
            return
        _swap(keys, vals, pos, parent)
        pos = parent


@njit_cached()
def grow_boxes(avail, max_boxes, min_voxels, target_voxels):
    """Greedy boxes of maximal volume over available voxels, marking each taken.

    Lazy greedy: the heap holds upper bounds (the product of the per-axis run
    lengths, or an exact value from an earlier step; values only shrink as
    voxels are taken); an entry made exact at the current step is the
    maximum. Ties go to the smallest (x, y, z). An exact value from an earlier
    step stays exact when no box taken since then reaches the part of the
    grid above the voxel (x' >= x, y' >= y, z' >= z): it is re-queued without
    being recomputed.

    The heap is two int64 arrays (16 bytes per available voxel): the negated
    volume, and the step at which it was computed (+1) above the voxel's flat
    index. Returns an (k, 6) int64 array of boxes [x0, y0, z0, x1, y1, z1) in
    voxels.
    """
    avail = avail.copy()
    nx, ny, nz = avail.shape
    dx = runs_along_x(avail)
    dy, dz = _runs_along_y_z(avail)
    cells = nx * ny * nz
    shift = 1
    while (1 << shift) <= cells:
        shift += 1
    mask = (1 << shift) - 1
    n = 0
    for x in range(nx):
        for y in range(ny):
            for z in range(nz):
                if avail[x, y, z]:
                    n += 1
    keys = np.empty(n, np.int64)
    vals = np.empty(n, np.int64)  # (epoch + 1) << shift | flat index; epoch -1: a bound
    n = 0
    for x in range(nx):
        for y in range(ny):
            for z in range(nz):
                if avail[x, y, z]:
                    keys[n] = -(np.int64(dx[x, y, z]) * dy[x, y, z] * dz[x, y, z])
                    vals[n] = (x * ny + y) * nz + z
                    n += 1
    for i in range(n // 2 - 1, -1, -1):
        _sift_down(keys, vals, i, n)
    boxes = np.zeros((max_boxes, 6), np.int64)
    k = 0
    covered = 0
    step = 0
    while k < max_boxes and covered < target_voxels and n > 0:
        negv, packed = keys[0], vals[0]
        n -= 1
        keys[0], vals[0] = keys[n], vals[n]
        _sift_down(keys, vals, 0, n)
        epoch = (packed >> shift) - 1
        flat = packed & mask
        x = flat // (ny * nz)
        y = (flat // nz) % ny
        z = flat % nz
        if not avail[x, y, z]:
            continue
        if epoch != step:
            still = epoch >= 0
            for j in range(max(epoch, 0), step):
                if x < boxes[j, 3] and y < boxes[j, 4] and z < boxes[j, 5]:
                    still = False
                    break
            if not still:
                vol, bx, by, bz = _best_box_at(dx, x, y, z, dy[x, y, z], dz[x, y, z])
                negv = -vol
            if negv < 0:
                keys[n], vals[n] = negv, ((step + 1) << shift) | flat
                _sift_up(keys, vals, n)
                n += 1
            continue
        vol, bx, by, bz = _best_box_at(dx, x, y, z, dy[x, y, z], dz[x, y, z])
        if vol < min_voxels:
            break
        boxes[k, 0], boxes[k, 1], boxes[k, 2] = x, y, z
        boxes[k, 3], boxes[k, 4], boxes[k, 5] = x + bx, y + by, z + bz
        k += 1
        covered += vol
        for a in range(x, x + bx):
            for b in range(y, y + by):
                for c in range(z, z + bz):
                    avail[a, b, c] = False
        # runs along +X change only in the box's rows, at x below the box's end
        for b in range(y, y + by):
            for c in range(z, z + bz):
                run = 0
                if x + bx < nx:
                    run = dx[x + bx, b, c] if avail[x + bx, b, c] else 0
                for a in range(x + bx - 1, -1, -1):
                    if avail[a, b, c]:
                        run += 1
                    else:
                        run = 0
                    dx[a, b, c] = run
        step += 1
    return boxes[:k]


@njit_cached()
def _slab_free(avail, lo, hi, axis, at):
    """Whether the one-voxel slab at index ``at`` along ``axis`` over the box is available."""
    if at < 0 or at >= avail.shape[axis]:
        return False
    a0, a1 = lo[0], hi[0]
    b0, b1 = lo[1], hi[1]
    c0, c1 = lo[2], hi[2]
    if axis == 0:
        a0, a1 = at, at + 1
    elif axis == 1:
        b0, b1 = at, at + 1
    else:
        c0, c1 = at, at + 1
    for a in range(a0, a1):
        for b in range(b0, b1):
            for c in range(c0, c1):
                if not avail[a, b, c]:
                    return False
    return True


@njit_cached()
def grow_boxes_from_seeds(avail, seeds, max_boxes, min_voxels, target_voxels):
    """Boxes grown from seed voxels in the given order (Leone et al. 2012, sec. 4).

    Each box starts as its seed voxel and expands by one voxel layer in each of
    the six directions in turn while the new layer is all available, until no
    direction can grow; its voxels are then taken. Seeds already taken are
    skipped. Returns (k, 6) int64 boxes [x0, y0, z0, x1, y1, z1).
    """
    avail = avail.copy()
    boxes = np.zeros((max_boxes, 6), np.int64)
    k = 0
    covered = 0
    lo = np.zeros(3, np.int64)
    hi = np.zeros(3, np.int64)
    for s in range(seeds.shape[0]):
        if k >= max_boxes or covered >= target_voxels:
            break
        x, y, z = seeds[s, 0], seeds[s, 1], seeds[s, 2]
        if not avail[x, y, z]:
            continue
        lo[0], lo[1], lo[2] = x, y, z
        hi[0], hi[1], hi[2] = x + 1, y + 1, z + 1
        grown = True
        while grown:
            grown = False
            for axis in range(3):
                if _slab_free(avail, lo, hi, axis, hi[axis]):
                    hi[axis] += 1
                    grown = True
                if _slab_free(avail, lo, hi, axis, lo[axis] - 1):
                    lo[axis] -= 1
                    grown = True
        vol = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2])
        if vol < min_voxels:
            break  # Leone et al.: a box under the minimum stops the search
        for a in range(lo[0], hi[0]):
            for b in range(lo[1], hi[1]):
                for c in range(lo[2], hi[2]):
                    avail[a, b, c] = False
        boxes[k, 0], boxes[k, 1], boxes[k, 2] = lo[0], lo[1], lo[2]
        boxes[k, 3], boxes[k, 4], boxes[k, 5] = hi[0], hi[1], hi[2]
        k += 1
        covered += vol
    return boxes[:k]
