"""walk_plot and picture_grid (viscore.metrics.plots): the report pages' figures."""

import numpy as np
import pytest
from PIL import Image

import viscore.metrics.plots as plots
from viscore import InputError
from viscore.metrics.plots import picture_grid, walk_plot


def _plan(rows=200, cols=200):
    img = np.full((rows, cols, 3), 230, dtype=np.uint8)
    img[50:150, 50:150] = (90, 110, 160)  # a building
    return img


def test_walk_plot_marks_where_the_cameras_are(tmp_path):
    points = np.array([[100.0, 100.0], [150.0, 50.0], [400.0, 100.0]])  # the last: far east
    marks = walk_plot(_plan(), points, tmp_path / "w.png", far=[False, False, True],
                      shown=[1])
    side = plots._WALK_INCHES * plots.DPI  # the plan fills the figure: 720 / 200 px a pixel
    assert np.allclose(marks[0], [side / 2, side / 2], atol=0.5)
    assert np.allclose(marks[1], [150 * side / 200, 50 * side / 200], atol=0.5)
    # outside: pulled back to _WALK_EDGE of the way from the centre to the edge
    assert np.allclose(marks[2], [side / 2 * (1 + plots._WALK_EDGE), side / 2], atol=0.5)
    img = np.asarray(Image.open(tmp_path / "w.png").convert("RGB"))
    assert img.shape == (side, side, 3)
    # the walk's colour is drawn between the first two cameras, over the building
    mid = ((marks[0] + marks[1]) / 2).round().astype(int)
    walk = np.round(np.array(plots._WALK_RGB) * 255)
    patch = img[mid[1] - 2:mid[1] + 3, mid[0] - 2:mid[0] + 3].reshape(-1, 3).astype(float)
    assert np.abs(patch - walk).sum(axis=1).min() < 60


def test_walk_plot_invalid_input(tmp_path):
    with pytest.raises(InputError, match="image"):
        walk_plot(np.zeros((4, 4)), np.zeros((1, 2)), tmp_path / "w.png")
    with pytest.raises(InputError, match="points"):
        walk_plot(_plan(), np.array([[np.nan, 1.0]]), tmp_path / "w.png")
    with pytest.raises(InputError, match="figure"):
        walk_plot(_plan(), np.zeros((1, 2)), tmp_path / "w.txt")
    assert not (tmp_path / "w.png").exists()


def test_picture_grid_places_each_picture_at_its_own_size(tmp_path):
    red = np.zeros((30, 40, 3), np.uint8)
    red[..., 0] = 255
    blue = np.zeros((30, 40, 3), np.uint8)
    blue[..., 2] = 255
    tall = np.full((50, 40, 3), 255, np.uint8)
    picture_grid([[red, blue], [tall, tall]], tmp_path / "g.png", row_labels=["a", "b"],
                 column_labels=["x", "y"], title="t")
    img = np.asarray(Image.open(tmp_path / "g.png").convert("RGB"))
    label = round(plots._GRID_LABEL_INCHES * plots.DPI)
    assert img.shape == (2 * label + 30 + 50, label + 80, 3)
    top = 2 * label  # the title's and the column labels' rows
    assert img[top + 15, label + 20].tolist() == [255, 0, 0]
    assert img[top + 15, label + 60].tolist() == [0, 0, 255]


def test_picture_grid_invalid_input(tmp_path):
    a = np.zeros((10, 10, 3), np.uint8)
    with pytest.raises(InputError, match="images"):
        picture_grid([[a, np.zeros((10, 12, 3), np.uint8)]], tmp_path / "g.png",
                     row_labels=["r"], column_labels=["a", "b"])
    with pytest.raises(InputError, match="labels"):
        picture_grid([[a]], tmp_path / "g.png", row_labels=[], column_labels=["a"])
    with pytest.raises(InputError, match="images"):
        picture_grid([], tmp_path / "g.png", row_labels=[], column_labels=[])
