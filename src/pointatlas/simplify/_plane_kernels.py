"""numba kernels of the collapses held on flat planes (`_kernels.collapse_edges` with
the regions' planes; plain-numpy references in tests/simplify/reference.py).

A collapse of edge (a, b) whose triangles left around the merged vertex lie on flat
regions puts the vertex on all of their planes at once: the least quadric cost on
the set where they meet (a plane, a line or a point), not the quadric's free
minimiser moved there afterwards. A plane within `PARALLEL_SINE` of the ones before
it (its normal's part across them) adds no direction: the vertex must then already
lie within ``tol`` of it, else the collapse is refused (two parallel faces of a thin
wall, four planes that do not meet at one point). A region the collapse leaves with
one triangle holds nothing (a triangle is planar wherever its corners go): the sides
of a tessellated hole or fillet, each a flat region of two triangles, can then be
collapsed away one by one. So every vertex a collapse moves lies on the planes of its
flat regions of two or more triangles up to rounding, and the faces of flat regions
stay exactly planar through the whole sequence (docs/decisions/simplify.md,
"Decimation").
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["PARALLEL_SINE", "collapse_position", "edge_planes", "planes_position", "quadric_cost"]

#: A plane whose normal's part across the planes before it is shorter than this (the
#: sine of 2.5 degrees, as the placement's `_place._PARALLEL_RTOL`) adds no direction.
PARALLEL_SINE = 0.0437
#: The quadric's least point on the planes is taken only within this many edge lengths
#: of the edge's midpoint: the quadrics of a thin wall's two sides, parallel along a
#: face, put it anywhere along it (a 400,000-triangle clip: 101 diagonals away).
REACH = 1.0


@njit(cache=True)
def quadric_cost(q, x, y, z) -> float:
    """The quadric ``q`` (4, 4) at (x, y, z): p^T q p with p = (x, y, z, 1)."""
    p = (x, y, z, 1.0)
    total = 0.0
    for i in range(4):
        row = 0.0
        for j in range(4):
            row += q[i, j] * p[j]
        total += p[i] * row
    return total


@njit(cache=True)
def collapse_position(q, a, b):
    """``(cost, x, y, z)``: where the quadric ``q`` (4, 4) of an edge (a, b) is least.

    The minimiser of the quadric when its 3x3 part is well conditioned (its
    determinant above 1e-10 of the product of its row norms), else nothing; then the
    cheapest of the minimiser, the two ends and the midpoint.
    """
    best = quadric_cost(q, a[0], a[1], a[2])
    bx, by, bz = a[0], a[1], a[2]
    c = quadric_cost(q, b[0], b[1], b[2])
    if c < best:
        best, bx, by, bz = c, b[0], b[1], b[2]
    mx, my, mz = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    c = quadric_cost(q, mx, my, mz)
    if c < best:
        best, bx, by, bz = c, mx, my, mz
    m00, m01, m02 = q[0, 0], q[0, 1], q[0, 2]
    m10, m11, m12 = q[1, 0], q[1, 1], q[1, 2]
    m20, m21, m22 = q[2, 0], q[2, 1], q[2, 2]
    c0 = m11 * m22 - m12 * m21
    c1 = m12 * m20 - m10 * m22
    c2 = m10 * m21 - m11 * m20
    det = m00 * c0 + m01 * c1 + m02 * c2
    scale = (
        np.sqrt(m00 * m00 + m01 * m01 + m02 * m02)
        * np.sqrt(m10 * m10 + m11 * m11 + m12 * m12)
        * np.sqrt(m20 * m20 + m21 * m21 + m22 * m22)
    )
    if scale > 0.0 and abs(det) > 1e-10 * scale:
        r0, r1, r2 = -q[0, 3], -q[1, 3], -q[2, 3]
        x = (r0 * c0 + r1 * (m02 * m21 - m01 * m22) + r2 * (m01 * m12 - m02 * m11)) / det
        y = (r0 * c1 + r1 * (m00 * m22 - m02 * m20) + r2 * (m02 * m10 - m00 * m12)) / det
        z = (r0 * c2 + r1 * (m01 * m20 - m00 * m21) + r2 * (m00 * m11 - m01 * m10)) / det
        c = quadric_cost(q, x, y, z)
        if c < best:
            best, bx, by, bz = c, x, y, z
    return best, bx, by, bz


@njit(cache=True, inline="always")
def edge_planes(tri, head, nxt, alive, tflat, a, b, ids, left) -> int:
    """The flat regions of the live triangles around ``a`` and ``b`` that do not hold
    both (those the collapse removes) and keep two or more triangles after it (of
    ``left`` (R,), each region's live triangles: a region of one triangle is planar
    wherever its vertices go), in increasing order, into ``ids``; returns how many
    (at most ``ids.shape[0]``: the rest are dropped, the collapse then refused by
    the caller). ``tflat`` (T,): each triangle's flat region, -1: none."""
    k = 0
    gone0 = gone1 = -1  # the flat regions of the (two) triangles the collapse removes
    for w in (a, b):
        c = head[w]
        while c != -1:
            f = c // 3
            r = tflat[f]
            if alive[f] and r >= 0:
                other = b if w == a else a
                if tri[f, 0] != other and tri[f, 1] != other and tri[f, 2] != other:
                    k = _insert(ids, k, r)
                    if k > ids.shape[0] - 1:
                        return k
                elif w == a:
                    if gone0 == -1:
                        gone0 = r
                    else:
                        gone1 = r
            c = nxt[c]
    kept = 0
    for i in range(k):
        r = ids[i]
        if left[r] - (r == gone0) - (r == gone1) >= 2:
            ids[kept] = r
            kept += 1
    return kept


