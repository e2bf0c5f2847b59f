"""Tolerances shared across viscore, metrics and generators.

Each value states its unit and why it has that value.
"""

#: Relative ray offset past a hit when collecting all hits along a ray, as a
#: fraction of the scene's bounding-box diagonal. Embree works in float32
#: (about 7 significant digits); 1e-6 of the diagonal is a few ulps of the
#: largest coordinate after the scene is centred, enough to step past the hit
#: triangle without skipping a distinct surface further than that.
RAY_STEP_RELATIVE = 1e-6

#: Maximum number of hits collected along one ray by ``Scene.all_hits``. The
#: loop that steps past each hit is bounded by it so that it always ends.
MAX_HITS = 256

#: Relative tolerance of the conservativeness check (fraction of the
#: bounding-box diagonal): an occluder hit counts as a violation only when it
#: is nearer than the original's hit by more than this. Covers float32
#: rounding of coincident surfaces (an occluder equal to the mesh).
CONSERVATIVE_EPS_RELATIVE = 1e-5

#: Triangles whose area is below this fraction of the squared bounding-box
#: diagonal are degenerate and dropped at load time (their normals are
#: undefined and they block no ray).
DEGENERATE_AREA_RELATIVE = 1e-14

#: Fewest rays per Embree call (a chunk): batches are cut into equal chunks of
#: at least this many rays (at most ``scene._MAX_RAYS_PER_CHUNK``), so that one
#: chunk's float32 copies stay in cache and the fixed cost of each numpy call
#: and Embree call is spread; a batch no larger than this runs on the calling thread.
#: The last chunks of a large batch on several threads shrink to half of it
#: (``Scene._chunk_bounds``), so that the threads finish together.
MIN_RAYS_PER_TASK = 16384

#: Voxel grids above this many cells are refused outright (about 6 GiB of
#: working memory at the ~24 bytes per cell of
#: :data:`viscore.voxel.grid.VOXELIZE_BYTES_PER_CELL`); smaller grids are still
#: checked against the available memory before any work.
MAX_VOXEL_CELLS = 256_000_000

#: The conservative depth buffer (:mod:`viscore.culling.depth_buffer`) has 1/2 of the
#: screen's pixels per side by default (1280 x 720 -> 640 x 360): a quarter of the
#: screen's pixels, the "quarter size of the screen" of the occluder-skins paper,
#: sec. 7, read as a quarter-VGA screen is a quarter of VGA. Until December 2026 the
#: default was 4, a quarter per side: on 37 game levels the half-size buffer culls as
#: much or more everywhere, 0.75 of what the truth hides against 0.73 on average over
#: 27 of them, at about twice the buffer's time a frame.
DEFAULT_REDUCTION = 2
