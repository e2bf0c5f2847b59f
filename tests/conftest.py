import numpy as np
import pytest
import trimesh


@pytest.fixture
def unit_sphere():
    """Icosphere of radius 1 (20,480 faces): projected area within 0.2% of pi."""
    return trimesh.creation.icosphere(subdivisions=5, radius=1.0)


@pytest.fixture
def cube():
    """Closed axis-aligned cube [-1, 1]^3."""
    return trimesh.creation.box(extents=(2.0, 2.0, 2.0))


@pytest.fixture
def open_cube(cube):
    """The cube [-1, 1]^3 without its two +Z triangles."""
    keep = cube.face_normals[:, 2] < 0.5
    return trimesh.Trimesh(cube.vertices, cube.faces[keep], process=False)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