@njit(cache=True, inline="always")
def _insert(ids, k, r) -> int:
    """``r`` into the sorted ``ids[:k]`` unless there; returns the new count."""
    i = 0
    while i < k and ids[i] < r:
        i += 1
    if i < k and ids[i] == r:
        return k
    for j in range(k, i, -1):
        ids[j] = ids[j - 1]
    ids[i] = r
    return k + 1


@njit(cache=True)
def planes_position(q, a, b, normals, offsets, ids, k, tol, work):
    """``(cost, x, y, z, ok)``: where the quadric ``q`` (4, 4) of edge (a, b) is least
    on the planes ``ids[:k]`` (``normals`` (R, 3), ``offsets`` (R,)); ``ok`` False
    when a plane adding no direction is farther than ``tol`` from that point.

    The planes' independent normals are made orthonormal one after the other
    (Gram-Schmidt), the point of their meet nearest the edge's midpoint found from
    the triangular system, and the quadric minimised over the directions left
    (where its part there is well conditioned); the cheapest of that minimiser and
    the meet's points nearest a, b and the midpoint. With no plane:
    `collapse_position`. ``work`` (12, 3): scratch (rows 0-2 the orthonormal
    normals, 3-5 the triangular factor, 6-8 the free directions, 9-11 the right-hand
    side, the coefficients and the meet's point; no array made per call).
    """
    if k == 0:
        cost, x, y, z = collapse_position(q, a, b)
        return cost, x, y, z, True
    mx, my, mz = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    n_ind = 0
    for i in range(k):
        if n_ind == 3:
            break  # every later plane adds no direction
        r = ids[i]
        u0, u1, u2 = normals[r, 0], normals[r, 1], normals[r, 2]
        for j in range(n_ind):
            f = u0 * work[j, 0] + u1 * work[j, 1] + u2 * work[j, 2]
            work[3 + n_ind, j] = f
            u0 -= f * work[j, 0]
            u1 -= f * work[j, 1]
            u2 -= f * work[j, 2]
        size = np.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if size > PARALLEL_SINE:
            work[n_ind, 0], work[n_ind, 1], work[n_ind, 2] = u0 / size, u1 / size, u2 / size
            work[3 + n_ind, n_ind] = size
            work[9, n_ind] = offsets[r] - (
                normals[r, 0] * mx + normals[r, 1] * my + normals[r, 2] * mz
            )
            n_ind += 1
    # the meet's point nearest the midpoint: m + sum c_j e_j, L c = d - N m
    work[11, 0], work[11, 1], work[11, 2] = mx, my, mz
    for i in range(n_ind):
        s = work[9, i]
        for j in range(i):
            s -= work[3 + i, j] * work[10, j]
        work[10, i] = s / work[3 + i, i]
        for d in range(3):
            work[11, d] += work[10, i] * work[i, d]
    _free_directions(work, n_ind)
    best, bx, by, bz = _cheapest_projection(q, a, b, work, 3 - n_ind)
    if n_ind < 3:
        found, px, py, pz = _least_along(q, work, 3 - n_ind)
        dx, dy, dz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
        fx, fy, fz = px - mx, py - my, pz - mz
        if fx * fx + fy * fy + fz * fz > REACH * REACH * (dx * dx + dy * dy + dz * dz):
            found = False  # the quadrics' planes nearly parallel along the meet: a spike
        if found:
            c = quadric_cost(q, px, py, pz)
            if c < best:
                best, bx, by, bz = c, px, py, pz
    for i in range(k):
        r = ids[i]
        if abs(normals[r, 0] * bx + normals[r, 1] * by + normals[r, 2] * bz - offsets[r]) > tol:
            return best, bx, by, bz, False
    return best, bx, by, bz, True


