"""The simplification chain of a polygon, every stage inside its candidate.

Silvennoinen et al. 2014, sec. 4.4: the greedy smallest-ear collapse
(:func:`simplification_chain`) and its refinement with the largest inscribed
polygons and the containment checks (:func:`refine_chain`). Shared by the
families that cut occluders from polygons (planar sections; surface patches).
"""

from .optimal import MAX_TRIANGLES, POOL, StageChain, best_inscribed, refine_chain
from .simplify import SimplificationChain, simplification_chain

__all__ = ["SimplificationChain", "simplification_chain", "StageChain", "refine_chain",
           "best_inscribed", "MAX_TRIANGLES", "POOL"]
