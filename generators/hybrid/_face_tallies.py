"""Incremental precision and recall tallies of face removal, for the metric-guided step."""

from __future__ import annotations

import copy
import time

import numpy as np
import trimesh

from viscore import Scene
from viscore._jit import njit_cached
from viscore._validate import check_memory
from viscore.metrics.precision_recall import pooled_ratio, ratio
from viscore.metrics.reference_views import ReferenceViews

#: Coplanar partners (faces overlapping in one plane, which all-hits lists one of):
#: plane distance as a fraction of the diagonal (the all-hits step, under which two
#: surfaces count as one), normals parallel within 1 - cos, faces per chunk of the
#: pair test; a partner is added to a hit clearly inside it (edge distance of 1e-5
#: of the diagonal, ~100x float32's error) on a ray not grazing it (|cos| > 0.2,
#: so that its own intersection lies within that margin of the hit).
_COPLANAR_RELATIVE = 1e-6
_PARALLEL_TOLERANCE = 1e-9
_PARTNER_CHUNK = 256
_INTERIOR_RELATIVE = 1e-5
_GRAZING_COSINE = 0.2

#: A pixel cast again (:meth:`_State._recast`) is cast against the faces left only when
#: its ray passes within this fraction of the diagonal of one of them (a float64 test,
#: 1000 times float32's error at the scene's scale): most rays cast again find nothing
#: (3,518 of 3,521 on the bunny at 64 triangles), and an Embree scene of the faces left
#: for each removal cost as much as the rest of the step.
_RECAST_NEAR_RELATIVE = 1e-5

#: Rays per all-hits batch.
_RAYS_PER_BATCH = 1 << 19

#: Hits per ray assumed by the memory estimate made before casting (checked
#: again with the real count after casting, before the ray lists are built).
_ASSUMED_HITS_PER_RAY = 4.0

#: Bytes per cast pixel (pixel map, active-pixel arrays), per hit (face id,
#: back flag, face-ordered copy, sort temporaries) and per stored quad.
_BYTES_PER_PIXEL = 4 + 4 * 6
_BYTES_PER_HIT = 4 + 1 + 8 + 1 + 24
_BYTES_PER_QUAD = 16 + 8 + 8 + 4 + 1


# ---------------------------------------------------------------------------- numba kernels
@njit_cached()
def _any_ray_near(centre, radius, normal, edge_normal, edge_offset, origins, dirs,
                  margin):  # pragma: no cover - compiled
    """Whether any ray ``origins[j] + t dirs[j]``, ``t >= 0``, may pass within ``margin``
    of any triangle (its centroid ``centre``, bounding radius ``radius``, unit normal,
    in-plane inward unit edge normals ``edge_normal[i, e]`` and their offsets).

    Conservative: the points within ``margin`` of a triangle lie in the prism cut by
    its plane +- ``margin`` and its three edge lines moved out by ``margin`` (each a
    unit normal's linear function moves by at most ``margin``); False only when every
    ray misses every triangle's bounding sphere (grown by ``margin``) or its prism
    (the ray clipped by the prism's five half-spaces, Cyrus and Beck).
    """
    for i in range(centre.shape[0]):
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        level = nx * centre[i, 0] + ny * centre[i, 1] + nz * centre[i, 2]
        reach = radius[i] + margin
        for j in range(origins.shape[0]):
            ox, oy, oz = origins[j, 0], origins[j, 1], origins[j, 2]
            dx, dy, dz = dirs[j, 0], dirs[j, 1], dirs[j, 2]
            dd = dx * dx + dy * dy + dz * dz
            if dd == 0.0:
                return True
            cx, cy, cz = centre[i, 0] - ox, centre[i, 1] - oy, centre[i, 2] - oz
            s = max(0.0, (cx * dx + cy * dy + cz * dz) / dd)
            qx, qy, qz = cx - s * dx, cy - s * dy, cz - s * dz
            if qx * qx + qy * qy + qz * qz > reach * reach:
                continue  # the ray misses the bounding sphere
            low, high = 0.0, np.inf
            for k in range(5):  # half-spaces a.x <= b of the prism
                if k < 2:
                    sign = 1.0 if k == 0 else -1.0
                    ax, ay, az = sign * nx, sign * ny, sign * nz
                    b = sign * level + margin
                else:
                    e = k - 2
                    ax, ay, az = (-edge_normal[i, e, 0], -edge_normal[i, e, 1],
                                  -edge_normal[i, e, 2])
                    b = -edge_offset[i, e] + margin
                start = ax * ox + ay * oy + az * oz - b
                rate = ax * dx + ay * dy + az * dz
                if rate == 0.0:
                    if start > 0.0:
                        low, high = 1.0, 0.0  # parallel and outside: empty
                        break
                elif rate > 0.0:
                    high = min(high, -start / rate)
                else:
                    low = max(low, -start / rate)
                if low > high:
                    break
            if low <= high:
                return True
    return False


