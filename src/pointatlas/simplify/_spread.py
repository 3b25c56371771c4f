"""Vertices of triangles without area moved inside their face (private; the last of
the zero-area steps after `_caps.weld_needles` and `_caps.flip_caps`).

What neither ends (twins whose merge would break the link condition, clusters of
vertices a millionth of an edge apart) `spread_tiny` ends by moving a vertex inside
its face: in a flat face's plane, where the face stays the same polygon; towards its
neighbours' mean, else a short step any way round in the plane that gives more of
its triangles an area (twins in a row, a fold beside them).
"""

from __future__ import annotations

import numpy as np

from ._caps import _PASSES, _areas, _tiny, outline_vertices
from ._mesh import cross, plane_basis, vertex_triangles
from ._place import _cross

__all__ = [
    "CURVED_LAST",
    "CURVED_REACH",
    "FLAT_SHARES",
    "ON_PLANE_RTOL",
    "TURN_DIRECTIONS",
    "TURN_SHARES",
    "spread_tiny",
]

#: `spread_tiny` moves a vertex these shares of the way to its neighbours' mean in a
#: flat face (the surface stays) ...
FLAT_SHARES = (1.0, 0.5, 0.25)
#: ... and in a curved one (the surface moves by as much) at most this fraction of
#: the mean edge (all the way where its neighbours' mean is nearer: a cluster of
#: vertices a millionth of an edge apart), else a tenth of that, else this many times
#: it (two vertices on one spot, one of whose triangles a thousandth of an edge left
#: with 0.74 of the area a triangle needs) ...
CURVED_REACH = 1e-3
CURVED_LAST = 4.0
#: ... a face being flat around a vertex when the ring lies this close to its plane,
#: relative to the ring's extent.
ON_PLANE_RTOL = 1e-9
#: Where no move towards the neighbours' mean leaves every triangle an area, a step
#: of these shares of the vertex's shortest edge (in a curved face at most the last
#: reach above) ...
TURN_SHARES = (0.25, 0.1, 0.01)
#: ... along one of this many directions in the face's plane, evenly turned.
TURN_DIRECTIONS = 12


