"""Faces of flat regions made planar where their vertices are a little off (private).

On the points path a flat region's face can come out bent: its vertices were placed
on the region's plane and then partly put back (a triangle the placement turned
over, a vertex the points' surface did not accept), or the collapses left them near
it. `planar_faces` takes each such face whose vertices lie within ``cap`` of their
own least-squares plane and moves them onto it, for all of them at once: the faces'
normals are their fits, and their offsets are the ones that move the vertices
least (one sparse least-squares problem), each vertex going to the nearest point on
the planes of all its flat faces of two or more triangles (the pseudo-inverse of
`_place._plane_groups`, planes within 2.5 degrees of parallel acting as one). A
planar face that shares a vertex with a bent one keeps its plane: the vertex slides
along it. At a vertex that would move more than ``cap``, on a triangle that would
turn over or keep less than `SHRINK` of its area, or that cannot lie on all its
planes (two near-parallel planes), its bent face of fewest triangles is given up
(left as it was); the rest is solved again without it. `merged_planar_faces` first
takes flat faces that meet on near-parallel planes as one face (made planar together,
or apart again where the merged face stays bent). Given the regions' planes (the
points' fits, which the placement used), it first moves the bent faces onto those,
their offsets held (each vertex to the nearest point on its faces' planes), and then
what stays bent onto its own plane: the points' planes are nearer the surface than
the vertices' (all 149 collection models, true normals: mean distance to the truth
0.90x at equal triangle counts). `_snap.PointsDecimation` runs it on every placed
level, and measures a level it takes over the bound again without it and with
shorter moves (`_snap.GENTLE_SHARES`). Before it, `off_plane_relabelled` gives each
triangle of a flat face with a corner farther than the bound from the face's plane
(a wall's triangle on the wrong side of a sharp edge) to the face across an edge
whose plane holds it, else to a curved neighbour: no move within the bound could
have made that face planar.
Decisions in docs/decisions/simplify.md ("The points path's planar faces").
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from ._mesh import unique_ints, unique_pairs
from ._place import _PARALLEL_RTOL, _cross, _plane_groups, plane_fits

__all__ = [
    "APART_KEEP",
    "APART_ROUNDS",
    "PLANAR_ATTEMPTS",
    "RELABEL_PASSES",
    "SHRINK",
    "bent_apart",
    "edge_neighbours",
    "merged_planar_faces",
    "off_plane_relabelled",
    "planar_faces",
]

#: A triangle left with less than this share of its area (along its former normal)
#: counts as turned over: no triangle of (near) zero area.
SHRINK = 1e-3
#: The offsets' system's ridge, a share of its mean diagonal (`_least_moves`).
_RIDGE = 1e-12
#: Solves at most (each gives up the faces that failed the one before).
PLANAR_ATTEMPTS = 8


def merged_planar_faces(x, triangles, triangle_face, flat, tol: float, cap: float, planes=None):
    """`planar_faces` with the flat faces that meet at a vertex on planes within 2.5
    degrees of parallel (`_place._PARALLEL_RTOL`: no vertex can lie on both) taken
    as one face where that face comes out planar; the others are made planar apart.
    Where ``planes`` (the regions' normals (R, 3) and offsets (R,): the points' fits)
    is given, the bent faces go onto those planes first, offsets held, and what stays
    bent then onto its own plane.

    Returns ``(x, triangle_face)``: the vertices (a copy) and each triangle's face,
    a merged face labelled as its largest member (in triangles; ties: the lower
    label). The sampled spool holder (`voron0_spool_holder_x1`, its output): flat
    faces 133 -> 96, bent by more than 1e-6 of the diagonal 44 -> 22 (all 149
    collection models: 2,470 -> 2,322 bent; docs/decisions/simplify.md).
    """
    x = np.asarray(x, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tface = np.asarray(triangle_face, dtype=np.int64)
    flat = np.asarray(flat, dtype=bool)
    if planes is not None:
        x, tface = _merged(x, tri, tface, flat, tol, cap, planes)
    return _merged(x, tri, tface, flat, tol, cap, None)


def _merged(x, tri, tface, flat, tol, cap, planes):
    """`merged_planar_faces`' one pass: onto ``planes`` with their offsets held, or
    (None) onto the faces' own planes."""
    hold = planes is not None
    fits = _fits(x, tri, tface, flat, planes)
    merged = _near_parallel(tri, tface, flat, fits)
    if np.array_equal(merged, tface):
        return planar_faces(x, tri, tface, flat, tol, cap, fits, hold), tface
    fits = _fits(x, tri, merged, flat, planes)
    y = planar_faces(x, tri, merged, flat, tol, cap, fits, hold)
    deviation = _bendable_fits(y, tri, merged, flat)[2]
    joined = np.flatnonzero(merged != tface)
    apart = joined[deviation[merged[joined]] > tol]  # a merged face left bent: apart
    if apart.size == 0:
        return y, merged
    bent = np.zeros(flat.size, dtype=bool)
    bent[merged[apart]] = True
    merged = np.where(bent[merged], tface, merged)
    return planar_faces(
        x, tri, merged, flat, tol, cap, _fits(x, tri, merged, flat, planes), hold
    ), merged


