"""What a format reader returns before validation (private)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RawData", "colors_to_uint8"]


@dataclass
class RawData:
    """Arrays as read from a file, not yet validated.

    ``points`` is (N, 3) float64; ``faces``/``face_offsets`` are the compressed-row
    polygon layout of :class:`Mesh` (None for point formats); ``meta`` holds format
    details for a later write (PointSet.meta).
    """

    points: np.ndarray
    normals: np.ndarray | None = None
    attributes: dict[str, np.ndarray] = field(default_factory=dict)
    faces: np.ndarray | None = None
    face_offsets: np.ndarray | None = None
    face_colors: np.ndarray | None = None
    meta: dict[str, object] = field(default_factory=dict)

    @property
    def has_faces(self) -> bool:
        return self.face_offsets is not None and self.face_offsets.size > 1


def colors_to_uint8(values: np.ndarray) -> np.ndarray | None:
    """Convert colour channels to uint8: integers 0..255 kept, floats in [0, 1] scaled.

    Returns None when the values fit neither convention (the caller keeps them as
    separate attributes).
    """
    arr = np.asarray(values)
    if arr.dtype == np.uint8:
        return arr.copy()
    if arr.size == 0:
        return arr.astype(np.uint8)
    if arr.dtype.kind in "iu":
        if arr.min() >= 0 and arr.max() <= 255:
            return arr.astype(np.uint8)
        return None
    if arr.dtype.kind == "f" and np.isfinite(arr).all() and arr.min() >= 0 and arr.max() <= 1:
        return np.rint(arr * 255.0).astype(np.uint8)
    return None
