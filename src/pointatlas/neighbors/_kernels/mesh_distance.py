"""Exact point-to-triangle-mesh distance: a bounding-volume hierarchy over the
triangles and a nearest-first descent per point (numba kernels; validated input
assumed).

* `closest_sq`: squared distance from a point to one triangle (Ericson, Real-Time
  Collision Detection 5.1.5; a zero-area triangle is the union of its edges);
* `build_bvh`: the hierarchy (median split of the centroids along the longest
  axis by quickselect, leaves of at most ``leaf_size`` triangles, axis-aligned
  boxes);
* `bvh_distances`: the distance of every point, skipping every box farther than
  the best triangle found so far (with a round-off slack, so the minimum is the
  one a brute-force scan over all triangles finds).

The plain-numpy reference is in ``tests/neighbors/test_mesh_distance.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["build_bvh", "bvh_distances", "closest_sq"]

#: depth of the descent stack (the median split keeps depth <= log2(T) + 1)
_STACK = 128
#: points handled by one parallel chunk (one stack allocation per chunk)
_CHUNK = 256


@njit(cache=True)
def _segment_sq(px, py, pz, ax, ay, az, bx, by, bz):
    """Squared distance from p to segment ab (a point when a == b)."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    ll = dx * dx + dy * dy + dz * dz
    t = 0.0
    if ll > 0.0:
        t = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / ll
        t = min(1.0, max(0.0, t))
    qx, qy, qz = ax + t * dx - px, ay + t * dy - py, az + t * dz - pz
    return qx * qx + qy * qy + qz * qz


@njit(cache=True)
def closest_sq(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Squared distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5)."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    scale = (abx * abx + aby * aby + abz * abz) * (acx * acx + acy * acy + acz * acz)
    if nx * nx + ny * ny + nz * nz <= 1e-24 * scale or scale == 0.0:
        # degenerate (collinear or repeated corners): nearest of the three segments
        d = _segment_sq(px, py, pz, ax, ay, az, bx, by, bz)
        d = min(d, _segment_sq(px, py, pz, bx, by, bz, cx, cy, cz))
        return min(d, _segment_sq(px, py, pz, cx, cy, cz, ax, ay, az))
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = ax + v * abx - px, ay + v * aby - py, az + v * abz - pz
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = ax + w * acx - px, ay + w * acy - py, az + w * acz - pz
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx = bx + w * (cx - bx) - px
        qy = by + w * (cy - by) - py
        qz = bz + w * (cz - bz) - pz
        return qx * qx + qy * qy + qz * qz
    denom = va + vb + vc
    v = vb / denom
    w = vc / denom
    qx = ax + abx * v + acx * w - px
    qy = ay + aby * v + acy * w - py
    qz = az + abz * v + acz * w - pz
    return qx * qx + qy * qy + qz * qz


