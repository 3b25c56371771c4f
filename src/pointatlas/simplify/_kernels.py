"""numba kernels of the decimation step (`_decimate.py`) and of the robust path's field
(`_reconstruct.py`); plain-numpy references in tests/simplify/reference.py."""

from __future__ import annotations

import numpy as np
from numba import njit

from .._core._threads import run_chunks
from ._bound_kernels import link_points, move_points, points_stay
from ._fan_kernels import fan_crosses, fan_scratch
from ._heap import heap_grown, heap_pop, heap_push, heapify
from ._plane_kernels import collapse_position, edge_planes, planes_position

__all__ = ["add_rows", "band_field", "collapse_edges", "collapse_position", "replay", "turns_over"]

#: A collapse whose merged vertex would lie on more flat regions than this is refused.
_MAX_PLANES = 16


@njit(cache=True)
def turns_over(v, faces, w, x) -> bool:
    """Whether moving vertex ``w`` to ``x`` turns a triangle of ``faces`` (k, 3) by
    90 degrees or more, or shrinks its area below 1e-6 of what it was."""
    for k in range(faces.shape[0]):
        if _flips(v, faces, k, w, x):
            return True
    return False


@njit(cache=True)
def _flips(v, tri, f, w, x) -> bool:
    """Whether moving vertex ``w`` of triangle ``f`` to ``x`` turns it by 90 degrees or
    more, or shrinks its area below 1e-6 of what it was. On scalars (the collapse
    loop asks this of every triangle around an edge it tries: arrays here made it
    allocate a few million times on a fan of a flat face); the same products and
    sums as ``np.cross`` of the edge vectors."""
    i0, i1, i2 = tri[f, 0], tri[f, 1], tri[f, 2]
    b00, b01, b02 = v[i1, 0] - v[i0, 0], v[i1, 1] - v[i0, 1], v[i1, 2] - v[i0, 2]
    b10, b11, b12 = v[i2, 0] - v[i0, 0], v[i2, 1] - v[i0, 1], v[i2, 2] - v[i0, 2]
    n0 = b01 * b12 - b02 * b11
    n1 = b02 * b10 - b00 * b12
    n2 = b00 * b11 - b01 * b10
    # the corners after w moves to x (no function handed the arrays: numba would
    # count references to them on every call)
    p00, p01, p02 = (x[0], x[1], x[2]) if i0 == w else (v[i0, 0], v[i0, 1], v[i0, 2])
    p10, p11, p12 = (x[0], x[1], x[2]) if i1 == w else (v[i1, 0], v[i1, 1], v[i1, 2])
    p20, p21, p22 = (x[0], x[1], x[2]) if i2 == w else (v[i2, 0], v[i2, 1], v[i2, 2])
    a00, a01, a02 = p10 - p00, p11 - p01, p12 - p02
    a10, a11, a12 = p20 - p00, p21 - p01, p22 - p02
    m0 = a01 * a12 - a02 * a11
    m1 = a02 * a10 - a00 * a12
    m2 = a00 * a11 - a01 * a10
    bb = n0 * n0 + n1 * n1 + n2 * n2
    ab = m0 * n0 + m1 * n1 + m2 * n2
    aa = m0 * m0 + m1 * m1 + m2 * m2
    return ab <= 0.0 or aa <= 1e-12 * bb


@njit(cache=True, inline="always")
def _edge_cost(v, q, a, b, tie, qab, x, mesh, hold) -> float:
    """The heap cost of edge (a, b): its quadric's least cost, plus ``tie`` x the
    squared squared length (so that flat parts decimate evenly); where that is, into
    ``x`` (3,). ``qab`` (4, 4) is scratch for the edge's quadric (no array made per
    edge). With flat planes (``hold``: `collapse_edges`' ``planes``; ``mesh``: the
    live triangles ``(tri, head, nxt, alive)``), the least cost on the planes of the
    flat regions left around the merged vertex (`planes_position`); infinite where
    they do not meet there. The same inputs give the same bits: the loop finds an
    entry's position again when it pops it, its ends unchanged since."""
    for i in range(4):
        for j in range(4):
            qab[i, j] = q[a, i, j] + q[b, i, j]
    tflat, normals, offsets, tol, ids, work, left = hold
    if tflat.size == 0:
        cost, x[0], x[1], x[2] = collapse_position(qab, v[a], v[b])
    else:
        tri, head, nxt, alive = mesh
        k = edge_planes(tri, head, nxt, alive, tflat, a, b, ids, left)
        if k >= ids.shape[0]:
            return np.inf
        cost, x[0], x[1], x[2], ok = planes_position(
            qab, v[a], v[b], normals, offsets, ids, k, tol, work
        )
        if not ok:
            return np.inf
    d0, d1, d2 = v[a, 0] - v[b, 0], v[a, 1] - v[b, 1], v[a, 2] - v[b, 2]
    dd = d0 * d0 + d1 * d1 + d2 * d2
    return max(cost, 0.0) + tie * dd * dd


