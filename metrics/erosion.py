"""Erosion-based occlusion measure of an object (Silvennoinen et al. 2014, sec. 3; seeds/000).

The directional measure is M(d) = integral over r of A(I_{d,r}), the area of
the projection eroded by a disk of radius r, which equals the integral of the
Euclidean distance transform over the projection (eq. 3). The projection is
an orthographic coverage image by ray casting; the EDT is scipy's, in world
units (pixel size as sampling), with the image padded so that its border is
background. The total measure M (eq. 2) is estimated as 4 pi times the mean
of M(d) over N uniform random directions, with its standard error.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import ndimage

from viscore import OrthoCamera, coverage_image, directions_uniform
from viscore._validate import as_positive_int

from ._views import scene_of
from .orbit import orbit_frame

__all__ = ["OcclusionMeasure", "directional_occlusion_measure", "occlusion_measure",
           "erosion_curve"]


def _erosion_radius(covered: np.ndarray, pixel: float) -> np.ndarray:
    """Radius (world units) at which erosion removes each pixel; 0 outside I_d.

    The EDT between pixel centres less half a pixel (the mean offset of the
    true boundary), clipped at 0; the image is padded so its border is empty.
    """
    d = ndimage.distance_transform_edt(np.pad(covered, 1), sampling=pixel)[1:-1, 1:-1]
    return np.where(covered, np.maximum(d - 0.5 * pixel, 0.0), 0.0)


def directional_occlusion_measure(covered: np.ndarray, pixel: float) -> tuple[float, float]:
    """M(d) and the area A(I_{d,0}) of one coverage image (seed 000, eqs. 1 and 3).

    Parameters
    ----------
    covered : (R, R) bool
        Orthographic projection I_d.
    pixel : float
        Pixel side, world units.

    Returns
    -------
    measure : float
        Sum over covered pixels of the EDT times the pixel area (world units^3).
    area : float
        Covered area, world units^2.

    Notes
    -----
    The EDT of a pixel is the distance between pixel centres, which
    over-estimates the distance to the true boundary by half a pixel on
    average; :func:`occlusion_measure` subtracts that half pixel, which makes
    the discrete sum converge to the integral at first order.

    Examples
    --------
    >>> img = np.zeros((64, 64), bool); img[16:48, 16:48] = True
    >>> m, a = directional_occlusion_measure(img, 1 / 32)   # unit square
    >>> round(m, 3), a
    (0.167, 1.0)
    """
    d = _erosion_radius(covered, pixel)
    return float(d.sum() * pixel**2), float(covered.sum() * pixel**2)


def erosion_curve(covered: np.ndarray, pixel: float, radii: np.ndarray) -> np.ndarray:
    """Area A(I_{d,r}) of the eroded projection for each radius (seed 000, sec. 3.1).

    Returns
    -------
    area : (len(radii),) float64
        World units^2; non-increasing in r, and its integral over r is M(d).
    """
    values = np.sort(_erosion_radius(covered, pixel)[covered])
    radii = np.asarray(radii, dtype=np.float64)
    above = len(values) - np.searchsorted(values, radii, side="right")
    return above * pixel**2


@dataclass(frozen=True)
class OcclusionMeasure:
    """Total occlusion measure of a mesh with its Monte-Carlo error.

    Attributes
    ----------
    occlusion_measure : float
        M = 4 pi mean M(d), world units^3 x steradian.
    occlusion_measure_se : float
        Its standard error (4 pi x s.d. of M(d) / sqrt(N)).
    surface_area_measure : float
        4 pi mean A(I_{d,0}): the plain projected-area measure, world units^2 x sr.
    per_view : dict
        ``measure`` and ``area`` (per direction) and ``direction``.
    seed : int
    params : dict
    seconds : float
    """

    occlusion_measure: float
    occlusion_measure_se: float
    surface_area_measure: float
    per_view: dict
    seed: int
    params: dict
    seconds: float


def occlusion_measure(mesh: trimesh.Trimesh, *, directions: int = 64, resolution: int = 256,
                      seed: int = 0, frame: tuple[np.ndarray, float] | None = None
                      ) -> OcclusionMeasure:
    """Total occlusion measure M of a mesh over N uniform random directions.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Object O.
    directions : int, optional
        N, default 64.
    resolution : int, optional
        R of each orthographic projection, default 256.
    seed : int, optional
        Seeds the directions. Default 0.
    frame : (center, extent), optional
        Image window; default the orbit frame of ``mesh`` (its enclosing
        sphere x 1.01), which holds every projection.

    Returns
    -------
    OcclusionMeasure

    Examples
    --------
    >>> sphere = trimesh.creation.icosphere(subdivisions=4)
    >>> r = occlusion_measure(sphere, directions=4, resolution=128)
    >>> bool(abs(r.occlusion_measure / (4 * np.pi * np.pi / 3) - 1) < 0.02)
    True
    """
    directions = as_positive_int(directions, "directions")
    resolution = as_positive_int(resolution, "resolution", maximum=8192)
    start = time.perf_counter()
    scene = scene_of(mesh, "mesh")
    center, extent = orbit_frame(mesh) if frame is None else frame
    dirs = directions_uniform(directions, seed=seed)
    measure = np.zeros(directions)
    area = np.zeros(directions)
    for k, d in enumerate(dirs):
        cam = OrthoCamera(d, center, extent, resolution)
        measure[k], area[k] = directional_occlusion_measure(
            coverage_image(scene, cam), cam.pixel_size)
    se = measure.std(ddof=1) / np.sqrt(directions) if directions > 1 else np.nan
    return OcclusionMeasure(
        occlusion_measure=float(4 * np.pi * measure.mean()),
        occlusion_measure_se=float(4 * np.pi * se),
        surface_area_measure=float(4 * np.pi * area.mean()),
        per_view={"measure": measure, "area": area, "direction": dirs},
        seed=seed, params={"directions": directions, "resolution": resolution,
                           "center": np.asarray(center).tolist(), "extent": float(extent)},
        seconds=time.perf_counter() - start)
