"""The o/g and usemtl groups of an OBJ file, per triangle."""

import numpy as np
import pytest

from viscore import InputError
from viscore.exchange.obj_groups import label_faces, obj_groups

_TEXT = """# a quad and a triangle
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 5 5 5
usemtl red
o first
g left
f 1 2 3 4
o second
usemtl blue
f -5/1/1 -3//2 -1
"""


def test_obj_groups_labels_each_triangle(tmp_path):
    p = tmp_path / "g.obj"
    p.write_text(_TEXT)
    g = obj_groups(p)
    assert g.group_names == ("", "first", "first/left", "second")
    assert g.material_names == ("", "red", "blue")
    assert g.group.tolist() == [2, 2, 3] and g.material.tolist() == [1, 1, 2]
    # the quad fanned from its first vertex; the relative indices of the triangle
    np.testing.assert_allclose(g.centroids, [[2 / 3, 1 / 3, 0], [1 / 3, 2 / 3, 0],
                                             [2, 2, 5 / 3]])
    # carried onto a mesh of the same triangles in another order
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 5.0]])
    f = np.array([[0, 2, 4], [0, 2, 3], [0, 1, 2]])
    assert label_faces(g, v, f, g.group).tolist() == [3, 2, 2]


@pytest.mark.parametrize("text,match", [("v 0 0 x\n", "vertex line"),
                                        ("v 0 0 0\nf 1 2 3\n", "line 2"),
                                        ("v 0 0\n", "line 1")])
def test_obj_groups_invalid_input(tmp_path, text, match):
    p = tmp_path / "bad.obj"
    p.write_text(text)
    with pytest.raises(InputError, match=match):
        obj_groups(p)
    with pytest.raises(InputError, match="no such file"):
        obj_groups(tmp_path / "missing.obj")
