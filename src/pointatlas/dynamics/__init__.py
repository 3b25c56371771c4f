"""Cloud dynamics (thesis 2.3, Algorithm 3): points follow the realisation of their clouds.

Layer 4; uses `pointatlas.complex` for the cloud complex and its orientation.
"""

from ._deform import DeformResult, deform_points

__all__ = ["DeformResult", "deform_points"]
