"""Plain numpy references for the simplify kernels."""

from __future__ import annotations

import collections
import math

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


def planes_position_reference(q, a, b, normals, offsets, ids, tol):
    """`_plane_kernels.planes_position` with numpy's linear algebra: the planes that
    add a direction (their normal's part across the planes before it longer than
    `PARALLEL_SINE`), their meet's point nearest the midpoint (pseudo-inverse), the
    directions left (SVD), and the cheapest of the quadric's least point there (when
    well conditioned and within `REACH`) and a, b and the midpoint moved onto the
    meet: ``(cost, x, y, z, ok)``."""
    from pointatlas.simplify._plane_kernels import PARALLEL_SINE, REACH

    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(ids) == 0:
        return (*collapse_position_reference(q, a, b), True)
    kept = []
    for r in ids:
        n = normals[r]
        if kept:
            span = normals[kept]
            n = n - span.T @ np.linalg.lstsq(span.T, n, rcond=None)[0]
        if len(kept) < 3 and np.linalg.norm(n) > PARALLEL_SINE:
            kept.append(r)
    big_n, mid = normals[kept], 0.5 * (a + b)
    x0 = mid + np.linalg.pinv(big_n) @ (offsets[kept] - big_n @ mid)
    free = np.linalg.svd(big_n)[2][len(kept) :]
    candidates = [x0 + free.T @ (free @ (p - x0)) for p in (a, b, mid)]
    if len(free):
        h = free @ q[:3, :3] @ free.T
        g = q[:3, :3] @ x0 + q[:3, 3]
        good = abs(np.linalg.det(h)) > 1e-10 * np.linalg.norm(q[:3, :3]) ** len(free)
        if len(free) == 1:
            good = h[0, 0] > 1e-10 * np.linalg.norm(q[:3, :3])
        least = x0 + free.T @ np.linalg.solve(h, -free @ g) if good else None
        if good and np.linalg.norm(least - mid) <= REACH * np.linalg.norm(a - b):
            candidates.append(least)
    costs = [float(np.append(p, 1.0) @ q @ np.append(p, 1.0)) for p in candidates]
    x = candidates[int(np.argmin(costs))]
    ok = bool(np.all(np.abs(normals[list(ids)] @ x - offsets[list(ids)]) <= tol))
    return (min(costs), *x.tolist(), ok)


def turns_over_reference(v, faces, w, x):
    for f in faces:
        p = v[f].copy()
        before = np.cross(p[1] - p[0], p[2] - p[0])
        p[f == w] = x
        after = np.cross(p[1] - p[0], p[2] - p[0])
        if before @ after <= 0 or after @ after <= 1e-12 * (before @ before):
            return True
    return False


