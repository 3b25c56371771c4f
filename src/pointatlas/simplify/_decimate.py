"""The decimation step: structure-aware quadric edge collapse.

Garland and Heckbert's quadric error metric, with the structure term of Salinas,
Lafarge and Alliez (2015): every vertex carries the quadric of its triangles' planes
(area-weighted) plus, for each flat region it lies on, that region's plane quadric
weighted by ``structure`` times the vertex's area; an open boundary edge adds the
quadric of the plane through it perpendicular to its triangle (weighted 100x, so the
outline stays). The cheapest edge is collapsed to the point minimising the summed
quadric (the better of its ends and midpoint when that point is ill-defined), on the
planes of the flat regions left around it when they are held (`_plane_kernels`: the
faces of flat regions stay exactly planar; refused where those planes do not meet),
unless the collapse would break the surface: the link condition (the ends share
exactly the two vertices opposite the edge, one on an open boundary) keeps it
manifold, and no triangle around may turn by more than 90 degrees or lose its area.
Triangles keep their identity (and region) through collapses, so the regions of the
result are the input's regions, decimated.
"""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .._core.tolerances import CROSSING_FLAT_RTOL, CROSSING_RTOL
from ._bound_kernels import nearest_of
from ._kernels import add_rows, collapse_edges, replay
from ._mesh import unique_pairs

__all__ = ["CarriedPoints", "Collapses", "collapse_all", "decimate"]

#: Weight of an open boundary edge's quadric relative to the triangles'.
_BOUNDARY_WEIGHT = 100.0
#: Weight of the squared squared edge length added to a collapse's cost (ties).
_TIE = 1e-6
#: A flat plane that adds no direction at a merged vertex (parallel to its others)
#: must pass within this fraction of the diagonal of it, else the collapse is refused.
_ON_PLANES = 1e-7
#: A carried point's first owner is the nearest of this many triangles (the nearest
#: centroids).
_OWNER_CANDIDATES = 8
#: The carried points' grid has at most this many cells a side.
_MAX_CELLS = 256


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
    seq = collapse_all(
        vertices, triangles, labels=labels, planes=planes, structure=structure, target=target
    )
    return seq.mesh(seq.steps_for(target))


class CarriedPoints(NamedTuple):
    """What `collapse_all` reads of its ``surface`` (a `PointSurface`): the points,
    their normals (or None) and their discs' radii
    (`_level_search.start_collapses`: every s-th point of a large input)."""

    points: np.ndarray
    normals: np.ndarray | None
    radius: np.ndarray