def _bendable(tface, flat) -> np.ndarray:
    """Which faces can bend: those of flat regions with two triangles or more."""
    return flat & (np.bincount(tface, minlength=flat.size) >= 2)


def _bendable_fits(x, tri, tface, flat):
    """`_place.plane_fits` of the faces that can bend (`_bendable`; zeros and not
    spanned for the others)."""
    on = np.flatnonzero(_bendable(tface, flat)[tface])
    return plane_fits(x, tri[on], tface[on], flat.size)


def _fits(x, tri, tface, flat, planes):
    """`_bendable_fits`, or where ``planes`` (normals, offsets) is given, those planes
    for the faces that span one, their deviation the largest distance of their
    vertices from them."""
    fits = _bendable_fits(x, tri, tface, flat)
    if planes is None:
        return fits
    normals, offsets, deviation, spanned = fits
    on = spanned[tface]
    face = tface[on]
    normals = np.where(spanned[:, None], planes[0], normals)
    offsets = np.where(spanned, planes[1], offsets)
    corners = x[tri[on]]  # (t, 3, 3)
    height = np.abs(np.einsum("tcd,td->tc", corners, normals[face]) - offsets[face][:, None])
    deviation = np.where(spanned, 0.0, deviation)
    np.maximum.at(deviation, face, height.max(axis=1))
    return normals, offsets, deviation, spanned


def _near_parallel(tri, tface, flat, fits):
    """Each triangle's face with the flat faces (two triangles or more, spanning a
    plane; ``fits``: `_bendable_fits`) that meet at a vertex on planes within
    `_PARALLEL_RTOL` of parallel joined, transitively, each group labelled as its
    largest member."""
    nf = flat.size
    size = np.bincount(tface, minlength=nf)
    normals, _, _, spanned = fits
    ok = _bendable(tface, flat) & spanned
    pairs = unique_pairs(np.column_stack([tri.reshape(-1), tface.repeat(3)]))
    pairs = pairs[ok[pairs[:, 1]]]
    # every two faces at a vertex: each row against the next ones of its vertex
    a, b = [], []
    for shift in range(1, int(np.bincount(pairs[:, 0]).max(initial=0))):
        same = pairs[shift:, 0] == pairs[:-shift, 0]
        a.append(pairs[:-shift, 1][same])
        b.append(pairs[shift:, 1][same])
    if not a:
        return tface
    a, b = np.concatenate(a), np.concatenate(b)
    cos = np.abs(np.einsum("ij,ij->i", normals[a], normals[b]))
    near = cos >= np.sqrt(1.0 - _PARALLEL_RTOL**2)
    if not near.any():
        return tface
    graph = sparse.coo_array((np.ones(int(near.sum())), (a[near], b[near])), shape=(nf, nf))
    _, group = connected_components(graph, directed=False)
    # the largest member of each group (ties: the lower label) names it
    order = np.lexsort((-np.arange(nf), size))
    label = np.empty(group.max() + 1, dtype=np.int64)
    label[group[order]] = order
    return label[group][tface]


