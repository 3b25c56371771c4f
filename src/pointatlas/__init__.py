"""pointatlas: point-set geometry processing between local and global approaches.

Planar segmentation (VSA with guaranteed convergence), simplified polygon meshes,
per-point eigen-features with optimal normal-weighted neighbourhoods, denoising and
cloud surfaces, after the thesis *Point Clouds - Between Local and Global Approaches*.

The rooms are imported explicitly, e.g. ``from pointatlas.neighbors import query_knn``.
"""

from ._core import PointAtlasError, PointSet

#: the package version (as in pyproject.toml)
__version__ = "0.1.0"

__all__ = ["PointAtlasError", "PointSet", "__version__"]
