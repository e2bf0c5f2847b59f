"""viscore.metrics.estimates: the memory figures the command line checks settings against."""

import pytest
import trimesh

from viscore.metrics import estimates as est


def test_estimates_figures_are_documented_bytes():
    # the stored quad is the reference views' own layout: 4 int16 corners, 2 int32, 1 int16
    assert est.BYTES_PER_STORED_QUAD == 18
    # the scored quad is a measured transient peak, larger than what is stored
    assert est.BYTES_PER_SCORED_QUAD > est.BYTES_PER_STORED_QUAD


def test_evaluation_bytes_orbit_one_batch_of_views():
    small = est.evaluation_bytes("orbit", views=1, quads=0, resolution=256)
    assert small == 256 * 256 * est.BYTES_PER_ORBIT_PIXEL + est.BYTES_PER_RESULT_VIEW
    # beyond one batch (2**18 rays = 4 images of 256^2), only the per-view results grow
    four = est.evaluation_bytes("orbit", views=4, quads=0, resolution=256)
    many = est.evaluation_bytes("orbit", views=400, quads=0, resolution=256)
    assert many - four == 396 * est.BYTES_PER_RESULT_VIEW
    deep = est.evaluation_bytes("orbit", views=1, quads=0, resolution=256, depth_aware=True)
    assert deep - small == 256 * 256 * est.BYTES_PER_DEPTH_AWARE_PIXEL


def test_conservativeness_and_measure_bytes():
    assert est.conservativeness_bytes(10) == 10 * est.BYTES_PER_CHECK_RAY
    assert est.conservativeness_bytes(10**9) == est.RAYS_PER_BATCH * est.BYTES_PER_CHECK_RAY
    assert est.measure_bytes(2, 16) == 256 * est.BYTES_PER_MEASURE_PIXEL + 2048


@pytest.mark.parametrize("jobs", [1, 3])
def test_study_bytes_orbit_counts_views_per_worker_and_once_more(jobs):
    box = trimesh.creation.box()
    kw = {"views": 10, "quads": 100, "resolution": 64, "rays": 1000}
    one = est.study_bytes("orbit", meshes={"box": box}, jobs=jobs, **kw)
    views = 10 * (100 * est.BYTES_PER_STORED_QUAD + est.BYTES_PER_STORED_VIEW)
    two = est.study_bytes("orbit", meshes={"box": box, "b2": box.copy()}, jobs=jobs, **kw)
    assert two - one == pytest.approx(views)
    assert one > jobs * est.PROCESS_BYTES