@njit_cached()
def _owner(p, c, pptr, hface, hback, galive, extra_owner, extra_back, skip_back):
    """The one face left at an exclusive pixel (c == 1), or -1 (shared, empty, or skipped)."""
    if c[p] != 1:
        return -1
    for k in range(pptr[p], pptr[p + 1]):
        f = hface[k]
        if galive[f] > 0:
            if skip_back and hback[k]:
                return -1
            return f
    e = extra_owner[p]
    if e >= 0 and galive[e] > 0:
        if skip_back and extra_back[p]:
            return -1
        return e
    return -1


@njit_cached()
def _quad_owners(q, img, quads, pm_off, pixmap, img_w, c, pptr, hface, hback, galive,
                 extra_owner, extra_back, skip_back, mark, stamp, buf):
    """Distinct faces whose removal alone uncovers part of quad ``q`` (into ``buf``).

    Returns their number, or -1 when the quad is not fully covered.
    """
    w = img_w[img]
    base = pm_off[img]
    k = 0
    for r in range(quads[q, 0], quads[q, 2]):
        row = base + r * w
        for col in range(quads[q, 1], quads[q, 3]):
            p = pixmap[row + col]
            if p < 0 or c[p] == 0:
                return -1
            if c[p] == 1:
                o = _owner(p, c, pptr, hface, hback, galive, extra_owner, extra_back,
                           skip_back)
                if o >= 0 and mark[o] != stamp:
                    mark[o] = stamp
                    buf[k] = o
                    k += 1
    return k


@njit_cached()
def _exclusive_table(img, pm_off, pixmap, img_w, img_h, c, sat):
    """Summed-area table of the pixels of one image that have exactly one face left."""
    _fill_sat(sat, img_w[img], img_h[img], pixmap, pm_off[img], c, sat, 1)


@njit_cached()
def _fill_sat(sat, w, h, pixmap, base, c, ind, mode):
    """Summed-area table ((h + 1) x (w + 1), flat, into ``sat``) of one image's pixels.

    Counts, for pixel ``i = r * w + col``: ``mode`` 0, covered pixels
    (``pixmap[base + i] >= 0``); 1, covered pixels with exactly one face left
    (``c[p] == 1``); 2, the values ``ind[i]``. Arguments a mode does not read
    may be any array of the right kind.
    """
    for col in range(w + 1):
        sat[col] = 0
    for r in range(h):
        run = 0
        sat[(r + 1) * (w + 1)] = 0
        for col in range(w):
            if mode == 2:
                run += ind[r * w + col]
            else:
                p = pixmap[base + r * w + col]
                if p >= 0 and (mode == 0 or c[p] == 1):
                    run += 1
            sat[(r + 1) * (w + 1) + col + 1] = sat[r * (w + 1) + col + 1] + run


@njit_cached()
def _rect(sat, w, q, quads):
    r0, c0, r1, c1 = quads[q, 0], quads[q, 1], quads[q, 2], quads[q, 3]
    return (sat[r1 * (w + 1) + c1] - sat[r0 * (w + 1) + c1] - sat[r1 * (w + 1) + c0]
            + sat[r0 * (w + 1) + c0])


@njit_cached()
def _all_pairs(quads, q_off, full, pm_off, pixmap, img_w, img_h, c, pptr, hface, hback,
               galive, extra_owner, extra_back, skip_back, n_faces, sat):
    """Every (face, quad) where removing the face alone uncovers the fully covered quad."""
    cap = 1024
    out_f = np.empty(cap, np.int64)
    out_q = np.empty(cap, np.int64)
    m = 0
    mark = np.full(n_faces, -1, np.int64)
    buf = np.empty(n_faces, np.int64)
    stamp = 0
    for img in range(len(q_off) - 1):
        _exclusive_table(img, pm_off, pixmap, img_w, img_h, c, sat)
        w = img_w[img]
        for q in range(q_off[img], q_off[img + 1]):
            if not full[q] or _rect(sat, w, q, quads) == 0:
                continue
            stamp += 1
            k = _quad_owners(q, img, quads, pm_off, pixmap, img_w, c, pptr, hface, hback,
                             galive, extra_owner, extra_back, skip_back, mark, stamp, buf)
            for j in range(k):
                if m == cap:
                    cap *= 2
                    nf = np.empty(cap, np.int64)
                    nq = np.empty(cap, np.int64)
                    for t in range(m):  # a loop: a slice copy compiles numba's shape checks
                        nf[t] = out_f[t]
                        nq[t] = out_q[t]
                    out_f, out_q = nf, nq
                out_f[m] = buf[j]
                out_q[m] = q
                m += 1
    return out_f[:m], out_q[:m]


