"""The polygons step: each face's triangles grouped into simple, planar polygons.

What a file can hold is a list of simple polygons: no holes, no vertex twice, and
(for every reader to agree on the surface) flat. A region's face is one polygon when
its outer loop is all that and, otherwise, the fewest pieces the greedy growth below
finds: triangles of the face's triangulation joined across shared edges while the
piece's boundary stays one cycle through distinct vertices and its vertices stay on
one plane (largest distance to their least-squares plane at most ``tol``). A face
with a hole becomes two or more simple polygons; a face pinched at a vertex becomes
the polygons on either side; a curved region becomes its planar pieces (triangles in
the worst case), so every polygon written is planar whatever the vertices are. The
triangles themselves are not changed: the polygons cover exactly the same surface.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ._faces import plane_deviation
from ._mesh import cross, unique_ints
from ._polygon_kernels import fan_kind
from ._readers import ear_clip_triangles, fan_triangles

__all__ = ["PLANAR_RTOL", "face_polygons", "planar_pieces"]

#: Largest distance of a written polygon's vertices to its least-squares plane, as a
#: fraction of the diagonal of the output's bounding box (the issue's bound is 1e-6;
#: the growth checks a tenth of it).
PLANAR_RTOL = 1e-7


def face_polygons(vertices, triangles, triangle_face, face_loops, tol: float):
    """Simple, planar polygons covering every face's triangles.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Output vertices.
    triangles : ndarray of shape (T, 3), int64
        Triangulation of all faces (consistently oriented).
    triangle_face : ndarray of shape (T,), int64
        Face of every triangle, in 0..F-1.
    face_loops : sequence of tuple of ndarray
        Per face its loops (outer loop first); a face whose only loop has distinct
        vertices, holds every vertex of the face's triangles and lies within ``tol``
        of one plane is written as that loop.
    tol : float
        Largest distance of a polygon's vertices to its least-squares plane.

    Returns
    -------
    polygons : tuple of ndarray of int64
        Vertex ids of every polygon, oriented as the triangles.
    polygon_face : ndarray of shape (P,), int64
        Face of every polygon (faces in order).
    polygon_planarity : ndarray of shape (P,), float64
        Largest distance of each polygon's vertices to their least-squares plane.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 1, 0.0]])
    >>> t = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> polys, face, _ = face_polygons(v, t, np.zeros(4, np.int64), [()], 1e-9)
    >>> [p.tolist() for p in polys], face.tolist()
    ([[0, 1, 2, 3]], [0])
    """
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    tf = np.asarray(triangle_face, dtype=np.int64)
    order = np.argsort(tf, kind="stable")
    bounds = np.searchsorted(tf[order], np.arange(len(face_loops) + 1))
    alone = _alone(v, t, tf, tol)[order] if t.size else np.zeros(0, dtype=bool)
    t_sorted = t[order]
    first = np.argmin(t_sorted, axis=1)[:, None]  # every triangle from its lowest id
    rolled = np.take_along_axis(t_sorted, (first + np.arange(3)) % 3, axis=1)
    pieces, piece_face = [], []
    for f, loops in enumerate(face_loops):
        mine = t_sorted[bounds[f] : bounds[f + 1]]
        simple = len(loops) == 1 and unique_ints(loops[0]).size == loops[0].size >= 3
        inside = unique_ints(mine).size != loops[0].size if simple else True
        if simple and not inside and plane_deviation(v[loops[0]]) <= tol:
            mine_pieces = [(np.asarray(loops[0], dtype=np.int64), mine)]
        elif alone[bounds[f] : bounds[f + 1]].all():  # each triangle its own piece
            mine_pieces = [(rolled[k], t_sorted[k : k + 1]) for k in range(*bounds[f : f + 2])]
        else:
            mine_pieces = _pieces(v, mine, tol, alone=alone[bounds[f] : bounds[f + 1]])
        for piece in _fan_ready(v, mine_pieces, tol):
            pieces.append(piece)
            piece_face.append(f)
    polygons, polygon_face = _no_shared_diagonals(v, pieces, piece_face, tol)
    planarity = np.zeros(len(polygons))
    for i, p in enumerate(polygons):
        if len(p) > 3:
            planarity[i] = plane_deviation(v[p])
    return tuple(polygons), np.asarray(polygon_face, dtype=np.int64), planarity


def _no_shared_diagonals(v, pieces, piece_face, tol: float):
    """Each piece started where both common readers (`_readers`: trimesh's fan,
    Open3D's ear clipping) triangulate it without a diagonal on an edge of another
    polygon (that edge would be in four triangles); a piece with no such start is
    regrown from its triangles into convex pieces, each written the same way, and a
    convex piece with no such start as its triangles (written as its triangles, a
    sampled L-bracket's 23 planar pieces became 130 polygons)."""
    edges = _cycle_edges([cycle for cycle, _ in pieces])
    polygons, polygon_face = [], []
    for (cycle, tris), f in zip(pieces, piece_face, strict=True):
        if len(cycle) == 3:  # a triangle: every reader takes it as it is
            polygons.append(cycle)
            polygon_face.append(f)
            continue
        parts = _reader_parts(v, cycle, tris, edges, tol)
        polygons.extend(np.asarray(p, dtype=np.int64) for p in parts)
        polygon_face.extend([f] * len(parts))
    return polygons, polygon_face


def _cycle_edges(cycles) -> set[tuple[int, int]]:
    """The undirected edges ``(lo, hi)`` of every cycle (vertex ids), as a set."""
    if not cycles:
        return set()
    ids = np.concatenate(cycles)
    sizes = np.asarray([len(c) for c in cycles])
    ends = np.cumsum(sizes)
    after = np.arange(1, ids.size + 1)  # each id's successor on its cycle
    after[ends - 1] = ends - sizes  # the last one's: the cycle's first
    lo, hi = np.minimum(ids, ids[after]), np.maximum(ids, ids[after])
    return set(zip(lo.tolist(), hi.tolist(), strict=True))


def _reader_parts(v, cycle, tris, edges, tol: float, convex: bool = False) -> list:
    """A piece as the polygons `_no_shared_diagonals` writes for it."""
    start = _reader_start(v, cycle, edges)
    if start is not None:
        return [np.roll(cycle, -start)] if start else [cycle]
    if convex or len(tris) <= 2:
        return list(tris)
    sub = _convex_pieces(v, cycle, tris, tol)
    if len(sub) == 1:  # convex already: no start joins it
        return list(tris)
    for c, _ in sub:  # the new pieces' own edges are edges too
        ids = c.tolist()
        edges.update(_edge(a, b) for a, b in zip(ids, ids[1:] + ids[:1], strict=True))
    return [p for c, t in sub for p in _reader_parts(v, c, t, edges, tol, convex=True)]


def _reader_start(v, cycle, edges) -> int | None:
    """The first of `fan_starts` where Open3D's ear clipping also closes the mesh;
    the diagonals both readers cut there join ``edges`` (two polygons that share two
    corners must not both cut between them)."""
    if len(cycle) == 3:
        return 0
    own = {(min(a, b), max(a, b)) for a, b in zip(cycle, np.roll(cycle, -1), strict=True)}
    for s in fan_starts(v[cycle], cycle, edges):
        rolled = np.roll(cycle, -s)
        ears = ear_clip_triangles(v[rolled], rolled)
        if ears is None:
            continue
        cuts = {_edge(a, b) for t in ears + fan_triangles(rolled) for a, b in _sides(t)} - own
        if not cuts & edges:
            edges |= cuts
            return s
    return None


def _edge(a, b) -> tuple[int, int]:
    return (int(min(a, b)), int(max(a, b)))


def _sides(t):
    return ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))


