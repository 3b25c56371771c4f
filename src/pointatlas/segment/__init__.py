"""Segmentation of point sets into flat regions (thesis 4.2-4.3).

Variational shape approximation with flood, switch, split and merge
(`vsa_segment`, its settings `VSAOptions`), the region-growing baseline of
Rabbani et al. (2006) (`region_growing`), region adjacency (Remark 6), the area
weights of Eq. 4.6 and the eta estimate of Eq. 4.9.
"""

from ._eta import estimate_eta
from ._graph import region_adjacency
from ._options import VSAOptions
from ._region_growing import RegionGrowingResult, region_growing, surface_curvature
from ._small import pick_merge_targets
from ._vsa import VSAResult, vsa_segment
from ._weights import area_weights

__all__ = [
    "RegionGrowingResult",
    "VSAOptions",
    "VSAResult",
    "area_weights",
    "estimate_eta",
    "pick_merge_targets",
    "region_adjacency",
    "region_growing",
    "surface_curvature",
    "vsa_segment",
]
