"""numba kernels of the collapses bounded by points (`_kernels.collapse_edges` with
points; the bound is checked on every level in tests/simplify/test_decimate.py).

Every point is carried by one live triangle, its owner, within its tolerance of it.
A collapse changes only the triangles around its two vertices: their points are
measured to the triangles left around the merged vertex, at its new position, and
the collapse is refused when one of them would be farther than its tolerance from
all of them; else each goes to the nearest. A point's distance to its owner bounds
its distance to the whole surface, so every level of the sequence keeps every point
within its tolerance (the owner need not be the nearest triangle: the bound is
conservative). And each triangle left around the merged vertex must lie near the
points: the vertex and the triangle's centroid each within the tolerance of a point
of the grid cells around it (as the
distance to the points' discs, `_distance.PointSurface`: height over the point's
tangent plane and distance past its disc), else the collapse is refused too.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..neighbors._kernels.mesh_distance import closest_sq

#: A point stays with its owner while within this share of its squared tolerance of
#: it (else it goes to the nearest triangle around the collapse).
SETTLED = 0.25

__all__ = ["link_points", "move_points", "near_points", "nearest_of", "points_stay"]


@njit(cache=True)
def nearest_of(pts, v, tri, candidates):
    """Of each point's ``candidates`` (P, K) triangles, the nearest and its squared
    distance."""
    owner = np.empty(pts.shape[0], dtype=np.int64)
    dist2 = np.empty(pts.shape[0])
    for p in range(pts.shape[0]):
        best, best_f = np.inf, -1
        for k in range(candidates.shape[1]):
            f = candidates[p, k]
            a, b, c = tri[f, 0], tri[f, 1], tri[f, 2]
            d = closest_sq(
                pts[p, 0],
                pts[p, 1],
                pts[p, 2],
                v[a, 0],
                v[a, 1],
                v[a, 2],
                v[b, 0],
                v[b, 1],
                v[b, 2],
                v[c, 0],
                v[c, 1],
                v[c, 2],
            )
            if d < best:
                best, best_f = d, f
        owner[p], dist2[p] = best_f, best
    return owner, dist2


@njit(cache=True)
def link_points(owner, n_triangles):
    """Each triangle's points as linked lists: ``(phead (T,), pnext (P,))``, -1 ends."""
    phead = np.full(n_triangles, -1, dtype=np.int64)
    pnext = np.full(owner.shape[0], -1, dtype=np.int64)
    for p in range(owner.shape[0] - 1, -1, -1):
        t = owner[p]
        pnext[p] = phead[t]
        phead[t] = p
    return phead, pnext


@njit(cache=True)
def _corner_at(v, u, a, b, x):
    """Vertex ``u``'s position after ``b`` merges into ``a`` at ``x``."""
    if u == a or u == b:
        return x[0], x[1], x[2]
    return v[u, 0], v[u, 1], v[u, 2]


@njit(cache=True)
def _ring(tri, head, nxt, alive, a, b, tmark, stamp, ring) -> int:
    """The live triangles around ``a`` or ``b``, each once, into ``ring``: how many."""
    stamp[0] += 1
    n = 0
    for w in (a, b):
        c = head[w]
        while c != -1:
            f = c // 3
            if alive[f] and tmark[f] != stamp[0]:
                tmark[f] = stamp[0]
                ring[n] = f
                n += 1
            c = nxt[c]
    return n


@njit(cache=True)
def near_points(y0, y1, y2, carried) -> bool:
    """Whether position y is within the tolerance of a point of the grid cells around
    it (its own cell first): the point's height over its tangent plane, and its
    distance past its disc."""
    dims = carried[9]
    origin, cell = carried[7], carried[8]
    c0 = int(np.floor((y0 - origin[0]) / cell))
    c1 = int(np.floor((y1 - origin[1]) / cell))
    c2 = int(np.floor((y2 - origin[2]) / cell))
    if _cell_near(y0, y1, y2, c0, c1, c2, carried):
        return True
    for i in range(max(c0 - 1, 0), min(c0 + 2, dims[0])):
        for j in range(max(c1 - 1, 0), min(c1 + 2, dims[1])):
            for k in range(max(c2 - 1, 0), min(c2 + 2, dims[2])):
                if (i != c0 or j != c1 or k != c2) and _cell_near(y0, y1, y2, i, j, k, carried):
                    return True
    return False


