"""The placement step: output vertices moved onto the planes of their flat regions.

A region of the input's triangles is *flat* when its vertices lie within
``FLAT_RTOL`` of the diagonal of their least-squares plane (a CAD face, stored with
float rounding). Every output vertex goes to the point nearest to where it is that
lies on the planes of all its flat regions (thesis 4.4, the vertex fitting of
Eq. 4.12 restricted to fixed planes: one plane -> onto it, two -> onto their line,
three -> their common point). Planes within 2.5 degrees of parallel act as one
(the pseudo-inverse drops their difference) so a vertex is never flung along a
near-parallel intersection; four or more planes that do not meet give their
least-squares point; a vertex that would move more than ``bound`` stays where it is,
and a triangle that would flip puts its vertices back. The faces of flat regions are
then exactly planar wherever their vertices could be placed; `face_polygons` splits
the rest.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._mesh import unique_ints, unique_pairs

__all__ = [
    "FLAT_RTOL",
    "flat_planes",
    "place_on_planes",
    "plane_fits",
    "settle_planes",
    "triangle_normals",
]

#: Largest distance of a region's input vertices to its plane, as a fraction of the
#: diagonal, for the region to count as flat.
FLAT_RTOL = 1e-4
#: Singular values of a vertex's plane normals below this fraction of the largest are
#: dropped: planes within asin(0.0437) = 2.5 degrees of each other act as one.
_PARALLEL_RTOL = 0.0437
#: Rounds of `settle_planes` at most (a bent face's planes and vertices fitted in turn).
_SETTLE_ROUNDS = 100
#: A triangle whose area along its former normal falls to this fraction of the mean
#: triangle's area, or below (turned over, or collapsed to a point or a segment), puts
#: its vertices back: two vertices fitted to the same spot made a zero-area triangle
#: whose normal, noise, could still point the former way.
_COLLAPSED = 1e-10


def flat_planes(vertices, triangles, labels, n_regions: int, tol: float):
    """Least-squares plane of every region's vertices, and which regions are flat.

    Returns ``normals`` (R, 3), ``offsets`` (R,) with ``normals[r] . x = offsets[r]``
    on the plane, and ``flat`` (R,) bool: the region's vertices lie within ``tol`` of
    its plane (regions with fewer than three vertices are not flat).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> t = np.array([[0, 1, 2], [0, 3, 1]])
    >>> n, d, flat = flat_planes(v, t, np.array([0, 1]), 2, 1e-9)
    >>> np.abs(n).round(6).tolist(), flat.tolist()
    ([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]], [True, True])
    """
    normals, offsets, deviation, spanned = plane_fits(vertices, triangles, labels, n_regions)
    return normals, offsets, spanned & (deviation <= tol)


def plane_fits(vertices, triangles, labels, n_regions: int):
    """``(normals, offsets, deviation, spanned)`` of every region's least-squares plane
    (`flat_planes`): ``deviation`` (R,) the largest distance of its vertices to it,
    ``spanned`` (R,) its vertices span a plane (at least three, not on one line);
    zeros and False for a region of fewer than three vertices. Each region's normal
    is the last right singular vector of its centred vertices (`_fit_rows`, one
    LAPACK call a region in a kernel: the planar step's fits of every placed level
    had cost a numpy call per vertex count, 24 a call, 0.1 ms each)."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    lab = np.asarray(labels, dtype=np.int64)
    pairs = unique_pairs(np.column_stack([np.repeat(lab, 3), tri.reshape(-1)]))
    bounds = np.searchsorted(pairs[:, 0], np.arange(n_regions + 1))
    normals = np.zeros((n_regions, 3))
    centres = np.zeros((n_regions, 3))
    deviation = np.zeros(n_regions)
    spanned = np.zeros(n_regions, dtype=bool)
    rows = np.ascontiguousarray(pairs[:, 1])
    _fit_rows(v, rows, bounds.astype(np.int64), normals, centres, deviation, spanned)
    # numpy's products, as before the kernel (the same offsets bit for bit)
    offsets = np.matmul(normals[:, None, :], centres[:, :, None])[:, 0, 0]
    return normals, offsets, deviation, spanned