@njit(cache=True)
def build_bvh(corners, leaf_size):
    """Bounding-volume hierarchy over triangles.

    Parameters
    ----------
    corners : (T, 9) float64
        Corner coordinates a, b, c of every triangle (T >= 1).
    leaf_size : int
        Most triangles in a leaf (>= 1).

    Returns
    -------
    boxes : (M, 6) float64
        Box of every node: x0, x1, y0, y1, z0, z1.
    first : (M,) int64
        Leaf: position of its first triangle in ``order``; inner node: index of its
        left child (the right child follows it).
    count : (M,) int64
        Triangles of a leaf; 0 for an inner node.
    order : (T,) int64
        Triangle ids, each leaf's triangles consecutive.
    """
    t = corners.shape[0]
    lo = np.empty((t, 3))
    hi = np.empty((t, 3))
    cen = np.empty((t, 3))
    for f in range(t):
        for k in range(3):
            a, b, c = corners[f, k], corners[f, 3 + k], corners[f, 6 + k]
            lo[f, k] = min(a, min(b, c))
            hi[f, k] = max(a, max(b, c))
            cen[f, k] = (a + b + c) / 3.0
    order = np.arange(t)
    m = 2 * t
    first = np.empty(m, dtype=np.int64)
    count = np.empty(m, dtype=np.int64)
    st_node = np.empty(_STACK, dtype=np.int64)
    st_s = np.empty(_STACK, dtype=np.int64)
    st_e = np.empty(_STACK, dtype=np.int64)
    st_node[0], st_s[0], st_e[0] = 0, 0, t
    top = 1
    n_nodes = 1
    # the tree top-down by the centroids' spans; the boxes after it, bottom-up (each
    # node's the union of its children's: the same boxes, each triangle read once)
    while top > 0:
        top -= 1
        node, s, e = st_node[top], st_s[top], st_e[top]
        if e - s <= leaf_size:
            first[node] = s
            count[node] = e - s
            continue
        clo = np.full(3, np.inf)
        chi = np.full(3, -np.inf)
        for j in range(s, e):
            f = order[j]
            for k in range(3):
                clo[k] = min(clo[k], cen[f, k])
                chi[k] = max(chi[k], cen[f, k])
        axis = 0
        for k in (1, 2):
            if chi[k] - clo[k] > chi[axis] - clo[axis]:
                axis = k
        mid = (s + e) // 2
        _select(order, cen, axis, s, e, mid)
        first[node] = n_nodes
        count[node] = 0
        st_node[top], st_s[top], st_e[top] = n_nodes, s, mid
        st_node[top + 1], st_s[top + 1], st_e[top + 1] = n_nodes + 1, mid, e
        top += 2
        n_nodes += 2
    boxes = np.empty((n_nodes, 6))
    for node in range(n_nodes - 1, -1, -1):  # children come after their parent
        for k in range(3):
            boxes[node, 2 * k] = np.inf
            boxes[node, 2 * k + 1] = -np.inf
        if count[node] > 0:  # a leaf: its triangles
            for j in range(first[node], first[node] + count[node]):
                f = order[j]
                for k in range(3):
                    boxes[node, 2 * k] = min(boxes[node, 2 * k], lo[f, k])
                    boxes[node, 2 * k + 1] = max(boxes[node, 2 * k + 1], hi[f, k])
            continue
        for child in (first[node], first[node] + 1):
            for k in range(3):
                boxes[node, 2 * k] = min(boxes[node, 2 * k], boxes[child, 2 * k])
                boxes[node, 2 * k + 1] = max(boxes[node, 2 * k + 1], boxes[child, 2 * k + 1])
    return boxes, first[:n_nodes].copy(), count[:n_nodes].copy(), order