@njit(cache=True)
def _cell_near(y0, y1, y2, i, j, k, carried) -> bool:
    """Whether a point of cell (i, j, k) is near y (`near_points`)."""
    pts, normals, radius, back2 = carried[0], carried[4], carried[5], carried[6]
    dims, start, order = carried[9], carried[10], carried[11]
    if i < 0 or j < 0 or k < 0 or i >= dims[0] or j >= dims[1] or k >= dims[2]:
        return False
    key = (i * dims[1] + j) * dims[2] + k
    for s in range(start[key], start[key + 1]):
        p = order[s]
        o0, o1, o2 = y0 - pts[p, 0], y1 - pts[p, 1], y2 - pts[p, 2]
        h = o0 * normals[p, 0] + o1 * normals[p, 1] + o2 * normals[p, 2]
        t = np.sqrt(max(o0 * o0 + o1 * o1 + o2 * o2 - h * h, 0.0))
        past = max(t - radius[p], 0.0)
        if h * h + past * past <= back2[p]:
            return True
    return False


@njit(cache=True)
def _triangles_near(v, tri, ring, n_ring, a, b, x, ns, shared, carried) -> bool:
    """Whether the merged vertex ``x`` and the centroid of every triangle left around
    it are near the points."""
    if not near_points(x[0], x[1], x[2], carried):
        return False
    for k in range(n_ring):
        f = ring[k]
        if f == shared[0] or (ns == 2 and f == shared[1]):
            continue
        c0 = c1 = c2 = 0.0
        for i in range(3):
            p0, p1, p2 = _corner_at(v, tri[f, i], a, b, x)
            c0 += p0 / 3.0
            c1 += p1 / 3.0
            c2 += p2 / 3.0
        if not near_points(c0, c1, c2, carried):
            return False
    return True


@njit(cache=True)
def points_stay(v, tri, head, nxt, alive, a, b, x, ns, shared, carried, phead, pnext, work):
    """Whether every point carried by a triangle around ``a`` or ``b`` stays within its
    tolerance of a triangle left after ``b`` merges into ``a`` at ``x``
    (``shared[:ns]``: the triangles that go), and those triangles near the points
    (`near_points`). ``carried``: (points, squared tolerances, squared distances at
    first (a point may stay as far), owners, normals, disc radii, squared
    tolerances of the triangles' distance back, grid origin, cell size, cells (3,),
    each cell's first row in ``order``, the points by cell); ``work``: (tmark, stamp,
    ring, pbuf, pbest) scratch, filled for `move_points`: returns ``(ok, n_ring,
    n_points)``."""
    pts, tol2, start2 = carried[0], carried[1], carried[2]
    tmark, stamp, ring, pbuf, pbest = work
    n_ring = _ring(tri, head, nxt, alive, a, b, tmark, stamp, ring)
    n_points = 0
    for k in range(n_ring):
        p = phead[ring[k]]
        while p != -1:
            pbuf[n_points] = p
            pbest[n_points] = ring[k]  # its owner until found otherwise
            n_points += 1
            p = pnext[p]
    for i in range(n_points):
        p = pbuf[i]
        limit = max(tol2[p], start2[p])
        f = pbest[i]
        if f != shared[0] and (ns == 1 or f != shared[1]):
            if _distance2(v, tri, f, a, b, x, pts, p) <= SETTLED * limit:
                continue  # its owner stays: near enough
        best, best_f = np.inf, -1
        for k in range(n_ring):
            f = ring[k]
            if f == shared[0] or (ns == 2 and f == shared[1]):
                continue
            d = _distance2(v, tri, f, a, b, x, pts, p)
            if d < best:
                best, best_f = d, f
        if best_f == -1 or best > limit:
            return False, n_ring, n_points
        pbest[i] = best_f
    ok = _triangles_near(v, tri, ring, n_ring, a, b, x, ns, shared, carried)
    return ok, n_ring, n_points


@njit(cache=True)
def _distance2(v, tri, f, a, b, x, pts, p) -> float:
    """Squared distance of point ``p`` to triangle ``f`` after ``b`` merges into ``a``
    at ``x``."""
    ax, ay, az = _corner_at(v, tri[f, 0], a, b, x)
    bx, by, bz = _corner_at(v, tri[f, 1], a, b, x)
    cx, cy, cz = _corner_at(v, tri[f, 2], a, b, x)
    return closest_sq(pts[p, 0], pts[p, 1], pts[p, 2], ax, ay, az, bx, by, bz, cx, cy, cz)


@njit(cache=True)
def move_points(n_ring, n_points, phead, pnext, work) -> None:
    """After the collapse `points_stay` allowed: its points to their nearest triangles."""
    _, _, ring, pbuf, pbest = work
    for k in range(n_ring):
        phead[ring[k]] = -1
    for i in range(n_points - 1, -1, -1):
        p, f = pbuf[i], pbest[i]
        pnext[p] = phead[f]
        phead[f] = p