@njit(cache=True)
def _free_directions(work, n_ind) -> None:
    """Rows 6 to 8 - ``n_ind`` of ``work``: an orthonormal basis of the directions
    across its ``n_ind`` orthonormal rows 0, 1, ...."""
    if n_ind == 2:
        e0, e1, e2 = work[0, 0], work[0, 1], work[0, 2]
        f0, f1, f2 = work[1, 0], work[1, 1], work[1, 2]
        c0, c1, c2 = e1 * f2 - e2 * f1, e2 * f0 - e0 * f2, e0 * f1 - e1 * f0
        size = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        work[6, 0], work[6, 1], work[6, 2] = c0 / size, c1 / size, c2 / size
    elif n_ind == 1:
        e0, e1, e2 = work[0, 0], work[0, 1], work[0, 2]
        axis = 0  # the axis least along e
        if abs(e1) < abs(e0):
            axis = 1
        if abs(e2) < abs((e0, e1)[axis]):
            axis = 2
        ea = (e0, e1, e2)[axis]
        t0, t1, t2 = -ea * e0, -ea * e1, -ea * e2
        if axis == 0:
            t0 += 1.0
        elif axis == 1:
            t1 += 1.0
        else:
            t2 += 1.0
        size = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0, t1, t2 = t0 / size, t1 / size, t2 / size
        work[6, 0], work[6, 1], work[6, 2] = t0, t1, t2
        work[7, 0], work[7, 1], work[7, 2] = e1 * t2 - e2 * t1, e2 * t0 - e0 * t2, e0 * t1 - e1 * t0


@njit(cache=True)
def _cheapest_projection(q, a, b, work, n_free):
    """The cheapest of a, b and their midpoint moved to the meet (``work``'s row 11
    plus their parts along its ``n_free`` rows from 6): ``(cost, x, y, z)``."""
    best = np.inf
    bx = by = bz = 0.0
    ox, oy, oz = work[11, 0], work[11, 1], work[11, 2]
    for t in range(3):
        px = a[0] if t == 0 else (b[0] if t == 1 else 0.5 * (a[0] + b[0]))
        py = a[1] if t == 0 else (b[1] if t == 1 else 0.5 * (a[1] + b[1]))
        pz = a[2] if t == 0 else (b[2] if t == 1 else 0.5 * (a[2] + b[2]))
        x, y, z = ox, oy, oz
        for j in range(6, 6 + n_free):
            s = work[j, 0] * (px - ox) + work[j, 1] * (py - oy) + work[j, 2] * (pz - oz)
            x += s * work[j, 0]
            y += s * work[j, 1]
            z += s * work[j, 2]
        c = quadric_cost(q, x, y, z)
        if c < best:
            best, bx, by, bz = c, x, y, z
    return best, bx, by, bz


@njit(cache=True)
def _least_along(q, work, n_free):
    """``(found, x, y, z)``: the quadric's least point on the meet's point (``work``'s
    row 11) plus its ``n_free`` rows from 6, when its part there is well conditioned:
    its determinant above 1e-10 of the quadric's 3x3 part's (Frobenius) norm to the
    power of the directions (a flat face's quadric is nearly zero along the face: its
    minimiser there is noise, as `collapse_position`'s test finds of the whole
    3x3 part)."""
    ox, oy, oz = work[11, 0], work[11, 1], work[11, 2]
    # half the gradient at the meet's point: A o + q[:3, 3]
    g0 = q[0, 0] * ox + q[0, 1] * oy + q[0, 2] * oz + q[0, 3]
    g1 = q[1, 0] * ox + q[1, 1] * oy + q[1, 2] * oz + q[1, 3]
    g2 = q[2, 0] * ox + q[2, 1] * oy + q[2, 2] * oz + q[2, 3]
    h00 = _along(q, work, 6, 6)
    r0 = -(work[6, 0] * g0 + work[6, 1] * g1 + work[6, 2] * g2)
    norm = 0.0  # the quadric's 3x3 part's size: a part along the meet far below it is noise
    for m in range(3):
        for n in range(3):
            norm += q[m, n] * q[m, n]
    norm = np.sqrt(norm)
    if n_free == 1:
        if not h00 > 1e-10 * norm:
            return False, 0.0, 0.0, 0.0
        y0, y1 = r0 / h00, 0.0
    else:
        h01, h10, h11 = _along(q, work, 6, 7), _along(q, work, 7, 6), _along(q, work, 7, 7)
        r1 = -(work[7, 0] * g0 + work[7, 1] * g1 + work[7, 2] * g2)
        det = h00 * h11 - h01 * h10
        if not abs(det) > 1e-10 * norm * norm:
            return False, 0.0, 0.0, 0.0
        y0 = (r0 * h11 - r1 * h01) / det
        y1 = (h00 * r1 - h10 * r0) / det
    x = ox + y0 * work[6, 0] + y1 * work[7, 0]
    y = oy + y0 * work[6, 1] + y1 * work[7, 1]
    z = oz + y0 * work[6, 2] + y1 * work[7, 2]
    return True, x, y, z


@njit(cache=True)
def _along(q, work, i, j) -> float:
    """``work[i] . A . work[j]``, A the quadric's 3x3 part."""
    s = 0.0
    for m in range(3):
        for n in range(3):
            s += work[i, m] * q[m, n] * work[j, n]
    return s
