"""Zero-area triangles ended by merging vertices and by edge flips (private).

Placing vertices on their planes sends every vertex near a corner of three planes
to that corner: two of them on one spot leave a *needle*, a triangle with an edge of
no length. `weld_needles` merges the two ends of every such edge (an edge collapse
that moves nothing), and of every edge a thousandth of the mean edge long whose
triangle has no area (a cluster of vertices placed a hair apart), where the mesh
stays manifold (the link condition: the two ends share exactly the neighbours of the
triangles the edge bounds).

Placing vertices on the line where two planes meet can leave three of them in a row:
the triangle they make has no area (a *cap*: its middle vertex lies on its longest
edge). The polygon faces do not mind (the triangle lies inside one), but the
triangles file, and any reader that checks its triangles, does. `flip_caps` flips a
cap's longest edge: the cap and its neighbour across that edge, quad ``a, d, b, c``
with ``c`` on ``a b``, become ``a d c`` and ``d b c``, which cover the same area with
the same orientation; the vertices and the faces' outlines stay as they are. A flip
is made only inside one region (a region's outline is its polygon), where the new
edge is not already an edge (the mesh stays manifold) and both new triangles keep
area along the neighbour's normal (no fold). A flip can leave a new cap where a row
holds more than three vertices: the passes repeat while they flip something.

Where the link test fails only on a fold (merged, two triangles around the twins
would be one triangle turned both ways: the voxel surface folded over between them
and a neighbour of both), the twins merge and the fold goes with them, when every
vertex around is one closed fan after (`_merge_folded`; a vertex of the fold left
without a triangle goes into the merged one).

What neither ends `_spread.spread_tiny` ends by moving a vertex inside its face.
"""

from __future__ import annotations

import collections

import numpy as np

from ._mesh import cross, unique_pairs, vertex_triangles
from ._place import _cross

__all__ = [
    "CAP_RTOL",
    "CLUSTER_RTOL",
    "NEEDLE_RTOL",
    "flip_caps",
    "outline_vertices",
    "compact",
    "weld_needles",
]

#: A triangle is a cap when its area is at most this fraction of the mean triangle's.
CAP_RTOL = 1e-6
#: Passes over the caps at most (each one flips what it can).
_PASSES = 8
#: An edge is of no length when it is at most this fraction of the mean edge ...
NEEDLE_RTOL = 1e-7
#: ... or, as an edge of a triangle without area (`CAP_RTOL`), at most this fraction:
#: vertices placed a millionth of the diagonal apart make a cluster whose triangles
#: no move of one vertex gives an area (`_spread.spread_tiny`), only merging them.
CLUSTER_RTOL = 1e-3