@njit_cached()
def _full_quads(quads, q_off, qn, pm_off, pixmap, img_w, img_h, sat):
    """``(Q,) bool``: quads whose every pixel the occluder covers (a list is non-empty)."""
    full = np.zeros(len(qn), np.bool_)
    for img in range(len(q_off) - 1):
        w = img_w[img]
        _fill_sat(sat, w, img_h[img], pixmap, pm_off[img], pixmap, sat, 0)
        for q in range(q_off[img], q_off[img + 1]):
            full[q] = _rect(sat, w, q, quads) == qn[q]
    return full


@njit_cached()
def _add_quad(q, sign, k, buf, qn, qa, qunit, coef_r, coef_p, loss, relief):
    n = qn[q]
    a = qa[q]
    u = qunit[q]
    for j in range(k):
        o = buf[j]
        if a == n:
            loss[o] += sign * coef_r[u] * n
        else:
            relief[o] += sign * coef_p[u] * (n - a)


@njit_cached()
def _image_of(q_off, q):  # pragma: no cover
    """The image of quad ``q``: the last ``i`` with ``q_off[i] <= q``, by bisection (as
    ``np.searchsorted(q_off, q, side="right") - 1``, whose numba version took about a second
    to compile)."""
    lo, hi = 0, len(q_off)
    while lo < hi:
        mid = (lo + hi) // 2
        if q_off[mid] <= q:
            lo = mid + 1
        else:
            hi = mid
    return lo - 1


@njit_cached()
def _remove_face(g, plist, refound, a_img, a_loc, quads, q_off, qn, qa, qunit, full,
                 pm_off, pixmap, img_w, img_h, c, pptr, hface, hback, galive, extra_owner,
                 extra_back, skip_back, coef_r, coef_p, loss, relief, nt, pf, nf, sat, ind,
                 mark, buf, stamp):
    """Remove face ``g`` (its last copy): pixel counts, quad flags, tallies and the losses.

    ``plist`` are the active pixels whose lists hold ``g`` (sorted, so grouped by
    image); ``refound`` marks those a re-cast found covered by another face.
    Returns the stamp counter.
    """
    cap = 256
    affected = np.empty(cap, np.int64)
    na = 0
    i = 0
    n_list = len(plist)
    while i < n_list:
        img = a_img[plist[i]]
        j = i
        changed = False
        while j < n_list and a_img[plist[j]] == img:
            p = plist[j]
            if c[p] <= 2:
                ind[a_loc[p]] = 1
                changed = True
            j += 1
        if changed:
            w = img_w[img]
            _fill_sat(sat, w, img_h[img], pixmap, 0, c, ind, 2)
            for q in range(q_off[img], q_off[img + 1]):
                if not full[q] or _rect(sat, w, q, quads) == 0:
                    continue
                stamp += 1
                k = _quad_owners(q, img, quads, pm_off, pixmap, img_w, c, pptr, hface, hback,
                                 galive, extra_owner, extra_back, skip_back, mark, stamp, buf)
                _add_quad(q, -1.0, k, buf, qn, qa, qunit, coef_r, coef_p, loss, relief)
                if na == cap:
                    cap *= 2
                    grown = np.empty(cap, np.int64)
                    for t in range(na):
                        grown[t] = affected[t]
                    affected = grown
                affected[na] = q
                na += 1
            for t in range(i, j):
                ind[a_loc[plist[t]]] = 0
        i = j
    galive[g] = 0
    for t in range(n_list):
        p = plist[t]
        c[p] -= 1
        if refound[t]:
            c[p] += 1
    # the quads' images, from their ranges
    for t in range(na):
        q = affected[t]
        img = _image_of(q_off, q)
        stamp += 1
        k = _quad_owners(q, img, quads, pm_off, pixmap, img_w, c, pptr, hface, hback, galive,
                         extra_owner, extra_back, skip_back, mark, stamp, buf)
        if k < 0:
            full[q] = False
            u = qunit[q]
            if qa[q] == qn[q]:
                nt[u] -= qn[q]
                pf[u] += qn[q]
            else:
                nf[u] -= qn[q] - qa[q]
        else:
            _add_quad(q, 1.0, k, buf, qn, qa, qunit, coef_r, coef_p, loss, relief)
    return stamp


