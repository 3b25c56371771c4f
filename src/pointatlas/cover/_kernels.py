"""numba kernels of the cover room (inputs validated by the callers).

Every kernel has a plain-numpy reference in ``tests/cover/reference.py``.
Coordinates arrive in lattice units (divided by the grid scale s, translated so the
bounding box starts at the origin); balls are closed (distance <= radius).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_SQRT3 = np.sqrt(3.0)


@njit(cache=True, parallel=True)
def cubic_membership(y, dim, r2_even, r2_odd, shape):
    """Balls of the integer lattice (Prop. 4 for dim 3, Prop. 5 ii for dim 2) holding each point.

    ``y`` is (N, 3) float64 in lattice units (only the first ``dim`` columns are used);
    a ball sits at every integer point c with radius^2 ``r2_even`` when sum(c) is
    even and ``r2_odd`` when odd. Both radii are < 1, so only the 2^dim corners of a
    point's unit cell can hold it. ``shape`` (3,) int64 are the lattice sizes per axis
    (corner indices 0..shape-1). Returns (codes (N, 2^dim) int64, ascending,
    padded with -1; counts (N,) int64) with code = (i * shape[1] + j) * shape[2] + k.
    """
    n = y.shape[0]
    width = 1 << dim
    codes = np.full((n, width), -1, dtype=np.int64)
    counts = np.zeros(n, dtype=np.int64)
    for p in prange(n):
        base0 = np.int64(np.floor(y[p, 0]))
        base1 = np.int64(np.floor(y[p, 1]))
        base2 = np.int64(np.floor(y[p, 2])) if dim == 3 else np.int64(0)
        m = 0
        for o0 in range(2):
            for o1 in range(2):
                for o2 in range(2 if dim == 3 else 1):
                    c0 = base0 + o0
                    c1 = base1 + o1
                    c2 = base2 + o2
                    d0 = y[p, 0] - c0
                    d1 = y[p, 1] - c1
                    d2 = (y[p, 2] - c2) if dim == 3 else 0.0
                    dd = d0 * d0 + d1 * d1 + d2 * d2
                    r2 = r2_even if (c0 + c1 + c2) % 2 == 0 else r2_odd
                    if dd <= r2:
                        codes[p, m] = (c0 * shape[1] + c1) * shape[2] + c2
                        m += 1
        counts[p] = m
    return codes, counts


@njit(cache=True, parallel=True)
def tiling_membership(y, r2, shape, offset):
    """Balls at the vertices of the triangular tiling {3, 6} with unit edge (Prop. 5 i).

    Vertex (i, j) sits at (i + j / 2, j * sqrt(3) / 2); ``y`` (N, 3) float64 holds the
    points in edge units (z ignored). A ball of radius <= sqrt(3)/2 (squared ``r2``)
    reaches only triangles at its vertex, so the four corners of the point's rhombus
    (skewed cell) are the candidates. ``offset`` (2,) int64 is subtracted from (i, j)
    so codes start at 0; ``shape`` (2,) int64 the index sizes; code = i * shape[1] + j.
    Returns (codes (N, 4) ascending, -1 padded; counts (N,)).
    """
    n = y.shape[0]
    codes = np.full((n, 4), -1, dtype=np.int64)
    counts = np.zeros(n, dtype=np.int64)
    for p in prange(n):
        u = y[p, 0] - y[p, 1] / _SQRT3
        v = 2.0 * y[p, 1] / _SQRT3
        bu = np.int64(np.floor(u))
        bv = np.int64(np.floor(v))
        m = 0
        for ou in range(2):
            for ov in range(2):
                i = bu + ou
                j = bv + ov
                dx = y[p, 0] - (i + 0.5 * j)
                dy = y[p, 1] - 0.5 * _SQRT3 * j
                if dx * dx + dy * dy <= r2:
                    codes[p, m] = (i - offset[0]) * shape[1] + (j - offset[1])
                    m += 1
        counts[p] = m
    return codes, counts
