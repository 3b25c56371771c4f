"""Triangles that placing vertices on their planes turned over, mended by merging
vertices (private).

At a coarse level of the points path a row of vertices lies along the rounded edge of
the voxel surface, with vertices of the faces beside it within a grid step of the
edge's line. Placed on the line of their two planes, the row's vertices pass those
neighbours (a triangle turns over) or meet them on the line (a triangle loses its
area), and putting them back (`_place._unflip`) left them up to 0.3 % of the diagonal
off their planes: their faces were not planar (the polygons split into their
triangles) and a plane refitted to the points made a sampled L-bracket's corner come
out 0.3 % off. `untangle` instead merges a vertex of every such triangle into
another (an edge collapse under the link condition, `_caps`): the vertex on more
flat faces stays where it was placed, so the row ends on the line, and no triangle
around the merge turns over. What it cannot merge is put back as before.
"""

from __future__ import annotations

import collections

import numpy as np

from ._caps import CAP_RTOL, _find, _link_ok, _merge, compact, outline_vertices
from ._mesh import unique_pairs
from ._place import _cross

__all__ = ["ROUNDS", "untangle"]

#: Passes over the triangles left without area (each merges what it can).
ROUNDS = 4


def untangle(v0, placed, triangles, face, flat, source, kept, went):
    """Merge away the triangles that ``placed`` turned over or left without area.

    Parameters
    ----------
    v0, placed : ndarray of shape (V, 3)
        The vertices before and after their placement on their planes.
    triangles : ndarray of shape (T, 3), int64
        Consistently oriented triangles of a manifold mesh.
    face : ndarray of shape (T,), int64
        The face of each triangle; ``flat`` (F,) bool: which faces are flat.
    source, kept, went : ndarray
        The lineage, as `_caps.weld_needles` takes it.

    Returns
    -------
    tuple
        ``(v0, placed, triangles, face, source, kept, went, normals)`` without the
        merged vertices and the triangles the merges removed (the inputs when every
        triangle keeps more than `CAP_RTOL` of the mean triangle's area along its
        former normal, or nothing can be merged); ``normals``: each triangle's unit
        normal before the placement (zero where it had no area), for `_place._unflip`
        (a merged triangle never was at ``v0``: its shape there says nothing).

    Examples
    --------
    Vertices 3 and 4 inside a triangle placed onto its edge x = 0: the triangles
    they leave without area go, the triangle is whole again.

    >>> v = np.array([[0, 0, 0], [0, 2, 0], [2, 1, 0], [0.1, 1, 0], [0.3, 1.5, 0.0]])
    >>> t = np.array([[0, 2, 3], [3, 2, 4], [4, 2, 1], [0, 3, 1], [3, 4, 1]])
    >>> x = v.copy(); x[3, 0] = x[4, 0] = 0.0
    >>> out = untangle(v, x, t, np.array([0, 0, 0, 1, 1]), np.ones(2, bool),
    ...                np.arange(5), np.arange(5), np.arange(5))
    >>> out[1].tolist(), out[2].tolist(), (out[7] == [0, 0, 1]).all()
    ([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [2.0, 1.0, 0.0]], [[0, 2, 1]], np.True_)
    """
    v0 = np.asarray(v0, dtype=np.float64)
    x = np.asarray(placed, dtype=np.float64)
    rows = np.array(triangles, dtype=np.int64)
    face = np.array(face, dtype=np.int64)  # a flipped cap takes its neighbour's face
    c0 = _cross(v0, rows)
    twice = np.linalg.norm(c0, axis=1)
    side = c0 / np.maximum(twice, 1e-300)[:, None]
    out = (v0, x, rows, face, source, kept, went, side)
    if rows.shape[0] == 0:
        return out
    tiny = 2.0 * CAP_RTOL * float(0.5 * twice.mean())  # twice the area, as `_cross`
    rank = _flat_faces(rows, face, flat, x.shape[0]).astype(np.float64)
    rank[outline_vertices(rows)] = np.inf  # an open boundary's vertex is never merged away
    into = np.arange(x.shape[0])
    alive = np.ones(rows.shape[0], dtype=bool)
    merged = False
    for _ in range(ROUNDS):
        area = np.einsum("ij,ij->i", side, _cross(x, rows))
        bad = np.flatnonzero(alive & (area <= tiny) & (twice > 0.0))
        if bad.size == 0:
            break
        around = _around(rows, alive, np.unique(rows[bad]))
        done = 0
        for t in bad[np.argsort(area[bad], kind="stable")].tolist():
            if alive[t]:
                done += _merge_one(x, rows, side, around, alive, into, rank, t, tiny) or (
                    _flip_one(x, rows, side, face, around, t, tiny)
                )
        if done == 0:
            break
        merged = True
    if not merged:
        return out
    return (*compact(rows, alive, into, (v0, x), face, source, kept, went), side[alive])


