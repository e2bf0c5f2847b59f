"""The original mesh's views, computed once and used to score any number of occluders.

The protocols of :mod:`viscore.metrics.orbit` (Silvennoinen et al. 2014, sec.
6.1) and :mod:`viscore.metrics.volume` (Wu et al. 2022, sec. 3.2).

References
----------
.. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification using Planar Sections". Computer Graphics Forum 33(1), 2014,
   pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [2] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import itertools
import logging
import time
from dataclasses import replace

import numpy as np
import trimesh

from viscore import (
    InputError,
    OrthoCamera,
    Scene,
    cube_cameras,
    directions_uniform,
    stream_seed,
)
from viscore._validate import as_positive_int, as_seed, check_memory, memory_limit

from ._views import cast_depths, cast_hits, ortho_box_rays, scene_of
from .bootstrap import bootstrap_ratio
from .frames import (
    evaluation_box,
    frusta_see_box,
    orbit_frame,
    volume_positions,
    volume_positions_bytes,
)
from .precision_recall import PrecisionRecall, pooled_parts, pooled_ratio, ratio
from .quads import ImageQuads, image_quads, level_table_bytes, occluder_counts

__all__ = ["ReferenceViews", "PROTOCOLS"]

_log = logging.getLogger(__name__)

#: The evaluation protocols, by name.
PROTOCOLS = ("orbit", "volume")

#: Default quads per view (orbit, Silvennoinen et al. 2014, sec. 6.1) and per frustum
#: (volume, Wu et al. 2022, sec. 4.1).
DEFAULT_QUADS = {"orbit": 32000, "volume": 5000}

#: Default orbit views (Silvennoinen et al. 2014, Fig. 11).
DEFAULT_VIEWS = 256

#: Rays cast in one Embree batch (eight 256 x 256 images; one image at least).
_RAYS_PER_BATCH = 8 * 256 * 256

#: Bytes per ray of one batch: float64 origins and directions, their float32
#: copies per chunk, the float64 distance and int64 triangle id.
_BYTES_PER_RAY = 2 * 24 + 2 * 12 + 16

#: Bytes per stored quad: four int16 corners, int32 pixel and original counts,
#: int16 depth level.
_BYTES_PER_QUAD = 8 + 4 + 4 + 2


def _batch_images(resolution: int) -> int:
    """Images per Embree batch at resolution R."""
    return max(1, _RAYS_PER_BATCH // (resolution * resolution))


class ReferenceViews:
    """The original mesh's views for one protocol, settings and seed, built once.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The original (validated as by :func:`viscore.validate_mesh`).
    protocol : {'orbit', 'volume'}, optional
        Default 'orbit'.
    views : int, optional
        Orbit only: N view directions uniform on the sphere (default 256).
    quads : int, optional
        Q per orbit view (default 32,000) or per volume frustum (default 5,000).
    resolution : int, optional
        R, pixels per image side, at most 8192 (default 256).
    spacing, padding : float, optional
        Volume only: view spacing dx and bounding-box growth, world units
        (defaults 4% of the bounding-box diagonal and its smallest side).
    merge_views : bool, optional
        Volume only: octree view merging with volume weights (default True).
    jitter : bool, optional
        Volume only: shift the position grid by a seeded uniform offset.
    depth_aware : bool, optional
        Classify by depth instead of coverage (default False).
    depth_levels : int, optional
        Quad depth values of the depth-aware variant (default 32).
    seed : int, optional
        Seeds the directions (orbit), the merged positions (volume) and, one
        child seed per view or position, the quads. Default 0.
    cache : bool or None, optional
        Keep the quads and the original's per-quad tallies in memory, so that
        each :meth:`score` casts only the occluder (True; refused with an
        :class:`InputError` when they would not fit), or draw them anew from
        the original inside each :meth:`score` (False: bounded memory, for a
        single occluder). None (default): cache when it fits in the memory
        limit, else not (logged). The results are the same either way.

    Attributes
    ----------
    mesh : trimesh.Trimesh
    protocol : str
    settings : dict
        The protocol's settings as recorded in ``PrecisionRecall.params``.
    seed : int
    depth_aware : bool
    directions : (N, 3) float64
        Orbit view directions (None for volume).
    positions : (m, 3) float64
        Volume view positions (None for orbit).
    weights : (views,) float64
        Weight of each view in the pooled figures: 1 per orbit view, the
        block volume in grid cells per volume position (the weights of
        ``per_view['weight']``).
    cached : bool
        Whether the per-quad tallies are held in memory.
    seconds : float
        Wall time of the construction.
    timing : dict
        ``seconds_rays``, ``rays`` and ``seconds_quads`` of the construction.

    Raises
    ------
    InputError
        On an unknown protocol, an option of the other protocol, a
        non-positive count, an empty original, or settings whose data would
        not fit in memory (checked before any work).

    Notes
    -----
    Deterministic given ``seed``: :meth:`score` gives bit for bit the
    :class:`PrecisionRecall` of :func:`viscore.metrics.orbit_precision_recall`
    or :func:`viscore.metrics.volume_precision_recall` with the same settings
    (``seconds`` and ``timing`` aside). Volume frusta that see neither mesh's
    bounding box are skipped; a frustum that sees only the occluder's box
    counts the occluder's false occlusion, so positions whose frusta change
    that way are drawn again from the original inside :meth:`score`.

    Examples
    --------
    >>> box = trimesh.creation.box()
    >>> views = ReferenceViews(box, views=4, quads=200, resolution=32)
    >>> small = box.copy(); _ = small.apply_scale(0.5)
    >>> float(views.score(box).recall), bool(views.score(small).recall < 1)
    (1.0, True)
    """

    def __init__(self, mesh: trimesh.Trimesh, *, protocol: str = "orbit",
                 views: int | None = None, quads: int | None = None, resolution: int = 256,
                 spacing: float | None = None, padding: float | None = None,
                 merge_views: bool | None = None, jitter: bool | None = None,
                 depth_aware: bool = False, depth_levels: int = 32, seed: int = 0,
                 cache: bool | None = None) -> None:
        protocol = check_protocol(protocol)
        other = ({"spacing": spacing, "padding": padding, "merge_views": merge_views,
                  "jitter": jitter} if protocol == "orbit" else {"views": views})
        given = [k for k, v in other.items() if v is not None]
        if given:
            raise InputError(f"{given[0]}: not an option of the {protocol} protocol")
        quads = as_positive_int(DEFAULT_QUADS[protocol] if quads is None else quads, "quads")
        resolution = as_positive_int(resolution, "resolution", maximum=8192)
        depth_levels = as_positive_int(depth_levels, "depth_levels", maximum=2**15)
        seed = as_seed(seed)
        if cache not in (None, True, False):
            raise InputError(f"cache: expected True, False or None, got {cache!r}")
        start = time.perf_counter()
        self.protocol = protocol
        self.seed = seed
        self.depth_aware = bool(depth_aware)
        self.quads_per_image = quads
        self.resolution = resolution
        self.depth_levels = depth_levels
        self._original = scene_of(mesh, "mesh")
        self.mesh = mesh
        self.timing: dict = {}
        self._depth_images = None
        # the per-batch working set: rays, their images, their quads and the level tables
        working = (_batch_images(resolution) * (resolution**2 * _BYTES_PER_RAY
                                                + quads * float(_BYTES_PER_QUAD))
                   + (level_table_bytes(resolution, depth_levels) if depth_aware else 0))
        if protocol == "orbit":
            views = as_positive_int(DEFAULT_VIEWS if views is None else views, "views")
            check_memory(working + views * 200.0, f"resolution={resolution}, quads={quads}")
            self._setup_orbit(mesh, views)
        else:
            merge_views = True if merge_views is None else bool(merge_views)
            jitter = bool(jitter)
            check_memory(working + volume_positions_bytes(mesh, spacing=spacing,
                                                          padding=padding),
                         f"spacing={spacing}, resolution={resolution}, quads={quads}")
            self._setup_volume(mesh, spacing, padding, merge_views, jitter)
        need = len(self._images) * quads * float(_BYTES_PER_QUAD) + working
        what = (f"views={len(self.weights)}, quads={quads}" if protocol == "orbit" else
                f"positions={len(self.weights)}, frusta={len(self._images)}, quads={quads}")
        if cache is None:
            cache = need <= memory_limit()
            if not cache:
                _log.info("reference views: %s do not fit in memory; the original's quads are "
                          "drawn again for each occluder", what)
        if cache:
            check_memory(need, what)
            self._refs = [r for batch in self._reference_batches(self._images, self.timing)
                          for r in batch]
        else:
            self._refs = None  # type: ignore[assignment]
        self.cached = bool(cache)
        self.seconds = time.perf_counter() - start

    # ------------------------------------------------------------------ construction
    def _setup_orbit(self, mesh, views: int) -> None:
        center, extent = orbit_frame(mesh)
        self.center, self.extent = center, extent
        self.directions = directions_uniform(views, seed=self.seed)
        self.positions = None
        self.weights = np.ones(views)
        self._children = np.random.SeedSequence(self.seed).spawn(views)
        # images: (view, view) -- one image per orbit view, counted in its own row
        self._images = np.stack([np.arange(views), np.arange(views)], axis=1)
        self.settings = {"views": views, "quads": self.quads_per_image,
                         "resolution": self.resolution, "center": center.tolist(),
                         "extent": extent,
                         **({"depth_levels": self.depth_levels} if self.depth_aware else {})}

    def _setup_volume(self, mesh, spacing, padding, merge_views: bool, jitter: bool) -> None:
        seed = self.seed
        offset = np.random.default_rng([seed, 1]).uniform(-0.5, 0.5, 3) if jitter else None
        positions, weights = volume_positions(mesh, spacing=spacing, padding=padding,
                                              merge_views=merge_views, scene=self._original,
                                              offset=offset, seed=seed)
        n = len(positions)
        if n == 0:
            raise InputError("spacing: no view position lies outside the mesh; "
                             "use a smaller spacing")
        self.directions = None  # type: ignore[assignment]
        self.positions, self.weights = positions, weights  # type: ignore[assignment]
        self._children = np.random.SeedSequence(seed).spawn(n)
        cams = cube_cameras(np.zeros(3), self.resolution)
        # the six frusta's ray directions are the same at every position: built once
        self._bundle = np.stack([c.rays()[1] for c in cams])  # (6, R*R, 3)
        self._axes = np.stack([c.forward for c in cams])
        self._mesh_box = np.asarray(mesh.bounds, dtype=np.float64)
        self._sees = frusta_see_box(positions, self._axes, *self._mesh_box)
        # images: (position, frustum), position-major, the frusta that see the mesh's box
        self._images = np.argwhere(self._sees)
        box_lo, _, dx = evaluation_box(mesh, spacing=spacing, padding=padding)
        pad = float(np.asarray(mesh.bounds, dtype=np.float64)[0, 0] - box_lo[0])
        # the values used (world units), not the None that asks for the defaults
        self.settings = {"spacing": dx, "padding": pad, "quads": self.quads_per_image,
                         "resolution": self.resolution, "merge_views": merge_views,
                         "positions": n, "jitter": jitter,
                         **({"depth_levels": self.depth_levels} if self.depth_aware else {})}
        _log.debug("volume protocol: %d positions, %d frusta, %.3g rays per mesh", n,
                   len(self._images), len(self._images) * float(self.resolution) ** 2)

    # ------------------------------------------------------------------ rays
    def _rays(self, unit: int, cam: int, box: tuple | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Origins and directions of one image's pixels (within ``box``, row-major)."""
        res = self.resolution
        whole = box is None or box == (0, 0, res, res)
        if self.protocol == "orbit":
            camera = OrthoCamera(self.directions[cam], self.center, self.extent, res)
            return ortho_box_rays(camera, (0, 0, res, res) if whole else box)  # type: ignore[arg-type]
        d = self._bundle[cam]
        if not whole:
            r0, c0, r1, c1 = box  # type: ignore[misc]
            d = d.reshape(res, res, 3)[r0:r1, c0:c1].reshape(-1, 3)
        return np.broadcast_to(self.positions[unit], d.shape), d  # type: ignore[index]

    def _reference_batches(self, images: np.ndarray, timing: dict, *,
                           depths: np.ndarray | None = None, quads: int | None = None,
                           rng_of=None):
        """The original's side of ``images`` ((k, 2) unit and camera), a batch at a time.

        Casts the original (or takes ``depths``, (k, R, R) images aligned with
        ``images``), draws each image's quads and tallies the original. Quads
        of one unit come, in image order, from one generator: by default the
        unit's child seed, the same stream as the one-call protocols;
        ``rng_of(unit)`` overrides it (the quads ablation).
        """
        res = self.resolution
        quads = self.quads_per_image if quads is None else quads
        rng_of = rng_of or (lambda unit: np.random.default_rng(self._children[unit]))
        rngs: dict = {}
        step = _batch_images(res)
        for b0 in range(0, len(images), step):
            batch = images[b0:b0 + step]
            if depths is None:
                rays = [self._rays(int(u), int(c)) for u, c in batch]
                depth = cast_depths(self._original, np.concatenate([r[0] for r in rays]),
                                    np.concatenate([r[1] for r in rays]), len(batch), res,
                                    timing)
            else:
                depth = depths[b0:b0 + step]
            t0 = time.perf_counter()
            out = []
            for j, im in enumerate(batch):
                unit = int(im[0])  # a new unit starts its own stream
                if unit not in rngs:
                    rngs = {unit: rng_of(unit)}
                out.append(image_quads(unit, int(im[1]), depth[j], quads, rngs[unit],
                                       whole_screen=self.protocol == "volume",
                                       depth_aware=self.depth_aware,
                                       depth_levels=self.depth_levels))
            timing["seconds_quads"] = timing.get("seconds_quads", 0.0) + (
                time.perf_counter() - t0)
            yield out

    # ------------------------------------------------------------------ scoring
    def _cast_regions(self, other, occluder_sees, timing: dict):
        """Occluder pixels over each image's box, one Embree batch per call (None: unseen)."""

        def regions(refs: list) -> list:
            todo = [r for r in refs if r.quads is not None and other is not None
                    and occluder_sees(r)]
            if not todo:
                return [None] * len(refs)
            rays = [self._rays(r.unit, r.cam, r.box) for r in todo]
            hits = cast_hits(other, np.concatenate([x[0] for x in rays]),
                             np.concatenate([x[1] for x in rays]), timing,
                             depth=self.depth_aware)
            found, at = {}, 0
            for r in todo:
                h, w = r.box[2] - r.box[0], r.box[3] - r.box[1]
                found[id(r)] = hits[at:at + h * w].reshape(h, w)
                at += h * w
            return [found.get(id(r)) for r in refs]

        return regions

    def _score_batches(self, batches, regions_of, counts: np.ndarray, timing: dict) -> None:
        """The one tally loop: the occluder's pixels over each image's box, classify, add up.

        ``batches`` yields lists of :class:`ImageQuads`; ``regions_of(refs)``
        gives the occluder's coverage (or depth) over each one's box.
        """
        step = _batch_images(self.resolution)
        pending: list = []
        for batch in itertools.chain(batches, [None]):
            pending += batch or []
            while pending and (len(pending) >= step or batch is None):
                refs, pending = pending[:step], pending[step:]
                regions = regions_of(refs)
                t0 = time.perf_counter()
                for r, region in zip(refs, regions, strict=True):
                    c = occluder_counts(r, region)
                    counts[r.unit] += (c.nt, c.pf, c.nf, c.q_orig, c.q_occ, c.q_both)
                timing["seconds_quads"] = timing.get("seconds_quads", 0.0) + (
                    time.perf_counter() - t0)

    def score(self, occluder: trimesh.Trimesh | Scene | None) -> PrecisionRecall:
        """Precision and recall of an occluder against the stored views of the original.

        Parameters
        ----------
        occluder : trimesh.Trimesh, Scene or None
            The occluder; None or an empty mesh covers nothing. A
            :class:`~viscore.Scene` already built for it is cast as it is (no
            second Embree scene).

        Returns
        -------
        PrecisionRecall
            As :func:`viscore.metrics.orbit_precision_recall` (orbit) or
            :func:`viscore.metrics.volume_precision_recall` (volume) with these
            settings; ``seconds`` and ``timing`` are this call's (the
            occluder's rays only when the views are cached).

        Raises
        ------
        InputError
            On an occluder that is not a mesh or fails validation.
        """
        start = time.perf_counter()
        other = scene_of(occluder, "occluder")
        units = len(self.weights)
        counts = np.zeros((units, 6), dtype=np.int64)  # nt, pf, nf, q_orig, q_occ, q_both
        timing: dict = {}
        if self.protocol == "orbit":
            self._score_orbit(other, counts, timing)
        else:
            self._score_volume(other, counts, timing)
        return self._result(counts, timing, time.perf_counter() - start)

    def _batched(self, refs: list):
        step = _batch_images(self.resolution)
        for b0 in range(0, len(refs), step):
            yield refs[b0:b0 + step]

    def _score_orbit(self, other, counts, timing) -> None:
        batches = (self._batched(self._refs) if self._refs is not None
                   else self._reference_batches(self._images, timing))
        self._score_batches(batches, self._cast_regions(other, lambda r: True, timing), counts,
                            timing)

    def _score_volume(self, other, counts, timing) -> None:
        sees = self._sees
        sees_occ = np.zeros_like(sees)
        if other is not None:
            sees_occ = frusta_see_box(self.positions, self._axes, *other.bounds)  # type: ignore[arg-type]
            # frusta are skipped when they see neither mesh's box (their joint bounding box)
            lo = np.minimum(self._mesh_box[0], other.bounds[0])
            hi = np.maximum(self._mesh_box[1], other.bounds[1])
            if (lo < self._mesh_box[0]).any() or (hi > self._mesh_box[1]).any():
                sees = frusta_see_box(self.positions, self._axes, lo, hi)  # type: ignore[arg-type]
        # positions that gain frusta have all their quads drawn anew, in frustum order
        affected = (sees & ~self._sees).any(axis=1)
        if self._refs is not None:
            kept = [r for r in self._refs if not affected[r.unit]]
            again = np.argwhere(sees & affected[:, None])
            batches = itertools.chain(self._batched(kept),
                                      self._reference_batches(again, timing))
        else:
            batches = self._reference_batches(np.argwhere(sees), timing)
        regions = self._cast_regions(other, lambda r: sees_occ[r.unit, r.cam], timing)
        self._score_batches(batches, regions, counts, timing)
        timing["frusta"] = int(sees.sum())
        timing["frusta_skipped"] = int(sees.size - sees.sum())

    # ------------------------------------------------------------------ inspection
    @property
    def scene(self) -> Scene:
        """The original's :class:`~viscore.Scene` (its one Embree scene), to cast it again
        elsewhere (the conservativeness check of an assessment) without building another."""
        return self._original  # type: ignore[return-value]

    @property
    def images(self) -> np.ndarray:
        """``(k, 2) int64``: (view, view) per orbit image; (position, frustum 0-5) per volume
        frustum that sees the mesh's bounding box, position-major."""
        return self._images.copy()

    def _ref(self, image: int) -> ImageQuads:
        if not 0 <= image < len(self._images):
            raise InputError(f"image: expected an index in [0, {len(self._images)}), got {image}")
        if self._refs is not None:
            return self._refs[image]
        unit = self._images[image, 0]
        first = int(np.searchsorted(self._images[:, 0], unit))  # the unit's stream starts here
        todo = self._images[first:image + 1]
        return [r for b in self._reference_batches(todo, {}) for r in b][-1]

    def pixel_rays(self, unit: int, cam: int, box: tuple | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions of one image's pixel rays, as :meth:`score` casts them.

        Parameters
        ----------
        unit, cam : int
            Orbit: the view twice. Volume: the position and the frustum (0-5).
        box : (row0, col0, row1, col1), optional
            Only the pixels of this box (exclusive ends); default the whole image.

        Returns
        -------
        origins, directions : (h * w, 3) float64
            World units, row-major over the box (read-only views may be returned).
        """
        return self._rays(int(unit), int(cam), None if box is None else tuple(box))

    def scored_images(self, occluder_bounds: np.ndarray | None) -> tuple[list, np.ndarray]:
        """The original's side of every image that :meth:`score` counts for an occluder.

        Incremental scorers (metric-guided simplification) tally these images
        themselves: with the occluder's coverage over each image's box,
        :func:`viscore.metrics.quads.occluder_counts` summed into
        ``per_view`` rows gives the counts of :meth:`score` bit for bit.

        Parameters
        ----------
        occluder_bounds : (2, 3) float or None
            The occluder's bounding box (world units); None for an empty occluder.

        Returns
        -------
        images : list of ImageQuads
            In scoring order: ``unit`` (row of ``per_view``), ``cam``,
            ``box``, ``quads`` relative to the box (None: the image counts
            nothing), ``n`` and ``a`` (pixels of each quad and those the
            original covers). Volume positions whose frusta see the
            occluder's box but not the original's have all their quads drawn
            anew, as :meth:`score` does.
        sees : (len(images),) bool
            Whether the occluder's box can be seen in the image (where not,
            the occluder covers none of its pixels).

        Raises
        ------
        InputError
            On depth-aware views (their tallies depend on depths, not coverage).
        """
        if self.depth_aware:
            raise InputError("scored_images: depth-aware views are scored by depth, "
                             "not coverage")
        timing: dict = {}
        if self.protocol == "orbit":
            refs = (list(self._refs) if self._refs is not None else
                    [r for b in self._reference_batches(self._images, timing) for r in b])
            return refs, np.full(len(refs), occluder_bounds is not None)
        sees = self._sees
        sees_occ = np.zeros_like(sees)
        if occluder_bounds is not None:
            bounds = np.asarray(occluder_bounds, dtype=np.float64)
            sees_occ = frusta_see_box(self.positions, self._axes, *bounds)  # type: ignore[arg-type]
            lo = np.minimum(self._mesh_box[0], bounds[0])
            hi = np.maximum(self._mesh_box[1], bounds[1])
            if (lo < self._mesh_box[0]).any() or (hi > self._mesh_box[1]).any():
                sees = frusta_see_box(self.positions, self._axes, lo, hi)  # type: ignore[arg-type]
        affected = (sees & ~self._sees).any(axis=1)
        if self._refs is not None:
            refs = [r for r in self._refs if not affected[r.unit]]
            again = np.argwhere(sees & affected[:, None])
            refs += [r for b in self._reference_batches(again, timing) for r in b]
        else:
            refs = [r for b in self._reference_batches(np.argwhere(sees), timing) for r in b]
        return refs, np.array([bool(sees_occ[r.unit, r.cam]) for r in refs], dtype=bool)

    def quads(self, image: int) -> np.ndarray:
        """``(Q, 4) int64`` quads of one image: row0, col0, row1, col1 in pixels (exclusive
        ends); ``(0, 4)`` for an image that counts nothing (the original misses it)."""
        r = self._ref(image)
        if r.quads is None:
            return np.zeros((0, 4), dtype=np.int64)
        return r.quads.astype(np.int64) + np.array([r.box[0], r.box[1], r.box[0], r.box[1]])

    def quad_depths(self, image: int) -> np.ndarray | None:
        """``(Q,) float64`` depth of each quad of one image (depth-aware), else None.

        Depths take ``depth_levels`` values spanning the original's depths in
        that image, world units along the pixel rays.
        """
        r = self._ref(image)
        return None if r.levels is None else r.levels[r.level.astype(np.int64)]  # type: ignore[union-attr]

    def depth_images(self, mesh: trimesh.Trimesh | None = None) -> np.ndarray:
        """``(k, R, R) float32`` depth images, one per image of :attr:`images`.

        Of the original by default (cast on the first call and kept, not
        pickled), or of another ``mesh`` seen by the same cameras (not kept).
        World units along the pixel rays, ``inf`` where the ray misses.
        Refused with an :class:`InputError` when they would not fit in memory.
        """
        if mesh is None and self._depth_images is not None:
            return self._depth_images
        scene = self._original if mesh is None else scene_of(mesh, "occluder")
        res = self.resolution
        check_memory(len(self._images) * float(res) ** 2 * 4
                     + _batch_images(res) * res**2 * _BYTES_PER_RAY,
                     f"depth images of {len(self._images)} images at resolution={res}")
        out = np.full((len(self._images), res, res), np.inf, dtype=np.float32)
        step = _batch_images(res)
        for b0 in range(0, len(self._images) if scene is not None else 0, step):
            batch = self._images[b0:b0 + step]
            rays = [self._rays(int(u), int(c)) for u, c in batch]
            out[b0:b0 + len(batch)] = cast_depths(
                scene, np.concatenate([r[0] for r in rays]),
                np.concatenate([r[1] for r in rays]), len(batch), res, {})
        if mesh is None:
            self._depth_images = out  # type: ignore[assignment]
        return out

    def _score_images(self, occluder_depths: np.ndarray, *, quads: int, rng_of
                      ) -> PrecisionRecall:
        """Score fixed occluder images with quads drawn anew (``rng_of(unit)``) over the
        original's kept depth images: the quads ablation, through the one tally loop."""
        start = time.perf_counter()
        counts = np.zeros((len(self.weights), 6), dtype=np.int64)
        timing: dict = {}
        batches = self._reference_batches(self._images, timing, depths=self.depth_images(),
                                          quads=quads, rng_of=rng_of)
        index = {(int(u), int(c)): k for k, (u, c) in enumerate(self._images)}

        def regions(refs: list) -> list:
            out = []
            for r in refs:
                d = occluder_depths[index[r.unit, r.cam], r.box[0]:r.box[2], r.box[1]:r.box[3]]
                out.append(d if self.depth_aware else np.isfinite(d))
            return out

        self._score_batches(batches, regions, counts, timing)
        return self._result(counts, timing, time.perf_counter() - start)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_depth_images"] = None
        return state

    # ------------------------------------------------------------------ result
    def _result(self, counts: np.ndarray, timing: dict, seconds: float) -> PrecisionRecall:
        nt, pf, nf = counts[:, 0], counts[:, 1], counts[:, 2]
        per_view = {"nt": nt, "pf": pf, "nf": nf,
                    "precision": ratio(nt, nt + nf), "recall": ratio(nt, nt + pf),
                    "weight": self.weights}
        if self.protocol == "orbit":
            per_view["direction"] = self.directions
        else:
            per_view["position"] = self.positions  # type: ignore[assignment]
        per_view |= {"quads_orig": counts[:, 3], "quads_occ": counts[:, 4],
                     "quads_both": counts[:, 5]}
        pooled = {k: pooled_parts(per_view, self.protocol, k) for k in ("precision", "recall")}
        boot = stream_seed(self.seed, "bootstrap")  # independent of the views' own draws
        return PrecisionRecall(
            precision=pooled_ratio(per_view, self.protocol, "precision"),
            recall=pooled_ratio(per_view, self.protocol, "recall"),
            precision_ci=list(bootstrap_ratio(*pooled["precision"], seed=boot)),
            recall_ci=list(bootstrap_ratio(*pooled["recall"], seed=boot)),
            per_view=per_view, protocol=self.protocol, depth_aware=self.depth_aware,
            seed=self.seed, params=dict(self.settings), seconds=seconds, timing=timing)


def check_protocol(protocol: object, name: str = "protocol") -> str:
    """The protocol name, or :class:`InputError` listing the valid ones."""
    if not isinstance(protocol, str) or protocol not in PROTOCOLS:
        raise InputError(f"{name}: expected one of {', '.join(map(repr, PROTOCOLS))}, "
                         f"got {protocol!r}")
    return protocol


def score_once(views: ReferenceViews, occluder) -> PrecisionRecall:
    """``views.score(occluder)`` with ``seconds`` and ``timing`` covering the construction."""
    r = views.score(occluder)
    timing = dict(r.timing)
    for k, v in views.timing.items():
        timing[k] = timing.get(k, 0) + v
    timing["seconds_reference"] = views.seconds
    return replace(r, seconds=views.seconds + r.seconds, timing=timing)
