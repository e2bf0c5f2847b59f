"""``viscore bench cull-scale``: the city tiled n x n in memory (the timed run is a bench)."""

import numpy as np
import pytest

from viscore import InputError
from viscore.cli.bench.cull_scale import TILE_GAP, bench_cull_scale, tiled_city


def test_tiled_city_copies_every_node_with_the_tile_offsets():
    one, two = tiled_city(1), tiled_city(2)
    nodes = sorted(one.graph.nodes_geometry)
    assert len(two.graph.nodes_geometry) == 4 * len(nodes)
    extent = one.bounds[1] - one.bounds[0]
    node = nodes[0]
    assert node.endswith("_t00")
    base, base_geometry = one.graph[node]
    for i, j in ((0, 0), (1, 0), (0, 1), (1, 1)):
        matrix, geometry = two.graph[node[: -len("_t00")] + f"_t{i}{j}"]
        assert geometry == base_geometry  # the city's own geometry, shared
        assert np.allclose(matrix[:3, :3], base[:3, :3])
        shift = matrix[:3, 3] - base[:3, 3]
        assert np.allclose(shift, [i * TILE_GAP * extent[0], 0.0, j * TILE_GAP * extent[2]])
    assert set(two.geometry) == set(one.geometry)  # held once, not per tile


def test_bench_cull_scale_invalid_input():
    with pytest.raises(InputError, match="sizes"):
        bench_cull_scale(sizes=(0,))
    with pytest.raises(InputError, match="frames"):
        bench_cull_scale(frames=0)
