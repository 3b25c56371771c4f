"""Exact distance from points to a triangle mesh (`point_mesh_distance`, and
`MeshDistanceIndex` for many queries against one mesh)."""

from __future__ import annotations

import numpy as np

from .._core import as_float, as_points
from ._kernels.mesh_distance import build_bvh, bvh_distances

__all__ = ["MeshDistanceIndex", "point_mesh_distance"]

#: most triangles in a leaf of the hierarchy
_LEAF_SIZE = 8
#: round-off margin of the box bound: a box is skipped only when its squared
#: distance exceeds best * (1 + _PRUNE_RTOL) + (_PRUNE_RTOL * extent)^2, far above
#: the rounding error of a computed point-triangle distance, so the minimum found
#: is the minimum over all triangles
_PRUNE_RTOL = 1e-9
#: hinted points are measured in the Morton order of the cells of a grid of 2^this
#: cells a side over their box (near points one after the other)
_ORDER_BITS = 8


def _as_triangles(triangles, n_vertices: int) -> np.ndarray:
    try:
        tri = np.asarray(triangles)
    except (TypeError, ValueError):
        raise TypeError(
            f"triangles must be an integer array of shape (T, 3); got {triangles!r}"
        ) from None
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] < 1:
        raise ValueError(f"triangles must have shape (T, 3) with T >= 1; got {tri.shape}")
    if tri.dtype.kind not in "iu":
        raise ValueError(f"triangles must hold integers; got dtype {tri.dtype}")
    if tri.min() < 0 or tri.max() >= n_vertices:
        raise ValueError(
            f"triangles must index vertices 0..{n_vertices - 1}; "
            f"got {int(tri.min())}..{int(tri.max())}"
        )
    return np.ascontiguousarray(tri, dtype=np.int64)


def point_mesh_distance(points, vertices, triangles, *, within: float = 0.0) -> np.ndarray:
    """Exact Euclidean distance from every point to a triangle mesh.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Query points (N >= 0).
    vertices : array_like of shape (V, 3), float64
        Mesh vertices.
    triangles : array_like of shape (T, 3), int
        Triangles (T >= 1; polygon meshes: triangulate first). Zero-area triangles
        (repeated or collinear corners) count as the union of their edges.
    within : float
        Distances up to this are not refined: a point with a triangle that near
        gets some value at most ``within`` (default 0: every distance exact). Every
        larger distance is exact, so ``max() <= within`` is decided exactly, much
        faster (a bound check).

    Returns
    -------
    distances : ndarray of shape (N,), float64
        Unsigned distance to the closest point of the closest triangle, in the
        input's units.

    Raises
    ------
    ValueError
        Bad shapes, no triangles, indices out of range, non-integer triangles,
        non-finite coordinates.
    TypeError
        Triangles that are not an array.

    Notes
    -----
    Exact, not sampled: the triangles go into a bounding-volume hierarchy (median
    splits of the centroids, axis-aligned boxes, leaves of 8); every point descends
    it nearest box first and skips every box farther than the closest triangle found
    so far (plus a round-off margin of 1e-9 relative), so the result is the minimum
    over all triangles of the closest-point distance (Ericson, Real-Time Collision
    Detection 5.1.5) -- the same value a scan over every triangle returns. Both sets
    are first centred on the mesh's bounding box, so coordinates far from the origin
    keep their digits. Cost: about O((N + T) log T) for points near the surface.

    Examples
    --------
    >>> point_mesh_distance([[0.2, 0.2, 1.0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    array([1.])
    """
    pts = as_points(points, min_points=0)
    verts = as_points(vertices, name="vertices")
    within = as_float(within, "within", lo=0.0)
    tri = _as_triangles(triangles, verts.shape[0])
    if pts.shape[0] == 0:
        return np.empty(0)
    return MeshDistanceIndex(verts, tri).distance(pts, within=within)


