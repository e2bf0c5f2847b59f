"""The ``planar-sections --hierarchy`` generator: a hierarchy as an :class:`Occluder`.

:func:`generate_planar_hierarchy` builds the tree
(:func:`viscore.generators.planar_hierarchy.build_hierarchy`) and returns it in
``parts["hierarchy"]`` with the root's occluder as the mesh (Silvennoinen et
al. 2014, sec. 5).
"""

from __future__ import annotations

import time

import numpy as np

from viscore import InputError

from ..occluder import Occluder
from .tree import (
    DEFAULT_MAX_LEAVES,
    DEFAULT_VOXELS,
    INNER_DILATION,
    NODE_OCCLUDERS,
    _walk,
    build_hierarchy,
)

__all__ = ["generate_planar_hierarchy"]


def generate_planar_hierarchy(mesh, *, budget: int | None = 64, seed: int = 0,
                              voxels: int | None = None, leaf_objects: int = 1,
                              max_leaves: int = DEFAULT_MAX_LEAVES,
                              node_occluder: str | None = None, conservative: bool = False,
                              voxel_size: float | None = None, pixel_error: float | None = None,
                              distance: float | None = None, lod_distances=None, dilate: int = 0,
                              fov: float | None = None, screen: int | None = None,
                              jobs: int = 1, **node_options) -> Occluder:
    """Hierarchical planar-section occluder: the generator entry of sec. 5.

    Builds the tree with :func:`build_hierarchy` and returns the root's
    occluder as the mesh, the tree in ``parts["hierarchy"]``. Takes the
    options of :func:`~viscore.generators.planar_sections.generate_planar_sections`
    so that ``planar-sections --hierarchy`` can hand them all over.

    Parameters
    ----------
    mesh : trimesh.Trimesh or sequence of trimesh.Trimesh
        The scene (see :func:`build_hierarchy`).
    budget : int or None, optional
        Triangle budget of every node's occluder, hence of the mesh returned
        (default 64).
    seed : int, optional
        Passed to every node's builder.
    voxels : int, optional
        Voxels along the longest side of each node (default 64).
    leaf_objects, max_leaves, node_occluder : optional
        As :func:`build_hierarchy`; ``node_occluder`` is a name here.
    conservative : bool, optional
        Passed to the builder (planar sections: slices through the eroded
        inside only), and no dilation at inner nodes, which would grow the
        solids past the mesh. Default False.
    voxel_size, pixel_error, distance, lod_distances : None
        Refused: a hierarchy sizes each node's voxels by ``voxels`` over the
        node's extent, and the screen-space error is applied per frame by
        :func:`cut_hierarchy`.
    dilate : int, optional
        Must be 0: the hierarchy applies the paper's dilation itself.
    fov, screen : optional
        Accepted for the common option set and unused: the viewing
        parameters belong to the cut.
    jobs : int, optional
        Processes building the nodes (:func:`build_hierarchy`); default 1.
    **node_options
        Passed to every node's builder (planar sections: ``direction_bins``,
        ``depth_bins``, ``alpha``, ``measure``, ``reduce``).

    Returns
    -------
    Occluder
        ``mesh`` is the root's occluder: the one the runtime cut draws for
        any camera far enough from the scene (every orbit view of a study),
        and within the budget, so studies compare it with single-object
        methods at equal triangle counts; the leaves' union would carry up
        to ``max_leaves`` budgets. ``double_sided`` is True if any node's
        occluder is. ``parts["hierarchy"]`` is the root node; ``info`` holds
        ``nodes``, ``leaves``, ``depth``, ``objects``, ``builder``,
        ``node_triangles`` (sum over nodes), ``leaf_triangles`` (sum over
        leaves), ``root_error`` and ``leaf_error_max`` (world units).

    Raises
    ------
    InputError
        As :func:`build_hierarchy`, and for the refused options above.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> import trimesh
    >>> boxes = [trimesh.creation.box(bounds=[[x, 0, 0], [x + 1, 1, 1]]) for x in (0, 2)]
    >>> occ = generate_planar_hierarchy(boxes, budget=12, voxels=8, node_occluder="qem")
    >>> occ.info["nodes"], occ.info["leaves"], occ.triangles <= 12
    (3, 2, True)
    """
    start = time.perf_counter()
    if node_occluder is not None and node_occluder not in NODE_OCCLUDERS:
        raise InputError(f"node_occluder: expected one of {', '.join(NODE_OCCLUDERS)}, "
                         f"got {node_occluder!r}")
    for name, value in (("voxel_size", voxel_size), ("pixel_error", pixel_error),
                        ("distance", distance), ("lod_distances", lod_distances)):
        if value is not None:
            raise InputError(f"{name}: not with a hierarchy, which sizes each node's voxels "
                             "by voxels over the node's extent; the screen-space error is "
                             "the runtime cut's")
    if dilate != 0:
        raise InputError(f"dilate: not with a hierarchy, which dilates its inner nodes "
                         f"itself (sec. 5), got {dilate!r}")
    if not isinstance(conservative, (bool, np.bool_)):
        raise InputError(f"conservative: expected True or False, got {conservative!r}")
    if conservative:
        node_options["conservative"] = True
    voxels = DEFAULT_VOXELS if voxels is None else voxels
    root = build_hierarchy(mesh, node_occluder=node_occluder, budget=budget, voxels=voxels,
                           leaf_objects=leaf_objects, max_leaves=max_leaves,
                           inner_dilation=0 if conservative else INNER_DILATION, seed=seed,
                           jobs=jobs, **node_options)
    nodes = _walk(root)
    leaves = [n for n in nodes if not n["children"]]
    params = {"budget": budget, "seed": seed, "voxels": voxels, "hierarchy": True,
              "leaf_objects": leaf_objects, "max_leaves": max_leaves,
              "node_occluder": root["builder"], "conservative": bool(conservative),
              "fov": fov, "screen": screen, **node_options}
    return Occluder(
        mesh=root["occluder"], method="planar-sections", params=params,
        double_sided=any(n["double_sided"] for n in nodes),
        seconds=time.perf_counter() - start, parts={"hierarchy": root},
        info={"nodes": len(nodes), "leaves": len(leaves),
              "depth": max(_depths(root)), "objects": len(root["objects"]),
              "builder": root["builder"],
              "node_triangles": sum(n["triangles"] for n in nodes),
              "leaf_triangles": sum(n["triangles"] for n in leaves),
              "root_error": float(root["error"]),
              "leaf_error_max": float(max(n["error"] for n in leaves))})


def _depths(root: dict) -> list[int]:
    out, stack = [], [(root, 0)]
    while stack:
        n, d = stack.pop()
        out.append(d)
        stack.extend((c, d + 1) for c in n["children"])
    return out
