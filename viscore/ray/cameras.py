"""Cameras as ray bundles: orthographic, perspective and the cube of six frusta.

The orthographic camera of the orbit protocol (Silvennoinen et al. 2014 [1]_,
sec. 6.1) and the six 90-degree frusta of the volume protocol (Wu et al. 2022 [2]_,
sec. 3.2).

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

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from .._validate import InputError, as_positive, as_positive_int, as_vector, check_memory

__all__ = ["OrthoCamera", "PerspectiveCamera", "cube_cameras", "camera_basis",
           "horizontal_basis"]

#: Axes and up vectors of the six cube frusta (+X, -X, +Y, -Y, +Z, -Z).
_CUBE_AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
                      dtype=np.float64)
#: Peak bytes per pixel of ``rays()``: two (R*R,) pixel coordinates, the (R*R, 3)
#: temporaries of the plane points, and the origins and directions returned.
_BYTES_PER_PIXEL = 160

_CUBE_UPS = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 1, 0], [0, 1, 0]],
                     dtype=np.float64)


def horizontal_basis(up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane perpendicular to the unit vector ``up``
    (right-handed with it): a level's map seen from above."""
    axis = np.zeros(3)
    axis[int(np.argmin(np.abs(up)))] = 1.0
    e1 = np.cross(up, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e1, up)
    return e1, e2