@dataclass(frozen=True, slots=True)
class Collapses:
    """Every collapse of a mesh's decimation, cheapest first (`collapse_all`), or
    those down to a triangle count (its ``target``: a prefix of all of them); the mesh
    after any number of them is `mesh` (a level of detail is a prefix).

    Attributes
    ----------
    vertices, triangles : ndarray
        The input mesh.
    kept, gone : ndarray of shape (n,), int64
        Collapse k merges vertex ``gone[k]`` into ``kept[k]``...
    position : ndarray of shape (n, 3)
        ...and moves it to ``position[k]``...
    removed : ndarray of shape (n,), int64
        ...removing this many triangles (1 on an open boundary, else 2).
    cost : ndarray of shape (n,)
        Its quadric cost (area times squared distance, plus the tie-break).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    kept: np.ndarray
    gone: np.ndarray
    position: np.ndarray
    removed: np.ndarray
    cost: np.ndarray

    def n_triangles(self, m: int) -> int:
        """Triangles left after the first ``m`` collapses."""
        return int(self.triangles.shape[0] - self.removed[:m].sum())

    def steps_for(self, target: int) -> int:
        """The fewest collapses that leave at most ``target`` triangles (all of them
        when no prefix does)."""
        left = self.triangles.shape[0] - np.cumsum(self.removed)
        if self.triangles.shape[0] <= target:
            return 0
        hit = np.flatnonzero(left <= target)
        return int(hit[0]) + 1 if hit.size else int(self.kept.size)

    def mesh(self, m: int):
        """The mesh after the first ``m`` collapses: ``(vertices, triangles, kept,
        source)`` as `decimate` returns them."""
        return self.mesh_and_map(m)[:4]

    def mesh_and_map(self, m: int):
        """`mesh` and ``went`` (V,): the output vertex every input vertex became (-1
        for a vertex on no triangle)."""
        n_v = self.vertices.shape[0]
        rep, moved, at, alive = replay(
            n_v, self.triangles, self.kept, self.gone, self.position, int(m)
        )
        v = np.where(moved[:, None], at, self.vertices)
        kept = np.flatnonzero(alive)
        tri = rep[self.triangles[kept]]
        is_used = np.zeros(n_v, dtype=bool)
        is_used[tri.reshape(-1)] = True
        used = np.flatnonzero(is_used)  # np.unique(tri), without its sort
        remap = np.full(n_v, -1, dtype=np.int64)
        remap[used] = np.arange(used.size)
        return v[used], remap[tri], kept, used, remap[rep]


def collapse_all(
    vertices,
    triangles,
    *,
    labels=None,
    planes=None,
    structure=1.0,
    target=None,
    surface=None,
    tolerance=None,
    back=None,
    hold=True,
    uncross=True,
) -> Collapses:
    """The decimation's collapses down to the last valid one (`Collapses`), or down to
    the first that leaves at most ``target`` triangles (the same collapses: the
    sequence stops there, and ``steps_for(target)`` is the same); options as in
    `decimate`. With the points' ``surface`` (`PointSurface`) and ``tolerance`` (a
    number or one per point), a collapse that would take a point farther than its
    tolerance from the triangles, or leave a triangle farther than ``back``
    (default: ``tolerance``) from the points, is refused, so that every level keeps
    every point within it (`_bound_kernels`; a point already farther at first may
    stay as far). ``tolerance`` may be a `concurrent.futures.Future` of the pair
    ``(tolerance, back)``: waited for once the quadrics and the points' first owners
    are found (on a thread, `Decimation.start`, while the caller measures them).
    With ``labels`` and ``planes`` and ``hold``, every merged vertex goes onto the
    planes of its flat regions (`_plane_kernels`: the faces of flat regions stay
    exactly planar). With ``uncross``, a collapse that makes more triangles pass
    through each other around it is refused (`_fan_kernels`)."""
    v = np.array(vertices, dtype=np.float64)
    tri = np.array(triangles, dtype=np.int64)
    n_v = v.shape[0]
    q = _vertex_quadrics(v, tri, labels, planes, structure)
    und = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edge, count = unique_pairs(und, return_counts=True)
    on_boundary = np.zeros(n_v, dtype=bool)
    on_boundary[edge[count == 1].reshape(-1)] = True
    owners = None if surface is None else _owners(surface, v, tri)
    if isinstance(tolerance, Future):
        tolerance, back = tolerance.result()
    if edge.shape[0] == 0:
        return no_collapses(v, tri)
    carried = _carried(surface, owners, tolerance, back)
    held = _held_planes(v, tri, labels, planes if hold else None)
    cross = _cross_tolerances(v, tri) if uncross else (-1.0, -1.0)
    kept, gone, position, removed, cost = collapse_edges(
        v.copy(),
        tri,
        q,
        on_boundary,
        edge.astype(np.int64),
        _TIE,
        int(target or 0),
        carried,
        held,
        cross,
    )
    return Collapses(v, tri, kept, gone, position, removed, cost)


def _cross_tolerances(v, tri):
    """`collapse_edges`' ``cross``: the tolerances of `_crossings.crossing_pairs` on
    the diagonal of the triangles' vertices (a collapse is refused where it makes
    more pairs cross by the measure's count)."""
    diag = _diagonal_of_used(v, tri)
    return CROSSING_RTOL * diag, CROSSING_FLAT_RTOL * diag


def _diagonal_of_used(v, tri) -> float:
    """The bounding-box diagonal of the vertices on a triangle of ``tri`` (T >= 1)."""
    on = v[np.unique(tri)]
    return float(np.linalg.norm(on.max(axis=0) - on.min(axis=0)))


def _held_planes(v, tri, labels, planes):
    """`collapse_edges`' ``planes``: each triangle's flat region (-1: none), the
    regions' normals and offsets, and how far (`_ON_PLANES` of the diagonal of the
    triangles' vertices) a plane adding no direction may be from the merged vertex;
    no rows without ``labels`` and ``planes``."""
    if labels is None or planes is None or tri.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros(0), 0.0
    normals, offsets, flat = planes
    lab = np.asarray(labels, dtype=np.int64)
    tflat = np.where(flat[lab], lab, -1).astype(np.int64)
    diag = _diagonal_of_used(v, tri)
    normals = np.ascontiguousarray(normals, dtype=np.float64)
    return tflat, normals, np.ascontiguousarray(offsets, dtype=np.float64), _ON_PLANES * diag


def _owners(surface, v, tri):
    """The points of ``surface`` (`PointSurface`), each one's first owner (the nearest
    of the triangles whose centroids are its `_OWNER_CANDIDATES` nearest) and its
    squared distance to it."""
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(surface.points, dtype=np.float64)
    if tri.shape[0] == 0:
        return pts, np.zeros(0, dtype=np.int64), np.zeros(0)
    n_p = pts.shape[0]
    centroids = v[tri].mean(axis=1)
    k = min(_OWNER_CANDIDATES, tri.shape[0])
    _, cand = cKDTree(centroids).query(pts, k=k, workers=-1)
    owner, d2 = nearest_of(pts, v, tri, cand.reshape(n_p, k).astype(np.int64))
    return pts, owner, d2