def decimate_reference(vertices, triangles, target, *, labels=None, planes=None, structure=1.0):
    """The decimation loop in plain Python (heap of edges, sets of faces per vertex),
    stopping at ``target`` triangles: what `collapse_edges` computes, with the flat
    regions' planes held (`_plane_kernels`) when ``labels`` and ``planes`` are given.
    The collapse position is the kernel's (checked on its own against
    `collapse_position_reference` and `planes_position_reference`): on symmetric
    shapes one ulp reorders ties."""
    import heapq

    from pointatlas.simplify._decimate import (
        _TIE,
        _cross_tolerances,
        _held_planes,
        _vertex_quadrics,
    )
    from pointatlas.simplify._kernels import collapse_position
    from pointatlas.simplify._plane_kernels import planes_position

    held = _held_planes(np.asarray(vertices, float), np.asarray(triangles), labels, planes)
    tflat = held[0]
    left = np.bincount(tflat[tflat >= 0], minlength=held[2].size)  # live triangles

    def position(v, q, a, b):
        tflat, normals, offsets, tol = held
        if tflat.size == 0:
            cost, x, y, z = collapse_position(q[a] + q[b], v[a], v[b])
        else:
            shared = faces_of[a] & faces_of[b]
            near = (faces_of[a] | faces_of[b]) - shared
            regions = {int(tflat[f]) for f in near if tflat[f] >= 0}
            # a region left with one triangle is planar wherever its vertices go
            removed = [int(tflat[f]) for f in shared]
            regions = {r for r in regions if left[r] - removed.count(r) >= 2}
            ids = np.array(sorted(regions), np.int64)
            cost, x, y, z, ok = planes_position(
                q[a] + q[b], v[a], v[b], normals, offsets, ids, len(ids), tol, np.empty((12, 3))
            )
            if not ok:
                return np.inf, (x, y, z)
        d = v[a] - v[b]
        dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        return max(cost, 0.0) + _TIE * dd * dd, (x, y, z)

    def push(heap, v, q, a, b, version):
        cost, x = position(v, q, a, b)
        heapq.heappush(heap, (cost, a, b, int(version[a]), int(version[b]), x))

    def collapsible(v, tri, faces_of, a, b, shared, x):
        ring_a = {int(u) for f in faces_of[a] for u in tri[f]} - {a}
        ring_b = {int(u) for f in faces_of[b] for u in tri[f]} - {b}
        opposite = {int(u) for f in shared for u in tri[f]} - {a, b}
        if ring_a & ring_b != opposite:
            return False
        sides_a = {frozenset(tri[f].tolist()) - {a} for f in faces_of[a] - shared}
        sides_b = {frozenset(tri[f].tolist()) - {b} for f in faces_of[b] - shared}
        if sides_a & sides_b:
            return False  # the same triangle twice (a tetrahedron)
        if not (faces_of[a] | faces_of[b]) - shared:
            return False  # the last triangles of a piece
        for w, others in ((a, faces_of[a]), (b, faces_of[b])):
            around = list(others - shared)
            if around and turns_over_reference(v, tri[around], w, x):
                return False
        return not fan_crosses_reference(v, tri, faces_of, a, b, shared, x, cross)

    v = np.array(vertices, dtype=np.float64)
    tri = np.array(triangles, dtype=np.int64)
    n_v = v.shape[0]
    cross = _cross_tolerances(v, tri)
    q = _vertex_quadrics(v, tri, labels, planes, structure)
    faces_of = [set() for _ in range(n_v)]
    for f, (a, b, c) in enumerate(tri.tolist()):
        faces_of[a].add(f)
        faces_of[b].add(f)
        faces_of[c].add(f)
    on_boundary = np.zeros(n_v, dtype=bool)
    und = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edge, count = np.unique(und, axis=0, return_counts=True)
    on_boundary[edge[count == 1].reshape(-1)] = True
    alive = np.ones(tri.shape[0], dtype=bool)
    version = np.zeros(n_v, dtype=np.int64)
    heap = []
    for a, b in edge.tolist():
        push(heap, v, q, a, b, version)
    n_alive = tri.shape[0]
    while n_alive > target and heap:
        cost, a, b, va, vb, x = heapq.heappop(heap)
        if version[a] != va or version[b] != vb or not faces_of[a] or not faces_of[b]:
            continue
        cost, x = position(v, q, a, b)  # the same unless a triangle around went
        if cost == np.inf:
            continue
        shared = faces_of[a] & faces_of[b]
        if not shared or (len(shared) == 2 and on_boundary[a] and on_boundary[b]):
            continue  # an inner edge between two boundary vertices would pinch
        if not collapsible(v, tri, faces_of, a, b, shared, np.array(x)):
            continue
        for f in shared:
            alive[f] = False
            if tflat.size and tflat[f] >= 0:
                left[tflat[f]] -= 1
            for w in tri[f].tolist():
                faces_of[w].discard(f)
        n_alive -= len(shared)
        for f in faces_of[b]:
            tri[f][tri[f] == b] = a
        faces_of[a] |= faces_of[b]
        faces_of[b] = set()
        v[a] = x
        q[a] += q[b]
        on_boundary[a] |= on_boundary[b]
        version[a] += 1
        version[b] += 1
        for w in {int(u) for f in faces_of[a] for u in tri[f]} - {a}:
            push(heap, v, q, a, w, version)
    kept = np.flatnonzero(alive)
    used = np.unique(tri[kept])
    remap = np.full(n_v, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return v[used], remap[tri[kept]], kept, used


def _candidate_pairs(y, t, changed, others, cross):
    """The pairs ``(f, g)``, f of ``changed`` and g after it in ``changed + others``,
    sharing at most one corner, whose boxes meet and each of which reaches both sides
    of the other's plane or lies in it (the rest cannot cross: a quick filter in
    numpy before `triangles_cross_reference`)."""
    tol, flat_tol = cross
    near = np.array(changed + others, dtype=np.int64)
    k, m = np.triu_indices(len(near), 1)
    keep = k < len(changed)
    k, m = k[keep], m[keep]
    f, g = near[k], near[m]
    p, q = y[t[f]], y[t[g]]
    meets = (p.min(axis=1) <= q.max(axis=1) + tol).all(1) & (
        q.min(axis=1) <= p.max(axis=1) + tol
    ).all(1)
    same = t[f][:, :, None] == t[g][:, None, :]  # (pairs, f's corner, g's corner)
    n_shared = same.any(axis=2).sum(axis=1)

    def one_side(a, b, b_shared):
        n = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
        n = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        d = np.einsum("pk,pjk->pj", n, b - a[:, :1])
        d = np.where(b_shared, 0.0, d)
        far = np.abs(d) > flat_tol
        return far.any(axis=1) & ((d <= tol).all(axis=1) | (d >= -tol).all(axis=1))

    apart = one_side(p, q, same.any(axis=1)) | one_side(q, p, same.any(axis=2))
    hit = meets & (n_shared < 2) & ~apart
    return list(zip(f[hit].tolist(), g[hit].tolist(), strict=True))


def fan_crosses_reference(v, tri, faces_of, a, b, shared, x, cross):
    """Whether merging ``a`` and ``b`` at ``x`` makes more pairs cross among the
    triangles on them (but the ``shared``) and those on their other vertices than
    crossed among these and the ``shared`` before (`triangles_cross_reference` on
    every pair a quick numpy filter leaves, `_candidate_pairs`)."""
    from .reference_crossings import triangles_cross_reference

    fan = sorted((faces_of[a] | faces_of[b]) - shared)
    link = {int(u) for f in fan for u in tri[f]} - {a, b}
    ring = sorted({f for u in link for f in faces_of[u]} - set(fan) - shared)
    after = v.copy()
    after[a] = after[b] = x
    merged = np.where(tri == b, a, tri)

    def count(y, t, changed, others):
        n = 0
        for f, g in _candidate_pairs(y, t, changed, others, cross):
            common = set(t[f].tolist()) & set(t[g].tolist())
            sp = sq = -1
            if common:
                (c,) = common
                sp, sq = list(t[f]).index(c), list(t[g]).index(c)
            n += bool(triangles_cross_reference(y[t[f]], y[t[g]], sp, sq, *cross))
        return n

    if not fan:
        return False
    new = count(after, merged, fan, ring)
    return new > 0 and new > count(v, tri, fan + sorted(shared), ring)


def place_on_planes_reference(v0, triangles, triangle_face, normals, offsets, flat, bound, still):
    """`place_on_planes` one vertex at a time (before the flip guard)."""
    v0 = np.asarray(v0, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    triangle_face = np.asarray(triangle_face)
    x = v0.copy()
    for j in range(v0.shape[0]):
        regions = sorted({int(f) for f in triangle_face[(tri == j).any(axis=1)]})
        regions = [r for r in regions if flat[r]]
        if not regions:
            continue
        a = normals[regions]
        residual = offsets[regions] - a @ v0[j]
        if np.abs(residual).max() <= still:
            continue
        move = np.linalg.pinv(a, rcond=0.0437) @ residual
        if np.linalg.norm(move) <= bound:
            x[j] = v0[j] + move
    return x


def plane_fits_reference(vertices, triangles, labels, n_regions):
    """`plane_fits` one region at a time in numpy: the SVD of its distinct vertices,
    centred (in order of their index)."""
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    labels = np.asarray(labels)
    normals, offsets = np.zeros((n_regions, 3)), np.zeros(n_regions)
    deviation, spanned = np.zeros(n_regions), np.zeros(n_regions, dtype=bool)
    for r in range(n_regions):
        ids = np.unique(tri[labels == r])
        if ids.size < 3:
            continue
        centre = v[ids].mean(axis=0)
        _, sv, vt = np.linalg.svd(v[ids] - centre, full_matrices=False)
        normals[r], offsets[r] = vt[-1], vt[-1] @ centre
        deviation[r] = np.abs((v[ids] - centre) @ vt[-1]).max()
        spanned[r] = sv[1] > 0.0
    return normals, offsets, deviation, spanned


def ear_clip_reference(points, ids):
    """Open3D's ear clipping in numpy (`_readers.ear_clip_triangles`), one corner test
    at a time."""
    ids = [int(i) for i in ids]
    p = np.asarray(points, dtype=np.float64)
    n = len(ids)
    if n == 3:
        return [tuple(ids)]
    d = np.roll(p, -1, axis=0) - p  # the sides
    normal = np.cross(d, np.roll(d, -1, axis=0)).sum(axis=0)
    length = float(np.sqrt(normal @ normal))
    if not length > 0.0 or not np.isfinite(length):
        return None
    normal = normal / length
    order = list(range(n))
    out = []
    while len(order) > 3:
        cut = _first_ear_reference(p, order, normal)
        if cut is None:
            return None
        out.append((ids[order[cut - 1]], ids[order[cut]], ids[order[cut + 1]]))
        del order[cut]
    out.append(tuple(ids[k] for k in order))
    return out


def _first_ear_reference(p, order, normal) -> int | None:
    q = p[order]
    m = len(order)
    turn = np.cross(q[1:-1] - q[:-2], q[2:] - q[1:-1]) @ normal
    for i in np.flatnonzero(turn > 0.0) + 1:
        others = np.ones(m, dtype=bool)
        others[i - 1 : i + 2] = False
        if not _inside_xy_reference(q[i - 1 : i + 2, :2], q[others, :2]).any():
            return int(i)
    return None


def _inside_xy_reference(tri: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd test of ``pts`` (K, 2) against the triangle ``tri`` (3, 2), rays to -x."""
    inside = np.zeros(pts.shape[0], dtype=bool)
    x, y = pts[:, 0], pts[:, 1]
    for k in range(3):
        (x0, y0), (x1, y1) = tri[k], tri[(k + 1) % 3]
        spans = ((y0 <= y) & (y1 > y)) | ((y1 <= y) & (y0 > y))
        if not spans.any():
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = (x1 - x0) * (y - y0) / (y1 - y0) + x0
        inside ^= spans & (cross < x)
    return inside


def winding_reference(x, points, normals, areas):
    """The winding number of oriented points (discs of ``areas``) at ``x``, summed
    point by point (`pointatlas.simplify._winding.winding_numbers` groups far ones)."""
    e = points[None, :, :] - x[:, None, :]
    r = np.linalg.norm(e, axis=2)
    dot = np.einsum("mnd,nd->mn", e, normals * areas[:, None])
    return (dot / np.maximum(r, 1e-300) ** 3).sum(axis=1) / (4.0 * np.pi)


def winding_cells_reference(x, sources):
    """`_winding.Dipoles.at` as a plain loop (pointatlas.simplify._winding's
    ``sources``): each row sums the cells in order, a cell beyond its reach as its
    one dipole, a near one point by point; the same operations in the same order,
    so the same bits."""
    out = np.zeros(x.shape[0])
    for i, (x0, x1, x2) in enumerate(x):
        s = 0.0
        for c, (cx, cy, cz) in enumerate(sources.centres):
            dx, dy, dz = cx - x0, cy - x1, cz - x2
            r2 = dx * dx + dy * dy + dz * dz
            if r2 > sources.reach2[c] and r2 > 0.0:
                d = sources.cell_dipoles[c]
                s += (d[0] * dx + d[1] * dy + d[2] * dz) / (r2 * math.sqrt(r2))
                continue
            for t in range(sources.starts[c], sources.starts[c + 1]):
                j = sources.order[t]
                ex, ey, ez = (sources.p[j, a] - (x0, x1, x2)[a] for a in range(3))
                e2 = ex * ex + ey * ey + ez * ez
                if e2 > 0.0:
                    d = sources.dipoles[j]
                    s += (d[0] * ex + d[1] * ey + d[2] * ez) / (e2 * math.sqrt(e2))
        out[i] = s / (4.0 * np.pi)
    return out


def band_field_reference(x, points, normals, dist, idx, step, spacing):
    """The robust path's field at nodes ``x`` from their nearest points (``dist``,
    ``idx`` (n, k), nearest first), in numpy over all nodes at once
    (`pointatlas.simplify._kernels.band_field`): the Gaussian-weighted mean of the
    tangent-plane distances of the neighbours within the nearest + ``spacing``; where
    they disagree on the side, the nearest point's distance, outside at a convex turn
    of the surface, inside at a concave one, else with their vote's sign."""
    near = dist <= dist[:, :1] + spacing
    w = np.where(near, np.exp(-((dist / step) ** 2)) + 1e-300, 0.0)
    w /= w.sum(axis=1, keepdims=True)
    signed = np.einsum("nkd,nkd->nk", normals[idx], x[:, None, :] - points[idx])
    values = (w * signed).sum(axis=1)
    side = np.sign(signed) * (np.abs(signed) > 1e-9 * step) * near  # on a plane: abstains
    split = (side > 0).any(axis=1) & (side < 0).any(axis=1)
    vote = side[split].sum(axis=1) + (w[split] * side[split]).sum(axis=1)
    # the nearest point outside whose plane the node lies and the nearest inside:
    # each below the other's plane (convex: outside), above it (concave: inside)
    rows = np.flatnonzero(split)
    ja = idx[rows, np.argmax(side[rows] > 0, axis=1)]
    jb = idx[rows, np.argmax(side[rows] < 0, axis=1)]
    e = points[jb] - points[ja]
    reach = 0.1 * np.linalg.norm(e, axis=1)
    below_a = np.einsum("nd,nd->n", normals[ja], e)
    below_b = -np.einsum("nd,nd->n", normals[jb], e)
    turn = np.where((below_a < -reach) & (below_b < -reach), 1.0, 0.0)
    turn = np.where((below_a > reach) & (below_b > reach), -1.0, turn)
    vote = np.where(turn != 0.0, turn, vote)
    values[split] = np.where(vote >= 0.0, 1.0, -1.0) * dist[split, 0]
    return values


def upsample_reference(w, stride, shape):
    """Values on every node of a grid of ``shape`` from ``w`` on the lattice of every
    ``stride``-th node, linear along axis 0, then 1, then 2 (past the last lattice
    node: its value)."""
    for axis, n in enumerate(shape):
        pos = np.arange(n) / stride
        lo = np.minimum(np.floor(pos).astype(np.int64), w.shape[axis] - 1)
        hi = np.minimum(lo + 1, w.shape[axis] - 1)
        t = np.clip(pos - lo, 0.0, 1.0).reshape([n if a == axis else 1 for a in range(w.ndim)])
        w = np.take(w, lo, axis=axis) * (1.0 - t) + np.take(w, hi, axis=axis) * t
    return w


def far_sides_reference(f, w, far_from, near, stride, clear):
    """`_winding.far_sides`: nodes farther than ``near`` take the interpolated winding
    number's side where it is clear."""
    wf = upsample_reference(w, stride, f.shape)
    far = far_from > near
    size = np.maximum(np.abs(f), far_from)
    f = np.where(far & (wf > 1.0 - clear), -size, f)
    return np.where(far & (wf < clear), size, f)


def _discs_reference(surface, x, d, j):
    """Distance of every row of ``x`` to the discs of its nearest points ``j`` (at
    distances ``d``) of a `PointSurface`, and its height over their planes."""
    h = np.abs(np.einsum("ikd,ikd->ik", x[:, None, :] - surface.points[j], surface.normals[j]))
    t = np.sqrt(np.maximum(d * d - h * h, 0.0))
    return np.hypot(h, np.maximum(t - surface.radius[j], 0.0)), h


def disc_distance_reference(surface, x, candidates):
    """`PointSurface.distance` with normals: the nearest of ``candidates`` discs."""
    d, j = surface.tree.query(x, k=candidates)
    return _discs_reference(surface, x, d, j)[0].min(axis=1)


def outline_distance_reference(surface, x, neighbors, candidates, margin):
    """`PointSurface.outline_distance` with normals, in numpy."""
    d, j = surface.tree.query(x, k=neighbors)
    disc, h = _discs_reference(surface, x, d[:, :candidates], j[:, :candidates])
    rows = np.arange(x.shape[0])
    best = disc.argmin(axis=1)
    n = surface.normals[j[rows, best]]
    off = surface.points[j] - x[:, None, :]
    off -= np.einsum("ikd,id->ik", off, n)[:, :, None] * n[:, None, :]
    e1 = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    turn = np.sort(
        np.arctan2(np.einsum("ikd,id->ik", off, e2), np.einsum("ikd,id->ik", off, e1)), axis=1
    )
    gaps = np.column_stack([np.diff(turn, axis=1), turn[:, 0] + 2.0 * np.pi - turn[:, -1]])
    g = gaps.argmax(axis=1)
    gap = gaps[rows, g]
    across = turn[rows, g] + 0.5 * gap  # the gap's middle direction
    u = np.cos(across)[:, None] * e1 + np.sin(across)[:, None] * e2
    past = np.maximum(-np.einsum("ikd,id->ik", off, u).max(axis=1), 0.0)
    near = disc[rows, best]
    out = gap > np.pi + margin
    return np.where(out, np.maximum(near, np.hypot(h[rows, best], past)), near)


def untangle_reference(v0, placed, triangles, face, flat, source, kept, went):
    """`_untangle.untangle` with the plain Python passes (`merge_round_reference`)."""
    from pointatlas.simplify._untangle import _untangle

    return _untangle(merge_round_reference, v0, placed, triangles, face, flat, source, kept, went)


def merge_round_reference(x, rows, side, face, ring, deg, alive, into, rank, order, tiny):
    """`_untangle_kernels.merge_round` in plain Python: each vertex's triangles a set
    (``ring`` and ``deg`` are not read), the merges and flips one at a time (edge
    lengths and areas as plain sums of products, as the kernels compute them)."""
    around = collections.defaultdict(set)
    for t in np.flatnonzero(alive).tolist():
        for v in rows[t].tolist():
            around[v].add(t)
    done = 0
    for t in order.tolist():
        if alive[t]:
            done += _merge_one_reference(x, rows, side, around, alive, into, rank, t, tiny) or (
                _flip_one_reference(x, rows, side, face, around, t, tiny)
            )
    return done, ring


def _length_reference(x, a, b) -> float:
    d = (x[a] - x[b]).tolist()
    return math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])


