"""numba kernels of `_untangle.untangle`: one pass of merges and flips over the
triangles left without area (private; kernels assume validated input).

Each vertex keeps the live triangles around it as a row of ``ring`` (its first
``deg`` entries, in no order): the set operations of the link condition, the side
test and the merge read a vertex's few triangles, so plain loops over the rows
replace Python's sets (the pure Python pass took 1.8 s of a 9 s run on a 93,000-
triangle level 0; tests/simplify/reference.py keeps it, and the kernels give the
same triangles bit for bit, tests/simplify/test_untangle.py). A row that would
overflow is widened (`_room`). Edge lengths and the areas checked along a side are
plain sums of products in one order, in both.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["merge_round", "triangle_rings"]


@njit(cache=True)
def triangle_rings(rows, alive, n_v):
    """``(ring, deg)``: the live triangles of every vertex (its first ``deg`` entries
    of its row of ``ring``, -1 after them)."""
    deg = np.zeros(n_v, np.int64)
    for t in range(rows.shape[0]):
        if alive[t]:
            for k in range(3):
                deg[rows[t, k]] += 1
    cap = 2 * (deg.max() if n_v > 0 else 0) + 8
    ring = np.full((n_v, cap), -1, np.int64)
    deg[:] = 0
    for t in range(rows.shape[0]):
        if alive[t]:
            for k in range(3):
                v = rows[t, k]
                ring[v, deg[v]] = t
                deg[v] += 1
    return ring, deg


@njit(cache=True)
def _room(ring, need):
    """``ring`` with rows of at least ``need`` entries (a copy when wider)."""
    if need <= ring.shape[1]:
        return ring
    out = np.full((ring.shape[0], max(2 * ring.shape[1], need)), -1, np.int64)
    out[:, : ring.shape[1]] = ring
    return out


@njit(cache=True)
def _has(ring, deg, v, t):
    for i in range(deg[v]):
        if ring[v, i] == t:
            return True
    return False


@njit(cache=True)
def _discard(ring, deg, v, t):
    for i in range(deg[v]):
        if ring[v, i] == t:
            deg[v] -= 1
            ring[v, i] = ring[v, deg[v]]
            ring[v, deg[v]] = -1
            return


@njit(cache=True)
def _add(ring, deg, v, t):
    if not _has(ring, deg, v, t):
        ring[v, deg[v]] = t
        deg[v] += 1


@njit(cache=True)
def _common(ring, deg, a, b, skip):
    """The triangles of both ``a`` and ``b`` but ``skip``: ``(count, first)``."""
    count, first = 0, -1
    for i in range(deg[a]):
        t = ring[a, i]
        if t != skip and _has(ring, deg, b, t):
            if count == 0:
                first = t
            count += 1
    return count, first


@njit(cache=True)
def _neighbours(rows, ring, deg, p):
    """The other vertices of p's triangles, once per triangle (sorted)."""
    out = np.empty(2 * deg[p], np.int64)
    n = 0
    for i in range(deg[p]):
        t = ring[p, i]
        for k in range(3):
            if rows[t, k] != p:
                out[n] = rows[t, k]
                n += 1
    return np.sort(out[:n])


@njit(cache=True)
def _on_outline(near):
    """Whether a vertex's sorted neighbours (`_neighbours`) hold one seen once (an
    edge in one triangle)."""
    i = 0
    while i < near.size:
        j = i
        while j < near.size and near[j] == near[i]:
            j += 1
        if j - i == 1:
            return True
        i = j
    return False


@njit(cache=True)
def _link_ok(rows, ring, deg, p, q):
    """`_caps._link_ok`: edge p q has two triangles, p and q share no neighbour but
    their two opposite vertices, and not both are on an open outline."""
    count, t0 = _common(ring, deg, p, q, -1)
    if count != 2:
        return False
    t1 = -1
    for i in range(deg[p]):
        t = ring[p, i]
        if t != t0 and _has(ring, deg, q, t):
            t1 = t
    o = np.full(2, -1, np.int64)
    n_o = 0
    for t in (t0, t1):
        for k in range(3):
            v = rows[t, k]
            if v != p and v != q and v != o[0] and v != o[1]:
                if n_o == 2:
                    return False
                o[n_o] = v
                n_o += 1
    if n_o != 2:
        return False
    near_p, near_q = _neighbours(rows, ring, deg, p), _neighbours(rows, ring, deg, q)
    for v in near_p:  # p and q share only o: q is no neighbour of itself, nor p of p
        if v != o[0] and v != o[1] and v != q and v != p:
            for w in near_q:
                if w == v:
                    return False
    return not (_on_outline(near_p) and _on_outline(near_q))


@njit(cache=True)
def _along(n, a, b, c):
    """``n`` dotted with (b - a) x (c - a), in `_stays`'s order of products."""
    u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    w0, w1, w2 = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    return n[0] * (u1 * w2 - u2 * w1) + n[1] * (u2 * w0 - u0 * w2) + n[2] * (u0 * w1 - u1 * w0)


