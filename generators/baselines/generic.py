"""Baselines every study includes: quadric decimation, the bounding box, the original.

References
----------
.. [1] Garland, M., Heckbert, P. S. "Surface Simplification Using Quadric Error
   Metrics". Proceedings of SIGGRAPH '97, ACM, 1997, pp. 209-216.
   :DOI:`10.1145/258734.258849`
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification Using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271`
.. [3] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import logging
import time

import numpy as np
import trimesh

from viscore import InputError, validate_mesh
from viscore._validate import as_positive_int

from .._decimate import quadric_edge_collapse
from ..occluder import Occluder

_log = logging.getLogger(__name__)

__all__ = ["generate_qem", "generate_bbox", "generate_original"]

#: Default triangle budget of the baselines when none is given.
DEFAULT_BUDGET = 256


#: A decimation pass has collapsed the mesh when its bounding-box diagonal is under this
#: share of the input's.
COLLAPSED_DIAGONAL = 0.5


def _diagonal(vertices) -> float:
    v = np.asarray(vertices, dtype=np.float64)
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) if len(v) else 0.0


def _collapsed(current, mesh: trimesh.Trimesh) -> bool:
    return _diagonal(current.vertex_matrix()) < COLLAPSED_DIAGONAL * _diagonal(mesh.vertices)


def _meshset(mesh: trimesh.Trimesh):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=np.asarray(mesh.vertices, dtype=np.float64),
                               face_matrix=np.asarray(mesh.faces, dtype=np.int32)))
    return ms


def generate_qem(mesh: trimesh.Trimesh, *, budget: int = DEFAULT_BUDGET, seed: int = 0
                 ) -> Occluder:
    """Quadric edge-collapse decimation to at most ``budget`` triangles (pymeshlab).

    Parameters
    ----------
    mesh : trimesh.Trimesh
    budget : int, optional
        Target triangle count, default 256. Boundaries are preserved when
        the budget allows and collapsed in a second pass when it does not.
        The result may end under the budget, and on meshes pymeshlab cannot
        collapse further, over it (``info["over_budget"]``).
    seed : int, optional
        Unused (deterministic); accepted for the common signature.

    Returns
    -------
    Occluder
        Double-sided (decimation can open the surface).

    Examples
    --------
    >>> occ = generate_qem(trimesh.creation.icosphere(subdivisions=3), budget=100)
    >>> occ.triangles <= 100
    True
    """
    budget = as_positive_int(budget, "budget")
    start = time.perf_counter()
    ms = _meshset(mesh)
    if len(mesh.faces) > budget:
        ms.meshing_remove_duplicate_vertices()
        # keep open boundaries where the budget allows; open sheets (terrain, walls)
        # cannot reach small budgets that way, so a second pass may collapse them
        for preserve in (True, False):
            quadric_edge_collapse(ms, targetfacenum=budget, preserveboundary=preserve,
                                  preservenormal=True, optimalplacement=True,
                                  planarquadric=True, autoclean=True)
            if ms.current_mesh().face_number() <= budget:
                break
            if preserve and _collapsed(ms.current_mesh(), mesh):
                # the preserving pass can shrink an open scan to a sliver that misses the
                # budget (the open bunny at 56k to 32 triangles: 42 faces over 7% of its
                # box); the second pass then starts again from the input
                _log.info("qem: the boundary-preserving pass collapsed the mesh to %d faces "
                          "over %.0f%% of its diagonal; decimating the input again without it",
                          ms.current_mesh().face_number(),
                          100 * _diagonal(ms.current_mesh().vertex_matrix()) / _diagonal(
                              mesh.vertices))
                ms = _meshset(mesh)
                ms.meshing_remove_duplicate_vertices()
    m = ms.current_mesh()
    out = trimesh.Trimesh(m.vertex_matrix(), m.face_matrix(), process=False)
    if len(out.faces) == 0:
        raise InputError("mesh: decimation removed every triangle")
    out = validate_mesh(out, name="qem")
    return Occluder(mesh=out, method="qem", params={"budget": budget}, double_sided=True,
                    seconds=time.perf_counter() - start,
                    info={"over_budget": len(out.faces) > budget})


def generate_bbox(mesh: trimesh.Trimesh, *, budget: int | None = None, seed: int = 0
                  ) -> Occluder:
    """The axis-aligned bounding box of the mesh as a closed 12-triangle box.

    ``budget`` is ignored (always 12 triangles) and ``seed`` unused; both are
    accepted for the common signature. ``parts["boxes"]`` is the box, (1, 2, 3).

    Examples
    --------
    >>> generate_bbox(trimesh.creation.icosphere()).triangles
    12
    """
    start = time.perf_counter()
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    box = trimesh.creation.box(bounds=np.stack([lo, hi]))
    return Occluder(mesh=box, method="bbox", params={}, double_sided=False,
                    seconds=time.perf_counter() - start, parts={"boxes": np.stack([lo, hi])[None]})


def generate_original(mesh: trimesh.Trimesh, *, budget: int | None = None, seed: int = 0
                      ) -> Occluder:
    """The mesh itself (a check on the metrics: P = R = 1).

    ``budget`` is ignored and ``seed`` unused; both are accepted for the
    common signature. Conservative on any input, open or not: every ray
    meets the occluder first where it meets the mesh first, so
    ``info["conservative_guaranteed"]`` is True (the upper reference of a
    guaranteed culling runtime: the depth buffer of the level's own
    triangles).

    Examples
    --------
    >>> generate_original(trimesh.creation.box()).triangles
    12
    """
    return Occluder(mesh=mesh.copy(), method="original", params={}, double_sided=True,
                    seconds=0.0, info={"conservative_guaranteed": True})