def _along_reference(n, a, b, c) -> float:
    from pointatlas.simplify._caps import _cross3

    u = _cross3(a, b, c)
    return n[0] * u[0] + n[1] * u[1] + n[2] * u[2]


def _merge_one_reference(x, rows, side, around, alive, into, rank, t, tiny) -> int:
    from pointatlas.simplify._caps import _find, _link_ok, _merge

    row = [_find(into, int(v)) for v in rows[t]]
    edges = [(row[k], row[(k + 1) % 3]) for k in range(3)]
    edges.sort(key=lambda e: _length_reference(x, e[0], e[1]))
    for a, b in edges:
        if rank[a] == rank[b] == np.inf:
            continue
        ways = [(a, b), (b, a)] if rank[a] == rank[b] else [(a, b) if rank[a] > rank[b] else (b, a)]
        for p, q in ways:
            if _link_ok(rows, around, p, q) and _stays_reference(x, rows, side, around, p, q, tiny):
                _merge(rows, around, alive, into, p, q)
                return 1
    return 0


def _stays_reference(x, rows, side, around, p, q, tiny) -> bool:
    for t in around[q] - around[p]:
        a, b, c = (x[v].tolist() if v != q else x[p].tolist() for v in rows[t].tolist())
        if _along_reference(side[t].tolist(), a, b, c) <= tiny:
            return False
    return True


