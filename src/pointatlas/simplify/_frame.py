"""The simplify room's working frame: centred, power-of-two scaled coordinates.

Every geometric step of the room (proxies, complex, vertices, faces, distances)
runs on ``(points - center) / scale`` and the results are mapped back, so the
mesh does not depend on where the model lies or in which units it is given, and
every tolerance is relative to the model's size (docs/decisions/simplify.md, "The
thesis path").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Frame", "frame_of"]

#: the centre is rounded to a grid of ``scale * 2**-FRAME_GRID_BITS``: a translation
#: by a multiple of that step (e.g. any integer for models smaller than 2**20 units)
#: then moves the centre by exactly the translation, so exactly representable
#: shifted inputs give bit-identical working coordinates
FRAME_GRID_BITS = 20


@dataclass(frozen=True, slots=True)
class Frame:
    """Working coordinates ``(x - center) / scale`` (private).

    ``scale`` is a power of two (division and multiplication by it are exact) at
    least the bounding-box diagonal; ``center`` is the bounding-box centre on a
    dyadic grid.
    """

    center: np.ndarray
    scale: float

    def to_local(self, x) -> np.ndarray:
        """Input coordinates -> working coordinates (a new array)."""
        return (np.asarray(x, dtype=np.float64) - self.center) / self.scale

    def to_input(self, x) -> np.ndarray:
        """Working coordinates -> input coordinates (a new array)."""
        return np.asarray(x, dtype=np.float64) * self.scale + self.center

    def offsets_to_input(self, normals, offsets) -> np.ndarray:
        """Plane offsets d (n . y = d in working coordinates) -> input coordinates."""
        return np.asarray(offsets) * self.scale + np.asarray(normals) @ self.center


def frame_of(points: np.ndarray) -> Frame:
    """The working frame of validated, finite ``points`` (N >= 1) (private)."""
    lo = points.min(axis=0)
    hi = points.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    if diag == 0.0:  # one distinct point: nothing to rescale
        scale = 1.0
    elif math.isfinite(diag):
        scale = 2.0 ** math.ceil(math.log2(diag))
    else:  # pragma: no cover - an extent beyond the float range
        scale = 2.0**1023
    mid = lo + 0.5 * (hi - lo)
    step = scale * 2.0**-FRAME_GRID_BITS
    center = np.round(mid / step) * step
    if not np.isfinite(center).all():  # pragma: no cover - extreme magnitudes only
        center = mid
    return Frame(center=center, scale=float(scale))
