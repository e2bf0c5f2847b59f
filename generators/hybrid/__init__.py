"""hybrid: patch-based and voxel-based candidates with hole filling, conservative enforcement
and metric-guided face removal, for game buildings (Wu et al. 2022, sec. 3)."""

from .generator import generate_hybrid, shared_budgets
from .metric_guided import metric_guided_simplify

__all__ = ["generate_hybrid", "metric_guided_simplify", "shared_budgets"]