def planar_faces(
    x, triangles, triangle_face, flat, tol: float, cap: float, fits=None, hold_offsets: bool = False
):
    """``x`` with the bent faces of flat regions moved onto their planes (see the module).

    Parameters
    ----------
    x : ndarray of shape (V, 3)
        Vertices.
    triangles : ndarray of shape (T, 3), int64
        Triangles; ``triangle_face`` (T,) their face (region).
    flat : ndarray of shape (R,), bool
        Which regions are flat.
    tol : float
        A face whose vertices lie within this distance of their plane is planar.
    cap : float
        Faces bent by more than this, and moves longer than this, are left.
    fits : tuple, optional
        `_bendable_fits` of these arguments (found when None), or other planes
        (`_fits`).
    hold_offsets : bool
        The bent faces' offsets stay those of ``fits`` (each vertex goes to the
        nearest point on its faces' planes); False: they are the offsets that move
        the vertices least.

    Returns
    -------
    ndarray of shape (V, 3)
        The vertices (a copy).

    Examples
    --------
    A square of two triangles with one corner lifted a little comes out flat:

    >>> v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.01], [0, 1, 0.0]])
    >>> t = np.array([[0, 1, 2], [0, 2, 3]])
    >>> y = planar_faces(v, t, np.zeros(2, int), np.ones(1, bool), 1e-9, 0.1)
    >>> bool(abs(np.linalg.det(np.c_[y[1:] - y[0]])) < 1e-12)
    True
    """
    x = np.asarray(x, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    tface = np.asarray(triangle_face, dtype=np.int64)
    flat = np.asarray(flat, dtype=bool)
    nf = flat.size
    size = np.bincount(tface, minlength=nf)  # which face gives way first (`_failed`)
    bendable = _bendable(tface, flat)
    if not bendable[tface].any():  # no face that can bend
        return x.copy()
    if fits is None:
        fits = _bendable_fits(x, tri, tface, flat)
    normals, offsets, deviation, spanned = fits
    held = bendable & spanned & (deviation <= cap)
    before = _cross(x, tri)
    for _ in range(PLANAR_ATTEMPTS):
        bent = held & (deviation > tol)
        if not bent.any():
            break
        rows = _bent_rows(tri, tface, held, bent)
        free = np.full(nf, -1, dtype=np.int64)
        if not hold_offsets:
            free[bent] = np.arange(int(bent.sum()))
        verts, move, solved = _least_moves(x, rows, normals, offsets, free)
        if not np.isfinite(move).all():
            break
        y = x.copy()
        y[verts] += move
        d = offsets.copy()
        if not hold_offsets:
            d[bent] = solved
        failed = _failed(x, y, tri, rows, normals, d, bent, size, before, tol, cap)
        if not failed.any():
            return y
        held &= ~failed
    return x.copy()


def _bent_rows(tri, tface, held, bent) -> np.ndarray:
    """The (vertex, face) pairs, sorted, of the ``held`` faces at the vertices of the
    ``bent`` ones: what `_least_moves` moves."""
    t = np.flatnonzero(held[tface])
    pairs = unique_pairs(np.column_stack([tri[t].reshape(-1), np.repeat(tface[t], 3)]))
    return pairs[np.isin(pairs[:, 0], unique_ints(pairs[bent[pairs[:, 1]], 0]))]


def _least_moves(x, rows, normals, offsets, free):
    """The moves of ``rows``' vertices ((vertex, face) pairs sorted by vertex) onto all
    their faces' planes, with the offsets of the faces where ``free`` >= 0 (their
    index among the unknowns) changed from ``offsets`` so that the sum of the squared
    moves is least: ``(vertices, moves (n, 3), offsets of the free faces)``; with
    no free face, each vertex onto the nearest point on its faces' planes."""
    n_free = int(free.max(initial=-1)) + 1
    ids, cols, vals, verts, fixed = [], [], [], [], []
    start = 0
    for v, faces, a, p in _plane_groups(rows, normals):
        fixed.append(np.einsum("ndc,nc->nd", p, offsets[faces] - np.einsum("ncd,nd->nc", a, x[v])))
        row = start + 3 * np.arange(v.size)[:, None] + np.arange(3)
        for k in range(faces.shape[1] if n_free else 0):  # the free offsets' columns
            col = free[faces[:, k]]
            on = col >= 0
            ids.append(row[on].reshape(-1))
            cols.append(np.repeat(col[on], 3))
            vals.append(p[on, :, k].reshape(-1))
        verts.append(v)
        start += 3 * v.size
    b = np.concatenate(fixed).reshape(-1)
    if n_free == 0:
        return np.concatenate(verts), b.reshape(-1, 3), offsets[:0]
    m = sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(ids), np.concatenate(cols))),
        shape=(start, n_free),
    )
    # the offsets' changes; a ridge of `_RIDGE` of the mean diagonal keeps the system
    # regular where two faces' offsets move no vertex apart (it draws them to their
    # fits, by far less than the tolerance)
    lhs = (m.T @ m).tocsc()
    lhs = lhs + sparse.identity(n_free, format="csc") * (_RIDGE * lhs.diagonal().mean())
    change = np.atleast_1d(spsolve(lhs, -(m.T @ b)))
    return np.concatenate(verts), (m @ change + b).reshape(-1, 3), offsets[free >= 0] + change