def spread_tiny(vertices, triangles, face, planes) -> np.ndarray:
    """``vertices`` with the vertices of triangles that kept no area moved inside
    their flat face, where that gives every triangle around them an area.

    What `weld_needles` and `flip_caps` leave: two ends of an edge of no length whose
    merge would break the link condition, and clusters of vertices a millionth of an
    edge apart. A vertex of such a triangle whose triangles all lie in one face, off
    the mesh's open boundary (its outline would move), moves
    towards the mean of its neighbours: where it and its neighbours lie on their flat
    face's plane (within `ON_PLANE_RTOL` of the ring's size), in that plane, all the
    way, else half, else a quarter (`FLAT_SHARES`), where its triangles then cover the
    same polygon (its neighbours stay), so the surface and the face's outline do not
    change; elsewhere (a curved face, or vertices a flat face's plane did not take) at
    most a thousandth of the mean edge, else a tenth of that (`CURVED_REACH`): a move
    the size of the ring, or onto a plane the vertex was not on, changed the surface there
    (`cad_a_a32`'s voxel surface, whose error sets the default bound's floor: 0.95 ->
    8.84 % of the diagonal from the truth). Where every such move leaves a triangle
    without area, a short step in the plane that gives more of them one
    (`_spread_turning`). The moves stay in the hull (the steps in the box) of the
    ring's vertices (no vertex leaves the points' box).
    A move is made only where every triangle around the vertex keeps more than
    `CAP_RTOL` of the mean triangle's area along the face's side (the plane's normal;
    in a curved face, the sum of its triangles' around the vertex): no fold; passes
    repeat while one moves something.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
        Vertex coordinates.
    triangles : ndarray of shape (T, 3), int64
        Consistently oriented triangles.
    face : ndarray of shape (T,), int64
        The face (region) of each triangle.
    planes : tuple
        ``(normals, offsets, flat)`` per face: its plane (unit normal, offset) and
        whether it is flat (`_place.flat_planes`).

    Returns
    -------
    ndarray of shape (V, 3)
        The vertices (a copy; the input when no triangle is without area).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [2, 0, 0], [1, 2, 0], [1, 2e-9, 0], [1, -2, 0.0]])
    >>> t = np.array([[0, 1, 3], [0, 3, 2], [3, 1, 2], [0, 4, 1]])
    >>> planes = (np.array([[0, 0, 1.0]]), np.zeros(1), np.array([True]))
    >>> spread_tiny(v, t, np.zeros(4, dtype=np.int64), planes)[3].round(6).tolist()
    [1.0, 0.666667, 0.0]
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tiny = _tiny(v, tri)
    if tiny is None:
        return v
    v = v.copy()
    start, around = vertex_triangles(tri, v.shape[0])
    on_outline = outline_vertices(tri)
    reach = CURVED_REACH * float(np.linalg.norm(v[tri[:, [1, 2, 0]]] - v[tri], axis=2).mean())
    for _ in range(_PASSES):
        ends = np.setdiff1d(tri[_areas(v, tri) <= tiny], on_outline)
        rings = (around[start[i] : start[i + 1]] for i in ends)  # triangles around
        if ends.size == 0 or not sum(
            _spread(v, tri, face, planes, ring, i, tiny, reach)
            for i, ring in zip(ends, rings, strict=True)
        ):
            break
    return v


def _spread(v, tri, face, planes, ring, i: int, tiny: float, reach: float) -> bool:
    """Move vertex ``i`` (triangles ``ring``) as `spread_tiny` says, if it can be."""
    normals, offsets, flat = planes
    f = int(face[ring[0]])
    if (face[ring] != f).any():
        return _spread_across(v, tri, face, planes, ring, i, tiny, reach)
    total = _cross(v, tri[ring]).sum(axis=0)
    mean = v[np.setdiff1d(tri[ring], [i])].mean(axis=0)
    corners = v[tri[ring]].reshape(-1, 3)
    off = np.abs(corners @ normals[f] - offsets[f]).max() if flat[f] else np.inf
    first = min(1.0, reach / max(float(np.linalg.norm(mean - v[i])), 1e-300))
    short = (first, 0.1 * first, min(1.0, CURVED_LAST * first))
    in_plane = off <= ON_PLANE_RTOL * float(np.ptp(corners, axis=0).max())
    if in_plane:
        # in the plane: the shares of the way, then the short moves of a curved face
        # (twins in a flat face whose ring no share of the way left folded-free)
        n, shares = normals[f], FLAT_SHARES + short
        mean -= (float(np.dot(n, mean)) - offsets[f]) * n
    else:  # a curved face: its side is the triangles' around the vertex
        n = total / max(float(np.linalg.norm(total)), 1e-300)
        shares = short
    side = np.sign(float(np.dot(total, n)))
    if side == 0.0:
        return False
    here = v[i].copy()
    for share in shares:
        v[i] = here + share * (mean - here)
        if (0.5 * side * (_cross(v, tri[ring]) @ n) > tiny).all():
            return True
    v[i] = here
    # towards the mean, a triangle turns over: a short step any way in the plane
    # that gives more of them an area (twins in a row, a fold beside them)
    longest = np.inf if in_plane else CURVED_LAST * first * float(np.linalg.norm(mean - here))
    return _spread_turning(v, tri[ring], i, side * n, tiny, longest)


def _spread_turning(v, rows, i: int, n, tiny: float, longest: float) -> bool:
    """Move vertex ``i`` (its triangles ``rows``) by `TURN_SHARES` of its shortest
    edge, at most ``longest``, along one of `TURN_DIRECTIONS` directions in the plane
    of normal ``n``: the move that leaves the most triangles an area along ``n`` (more
    than ``tiny``; the first such move on ties), where that is more than before and
    none of them loses its area. Where the twins of a row share a vertex, no single
    move gives every triangle an area, and a fold beside them turns one over
    whatever the move: `spread_tiny`'s next pass, or another vertex, ends the rest."""
    ring = np.setdiff1d(rows, [i])
    edges = np.linalg.norm(v[ring] - v[i], axis=1)
    edges = edges[edges > 0.0]
    if edges.size == 0:
        return False
    u, w = plane_basis(n)
    angles = np.arange(TURN_DIRECTIONS) * (2.0 * np.pi / TURN_DIRECTIONS)
    ways = np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * w
    had = 0.5 * (_cross(v, rows) @ n) > tiny
    # within the box of the ring (no vertex leaves the points' box)
    grow = ON_PLANE_RTOL * float(np.ptp(v[ring], axis=0).max())
    lo, hi = v[ring].min(axis=0) - grow, v[ring].max(axis=0) + grow
    here = v[i].copy()
    best, at = int(had.sum()), None
    for share in TURN_SHARES:
        for way in ways:
            v[i] = here + min(share * float(edges.min()), longest) * way
            now = 0.5 * (_cross(v, rows) @ n) > tiny
            inside = bool(((v[i] >= lo) & (v[i] <= hi)).all())
            if inside and (now | ~had).all() and int(now.sum()) > best:
                best, at = int(now.sum()), v[i].copy()
    v[i] = here if at is None else at
    return at is not None


def _spread_across(v, tri, face, planes, ring, i: int, tiny: float, reach: float) -> bool:
    """Move vertex ``i``, whose triangles ``ring`` lie in two faces or more, as a
    curved face's vertex (`CURVED_REACH`), but only along the flat faces' planes it
    lies on (along their line where two meet; not at a corner of three): marching
    cubes' twin vertices on the line of two faces, whose merge the link condition
    refuses. Each triangle keeps an area along its face's side (the plane's normal, or
    the sum of the face's triangles around the vertex)."""
    normals, offsets, flat = planes
    faces = np.unique(face[ring])
    size = float(np.ptp(v[tri[ring]].reshape(-1, 3), axis=0).max())
    on = [
        g for g in faces if flat[g] and abs(v[i] @ normals[g] - offsets[g]) <= ON_PLANE_RTOL * size
    ]
    if len(on) > 2:
        return False
    mean = v[np.setdiff1d(tri[ring], [i])].mean(axis=0)
    move = mean - v[i]
    if len(on) == 2:
        d = cross(normals[on[0]], normals[on[1]])
        d /= max(float(np.linalg.norm(d)), 1e-300)
        move = float(d @ move) * d
    elif on:
        move -= float(normals[on[0]] @ move) * normals[on[0]]
    length = float(np.linalg.norm(move))
    if length == 0.0:
        return False
    crosses = _cross(v, tri[ring])
    sides = np.empty((ring.size, 3))
    for g in faces:
        mine = face[ring] == g
        n = normals[g] if g in on else crosses[mine].sum(axis=0)
        sides[mine] = n / max(float(np.linalg.norm(n)), 1e-300)
    first = min(1.0, reach / length)
    here = v[i].copy()
    for share in (first, 0.1 * first, min(1.0, CURVED_LAST * first)):
        v[i] = here + share * move
        if (0.5 * np.einsum("ij,ij->i", _cross(v, tri[ring]), sides) > tiny).all():
            return True
    v[i] = here
    return False
