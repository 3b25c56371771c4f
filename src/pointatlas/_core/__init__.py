"""Layer 0: array conventions, validation, rng, tolerances, the PointSet container."""

from ._pointset import PointSet, readonly
from ._scalars import as_float, as_float_array, as_int, as_iterations, as_k
from ._validation import (
    as_labels,
    as_normals,
    as_points,
    as_rng,
    as_vectors,
    check_finite,
    check_neighbors,
    describe_indices,
)
from .errors import NonFiniteError, PointAtlasError

__all__ = [
    "NonFiniteError",
    "PointAtlasError",
    "PointSet",
    "as_float",
    "as_float_array",
    "as_int",
    "as_iterations",
    "as_k",
    "as_labels",
    "as_normals",
    "as_points",
    "as_rng",
    "as_vectors",
    "check_finite",
    "check_neighbors",
    "describe_indices",
    "readonly",
]
