"""Nodes a game does not draw (collision, navigation, hidden) are left out of a level."""

import logging

import numpy as np
import pytest
from test_scene_graph import _glb, _write

from viscore.level.hidden_nodes import hidden_reason
from viscore.level.scene_graph import load_scene_objects


@pytest.mark.parametrize("node, reason", [
    ({"name": "wall-colonly"}, "Godot's -colonly hint"),
    ({"name": "Wall_ConvColOnly"}, "Godot's -convcolonly hint"),
    ({"name": "floor$navmesh"}, "Godot's -navmesh hint"),
    ({"name": "lamp-NOIMP"}, "Godot's -noimp hint"),
    ({"name": "block-occonly"}, "Godot's -occonly hint"),
    ({"name": "UCX_Wall_01"}, "Unreal's UCX_ collision prefix"),
    ({"name": "__collision__"}, "a collision name"),
    ({"name": "collider_GalleryBuilding"}, "a collision name"),
    ({"name": "WallCollider"}, "a collision name"),
    ({"name": "Colliders.003"}, "a collision name"),
    ({"name": "x", "extras": {"visible": "false"}}, "extras: visible false"),
    ({"name": "x", "extras": {"visible": False}}, "extras: visible false"),
    ({"name": "x", "extras": {"visible": 0}}, "extras: visible false"),
    ({"name": "x", "extensions": {"KHR_node_visibility": {"visible": False}}},
     "KHR_node_visibility: visible false"),
])
def test_hidden_reason_names_the_rule(node, reason):
    assert hidden_reason(node) == reason


@pytest.mark.parametrize("node", [
    {"name": "wall-col"},            # Godot: drawn, with a collision body added
    {"name": "wall-convcol"},
    {"name": "floor-occ"},           # Godot: drawn, with an occluder added
    {"name": "colonnade"},
    {"name": "ucx_wall"},            # Unreal's prefixes are upper case
    {"name": "Collisionless_Rock"},  # one word, not 'collision'
    {"name": "__water__"},
    {"name": "x", "extras": {"visible": "true"}},
    {"name": "x", "extras": {"visible": 1}},
    {"name": "x", "extensions": {"KHR_node_visibility": {"visible": True}}},
    {"name": "x", "extensions": {"KHR_node_visibility": {}}},  # default: visible
    {"mesh": 0},
])
def test_hidden_reason_leaves_drawn_nodes(node):
    assert hidden_reason(node) is None


def test_level_leaves_out_hidden_nodes_and_their_subtrees(tmp_path, caplog):
    nodes = [
        {"name": "ground", "mesh": 0, "scale": [10.0, 0.1, 10.0]},
        {"name": "__collision__", "mesh": 0, "scale": [12.0, 0.1, 12.0]},
        {"name": "proxies", "extensions": {"KHR_node_visibility": {"visible": False}},
         "children": [3]},
        {"name": "proxy_box", "mesh": 0, "translation": [0.0, 5.0, 0.0]},  # hidden by its parent
        {"name": "crate", "mesh": 0, "translation": [2.0, 1.0, 0.0]},
        {"name": "crate_hull", "mesh": 0, "extras": {"visible": "false"}},
    ]
    path = _write(tmp_path, "level.glb", _glb(nodes, [0, 1, 2, 4, 5]))
    with caplog.at_level(logging.WARNING, logger="viscore.level.scene_graph"):
        objects = load_scene_objects(path)
    assert objects.names == ("crate", "ground")
    # the level's extent is the drawn ground's, not the larger collision plane's
    np.testing.assert_allclose(objects.bounds[:, 0], [-5.0, 5.0])
    text = caplog.text
    assert "left out 3 mesh nodes marked as not drawn" in text
    assert "'__collision__' (a collision name)" in text
    assert "'proxy_box' (KHR_node_visibility: visible false)" in text
    assert "'crate_hull' (extras: visible false)" in text


def test_level_of_hidden_nodes_only_is_read_whole(tmp_path, caplog):
    nodes = [{"name": "a-colonly", "mesh": 0}, {"name": "b-colonly", "mesh": 0,
                                                 "translation": [3.0, 0.0, 0.0]}]
    path = _write(tmp_path, "all.glb", _glb(nodes, [0, 1]))
    with caplog.at_level(logging.WARNING, logger="viscore.level.scene_graph"):
        objects = load_scene_objects(path)
    assert objects.names == ("a-colonly", "b-colonly")
    assert "every mesh node is marked as not drawn" in caplog.text