@njit(cache=True)
def _fit_rows(v, rows, bounds, normals, centres, deviation, spanned) -> None:
    """`plane_fits` of each region r of three or more vertices ``v[rows[bounds[r]:
    bounds[r + 1]]]``: its centre (the coordinates summed in order, then divided),
    the normal (the SVD of the centred vertices), the largest distance of a vertex
    to the plane and whether the second singular value is positive."""
    for r in range(bounds.shape[0] - 1):
        a, c = bounds[r], bounds[r + 1] - bounds[r]
        if c < 3:
            continue
        pts = np.empty((c, 3))
        total = np.zeros(3)
        for i in range(c):
            for k in range(3):
                pts[i, k] = v[rows[a + i], k]
                total[k] += pts[i, k]
        for k in range(3):
            centres[r, k] = total[k] / c
        for i in range(c):
            for k in range(3):
                pts[i, k] -= centres[r, k]
        _, sv, vt = np.linalg.svd(pts, full_matrices=False)
        most = 0.0
        for i in range(c):
            h = abs(pts[i, 0] * vt[2, 0] + pts[i, 1] * vt[2, 1] + pts[i, 2] * vt[2, 2])
            most = max(most, h)
        normals[r] = vt[2]
        deviation[r] = most
        spanned[r] = sv[1] > 0.0