def _fan_ready(v, pieces, tol):
    """The pieces ``(cycle, triangles)`` whose fan from some vertex is valid
    (`fan_start`); a piece no fan covers (not star-shaped from any of its vertices,
    e.g. a ring around a hole) is regrown from its triangles into convex pieces, so
    that readers that fan-triangulate a polygon get our surface."""
    for cycle, tris in pieces:
        if len(cycle) == 3 or fan_start(v[cycle]) is not None:
            yield cycle, tris
            continue
        yield from _convex_pieces(v, cycle, tris, tol)


def _convex_pieces(v, cycle, tris, tol):
    """A piece's triangles regrown into pieces convex about the piece's normal."""
    normal = cross(v[cycle], v[np.roll(cycle, -1)]).sum(axis=0)
    return _pieces(v, tris, tol, convex=normal)


def planar_pieces(vertices: np.ndarray, triangles: np.ndarray, tol: float) -> list[np.ndarray]:
    """Group edge-adjacent triangles into simple polygons within ``tol`` of a plane.

    Greedy and deterministic: a piece starts at the lowest unused triangle and grows
    breadth-first across its boundary edges. A triangle joins when it shares one
    edge and its third vertex is not on the piece yet, or shares two edges (their
    common vertex moves inside), and the piece stays within ``tol`` of its
    least-squares plane. The piece's boundary is then one cycle through distinct
    vertices, and since the triangles do not overlap, a simple polygon.

    Examples
    --------
    A square with a square hole (8 triangles) becomes two simple polygons (a C of
    six triangles and a quad):

    >>> v = np.array([[0, 0, 0], [3, 0, 0], [3, 3, 0], [0, 3, 0],
    ...               [1, 1, 0], [2, 1, 0], [2, 2, 0], [1, 2, 0.0]])
    >>> t = np.array([[0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
    ...               [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    >>> [len(p) for p in planar_pieces(v, t, 1e-9)]
    [8, 4]
    """
    return [cycle for cycle, _ in _pieces(vertices, triangles, tol)]


