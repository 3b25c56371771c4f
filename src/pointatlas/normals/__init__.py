"""Normals: PCA estimation (unoriented), orientation, and comparison metrics.

Estimation and orientation are separate steps (Open3D style); one k-NN query can
serve both through their ``neighbors`` argument.
"""

from ._compare import compare_normals
from ._estimate import PCANormalsResult, estimate_normals, pca_normals
from ._metrics import angle_error, flipped_fraction
from ._orient import orient_normals

__all__ = [
    "PCANormalsResult",
    "angle_error",
    "compare_normals",
    "estimate_normals",
    "flipped_fraction",
    "orient_normals",
    "pca_normals",
]