def _failed(x, y, tri, rows, normals, offsets, bent, size, before, tol, cap):
    """Which bent faces give way: at each vertex that cannot go where ``y`` puts it
    (`_unplaceable`), its bent face of fewest triangles (ties: the lower label)."""
    bad = _unplaceable(x, y, tri, rows, normals, offsets, before, tol, cap)
    off = rows[bad[rows[:, 0]] & bent[rows[:, 1]]]
    failed = np.zeros(bent.size, dtype=bool)
    if off.size:
        off = off[np.lexsort((off[:, 1], size[off[:, 1]], off[:, 0]))]
        failed[off[np.r_[True, off[1:, 0] != off[:-1, 0]], 1]] = True
    return failed


def _unplaceable(x, y, tri, rows, normals, offsets, before, tol, cap, movers=False):
    """(V,) bool: the vertices moved from ``x`` to ``y`` by more than ``cap``, on a
    triangle turned over (``movers``: those of its corners that moved), or left off
    one of their faces' planes (``rows``: (vertex, face) pairs) by more than ``tol``
    (near-parallel planes, or four that do not meet). A triangle left with less than
    `SHRINK` of its area along its former normal (``before``: its cross product)
    counts as turned over."""
    moved = np.linalg.norm(y - x, axis=1)
    bad = moved > cap
    kept = np.einsum("ij,ij->i", before, _cross(y, tri))
    flipped = (kept <= SHRINK * np.einsum("ij,ij->i", before, before)) & before.any(axis=1)
    corners = unique_ints(tri[flipped])
    bad[corners[moved[corners] > 0.0] if movers else corners] = True
    height = np.einsum("ij,ij->i", normals[rows[:, 1]], y[rows[:, 0]]) - offsets[rows[:, 1]]
    bad[rows[np.abs(height) > tol, 0]] = True
    return bad


