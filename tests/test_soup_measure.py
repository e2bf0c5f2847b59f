"""The soup measure's kernels against the definition, pixel by pixel (bit for bit)."""

import math

import numpy as np
import pytest

from viscore.generators._soup_measure import soup_measures, soup_totals


def _by_definition(img: np.ndarray) -> float:
    """Sum over covered pixels, row by row, of the distance to the nearest mid-point
    between two 4-neighbours of which one is covered (outside the image is not)."""
    padded = np.pad(np.asarray(img, dtype=bool), 1)
    h, w = padded.shape
    points = []
    for i in range(h):
        for j in range(w - 1):
            if padded[i, j] != padded[i, j + 1]:
                points.append((i - 1.0, j - 0.5))
    for i in range(h - 1):
        for j in range(w):
            if padded[i, j] != padded[i + 1, j]:
                points.append((i - 0.5, j - 1.0))
    pts = np.array(points, dtype=np.float64).reshape(-1, 2)
    total = 0.0
    for i, j in zip(*np.nonzero(img), strict=True):  # row-major order
        d = float(np.min((pts[:, 0] - i) ** 2 + (pts[:, 1] - j) ** 2))  # exact: quarters
        total += math.sqrt(d)
    return total


def _row_and_column(shape: tuple[int, int], row: int, col: int) -> np.ndarray:
    """One whole row and one whole column covered: lines a pixel wide, crossing."""
    img = np.zeros(shape, bool)
    img[row, :] = True
    img[:, col] = True
    return img


def _images(seed: int) -> np.ndarray:
    """Blobs, holes, thin lines, a full and an empty image, 24 x 17."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:24, :17]
    out = [np.zeros((24, 17), bool), np.ones((24, 17), bool)]
    for _ in range(10):
        cy, cx, r = rng.uniform(0, 24), rng.uniform(0, 17), rng.uniform(1, 12)
        blob = (yy - cy) ** 2 + (xx - cx) ** 2 < r * r
        blob &= ~((yy - cy) ** 2 + (xx - cx) ** 2 < (r / 3) ** 2)  # a hole
        blob |= rng.random((24, 17)) < 0.05
        out.append(blob)
    out.append(_row_and_column((24, 17), 5, 9))
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1])
def test_measures_are_the_definition_bit_for_bit(seed):
    images = _images(seed)
    got = soup_measures(images, 1.0)
    want = np.array([_by_definition(img) for img in images])
    assert got.tobytes() == want.tobytes()
    assert got[0] == 0.0 and got[1] > 0


def test_totals_are_the_definition_of_each_union_bit_for_bit():
    images = _images(2)
    union = images[2:5].copy()  # 3 directions
    bitmaps = np.stack([images[5:8], images[8:11], np.zeros_like(union), images[[0, 1, 11]]])
    base = soup_measures(union, 1.0)
    ids = np.array([3, 0, 2, 1])
    got = soup_totals(ids, union, bitmaps, base)
    want = []
    for i in ids:
        total = 0.0
        for k in range(len(union)):
            adds = (bitmaps[i, k] & ~union[k]).any()
            total += _by_definition(union[k] | bitmaps[i, k]) if adds else base[k]
        want.append(total)
    assert got.tobytes() == np.array(want).tobytes()
    assert got[2] == base.sum()  # a candidate that adds nothing keeps the union's measure


def _deep_images(seed: int) -> np.ndarray:
    """64 x 64 discs, squares and rings, deep inside (distances of many pixels), an image
    covered whole, one row and one column: the measure's search reaches far."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:64, :64]
    out = [np.ones((64, 64), bool)]
    for _ in range(4):
        cy, cx, r = rng.uniform(10, 54, size=2).tolist() + [rng.uniform(8, 40)]
        disc = (yy - cy) ** 2 + (xx - cx) ** 2 < r * r
        out.append(disc)
        out.append(disc & ~((yy - cy) ** 2 + (xx - cx) ** 2 < (r / 2) ** 2))
    square = np.zeros((64, 64), bool)
    square[3:61, 5:50] = True
    out.append(square)
    out.append(_row_and_column((64, 64), 40, 2))
    return np.array(out)


def test_measures_of_deep_images_are_the_definition_bit_for_bit():
    images = _deep_images(3)
    got = soup_measures(images, 1.0)
    want = np.array([_by_definition(img) for img in images])
    assert got.tobytes() == want.tobytes()
    # the whole square: a pixel's distance is to the nearest side
    ii, jj = np.mgrid[:64, :64]
    side = np.minimum(np.minimum(ii, 63 - ii), np.minimum(jj, 63 - jj)) + 0.5
    assert got[0] == pytest.approx(side.sum(), rel=1e-12)


def test_totals_of_deep_images_in_one_box_are_the_definition_bit_for_bit():
    images = _deep_images(4)
    union = np.zeros((2, 64, 64), bool)
    union[0, 20:30, 20:30] = True  # the candidates add to it, in a box around both
    bitmaps = images[:, None].repeat(2, axis=1)
    base = soup_measures(union, 1.0)
    ids = np.arange(len(images))
    got = soup_totals(ids, union, bitmaps, base)
    want = [_by_definition(union[0] | images[i]) + _by_definition(images[i]) for i in ids]
    assert got.tobytes() == np.array(want).tobytes()
