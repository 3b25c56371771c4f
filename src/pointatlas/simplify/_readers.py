"""What common readers make of a polygon in a file, so OUT is written for them.

A polygon file leaves the triangulation to the reader, and readers differ:

- trimesh (and most OBJ loaders) fan a polygon from its first vertex;
- Open3D's PLY reader clips ears: it takes the face normal from the sum of the
  corners' cross products, then repeatedly cuts the first corner among the second
  to the second-to-last that turns the polygon's way (strictly) and whose triangle
  holds no other corner, deciding "holds" in the x-y coordinates whatever the
  polygon's plane; when no corner qualifies it refuses the whole file.

`fan_triangles` and `ear_clip_triangles` reproduce both (written from the readers'
documented behaviour and read sources), so `face_polygons` can start each polygon
where both readers get a triangulation that closes the mesh, and split it where
none does.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["ear_clip_triangles", "fan_triangles"]


def fan_triangles(ids) -> list[tuple[int, int, int]]:
    """The fan from the first vertex: (v0, v_i, v_i+1).

    Examples
    --------
    >>> fan_triangles([4, 5, 6, 7])
    [(4, 5, 6), (4, 6, 7)]
    """
    ids = [int(i) for i in ids]
    return [(ids[0], ids[i], ids[i + 1]) for i in range(1, len(ids) - 1)]


def ear_clip_triangles(points: np.ndarray, ids) -> list[tuple[int, int, int]] | None:
    """Open3D's ear clipping of one polygon (see the module), or None where it fails.

    Examples
    --------
    >>> sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    >>> ear_clip_triangles(sq, [0, 1, 2, 3])
    [(0, 1, 2), (0, 2, 3)]
    >>> flat = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [1, 0, 0.0]])
    >>> ear_clip_triangles(flat, [0, 1, 2, 3]) is None  # no corner turns
    True
    """
    ids = np.asarray([int(i) for i in ids], dtype=np.int64)
    tri, ok = _ear_clip(np.ascontiguousarray(points, dtype=np.float64))
    if not ok:
        return None
    return [tuple(int(i) for i in ids[t]) for t in tri]


@njit(cache=True)
def _ear_clip(p):
    """Corners (n - 2, 3) of the ears cut from polygon ``p`` (n, 3), and whether
    every cut was found (the reader's loop, one corner at a time)."""
    n = p.shape[0]
    out = np.zeros((max(n - 2, 0), 3), dtype=np.int64)
    if n == 3:
        out[0, 0], out[0, 1], out[0, 2] = 0, 1, 2
        return out, True
    normal = np.zeros(3)
    for i in range(n):
        d0 = p[(i + 1) % n] - p[i]
        d1 = p[(i + 2) % n] - p[(i + 1) % n]
        normal += np.cross(d0, d1)
    length = np.sqrt(normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2)
    if not (length > 0.0 and np.isfinite(length)):
        return out, False
    normal = normal / length
    order = np.arange(n)
    m, k = n, 0
    while m > 3:
        cut = _first_ear(p, order, m, normal)
        if cut < 0:
            return out, False
        out[k, 0], out[k, 1], out[k, 2] = order[cut - 1], order[cut], order[cut + 1]
        k += 1
        for j in range(cut, m - 1):
            order[j] = order[j + 1]
        m -= 1
    out[k, 0], out[k, 1], out[k, 2] = order[0], order[1], order[2]
    return out, True


@njit(cache=True)
def _first_ear(p, order, m, normal) -> int:
    """The first corner among the second to the second-to-last that turns the
    polygon's way and whose triangle holds no other corner (in x-y); -1 if none."""
    for i in range(1, m - 1):
        a, b, c = p[order[i - 1]], p[order[i]], p[order[i + 1]]
        turn = np.cross(b - a, c - b)
        if turn[0] * normal[0] + turn[1] * normal[1] + turn[2] * normal[2] <= 0.0:
            continue
        held = False
        for j in range(m):
            if i - 1 <= j <= i + 1:
                continue
            if _inside_xy(a, b, c, p[order[j]]):
                held = True
                break
        if not held:
            return i
    return -1


@njit(cache=True)
def _inside_xy(a, b, c, x) -> bool:
    """Even-odd test of point ``x`` against triangle (a, b, c) in x-y, ray to -x."""
    inside = False
    for k in range(3):
        p0 = a if k == 0 else b if k == 1 else c
        p1 = b if k == 0 else c if k == 1 else a
        x0, y0, x1, y1 = p0[0], p0[1], p1[0], p1[1]
        if (y0 <= x[1] and y1 > x[1]) or (y1 <= x[1] and y0 > x[1]):
            if (x1 - x0) * (x[1] - y0) / (y1 - y0) + x0 < x[0]:
                inside = not inside
    return inside
