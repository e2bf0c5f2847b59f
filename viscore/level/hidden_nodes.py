"""Which glTF nodes a game does not draw: visibility flags and engine naming rules."""

from __future__ import annotations

import re

__all__ = ["hidden_reason"]

_GODOT_HINTS = ("noimp", "colonly", "convcolonly", "navmesh", "occonly")
_GODOT_SUFFIX = re.compile(r"[-_$](" + "|".join(_GODOT_HINTS) + r")$", re.IGNORECASE)
_UNREAL_PREFIX = re.compile(r"^(UCX|UBX|USP|UCP)_")
_COLLISION_WORDS = frozenset({"collision", "collisions", "collider", "colliders"})
_WORD = re.compile(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|[0-9]+")
_FALSE = frozenset({"false", "0", "no", "off"})


def _false(value) -> bool:
    """True for a JSON value that reads as 'false' (a boolean, a number, a word)."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value == 0
    if isinstance(value, str):
        return value.strip().lower() in _FALSE
    return False


def hidden_reason(node: dict) -> str | None:
    """Why a glTF node is not drawn, in a few words, or None when it is drawn.

    Parameters
    ----------
    node : dict
        One entry of a glTF file's ``nodes`` list (its JSON object).

    Returns
    -------
    str or None
        The rule that hides it (see the module docstring), e.g.
        ``"KHR_node_visibility: visible false"`` or ``"Godot's -colonly
        hint"``; None when no rule applies. Descendants are not looked at:
        the caller carries a hidden parent down its subtree.

    Examples
    --------
    >>> hidden_reason({"name": "wall-colonly"})
    "Godot's -colonly hint"
    >>> hidden_reason({"name": "colonnade"}) is None
    True
    """
    ext = node.get("extensions")
    if isinstance(ext, dict):
        vis = ext.get("KHR_node_visibility")
        if isinstance(vis, dict) and vis.get("visible", True) is False:
            return "KHR_node_visibility: visible false"
    extras = node.get("extras")
    if isinstance(extras, dict) and "visible" in extras and _false(extras["visible"]):
        return "extras: visible false"
    name = node.get("name")
    if not isinstance(name, str):
        return None
    hint = _GODOT_SUFFIX.search(name)
    if hint:
        return f"Godot's -{hint.group(1).lower()} hint"
    prefix = _UNREAL_PREFIX.match(name)
    if prefix:
        return f"Unreal's {prefix.group(1)}_ collision prefix"
    if _COLLISION_WORDS.intersection(w.lower() for w in _WORD.findall(name)):
        return "a collision name"
    return None
