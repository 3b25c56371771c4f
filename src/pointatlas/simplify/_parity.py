"""Which side of each point is outside, by the parity of ray crossings (private).

A ray leaving a closed surface from one of its points crosses it an even number of
times more when it leaves outward and an odd number when it leaves inward. The
surface here is the points' discs (`PARITY_RADIUS` spacings, in their tangent
planes: the normals' directions only, not their signs), so the answer does not
lean on the other points' orientation, as the winding number does. Rays run along
the axes of a fixed rotated frame (`FRAME`: no CAD face lies along one), both ways,
from each point along the axes at most `PARITY_TILT` off its normal; hits nearer
than `SKIP_SPACINGS` are the point's own sheet, and hits within `MERGE_SPACINGS`
of each other along the ray are one crossing (overlapping discs). Decisions:
docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = [
    "FRAME",
    "MERGE_SPACINGS",
    "PARITY_RADIUS",
    "PARITY_TILT",
    "SKIP_SPACINGS",
    "parity_votes",
]

#: The discs' radius, in point spacings (median nearest-neighbour distance): on a
#: uniform random sample discs of 1.5 spacings leave about a fifth of the surface
#: uncovered (a sphere's 3,000 points: 65 % of them vote exactly +1), 2.5 about 3 %
#: (97 %).
PARITY_RADIUS = 2.5
#: Hits nearer than this along the ray (spacings) are the point's own sheet.
SKIP_SPACINGS = 0.5
#: Hits within this of the previous one along the ray (spacings) are one crossing.
MERGE_SPACINGS = 1.0
#: A ray runs along an axis whose cosine with the point's normal is at least this.
PARITY_TILT = 0.4
#: The rays' frame: a fixed rotation (rows: the axes), no face of an axis-aligned
#: part along one of them.
FRAME = np.linalg.qr(np.array([[0.8, 0.3, -0.5], [0.2, 0.9, 0.4], [0.6, -0.3, 0.7]]))[0].T


def parity_votes(q, normals, spacing: float) -> np.ndarray:
    """Per point: (outward votes - inward votes) / votes of its normal's sign, in
    [-1, 1] (0 where no axis was near enough to its normal), by the parity of the
    crossings of rays along the axes of `FRAME` (see the module's notes).

    Parameters
    ----------
    q : ndarray of shape (N, 3)
        Points.
    normals : ndarray of shape (N, 3)
        Unit normals; their signs are judged, only their directions are used.
    spacing : float
        The points' spacing (median nearest-neighbour distance), > 0.

    Returns
    -------
    votes : ndarray of shape (N,)
    """
    x = np.ascontiguousarray(q @ FRAME.T)
    n = np.ascontiguousarray(normals @ FRAME.T)
    r = PARITY_RADIUS * spacing
    out = np.zeros(q.shape[0])
    count = np.zeros(q.shape[0])
    for axis in range(3):
        b, c = (axis + 1) % 3, (axis + 2) % 3
        lo = x[:, [b, c]].min(axis=0) - r
        cells = np.floor((x[:, [b, c]].max(axis=0) + r - lo) / (2.0 * r)).astype(np.int64) + 1
        start, members = _bins(x[:, b], x[:, c], lo, 2.0 * r, cells, r)
        grid = (lo, 2.0 * r, cells, start, members)
        gaps = (SKIP_SPACINGS * spacing, MERGE_SPACINGS * spacing)
        _cast(x, n, axis, grid, r, gaps, PARITY_TILT, out, count)
    return np.where(count > 0, out / np.maximum(count, 1.0), 0.0)


@njit(cache=True)
def _bins(u, v, lo, size, cells, r):
    """CSR of the discs by the 2-D cells (``size`` wide from ``lo``, ``cells`` of
    them along u and v) their centres' squares of half-width ``r`` reach."""
    n = u.shape[0]
    nu, nv = cells[0], cells[1]
    start = np.zeros(nu * nv + 1, dtype=np.int64)
    for pas in range(2):
        if pas == 1:
            for k in range(nu * nv):
                start[k + 1] += start[k]
            fill = start[:-1].copy()
            members = np.empty(start[-1], dtype=np.int64)
        for i in range(n):
            a0 = int((u[i] - r - lo[0]) / size)
            a1 = int((u[i] + r - lo[0]) / size)
            b0 = int((v[i] - r - lo[1]) / size)
            b1 = int((v[i] + r - lo[1]) / size)
            for a in range(max(a0, 0), min(a1, nu - 1) + 1):
                for b in range(max(b0, 0), min(b1, nv - 1) + 1):
                    k = a * nv + b
                    if pas == 0:
                        start[k + 1] += 1
                    else:
                        members[fill[k]] = i
                        fill[k] += 1
    return start, members


@njit(cache=True, parallel=True)
def _cast(x, n, axis, grid, r, gaps, tilt, out, count):
    """Adds each point's votes along ``axis`` (both ways) to ``out`` and their
    number to ``count``: +1 where the crossings' parity says its normal points out.
    (Separate arguments: unpacked from a tuple in this parallel loop, they stayed 0.)"""
    lo, size, cells, start, members = grid
    skip, merge = gaps
    b, c = (axis + 1) % 3, (axis + 2) % 3
    nv = cells[1]
    r2 = r * r
    for i in prange(x.shape[0]):
        na = n[i, axis]
        if abs(na) < tilt:
            continue
        a = int((x[i, b] - lo[0]) / size)
        bb = int((x[i, c] - lo[1]) / size)
        k = a * nv + bb
        hits = np.empty(start[k + 1] - start[k])
        m = 0
        for s in range(start[k], start[k + 1]):
            j = members[s]
            d = n[j, axis]
            if abs(d) < 1e-3:
                continue
            # the ray x_i + t e_axis meets disc j's plane at t
            t = (
                n[j, 0] * (x[j, 0] - x[i, 0])
                + n[j, 1] * (x[j, 1] - x[i, 1])
                + n[j, 2] * (x[j, 2] - x[i, 2])
            ) / d
            e0 = x[i, 0] - x[j, 0]
            e1 = x[i, 1] - x[j, 1]
            e2 = x[i, 2] - x[j, 2]
            if axis == 0:
                e0 += t
            elif axis == 1:
                e1 += t
            else:
                e2 += t
            if e0 * e0 + e1 * e1 + e2 * e2 <= r2 and abs(t) > skip:
                hits[m] = t
                m += 1
        hits = np.sort(hits[:m])
        ahead = 0
        behind = 0
        last = -np.inf
        for h in range(m):
            if hits[h] > 0.0:
                if ahead == 0 or hits[h] - last > merge:
                    ahead += 1
                last = hits[h]
        first = np.inf
        for h in range(m - 1, -1, -1):
            if hits[h] < 0.0:
                if behind == 0 or first - hits[h] > merge:
                    behind += 1
                first = hits[h]
        # along +axis: out if the normal points that way and the crossings are even
        sign = 1.0 if na > 0.0 else -1.0
        out[i] += sign * (1.0 if ahead % 2 == 0 else -1.0)
        out[i] -= sign * (1.0 if behind % 2 == 0 else -1.0)
        count[i] += 2.0
