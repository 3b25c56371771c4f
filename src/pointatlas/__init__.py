"""pointatlas: point-set geometry processing between local and global approaches.

Planar segmentation (VSA with guaranteed convergence), simplified polygon meshes,
per-point eigen-features with optimal normal-weighted neighbourhoods, denoising and
cloud surfaces, after the thesis *Point Clouds - Between Local and Global Approaches*.

The rooms are imported explicitly, e.g. ``from pointatlas.neighbors import query_knn``.
"""

import os
import platform
import sys

# OpenBLAS picks its kernels by the CPU (AVX2 or AVX-512 ones): the same products
# rounded apart, and a level search then ends elsewhere (a sampled CAD part of the
# collection: 986 or 1,434 triangles). Its AVX2 kernels run on every x86-64 CPU of
# the last decade and give the same bits on each; set before numpy loads OpenBLAS
# (too late once it has: then the CPU's), a caller's own choice kept.
if "numpy" not in sys.modules and platform.machine().lower() in ("x86_64", "amd64"):
    os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")

from ._core import PointAtlasError, PointSet  # noqa: E402

#: the package version (as in pyproject.toml)
__version__ = "0.1.0"

__all__ = ["PointAtlasError", "PointSet", "__version__"]