#: Rounds of `bent_apart` at most (the triangles set apart at one vertex can leave
#: the face's next vertex unable to go onto its plane).
APART_ROUNDS = 4
#: ... and a face keeps at least this share of its triangles: set apart, a face
#: of which most was bent would only be called curved (it stays, bent).
APART_KEEP = 0.5


def bent_apart(x, triangles, triangle_face, flat, planes, tol: float, cap: float):
    """Every bent face of a flat region made planar, its triangles at the vertices
    that cannot go onto its plane set apart.

    Where `merged_planar_faces` (the faces' own planes) leaves a face bent by more
    than ``tol``, the vertices of the bent faces that cannot go onto the ``planes``
    of all their flat faces (the regions' normals (R, 3) and offsets (R,): the
    points' fits; each vertex to the nearest point on them) are found
    (`_unplaceable`: a move longer than ``cap``, a move that turns a triangle over,
    planes that do not meet), and the bent face's triangles at them go to the face's
    *companion* (label ``R + face``, not flat), in at most `APART_ROUNDS` rounds,
    while the face keeps `APART_KEEP` of its triangles.
    The points' planes, not the face's own fit, tell which vertices those are: a
    far corner tilts the fit and takes every vertex off it. What held a face bent
    (a corner across a sharp edge, a vertex of four planes) is then in its
    companion, written as its own planar pieces.

    Returns ``(x, triangle_face)``: the vertices (a copy) and each triangle's face,
    a companion's label ``R + face``.

    Examples
    --------
    A strip of four triangles on z = 0 whose last corner lies far above it: the
    triangle at that corner is set apart, the rest stays on the plane:

    >>> v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 1.0]])
    >>> t = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 4], [2, 5, 4]])
    >>> planes = (np.array([[0, 0, 1.0]]), np.zeros(1))
    >>> y, face = bent_apart(v, t, np.zeros(4, np.int64), np.ones(1, bool), planes, 1e-9, 0.1)
    >>> face.tolist(), bool(np.array_equal(y, v))
    ([0, 0, 0, 1], True)
    """
    x = np.asarray(x, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    face = np.asarray(triangle_face, dtype=np.int64).copy()
    n = np.asarray(flat, dtype=bool).size
    flat = np.concatenate([np.asarray(flat, dtype=bool), np.zeros(n, dtype=bool)])
    normals = np.concatenate([planes[0], np.zeros((n, 3))])
    offsets = np.concatenate([planes[1], np.zeros(n)])
    size = np.bincount(face, minlength=2 * n)
    for _ in range(APART_ROUNDS):
        y, merged = merged_planar_faces(x, tri, face, flat, tol, cap)
        bendable = _bendable(face, flat)
        _, _, deviation, spanned = _bendable_fits(y, tri, face, flat)
        bent = bendable & spanned & (deviation > tol)
        if not bent.any():
            return y, merged
        # each vertex of a bent face to the nearest point on its faces' planes
        rows = _bent_rows(tri, face, spanned & bendable, bent)
        verts, move, _ = _least_moves(x, rows, normals, offsets, np.full(2 * n, -1))
        z = x.copy()
        z[verts] += move
        bad = _unplaceable(x, z, tri, rows, normals, offsets, _cross(x, tri), tol, cap, True)
        hit = bent[face] & bad[tri].any(axis=1)
        # a face left with less than `APART_KEEP` of its triangles stays whole (bent)
        left = np.bincount(face[~hit], minlength=2 * n)
        hit &= left[face] >= APART_KEEP * size[face]
        if not hit.any():
            return y, merged
        face = np.where(hit, n + face, face)
    return merged_planar_faces(x, tri, face, flat, tol, cap)


#: Passes of `off_plane_relabelled` at most (a triangle given away can let the one
#: behind it go next).
RELABEL_PASSES = 3


def off_plane_relabelled(x, triangles, triangle_face, flat, planes, far: float) -> np.ndarray:
    """Each triangle's face, the triangles of flat faces with a corner farther than
    ``far`` from their face's plane (``planes``: normals (R, 3) and offsets (R,), by
    face) given to a face across one of their edges: the flat one whose plane holds
    their corners nearest, within ``far``, else the first that is not flat; in at
    most `RELABEL_PASSES` passes. Such a triangle lies on another face (a corner of a
    sharp edge the segmentation gave to the wrong side): left in, it keeps its face
    bent (`merged_planar_faces` cannot move its corner that far).

    Examples
    --------
    Two triangles given each other's face: the first (face 0, the plane z = 0) lies
    on x = 0, the second (face 1, the plane x = 0) on z = 0:

    >>> x = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0.0]])
    >>> t = np.array([[0, 1, 2], [0, 3, 1]])
    >>> planes = (np.array([[0, 0, 1], [1, 0, 0.0]]), np.zeros(2))
    >>> off_plane_relabelled(x, t, np.array([0, 1]), np.array([True, True]), planes, 0.1)
    array([1, 0])
    """
    x = np.asarray(x, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    face = np.asarray(triangle_face, dtype=np.int64).copy()
    flat = np.asarray(flat, dtype=bool)
    normals, offsets = planes
    if tri.shape[0] == 0 or not flat.any():
        return face
    across = edge_neighbours(tri)
    corners = x[tri]  # (T, 3, 3)
    for _ in range(RELABEL_PASSES):
        height = np.abs(np.einsum("tcd,td->tc", corners, normals[face]) - offsets[face][:, None])
        off = np.flatnonzero(flat[face] & (height.max(axis=1) > far))
        if off.size == 0:
            break
        new = _taker(corners[off], face[off], face, across[off], flat, planes, far)
        changed = new != face[off]
        if not changed.any():
            break
        face[off[changed]] = new[changed]
    return face


def _taker(corners, own, face, across, flat, planes, far: float) -> np.ndarray:
    """`off_plane_relabelled`'s new face for triangles of ``corners`` (k, 3, 3), of
    faces ``own`` (k,), whose neighbours are ``across`` (k, 3; -1: none) and the
    triangles' faces ``face``: ``own`` where none takes them."""
    normals, offsets = planes
    cand = np.where(across >= 0, face[np.maximum(across, 0)], -1)
    cand = np.where(cand == own[:, None], -1, cand)
    valid = cand >= 0
    g = np.maximum(cand, 0)
    height = np.einsum("kcd,kjd->kjc", corners, normals[g]) - offsets[g][:, :, None]
    fit = np.abs(height).max(axis=2)  # (k, 3): the corners' farthest from each plane
    score = np.where(valid & flat[g] & (fit <= far), fit, np.inf)
    rows = np.arange(own.size)
    best = np.argmin(score, axis=1)
    curved = valid & ~flat[g]
    return np.where(
        np.isfinite(score[rows, best]),
        g[rows, best],
        np.where(curved.any(axis=1), g[rows, np.argmax(curved, axis=1)], own),
    )


def edge_neighbours(tri) -> np.ndarray:
    """(T, 3): the triangle across each edge (``a b``, ``b c``, ``c a``) of every
    triangle, -1 on an edge of one triangle or of more than two.

    Examples
    --------
    >>> edge_neighbours(np.array([[0, 1, 2], [2, 1, 3]]))
    array([[-1,  1, -1],
           [ 0, -1, -1]])
    """
    n = tri.shape[0]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    _, inverse, counts = unique_pairs(
        np.sort(edges, axis=1), return_inverse=True, return_counts=True
    )
    out = np.full(3 * n, -1, dtype=np.int64)
    two = np.flatnonzero(counts[inverse] == 2)
    order = two[np.argsort(inverse[two], kind="stable")]  # the two sides in turn
    a, b = order[0::2], order[1::2]
    out[a], out[b] = b % n, a % n
    return out.reshape(3, n).T