def _pieces(
    vertices, triangles, tol: float, convex=None, alone=None
) -> list[tuple[np.ndarray, np.ndarray]]:
    """`planar_pieces` with each piece's triangles: ``[(cycle, triangles (k, 3))]``;
    ``convex`` (a normal): every piece convex about it; ``alone`` (`_alone`): the
    triangles that are pieces of their own."""
    tri = np.asarray(triangles, dtype=np.int64)
    n = tri.shape[0]
    if n == 0:
        return []
    pts = np.asarray(vertices, dtype=np.float64)
    flat = plane_deviation(pts[unique_ints(tri)]) <= tol
    by_edge: dict[tuple[int, int], list[int]] = {}
    rows = tri.tolist()
    for k, (a, b, c) in enumerate(rows):
        for x, y in ((a, b), (b, c), (c, a)):
            by_edge.setdefault((min(x, y), max(x, y)), []).append(k)
    used = np.zeros(n, dtype=bool)
    if flat or convex is not None or alone is None:
        alone = np.zeros(n, dtype=bool)
    pieces = []
    for seed in range(n):
        if used[seed]:
            continue
        if alone[seed]:  # no neighbour near its plane: a piece of its own
            used[seed] = True
            pieces.append((_lowest_first(tri[seed]), tri[seed : seed + 1]))
            continue
        before = used.copy()
        cycle = _grow(seed, rows, by_edge, used, pts, None if flat else tol, convex)
        pieces.append((cycle, tri[used & ~before]))
    return pieces


def _lowest_first(t: np.ndarray) -> np.ndarray:
    """A triangle's corners from its lowest id, in its order (as `_grow` gives them)."""
    i = int(np.argmin(t))
    return t[[i, (i + 1) % 3, (i + 2) % 3]]


def _alone(pts, tri, face, tol: float) -> np.ndarray:
    """(T,) bool: no triangle of the same ``face`` across an edge has its third vertex
    within 10 ``tol`` of the triangle's plane, nor the other way round (a curved
    region's triangles: the growth would stop at once, one plane fit per neighbour;
    the margin keeps every triangle the growth could join out of it)."""
    n = tri.shape[0]
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    normal = np.cross(b - a, c - a)
    length = np.linalg.norm(normal, axis=1)
    normal /= np.maximum(length, 1e-300)[:, None]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    third = np.concatenate([tri[:, 2], tri[:, 0], tri[:, 1]])
    owner = np.tile(np.arange(n), 3)
    key = np.minimum(edges[:, 0], edges[:, 1]) * (int(tri.max()) + 1) + edges.max(axis=1)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    k, j = owner[order][:-1][same], owner[order][1:][same]
    tk, tj = third[order][:-1][same], third[order][1:][same]
    off_k = np.abs(np.einsum("ij,ij->i", normal[k], pts[tj] - a[k]))
    off_j = np.abs(np.einsum("ij,ij->i", normal[j], pts[tk] - a[j]))
    near = ((off_k <= 10.0 * tol) | (off_j <= 10.0 * tol)) & (face[k] == face[j])
    alone = length > 0.0
    alone[k[near]] = False
    alone[j[near]] = False
    return alone


def _grow(seed, rows, by_edge, used, pts, tol, convex=None) -> np.ndarray:
    """One piece grown from triangle ``seed`` (marks its triangles used); its cycle.

    ``convex``: the plane's normal when the piece must stay convex (no boundary
    vertex turning against it), else None.
    """
    a, b, c = rows[seed]
    nxt = {a: b, b: c, c: a}  # boundary half-edges, start -> end
    prv = {b: a, c: b, a: c}
    members = [a, b, c]
    used[seed] = True
    queue = deque(_neighbours(seed, rows, by_edge))
    while queue:
        k = queue.popleft()
        if used[k]:
            continue
        join = _join(rows[k], nxt)
        if join is None:
            continue
        before, new, after = join
        inside = new in nxt  # two shared edges: ``new`` (their common vertex) moves inside
        if convex is not None:
            chain = [prv[before], before] + ([] if inside else [new]) + [after, nxt[after]]
            if not _turns_left(pts[chain], convex):
                continue
        if inside:
            del nxt[new], prv[new]
            nxt[before], prv[after] = after, before
        else:
            if tol is not None and plane_deviation(pts[members + [new]]) > tol:
                continue
            nxt[before], nxt[new] = new, after
            prv[new], prv[after] = before, new
            members.append(new)
        used[k] = True
        queue.extend(j for j in _neighbours(k, rows, by_edge) if not used[j])
    start = min(nxt)
    cycle = [start]
    while (following := nxt[cycle[-1]]) != start:
        cycle.append(following)
    return np.asarray(cycle, dtype=np.int64)


