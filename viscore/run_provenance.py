"""Provenance of a result: software versions, Embree, worker count, and platform.

Every JSON result embeds :func:`provenance` together with its seed and
parameters, so that a figure can be traced to the software that made it.
"""

from __future__ import annotations

import platform
import sys
from importlib.metadata import PackageNotFoundError, version

from .ray.embree_scene import get_workers

__all__ = ["provenance", "package_version"]


def package_version(dist: str) -> str | None:
    """The installed version of distribution ``dist``, or None where it is not installed."""
    try:
        return version(dist)
    except PackageNotFoundError:
        return None


def _embree_version() -> str | None:
    """Embree's own version string as reported by its device, if readable."""
    try:
        from embreex import rtcore

        device = rtcore.EmbreeDevice()
        text = repr(device)  # "Embree version:  4.4.0"
        return text.split(":", 1)[1].strip() if "Embree version" in text else None
    except Exception:  # pragma: no cover - diagnostic only
        return None


def provenance() -> dict:
    """Versions and settings that a result depends on.

    Returns
    -------
    info : dict
        Keys ``viscore``, ``embreex``, ``embree``, ``numpy``, ``scipy``,
        ``trimesh``, ``python``, ``platform`` (strings or None when unknown)
        and ``workers`` (int, the default ray-casting thread count).

    Examples
    --------
    >>> sorted(provenance())[:3]
    ['embree', 'embreex', 'numpy']
    """
    return {
        "viscore": package_version("viscore"),
        "embreex": package_version("embreex"),
        "embree": _embree_version(),
        "numpy": package_version("numpy"),
        "scipy": package_version("scipy"),
        "trimesh": package_version("trimesh"),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "workers": get_workers(),
    }
