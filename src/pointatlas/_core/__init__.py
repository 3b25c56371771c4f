"""Layer 0: array conventions, validation, rng, tolerances, the PointSet container."""

from ._deprecation import deprecated_alias, warn_renamed
from ._interrupt import (
    STOP_SIGNALS,
    clear_interrupt,
    interrupt_requested,
    interrupt_signal,
    interrupts_deferred,
    interrupts_deferred_now,
    request_interrupt,
)
from ._pointset import PointSet, readonly, readonly_view
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
    "STOP_SIGNALS",
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
    "clear_interrupt",
    "deprecated_alias",
    "describe_indices",
    "interrupt_requested",
    "interrupt_signal",
    "interrupts_deferred",
    "interrupts_deferred_now",
    "readonly",
    "readonly_view",
    "request_interrupt",
    "warn_renamed",
]
