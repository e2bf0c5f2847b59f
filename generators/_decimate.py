"""Quadric edge-collapse decimation (pymeshlab) with every parameter named.

Shared by the ``qem`` baseline (:mod:`viscore.generators.baselines`) and the
hybrid method's patch and voxel candidates (:mod:`viscore.generators.hybrid`).
"""

from __future__ import annotations

__all__ = ["QEM_DEFAULTS", "quadric_edge_collapse"]

#: Every parameter of pymeshlab's ``meshing_decimation_quadric_edge_collapse`` at
#: MeshLab's default. pymeshlab keeps a parameter left out at the value the last call in
#: the process gave it, so a call that names only some of them depends on what ran
#: before (the hybrid's boundary weight changed later ``qem`` occluders); every call
#: goes through :func:`quadric_edge_collapse`, which names them all.
QEM_DEFAULTS = {"targetfacenum": 6, "targetperc": 0.0, "qualitythr": 0.3,
                "preserveboundary": False, "boundaryweight": 1.0, "preservenormal": False,
                "preservetopology": False, "optimalplacement": True, "planarquadric": False,
                "planarweight": 0.001, "qualityweight": False, "autoclean": True,
                "selected": False}


def quadric_edge_collapse(ms, **params) -> None:
    """Run pymeshlab's quadric edge collapse on ``ms`` with every parameter named.

    ``params`` override :data:`QEM_DEFAULTS`; the others are passed at their
    defaults, so that the result does not depend on earlier calls in the process.
    """
    unknown = set(params) - set(QEM_DEFAULTS)
    if unknown:
        raise TypeError(f"quadric_edge_collapse: unknown parameters {sorted(unknown)}")
    ms.meshing_decimation_quadric_edge_collapse(**{**QEM_DEFAULTS, **params})
