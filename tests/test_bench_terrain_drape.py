"""``viscore bench generate terrain-drape``: its height fields and the area-above figure."""

import numpy as np
import trimesh

from viscore.cli.bench.terrain_drape import area_above, height_fields, terrain_drape_lines


def _square(z: float, size: float = 10.0) -> trimesh.Trimesh:
    return trimesh.Trimesh([[0, 0, z], [size, 0, z], [size, size, z], [0, size, z]],
                           [[0, 1, 2], [0, 2, 3]], process=False)


def test_area_above_counts_only_what_stands_over_the_surface():
    ground = _square(0.0)
    diag = float(np.linalg.norm(ground.extents))  # 14.1 (flat: no height)
    over = _square(0.02 * diag, size=5.0)  # 2% of the diagonal above: counted
    under = _square(-0.5, size=5.0)
    barely = _square(0.002 * diag, size=5.0)  # under the 0.5% threshold
    assert area_above(ground, over, "z") == 1.0
    assert area_above(ground, under, "z") == 0.0
    assert area_above(ground, barely, "z") == 0.0
    half = trimesh.util.concatenate([_square(0.02 * diag, 5.0), _square(-0.5, 5.0)])
    assert abs(area_above(ground, half, "z") - 0.5) < 0.03
    # past the ground's edge nothing is below: not above the surface
    assert area_above(ground, _square(1.0, 5.0).apply_translation((20, 0, 0)), "z") == 0.0


def test_height_fields_are_open_sheets_along_their_up_axis():
    fields = height_fields()
    assert {"terrain", "hills", "hills-y-up", "hills-lake", "fractal-3", "fractal-2.2"} == set(
        fields)
    for name, (mesh, up) in fields.items():
        k = "xyz".index(up)
        assert int(np.argmin(mesh.extents)) == k, name
        # an open sheet: most of its faces face one way along up
        n = mesh.face_normals[:, k]
        assert max((n > 0.1).mean(), (n < -0.1).mean()) > 0.9, name
    assert len(fields["hills-lake"][0].faces) < len(fields["hills"][0].faces)


def test_lines_show_each_method_and_a_missing_precision():
    row = {"name": "hills", "triangles": 44402,
           "terrain-drape": {"triangles": 0, "seconds": 1.0, "precision": None, "recall": 0.0,
                             "above": 0.0},
           "qem": {"triangles": 23, "seconds": 0.5, "precision": 0.9991, "recall": 0.96,
                   "above": 0.43}}
    text = "\n".join(terrain_drape_lines([row]))
    assert "terrain-drape" in text and "qem" in text and "44,402" in text
    assert " - " in text and "0.9991" in text and "0.43" in text
