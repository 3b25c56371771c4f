"""numba kernel of the collapses that would make the surface pass through itself
more (`_kernels.collapse_edges`; private, kernels assume validated input).

A collapse moves one vertex: only the triangles around it change (its new fan; the
two on the edge go), so only pairs with one of them can begin or stop crossing. The
pairs of the new fan with itself and with every live triangle on one of its
vertices (the fan's 1-ring) are tested by `_crossing_kernels.pair_crosses` with the
tolerances of the measure (`_crossings.crossing_pairs`); where some cross, the
collapse is refused if more pairs cross than did before among the old fan, the two
triangles that go and the ring. So a surface that passed through itself before (a
voxel surface's thin parts) may still be decimated there, and a collapse that
takes a crossing away is taken. Pairs farther apart (a fold across a thin part) are
not seen: measured on the mesh path, every crossing pair of its outputs had, at the
collapse that made it, a triangle of the fan and one on its vertices.

Speed: the near triangles' corners, normals and boxes are written once per collapse
tried; each pair is first tested on its boxes, then on the sides of each one's
plane that the other's corners lie on (`_one_side`, `pair_crosses`' first
rejections), all on the whole arrays (a view per pair cost more than the test).
On flat faces every pair is in one plane and reaches the in-plane test, which sets
most apart by their angles at the shared corner or a side's line first
(`_crossing_kernels._angles_apart`, `_edge_apart`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._crossing_kernels import pair_crosses

__all__ = ["fan_crosses", "fan_scratch", "live_around"]


@njit(cache=True)
def fan_scratch(n_triangles):
    """`fan_crosses`' scratch for a mesh of ``n_triangles``: the near triangles (the
    fan, the ring, the two on the edge), a stamp per triangle, and their corners,
    unit normals and boxes."""
    n = max(n_triangles, 1) + 2
    return (
        np.empty(n, dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.zeros(1, dtype=np.int64),
        np.empty((n, 3, 3)),
        np.empty((n, 3)),
        np.empty((n, 2, 3)),
        np.empty((3, 3)),
    )


@njit(cache=True, inline="always")
def _fill(v, tri, f, a, b, x, moved, corners, normals, boxes, m) -> None:
    """Row ``m`` of ``corners`` (M, 3, 3), ``normals`` (M, 3) and ``boxes`` (M, 2,
    3): triangle ``f``'s corners (``a`` and ``b`` at ``x`` where ``moved``), its unit
    normal (zero without area) and its box (on the whole arrays: no view per row)."""
    for i in range(3):
        u = tri[f, i]
        for k in range(3):
            corners[m, i, k] = x[k] if moved and (u == a or u == b) else v[u, k]
    e0 = corners[m, 1, 0] - corners[m, 0, 0]
    e1 = corners[m, 1, 1] - corners[m, 0, 1]
    e2 = corners[m, 1, 2] - corners[m, 0, 2]
    g0 = corners[m, 2, 0] - corners[m, 0, 0]
    g1 = corners[m, 2, 1] - corners[m, 0, 1]
    g2 = corners[m, 2, 2] - corners[m, 0, 2]
    n0, n1, n2 = e1 * g2 - e2 * g1, e2 * g0 - e0 * g2, e0 * g1 - e1 * g0
    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if length > 0.0:
        normals[m, 0], normals[m, 1], normals[m, 2] = n0 / length, n1 / length, n2 / length
    else:
        normals[m, 0] = normals[m, 1] = normals[m, 2] = 0.0
    for k in range(3):
        boxes[m, 0, k] = min(corners[m, 0, k], min(corners[m, 1, k], corners[m, 2, k]))
        boxes[m, 1, k] = max(corners[m, 0, k], max(corners[m, 1, k], corners[m, 2, k]))


@njit(cache=True, inline="always")
def _common(tri, f, g, a, b, merged):
    """``(n, i, j)``: the corners triangles f and g share (``a`` and ``b`` one vertex
    where ``merged``), and where the last one is in each."""
    n = 0
    si = -1
    sj = -1
    for i in range(3):
        u = tri[f, i]
        if merged and u == b:
            u = a
        for j in range(3):
            w = tri[g, j]
            if merged and w == b:
                w = a
            if u == w:
                n += 1
                si = i
                sj = j
    return n, si, sj


@njit(cache=True, inline="always")
def _boxes_apart(boxes, k, m, tol) -> bool:
    """Whether the boxes of the near triangles k and m are apart by more than
    ``tol`` (on the whole arrays: a view per pair cost more than the test)."""
    for i in range(3):
        if boxes[k, 0, i] > boxes[m, 1, i] + tol or boxes[k, 1, i] + tol < boxes[m, 0, i]:
            return True
    return False


@njit(cache=True, inline="always")
def _one_side(corners, normals, k, m, skip, cross) -> bool:
    """Whether the corners of near triangle m but its ``skip``-th (the one it shares
    with k; -1: none) lie on one side of k's plane, none farther than ``tol`` on the
    other, and one farther than ``flat_tol``: then `pair_crosses` is False (the two
    are not in one plane, and m only touches k's plane at most)."""
    tol, flat_tol = cross
    lo = hi = 0.0
    far = False
    for j in range(3):
        d = 0.0
        if j != skip:
            for i in range(3):
                d += normals[k, i] * (corners[m, j, i] - corners[k, 0, i])
        lo = min(lo, d)
        hi = max(hi, d)
        far = far or abs(d) > flat_tol
    return far and (hi <= tol or -lo <= tol)


@njit(cache=True, inline="always")
def live_around(head, nxt, alive, w, seen, stamp, out, n) -> int:
    """The live triangles on vertex ``w`` (corner lists ``head`` / ``nxt``) not yet
    ``seen`` at ``stamp`` appended to ``out`` from row ``n`` (and marked): the new
    count."""
    c = head[w]
    while c != -1:
        f = c // 3
        if alive[f] and seen[f] != stamp:
            seen[f] = stamp
            out[n] = f
            n += 1
        c = nxt[c]
    return n


@njit(cache=True)
def _gather(tri, head, nxt, alive, a, b, shared, ns, scratch):
    """``(n_fan, n_all)``: the live triangles on ``a`` or ``b`` but the collapse's
    ``shared`` (the fan), then the live triangles on the fan's other vertices that are
    not on ``a`` or ``b`` (its ring), then the ``shared``, into the scratch's first
    array."""
    near, seen, stamp = scratch[0], scratch[1], scratch[2]
    stamp[0] += 1
    for k in range(ns):
        seen[shared[k]] = stamp[0]
    n_fan = 0
    for w in (a, b):
        n_fan = live_around(head, nxt, alive, w, seen, stamp[0], near, n_fan)
    n_all = n_fan
    for k in range(n_fan):
        for i in range(3):
            u = tri[near[k], i]
            if u != a and u != b:
                n_all = live_around(head, nxt, alive, u, seen, stamp[0], near, n_all)
    for k in range(ns):
        near[n_all + k] = shared[k]
    return n_fan, n_all


@njit(cache=True)
def _crossings(tri, a, b, moved, n_changed, n_all, cross, scratch) -> int:
    """How many pairs of near triangles with one of the first ``n_changed`` cross
    (their corners, normals and boxes filled; ``a`` and ``b`` one vertex where
    ``moved``)."""
    near, corners, normals, boxes, work = scratch[0], scratch[3], scratch[4], scratch[5], scratch[6]
    count = 0
    for k in range(n_changed):
        f = near[k]
        for m in range(k + 1, n_all):
            g = near[m]
            if _boxes_apart(boxes, k, m, cross[0]):
                continue
            n, ip, iq = _common(tri, f, g, a, b, moved)
            if (
                n > 1
                or _one_side(corners, normals, k, m, iq, cross)
                or _one_side(corners, normals, m, k, ip, cross)
            ):
                continue
            if pair_crosses(
                corners[k], corners[m], normals[k], normals[m], ip, iq, cross[0], cross[1], work
            ):
                count += 1
    return count


@njit(cache=True)
def fan_crosses(v, tri, head, nxt, alive, a, b, x, shared, ns, cross, scratch) -> bool:
    """Whether collapsing edge (a, b) to ``x`` makes more pairs of triangles cross
    among the new fan and the triangles on its vertices than crossed among the old
    fan, the ``ns`` triangles on the edge (``shared``) and those (``tri``: the live
    triangles, corner lists ``head`` / ``nxt``; ``cross``: ``(tol, flat_tol)`` of
    `_crossing_kernels.pair_crosses`; ``scratch``: `fan_scratch`)."""
    n_fan, n_all = _gather(tri, head, nxt, alive, a, b, shared, ns, scratch)
    near, corners, normals, boxes = scratch[0], scratch[3], scratch[4], scratch[5]
    for m in range(n_all):
        _fill(v, tri, near[m], a, b, x, m < n_fan, corners, normals, boxes, m)
    after = _crossings(tri, a, b, True, n_fan, n_all, cross, scratch)
    if after == 0:
        return False
    # before: the fan and the two on the edge first (the ring is where it was)
    for k in range(ns):
        near[n_fan + k], near[n_all + k] = near[n_all + k], near[n_fan + k]
    for m in range(n_fan + ns):
        _fill(v, tri, near[m], a, b, x, False, corners, normals, boxes, m)
    for m in range(n_all, n_all + ns):
        _fill(v, tri, near[m], a, b, x, False, corners, normals, boxes, m)
    return after > _crossings(tri, a, b, False, n_fan + ns, n_all + ns, cross, scratch)