def place_on_planes(
    v0,
    triangles,
    triangle_face,
    normals,
    offsets,
    flat,
    bound: float,
    on_plane: float = 0.0,
    unflip: bool = True,
):
    """Output vertices moved onto the planes of their flat faces (see the module).

    Parameters
    ----------
    v0 : ndarray of shape (V, 3)
        Output vertices where they are.
    triangles : ndarray of shape (T, 3), int64
        Output triangles; ``triangle_face`` (T,) their face (region).
    normals, offsets, flat : ndarrays of shape (R, 3), (R,), (R,)
        From `flat_planes`.
    bound : float
        Largest move of a vertex.
    on_plane : float
        A vertex within this distance of all its planes stays where it is (an
        exactly flat input keeps its vertices bit for bit).
    unflip : bool
        Put back the vertices of triangles that turned over (False: every vertex
        placed, for `_untangle.untangle` to mend).

    Returns
    -------
    ndarray of shape (V, 3)
        The placed vertices (a copy).

    Examples
    --------
    A vertex near the corner of three planes goes to the corner:

    >>> n = np.eye(3); d = np.zeros(3)
    >>> v = np.array([[1e-5, -2e-5, 3e-5], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> t = np.array([[0, 2, 3], [0, 3, 1], [0, 1, 2]])
    >>> place_on_planes(v, t, np.arange(3), n, d, np.ones(3, bool), 0.1)[0].tolist()
    [0.0, 0.0, 0.0]
    """
    v0 = np.asarray(v0, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tface = np.asarray(triangle_face, dtype=np.int64)
    pairs = unique_pairs(np.column_stack([tri.reshape(-1), np.repeat(tface, 3)]))
    pairs = pairs[flat[pairs[:, 1]]]
    x = v0.copy()
    if pairs.shape[0] == 0:
        return x
    for j, residual, move in _moves_onto_planes(v0, pairs, normals, offsets):
        go = (np.abs(residual).max(axis=1) > on_plane) & (np.linalg.norm(move, axis=1) <= bound)
        x[j[go]] = v0[j[go]] + move[go]
    return _unflip(v0, x, tri, collapsed=True) if unflip else x


def _plane_groups(pairs, normals):
    """For the vertices of ``pairs`` ((vertex, face) rows sorted by vertex), each
    group of vertices on the same number c of planes at once: ``(vertices, faces (n,
    c), normals (n, c, 3), their pseudo-inverses (n, 3, c))``, planes within
    `_PARALLEL_RTOL` acting as one. The pseudo-inverse is found once per set of
    faces (most vertices share theirs with many: a flat face's inner ones, an
    edge's) and taken by each of its vertices, the same arrays."""
    first = np.flatnonzero(np.r_[True, pairs[1:, 0] != pairs[:-1, 0]])
    count = np.diff(np.append(first, pairs.shape[0]))
    n_faces = normals.shape[0]
    for c in np.unique(count):
        j = np.flatnonzero(count == c)
        regions = pairs[first[j][:, None] + np.arange(c), 1]
        a = normals[regions]
        if float(n_faces) ** c < 2.0**62:  # one integer per set of faces
            key = regions[:, 0]
            for k in range(1, c):
                key = key * n_faces + regions[:, k]
            _, one, each = np.unique(key, return_index=True, return_inverse=True)
            p = np.linalg.pinv(a[one], rcond=_PARALLEL_RTOL)[each.reshape(-1)]
        else:
            p = np.linalg.pinv(a, rcond=_PARALLEL_RTOL)
        yield pairs[first[j], 0], regions, a, p


def _moves_onto_planes(x, pairs, normals, offsets):
    """For the vertices of ``pairs`` ((vertex, face) rows sorted by vertex), each
    group of vertices on the same number c of planes at once (`_plane_groups`):
    ``(vertices, residual (n, c), move (n, 3))``, the move to the nearest point on
    all their planes (least squares; planes within `_PARALLEL_RTOL` act as one)."""
    for verts, regions, a, p in _plane_groups(pairs, normals):
        residual = offsets[regions] - np.einsum("ncd,nd->nc", a, x[verts])
        yield verts, residual, np.einsum("ndc,nc->nd", p, residual)


def _unflip(v0, x, tri, rounds: int = 4, collapsed: bool = False, before=None):
    """Vertices of triangles that turned over or collapsed (`_COLLAPSED`) go back;
    ``collapsed``: a collapsed triangle whose normal still points the former way
    stays (the placement onto planes and the surface's first fit, whose vertices
    meet on the line of two planes or at a corner: putting them back keeps them off
    their planes, and the level search then stops at far more triangles).
    ``before``: the triangles' former unit normals (zero: none), when ``v0`` does not
    give them (`_untangle.untangle`'s merged triangles, which never were at ``v0``)."""
    if before is None:
        c0 = _cross(v0, tri)
        area0 = np.linalg.norm(c0, axis=1)
        before = c0 / np.maximum(area0, 1e-300)[:, None]
    else:
        area0 = np.linalg.norm(before, axis=1)
    tiny = 0.0 if collapsed or area0.size == 0 else _COLLAPSED * float(area0.mean())
    for _ in range(rounds):
        bad = np.einsum("ij,ij->i", before, _cross(x, tri)) <= tiny
        bad &= area0 > 0.0
        if not bad.any():
            break
        back = unique_ints(tri[bad])
        x[back] = v0[back]
    return x


def triangle_normals(v, tri):
    """Unit normals of the triangles (zero for degenerate ones)."""
    c = _cross(v, tri)
    return c / np.maximum(np.linalg.norm(c, axis=1), 1e-300)[:, None]


def _cross(v, tri):
    """The triangles' edge cross products (twice their area along their normal):
    (b - a) x (c - a), the same products and differences as ``np.cross`` of the
    gathered edges (the same bits), in one pass (numpy's three gathers and
    temporaries on level 0's 100,000 triangles cost ten times as much)."""
    v = np.ascontiguousarray(v, dtype=np.float64)
    tri = np.ascontiguousarray(tri, dtype=np.int64).reshape(-1, 3)
    out = np.empty((tri.shape[0], 3))
    _cross_rows(v, tri, out)
    return out


@njit(cache=True, nogil=True)
def _cross_rows(v, tri, out):
    """``out[t]``: (b - a) x (c - a) of triangle ``tri[t]`` = (a, b, c) of ``v``."""
    for t in range(tri.shape[0]):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        u0, u1, u2 = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
        w0, w1, w2 = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
        out[t, 0] = u1 * w2 - u2 * w1
        out[t, 1] = u2 * w0 - u0 * w2
        out[t, 2] = u0 * w1 - u1 * w0


def settle_planes(x, triangles, triangle_face, normals, offsets, flat, tol: float, bound: float):
    """Faces of flat regions still bent after `place_on_planes` made planar within
    ``tol``: a vertex on four or more planes that do not quite meet (the input's
    faces are flat only to `FLAT_RTOL`) is left at their least-squares point, off
    each of them. The faces with a vertex farther than ``tol`` from their region's
    plane (``normals``, ``offsets``, ``flat``: `flat_planes`) and bent by more than
    ``tol`` have their planes and vertices fitted to each other in turn (each such
    face's least-squares plane through its vertices, then each of their vertices to
    the nearest point on all its flat faces' planes; the other faces keep their
    region's), which never raises the sum of their squared distances, for at most
    `_SETTLE_ROUNDS` rounds; kept where every such face ends within ``tol`` and no
    vertex moved more than ``bound`` or turned a triangle over, else ``x`` (a copy).
    Faces of three vertices are planar wherever they are and hold nothing."""
    x = np.asarray(x, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tface = np.asarray(triangle_face, dtype=np.int64)
    # faces of two or more triangles (four or more vertices) with a corner off the plane
    held = np.asarray(flat, dtype=bool) & (np.bincount(tface, minlength=flat.size) >= 2)
    t = np.flatnonzero(held[tface])
    n, d = normals[tface[t]], offsets[tface[t]]
    off = np.zeros(t.size, dtype=bool)
    for k in range(3):
        off |= np.abs(np.einsum("ij,ij->i", n, x[tri[t, k]]) - d) > tol
    if not off.any():
        return x.copy()
    normals, offsets = normals.copy(), offsets.copy()
    bent = np.zeros(flat.size, dtype=bool)
    bent[tface[t[off]]] = True
    sub = np.flatnonzero(bent[tface])
    fit = plane_fits(x, tri[sub], tface[sub], flat.size)
    bent &= fit[2] > tol
    if not bent.any():
        return x.copy()
    sub = np.flatnonzero(bent[tface])
    pairs = unique_pairs(np.column_stack([tri[t].reshape(-1), np.repeat(tface[t], 3)]))
    rows = pairs[np.isin(pairs[:, 0], unique_ints(pairs[bent[pairs[:, 1]], 0]))]
    y = x.copy()
    for _ in range(_SETTLE_ROUNDS):
        fit = plane_fits(y, tri[sub], tface[sub], flat.size)
        normals[bent], offsets[bent] = fit[0][bent], fit[1][bent]
        if fit[2][bent].max() <= tol:
            break
        y = _onto_planes(y, rows, normals, offsets)
    else:
        if plane_fits(y, tri[sub], tface[sub], flat.size)[2][bent].max() > tol:
            return x.copy()
    if np.linalg.norm(y - x, axis=1).max() > bound:
        return x.copy()
    before = _cross(x, tri)
    flipped = np.einsum("ij,ij->i", before, _cross(y, tri)) <= 0.0
    return x.copy() if (flipped & before.any(axis=1)).any() else y


def _onto_planes(y, rows, normals, offsets):
    """Each vertex of ``rows`` ((vertex, face) pairs sorted by vertex) moved to the
    nearest point on all its faces' planes (`_moves_onto_planes`)."""
    out = y.copy()
    for verts, _, move in _moves_onto_planes(y, rows, normals, offsets):
        out[verts] = y[verts] + move
    return out
