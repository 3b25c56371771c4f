"""Layer 0: array conventions, validation, rng, tolerances, the PointSet container."""

from ._pointset import PointSet, readonly
from ._validation import (
    as_float,
    as_float_array,
    as_int,
    as_k,
    as_labels,
    as_normals,
    as_points,
    as_rng,
    as_vectors,
    check_neighbors,
    describe_indices,
)
from .errors import PointAtlasError

__all__ = [
    "PointAtlasError",
    "PointSet",
    "as_float",
    "as_float_array",
    "as_int",
    "as_k",
    "as_labels",
    "as_normals",
    "as_points",
    "as_rng",
    "as_vectors",
    "check_neighbors",
    "describe_indices",
    "readonly",
]