def weld_needles(vertices, triangles, face, source, kept, went):
    """Merge the two ends of every edge of no length (`NEEDLE_RTOL`), or short and of a
    triangle without area (`CLUSTER_RTOL`), where the mesh stays manifold.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Vertex coordinates.
    triangles : ndarray of shape (T, 3), int64
        Consistently oriented triangles of a manifold mesh.
    face, kept : ndarrays of shape (T,), int64
        Per triangle: its face, and the input triangle it came from.
    source : ndarray of shape (V,), int64
        Per vertex: the input vertex it came from.
    went : ndarray of shape (N,), int64
        Per input vertex: the vertex it became (-1: none).

    Returns
    -------
    tuple
        ``(vertices, triangles, face, source, kept, went)`` without the merged
        vertices and the triangles that lost their area (the inputs when no edge
        is of no length), nor a triangle without area that is a piece of its own
        (none of its vertices on another triangle: no merge gives it an area, and
        `_spread.spread_tiny` leaves an outline where it is).
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    out = (v, tri, face, source, kept, went)
    if tri.shape[0] == 0:
        return out
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    length = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1)
    area = _areas(v, tri)
    no_area_t = area <= CAP_RTOL * float(area.mean())
    alone = no_area_t & (np.bincount(tri.ravel(), minlength=v.shape[0])[tri] == 1).all(axis=1)
    no_area = np.tile(no_area_t, 3)  # each edge's triangle
    mean = float(length.mean())
    short = np.flatnonzero(
        ((length <= NEEDLE_RTOL * mean) | (no_area & (length <= CLUSTER_RTOL * mean)))
        & ~np.tile(alone, 3)
    )
    if short.size == 0 and not alone.any():
        return out
    into = np.arange(v.shape[0])  # each vertex, or the one it merged into
    alive = ~alone
    rows = tri.copy()
    # the triangles of each vertex, for those of the triangles around an edge's ends
    # and of their neighbours (the link test reads only the ends' sets, a merge only
    # their triangles, a merge across a fold the neighbours' fans)
    ends = np.unique(edges[short])
    ends = np.unique(rows[np.isin(rows, ends).any(axis=1)])
    near = np.flatnonzero(np.isin(rows, ends).any(axis=1))
    around = collections.defaultdict(set)
    for t, row in zip(near.tolist(), rows[near].tolist(), strict=True):
        for x in row:
            around[x].add(t)
    for p, q in edges[short[np.argsort(length[short], kind="stable")]]:
        p, q = _find(into, int(p)), _find(into, int(q))
        if p == q or not _no_fold(v, rows, around, p, q):
            continue
        if _link_ok(rows, around, p, q):
            _merge(rows, around, alive, into, p, q)
        else:
            _merge_folded(rows, around, alive, into, p, q)
    if alive.all():
        return out
    return compact(rows, alive, into, (v,), face, source, kept, went)


def compact(rows, alive, into, coords, face, source, kept, went):
    """The mesh after merges (`_merge`): the live ``rows``, the used vertices of each
    array of ``coords`` renumbered, and the lineage ``face, kept`` (per triangle),
    ``source`` (per vertex), ``went`` (per input vertex) to match."""
    rows = rows[alive]
    used = np.unique(rows)
    remap = np.full(coords[0].shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    final = remap[_root(into)]
    went = np.asarray(went, dtype=np.int64)
    went = np.where(went >= 0, final[np.maximum(went, 0)], -1)
    return (*[c[used] for c in coords], remap[rows], face[alive], source[used], kept[alive], went)


def _find(into: np.ndarray, x: int) -> int:
    """The vertex ``x`` was last merged into (itself when none)."""
    while into[x] != x:
        x = int(into[x])
    return x


def _root(into: np.ndarray) -> np.ndarray:
    """Each vertex's last merge target (merges chain: p into q, then q into r)."""
    out = into.copy()
    while True:
        nxt = out[out]
        if (nxt == out).all():
            return out
        out = nxt


def _no_fold(v, rows, around, p: int, q: int) -> bool:
    """Moving q's other triangles from q to p turns none of them with an area over
    (plain floats: a few triangles at a time, where numpy's per-call cost dominated:
    0.87 s of a run's 1 s of welds)."""
    pv = v[p].tolist()
    for t in around[q] - around[p]:
        row = rows[t].tolist()
        a, b, c = (v[x].tolist() for x in row)
        before = _cross3(a, b, c)
        after = _cross3(*(pv if x == q else y for x, y in zip(row, (a, b, c), strict=True)))
        if before[0] * after[0] + before[1] * after[1] + before[2] * after[2] < 0.0:
            return False
    return True


def _cross3(a, b, c):
    """(b - a) x (c - a) of three points given as lists."""
    u = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    w = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
    return (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])


