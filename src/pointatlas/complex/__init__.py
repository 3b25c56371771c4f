"""The surface-like complex K' of a segmentation (thesis section 3, GUIDE B1)."""

from ._complex import SurfaceComplex, surface_complex

__all__ = ["SurfaceComplex", "surface_complex"]
