"""The decimation step: structure-aware quadric edge collapse (reference, pure Python).

Garland and Heckbert's quadric error metric, with the structure term of Salinas,
Lafarge and Alliez (2015): every vertex carries the quadric of its triangles' planes
(area-weighted) plus, for each flat region it lies on, that region's plane quadric
weighted by ``structure`` times the vertex's area; an open boundary edge adds the
quadric of the plane through it perpendicular to its triangle (weighted 100x, so the
outline stays). The cheapest edge is collapsed to the point minimising the summed
quadric (the better of its ends and midpoint when that point is ill-defined), unless
the collapse would break the surface: the link condition (the ends share exactly the
two vertices opposite the edge, one on an open boundary) keeps it manifold, and no
triangle around may turn by more than 90 degrees or lose its area. Triangles keep
their identity (and region) through collapses, so the regions of the result are the
input's regions, decimated.
"""

from __future__ import annotations

import heapq

import numpy as np

from ._kernels import collapse_position, turns_over

__all__ = ["decimate"]

#: Weight of an open boundary edge's quadric relative to the triangles'.
_BOUNDARY_WEIGHT = 100.0
#: Weight of the squared squared edge length added to a collapse's cost (ties).
_TIE = 1e-6


def _plane_quadrics(normals, offsets, weights) -> np.ndarray:
    """(K, 4, 4) weighted quadrics of planes n . x = d: w [n; -d][n; -d]^T."""
    h = np.column_stack([normals, -offsets])
    return weights[:, None, None] * h[:, :, None] * h[:, None, :]


def decimate(vertices, triangles, target: int, *, labels=None, planes=None, structure=1.0):
    """Collapse edges of a closed or open manifold triangle mesh down to ``target``
    triangles (or until no valid collapse is left).

    Parameters
    ----------
    vertices : ndarray of shape (V, 3)
    triangles : ndarray of shape (T, 3), int
        A consistently oriented manifold surface.
    target : int
        Number of triangles to stop at.
    labels : ndarray of shape (T,), int, optional
        Region of every triangle; with ``planes`` the structure term applies.
    planes : tuple of ndarrays (R, 3), (R,), (R,) bool, optional
        Normals, offsets and flatness of the regions (`flat_planes`); the quadric of
        each flat region is added to its vertices.
    structure : float
        Weight of the regions' plane quadrics.

    Returns
    -------
    vertices : ndarray of shape (V', 3)
        The kept vertices, placed.
    triangles : ndarray of shape (T', 3), int64
        Remaining triangles, renumbered.
    kept : ndarray of shape (T',), int64
        Input triangle each remaining triangle is (so ``labels[kept]`` are regions).
    source : ndarray of shape (V',), int64
        Input vertex each kept vertex was (before it moved).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> v, t, kept, source = decimate(m.vertices, m.faces, 12)
    >>> len(t), bool(np.allclose(np.abs(v), 0.5))  # the eight corners
    (12, True)
    """
    v = np.array(vertices, dtype=np.float64)
    tri = np.array(triangles, dtype=np.int64)
    n_v = v.shape[0]
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
        _push(heap, v, q, a, b, version)
    n_alive = tri.shape[0]
    while n_alive > target and heap:
        cost, a, b, va, vb, x = heapq.heappop(heap)
        if version[a] != va or version[b] != vb or not faces_of[a] or not faces_of[b]:
            continue
        shared = faces_of[a] & faces_of[b]
        if not shared or (len(shared) == 2 and on_boundary[a] and on_boundary[b]):
            continue  # an inner edge between two boundary vertices would pinch
        if not _collapsible(v, tri, faces_of, a, b, shared, np.array(x)):
            continue
        for f in shared:
            alive[f] = False
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
            _push(heap, v, q, a, w, version)
    kept = np.flatnonzero(alive)
    used = np.unique(tri[kept])
    remap = np.full(n_v, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    return v[used], remap[tri[kept]], kept, used


def _vertex_quadrics(v, tri, labels, planes, structure) -> np.ndarray:
    n_v = v.shape[0]
    cross = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(2.0 * area, 1e-300)[:, None]
    kf = _plane_quadrics(normal, np.einsum("ij,ij->i", normal, v[tri[:, 0]]), area)
    q = np.zeros((n_v, 4, 4))
    for c in range(3):
        np.add.at(q, tri[:, c], kf)
    # open boundary: an edge in one triangle, the plane through it across the triangle
    directed = np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1).reshape(-1, 2)
    owner = np.repeat(np.arange(tri.shape[0]), 3)
    keys = np.minimum(directed[:, 0], directed[:, 1]) * n_v + np.maximum(*directed.T)
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    open_edge = counts[inverse] == 1
    if open_edge.any():
        e = directed[open_edge]
        d = v[e[:, 1]] - v[e[:, 0]]
        side = np.cross(d, normal[owner[open_edge]])
        length = np.linalg.norm(side, axis=1)
        side /= np.maximum(length, 1e-300)[:, None]
        ke = _plane_quadrics(
            side, np.einsum("ij,ij->i", side, v[e[:, 0]]), _BOUNDARY_WEIGHT * length
        )
        np.add.at(q, e[:, 0], ke)
        np.add.at(q, e[:, 1], ke)
    if labels is not None and planes is not None and structure > 0.0:
        normals, offsets, flat = planes
        lab = np.asarray(labels, dtype=np.int64)
        pairs = np.unique(np.column_stack([tri.reshape(-1), np.repeat(lab, 3)]), axis=0)
        pairs = pairs[flat[pairs[:, 1]]]
        vertex_area = np.zeros(n_v)
        for c in range(3):
            np.add.at(vertex_area, tri[:, c], area / 3.0)
        kp = _plane_quadrics(
            normals[pairs[:, 1]], offsets[pairs[:, 1]], structure * vertex_area[pairs[:, 0]]
        )
        np.add.at(q, pairs[:, 0], kp)
    return q


def _push(heap, v, q, a, b, version) -> None:
    cost, x, y, z = collapse_position(q[a] + q[b], v[a], v[b])
    # ties (flat parts cost nothing) go to the shortest edge, so no vertex gathers a
    # whole flat face around it
    d = v[a] - v[b]
    cost = max(cost, 0.0) + _TIE * float(d @ d) ** 2
    heapq.heappush(heap, (cost, a, b, int(version[a]), int(version[b]), (x, y, z)))


def _collapsible(v, tri, faces_of, a, b, shared, x) -> bool:
    """Link condition, and no triangle around turning over or collapsing."""
    ring_a = {int(u) for f in faces_of[a] for u in tri[f]} - {a}
    ring_b = {int(u) for f in faces_of[b] for u in tri[f]} - {b}
    opposite = {int(u) for f in shared for u in tri[f]} - {a, b}
    if ring_a & ring_b != opposite:
        return False
    for w, others in ((a, faces_of[a]), (b, faces_of[b])):
        around = list(others - shared)
        if around and turns_over(v, tri[around], w, x):
            return False
    return True
