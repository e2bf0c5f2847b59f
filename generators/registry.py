"""The generator registry: the one mapping from CLI names to generator functions.

Each generator is ``generate(mesh, *, budget=..., seed=..., **params) -> Occluder``.
Methods that land later (planar sections, hybrid, solid frusta) add one entry
here and join every study without other changes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from viscore import InputError

from .aabb_skins import generate_aabb_skins
from .baselines import generate_bbox, generate_original, generate_qem
from .occluder import Occluder

__all__ = ["GeneratorSpec", "REGISTRY", "get_generator", "generate"]


@dataclass(frozen=True)
class GeneratorSpec:
    """A registered generator.

    Attributes
    ----------
    name : str
        CLI name.
    function : callable
        ``(mesh, *, budget, seed, **params) -> Occluder``.
    description : str
        One line for ``--help`` and reports.
    conservative : bool
        Whether the method guarantees conservativeness on closed meshes.
    experimental : bool
        Not yet validated; the CLI warns on stderr.
    baseline : bool
        One of the baselines every study includes.
    budgeted : bool
        Whether the triangle budget changes the result (studies run such a
        method once per budget, the others once).
    """

    name: str
    function: Callable[..., Occluder]
    description: str
    conservative: bool = False
    experimental: bool = False
    baseline: bool = False
    budgeted: bool = True


REGISTRY: dict[str, GeneratorSpec] = {
    spec.name: spec for spec in [
        GeneratorSpec("aabb-skins", generate_aabb_skins,
                      "greedy maximal boxes inside the voxelized mesh (seeds 002, 003)",
                      conservative=True),
        GeneratorSpec("qem", generate_qem, "quadric edge-collapse decimation to the budget",
                      baseline=True),
        GeneratorSpec("bbox", generate_bbox, "the bounding box (non-conservative extreme)",
                      baseline=True, budgeted=False),
        GeneratorSpec("original", generate_original, "the mesh itself (P = R = 1 check)",
                      baseline=True, budgeted=False),
    ]
}


def get_generator(name: str) -> GeneratorSpec:
    """The registered generator called ``name``, or :class:`InputError` listing them."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise InputError(f"method: unknown generator {name!r} "
                         f"(registered: {', '.join(REGISTRY)})") from None


def generate(name: str, mesh, **params) -> Occluder:
    """Run the generator registered as ``name`` on ``mesh`` with ``params``.

    Examples
    --------
    >>> import trimesh
    >>> generate("bbox", trimesh.creation.icosphere()).triangles
    12
    """
    return get_generator(name).function(mesh, **params)
