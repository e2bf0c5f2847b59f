"""Two occluder methods registered under the ``viscore.generators`` entry points.

``hull-box`` is a plain function (its options come from its signature and
docstring); ``fixture-spec`` is a full :class:`viscore.generators.GeneratorSpec`.
"""

from __future__ import annotations

import trimesh

from viscore.generators import GeneratorOption, GeneratorSpec, Occluder


def hull_box(mesh, *, budget=None, seed=0, shrink: float = 0.5):
    """The mesh's bounding box shrunk about its centre.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The input.
    shrink : float, optional
        Side of the box, a fraction of the bounding box's.
    """
    box = trimesh.creation.box(extents=mesh.extents * shrink)
    box.apply_translation(mesh.bounds.mean(axis=0))
    box.metadata["double_sided"] = False
    return box


def _fixture_spec(mesh, *, budget=None, seed=0, boxes=1):
    box = trimesh.creation.box(bounds=mesh.bounds)
    return Occluder(box, "fixture-spec", {"budget": budget, "seed": seed, "boxes": boxes},
                    double_sided=False, seconds=0.0)


FIXTURE_SPEC = GeneratorSpec(
    "fixture-spec", _fixture_spec, "the bounding box, declared by a GeneratorSpec",
    options=(GeneratorOption("boxes", int, 1, "boxes to make", low=1, high=4),), min_budget=12)
