"""numba kernels of the points' surface as tangent discs (`_distance.PointSurface`):
the distance to the nearest of a position's nearest points' discs, and that distance
cut at the points' outline. Serial ``nogil`` kernels over rows ``[i0, i1)``, run on
threads by `_core._threads.run_chunks`; plain-numpy references in
tests/simplify/reference.py (`disc_distance_reference`, `outline_distance_reference`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["disc_rows", "outline_rows"]


@njit(cache=True, nogil=True, inline="always")
def _best_disc(x, d, j, points, normals, radius, i, c):
    """Row ``i``'s nearest disc among its first ``c`` neighbours: (distance, column,
    height over its plane); the first column on ties."""
    best, at, height = np.inf, -1, 0.0
    for a in range(c):
        p = j[i, a]
        h = 0.0
        for e in range(3):
            h += (x[i, e] - points[p, e]) * normals[p, e]
        h = abs(h)
        t = np.sqrt(max(d[i, a] * d[i, a] - h * h, 0.0))
        disc = np.hypot(h, max(t - radius[p], 0.0))
        if at < 0 or disc < best:
            best, at, height = disc, a, h
    return best, at, height


@njit(cache=True, nogil=True)
def disc_rows(x, d, j, points, normals, radius, c, out, i0, i1):
    """``out[i]``: the distance of ``x[i]`` to the nearest disc of its first ``c``
    neighbours ``j[i]`` (at distances ``d[i]``)."""
    for i in range(i0, i1):
        out[i] = _best_disc(x, d, j, points, normals, radius, i, c)[0]


@njit(cache=True, nogil=True)
def outline_rows(x, d, j, points, normals, radius, c, margin, out, i0, i1):
    """``out[i]``: `disc_rows`' distance, or, where ``x[i]``'s neighbours ``j[i]``
    projected onto its nearest disc's plane leave an angular gap wider than pi +
    ``margin`` around it, at least the hypotenuse of its height over that plane and
    its distance past them along the gap's middle."""
    k = j.shape[1]
    off = np.empty((k, 3))
    turn = np.empty(k)
    for i in range(i0, i1):
        near, at, height = _best_disc(x, d, j, points, normals, radius, i, c)
        nb = j[i, at]
        n0, n1, n2 = normals[nb, 0], normals[nb, 1], normals[nb, 2]
        # a basis of the disc's plane: n x (x or y axis), then n x e1
        if abs(n0) < 0.9:
            a0, a1, a2 = 0.0, n2, -n1
        else:
            a0, a1, a2 = -n2, 0.0, n0
        length = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / length, a1 / length, a2 / length
        b0, b1, b2 = n1 * a2 - n2 * a1, n2 * a0 - n0 * a2, n0 * a1 - n1 * a0
        for a in range(k):
            p = j[i, a]
            o0 = points[p, 0] - x[i, 0]
            o1 = points[p, 1] - x[i, 1]
            o2 = points[p, 2] - x[i, 2]
            s = o0 * n0 + o1 * n1 + o2 * n2
            off[a, 0], off[a, 1], off[a, 2] = o0 - s * n0, o1 - s * n1, o2 - s * n2
            turn[a] = np.arctan2(
                off[a, 0] * b0 + off[a, 1] * b1 + off[a, 2] * b2,
                off[a, 0] * a0 + off[a, 1] * a1 + off[a, 2] * a2,
            )
        ordered = np.sort(turn)
        gap, g = ordered[0] + 2.0 * np.pi - ordered[k - 1], k - 1
        for a in range(k - 1):  # the first widest gap, as argmax finds it
            if ordered[a + 1] - ordered[a] > gap or (ordered[a + 1] - ordered[a] == gap and a < g):
                gap, g = ordered[a + 1] - ordered[a], a
        out[i] = near
        if gap <= np.pi + margin:
            continue
        across = ordered[g] + 0.5 * gap
        u0 = np.cos(across) * a0 + np.sin(across) * b0
        u1 = np.cos(across) * a1 + np.sin(across) * b1
        u2 = np.cos(across) * a2 + np.sin(across) * b2
        ahead = -np.inf  # how far the farthest point lies towards the gap
        for a in range(k):
            ahead = max(ahead, off[a, 0] * u0 + off[a, 1] * u1 + off[a, 2] * u2)
        out[i] = max(near, np.hypot(height, max(-ahead, 0.0)))
