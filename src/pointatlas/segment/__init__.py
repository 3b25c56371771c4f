"""Segmentation of point sets into flat regions (thesis 4.2-4.3, GUIDE B2).

Variational shape approximation with flood, switch, split and merge
(`vsa_segment`), the region-growing baseline of Rabbani et al. (2006)
(`region_growing`), region adjacency (Remark 6) and the eta estimate of Eq. 4.9.
"""

from ._graph import region_adjacency
from ._region_growing import RegionGrowingResult, region_growing, surface_curvature
from ._vsa import VSAResult, area_weights, estimate_eta, vsa_segment

__all__ = [
    "RegionGrowingResult",
    "VSAResult",
    "area_weights",
    "estimate_eta",
    "region_adjacency",
    "region_growing",
    "surface_curvature",
    "vsa_segment",
]