@njit(cache=True)
def _stays(x, rows, side, ring, deg, p, q, tiny):
    """Every triangle of q but those of edge p q keeps its side with q at p."""
    for i in range(deg[q]):
        t = ring[q, i]
        if _has(ring, deg, p, t):
            continue
        r = rows[t]
        a = x[p] if r[0] == q else x[r[0]]
        b = x[p] if r[1] == q else x[r[1]]
        c = x[p] if r[2] == q else x[r[2]]
        if _along(side[t], a, b, c) <= tiny:
            return False
    return True


@njit(cache=True)
def _merge(rows, ring, deg, alive, into, p, q):
    """Vertex q merged into p: the two triangles of edge p q go."""
    for _ in range(2):
        _, t = _common(ring, deg, p, q, -1)
        alive[t] = False
        for k in range(3):
            _discard(ring, deg, rows[t, k], t)
    for i in range(deg[q]):
        t = ring[q, i]
        for k in range(3):
            if rows[t, k] == q:
                rows[t, k] = p
        _add(ring, deg, p, t)
        ring[q, i] = -1
    deg[q] = 0
    into[q] = p


@njit(cache=True)
def _find(into, v):
    while into[v] != v:
        v = into[v]
    return v


@njit(cache=True)
def _length(x, a, b):
    d0, d1, d2 = x[a, 0] - x[b, 0], x[a, 1] - x[b, 1], x[a, 2] - x[b, 2]
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@njit(cache=True)
def _merge_one(x, rows, side, ring, deg, alive, into, rank, t, tiny):
    """`_untangle`'s merge of triangle ``t``'s shortest mergeable edge (its end on
    fewer flat faces into the other): ``(1 if merged else 0, ring)``."""
    r = np.array([_find(into, rows[t, 0]), _find(into, rows[t, 1]), _find(into, rows[t, 2])])
    length = np.array([_length(x, r[k], r[(k + 1) % 3]) for k in range(3)])
    order = np.argsort(length, kind="mergesort")  # stable: ties in edge order
    for k in order:
        a, b = r[k], r[(k + 1) % 3]
        if rank[a] == rank[b] and rank[b] == np.inf:
            continue
        for way in range(2):
            if rank[a] == rank[b]:
                p, q = (a, b) if way == 0 else (b, a)
            elif way == 0:
                p, q = (a, b) if rank[a] > rank[b] else (b, a)
            else:
                break
            if _link_ok(rows, ring, deg, p, q) and _stays(x, rows, side, ring, deg, p, q, tiny):
                ring = _room(ring, deg[p] + deg[q])
                _merge(rows, ring, deg, alive, into, p, q)
                return 1, ring
    return 0, ring


@njit(cache=True)
def _area(x, a, b, c):
    """Twice the area of triangle a b c (the norm of `_mesh.cross`'s product)."""
    u0, u1, u2 = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    w0, w1, w2 = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    c0, c1, c2 = u1 * w2 - u2 * w1, u2 * w0 - u0 * w2, u0 * w1 - u1 * w0
    return np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)


@njit(cache=True)
def _flip_one(x, rows, side, face, ring, deg, t, tiny):
    """`_untangle`'s flip of cap ``t``'s longest edge: ``(1 if flipped else 0, ring)``."""
    if _area(x, rows[t, 0], rows[t, 1], rows[t, 2]) > tiny:
        return 0, ring  # turned over with an area, not a cap
    k, longest = 0, -1.0
    for i in range(3):
        d = _length(x, rows[t, (i + 1) % 3], rows[t, i])
        if d > longest:
            k, longest = i, d
    a, b, c = rows[t, k], rows[t, (k + 1) % 3], rows[t, (k + 2) % 3]
    count, u = _common(ring, deg, a, b, t)
    if count != 1:
        return 0, ring
    d = -1
    for i in range(3):
        if d < 0 and rows[u, i] != a and rows[u, i] != b:
            d = rows[u, i]
    if d == c or _common(ring, deg, c, d, -1)[0] > 0:
        return 0, ring
    n = side[u].copy()
    first = _along(n, x[a], x[d], x[c])
    second = _along(n, x[d], x[b], x[c])
    if min(first, second) <= tiny:
        return 0, ring
    rows[t, 0], rows[t, 1], rows[t, 2] = a, d, c
    rows[u, 0], rows[u, 1], rows[u, 2] = d, b, c
    face[t] = face[u]
    side[t] = n
    ring = _room(ring, max(deg[c], deg[d]) + 1)
    _discard(ring, deg, a, u)
    _discard(ring, deg, b, t)
    _add(ring, deg, c, u)
    _add(ring, deg, d, t)
    return 1, ring


@njit(cache=True)
def merge_round(x, rows, side, face, ring, deg, alive, into, rank, order, tiny):
    """One pass over the triangles ``order`` (the live ones first merged, else
    flipped, `_untangle`): ``(the number mended, ring)``; ``rows``, ``side``,
    ``face``, ``deg``, ``alive`` and ``into`` change in place."""
    done = 0
    for t in order:
        if alive[t]:
            got, ring = _merge_one(x, rows, side, ring, deg, alive, into, rank, t, tiny)
            if got == 0:
                got, ring = _flip_one(x, rows, side, face, ring, deg, t, tiny)
            done += got
    return done, ring
