"""numba kernels of the synthetic data room (private)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["weighted_corners"]


@njit(cache=True)
def weighted_corners(verts, tri, face, weights):
    """Row i: ``weights[0, i] a + weights[1, i] b + weights[2, i] c``, a, b, c the
    corners of triangle ``face[i]``; the products and sums in numpy's order
    (`_sample.face_points`' expression), so the same values bit for bit."""
    n = face.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        f = face[i]
        a, b, c = tri[f, 0], tri[f, 1], tri[f, 2]
        wa, wb, wc = weights[0, i], weights[1, i], weights[2, i]
        for j in range(3):
            out[i, j] = wa * verts[a, j] + wb * verts[b, j] + wc * verts[c, j]
    return out
