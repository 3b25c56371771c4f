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

Speed: each point keeps a bound of its distance to its owner (the last one measured
plus how far the owner's corners moved since), measured again only when the bound
is not enough; the triangles around a collapse are written out once (`_ring_corners`)
and the checks run on arrays unpacked once per collapse tried: numba counts the
references of every array handed to a function, and tuples of arrays handed down
to small functions per point and per grid cell spent a third of the kernel's time
there (measured with `perf` on a 94,000-triangle surface: 0.69 -> 0.52 s, the same
collapses bit for bit).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..neighbors._kernels.mesh_distance import closest_sq
from ._fan_kernels import live_around

#: A point stays with its owner while within this share of its squared tolerance of
#: it (else it goes to the nearest triangle around the collapse).
SETTLED = 0.25
#: A point's distance to its owner is known up to this factor without measuring it
#: (`points_stay`: its last distance plus how far the owner's corners moved since,
#: a bound; the factor only keeps rounding on the bound's side).
REACH_SLACK = 1.0 + 1e-9

__all__ = ["link_points", "move_points", "nearest_of", "points_stay"]


@njit(cache=True, nogil=True)
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
def _ring(tri, head, nxt, alive, a, b, tmark, stamp, ring) -> int:
    """The live triangles around ``a`` or ``b``, each once, into ``ring``: how many."""
    stamp[0] += 1
    n = 0
    for w in (a, b):
        n = live_around(head, nxt, alive, w, tmark, stamp[0], ring, n)
    return n


@njit(cache=True)
def _ring_corners(v, tri, ring, n_ring, a, b, x, ns, shared, corners) -> None:
    """Row k of ``corners``: the corners of ``ring[k]`` after ``b`` merges into ``a``
    at ``x`` (9), how far its corner ``a`` or ``b`` moves, 1 when it goes (a triangle
    of ``shared[:ns]``) else 0."""
    move_a = np.sqrt((x[0] - v[a, 0]) ** 2 + (x[1] - v[a, 1]) ** 2 + (x[2] - v[a, 2]) ** 2)
    move_b = np.sqrt((x[0] - v[b, 0]) ** 2 + (x[1] - v[b, 1]) ** 2 + (x[2] - v[b, 2]) ** 2)
    for k in range(n_ring):
        f = ring[k]
        corners[k, 9] = move_b
        for i in range(3):
            u = tri[f, i]
            if u == a or u == b:
                corners[k, 3 * i], corners[k, 3 * i + 1], corners[k, 3 * i + 2] = x[0], x[1], x[2]
                if u == a:
                    corners[k, 9] = move_a
            else:
                corners[k, 3 * i] = v[u, 0]
                corners[k, 3 * i + 1] = v[u, 1]
                corners[k, 3 * i + 2] = v[u, 2]
        gone = f == shared[0] or (ns == 2 and f == shared[1])
        corners[k, 10] = 1.0 if gone else 0.0


@njit(cache=True, inline="always")
def _closest(px, py, pz, c, k) -> float:
    """Squared distance of p to the triangle of row ``k`` of ``c`` (`_ring_corners`)."""
    return closest_sq(
        px, py, pz, c[k, 0], c[k, 1], c[k, 2], c[k, 3], c[k, 4], c[k, 5], c[k, 6], c[k, 7], c[k, 8]
    )


@njit(cache=True)
def _points_kept(pts, tol2, start2, reach, pbuf, pslot, pnew, n_points, corners, n_ring) -> bool:
    """Whether every gathered point (``pbuf``, its owner's ring slot ``pslot``) is
    within its tolerance of a triangle left (`points_stay`): ``pslot`` and ``pnew``
    (the new owner's slot, the distance to it or a bound of it) filled."""
    for i in range(n_points):
        p = pbuf[i]
        limit = max(tol2[p], start2[p])
        k = pslot[i]
        px, py, pz = pts[p, 0], pts[p, 1], pts[p, 2]
        if corners[k, 10] == 0.0:
            # its owner moves one corner: the point is at most as much farther
            far = (reach[p] + corners[k, 9]) * REACH_SLACK
            if far * far <= SETTLED * limit:
                pnew[i] = far
                continue  # its owner stays: near enough
            d = _closest(px, py, pz, corners, k)
            if d <= SETTLED * limit:
                pnew[i] = np.sqrt(d)
                continue
        best, best_k = np.inf, -1
        for j in range(n_ring):
            if corners[j, 10] == 0.0:
                d = _closest(px, py, pz, corners, j)
                if d < best:
                    best, best_k = d, j
        if best_k == -1 or best > limit:
            return False
        pslot[i] = best_k
        pnew[i] = np.sqrt(best)
    return True


@njit(cache=True)
def _all_near(y, n_y, pts, normals, radius, back2, origin, cell, dims, start, order) -> bool:
    """Whether every row of ``y[:n_y]`` is within the tolerance of a point of the grid
    cells around it (``back2``): the point's height over its tangent plane, and its
    distance past its disc. The cell of the row first (where such a point mostly
    is), then the others of the (up to) 3 x 3 x 3 around it."""
    for r in range(n_y):
        y0, y1, y2 = y[r, 0], y[r, 1], y[r, 2]
        c0 = int(np.floor((y0 - origin[0]) / cell))
        c1 = int(np.floor((y1 - origin[1]) / cell))
        c2 = int(np.floor((y2 - origin[2]) / cell))
        inside = 0 <= c0 < dims[0] and 0 <= c1 < dims[1] and 0 <= c2 < dims[2]
        own = (c0 * dims[1] + c1) * dims[2] + c2
        first, last = (start[own], start[own + 1]) if inside else (0, 0)
        if _near_in(y0, y1, y2, first, last, pts, normals, radius, back2, order):
            continue
        i0, j0, k0 = max(c0 - 1, 0), max(c1 - 1, 0), max(c2 - 1, 0)
        ni = min(c0 + 2, dims[0]) - i0
        nj = min(c1 + 2, dims[1]) - j0
        nk = min(c2 + 2, dims[2]) - k0
        found = False
        for c in range(max(ni, 0) * max(nj, 0) * max(nk, 0)):
            i, j, k = i0 + c // (nj * nk), j0 + (c // nk) % nj, k0 + c % nk
            key = (i * dims[1] + j) * dims[2] + k
            if inside and key == own:
                continue
            if _near_in(y0, y1, y2, start[key], start[key + 1], pts, normals, radius, back2, order):
                found = True
                break
        if not found:
            return False
    return True


@njit(cache=True, inline="always")
def _near_in(y0, y1, y2, first, last, pts, normals, radius, back2, order) -> bool:
    """Whether a point of ``order[first:last]`` is within its tolerance of y."""
    for s in range(first, last):
        p = order[s]
        o0, o1, o2 = y0 - pts[p, 0], y1 - pts[p, 1], y2 - pts[p, 2]
        h = o0 * normals[p, 0] + o1 * normals[p, 1] + o2 * normals[p, 2]
        t = np.sqrt(max(o0 * o0 + o1 * o1 + o2 * o2 - h * h, 0.0))
        past = max(t - radius[p], 0.0)
        if h * h + past * past <= back2[p]:
            return True
    return False


@njit(cache=True)
def _near_rows(x, corners, n_ring, y) -> int:
    """Into ``y``: the merged vertex ``x``, then the centroid of every triangle left
    around it (`_ring_corners`); how many rows."""
    y[0, 0], y[0, 1], y[0, 2] = x[0], x[1], x[2]
    n = 1
    for k in range(n_ring):
        if corners[k, 10] != 0.0:
            continue
        for d in range(3):
            c = 0.0
            for i in range(3):
                c += corners[k, 3 * i + d] / 3.0
            y[n, d] = c
        n += 1
    return n


@njit(cache=True)
def points_stay(v, tri, head, nxt, alive, a, b, x, ns, shared, carried, phead, pnext, work):
    """Whether every point carried by a triangle around ``a`` or ``b`` stays within its
    tolerance of a triangle left after ``b`` merges into ``a`` at ``x``
    (``shared[:ns]``: the triangles that go), and those triangles near the points
    (`_all_near`: the merged vertex and every centroid). ``carried``: (points,
    squared tolerances, squared distances at first (a point may stay as far),
    owners, normals, disc radii, squared tolerances of the triangles' distance back,
    grid origin, cell size, cells (3,), each cell's first row in ``order``, the points
    by cell); ``work``: (tmark, stamp, ring, pbuf, pslot, reach, pnew, corners, rows)
    scratch (`collapse_edges`), filled for `move_points`: returns ``(ok, n_ring,
    n_points)``."""
    tmark, stamp, ring, pbuf, pslot, reach, pnew, corners, rows = work
    n_ring = _ring(tri, head, nxt, alive, a, b, tmark, stamp, ring)
    n_points = 0
    for k in range(n_ring):
        p = phead[ring[k]]
        while p != -1:
            pbuf[n_points] = p
            pslot[n_points] = k  # its owner until found otherwise
            n_points += 1
            p = pnext[p]
    _ring_corners(v, tri, ring, n_ring, a, b, x, ns, shared, corners)
    pts, tol2, start2 = carried[0], carried[1], carried[2]
    if not _points_kept(pts, tol2, start2, reach, pbuf, pslot, pnew, n_points, corners, n_ring):
        return False, n_ring, n_points
    n_y = _near_rows(x, corners, n_ring, rows)
    normals, radius, back2 = carried[4], carried[5], carried[6]
    origin, cell, dims, start, order = carried[7], carried[8], carried[9], carried[10], carried[11]
    ok = _all_near(rows, n_y, pts, normals, radius, back2, origin, cell, dims, start, order)
    return ok, n_ring, n_points


@njit(cache=True)
def move_points(n_ring, n_points, phead, pnext, work) -> None:
    """After the collapse `points_stay` allowed: its points to their nearest triangles."""
    _, _, ring, pbuf, pslot, reach, pnew, _, _ = work
    for k in range(n_ring):
        phead[ring[k]] = -1
    for i in range(n_points - 1, -1, -1):
        p, f = pbuf[i], ring[pslot[i]]
        pnext[p] = phead[f]
        phead[f] = p
        reach[p] = pnew[i]