@njit(cache=True)
def _select(order, cen, axis, s, e, k):
    """Reorder ``order[s:e]`` so that the triangles before position ``k`` have
    centroids at most, and those from ``k`` on at least, the k-th smallest along
    ``axis`` (Hoare's quickselect, median-of-three pivots; O(e - s) expected)."""
    lo, hi = s, e - 1
    while hi > lo:
        a = cen[order[lo], axis]
        b = cen[order[(lo + hi) // 2], axis]
        c = cen[order[hi], axis]
        pivot = max(min(a, b), min(max(a, b), c))
        i, j = lo, hi
        while i <= j:
            while cen[order[i], axis] < pivot:
                i += 1
            while cen[order[j], axis] > pivot:
                j -= 1
            if i <= j:
                order[i], order[j] = order[j], order[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return


@njit(cache=True, inline="always")
def _box_sq(px, py, pz, boxes, node):
    """Squared distance from p to the box of ``node`` (0 inside)."""
    gx = max(boxes[node, 0] - px, px - boxes[node, 1], 0.0)
    gy = max(boxes[node, 2] - py, py - boxes[node, 3], 0.0)
    gz = max(boxes[node, 4] - pz, pz - boxes[node, 5], 0.0)
    return gx * gx + gy * gy + gz * gz


@njit(cache=True, parallel=True)
def bvh_distances(
    points, leaf_corners, boxes, first, count, start, slack_rel, slack_abs, out, enough, bound, stop
):
    """Distance from every point to the nearest triangle of a `build_bvh` hierarchy.

    Parameters
    ----------
    points : (N, 3) float64
    leaf_corners : (T, 9) float64
        ``corners[order]``: the triangles in leaf order.
    boxes, first, count : arrays of `build_bvh`
    start : (N,) or (0,) int64
        Position (in leaf order) of a triangle to measure first, -1 for none; an
        empty array: none for every point. A hinted point also measures the nearest
        triangle found for the chunk's previous point (near points one after the
        other share it). Only the order of the search changes (the first distances
        bound the descent), not the minimum found.
    slack_rel, slack_abs : float
        A box is skipped when its squared distance exceeds
        ``best * (1 + slack_rel) + slack_abs`` (round-off margin of the bound).
    out : (N,) float64
        Distances (written).
    enough : float
        A squared distance at which a point's search stops (0: exact); its value is
        then some distance at most ``sqrt(enough)``.
    bound : float
        Boxes farther than ``bound`` (with the margin) are skipped, and the first
        point found farther than ``bound`` sets ``stop[0] = 1``: the points not yet
        measured are skipped (their ``out`` is undefined). ``inf``: neither.
    stop : (1,) int64
        Set to 1 when a point is farther than ``bound`` (read, never cleared).
    """
    n = points.shape[0]
    n_chunks = (n + _CHUNK - 1) // _CHUNK
    grow = 1.0 + slack_rel
    cut = bound * bound * grow + slack_abs
    hinted = start.shape[0] > 0
    for ch in prange(n_chunks):
        st = np.empty(_STACK, dtype=np.int64)
        sd = np.empty(_STACK)
        last = -1  # the nearest triangle of the chunk's previous point
        for i in range(ch * _CHUNK, min(n, (ch + 1) * _CHUNK)):
            if stop[0] != 0:
                break
            px, py, pz = points[i, 0], points[i, 1], points[i, 2]
            best = np.inf
            if hinted and start[i] >= 0:
                best = _leaf_sq(px, py, pz, leaf_corners, start[i])
                if best > enough and last >= 0:
                    best = min(best, _leaf_sq(px, py, pz, leaf_corners, last))
            if best <= enough:
                out[i] = np.sqrt(best)
                continue
            st[0] = 0
            sd[0] = 0.0
            top = 1
            while top > 0:
                top -= 1
                node = st[top]
                limit = min(best * grow + slack_abs, cut)
                if sd[top] > limit:
                    continue
                if count[node] > 0:
                    for j in range(first[node], first[node] + count[node]):
                        d = _leaf_sq(px, py, pz, leaf_corners, j)
                        if d < best:
                            best = d
                            last = j
                    if best <= enough:
                        break
                    continue
                left = first[node]
                dl = _box_sq(px, py, pz, boxes, left)
                dr = _box_sq(px, py, pz, boxes, left + 1)
                # push the farther child first: the nearer one is taken next
                if dl <= dr:
                    if dr <= limit:
                        st[top], sd[top] = left + 1, dr
                        top += 1
                    if dl <= limit:
                        st[top], sd[top] = left, dl
                        top += 1
                else:
                    if dl <= limit:
                        st[top], sd[top] = left, dl
                        top += 1
                    if dr <= limit:
                        st[top], sd[top] = left + 1, dr
                        top += 1
            out[i] = np.sqrt(best)
            if out[i] > bound:
                stop[0] = 1


@njit(cache=True, inline="always")
def _leaf_sq(px, py, pz, leaf_corners, j):
    """Squared distance from p to the triangle at leaf position ``j``."""
    return closest_sq(
        px,
        py,
        pz,
        leaf_corners[j, 0],
        leaf_corners[j, 1],
        leaf_corners[j, 2],
        leaf_corners[j, 3],
        leaf_corners[j, 4],
        leaf_corners[j, 5],
        leaf_corners[j, 6],
        leaf_corners[j, 7],
        leaf_corners[j, 8],
    )