def _link_ok(rows, around, p: int, q: int) -> bool:
    """Edge p q is inside the mesh with two triangles, and p and q share no other
    neighbour: merging them keeps the mesh manifold."""
    both = around[p] & around[q]
    if len(both) != 2:
        return False
    opposite = {int(x) for t in both for x in rows[t] if x != p and x != q}
    if len(opposite) != 2:
        return False
    near_p = {int(x) for t in around[p] for x in rows[t]} - {p}
    near_q = {int(x) for t in around[q] for x in rows[t]} - {q}
    if (near_p & near_q) != opposite:
        return False
    # an inner edge between two vertices of an open outline would pinch it
    return not (_on_outline(rows, around, p) and _on_outline(rows, around, q))


def _on_outline(rows, around, p: int) -> bool:
    """Whether an edge of p is in one triangle (its other end in one of p's)."""
    count = collections.Counter(int(x) for t in around[p] for x in rows[t] if x != p)
    return 1 in count.values()


def _merge(rows, around, alive, into, p: int, q: int) -> None:
    """Vertex q merged into p: the two triangles of edge p q go."""
    for t in around[p] & around[q]:
        alive[t] = False
        for x in rows[t]:
            around[x].discard(t)
    for t in around[q]:
        rows[t][rows[t] == q] = p
        around[p].add(t)
    around[q] = set()
    into[q] = p


def _merge_folded(rows, around, alive, into, p: int, q: int) -> bool:
    """Vertex q merged into p where the link condition fails only on a fold: after
    the merge two triangles around p would be one triangle twice, turned opposite
    ways (a triangle the surface folded over, between the twins and a vertex both
    neighbour), and with both gone every vertex around is manifold again (its
    triangles one closed fan). The fold's other vertices left without a triangle go
    into p. Returns whether the merge was made (nothing changes otherwise)."""
    both = around[p] & around[q]
    if len(both) != 2:
        return False
    after = {t: rows[t].copy() for t in (around[p] | around[q]) - both}
    for row in after.values():
        row[row == q] = p
    by_set = collections.defaultdict(list)
    for t, row in after.items():
        by_set[frozenset(row.tolist())].append(t)
    folds = [ts for ts in by_set.values() if len(ts) > 1]
    if not folds or any(len(ts) != 2 or not _opposite(after[ts[0]], after[ts[1]]) for ts in folds):
        return False
    gone = both | {t for ts in folds for t in ts}
    touched = {int(x) for t in gone for x in after.get(t, rows[t])} - {q}
    fans = {}
    for x in touched:
        near = (around[x] | around[q]) if x == p else around[x]
        fans[x] = [after.get(t, rows[t]) for t in near - gone]
    orphans = [x for x in touched if x != p and not fans[x]]
    if not all(_closed_fan(fans[x], x) for x in touched if x not in orphans):
        return False
    for t in gone - both:  # the fold; `_merge` drops the edge's two triangles
        alive[t] = False
        for x in rows[t]:
            around[int(x)].discard(t)
    _merge(rows, around, alive, into, p, q)
    for x in orphans:
        into[x] = p
    return True


def _opposite(a, b) -> bool:
    """Whether triangles a and b (the same three vertices) are turned opposite ways."""
    i = int(np.flatnonzero(b == a[0])[0])
    return bool(b[(i + 1) % 3] == a[2] and b[(i + 2) % 3] == a[1])


def _closed_fan(rows, c: int) -> bool:
    """Whether the triangles ``rows`` around vertex c make one closed fan, turned one
    way (each edge from c in two of them, once each way)."""
    step = {}
    for row in rows:
        i = int(np.flatnonzero(row == c)[0])
        a, b = int(row[(i + 1) % 3]), int(row[(i + 2) % 3])
        if a in step:
            return False
        step[a] = b
    if not step or set(step) != set(step.values()):
        return False
    x, n = next(iter(step)), 0
    while True:
        x, n = step[x], n + 1
        if x == next(iter(step)):
            return n == len(step)


