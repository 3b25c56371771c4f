"""Complexes on point sets and their simplicial-surface checks.

The cloud complex of a cloud set (thesis Chapter A, Defs 3-10) and the
surface-like complex K' of a segmentation (section 3) share one set of
simplicial-surface checks and one topology report (`surface_report`, Defs 7, 8, 13, 14).
"""

from .._core._deprecation import deprecated_alias
from ._clouds import CloudComplex, cloud_complex
from ._complex import SurfaceComplex, surface_complex
from ._report import CurveReport, curve_report, realize_complex, surface_report
from ._surface import SurfaceReport

__all__ = [
    "CloudComplex",
    "CurveReport",
    "SurfaceComplex",
    "SurfaceReport",
    "cloud_complex",
    "curve_report",
    "realize_complex",
    "surface_complex",
    "surface_report",
]

# Former (British) names: they still work and warn, naming the new name (not in __all__).
realise_complex = deprecated_alias(realize_complex, "realise_complex")