def _flip_one_reference(x, rows, side, face, around, t, tiny) -> int:
    from pointatlas.simplify._caps import _cross3

    row = rows[t].tolist()
    a, b, c = (x[v].tolist() for v in row)
    if math.sqrt(sum(s * s for s in _cross3(a, b, c))) > tiny:
        return 0
    k = max(range(3), key=lambda i: _length_reference(x, row[(i + 1) % 3], row[i]))
    a, b, c = row[k], row[(k + 1) % 3], row[(k + 2) % 3]
    others = (around[a] & around[b]) - {t}
    if len(others) != 1:
        return 0
    u = others.pop()
    d = next(int(v) for v in rows[u].tolist() if v != a and v != b)
    if d == c or around[c] & around[d]:
        return 0
    n = side[u].tolist()
    first = _along_reference(n, x[a].tolist(), x[d].tolist(), x[c].tolist())
    second = _along_reference(n, x[d].tolist(), x[b].tolist(), x[c].tolist())
    if min(first, second) <= tiny:
        return 0
    rows[t], rows[u] = [a, d, c], [d, b, c]
    face[t], side[t] = face[u], side[u]
    around[a].discard(u)
    around[b].discard(t)
    around[c].add(u)
    around[d].add(t)
    return 1


def fan_kind_reference(p, normal, s, tol):
    """`_polygon_kernels.fan_kind` in numpy: the fan triangles from vertex ``s`` all
    turning the polygon's way by more than ``tol`` (2), none against it (1), else 0."""
    d = np.concatenate((p[s + 1 :], p[:s])) - p[s]
    area = np.cross(d[:-1], d[1:]) @ normal
    if (area > tol).all():
        return 2
    return 1 if (area >= -tol).all() else 0
