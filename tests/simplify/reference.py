"""Plain numpy references for the simplify kernels."""

from __future__ import annotations

import numpy as np


def _segment_distance(p, a, b):
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / max(np.dot(ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t * ab))


def point_triangle_distance_reference(points, vertices, triangles):
    """Distance to the nearest triangle: the plane distance when the projection falls
    inside the triangle, else the nearest of its three edges."""
    out = np.empty(len(points))
    for i, p in enumerate(points):
        best = np.inf
        for tri in triangles:
            a, b, c = vertices[tri]
            n = np.cross(b - a, c - a)
            nn = np.dot(n, n)
            d = np.inf
            if nn > 0:
                q = p - np.dot(p - a, n) / nn * n
                # barycentric inside test
                v0, v1, v2 = b - a, c - a, q - a
                d00, d01, d11 = v0 @ v0, v0 @ v1, v1 @ v1
                d20, d21 = v2 @ v0, v2 @ v1
                den = d00 * d11 - d01 * d01
                v = (d11 * d20 - d01 * d21) / den
                w = (d00 * d21 - d01 * d20) / den
                if v >= 0 and w >= 0 and v + w <= 1:
                    d = abs(np.dot(p - a, n)) / np.sqrt(nn)
            d = min(
                d,
                _segment_distance(p, a, b),
                _segment_distance(p, b, c),
                _segment_distance(p, c, a),
            )
            best = min(best, d)
        out[i] = best
    return out


def row_majority_reference(nb):
    """Majority label per row by comparing all pairs (O(N k^2) memory): the own label
    (column 0) wins ties, other ties the label seen first in the row."""
    counts = (nb[:, :, None] == nb[:, None, :]).sum(axis=1).astype(np.float64)
    counts[:, 0] += 0.5
    return nb[np.arange(nb.shape[0]), counts.argmax(axis=1)]


def collapse_position_reference(q, a, b):
    """The cheapest of the quadric's minimiser (when its 3x3 part is well conditioned),
    the two ends and the midpoint: ``(cost, x, y, z)``."""
    candidates = [np.asarray(a, float), np.asarray(b, float), 0.5 * (np.asarray(a) + b)]
    m = q[:3, :3]
    scale = np.prod(np.linalg.norm(m, axis=1))
    if scale > 0 and abs(np.linalg.det(m)) > 1e-10 * scale:
        candidates.append(np.linalg.solve(m, -q[:3, 3]))
    costs = [float(np.append(p, 1.0) @ q @ np.append(p, 1.0)) for p in candidates]
    k = int(np.argmin(costs))
    return (costs[k], *candidates[k].tolist())


def turns_over_reference(v, faces, w, x):
    for f in faces:
        p = v[f].copy()
        before = np.cross(p[1] - p[0], p[2] - p[0])
        p[f == w] = x
        after = np.cross(p[1] - p[0], p[2] - p[0])
        if before @ after <= 0 or after @ after <= 1e-12 * (before @ before):
            return True
    return False