@njit(cache=True)
def _relink(head, nxt, alive, a, b) -> int:
    """Corner list of ``a`` := the live corners of ``a`` and ``b``; ``b``'s emptied.
    Returns how many corners ``a`` has."""
    new_head = -1
    n = 0
    for start in (head[a], head[b]):
        c = start
        while c != -1:
            nc = nxt[c]
            if alive[c // 3]:
                nxt[c] = new_head
                new_head = c
                n += 1
            c = nc
    head[a] = new_head
    head[b] = -1
    return n


@njit(cache=True)
def _doubles_a_triangle(tri, head, nxt, alive, a, b) -> bool:
    """Whether a triangle of ``a`` and one of ``b`` not on the edge share their other
    two vertices (merging a and b would give the same triangle twice: a tetrahedron,
    which the link condition lets through)."""
    c = head[a]
    while c != -1:
        f = c // 3
        if alive[f] and tri[f, 0] != b and tri[f, 1] != b and tri[f, 2] != b:
            u, w = tri[f, (c + 1) % 3], tri[f, (c + 2) % 3]
            e = head[b]
            while e != -1:
                g = e // 3
                if alive[g] and tri[g, 0] != a and tri[g, 1] != a and tri[g, 2] != a:
                    x, y = tri[g, (e + 1) % 3], tri[g, (e + 2) % 3]
                    if (x == u and y == w) or (x == w and y == u):
                        return True
                e = nxt[e]
        c = nxt[c]
    return False


@njit(cache=True)
def _collapsible(v, tri, head, nxt, alive, a, b, x, mark, stamp, shared) -> int:
    """Number of triangles on edge (a, b) (``shared`` filled) when collapsing it to
    ``x`` keeps the surface manifold (link condition) and turns no triangle over;
    else 0. ``mark`` (V, 2) and ``stamp`` (2,) are scratch."""
    ns = 0
    c = head[a]
    while c != -1:
        f = c // 3
        if alive[f] and (tri[f, 0] == b or tri[f, 1] == b or tri[f, 2] == b):
            if ns == 2:
                return 0  # an edge in three triangles: never collapsed
            shared[ns] = f
            ns += 1
        c = nxt[c]
    if ns == 0:
        return 0
    stamp[0] += 1
    stamp[1] += 1
    n_opposite = 0
    for k in range(ns):
        for i in range(3):
            u = tri[shared[k], i]
            if u != a and u != b and mark[u, 1] != stamp[1]:
                mark[u, 1] = stamp[1]
                n_opposite += 1
    stamp[1] += 1
    c = head[a]
    while c != -1:
        f = c // 3
        if alive[f]:
            for i in range(3):
                mark[tri[f, i], 0] = stamp[0]
        c = nxt[c]
    n_common = 0
    c = head[b]
    while c != -1:
        f = c // 3
        if alive[f]:
            for i in range(3):
                u = tri[f, i]
                if u != a and u != b and mark[u, 0] == stamp[0] and mark[u, 1] != stamp[1]:
                    mark[u, 1] = stamp[1]
                    n_common += 1
        c = nxt[c]
    if n_common != n_opposite or _doubles_a_triangle(tri, head, nxt, alive, a, b):
        return 0
    n_left = 0
    for w in (a, b):
        c = head[w]
        while c != -1:
            f = c // 3
            if alive[f] and f != shared[0] and (ns == 1 or f != shared[1]):
                if _flips(v, tri, f, w, x):
                    return 0
                n_left += 1
            c = nxt[c]
    return ns if n_left > 0 else 0  # else the last triangles of a piece would go


@njit(cache=True, nogil=True)
def collapse_edges(v, tri, q, on_boundary, edges, tie, target, carried, planes, cross):
    """Quadric edge collapse of a manifold triangle mesh, cheapest edge first, until
    no edge can be collapsed or at most ``target`` triangles are left (0: until none
    can; the decimation loop of `_decimate.decimate`). With points (``carried``: see
    `_bound_kernels.points_stay`; none: no rows), a collapse that would leave one
    farther than its tolerance from the triangles, or a triangle away from them, is
    refused. With flat planes (``planes``: ``(tflat (T,) each triangle's flat region
    or -1, normals (R, 3), offsets (R,), tol)``; ``tflat`` empty: none), every merged
    vertex goes onto the planes of its flat regions (`_plane_kernels`). A collapse
    that makes more triangles around it pass through each other is refused
    (`_fan_kernels.fan_crosses`; ``cross``: its ``(tol, flat_tol)``; negative: not
    tested).

    ``v`` (V, 3) and ``q`` (V, 4, 4) are changed in place; ``tri`` is read only.
    Returns the collapses in order: ``kept`` (n,) the vertex kept, ``gone`` (n,) the
    vertex merged into it, ``position`` (n, 3) where the kept vertex went, ``removed``
    (n,) the number of triangles each removed, ``cost`` (n,) its quadric cost.
    """
    n_v, n_t = v.shape[0], tri.shape[0]
    tri = tri.copy()
    head = np.full(n_v, -1, dtype=np.int64)
    nxt = np.full(3 * n_t, -1, dtype=np.int64)
    for f in range(n_t):
        for i in range(3):
            c = 3 * f + i
            nxt[c] = head[tri[f, i]]
            head[tri[f, i]] = c
    alive = np.ones(n_t, dtype=np.bool_)
    # entries are numbered as pushed; one pushed before the last change of an end
    # (``changed``: the number of the next entry then) is stale
    changed = np.zeros(n_v, dtype=np.int64)
    mark = np.zeros((n_v, 2), dtype=np.int64)
    stamp = np.zeros(2, dtype=np.int64)
    shared = np.zeros(2, dtype=np.int64)
    qab = np.empty((4, 4))
    x = np.empty(3)
    left = np.zeros(planes[1].shape[0], dtype=np.int64)  # each flat region's triangles
    for f in range(planes[0].shape[0]):
        if planes[0][f] >= 0:
            left[planes[0][f]] += 1
    hold = (*planes, np.empty(_MAX_PLANES, dtype=np.int64), np.empty((12, 3)), left)
    mesh = (tri, head, nxt, alive)
    fans = fan_scratch(n_t)
    n_heap = edges.shape[0]
    hc = np.empty(2 * n_heap)
    hk, hd = np.empty(2 * n_heap, np.int64), np.empty(2 * n_heap, np.int64)
    for e in range(n_heap):
        a, b = edges[e, 0], edges[e, 1]
        hc[e], hk[e], hd[e] = _edge_cost(v, q, a, b, tie, qab, x, mesh, hold), a * n_v + b, e
    heapify(hc, hk, hd, n_heap)
    pushed = n_heap
    n_p = carried[0].shape[0]
    phead, pnext = link_points(carried[3], n_t)
    work = (
        np.zeros(n_t, dtype=np.int64),
        np.zeros(1, dtype=np.int64),
        np.empty(n_t, dtype=np.int64),
        np.empty(n_p, dtype=np.int64),
        np.empty(n_p, dtype=np.int64),
        np.sqrt(carried[2]),
        np.empty(n_p),
        np.empty((n_t if n_p > 0 else 0, 11)),
        np.empty((n_t + 1 if n_p > 0 else 0, 3)),
    )
    out = (
        np.empty(n_v, dtype=np.int64),
        np.empty(n_v, dtype=np.int64),
        np.empty((n_v, 3)),
        np.empty(n_v, dtype=np.int64),
        np.empty(n_v),
    )
    n, n_alive = 0, n_t
    while n_heap > 0 and n_alive > target:
        cost, key, number = heap_pop(hc, hk, hd, n_heap)
        n_heap -= 1
        a, b = key // n_v, key % n_v
        if number < changed[a] or number < changed[b] or head[a] == -1 or head[b] == -1:
            continue
        cost = _edge_cost(v, q, a, b, tie, qab, x, mesh, hold)  # the same bits...
        if cost == np.inf:
            continue  # ...unless a triangle around went: its planes do not meet
        ns = _collapsible(v, tri, head, nxt, alive, a, b, x, mark, stamp, shared)
        if ns == 0 or (ns == 2 and on_boundary[a] and on_boundary[b]):
            continue  # an inner edge between two boundary vertices would pinch
        if cross[0] >= 0.0 and fan_crosses(
            v, tri, head, nxt, alive, a, b, x, shared, ns, cross, fans
        ):
            continue  # the surface would pass through itself more
        n_ring = n_points = 0
        if n_p > 0:
            ok, n_ring, n_points = points_stay(
                v, tri, head, nxt, alive, a, b, x, ns, shared, carried, phead, pnext, work
            )
            if not ok:
                continue
        for k in range(ns):
            alive[shared[k]] = False
            if left.size > 0 and planes[0][shared[k]] >= 0:
                left[planes[0][shared[k]]] -= 1
        c = head[b]
        while c != -1:
            tri[c // 3, c % 3] = a
            c = nxt[c]
        n_corners = _relink(head, nxt, alive, a, b)
        if n_p > 0:
            move_points(n_ring, n_points, phead, pnext, work)
        v[a] = x
        q[a] += q[b]
        on_boundary[a] = on_boundary[a] or on_boundary[b]
        changed[a] = changed[b] = pushed
        out[0][n], out[1][n], out[3][n], out[4][n] = a, b, ns, cost
        out[2][n] = x
        n_alive -= ns
        n += 1
        hc, hk, hd = heap_grown(hc, hk, hd, n_heap, 2 * n_corners)
        heap = (hc, hk, hd, n_heap, pushed)
        n_heap, pushed = _push_around(heap, v, q, mesh, hold, a, tie, qab, x, mark, stamp)
    return out[0][:n], out[1][:n], out[2][:n], out[3][:n], out[4][:n]


@njit(cache=True)
def _push_around(heap, v, q, mesh, hold, a, tie, qab, x, mark, stamp):
    """Every edge of ``a`` onto the heap ``(cost, key, number arrays, entries, entries
    pushed so far)``, each once (``x`` (3,): scratch); returns the two counts after."""
    hc, hk, hd, n_heap, pushed = heap
    tri, head, nxt = mesh[0], mesh[1], mesh[2]
    stamp[0] += 1
    c = head[a]
    while c != -1:
        f = c // 3
        for i in range(3):
            u = tri[f, i]
            if u != a and mark[u, 0] != stamp[0]:
                mark[u, 0] = stamp[0]
                cost = _edge_cost(v, q, a, u, tie, qab, x, mesh, hold)
                heap_push(hc, hk, hd, n_heap, cost, a * v.shape[0] + u, pushed)
                n_heap += 1
                pushed += 1
        c = nxt[c]
    return n_heap, pushed


@njit(cache=True, nogil=True)
def add_rows(idx, w, out) -> None:
    """``out[idx[i]] += w[i]`` for every i in turn (``w`` (n, C), ``out`` (V, C)): the
    sums of ``np.add.at`` and of ``np.bincount`` with weights, in their order."""
    for i in range(idx.shape[0]):
        r = idx[i]
        for c in range(w.shape[1]):
            out[r, c] += w[i, c]


@njit(cache=True)
def replay(n_vertices, tri, kept, gone, position, m):
    """The mesh after the first ``m`` collapses of `collapse_edges`: where each vertex
    went (``rep`` (V,): the vertex it was merged into, itself when kept), the kept
    vertices' positions (``moved`` (V,) bool, ``at`` (V, 3)) and which triangles are
    left (``alive`` (T,))."""
    rep = np.arange(n_vertices)
    moved = np.zeros(n_vertices, dtype=np.bool_)
    at = np.zeros((n_vertices, 3))
    for k in range(m):
        rep[gone[k]] = kept[k]
        moved[kept[k]] = True
        at[kept[k]] = position[k]
    for i in range(n_vertices):
        r = i
        while rep[r] != r:
            r = rep[r]
        rep[i] = r
    alive = np.empty(tri.shape[0], dtype=np.bool_)
    for f in range(tri.shape[0]):
        a, b, c = rep[tri[f, 0]], rep[tri[f, 1]], rep[tri[f, 2]]
        alive[f] = a != b and b != c and a != c
    return rep, moved, at, alive


@njit(cache=True)
def _numpy_sum(a, n) -> float:
    """The sum of ``a[:n]`` (n <= 128) in numpy's order (`np.sum` of a row: pairwise,
    eight partial sums from 8 elements on), so the kernel's field is numpy's bit for
    bit."""
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[i]
        return s
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    top = n - n % 8
    for i in range(8, top, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(top, n):
        s += a[i]
    return s


@njit(cache=True)
def _edge_turn(side, row, q, normals, k):
    """Whether the surface turns convex (1) or concave (-1) between the nearest point
    outside whose plane a node lies (``side`` +1) and the nearest inside (-1): each
    lies below the other's plane by more than `EDGE_TURN` of their distance (convex:
    the solid is the intersection of their half-spaces, a node outside one is
    outside), or above it (concave: the union, a node inside one is inside); 0 when
    neither (a saddle, or two points of one flat face)."""
    a = -1
    b = -1
    for m in range(k):
        if side[m] > 0.0 and a < 0:
            a = m
        if side[m] < 0.0 and b < 0:
            b = m
    ja, jb = row[a], row[b]
    e0 = q[jb, 0] - q[ja, 0]
    e1 = q[jb, 1] - q[ja, 1]
    e2 = q[jb, 2] - q[ja, 2]
    reach = EDGE_TURN * np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    below_a = (normals[ja, 0] * e0 + normals[ja, 2] * e2) + normals[ja, 1] * e1
    below_b = -((normals[jb, 0] * e0 + normals[jb, 2] * e2) + normals[jb, 1] * e1)
    if below_a < -reach and below_b < -reach:
        return 1.0
    if below_a > reach and below_b > reach:
        return -1.0
    return 0.0


#: `band_field`'s and `thin_sides`' rows a thread takes at least at once.
_ROWS_PIECE = 4096

#: `_edge_turn`: two points turn convex or concave when each lies this share of their
#: distance below (above) the other's plane (their normals more than about 11 degrees
#: apart).
EDGE_TURN = 0.1


def band_field(x, dist, gauss, idx, q, normals, step, spacing):
    """The robust path's field at band nodes ``x`` (n, 3) from their ``k`` <= 128
    nearest points (``dist``, ``idx`` (n, k), nearest first; ``gauss`` =
    exp(-(dist / step)^2), from numpy, whose exp may differ from LLVM's in the last
    bit): the weighted mean of the points' tangent-plane distances n . (x - p) over
    the neighbours within the nearest + ``spacing``; where those disagree on the side,
    the distance to the nearest point with the sign of their vote (`_reconstruct._field`).
    Sums in numpy's order (the dot product as (n0 e0 + n2 e2) + n1 e1, as numpy's
    einsum adds three terms): the plain-numpy reference's values bit for bit. Rows
    apart on threads (`run_chunks`: the same values)."""
    out = np.empty(dist.shape[0])
    args = (x, dist, gauss, idx, q, normals, float(step), float(spacing), out)
    run_chunks(_band_field_rows, dist.shape[0], args, min_piece=_ROWS_PIECE)
    return out


@njit(cache=True, nogil=True)
def _band_field_rows(x, dist, gauss, idx, q, normals, step, spacing, out, i0, i1) -> None:
    """`band_field` for the rows ``i0`` to ``i1`` (into ``out``)."""
    k = dist.shape[1]
    w = np.empty(k)
    signed = np.empty(k)
    side = np.empty(k)
    tmp = np.empty(k)
    tol = 1e-9 * step
    for i in range(i0, i1):
        reach = dist[i, 0] + spacing
        for m in range(k):
            j = idx[i, m]
            w[m] = gauss[i, m] + 1e-300 if dist[i, m] <= reach else 0.0
            e0 = x[i, 0] - q[j, 0]
            e1 = x[i, 1] - q[j, 1]
            e2 = x[i, 2] - q[j, 2]
            signed[m] = (normals[j, 0] * e0 + normals[j, 2] * e2) + normals[j, 1] * e1
        total = _numpy_sum(w, k)
        pos = False
        neg = False
        for m in range(k):
            w[m] /= total
            tmp[m] = w[m] * signed[m]
            s = signed[m]
            side[m] = 0.0
            if abs(s) > tol and dist[i, m] <= reach:  # on a plane: abstains
                side[m] = 1.0 if s > 0.0 else -1.0
                pos |= s > 0.0
                neg |= s < 0.0
        value = _numpy_sum(tmp, k)
        if pos and neg:  # the planes disagree: the nearest point's distance, signed
            turn = _edge_turn(side, idx[i], q, normals, k)
            if turn == 0.0:  # neither convex nor concave: the neighbours' vote
                for m in range(k):
                    tmp[m] = w[m] * side[m]
                turn = _numpy_sum(side, k) + _numpy_sum(tmp, k)
            value = dist[i, 0] if turn >= 0.0 else -dist[i, 0]
        out[i] = value


#: `thin_sides`: two neighbours of a node face opposite ways when their normals are
#: more than 120 degrees apart (the two sides of a wall, or an acute edge's faces).
OPPOSITE = -0.5


def thin_sides(x, dist, idx, q, normals, step, spacing):
    """Nodes between two sides of a thin part that the grid resolves
    (`_reconstruct._field`): -1 where a node ``x`` lies behind the tangent planes of
    all its neighbours within the nearest + ``spacing`` and two of them face
    opposite ways (inside a wall), +1 where it lies in front of all of them and two
    face opposite ways (in a gap between two walls), else 0: a node on a plane,
    planes that disagree, or a part thinner across (the distance between the two
    planes through the node) than the grid's nodes along its normal reach, ``step``
    times the normal's 1-norm (a digital plane that thin has holes). Rows apart on
    threads (`run_chunks`: the same values)."""
    out = np.zeros(dist.shape[0], dtype=np.int8)
    args = (x, dist, idx, q, normals, float(step), float(spacing), out)
    run_chunks(_thin_sides_rows, dist.shape[0], args, min_piece=_ROWS_PIECE)
    return out


@njit(cache=True, nogil=True)
def _thin_sides_rows(x, dist, idx, q, normals, step, spacing, out, i0, i1) -> None:
    """`thin_sides` for the rows ``i0`` to ``i1`` (into ``out``, zeros)."""
    k = dist.shape[1]
    signed = np.empty(k)
    tol = 1e-9 * step
    for i in range(i0, i1):
        reach = dist[i, 0] + spacing
        pos = False
        neg = False
        speak = 0
        for m in range(k):
            if dist[i, m] > reach:
                break
            j = idx[i, m]
            s = (
                normals[j, 0] * (x[i, 0] - q[j, 0])
                + normals[j, 1] * (x[i, 1] - q[j, 1])
                + normals[j, 2] * (x[i, 2] - q[j, 2])
            )
            signed[m] = s
            pos |= s >= -tol
            neg |= s <= tol
            speak += 1
        if pos == neg:
            continue
        for a in range(speak):
            ja = idx[i, a]
            need = step * (abs(normals[ja, 0]) + abs(normals[ja, 1]) + abs(normals[ja, 2]))
            for b in range(a + 1, speak):
                jb = idx[i, b]
                c = (
                    normals[ja, 0] * normals[jb, 0]
                    + normals[ja, 1] * normals[jb, 1]
                    + normals[ja, 2] * normals[jb, 2]
                )
                if c < OPPOSITE and abs(signed[a]) + abs(signed[b]) >= need:
                    out[i] = -1 if neg else 1
                    break
            if out[i] != 0:
                break
