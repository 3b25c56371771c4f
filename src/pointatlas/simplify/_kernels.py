"""numba kernels of the decimation step (`_decimate.py`); plain-numpy references in
tests/simplify/reference.py."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["collapse_position", "turns_over"]


@njit(cache=True)
def _cost(q, x, y, z) -> float:
    p = (x, y, z, 1.0)
    total = 0.0
    for i in range(4):
        row = 0.0
        for j in range(4):
            row += q[i, j] * p[j]
        total += p[i] * row
    return total


@njit(cache=True)
def collapse_position(q, a, b):
    """``(cost, x, y, z)``: where the quadric ``q`` (4, 4) of an edge (a, b) is least.

    The minimiser of the quadric when its 3x3 part is well conditioned (its
    determinant above 1e-10 of the product of its row norms), else nothing; then the
    cheapest of the minimiser, the two ends and the midpoint.
    """
    best = _cost(q, a[0], a[1], a[2])
    bx, by, bz = a[0], a[1], a[2]
    c = _cost(q, b[0], b[1], b[2])
    if c < best:
        best, bx, by, bz = c, b[0], b[1], b[2]
    mx, my, mz = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    c = _cost(q, mx, my, mz)
    if c < best:
        best, bx, by, bz = c, mx, my, mz
    m00, m01, m02 = q[0, 0], q[0, 1], q[0, 2]
    m10, m11, m12 = q[1, 0], q[1, 1], q[1, 2]
    m20, m21, m22 = q[2, 0], q[2, 1], q[2, 2]
    c0 = m11 * m22 - m12 * m21
    c1 = m12 * m20 - m10 * m22
    c2 = m10 * m21 - m11 * m20
    det = m00 * c0 + m01 * c1 + m02 * c2
    scale = (
        np.sqrt(m00 * m00 + m01 * m01 + m02 * m02)
        * np.sqrt(m10 * m10 + m11 * m11 + m12 * m12)
        * np.sqrt(m20 * m20 + m21 * m21 + m22 * m22)
    )
    if scale > 0.0 and abs(det) > 1e-10 * scale:
        r0, r1, r2 = -q[0, 3], -q[1, 3], -q[2, 3]
        x = (r0 * c0 + r1 * (m02 * m21 - m01 * m22) + r2 * (m01 * m12 - m02 * m11)) / det
        y = (r0 * c1 + r1 * (m00 * m22 - m02 * m20) + r2 * (m02 * m10 - m00 * m12)) / det
        z = (r0 * c2 + r1 * (m01 * m20 - m00 * m21) + r2 * (m00 * m11 - m01 * m10)) / det
        c = _cost(q, x, y, z)
        if c < best:
            best, bx, by, bz = c, x, y, z
    return best, bx, by, bz


@njit(cache=True)
def turns_over(v, faces, w, x) -> bool:
    """Whether moving vertex ``w`` to ``x`` turns a triangle of ``faces`` (k, 3) by
    90 degrees or more, or shrinks its area below 1e-6 of what it was."""
    for k in range(faces.shape[0]):
        p = np.empty((3, 3))
        for i in range(3):
            vi = faces[k, i]
            for d in range(3):
                p[i, d] = x[d] if vi == w else v[vi, d]
        q = np.empty((3, 3))
        for i in range(3):
            for d in range(3):
                q[i, d] = v[faces[k, i], d]
        before = np.cross(q[1] - q[0], q[2] - q[0])
        after = np.cross(p[1] - p[0], p[2] - p[0])
        bb = before[0] * before[0] + before[1] * before[1] + before[2] * before[2]
        ab = after[0] * before[0] + after[1] * before[1] + after[2] * before[2]
        aa = after[0] * after[0] + after[1] * after[1] + after[2] * after[2]
        if ab <= 0.0 or aa <= 1e-12 * bb:
            return True
    return False
