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
    ids = [int(i) for i in ids]
    p = np.asarray(points, dtype=np.float64)
    n = len(ids)
    if n == 3:
        return [tuple(ids)]
    d = np.roll(p, -1, axis=0) - p  # the sides
    normal = np.cross(d, np.roll(d, -1, axis=0)).sum(axis=0)
    length = float(np.sqrt(normal @ normal))
    if not length > 0.0 or not np.isfinite(length):
        return None
    normal = normal / length
    order = list(range(n))
    out = []
    while len(order) > 3:
        cut = _first_ear(p, order, normal)
        if cut is None:
            return None
        out.append((ids[order[cut - 1]], ids[order[cut]], ids[order[cut + 1]]))
        del order[cut]
    out.append(tuple(ids[k] for k in order))
    return out


def _first_ear(p, order, normal) -> int | None:
    q = p[order]
    m = len(order)
    turn = np.cross(q[1:-1] - q[:-2], q[2:] - q[1:-1]) @ normal
    for i in np.flatnonzero(turn > 0.0) + 1:
        others = np.ones(m, dtype=bool)
        others[i - 1 : i + 2] = False
        if not _inside_xy(q[i - 1 : i + 2, :2], q[others, :2]).any():
            return int(i)
    return None


def _inside_xy(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd test of ``pts`` (K, 2) against the triangle ``tri`` (3, 2), rays to -x."""
    inside = np.zeros(pts.shape[0], dtype=bool)
    x, y = pts[:, 0], pts[:, 1]
    for k in range(3):
        (x0, y0), (x1, y1) = tri[k], tri[(k + 1) % 3]
        spans = ((y0 <= y) & (y1 > y)) | ((y1 <= y) & (y0 > y))
        if not spans.any():
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = (x1 - x0) * (y - y0) / (y1 - y0) + x0
        inside ^= spans & (cross < x)
    return inside