class MeshDistanceIndex:
    """A triangle mesh prepared for `point_mesh_distance` queries: the hierarchy is
    built once, every query gives what `point_mesh_distance` gives on the mesh.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
    triangles : array_like of shape (T, 3), int
        As in `point_mesh_distance` (T >= 1).

    Examples
    --------
    >>> index = MeshDistanceIndex([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> index.distance([[0.2, 0.2, 1.0]]), index.all_within([[0.2, 0.2, 1.0]], 0.5)
    (array([1.]), False)
    """

    def __init__(self, vertices, triangles):
        verts = as_points(vertices, name="vertices")
        tri = _as_triangles(triangles, verts.shape[0])
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        self._center = lo + 0.5 * (hi - lo)
        corners = np.ascontiguousarray((verts - self._center)[tri].reshape(-1, 9))
        self._boxes, self._first, self._count, order = build_bvh(corners, _LEAF_SIZE)
        self._leaf_corners = np.ascontiguousarray(corners[order])
        self._position = np.empty(tri.shape[0], dtype=np.int64)
        self._position[order] = np.arange(tri.shape[0])
        self._slack = (_PRUNE_RTOL * float(np.linalg.norm(hi - lo))) ** 2
        self.n_triangles = int(tri.shape[0])

    def distance(self, points, *, within: float = 0.0, hint=None, order=None) -> np.ndarray:
        """Distance of every point to the mesh, as `point_mesh_distance` (``within``
        likewise). ``hint`` (N,) int, optional: a triangle per point (-1: none) to
        measure first; a near one makes the search shorter, the values are the same
        (exact ones exactly, those up to ``within`` some value up to it). ``order``
        (N,) int, optional, with a hint: the order to measure the points in (a
        permutation; default `point_order`: near points one after the other); any
        order gives the same values, a caller that measures one point set often
        computes it once."""
        pts = as_points(points, min_points=0)
        within = as_float(within, "within", lo=0.0)
        out = np.empty(pts.shape[0])
        self._run(pts, out, within, np.inf, hint, order)
        return out

    def all_within(self, points, bound: float, *, hint=None, order=None) -> bool:
        """Whether every point is at most ``bound`` from the mesh: the same answer as
        ``distance(points, within=bound).max() <= bound`` (True without points), but
        boxes beyond ``bound`` are skipped and the search ends at the first point
        beyond it. ``hint`` and ``order`` as in `distance`."""
        pts = as_points(points, min_points=0)
        bound = as_float(bound, "bound", lo=0.0)
        return not self._run(pts, np.empty(pts.shape[0]), bound, bound, hint, order)

    @staticmethod
    def point_order(points) -> np.ndarray:
        """The order hinted points are measured in (by default): the Morton order of
        their cells in a grid of 2^8 cells a side over their box, near points one
        after the other (any order of ties). (N,) int64, a permutation."""
        pts = as_points(points, min_points=0)
        return np.argsort(_grid_cells(pts)) if pts.shape[0] else np.zeros(0, dtype=np.int64)

    def _run(self, pts, out, within, bound, hint, order=None) -> bool:
        """Run the kernel; whether a point was found beyond ``bound``."""
        if pts.shape[0] == 0:
            return False
        start = np.zeros(0, dtype=np.int64)
        if hint is not None:
            hint = np.asarray(hint, dtype=np.int64).reshape(-1)
            if hint.shape[0] != pts.shape[0] or hint.max(initial=-1) >= self.n_triangles:
                raise ValueError(
                    f"hint must hold one triangle (< {self.n_triangles}) or -1 per point"
                )
            start = np.where(hint >= 0, self._position[np.maximum(hint, 0)], -1)
            # near points in a row (Morton order of cells): each starts from the nearest
            # triangle of the one before it
            if order is None:
                order = np.argsort(_grid_cells(pts))  # any order of ties: the same values
            elif not _is_permutation(order, pts.shape[0]):
                raise ValueError(f"order must be a permutation of the {pts.shape[0]} points")
            pts, start, sorted_out = pts[order], start[order], np.empty_like(out)
            found = self._kernel(pts, start, sorted_out, within, bound)
            out[order] = sorted_out
            return found
        return self._kernel(pts, start, out, within, bound)

    def _kernel(self, pts, start, out, within, bound) -> bool:
        stop = np.zeros(1, dtype=np.int64)
        bvh_distances(
            np.ascontiguousarray(pts - self._center),
            self._leaf_corners,
            self._boxes,
            self._first,
            self._count,
            start,
            _PRUNE_RTOL,
            self._slack,
            out,
            float(within) ** 2,
            float(bound),
            stop,
        )
        return bool(stop[0])


def _is_permutation(order, n: int) -> bool:
    order = np.asarray(order)
    if order.shape != (n,) or order.dtype.kind not in "iu":
        return False
    if order.min() < 0 or order.max() >= n:
        return False
    return bool((np.bincount(order, minlength=n) == 1).all())


def _grid_cells(pts, bits: int = _ORDER_BITS):
    """Morton code of every point's cell in a 2^bits per axis grid over their box."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    side = 1 << bits
    scale = side / np.maximum(hi - lo, 1e-300)
    cell = np.minimum(((pts - lo) * scale).astype(np.int64), side - 1)
    return _SPREAD[cell[:, 0]] | (_SPREAD[cell[:, 1]] << 1) | (_SPREAD[cell[:, 2]] << 2)


#: bit b of a cell coordinate at bit 3 b (a Morton code is x | y << 1 | z << 2)
_SPREAD = sum(
    ((np.arange(1 << _ORDER_BITS, dtype=np.int64) >> b) & 1) << (3 * b) for b in range(_ORDER_BITS)
)
