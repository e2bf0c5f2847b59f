"""The runtime tree cut of an occluder hierarchy (Silvennoinen et al. 2014, sec. 5).

For a camera, :func:`cut_hierarchy` picks the nodes whose error is below a
pixel threshold on screen, over the arrays of :func:`index_hierarchy`. The
tree comes from :func:`viscore.generators.planar_hierarchy.build_hierarchy`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from viscore import InputError
from viscore._validate import as_positive, as_positive_int, as_vector

__all__ = ["HierarchyIndex", "index_hierarchy", "cut_hierarchy"]


@dataclass(frozen=True, eq=False)
class HierarchyIndex:
    """A hierarchy flattened into arrays for :func:`cut_hierarchy`, built once per tree.

    Attributes
    ----------
    nodes : tuple of dict
        The node dicts in pre-order (root first).
    parent : (n,) int64
        Parent's position in ``nodes``; -1 for the root.
    lower, upper : (n, 3) float64
        Each node's ``bounds``, world units.
    error : (n,) float64
        Each node's ``error``, world units.
    leaf : (n,) bool
    levels : tuple of (k,) int64
        Positions of the nodes at depth 1, 2, ... (parents before children).
    """

    nodes: tuple
    parent: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    error: np.ndarray
    leaf: np.ndarray
    levels: tuple


def index_hierarchy(tree: dict) -> HierarchyIndex:
    """Flatten a hierarchy's nodes into the arrays the runtime cut needs.

    Parameters
    ----------
    tree : dict
        The root node, as :func:`build_hierarchy` or :func:`hierarchy_from_json`
        return it (every node needs ``bounds``, ``error`` and ``children``).

    Returns
    -------
    HierarchyIndex

    Raises
    ------
    InputError
        If a node lacks ``bounds``, ``error`` or ``children``, has bounds
        that are not a finite (2, 3) lower/upper pair, a negative or
        non-finite error, or the tree is deeper than 64 levels.

    Examples
    --------
    >>> leaf = {"bounds": np.array([[0.0, 0, 0], [1, 1, 1]]), "error": 0.1, "children": []}
    >>> idx = index_hierarchy({"bounds": np.array([[0.0, 0, 0], [2, 1, 1]]), "error": 0.2,
    ...                        "children": [leaf]})
    >>> idx.parent.tolist(), idx.leaf.tolist()
    ([-1, 0], [False, True])
    """
    if not isinstance(tree, dict):
        raise InputError(f"tree: expected the root node (a dict), got {type(tree).__name__}")
    nodes: list
    nodes, parent, depth = [], [], []
    stack = [(tree, -1, 0)]
    while stack:
        n, p, d = stack.pop()
        if d > 64:
            raise InputError("tree: deeper than 64 levels (a cycle?)")
        if not isinstance(n, dict) or not {"bounds", "error", "children"} <= set(n):
            raise InputError(f"tree: node {len(nodes)} needs bounds, error and children "
                             "(build it with build_hierarchy)")
        nodes.append(n)
        parent.append(p)
        depth.append(d)
        me = len(nodes) - 1
        stack.extend((c, me, d + 1) for c in reversed(n["children"]))
    try:
        bounds = np.array([np.asarray(n["bounds"], dtype=np.float64) for n in nodes])
        error = np.array([float(n["error"]) for n in nodes])
    except (TypeError, ValueError) as exc:
        raise InputError(f"tree: bounds or error are not numbers ({exc})") from None
    if bounds.shape != (len(nodes), 2, 3) or not np.isfinite(bounds).all() \
            or (bounds[:, 0] > bounds[:, 1]).any():
        raise InputError("tree: every node's bounds must be a finite (2, 3) lower/upper pair")
    if not np.isfinite(error).all() or (error < 0).any():
        raise InputError("tree: every node's error must be finite and >= 0")
    parent = np.array(parent, dtype=np.int64)
    depth = np.array(depth, dtype=np.int64)
    leaf = np.array([not n["children"] for n in nodes])
    levels = tuple(np.flatnonzero(depth == d) for d in range(1, int(depth.max()) + 1))
    return HierarchyIndex(nodes=tuple(nodes), parent=parent, lower=bounds[:, 0].copy(),
                          upper=bounds[:, 1].copy(), error=error, leaf=leaf, levels=levels)


def cut_hierarchy(tree, camera_position, *, fov_degrees: float = 60.0,
                  screen_pixels: int = 1920, pixel_error: float = 1.0) -> list[dict]:
    """The nodes to draw for one camera: the runtime tree cut by projected error.

    Silvennoinen et al. 2014 [1]_, sec. 5: "we use the hierarchy at runtime to
    select a suitable set of occluder nodes based on the camera position and
    viewing parameters". A node is taken when its ``error`` (world units),
    seen at the nearest point of its ``bounds`` to the camera, spans fewer
    than ``pixel_error`` pixels:
    ``error * screen_pixels / (2 * d * tan(fov / 2)) < pixel_error``; else
    its children are visited. Leaves are taken regardless. A camera inside
    a node's bounds (d = 0) always descends.

    Parameters
    ----------
    tree : dict or HierarchyIndex
        The root node (:func:`build_hierarchy`, :func:`hierarchy_from_json`),
        or its :func:`index_hierarchy` (faster per frame: built once).
    camera_position : (3,) float
        World units.
    fov_degrees : float, optional
        Field of view that ``screen_pixels`` spans, degrees in (0, 180)
        (default 60).
    screen_pixels : int, optional
        Pixels across the field of view (default 1920).
    pixel_error : float, optional
        Largest error allowed on screen, pixels, > 0 (default 1).

    Returns
    -------
    list of dict
        The chosen nodes, in pre-order: every leaf has exactly one chosen
        node among itself and its ancestors.

    Raises
    ------
    InputError
        Bad camera or viewing parameters, or a tree :func:`index_hierarchy`
        refuses.

    Notes
    -----
    Vectorised over the nodes: one distance and one test per node, then
    one numpy step per tree level to hide the descendants of taken nodes.
    Per-direction screen extents are not used (the whole field of view is
    assumed on screen); the cut does not cull nodes outside the view.

    References
    ----------
    .. [1] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
       Simplification using Planar Sections". Computer Graphics Forum 33(1),
       2014, pp. 235-245. :DOI:`10.1111/cgf.12271`

    Examples
    --------
    >>> leaf = lambda x: {"bounds": np.array([[x, 0, 0], [x + 1, 1, 1.0]]), "error": 0.01,
    ...                   "children": []}
    >>> root = {"bounds": np.array([[0, 0, 0], [3, 1, 1.0]]), "error": 0.1,
    ...         "children": [leaf(0.0), leaf(2.0)]}
    >>> len(cut_hierarchy(root, (1e6, 0, 0))), len(cut_hierarchy(root, (1.5, 0.5, 0.5)))
    (1, 2)
    """
    index = tree if isinstance(tree, HierarchyIndex) else index_hierarchy(tree)
    cam = as_vector(camera_position, "camera_position")
    fov = as_positive(fov_degrees, "fov_degrees")
    if fov >= 180:
        raise InputError(f"fov_degrees: expected a number in (0, 180), got {fov_degrees!r}")
    pixels = as_positive_int(screen_pixels, "screen_pixels")
    threshold = as_positive(pixel_error, "pixel_error")
    gap = np.maximum(np.maximum(index.lower - cam, cam - index.upper), 0.0)
    distance = np.sqrt(np.einsum("ij,ij->i", gap, gap))
    scale = pixels / (2.0 * math.tan(math.radians(fov) / 2.0))
    # error * scale / distance < threshold, without dividing (distance 0: never taken)
    take = (index.error * scale < threshold * distance) | index.leaf
    hidden = np.zeros(len(take), dtype=bool)
    for level in index.levels:
        up = index.parent[level]
        hidden[level] = hidden[up] | take[up]
    nodes = index.nodes
    return [nodes[i] for i in np.flatnonzero(take & ~hidden).tolist()]


# --------------------------------------------------------------------------- files
