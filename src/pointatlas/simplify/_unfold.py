"""Flat faces whose triangles fold over each other in their plane, triangulated
again from their outline (private).

On the points path a flat face's vertices are moved onto its plane (and its edges'
lines) after the collapses; a vertex moved past its neighbours there turns a
triangle over inside the face, which then covers part of the face twice: two of its
triangles pass through each other although every edge is shared by two triangles
(`_crossings`). The face itself is still the polygon its outline bounds: where that
outline is simple in the face's plane, earcut triangulates it again
(`_surface_faces.face_of_loops`: the new triangles cover the outline's area once and
have its edges), Lawson's flips make that the constrained Delaunay triangulation of
the outline (`delaunay_flips`), and the vertices inside the face, which then belong
to no triangle, are dropped. Decisions in docs/decisions/simplify.md ("Self-intersections").
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ._crossings import crossing_pairs
from ._faces import plane_deviation
from ._mesh import cross, plane_basis, unique_ints
from ._surface_faces import face_of_loops

__all__ = ["delaunay_flips", "folded_faces", "unfolded"]

#: A new triangle of less area than this share of the diagonal squared is not made
#: (the benchmarks' zero-area triangles: `degenerate`).
MIN_AREA_RTOL = 1e-12

#: `delaunay_flips` stops after this many flips per triangle (Lawson's flips end
#: after at most the square of the vertices; a bound against a loop on rounding).
FLIPS_PER_TRIANGLE = 10


def folded_faces(x: np.ndarray, tri: np.ndarray, face: np.ndarray, flat: np.ndarray):
    """The labels of ``face`` (T,) whose triangles pass through another triangle of
    the same face (``flat`` (L,): which labels are flat; others are not listed),
    ascending; and the crossing pairs (`crossing_pairs`)."""
    pairs = crossing_pairs(x, tri)
    fa, fb = face[pairs[:, 0]], face[pairs[:, 1]]
    same = fa == fb
    inside = np.zeros(same.shape, dtype=bool)
    inside[same] = fa[same] < flat.size
    inside[inside] = flat[fa[inside]]
    return unique_ints(fa[inside]), pairs


def _loops(tri: np.ndarray) -> list[np.ndarray] | None:
    """The boundary loops of ``tri`` (k, 3) in the triangles' direction; None where a
    vertex starts two boundary edges (the triangles pinch there)."""
    d = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    n = int(tri.max()) + 1
    key, back = d[:, 0] * n + d[:, 1], d[:, 1] * n + d[:, 0]
    edge = d[~np.isin(key, back)]
    if edge.shape[0] == 0 or unique_ints(edge[:, 0]).size != edge.shape[0]:
        return None
    nxt = dict(zip(edge[:, 0].tolist(), edge[:, 1].tolist(), strict=True))
    loops = []
    while nxt:
        start = min(nxt)
        loop = [start]
        v = nxt.pop(start)
        while v != start:
            if v not in nxt:  # an edge with a repeated end: not a loop
                return None
            loop.append(v)
            v = nxt.pop(v)
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def _retriangulated(x: np.ndarray, tri: np.ndarray, min_area: float):
    """``tri`` (k, 3), the triangles of one face, triangulated again from their
    outline in the plane of their summed normal; None where the outline is not a
    simple polygon there or a new triangle would have less area than ``min_area``."""
    loops = _loops(tri)
    if loops is None:
        return None
    normals = cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]])
    normal = normals.sum(axis=0)
    size = float(np.linalg.norm(normal))
    if size == 0.0:
        return None
    made = face_of_loops(loops, x, normal / size, every_vertex=True)
    if made is None:
        return None
    u, v = plane_basis(normal / size)
    used = unique_ints(made[1])
    local = np.full(x.shape[0], -1, dtype=np.int64)
    local[used] = np.arange(used.size)
    xy = x[used] - x[used].mean(axis=0)
    new = used[delaunay_flips(local[made[1]], np.stack([xy @ u, xy @ v], axis=1))]
    area = 0.5 * np.linalg.norm(
        cross(x[new[:, 1]] - x[new[:, 0]], x[new[:, 2]] - x[new[:, 0]]), axis=1
    )
    return new if bool((area > min_area).all()) else None


def _orient(p, a, b, c) -> float:
    """Twice the signed area of the 2-D triangle ``p[a] p[b] p[c]`` (``p``: a list
    of coordinate pairs)."""
    (ax, ay), (bx, by), (cx, cy) = p[a], p[b], p[c]
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def _in_circle(p, a, b, c, d) -> bool:
    """``p[d]`` strictly inside the circle through the counter-clockwise ``p[a]
    p[b] p[c]`` (the determinant of their offsets from ``p[d]`` and squared
    lengths)."""
    dx, dy = p[d]
    ax, ay = p[a][0] - dx, p[a][1] - dy
    bx, by = p[b][0] - dx, p[b][1] - dy
    cx, cy = p[c][0] - dx, p[c][1] - dy
    aw, bw, cw = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    det = ax * (by * cw - bw * cy) - ay * (bx * cw - bw * cx) + aw * (bx * cy - by * cx)
    return det > 0.0


def delaunay_flips(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``tri`` (k, 3), counter-clockwise in the 2-D coordinates ``p`` (V, 2), with
    its inner edges flipped until each pair of triangles across one is Delaunay
    (Lawson's flips: the constrained Delaunay triangulation of the same outline,
    which makes the smallest angle as large as it can be, so earcut's ears at
    nearly straight vertices of the outline become triangles with area); an edge
    is flipped only where both new triangles stay counter-clockwise and the new
    edge is not one already. The edges to test are kept on a stack: each flip puts
    the four edges of its quad back on it.

    Examples
    --------
    >>> p = np.array([[0, 0], [4, 0], [4, 1], [0, 1.0]])
    >>> delaunay_flips(np.array([[0, 1, 2], [0, 2, 3]]), p).tolist()
    [[0, 1, 2], [0, 2, 3]]
    >>> p = np.array([[0, 0], [2, -0.1], [4, 0], [2, 3.0]])
    >>> delaunay_flips(np.array([[0, 1, 2], [0, 2, 3]]), p).tolist()
    [[1, 2, 3], [0, 1, 3]]
    """
    t = tri.tolist()
    pts = [tuple(row) for row in p.tolist()]
    by_edge = {(r[i], r[(i + 1) % 3]): k for k, r in enumerate(t) for i in range(3)}
    stack = sorted(e for e in by_edge if e[0] < e[1] and (e[1], e[0]) in by_edge)
    stack.reverse()  # the lowest edge first
    budget = FLIPS_PER_TRIANGLE * len(t)
    while stack and budget > 0:
        a, b = stack.pop()
        k, j = by_edge.get((a, b)), by_edge.get((b, a))
        if k is None or j is None:
            continue  # flipped away since it was put on the stack
        c = next(v for v in t[k] if v not in (a, b))
        d = next(v for v in t[j] if v not in (a, b))
        if (c, d) in by_edge or (d, c) in by_edge or not _in_circle(pts, a, b, c, d):
            continue
        if _orient(pts, a, d, c) <= 0.0 or _orient(pts, d, b, c) <= 0.0:
            continue
        for row in (t[k], t[j]):
            for i in range(3):
                del by_edge[(row[i], row[(i + 1) % 3])]
        t[k], t[j] = [a, d, c], [d, b, c]
        for m in (k, j):
            for i in range(3):
                by_edge[(t[m][i], t[m][(i + 1) % 3])] = m
        stack.extend([(a, d), (d, b), (b, c), (c, a)])
        budget -= 1
    return np.array(t, dtype=np.int64).reshape(-1, 3)


