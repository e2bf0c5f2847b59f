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


@pytest.fixture(autouse=True)
def _restore_log_levels():
    """Every test starts from the same log levels: ``main([... '--quiet'])`` run in-process
    sets the ``viscore`` logger to ERROR for the rest of the process, and a later test's
    ``caplog.at_level('WARNING')`` (which sets the root logger's level only) then saw
    nothing of the toolkit's warnings, depending on which tests a worker ran before."""
    import logging

    loggers = [logging.getLogger(), logging.getLogger("viscore")]
    saved = [lg.level for lg in loggers]
    yield
    for lg, level in zip(loggers, saved, strict=True):
        lg.setLevel(level)
    logging.captureWarnings(False)