def flip_caps(vertices, triangles, face) -> np.ndarray:
    """``triangles`` with the longest edge of every cap flipped where it can be.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Vertex coordinates.
    triangles : ndarray of shape (T, 3), int64
        Consistently oriented triangles of a manifold mesh.
    face : ndarray of shape (T,), int64
        The face (region) of each triangle; a flip stays inside one face, each
        triangle keeps its row and so its face.

    Returns
    -------
    ndarray of shape (T, 3), int64
        The triangles (a copy; the input when nothing is a cap).
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tiny = _tiny(v, tri)
    if tiny is None:
        return tri
    tri = tri.copy()
    edge_of = _EdgeOwners(tri)
    for _ in range(_PASSES):
        caps = np.flatnonzero(_areas(v, tri) <= tiny)
        flipped = sum(_flip(v, tri, face, edge_of, int(t), tiny) for t in caps)
        if flipped == 0:
            break
    return tri


def _flip(v, tri, face, edge_of, t: int, tiny: float) -> bool:
    """Flip the longest edge of triangle ``t`` if it is still a cap and it can be."""
    row = tri[t]
    if _area(v, row) > tiny:  # an earlier flip of this pass ended it
        return False
    lengths = [np.linalg.norm(v[row[(k + 1) % 3]] - v[row[k]]) for k in range(3)]
    k = int(np.argmax(lengths))
    a, b, c = int(row[k]), int(row[(k + 1) % 3]), int(row[(k + 2) % 3])
    u = edge_of.get(b, a)
    if u is None or face[u] != face[t]:
        return False
    d = next(int(x) for x in tri[u] if x != a and x != b)
    if c == d or edge_of.get(c, d) is not None or edge_of.get(d, c) is not None:
        return False
    first, second = np.array([a, d, c]), np.array([d, b, c])
    normal = cross(v[a] - v[b], v[d] - v[b])  # the neighbour's (b, a, d)
    for new in (first, second):
        twice = cross(v[new[1]] - v[new[0]], v[new[2]] - v[new[0]])
        if 0.5 * float(np.dot(twice, normal)) / max(np.linalg.norm(normal), 1e-300) <= tiny:
            return False
    tri[t], tri[u] = first, second
    edge_of.flipped |= {t, u}
    return True


def outline_vertices(tri) -> np.ndarray:
    """The ends of the open (or non-manifold) edges of triangles ``tri``."""
    ends = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edge, count = unique_pairs(ends, return_counts=True)
    return np.unique(edge[count != 2])


class _EdgeOwners:
    """Directed edge ``(a, b)`` -> the triangle of ``tri`` that has it (`get`), looked
    for among the triangles ``a`` had at first (each vertex's listed once, from
    arrays, `vertex_triangles`) and the rows flipped since (``flipped``, changed in
    place). A dict of every edge cost level 0 of a sampled CAD part (92,842
    triangles, 4 caps) 0.09 s to build; this 0.01 s."""

    def __init__(self, tri: np.ndarray):
        self.tri = tri
        self.first, self.rows = vertex_triangles(tri, int(tri.max()) + 1)
        self.flipped = set()

    def get(self, a: int, b: int):
        """The triangle with edge ``(a, b)`` (the last by row), or None."""
        found = None
        around = set(self.rows[self.first[a] : self.first[a + 1]].tolist())
        for t in sorted(around | self.flipped):
            r = self.tri[t].tolist()
            if (r[0], r[1]) == (a, b) or (r[1], r[2]) == (a, b) or (r[2], r[0]) == (a, b):
                found = t
        return found


def _tiny(v, tri):
    """The area below which a triangle has none (`CAP_RTOL` of the mean triangle's),
    or None when no triangle is below it."""
    if tri.shape[0] == 0:
        return None
    area = _areas(v, tri)
    tiny = CAP_RTOL * float(area.mean())
    return tiny if (area <= tiny).any() else None


def _area(v, row) -> float:
    return float(_areas(v, row[None])[0])


def _areas(v, tri) -> np.ndarray:
    return 0.5 * np.linalg.norm(_cross(v, tri), axis=1)