def _turns_left(chain: np.ndarray, normal: np.ndarray) -> bool:
    """No interior vertex of the polyline ``chain`` turns right about ``normal``."""
    d = np.diff(chain, axis=0)
    turn = cross(d[:-1], d[1:]) @ normal
    return bool((turn >= -1e-12 * np.abs(turn).max(initial=0.0)).all())


def _neighbours(k, rows, by_edge):
    a, b, c = rows[k]
    for x, y in ((a, b), (b, c), (c, a)):
        for j in by_edge[(min(x, y), max(x, y))]:
            if j != k:
                yield j


def _join(row, nxt):
    """How triangle ``row`` joins the piece with boundary ``nxt``, or None.

    ``(before, new, after)``: with one shared edge ``after -> before`` of the
    triangle (the boundary runs ``before -> after``), the boundary becomes
    ``before -> new -> after`` (``new`` the third vertex, which must not be on the
    boundary yet); with two shared edges, ``new`` is their common vertex and the
    boundary ``before -> new -> after`` becomes ``before -> after``. None when the
    triangle shares no edge or three, or would bring a vertex twice.
    """
    a, b, c = row
    shared = [(x, y) for x, y in ((a, b), (b, c), (c, a)) if nxt.get(y) == x]
    if len(shared) == 1:
        x, y = shared[0]
        apex = ({a, b, c} - {x, y}).pop()
        return None if apex in nxt else (y, apex, x)
    if len(shared) == 2:
        (x1, y1), (x2, y2) = shared
        if y1 == x2:  # boundary y2 -> y1 (= x2) -> x1
            return y2, y1, x1
        return y1, x1, x2  # boundary y1 -> x1 (= y2) -> x2
    return None


def fan_start(points: np.ndarray, ids=None, edges=None) -> int | None:
    """A vertex from which the fan triangulation of a planar polygon is valid, or None.

    Readers that meet a polygon in a file (trimesh, many OBJ loaders) fan it from
    its first vertex: the fan is the polygon's surface when every triangle
    (p_s, p_s+i, p_s+i+1) turns the polygon's way (the polygon is star-shaped from
    p_s). The first of `fan_starts`.

    Examples
    --------
    >>> L = np.array([[0, 0, 0], [4, 0, 0], [4, 1, 0], [1, 1, 0], [1, 3, 0], [0, 3, 0.0]])
    >>> fan_start(L), fan_start(L[[1, 2, 3, 4, 5, 0]])  # the inner corner
    (3, 2)
    >>> spiral = np.array([[0, 0, 0], [3, 0, 0], [3, 3, 0], [1, 3, 0], [1, 2, 0],
    ...                    [2, 2, 0], [2, 1, 0], [0, 1, 0.0]])
    >>> fan_start(spiral) is None
    True
    """
    return next(fan_starts(points, ids, edges), None)


def fan_starts(points: np.ndarray, ids=None, edges=None):
    """Every vertex whose fan is valid (see `fan_start`), best first.

    Vertices where the polygon turns back (reflex) come first, then the others;
    starts whose fan has no flat triangle before those that have one. With vertex
    ``ids`` and a set of undirected ``edges`` (pairs ``(lo, hi)``), a start whose
    fan has a diagonal in ``edges`` is left out.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    if n <= 3:
        yield 0
        return
    after = np.concatenate((p[1:], p[:1]))  # np.roll(p, -1, axis=0)
    normal = cross(p, after).sum(axis=0)  # Newell
    turn = cross(p - np.concatenate((p[-1:], p[:-1])), after - p) @ normal
    scale = np.abs(turn).max(initial=0.0)
    order = np.argsort(turn >= 0.0, kind="stable")  # reflex vertices first
    flat = []
    for s in order.tolist():
        kind = fan_kind(p, normal, s, 1e-12 * scale)
        if kind == 0 or (edges is not None and _diagonal_in(ids, s, edges)):
            continue
        if kind == 2:
            yield s
        else:
            flat.append(s)
    yield from flat


def _diagonal_in(ids, s: int, edges) -> bool:
    """A diagonal (ids[s], ids[s + i]), 2 <= i <= n - 2, of the fan from ``s`` is in ``edges``."""
    n = len(ids)
    a = int(ids[s])
    for i in range(2, n - 1):
        b = int(ids[(s + i) % n])
        if (min(a, b), max(a, b)) in edges:
            return True
    return False
