"""numba kernels of `_crossings.crossing_pairs`: the pairs of triangles that share no
edge and pass through each other (private; kernels assume validated input).

Candidate pairs are those whose boxes meet, found in a grid of cells of the median
triangle's size (`_grid`); each is tested by the interval test of Möller (1997): two
triangles in different planes meet where the segments they cut from the line of their
planes overlap; two in one plane meet where an edge of one crosses an edge of the
other or a corner (or the centroid) of one lies inside the other. A corner the two
share lies on both planes exactly. Two triangles whose corners all lie within
``flat_tol`` of the other's plane (a planar face's triangles) are tested in that
plane; otherwise each must reach more than ``tol`` (a length) to both sides of the
other's plane (an edge of one lying on the other's plane, as the planar faces' rims
do, only touches it), and the sides of a plane are the signs of the computed
distances (a tolerance there would put one corner of a sliver on a plane it misses
and cross the fans of a flat face that do not). Triangles that only touch (at their
shared corner, too), or overlap by less than ``tol``, do not cross. Two in one plane
are first set apart cheaply where they can be: sharing a corner, by their angles
there (`_angles_apart`); sharing none, by the line of a side of one
(`_edge_apart`). Most pairs of a flat face's fans are set apart so, and the full
test (about 60 orientation products) is left to the few that are not: the same
answers, under a third of the fan test's cost on a subdivided CAD part.
tests/simplify/reference_crossings.py keeps a plain-numpy test of every pair by
another route (one triangle clipped by the other).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["crossings"]

#: Most (cell, triangle) entries of the candidates' grid per triangle: the cells grow
#: until long triangles (a CAD face's fan) take no more.
ENTRIES_PER_TRIANGLE = 8


@njit(cache=True)
def _unit_normal(a, b, c):
    n = np.cross(b - a, c - a)
    length = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    if length == 0.0:
        return n, False
    return n / length, True


@njit(cache=True)
def _interval(v, d, axis):
    """The segment (lo, hi along ``axis``) that the plane cuts from triangle ``v``
    whose signed distances to it are ``d``; (1, 0) where it cuts nothing."""
    lo = np.inf
    hi = -np.inf
    for i in range(3):
        s = axis[0] * v[i, 0] + axis[1] * v[i, 1] + axis[2] * v[i, 2]
        if d[i] == 0.0:
            lo = min(lo, s)
            hi = max(hi, s)
        j = (i + 1) % 3
        if (d[i] > 0.0 and d[j] < 0.0) or (d[i] < 0.0 and d[j] > 0.0):
            sj = axis[0] * v[j, 0] + axis[1] * v[j, 1] + axis[2] * v[j, 2]
            t = s + (sj - s) * d[i] / (d[i] - d[j])
            lo = min(lo, t)
            hi = max(hi, t)
    if lo > hi:
        return 1.0, 0.0
    return lo, hi


@njit(cache=True)
def _side(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True, inline="always")
def _edge_margins(t, x, y, tol):
    """``tol`` times the length of each edge (e, e + 1) of triangle ``t`` in the plane
    of the two axes: the margin a point's `_side` value must pass (once per triangle,
    not per point: the same values)."""
    m0 = tol * np.hypot(t[1, x] - t[0, x], t[1, y] - t[0, y])
    m1 = tol * np.hypot(t[2, x] - t[1, x], t[2, y] - t[1, y])
    m2 = tol * np.hypot(t[0, x] - t[2, x], t[0, y] - t[2, y])
    return (m0, m1, m2)


@njit(cache=True, inline="always")
def _turn(t, x, y) -> float:
    """The sign of triangle ``t``'s area in the plane of the two axes: 1 or -1, 0
    without area."""
    area = _side(t[0, x], t[0, y], t[1, x], t[1, y], t[2, x], t[2, y])
    if area == 0.0:
        return 0.0
    return 1.0 if area > 0.0 else -1.0


@njit(cache=True)
def _inside(p, q, x, y, tol):
    """Whether a corner or the centroid of p lies inside triangle q by more than
    ``tol`` (in the plane of the two axes; the centroid catches a p inside q whose
    corners lie on q's edges, and a copy of q)."""
    sign = _turn(q, x, y)
    if sign == 0.0:
        return False
    margin = _edge_margins(q, x, y, tol)
    for k in range(4):
        if k < 3:
            px = p[k, x]
            py = p[k, y]
        else:
            px = (p[0, x] + p[1, x] + p[2, x]) / 3.0
            py = (p[0, y] + p[1, y] + p[2, y]) / 3.0
        inside = True
        for e in range(3):
            f = (e + 1) % 3
            if sign * _side(q[e, x], q[e, y], q[f, x], q[f, y], px, py) <= margin[e]:
                inside = False
        if inside:
            return True
    return False


@njit(cache=True)
def _edges_cross(p, q, x, y, tol):
    """Whether an edge of p and an edge of q cross properly (in the plane of the two
    axes): each edge's ends on strictly opposite sides of the other's line."""
    mp = _edge_margins(p, x, y, tol)
    mq = _edge_margins(q, x, y, tol)
    for e in range(3):
        f = (e + 1) % 3
        for g in range(3):
            h = (g + 1) % 3
            s1 = _side(p[e, x], p[e, y], p[f, x], p[f, y], q[g, x], q[g, y])
            s2 = _side(p[e, x], p[e, y], p[f, x], p[f, y], q[h, x], q[h, y])
            s3 = _side(q[g, x], q[g, y], q[h, x], q[h, y], p[e, x], p[e, y])
            s4 = _side(q[g, x], q[g, y], q[h, x], q[h, y], p[f, x], p[f, y])
            apart_p = (s1 > mp[e] and s2 < -mp[e]) or (s1 < -mp[e] and s2 > mp[e])
            apart_q = (s3 > mq[g] and s4 < -mq[g]) or (s3 < -mq[g] and s4 > mq[g])
            if apart_p and apart_q:
                return True
    return False


#: `_angles_apart`: a ray lies outside an angle where its cross products with the
#: angle's sides pass this share of their lengths' product (L1 lengths, no square
#: root): far above the rounding of the products, far below any angle that matters.
APART_RTOL = 1e-9


@njit(cache=True, inline="always")
def _clearly_behind(ux, uy, rx, ry, turn) -> bool:
    """Whether ``turn`` times the cross product of (ux, uy) and (rx, ry) is below minus
    `APART_RTOL` of their L1 lengths' product: (rx, ry) clearly on the side of the
    line of (ux, uy) that ``turn`` calls behind."""
    scale = (abs(rx) + abs(ry)) * APART_RTOL
    return turn * (ux * ry - uy * rx) < -scale * (abs(ux) + abs(uy))


@njit(cache=True, inline="always")
def _outside(u1x, u1y, u2x, u2y, turn, rx, ry) -> bool:
    """Whether the ray (rx, ry) lies clearly outside the angle from (u1x, u1y) to
    (u2x, u2y) (``turn``: the sign of their cross product)."""
    return _clearly_behind(u1x, u1y, rx, ry, turn) or _clearly_behind(u2x, u2y, rx, ry, -turn)


@njit(cache=True)
def _angles_apart(p, q, ip, iq, x, y) -> bool:
    """Whether triangles ``p`` and ``q`` in one plane, sharing corner ``p[ip]`` =
    ``q[iq]``, have angles there that are clearly apart (in the plane of the two
    axes): each side of either lies outside the other's angle. Near its corner a
    triangle fills its angle, and two angles below a half-turn that overlap have a
    side of one inside the other: apart, the two meet only at the corner, and
    `_coplanar_cross` is False (checked against the full test in
    tests/simplify/test_crossings.py)."""
    i1, i2 = (ip + 1) % 3, (ip + 2) % 3
    j1, j2 = (iq + 1) % 3, (iq + 2) % 3
    ox, oy = p[ip, x], p[ip, y]
    ax, ay = p[i1, x] - ox, p[i1, y] - oy
    bx, by = p[i2, x] - ox, p[i2, y] - oy
    cx, cy = q[j1, x] - ox, q[j1, y] - oy
    dx, dy = q[j2, x] - ox, q[j2, y] - oy
    sp = ax * by - ay * bx
    sq = cx * dy - cy * dx
    if sp == 0.0 or sq == 0.0:
        return False  # a triangle without area in the plane: the full test
    tp = 1.0 if sp > 0.0 else -1.0
    tq = 1.0 if sq > 0.0 else -1.0
    return (
        _outside(ax, ay, bx, by, tp, cx, cy)
        and _outside(ax, ay, bx, by, tp, dx, dy)
        and _outside(cx, cy, dx, dy, tq, ax, ay)
        and _outside(cx, cy, dx, dy, tq, bx, by)
    )


@njit(cache=True)
def _edge_apart(p, q, x, y) -> bool:
    """Whether the line of an edge of triangle ``p`` has every corner of ``q`` clearly
    on its outer side (in the plane of the two axes; `APART_RTOL`): the two are
    apart, and `_coplanar_cross` is False."""
    turn = _turn(p, x, y)
    if turn == 0.0:
        return False
    for e in range(3):
        f = (e + 1) % 3
        ex, ey = p[f, x] - p[e, x], p[f, y] - p[e, y]
        apart = True
        for k in range(3):
            if not _clearly_behind(ex, ey, q[k, x] - p[e, x], q[k, y] - p[e, y], turn):
                apart = False
                break
        if apart:
            return True
    return False


@njit(cache=True)
def _coplanar_cross(p, q, n, tol, ip, iq):
    """The test of two triangles in one plane of normal ``n``: dropped onto the two
    axes the normal leans on least (``p[ip]`` is ``q[iq]`` where they share a corner,
    else both -1: then two whose angles at that corner are apart meet only there)."""
    drop = 0
    for k in range(1, 3):
        if abs(n[k]) > abs(n[drop]):
            drop = k
    x = (drop + 1) % 3
    y = (drop + 2) % 3
    if ip >= 0 and _angles_apart(p, q, ip, iq, x, y):
        return False
    if ip < 0 and (_edge_apart(p, q, x, y) or _edge_apart(q, p, x, y)):
        return False
    if _edges_cross(p, q, x, y, tol):
        return True
    return _inside(p, q, x, y, tol) or _inside(q, p, x, y, tol)


@njit(cache=True)
def _side_of(n, v, o):
    """Signed distance of ``v`` to the plane of unit normal ``n`` through ``o``."""
    return n[0] * (v[0] - o[0]) + n[1] * (v[1] - o[1]) + n[2] * (v[2] - o[2])


@njit(cache=True)
def _straddle(d):
    """How far a triangle reaches to the nearer side of a plane (its corners' signed
    distances ``d``): 0 where it lies on one side."""
    return min(max(d[0], max(d[1], d[2])), -min(d[0], min(d[1], d[2])))


@njit(cache=True)
def pair_crosses(p, q, np_, nq, ip, iq, tol, flat_tol, work):
    """Whether triangles ``p`` and ``q`` (3 x 3 corners, unit normals ``np_``, ``nq``:
    zero without area; ``p[ip]`` is ``q[iq]`` where they share a corner, else both
    are -1) pass through each other by more than ``tol``; triangles without area
    never do; ``flat_tol``: corners all this near the other's plane, in one plane.
    ``work``: a 3 x 3 scratch array (no allocation per pair)."""
    if (np_[0] == 0.0 and np_[1] == 0.0 and np_[2] == 0.0) or (
        nq[0] == 0.0 and nq[1] == 0.0 and nq[2] == 0.0
    ):
        return False
    dp = work[0]
    dq = work[1]
    axis = work[2]
    for i in range(3):
        dp[i] = _side_of(nq, p[i], q[0])
        dq[i] = _side_of(np_, q[i], p[0])
    if ip >= 0:
        dp[ip] = 0.0
        dq[iq] = 0.0
    flat = True
    for i in range(3):
        if abs(dp[i]) > flat_tol or abs(dq[i]) > flat_tol:
            flat = False
    if flat:  # a fold shows only in the plane
        return _coplanar_cross(p, q, nq, tol, ip, iq)
    if min(dp[0], min(dp[1], dp[2])) > 0.0 or max(dp[0], max(dp[1], dp[2])) < 0.0:
        return False
    if min(dq[0], min(dq[1], dq[2])) > 0.0 or max(dq[0], max(dq[1], dq[2])) < 0.0:
        return False
    if _straddle(dp) <= tol or _straddle(dq) <= tol:
        return False  # one only touches the other's plane: they touch at most
    axis[0] = np_[1] * nq[2] - np_[2] * nq[1]
    axis[1] = np_[2] * nq[0] - np_[0] * nq[2]
    axis[2] = np_[0] * nq[1] - np_[1] * nq[0]
    length = np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    if length == 0.0:
        return _coplanar_cross(p, q, nq, tol, ip, iq)
    for k in range(3):
        axis[k] /= length
    a0, a1 = _interval(p, dp, axis)
    b0, b1 = _interval(q, dq, axis)
    return min(a1, b1) - max(a0, b0) > tol


@njit(cache=True)
def _boxes(x, tri):
    lo = np.empty((tri.shape[0], 3))
    hi = np.empty((tri.shape[0], 3))
    for t in range(tri.shape[0]):
        for k in range(3):
            a = x[tri[t, 0], k]
            b = x[tri[t, 1], k]
            c = x[tri[t, 2], k]
            lo[t, k] = min(a, min(b, c))
            hi[t, k] = max(a, max(b, c))
    return lo, hi


@njit(cache=True)
def _shared(tri, a, b):
    """``(n, i, j)``: how many corners triangles a and b share, and where the last
    shared one is in each."""
    n = 0
    si = -1
    sj = -1
    for i in range(3):
        for j in range(3):
            if tri[a, i] == tri[b, j]:
                n += 1
                si = i
                sj = j
    return n, si, sj


@njit(cache=True)
def _apart(x, tri, nrm, a, b, skip, flat_tol):
    """Whether every corner of triangle b but its ``skip``-th (the corner it shares
    with a; -1: none) lies farther than ``flat_tol`` from the plane of triangle a,
    all on one side (then `pair_crosses` is False: a quick test first)."""
    above = 0
    below = 0
    o = tri[a, 0]
    for k in range(3):
        if k == skip:
            continue
        d = _side_of(nrm[a], x[tri[b, k]], x[o])
        if d > flat_tol:
            above += 1
        elif d < -flat_tol:
            below += 1
    corners = 3 if skip < 0 else 2
    return above == corners or below == corners


@njit(cache=True)
def _cell_of(v, gmin, h, k):
    return np.int64(np.floor((v - gmin[k]) / h))


@njit(cache=True)
def _entries(lo, hi, gmin, h, cap):
    """How many (cell, triangle) entries cells of side ``h`` take (stops past ``cap``)."""
    total = 0
    for t in range(lo.shape[0]):
        span = 1
        for k in range(3):
            span *= _cell_of(hi[t, k], gmin, h, k) - _cell_of(lo[t, k], gmin, h, k) + 1
        total += span
        if total > cap:
            break
    return total


@njit(cache=True)
def _grid(lo, hi):
    """``(key, ids, gmin, h, dims)``: every triangle under the key of every cell its box
    meets, sorted by key; the cells' side ``h`` starts at the median box and doubles
    until the entries are at most `ENTRIES_PER_TRIANGLE` per triangle."""
    n = lo.shape[0]
    gmin = np.empty(3)
    top = np.empty(3)
    for k in range(3):
        gmin[k] = lo[:, k].min()
        top[k] = hi[:, k].max()
    size = np.empty(n)
    for t in range(n):
        size[t] = max(hi[t, 0] - lo[t, 0], max(hi[t, 1] - lo[t, 1], hi[t, 2] - lo[t, 2]))
    h = np.median(size)
    span = max(top[0] - gmin[0], max(top[1] - gmin[1], top[2] - gmin[2]))
    if not h > span * 1e-6:
        h = max(span * 1e-6, 1e-300)
    cap = ENTRIES_PER_TRIANGLE * n
    total = _entries(lo, hi, gmin, h, cap)
    while total > cap:
        h *= 2.0
        total = _entries(lo, hi, gmin, h, cap)
    dims = np.empty(3, np.int64)
    for k in range(3):
        dims[k] = _cell_of(top[k], gmin, h, k) + 1
    key = np.empty(total, np.int64)
    ids = np.empty(total, np.int64)
    e = 0
    c0 = np.empty(3, np.int64)
    c1 = np.empty(3, np.int64)
    for t in range(n):
        for k in range(3):
            c0[k] = _cell_of(lo[t, k], gmin, h, k)
            c1[k] = _cell_of(hi[t, k], gmin, h, k)
        for i in range(c0[0], c1[0] + 1):
            for j in range(c0[1], c1[1] + 1):
                for m in range(c0[2], c1[2] + 1):
                    key[e] = (i * dims[1] + j) * dims[2] + m
                    ids[e] = t
                    e += 1
    order = np.argsort(key, kind="mergesort")
    return key[order], ids[order], gmin, h, dims


@njit(cache=True)
def _meets(lo, hi, a, b):
    for k in range(3):
        if lo[b, k] > hi[a, k] or hi[b, k] < lo[a, k]:
            return False
    return True


@njit(cache=True)
def crossings(x, tri, tol, flat_tol, live):
    """``(P, 2)`` int64: the pairs (a < b) of triangles of ``tri`` that share no edge
    and pass through each other by more than ``tol``, of those with a ``live``
    triangle. Each pair whose boxes meet is tried once: in the cell of the lowest
    corner of their boxes' overlap."""
    if tri.shape[0] == 0:
        return np.zeros((0, 2), np.int64)
    lo, hi = _boxes(x, tri)
    key, ids, gmin, h, dims = _grid(lo, hi)
    nrm = np.zeros((tri.shape[0], 3))
    for t in range(tri.shape[0]):
        nrm[t], _ = _unit_normal(x[tri[t, 0]], x[tri[t, 1]], x[tri[t, 2]])
    found = []
    p = np.empty((3, 3))
    q = np.empty((3, 3))
    work = np.empty((3, 3))
    start = 0
    while start < key.shape[0]:
        stop = start
        while stop < key.shape[0] and key[stop] == key[start]:
            stop += 1
        for i in range(start, stop):
            for j in range(i + 1, stop):
                a = min(ids[i], ids[j])
                b = max(ids[i], ids[j])
                if not (live[a] or live[b]) or not _meets(lo, hi, a, b):
                    continue
                corner = (
                    _cell_of(max(lo[a, 0], lo[b, 0]), gmin, h, 0) * dims[1]
                    + _cell_of(max(lo[a, 1], lo[b, 1]), gmin, h, 1)
                ) * dims[2] + _cell_of(max(lo[a, 2], lo[b, 2]), gmin, h, 2)
                if corner != key[start]:
                    continue
                n, ip, iq = _shared(tri, a, b)
                if n > 1:
                    continue
                if _apart(x, tri, nrm, a, b, iq, flat_tol) or _apart(
                    x, tri, nrm, b, a, ip, flat_tol
                ):
                    continue
                for k in range(3):
                    p[k] = x[tri[a, k]]
                    q[k] = x[tri[b, k]]
                if pair_crosses(p, q, nrm[a], nrm[b], ip, iq, tol, flat_tol, work):
                    found.append((a, b))
        start = stop
    out = np.empty((len(found), 2), np.int64)
    for k in range(len(found)):
        out[k, 0] = found[k][0]
        out[k, 1] = found[k][1]
    return out