def _edge_counts(tri: np.ndarray) -> Counter:
    """How many of the triangles ``tri`` (k, 3) hold each undirected edge."""
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return Counter(map(tuple, e.tolist()))


def unfolded(x, tri, face, folded, diag: float, tol: float):
    """``(x, tri, face, kept)``: the mesh with every face of ``folded`` (labels of
    ``face``, `folded_faces`) triangulated again from its outline (`_retriangulated`;
    a face whose outline is not simple in its plane stays as it was), the vertices
    then on no triangle dropped (``kept``: the old index of each vertex left, for
    arrays per vertex). Only faces planar within ``tol`` (their vertices to their
    least-squares plane) are triangulated again: a bent face's outline bounds
    another surface than its triangles. The triangles of the other faces keep their
    order, the new ones come last. Unchanged (the same arrays) where no face was
    triangulated again. A face is left as it was where a new inner edge is an edge
    of other triangles too (two of its outline's vertices joined outside it)."""
    min_area = MIN_AREA_RTOL * diag * diag
    keep = np.ones(tri.shape[0], dtype=bool)
    new_t, new_f = [], []
    edges = _edge_counts(tri)
    for f in folded.tolist():
        rows = np.flatnonzero(face == f)
        if plane_deviation(x[unique_ints(tri[rows])]) > tol:
            continue
        made = _retriangulated(x, tri[rows], min_area)
        if made is None:
            continue
        edges.subtract(_edge_counts(tri[rows]))
        inner = [e for e, c in _edge_counts(made).items() if c == 2]
        if any(edges[e] > 0 for e in inner):  # an edge of another face's triangles
            edges.update(_edge_counts(tri[rows]))
            continue
        edges.update(_edge_counts(made))
        keep[rows] = False
        new_t.append(made)
        new_f.append(np.full(made.shape[0], f, dtype=face.dtype))
    if not new_t:
        return x, tri, face, np.arange(x.shape[0])
    t = np.concatenate([tri[keep], *new_t])
    f = np.concatenate([face[keep], *new_f])
    kept = unique_ints(t)
    renumber = np.full(x.shape[0], -1, dtype=np.int64)
    renumber[kept] = np.arange(kept.size)
    return x[kept], renumber[t], f, kept
