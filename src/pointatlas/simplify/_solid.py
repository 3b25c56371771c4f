"""Parts thinner than the grid made solid again: the lost points' half balls (private).

A wall or fin thinner than a grid step has no node inside it: the tangent planes of
both its sides put every node outside, and the voxel surface loses the part (its
points a step or more off it) or cuts holes through it. Where the surface leaves
`LOST_POINTS` points more than `SOLID_LOST` steps off, the field is built again on
the finer grid with, at each point more than `SOLID_FROM` steps off in the same
pieces, its half ball behind its tangent plane (`SOLID_RADIUS` steps) set inside,
where the field puts the point's back outside: the part comes back as a slab about
a step thick around its points. The new surface is kept where it brings at least half
of those points near and keeps the first surface's Euler characteristic.
Decisions in docs/decisions/simplify.md ("Parts thinner than the grid").
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_array, csgraph
from scipy.spatial import cKDTree

from .._core import PointAtlasError
from ._voxel_grid import LOST_LINK, LOST_POINTS, euler_characteristic, lost_points, not_strays

__all__ = ["SOLID_FROM", "SOLID_LOST", "SOLID_RADIUS", "half_balls", "solid_retry"]

#: A surface leaving at least `LOST_POINTS` points more than this many grid steps
#: off is built again with their parts made solid ...
SOLID_LOST = 1.5
#: ... from every point more than this many steps (of that surface's grid) off, in
#: pieces (points within `SOLID_LINK` spacings of each other) holding a lost one ...
SOLID_FROM = 0.5
SOLID_LINK = 2.0
#: ... each giving the nodes behind its tangent plane within this many steps (of the
#: finer grid) of it: every point has a node within sqrt(3) / 2 steps, and a slab
#: thinner than about a step leaves holes between the nodes.
SOLID_RADIUS = 1.25
#: Nodes a half ball is measured at: the nearest points of each, at most this many.
SOLID_K = 8


def half_balls(f, origin, step: float, points, normals, radius: float) -> np.ndarray:
    """``f`` (nodes ``origin + index * step``, C order; written) with the half balls of
    the ``points`` whose back the field puts outside: at each node within ``radius``
    of one, the least over its `SOLID_K` nearest such points of max(|x - p| - radius,
    n . (x - p)) where that is lower (negative: inside). The grid's outer layer is
    left as it is (outside). A point whose front the field puts inside (in a pocket
    the surface bridged) is left out: carving those cut holes through thin parts."""
    p = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    # the field half a step and more behind and in front of each point (trilinear)
    probe = 0.75 * step * n
    back = ndimage.map_coordinates(f, ((p - probe - origin) / step).T, order=1, mode="nearest")
    front = ndimage.map_coordinates(f, ((p + probe - origin) / step).T, order=1, mode="nearest")
    lost = (back > 0.0) & (front >= 0.0)
    if not lost.any():
        return f
    p, n = p[lost], n[lost]
    reach = int(np.ceil(radius / step))
    r = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)
    nodes = (np.rint((p - origin) / step).astype(np.int64)[:, None, :] + offsets).reshape(-1, 3)
    inner = ((nodes >= 1) & (nodes <= np.array(f.shape) - 2)).all(axis=1)
    key = np.unique(np.ravel_multi_index(tuple(nodes[inner].T), f.shape))
    x = origin + np.stack(np.unravel_index(key, f.shape), axis=1) * step
    k = min(SOLID_K, p.shape[0])
    d, j = cKDTree(p).query(x, k=k, distance_upper_bound=radius)
    d, j = d.reshape(x.shape[0], k), j.reshape(x.shape[0], k)
    near = np.isfinite(d)
    j = np.where(near, j, 0)
    ahead = np.einsum("nkc,nkc->nk", x[:, None, :] - p[j], n[j])
    g = np.where(near, np.maximum(d - radius, ahead), np.inf).min(axis=1)
    flat = f.reshape(-1)
    flat[key] = np.minimum(flat[key], g)
    flat[flat == 0.0] = 1e-12 * step  # no node exactly on the level
    return f


def _solid_points(q, off, lost, spacing: float) -> np.ndarray:
    """Indices of the points ``off`` (mask) in pieces (points within `SOLID_LINK`
    spacings of each other) holding one of the ``lost`` (mask)."""
    idx = np.flatnonzero(off)
    pairs = cKDTree(q[idx]).query_pairs(SOLID_LINK * spacing, output_type="ndarray")
    graph = coo_array(
        (np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(idx.size, idx.size)
    )
    _, piece = csgraph.connected_components(graph, directed=False)
    holds = np.zeros(piece.max() + 1, dtype=bool)
    holds[piece[lost[idx]]] = True
    return idx[holds[piece]]


def solid_retry(q, normals, rec, build, step: float, spacing: float, off=None):
    """The surface ``rec`` (a `Reconstruction` of points ``q``), or the one ``build``
    gives with the points' parts lost on it made solid, where that brings at least
    half of the points more than `SOLID_LOST` ``step`` off near and keeps ``rec``'s
    Euler characteristic. ``build(points, normals)`` builds the surface on the finer
    grid with those points' `half_balls`. Strays among the lost points are left out
    (`_voxel_grid.not_strays`: ``off``, `LOST_LINK` spacings; None: none)."""
    d = rec.distance_index().distance(q, within=SOLID_FROM * rec.step)
    link = LOST_LINK * spacing
    lost = not_strays(q, d > SOLID_LOST * step, off, link)
    if lost.sum() < LOST_POINTS:
        return rec
    idx = _solid_points(q, d > SOLID_FROM * rec.step, lost, spacing)
    try:
        solid = build(q[idx], normals[idx])
    except PointAtlasError:
        return rec
    index = solid.distance_index()
    still = lost_points(q, solid.vertices, solid.triangles, SOLID_LOST * step, off, link, index)
    same = euler_characteristic(solid.triangles) == euler_characteristic(rec.triangles)
    return solid if 2 * still <= lost.sum() and same else rec