def _flip_one(x, rows, side, face, around, t: int, tiny: float) -> int:
    """Flip the longest edge of triangle ``t`` where it is a cap (three vertices in a
    row, placed on the line of two planes, the middle one ``c`` on edge ``a b``): it
    and its neighbour ``b a d`` become ``a d c`` and ``d b c``, both of the
    neighbour's face and side (they cover the neighbour's area: the cap had none),
    where both keep an area along that side and ``c d`` is not an edge yet (a cap
    across two faces, which `_caps.flip_caps` leaves, and whose merge the link
    condition refuses along a row). 1 if flipped, else 0."""
    row = rows[t].tolist()
    if float(np.linalg.norm(_cross(x, np.asarray(row)[None])[0])) > tiny:
        return 0  # turned over with an area, not a cap
    k = max(range(3), key=lambda i: float(np.linalg.norm(x[row[(i + 1) % 3]] - x[row[i]])))
    a, b, c = row[k], row[(k + 1) % 3], row[(k + 2) % 3]
    others = (around[a] & around[b]) - {t}
    if len(others) != 1:
        return 0
    u = others.pop()
    d = next(int(v) for v in rows[u].tolist() if v != a and v != b)
    if d == c or around[c] & around[d]:
        return 0
    first, second = np.array([a, d, c]), np.array([d, b, c])
    n = side[u]
    if min(float(n @ _cross(x, r[None])[0]) for r in (first, second)) <= tiny:
        return 0
    rows[t], rows[u] = first, second
    face[t], side[t] = face[u], n
    around[a].discard(u)
    around[b].discard(t)
    around[c].add(u)
    around[d].add(t)
    return 1


def _flat_faces(rows, face, flat, n_v: int) -> np.ndarray:
    """The number of flat faces around every vertex."""
    pairs = unique_pairs(np.column_stack([rows.reshape(-1), np.repeat(face, 3)]))
    pairs = pairs[flat[pairs[:, 1]]]
    return np.bincount(pairs[:, 0], minlength=n_v)


def _around(rows, alive, ends):
    """The live triangles of every vertex of the triangles around ``ends`` (what the
    link test of an edge between two of ``ends`` reads)."""
    live = np.flatnonzero(alive)
    near = live[np.isin(rows[live], ends).any(axis=1)]
    ring = np.unique(rows[near])
    near = live[np.isin(rows[live], ring).any(axis=1)]
    around = collections.defaultdict(set)
    for t, row in zip(near.tolist(), rows[near].tolist(), strict=True):
        for v in row:
            around[v].add(t)
    return around


def _merge_one(x, rows, side, around, alive, into, rank, t: int, tiny: float) -> int:
    """Merge the shortest edge of triangle ``t`` that can be merged: its end on fewer
    flat faces into the other (either way on a tie), where the mesh stays manifold
    and no other triangle of the gone end then turns over. 1 if merged, else 0."""
    row = [_find(into, int(v)) for v in rows[t]]
    edges = [(row[k], row[(k + 1) % 3]) for k in range(3)]
    edges.sort(key=lambda e: float(np.linalg.norm(x[e[0]] - x[e[1]])))
    for a, b in edges:
        if rank[a] == rank[b] == np.inf:
            continue
        ways = [(a, b), (b, a)] if rank[a] == rank[b] else [(a, b) if rank[a] > rank[b] else (b, a)]
        for p, q in ways:
            if _link_ok(rows, around, p, q) and _stays(x, rows, side, around, p, q, tiny):
                _merge(rows, around, alive, into, p, q)
                return 1
    return 0


def _stays(x, rows, side, around, p: int, q: int, tiny: float) -> bool:
    """Every triangle of q but those of edge p q keeps its side with q at p (plain
    floats: a few triangles at a time, where numpy's per-call cost dominated)."""
    px, py, pz = x[p].tolist()
    for t in around[q] - around[p]:
        a, b, c = (x[v].tolist() if v != q else (px, py, pz) for v in rows[t].tolist())
        u = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
        w = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
        n = side[t].tolist()
        along = (
            n[0] * (u[1] * w[2] - u[2] * w[1])
            + n[1] * (u[2] * w[0] - u[0] * w[2])
            + n[2] * (u[0] * w[1] - u[1] * w[0])
        )
        if along <= tiny:
            return False
    return True
