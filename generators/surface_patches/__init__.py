"""surface-patches: conservative double-sided occluders cut from the input's own coplanar
regions (the planar patches of Wu et al. 2022, sec. 3.1, grouped across loose parts; the
simplification chain and selection by occlusion measure of Silvennoinen et al. 2014, sec. 4),
with the boxes of the occluder-skins paper (Leone et al. 2012, sec. 4: aabb-skins) where
closed parts hold them."""

from .generator import generate_surface_patches

__all__ = ["generate_surface_patches"]