# ---------------------------------------------------------------------------- the state
class _State:
    """Per-pixel face lists, per-quad flags and per-position tallies of one occluder."""

    def __init__(self, reference: ReferenceViews, occ: trimesh.Trimesh, *, skip_unseen: bool,
                 skip_backfacing: bool) -> None:
        self.reference = reference
        self.skip_back = bool(skip_backfacing)
        faces = np.asarray(occ.faces, dtype=np.int64)
        vertices = np.asarray(occ.vertices, dtype=np.float64)
        m = len(faces)
        # exact duplicates (the same three points) share one record: the group's first face
        tri = _sorted_corners(vertices[faces])
        _, first, group = np.unique(tri.reshape(m, 9), axis=0, return_index=True,
                                    return_inverse=True)
        self.rep = first[group.ravel()].astype(np.int64)
        self.members = np.bincount(self.rep, minlength=m).astype(np.int32)
        self.galive = self.members.copy()
        self.alive = np.ones(m, dtype=bool)
        self.vertices, self.faces = vertices, faces
        self.normals = np.asarray(occ.face_normals, dtype=np.float64)
        reps = np.flatnonzero(self.members > 0)
        self._reps = reps
        units = len(reference.weights)
        self.nt = np.zeros(units, np.int64)
        self.pf = np.zeros(units, np.int64)
        self.nf = np.zeros(units, np.int64)
        images, sees = reference.scored_images(occ.bounds)
        todo = [k for k, r in enumerate(images) if r.quads is not None
                and (sees[k] or not skip_unseen)]
        counted = [r for r in images if r.quads is not None]
        if counted:  # the lost occlusion with nothing covered (the live images corrected below)
            n = np.concatenate([r.n for r in counted]).astype(np.int64)
            a = np.concatenate([r.a for r in counted]).astype(np.int64)
            unit = np.repeat([r.unit for r in counted], [len(r.n) for r in counted])
            self.pf += np.bincount(unit, np.where(a == n, n, 0),
                                   minlength=units).astype(np.int64)
        pixels = sum((images[k].box[2] - images[k].box[0]) * (images[k].box[3]
                     - images[k].box[1]) for k in todo)
        quads = sum(len(images[k].quads) for k in todo)
        check_memory(pixels * (_BYTES_PER_PIXEL + _ASSUMED_HITS_PER_RAY * _BYTES_PER_HIT)
                     + quads * _BYTES_PER_QUAD,
                     f"metric-guided simplification: {len(todo)} images, {pixels} rays")
        self.images_total = len(images)
        self.images_unseen = len(images) - len(todo)
        start = time.perf_counter()
        self._cast(images, todo, reps)
        self.seconds_cast = time.perf_counter() - start
        self.zero_loss = 0.5 * float(self.coef_r[self.coef_r > 0].min(initial=np.inf))

    #: The arrays that removals change in place (:meth:`remove`, its kernel and
    #: :meth:`_recast`) and the kernels' scratch: each copy has its own. Every other array
    #: is read-only once cast (the hit lists, pixel maps and quads: most of the bytes).
    _CHANGING = ("alive", "galive", "c", "full", "loss", "relief", "nt", "pf", "nf",
                 "extra_owner", "extra_back", "sat", "ind", "mark", "buf")

    def copy(self) -> _State:
        """A state that removals change apart from this one: the arrays they change
        (:data:`_CHANGING`) and the extra owners' lists copied; the reference, its images
        and the read-only tables shared."""
        other = copy.copy(self)
        for name in self._CHANGING:
            setattr(other, name, getattr(self, name).copy())
        other.extras = {k: list(v) for k, v in self.extras.items()}
        return other

    # ------------------------------------------------------------------ casting
    def _cast(self, images: list, todo: list, reps: np.ndarray) -> None:
        ref = self.reference
        scene = Scene(trimesh.Trimesh(self.vertices, self.faces[reps], process=False))
        self._scene_reps = reps
        self._margin = _INTERIOR_RELATIVE * scene.diagonal
        self._near = _RECAST_NEAR_RELATIVE * scene.diagonal
        self._partners = _coplanar_partners(self.vertices, self.faces, self.normals, reps,
                                            _COPLANAR_RELATIVE * scene.diagonal, self._margin)
        # inward unit normals of each face's edges in its plane, and their offsets
        tri = self.vertices[self.faces]
        edges = np.roll(tri, -1, axis=1) - tri
        planes = np.cross(self.normals[:, None, :], edges)
        planes /= np.maximum(np.linalg.norm(planes, axis=2, keepdims=True), 1e-300)
        self._edge_planes = planes, np.einsum("mkd,mkd->mk", planes, tri)
        # each face's centroid and bounding radius, for the re-casts' nearness test
        self._centre = tri.mean(axis=1)
        self._radius = np.linalg.norm(tri - self._centre[:, None], axis=2).max(axis=1)
        live, maps, a_loc_parts, hit_pix, hit_face, hit_back = [], [], [], [], [], []
        rays_cast = 0
        n_active = 0
        batch: list = []
        size = 0
        for pos, k in enumerate(todo):
            r = images[k]
            batch.append(k)
            size += (r.box[2] - r.box[0]) * (r.box[3] - r.box[1])
            if size < _RAYS_PER_BATCH and pos + 1 < len(todo):
                continue
            rays = [ref.pixel_rays(images[b].unit, images[b].cam, images[b].box)
                    for b in batch]
            origins = np.concatenate([o for o, _ in rays])
            dirs = np.concatenate([d for _, d in rays])
            hits = scene.all_hits(origins, dirs)
            rays_cast += len(origins)
            face = reps[hits.triangle]
            ray = hits.ray
            ray, face = self._with_partners(origins, dirs, ray, hits.t, face)
            key = np.sort(ray * len(self.faces) + face)  # one record per (pixel, face)
            key = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
            ray, face = key // len(self.faces), key % len(self.faces)
            back = np.einsum("ij,ij->i", dirs[ray], self.normals[face]) > 0
            at = 0
            for b in batch:
                hw = (images[b].box[2] - images[b].box[0]) * (images[b].box[3]
                                                             - images[b].box[1])
                lo, hi = np.searchsorted(ray, [at, at + hw])
                if hi > lo:
                    local = ray[lo:hi] - at
                    pix = local[np.r_[True, local[1:] != local[:-1]]]  # local is sorted
                    pmap = np.full(hw, -1, np.int32)
                    pmap[pix] = n_active + np.arange(len(pix), dtype=np.int32)
                    live.append(b)
                    maps.append(pmap)
                    a_loc_parts.append(pix.astype(np.int32))
                    hit_pix.append(pmap[local].astype(np.int64))
                    hit_face.append(face[lo:hi].astype(np.int32))
                    hit_back.append(back[lo:hi])
                    n_active += len(pix)
                at += hw
            batch, size = [], 0
        self.rays_cast = rays_cast
        hits_total = int(sum(len(h) for h in hit_pix))
        check_memory(rays_cast * _BYTES_PER_PIXEL + hits_total * _BYTES_PER_HIT,
                     f"metric-guided simplification: {hits_total} hits")
        self.images_live = len(live)
        self.live = [images[k] for k in live]
        L = len(live)
        self.img_h = np.array([r.box[2] - r.box[0] for r in self.live], np.int64)
        self.img_w = np.array([r.box[3] - r.box[1] for r in self.live], np.int64)
        self.img_unit = np.array([r.unit for r in self.live], np.int64)
        self._ray_table(ref)
        self.pm_off = np.concatenate([[0], np.cumsum(self.img_h * self.img_w)]).astype(np.int64)
        self.pixmap = np.concatenate(maps) if L else np.zeros(0, np.int32)
        self.a_loc = np.concatenate(a_loc_parts) if L else np.zeros(0, np.int32)
        self.a_img = np.repeat(np.arange(L, dtype=np.int32),
                               [len(x) for x in a_loc_parts]).astype(np.int32)
        hp = np.concatenate(hit_pix) if L else np.zeros(0, np.int64)
        hf = np.concatenate(hit_face) if L else np.zeros(0, np.int32)
        hb = np.concatenate(hit_back) if L else np.zeros(0, bool)
        order = np.argsort(hp, kind="stable")  # pixel-major
        self.hface, self.hback = hf[order], hb[order]
        counts = np.bincount(hp, minlength=n_active)
        self.pptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.c = counts.astype(np.int32)
        hp = hp[order]
        forder = np.argsort(self.hface, kind="stable")  # face-major, pixels ascending
        self.fpix = hp[forder]
        self.fptr = np.concatenate([[0], np.cumsum(np.bincount(self.hface, minlength=len(
            self.faces)))]).astype(np.int64)
        self.extra_owner = np.full(n_active, -1, np.int32)
        self.extra_back = np.zeros(n_active, bool)
        self.extras: dict[int, list] = {}
        # quads of the live images, their fullness and the tallies
        sizes = [len(r.n) for r in self.live]
        self.quads = (np.concatenate([r.quads for r in self.live]).astype(np.int32) if L
                      else np.zeros((0, 4), np.int32))
        self.qn = np.concatenate([r.n for r in self.live]).astype(np.int64) if L else \
            np.zeros(0, np.int64)
        self.qa = np.concatenate([r.a for r in self.live]).astype(np.int64) if L else \
            np.zeros(0, np.int64)
        self.qunit = np.repeat(self.img_unit, sizes).astype(np.int64)
        self.q_off = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        side = int(max(self.img_w.max(initial=1), self.img_h.max(initial=1)))
        self.sat = np.zeros((side + 1) ** 2, np.int32)
        self.full = _full_quads(self.quads, self.q_off, self.qn, self.pm_off, self.pixmap,
                                self.img_w, self.img_h, self.sat)
        # the live images' quads: Nt, Nf, and Pf where the occluder covers the quad too
        units = len(self.nt)
        orig = self.qa == self.qn
        both = self.full & orig
        self.nt += np.bincount(self.qunit, np.where(both, self.qn, 0),
                               minlength=units).astype(np.int64)
        self.pf -= self.nt  # the constant part counted every quad the original covers
        self.nf += np.bincount(self.qunit, np.where(self.full & ~orig, self.qn - self.qa, 0),
                               minlength=units).astype(np.int64)
        # recall is linear in Nt: R = sum_u coef_r[u] Nt_u (its denominators are fixed)
        w = np.asarray(self.reference.weights, dtype=np.float64)
        d_r = (self.nt + self.pf).astype(np.float64)
        ok = d_r > 0
        self.coef_r = np.where(ok, w / np.where(ok, d_r, 1.0), 0.0) / max(w[ok].sum(), 1e-300)
        d_p = (self.nt + self.nf).astype(np.float64)
        okp = d_p > 0
        self.coef_p = np.where(okp, w / np.where(okp, d_p, 1.0), 0.0) / max(w[okp].sum(),
                                                                            1e-300)
        self.ind = np.zeros(side * side, np.int32)
        m = len(self.faces)
        self.mark = np.full(m, -1, np.int64)
        self.buf = np.empty(m, np.int64)
        self.stamp = 0
        self.recast = self.refound = 0
        self.loss = np.zeros(m)
        self.relief = np.zeros(m)

    def _with_partners(self, origins, dirs, ray, t, face):
        """Add, to each hit, the faces coplanar with the hit face that clearly contain it.

        All-hits steps past a hit, so of two overlapping coplanar faces a ray
        lists one. A partner is added where the hit point lies in its plane
        (within the all-hits step), inside it by a margin far above float32's
        error, and the ray is not grazing: there Embree hits the partner
        alone too, so the lists stay true hits.
        """
        ptr, idx = self._partners
        count = ptr[face + 1] - ptr[face]
        if not count.any():
            return ray, face
        h = np.repeat(np.arange(len(face)), count)
        start = np.repeat(ptr[face], count)
        j = idx[start + np.arange(len(h)) - np.repeat(np.cumsum(count) - count, count)]
        d = dirs[ray[h]]
        p = origins[ray[h]] + t[h, None] * d
        inside = np.abs(np.einsum("ij,ij->i", d, self.normals[j])) > _GRAZING_COSINE
        planes, offsets = self._edge_planes
        for k in range(3):  # distance inside each edge, in the face's plane
            inside &= np.einsum("ij,ij->i", planes[j, k], p) - offsets[j, k] >= self._margin
        return np.concatenate([ray, ray[h[inside]]]), np.concatenate([face, j[inside]])

    # ------------------------------------------------------------------ figures
    def per_view(self) -> dict:
        nt, pf, nf = self.nt, self.pf, self.nf
        return {"nt": nt, "pf": pf, "nf": nf, "precision": ratio(nt, nt + nf),
                "recall": ratio(nt, nt + pf), "weight": self.reference.weights}

    def figures(self) -> tuple[float, float]:
        pv = self.per_view()
        return (pooled_ratio(pv, "volume", "precision"), pooled_ratio(pv, "volume", "recall"))

    def _args(self):
        return (self.pm_off, self.pixmap, self.img_w, self.c, self.pptr, self.hface, self.hback,
                self.galive, self.extra_owner, self.extra_back, self.skip_back)

    def pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """(face group, quad) pairs: the group's removal alone uncovers the full quad."""
        return _all_pairs(self.quads, self.q_off, self.full, self.pm_off, self.pixmap,
                          self.img_w, self.img_h, self.c, self.pptr, self.hface, self.hback,
                          self.galive, self.extra_owner, self.extra_back, self.skip_back,
                          len(self.faces), self.sat)

    def refresh_losses(self) -> None:
        """Recompute every group's recall loss and false-occlusion relief from scratch."""
        f, q = self.pairs()
        orig = self.qa[q] == self.qn[q]
        m = len(self.faces)
        self.loss = np.bincount(f[orig], self.coef_r[self.qunit[q[orig]]] * self.qn[q[orig]],
                                minlength=m).astype(np.float64)
        self.relief = np.bincount(f[~orig], self.coef_p[self.qunit[q[~orig]]]
                                  * (self.qn[q[~orig]] - self.qa[q[~orig]]),
                                  minlength=m).astype(np.float64)

    def precision_gains(self) -> np.ndarray:
        """``(m,) float64`` P(M - f) - P(M) for every face f (0 for duplicated, NaN undefined)."""
        m = len(self.faces)
        gain = np.zeros(m)
        f, q = self.pairs()
        if len(f) == 0:
            return gain
        units = len(self.nt)
        u = self.qunit[q]
        orig = self.qa[q] == self.qn[q]
        key, inv = np.unique(f * units + u, return_inverse=True)
        inv = inv.ravel()
        dnt = np.bincount(inv, np.where(orig, self.qn[q], 0), minlength=len(key))
        dnf = np.bincount(inv, np.where(orig, 0, self.qn[q] - self.qa[q]), minlength=len(key))
        kf, ku = key // units, key % units
        w = np.asarray(self.reference.weights, dtype=np.float64)
        nt, nf = self.nt.astype(np.float64), self.nf.astype(np.float64)
        den0 = nt + nf
        p0 = np.where(den0 > 0, nt / np.where(den0 > 0, den0, 1), 0.0)
        num_all = float((w * p0)[den0 > 0].sum())
        den_all = float(w[den0 > 0].sum())
        nt1 = nt[ku] - dnt
        den1 = nt1 + nf[ku] - dnf
        p1 = np.where(den1 > 0, nt1 / np.where(den1 > 0, den1, 1), 0.0)
        d_num = w[ku] * (p1 * (den1 > 0) - p0[ku] * (den0[ku] > 0))
        d_den = w[ku] * ((den1 > 0).astype(float) - (den0[ku] > 0))
        num = num_all + np.bincount(kf, d_num, minlength=m)
        den = den_all + np.bincount(kf, d_den, minlength=m)
        before = num_all / den_all if den_all > 0 else np.nan
        touched = np.bincount(kf, minlength=m) > 0
        after = np.where(den > 0, num / np.where(den > 0, den, 1), np.nan)
        gain[touched] = after[touched] - before
        return gain

    # ------------------------------------------------------------------ removal
    def group_alone(self) -> np.ndarray:
        """``(m,) bool``: alive faces that are the last copy of their group."""
        return self.alive & (self.galive[self.rep] == 1)

    def remove(self, f: int) -> None:
        """Remove face ``f`` and update every pixel, quad, tally and loss it touches."""
        self.alive[f] = False
        g = int(self.rep[f])
        if self.galive[g] > 1:  # another copy still covers the same pixels
            self.galive[g] -= 1
            return
        main = self.fpix[self.fptr[g]:self.fptr[g + 1]]
        extra = [p for p in self.extras.get(g, ()) if self.extra_owner[p] == g]
        # the face's own pixels are ascending and distinct (one record per pixel and face)
        plist = np.unique(np.concatenate([main, np.asarray(extra, np.int64)])) if extra else main
        refound = np.zeros(len(plist), bool)
        last = plist[self.c[plist] == 1]
        if len(last):
            found = self._recast(last, g)
            refound[np.isin(plist, found)] = True
            self.recast += len(last)
            self.refound += len(found)
        self.stamp = _remove_face(
            g, plist, refound, self.a_img, self.a_loc, self.quads, self.q_off, self.qn,
            self.qa, self.qunit, self.full, self.pm_off, self.pixmap, self.img_w, self.img_h,
            self.c, self.pptr, self.hface, self.hback, self.galive, self.extra_owner,
            self.extra_back, self.skip_back, self.coef_r, self.coef_p, self.loss,
            self.relief, self.nt, self.pf, self.nf, self.sat, self.ind, self.mark, self.buf,
            self.stamp)

    def _recast(self, pixels: np.ndarray, g: int) -> np.ndarray:
        """Pixels about to lose their last listed face that another face still covers.

        Their rays are cast again against the faces left (without ``g``); a
        hit records that face as the pixel's extra owner. Returns those pixels.
        """
        keep = self._reps[(self.galive[self._reps] > 0) & (self._reps != g)]
        if len(keep) == 0:
            return np.zeros(0, np.int64)
        origins, dirs = self._pixel_rays(pixels)
        planes, offsets = self._edge_planes
        if not _any_ray_near(self._centre[keep], self._radius[keep], self.normals[keep],
                             planes[keep], offsets[keep], origins, dirs, self._near):
            return np.zeros(0, np.int64)  # no face left near any of these rays: no hit
        scene = Scene(trimesh.Trimesh(self.vertices, self.faces[keep], process=False))
        _, tri = scene.first_hit(origins, dirs)
        hit = tri >= 0
        found = pixels[hit]
        owner = keep[tri[hit]]
        self.extra_owner[found] = owner
        self.extra_back[found] = np.einsum("ij,ij->i", dirs[hit], self.normals[owner]) > 0
        for p, o in zip(found.tolist(), owner.tolist(), strict=True):
            self.extras.setdefault(o, []).append(p)
        return found

    def _ray_table(self, ref: ReferenceViews) -> None:
        """The live images' rays as tables: each image's origin, and each frustum's
        whole-image directions, read from :meth:`ReferenceViews.pixel_rays` once (volume
        protocol: one origin per position, one direction bundle per frustum), so that
        :meth:`_pixel_rays` picks any pixels' rays by indexing, the same values."""
        self._rays_by_table = ref.protocol == "volume" and bool(self.live)
        if not self._rays_by_table:
            return
        cams = sorted({int(r.cam) for r in self.live})
        self._cam_row = np.full(max(cams) + 1, -1, np.int64)
        self._cam_row[cams] = np.arange(len(cams))
        self._cam_dirs = np.stack([ref.pixel_rays(self.live[0].unit, c)[1] for c in cams])
        self.img_origin = np.stack([ref.pixel_rays(r.unit, r.cam)[0][0] for r in self.live])
        self.img_cam = self._cam_row[np.array([r.cam for r in self.live], np.int64)]
        self.img_r0 = np.array([r.box[0] for r in self.live], np.int64)
        self.img_c0 = np.array([r.box[1] for r in self.live], np.int64)
        self._res = int(ref.resolution)

    def _pixel_rays(self, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self._rays_by_table:
            img = self.a_img[pixels]
            loc = self.a_loc[pixels].astype(np.int64)
            w = self.img_w[img]
            row, col = self.img_r0[img] + loc // w, self.img_c0[img] + loc % w
            return (self.img_origin[img],
                    self._cam_dirs[self.img_cam[img], row * self._res + col])
        origins = np.empty((len(pixels), 3))
        dirs = np.empty((len(pixels), 3))
        img = self.a_img[pixels]
        for i in np.unique(img):
            sel = img == i
            r = self.live[i]
            o, d = self.reference.pixel_rays(r.unit, r.cam, r.box)
            loc = self.a_loc[pixels[sel]]
            origins[sel] = np.broadcast_to(o, d.shape)[loc]
            dirs[sel] = d[loc]
        return origins, dirs


def _overlap_2d(a: np.ndarray, b: np.ndarray, n: np.ndarray, margin: float) -> np.ndarray:
    """``(P,) bool``: coplanar triangles ``a``, ``b`` (P, 3, 3) overlap by more than ``margin``.

    Separating axes of the two triangles projected on the plane of normal
    ``n``: the six edge normals; edge-sharing neighbours do not overlap.
    """
    if len(a) == 0:
        return np.zeros(0, bool)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(n, u)
    pa = np.stack([np.einsum("pkd,pd->pk", a, u), np.einsum("pkd,pd->pk", a, v)], axis=2)
    pb = np.stack([np.einsum("pkd,pd->pk", b, u), np.einsum("pkd,pd->pk", b, v)], axis=2)
    overlap = np.ones(len(a), bool)
    for tri in (pa, pb):
        for k in range(3):
            e = tri[:, (k + 1) % 3] - tri[:, k]
            axis = np.stack([-e[:, 1], e[:, 0]], axis=1)
            axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
            sa = np.einsum("pkd,pd->pk", pa, axis)
            sb = np.einsum("pkd,pd->pk", pb, axis)
            overlap &= (sa.max(axis=1) > sb.min(axis=1) + margin) & (
                sb.max(axis=1) > sa.min(axis=1) + margin)
    return overlap


def _coplanar_partners(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray,
                       reps: np.ndarray, tol: float, margin: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """CSR (``ptr`` (m + 1,), ``idx``) of the faces of ``reps`` overlapping in each one's plane.

    Two faces are partners when their normals are parallel (either way), the
    corners of each lie within ``tol`` (world units) of the other's plane and
    they overlap by more than ``margin`` (world units) in that plane.
    """
    m = len(faces)
    tri = vertices[faces[reps]]
    n = normals[reps]
    offset = np.einsum("ij,ij->i", n, tri[:, 0])
    lo, hi = tri.min(axis=1) - tol, tri.max(axis=1) + tol
    rows, cols = [], []
    for c0 in range(0, len(reps), _PARTNER_CHUNK):
        sl = slice(c0, c0 + _PARTNER_CHUNK)
        par = np.abs(n[sl] @ n.T) > 1 - _PARALLEL_TOLERANCE
        # the box and plane tests only on the columns parallel to some face of the chunk,
        # then only on those whose boxes also meet (the plane test's products in the same
        # layout as over every column: the same values)
        some = np.flatnonzero(par.any(axis=0))
        both = par[:, some] & ((lo[sl, None] <= hi[None, some])
                               & (hi[sl, None] >= lo[None, some])).all(axis=2)
        some, both = some[both.any(axis=0)], both[:, both.any(axis=0)]
        near = (np.abs(np.einsum("id,jkd->ijk", n[sl], tri[some]) - offset[sl, None, None])
                <= tol).all(axis=2)
        i, j = np.nonzero(both & near)
        j = some[j]
        keep = (i + c0) != j
        i, j = i[keep] + c0, j[keep]
        keep = _overlap_2d(tri[i], tri[j], n[i], margin)
        rows.append(reps[i[keep]])
        cols.append(reps[j[keep]])
    rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
    order = np.argsort(rows, kind="stable")
    ptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=m))]).astype(np.int64)
    return ptr, cols[order].astype(np.int64)


def _sorted_corners(tri: np.ndarray) -> np.ndarray:
    """``(m, 3, 3)`` triangle corners in lexicographic order (duplicates compare equal)."""
    order = np.lexsort((tri[:, :, 2], tri[:, :, 1], tri[:, :, 0]), axis=1)
    return np.take_along_axis(tri, order[:, :, None], axis=1)