def camera_basis(forward: npt.ArrayLike, up: npt.ArrayLike | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal (forward, right, up) frame for a viewing direction.

    Parameters
    ----------
    forward : (3,) float
        Viewing direction (normalised here).
    up : (3,) float, optional
        Approximate up vector. Default: +Z, or +Y when ``forward`` is within
        about 8 degrees of the Z axis.

    Returns
    -------
    forward, right, up : (3,) float64
        Unit vectors with ``right = forward x up`` (right-handed image plane).

    Raises
    ------
    InputError
        If ``forward`` is zero or ``up`` is parallel to it.
    """
    f = as_vector(forward, "forward")
    norm = np.linalg.norm(f)
    if norm == 0:
        raise InputError("forward: zero-length direction")
    f = f / norm
    if up is None:
        u = np.array([0.0, 0.0, 1.0]) if abs(f[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    else:
        u = as_vector(up, "up")
    r = np.cross(f, u)
    rn = np.linalg.norm(r)
    if rn < 1e-9 * max(1.0, np.linalg.norm(u)):  # type: ignore[operator]
        raise InputError("up: parallel to the viewing direction")
    r = r / rn
    return f, r, np.cross(r, f)


def _pixel_grid(resolution: int, height: int | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """(H*W,) horizontal and vertical pixel-centre coordinates in [-0.5, 0.5].

    W = ``resolution`` columns, H = ``height`` rows (default: square). Each
    coordinate is a fraction of its own side. Checks first that the rays of the
    image fit in memory.
    """
    rows = resolution if height is None else height
    check_memory(resolution * rows * _BYTES_PER_PIXEL,
                 f"resolution={resolution}" if height is None
                 else f"resolution={resolution}, height={height}")
    c = (np.arange(resolution) + 0.5) / resolution - 0.5
    if height is None:
        x = np.tile(c, resolution)
        y = np.repeat(-c, resolution)  # row 0 at the top
        return x, y
    cy = (np.arange(rows) + 0.5) / rows - 0.5
    return np.tile(c, rows), np.repeat(-cy, resolution)


@dataclass(frozen=True, eq=False)
class OrthoCamera:
    """Orthographic camera: parallel rays along ``direction`` through a square window.

    Parameters
    ----------
    direction : (3,) float
        Viewing direction (normalised).
    center : (3,) float
        Centre of the image plane, world units.
    extent : float
        Side of the square window, world units.
    resolution : int
        R: the image is R x R pixels, one ray per pixel centre.
    up : (3,) float, optional
        Approximate up vector (see :func:`camera_basis`).
    start : float, optional
        Rays start this far behind the image plane (world units); depths are
        measured from there. Default: ``extent``, so that everything within a
        sphere of diameter ``extent`` about ``center`` lies in front.

    Examples
    --------
    >>> cam = OrthoCamera((0, 0, 1), (0, 0, 0), 2.0, 4)
    >>> cam.rays()[0].shape
    (16, 3)
    """

    direction: npt.ArrayLike
    center: npt.ArrayLike
    extent: float
    resolution: int
    up: npt.ArrayLike | None = None
    start: float | None = None
    basis: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", as_vector(self.center, "center"))
        object.__setattr__(self, "extent", as_positive(self.extent, "extent"))
        object.__setattr__(self, "resolution", as_positive_int(self.resolution, "resolution",
                                                               maximum=16384))
        f, r, u = camera_basis(self.direction, self.up)
        object.__setattr__(self, "direction", f)
        object.__setattr__(self, "basis", (f, r, u))
        start = self.extent if self.start is None else as_positive(self.start, "start")
        object.__setattr__(self, "start", start)

    @property
    def pixel_size(self) -> float:
        """Side of one pixel, world units."""
        return self.extent / self.resolution

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape (rows, columns) = (R, R)."""
        return (self.resolution, self.resolution)

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins and directions, each ``(R*R, 3) float64``, one per pixel centre."""
        f, r, u = self.basis
        x, y = _pixel_grid(self.resolution)
        plane = self.center + self.extent * (x[:, None] * r + y[:, None] * u)
        origins = plane - self.start * f
        return origins, np.broadcast_to(f, origins.shape).copy()

    def project(self, points: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Continuous pixel coordinates (column, row) and depth of world points.

        Returns
        -------
        pixel : (n, 2) float64
            Column and row, in pixels; pixel (i, j) spans [j, j+1) x [i, i+1).
        depth : (n,) float64
            Distance along ``direction`` from the ray start plane.
        """
        f, r, u = self.basis
        p = np.asarray(points, dtype=np.float64) - self.center  # type: ignore[operator]
        col = (p @ r / self.extent + 0.5) * self.resolution
        row = (0.5 - p @ u / self.extent) * self.resolution
        return np.stack([col, row], axis=1), p @ f + self.start


@dataclass(frozen=True, eq=False)
class PerspectiveCamera:
    """Pinhole camera with a symmetric field of view; square unless ``height`` is given.

    Parameters
    ----------
    position : (3,) float
        Eye point, world units; every ray starts here.
    forward : (3,) float
        Viewing direction.
    up : (3,) float, optional
        Approximate up vector (see :func:`camera_basis`).
    fov : float, optional
        Full *horizontal* field of view in degrees (across the ``resolution``
        columns), in (0, 180). Default 90 (a cube face). For a square image it
        is also the vertical one.
    resolution : int, optional
        W, the number of columns (pixels across), default 256.
    height : int, optional
        H, the number of rows. Default None: H = W (square image). Pixels are
        square, so the vertical field of view is
        ``2 atan(tan(fov / 2) * H / W)`` (see :attr:`vertical_fov`). A height
        equal to ``resolution`` is stored as None.

    Notes
    -----
    Depth along a ray is the Euclidean distance from the eye, not the
    planar z of a rasterizer. The image has ``shape == (H, W)`` (rows,
    columns); ``rays()`` returns H*W rays, row-major. A square camera
    (``height`` None or equal to ``resolution``) computes exactly what it did
    before ``height`` existed.

    Examples
    --------
    >>> cam = PerspectiveCamera((0, 0, 0), (1, 0, 0), fov=90, resolution=16, height=9)
    >>> cam.shape, cam.rays()[1].shape
    ((9, 16), (144, 3))
    >>> round(cam.vertical_fov, 3)
    58.716
    """

    position: npt.ArrayLike
    forward: npt.ArrayLike
    up: npt.ArrayLike | None = None
    fov: float = 90.0
    resolution: int = 256
    height: int | None = None
    basis: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", as_vector(self.position, "position"))
        fov = as_positive(self.fov, "fov")
        if fov >= 180:
            raise InputError(f"fov: expected degrees in (0, 180), got {fov}")
        object.__setattr__(self, "fov", fov)
        object.__setattr__(self, "resolution", as_positive_int(self.resolution, "resolution",
                                                               maximum=16384))
        if self.height is not None:
            height = as_positive_int(self.height, "height", maximum=16384)
            object.__setattr__(self, "height", None if height == self.resolution else height)
        f, r, u = camera_basis(self.forward, self.up)
        object.__setattr__(self, "forward", f)
        object.__setattr__(self, "basis", (f, r, u))

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape (rows, columns) = (H, W)."""
        rows = self.resolution if self.height is None else self.height
        return (rows, self.resolution)

    @property
    def _half(self) -> float:
        """tan(horizontal half field of view)."""
        return float(np.tan(np.radians(self.fov) / 2))

    @property
    def _half_vertical(self) -> float:
        """tan(vertical half field of view)."""
        if self.height is None:
            return self._half
        return self._half * self.height / self.resolution

    @property
    def vertical_fov(self) -> float:
        """Full vertical field of view, degrees."""
        if self.height is None:
            return self.fov
        return float(np.degrees(2 * np.arctan(self._half_vertical)))

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions, each ``(H*W, 3) float64``."""
        f, r, u = self.basis
        x, y = _pixel_grid(self.resolution, self.height)
        if self.height is None:
            s = 2 * self._half
            d = f + s * (x[:, None] * r + y[:, None] * u)
        else:
            d = f + (2 * self._half * x)[:, None] * r + (2 * self._half_vertical * y)[:, None] * u
        d /= np.linalg.norm(d, axis=1)[:, None]
        return np.broadcast_to(self.position, d.shape).copy(), d

    def project(self, points: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (column, row) and eye distance of world points.

        Column in [0, W] and row in [0, H] inside the image; pixel (i, j)
        spans [j, j+1) x [i, i+1). Points behind the eye (or in its plane) get
        NaN pixel coordinates.
        """
        f, r, u = self.basis
        p = np.asarray(points, dtype=np.float64) - self.position  # type: ignore[operator]
        z = p @ f
        rows, cols = self.shape
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 0, (p @ r) / z, np.nan) / (2 * self._half)
            y = np.where(z > 0, (p @ u) / z, np.nan) / (2 * self._half_vertical)
        pixel = np.stack([(x + 0.5) * cols, (0.5 - y) * rows], axis=1)
        return pixel, np.linalg.norm(p, axis=1)

    def contains(self, directions: npt.ArrayLike) -> np.ndarray:
        """Whether each direction from the eye lies inside the frustum (edges included).

        Returns
        -------
        inside : (n,) bool
        """
        pixel, _ = self.project(self.position + np.asarray(directions, dtype=np.float64))  # type: ignore[operator]
        rows, cols = self.shape
        with np.errstate(invalid="ignore"):
            return ((pixel[:, 0] >= 0) & (pixel[:, 0] <= cols)
                    & (pixel[:, 1] >= 0) & (pixel[:, 1] <= rows))


def cube_cameras(position: npt.ArrayLike, resolution: int = 256) -> list[PerspectiveCamera]:
    """The six 90-degree frusta along +X, -X, +Y, -Y, +Z, -Z from one point.

    Together they see every direction exactly once (directions on the shared
    frustum edges belong to two or three faces). Volume protocol of Wu et
    al. 2022, sec. 3.2 [1]_.

    References
    ----------
    .. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
       Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
       :DOI:`10.1111/cgf.14669`

    Examples
    --------
    >>> [c.forward.tolist() for c in cube_cameras((0, 0, 0), 4)][:2]
    [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]
    """
    return [PerspectiveCamera(position, a, up=u, fov=90.0, resolution=resolution)
            for a, u in zip(_CUBE_AXES, _CUBE_UPS, strict=True)]