def _carried(surface, owners, tolerance, back):
    """`collapse_edges`' ``carried`` (`_bound_kernels.points_stay`): the points of
    ``surface`` (`PointSurface`), their squared tolerances, squared distances to
    their owners and owners (``owners``: `_owners`), normals, disc radii, squared
    tolerances back (``back``, default ``tolerance``) and the points in grid cells
    (`_point_cells`); no rows without a surface."""
    if surface is None:
        empty, none = np.zeros(0), np.zeros((0, 3))
        return (none, empty, empty, np.zeros(0, dtype=np.int64), none, empty, empty, *_no_cells())
    pts, owner, d2 = owners
    n_p = pts.shape[0]
    tol = np.broadcast_to(np.asarray(tolerance, dtype=np.float64), (n_p,))
    back = tol if back is None else np.broadcast_to(np.asarray(back, dtype=np.float64), (n_p,))
    normals = np.zeros((n_p, 3)) if surface.normals is None else surface.normals
    radius = np.ascontiguousarray(surface.radius, dtype=np.float64)
    cells = _point_cells(pts, float(np.quantile(radius, 0.9) + 2.0 * np.quantile(back, 0.9)))
    return (pts, tol * tol, d2, owner, normals, radius, back * back, *cells)


def _point_cells(pts, cell: float):
    """``(origin, cell size, cells (3,), each cell's first row, the points by cell)``:
    the points in a grid of cubes of at least ``cell`` (at most `_MAX_CELLS` a side),
    cell by cell (x slowest)."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    cell = max(cell, float((hi - lo).max()) / _MAX_CELLS, 1e-300)
    dims = np.floor((hi - lo) / cell).astype(np.int64) + 1
    at = np.minimum(np.floor((pts - lo) / cell).astype(np.int64), dims - 1)
    key = (at[:, 0] * dims[1] + at[:, 1]) * dims[2] + at[:, 2]
    order = np.argsort(key, kind="stable")
    start = np.searchsorted(key[order], np.arange(int(np.prod(dims)) + 1))
    return lo, cell, dims, start.astype(np.int64), order.astype(np.int64)


def _no_cells():
    """`_point_cells` of no points."""
    one = np.ones(3, dtype=np.int64)
    return np.zeros(3), 1.0, one, np.zeros(2, dtype=np.int64), np.zeros(0, dtype=np.int64)


def no_collapses(vertices, triangles) -> Collapses:
    """The empty sequence of a mesh: its level 0 (`Collapses.mesh_and_map` (0) as
    `collapse_all`'s gives it, without the collapses)."""
    v = np.array(vertices, dtype=np.float64)
    tri = np.array(triangles, dtype=np.int64)
    empty = np.zeros(0, dtype=np.int64)
    return Collapses(v, tri, empty, empty, np.zeros((0, 3)), empty, np.zeros(0))


def _vertex_quadrics(v, tri, labels, planes, structure) -> np.ndarray:
    """(V, 4, 4) quadric of every vertex: its triangles' planes, its open boundary
    edges' planes and, weighted by ``structure``, its flat regions' planes. Summed in
    that order, each term in turn, as ``np.add.at`` would (`_summed`)."""
    n_v = v.shape[0]
    cross = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(2.0 * area, 1e-300)[:, None]
    kf = _plane_quadrics(normal, np.einsum("ij,ij->i", normal, v[tri[:, 0]]), area)
    at, terms = [tri[:, 0], tri[:, 1], tri[:, 2]], [kf, kf, kf]
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
        at += [e[:, 0], e[:, 1]]
        terms += [ke, ke]
    if labels is not None and planes is not None and structure > 0.0:
        normals, offsets, flat = planes
        lab = np.asarray(labels, dtype=np.int64)
        pairs = unique_pairs(np.column_stack([tri.reshape(-1), np.repeat(lab, 3)]))
        pairs = pairs[flat[pairs[:, 1]]]
        vertex_area = _summed([tri[:, 0], tri[:, 1], tri[:, 2]], [area / 3.0] * 3, n_v)
        kp = _plane_quadrics(
            normals[pairs[:, 1]], offsets[pairs[:, 1]], structure * vertex_area[pairs[:, 0]]
        )
        at.append(pairs[:, 0])
        terms.append(kp)
    return _summed(at, [k.reshape(-1, 16) for k in terms], n_v).reshape(n_v, 4, 4)


def _summed(at, terms, n: int) -> np.ndarray:
    """``out[at[k][i]] += terms[k][i]`` for every k and i in turn, from zeros (n,) or
    (n, C): the sums of ``np.add.at`` term after term, bit for bit (`_kernels.
    add_rows` adds in the same order), without its per-element cost."""
    flat = terms[0].ndim == 1
    out = np.zeros((n, 1 if flat else terms[0].shape[1]))
    for idx, w in zip(at, terms, strict=True):
        w = np.ascontiguousarray(w.reshape(-1, 1) if flat else w, dtype=np.float64)
        add_rows(np.ascontiguousarray(idx, dtype=np.int64), w, out)
    return out[:, 0] if flat else out
