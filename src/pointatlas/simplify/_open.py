"""An open sample's voxel surface cut back to the points (private; `_reconstruct`).

The field of an open sample (a sheet, a scan that misses a side) has no inside: its
marching-cubes surface wraps both sides of the points and runs on past their outline
as far as the field's band reaches. What lies beyond the points is cut here.

Decisions in docs/decisions/simplify.md ("Open samples").
"""

from __future__ import annotations

import numpy as np

from .._core import PointAtlasError
from ._mesh import unique_pairs, used_only, vertex_pieces
from ._voxel_grid import LOST_SHARE, LOST_STEPS, lost_points

__all__ = [
    "AllBubbles",
    "OUTLINE_CUT_STEPS",
    "OUTLINE_SMOOTH_ROUNDS",
    "TRIM_MIN_PIECE",
    "TRIM_MIN_SHARE",
    "TRIM_STEPS",
    "as_open",
    "beyond_points",
    "drop_strays",
    "smooth_outline",
    "trim",
]

#: A triangle farther than this from every point (grid steps), or farther than one
#: step and facing away from its nearest point's normal, lies beyond an open boundary
#: of the input and is cut away ...
TRIM_STEPS = 4.5
#: ... and so is one whose centroid lies more than this many steps off the points'
#: surface counted past their outline (`PointSurface.outline_distance`: beyond the
#: last points, or over their discs where the surface wraps the sheet's other side):
#: without it the surface ran on up to 4.5 steps past the points of a scan that
#: misses a side, a flap 1-3 % of the diagonal off the true surface, whose staircase
#: edge kept hundreds of outline vertices (at one step: 21 of every 3rd collection
#: model scanned without its bottom within 1 % of the truth, at half a step 25, at a
#: quarter 24 with a third more triangles) ...
OUTLINE_CUT_STEPS = 0.5
#: The cut outline, a staircase of grid steps, is smoothed along itself this many
#: rounds (`smooth_outline`): the boundary quadrics pinned every step's corner, and
#: the collapses kept them (sampled without their bottom, a sphere kept 816 triangles
#: against 543 now, a cylinder 218 against 112; five rounds round a box's outline
#: corners, 1.41 % of the diagonal off the truth against 0.66 %).
OUTLINE_SMOOTH_ROUNDS = 2
#: ... unless its piece of far triangles is this small (a gap of the sampling) ...
TRIM_MIN_PIECE = 24
#: ... or this share of all triangles.
TRIM_MIN_SHARE = 0.01


def beyond_points(surface, centroids, d, facing, step: float) -> np.ndarray:
    """Which triangles (``centroids``) of the surface of an open sample lie beyond its
    points (``surface``: their `PointSurface`): farther than `TRIM_STEPS` steps from
    every point (``d``: each centroid's distance to its nearest point), farther than
    one step and facing away from that point's normal (``facing``: the cosine), or
    more than `OUTLINE_CUT_STEPS` steps off the points' surface counted past their
    outline (only the centroids farther than that from every point are asked)."""
    beyond = (d > TRIM_STEPS * step) | ((d > step) & (facing < -0.5))
    ask = np.flatnonzero(~beyond & (d > OUTLINE_CUT_STEPS * step))
    if ask.size:
        beyond[ask] = surface.outline_distance(centroids[ask]) > OUTLINE_CUT_STEPS * step
    return beyond


def trim(tri, far):
    """Far triangles to cut: those in pieces (edge-connected) of at least
    `TRIM_MIN_PIECE` triangles and `TRIM_MIN_SHARE` of all."""
    if not far.any():
        return far
    from scipy.sparse import coo_array, csgraph

    idx = np.flatnonzero(far)
    sub = tri[idx]
    edges = np.sort(np.stack([sub[:, [0, 1]], sub[:, [1, 2]], sub[:, [2, 0]]], 1), axis=2)
    edges = edges.reshape(-1, 2)
    owner = np.repeat(np.arange(idx.size), 3)
    _, inv = np.unique(edges, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    order = np.argsort(inv, kind="stable")
    same = inv[order[1:]] == inv[order[:-1]]
    a, b = owner[order[1:]][same], owner[order[:-1]][same]
    g = coo_array((np.ones(a.size), (a, b)), shape=(idx.size, idx.size))
    _, piece = csgraph.connected_components(g, directed=False)
    size = np.bincount(piece)
    cut = np.zeros_like(far)
    cut[idx[size[piece] >= max(TRIM_MIN_PIECE, TRIM_MIN_SHARE * tri.shape[0])]] = True
    return cut


def drop_strays(q, verts, tri, least: int):
    """``(verts, tri)`` without the pieces (vertex-connected) that fewer than ``least``
    of the points ``q`` have their nearest triangle (by centroid) on: a triangle the
    cut left touching the rest at one vertex only, on its own once the pinch is split
    (`_mesh.split_pinches`)."""
    from scipy.spatial import cKDTree

    piece = vertex_pieces(tri, verts.shape[0])[tri[:, 0]]
    _, nearest = cKDTree(verts[tri].mean(axis=1)).query(q, workers=-1)
    owned = np.bincount(piece[nearest], minlength=int(piece.max()) + 1)
    keep = owned[piece] >= least
    if keep.all() or not keep.any():
        return verts, tri
    return used_only(verts, tri[keep])


def smooth_outline(verts, tri, rounds: int = OUTLINE_SMOOTH_ROUNDS) -> np.ndarray:
    """``verts`` with the vertices of the open boundary of ``tri`` smoothed along it:
    ``rounds`` of Taubin's two steps (lambda 0.5, mu -0.53: a staircase flattened, a
    loop not shrunk), each such vertex moved towards the midpoint of its two
    neighbours along the boundary; the vertices of more than one boundary run
    (pinched) stay.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0.2, 0], [2, 0, 0], [1, 1, 0.0]])
    >>> t = np.array([[0, 1, 3], [1, 2, 3]])
    >>> float(smooth_outline(v, t, 1)[1, 1]) < 0.2  # the kink flattens
    True
    """
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    _, inv, count = unique_pairs(np.sort(directed, axis=1), return_inverse=True, return_counts=True)
    run = directed[count[inv.reshape(-1)] == 1]
    n = verts.shape[0]
    ends = np.bincount(run.reshape(-1), minlength=n)
    after, before = np.full(n, -1), np.full(n, -1)
    after[run[:, 0]], before[run[:, 1]] = run[:, 1], run[:, 0]
    on = np.flatnonzero((ends == 2) & (after >= 0) & (before >= 0))
    v = np.array(verts, dtype=np.float64)
    for _ in range(rounds):
        for share in (0.5, -0.53):
            mid = 0.5 * (v[after[on]] + v[before[on]])
            v[on] += share * (mid - v[on])
    return v


class AllBubbles(PointAtlasError):
    """Every piece of a voxel surface read as a bubble (`_reconstruct._surface_at`)."""


def as_open(q, build, first: AllBubbles):
    """The surface ``build()`` of points ``q`` taken for an open sample, where the
    dipole test called them closed and every piece of their surface read as a bubble
    (``first``: dipoles that cancel by symmetry, as an open tube's: its caps lie far
    from every point); kept when it leaves fewer than `LOST_SHARE` of the points more
    than `LOST_STEPS` grid steps off, else ``first`` is raised (walls thinner than the
    grid: the open surface loses the points too)."""
    try:
        rec = build()
    except PointAtlasError:
        raise first from None
    if (
        lost_points(
            q, rec.vertices, rec.triangles, LOST_STEPS * rec.step, index=rec.distance_index()
        )
        >= LOST_SHARE * q.shape[0]
    ):
        raise first from None
    return rec
