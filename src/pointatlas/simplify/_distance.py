"""Two-sided distances between the output and the input (what a user sees both ways).

Input -> output (`distances`: every input vertex or point to the output triangles)
misses a spike or a sheet the output adds where the input has nothing; output ->
input catches it: the output's vertices and a seeded, area-uniform sample of its
triangles, measured to the input's triangles (a mesh) or to the nearest input
point (a point set).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial import cKDTree

from .._core._threads import query_workers, run_chunks
from ..neighbors import MeshDistanceIndex, point_mesh_distance
from ..synth._sample import face_points, sample_draws
from ._disc_kernels import disc_rows, outline_rows
from ._grid_knn import GridKnn
from ._mesh import unique_pairs

__all__ = [
    "BACK_SAMPLES",
    "DISC_NEIGHBOR",
    "DISC_OFF",
    "DISC_TURN",
    "OUTLINE_MARGIN",
    "OUTLINE_NEIGHBORS",
    "PointSurface",
    "back_distances",
    "disc_radii",
    "output_samples",
    "output_samples_on",
    "point_back_samples",
]

#: Area-uniform samples of the output surface measured back to the input.
BACK_SAMPLES = 20_000
#: A point's tangent disc reaches its this-th nearest neighbour (`PointSurface`).
DISC_NEIGHBOR = 8
#: A disc stops at an edge: at the nearest of those neighbours whose normal's line
#: turns from the point's by more than this angle (radians; 30 degrees) ...
DISC_TURN = np.pi / 6
#: ... and which lie off the point's tangent plane by more than the sine of this
#: angle (15 degrees) times their distance (points with normals blended at an edge,
#: a mesh's vertex normals, lie on their own plane and do not stop it).
DISC_OFF = np.pi / 12
#: The distance to the points' surface is the nearest of this many points' discs (a
#: sample on one face near an edge may have its nearest point across the edge).
DISC_CANDIDATES = 6
#: `PointSurface.outline_distance`: a position is past the points' outline when its
#: this many nearest points, seen along the nearest disc's normal, all lie within a
#: half-turn less ...
OUTLINE_NEIGHBORS = 10
#: ... this angle (radians; 20 degrees) of one another around it.
OUTLINE_MARGIN = np.pi / 9


def disc_radii(distances: np.ndarray, points=None, normals=None, rows=None) -> np.ndarray:
    """The points' disc radii of `PointSurface` from their k-NN table (`query_knn`:
    the point itself first, at least `DISC_NEIGHBOR` + 1 columns or all the points):
    the distance to the `DISC_NEIGHBOR`-th nearest other point, and with ``points``,
    ``normals`` and the table's ``rows`` no more than the distance to the nearest of
    those neighbours past an edge (its normal's line turned by more than `DISC_TURN`
    and it off the point's tangent plane by more than sin `DISC_OFF` of its distance):
    a face's disc then does not reach over the edge, so a surface extended past the
    edge is measured."""
    k = min(DISC_NEIGHBOR + 1, distances.shape[0])
    if distances.shape[1] < k:
        raise ValueError(f"disc_radii needs {k} neighbours; got {distances.shape[1]}")
    radius = distances[:, k - 1] if k > 1 else np.zeros(distances.shape[0])
    if normals is None or k < 2:
        return radius
    p = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    radius = radius.copy()
    for j in range(1, k):  # a column at a time: (n, 3) temporaries, not (n, k, 3)
        near, dist = rows[:, j], distances[:, j]
        turned = np.abs(np.einsum("ij,ij->i", n, n[near])) < np.cos(DISC_TURN)
        height = np.abs(np.einsum("ij,ij->i", n, p[near] - p))
        edge = turned & (height > np.sin(DISC_OFF) * dist)
        radius[edge] = np.minimum(radius[edge], dist[edge])
    return radius


class PointSurface:
    """The surface a point set samples, as each point's tangent disc (its normal,
    radius the distance to its `DISC_NEIGHBOR`-th neighbour): the distance of x to it
    is the least of sqrt(h^2 + max(t - r, 0)^2) over x's nearest points (r no more
    than the distance to a neighbour past an edge, `disc_radii`), h the
    height of x over a point's tangent plane and t the distance along it. Sampling
    gaps (nearest points a spacing away on a flat face) then cost nothing, while a
    spike or a sheet where there are no points costs its full distance; without
    normals, the distance to the nearest point. ``tree`` (a `cKDTree` of the points)
    and ``radius`` (the discs' radii, e.g. from a k-NN table the caller has:
    `disc_radii`) are searched when not given.
    """

    def __init__(self, points, normals=None, tree=None, radius=None):
        # writeable arrays (a copy only of a read-only one): the kernels they reach
        # have one signature, the mesh path's (docs/decisions/cli.md, "First run")
        self.points = np.require(points, np.float64, ["C", "W"])
        self.tree = cKDTree(self.points) if tree is None else tree
        self.normals = None if normals is None else np.require(normals, np.float64, ["C", "W"])
        if radius is None:
            k = min(DISC_NEIGHBOR + 1, self.points.shape[0])
            far, rows = self.tree.query(self.points, k=k, workers=-1)
            shape = (self.points.shape[0], k)
            radius = disc_radii(far.reshape(shape), self.points, self.normals, rows.reshape(shape))
        self.radius = np.ascontiguousarray(radius, dtype=np.float64)

    @functools.cached_property
    def grid(self) -> GridKnn:
        """The points on a grid (`GridKnn`: the k-d tree's answers, faster near the
        points), cells of twice the median disc radius (about 3 spacings)."""
        return GridKnn(self.points, 2.0 * float(np.median(self.radius)))

    @functools.cached_property
    def _normal_scale(self) -> float:
        """The normals' largest length, at least 1 (`distance_over`'s margin: a disc
        is no farther than its point times it)."""
        return max(1.0, float(np.sqrt(np.einsum("ij,ij->i", self.normals, self.normals).max())))

    def distance(self, x, nearest: bool = False):
        """Distance of every row of ``x`` to the points' surface: the nearest of its
        `DISC_CANDIDATES` nearest points' discs. With ``nearest``, ``(distances,
        rows)``: each row's nearest point too (found by the same search: where two
        are exactly as near, the smaller row)."""
        x = np.asarray(x, dtype=np.float64)
        if self.normals is None:
            d, j = self.tree.query(x, workers=query_workers(x.shape[0]))
            return (d, j.astype(np.int64)) if nearest else d
        k = min(DISC_CANDIDATES, self.points.shape[0])
        return self._rows(disc_rows, x, k, (), nearest)

    def distance_over(self, x, bound: float) -> np.ndarray:
        """`distance` where it may pass ``bound``; elsewhere at most ``bound``: a row
        whose nearest point is nearer than ``bound`` (by a relative 1e-9, and the
        normals' length) is within it, its nearest disc being no farther than that
        point, and gets that point's distance (a search for 1 neighbour instead of
        6 and the discs: most of a level's samples)."""
        x = np.asarray(x, dtype=np.float64)
        if self.normals is None or x.shape[0] == 0:
            return self.distance(x)
        out = self.grid.query(x, 1)[0][:, 0]
        far = np.flatnonzero(out * self._normal_scale * (1.0 + 1e-9) > bound)
        if far.size:
            out[far] = self.distance(x[far])
        return out

    def outline_distance(self, x) -> np.ndarray:
        """`distance`, with the discs cut at the points' outline: where the
        `OUTLINE_NEIGHBORS` nearest points of ``x``, projected onto the tangent plane
        of its nearest disc, leave a gap wider than a half-turn plus `OUTLINE_MARGIN`
        around it (``x`` lies past the edge of the sampled surface, e.g. a face
        extended over a step), it is at least as far as its height over that plane
        and its distance past those points along the middle of the gap. Inside the
        outline, and without normals, `distance`. A placement checked with `distance`
        alone may extend a face three spacings past a wall (a disc's radius).

        Examples
        --------
        >>> g = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
        >>> s = PointSurface(np.c_[g, np.zeros(25)], np.tile([0, 0, 1.0], (25, 1)))
        >>> x = np.array([[2.0, 2.5, 0.0], [6.0, 2.0, 0.0]])
        >>> s.distance(x).tolist(), s.outline_distance(x).round(9).tolist()
        ([0.0, 0.0], [0.0, 2.0])
        """
        x = np.asarray(x, dtype=np.float64)
        if self.normals is None or x.shape[0] == 0:
            return self.distance(x)
        k = min(max(OUTLINE_NEIGHBORS, DISC_CANDIDATES), self.points.shape[0])
        return self._rows(outline_rows, x, k, (float(OUTLINE_MARGIN),))

    def _rows(self, kernel, x, k: int, extra: tuple, nearest: bool = False):
        """``kernel`` (`_disc_kernels`) on every row of ``x`` with its ``k`` nearest
        points, on threads (with ``nearest``, and the nearest point's row)."""
        d, j = self.grid.query(x, k)
        x = np.ascontiguousarray(x)
        out = np.empty(x.shape[0])
        c = min(DISC_CANDIDATES, k)
        args = (x, d, j, self.points, self.normals, self.radius, c, *extra, out)
        run_chunks(kernel, x.shape[0], args)
        return (out, j[:, 0].copy()) if nearest else out


def output_samples(vertices, triangles, n: int = BACK_SAMPLES, seed: int = 0) -> np.ndarray:
    """The used output vertices and ``n`` area-uniform samples of the triangles (seeded).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> output_samples(v, np.array([[0, 1, 2]]), n=5).shape
    (8, 3)
    """
    return output_samples_on(vertices, triangles, n, seed)[0]


def point_back_samples(vertices, triangles, n: int = BACK_SAMPLES, seed: int = 0):
    """What the points path measures back to the points' surface: the midpoints of
    the output's edges, then `output_samples` (its used vertices and ``n`` area
    samples). A sliver triangle whose long edge crosses a concave corner of the
    points, through the air, takes few area samples: 20,000 of them missed one 1.28 %
    of the diagonal off on a sampled CAD part, whose edge midpoint is that far.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> point_back_samples(v, np.array([[0, 1, 2]]), n=5)[:3].tolist()
    [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.5, 0.5, 0.0]]
    """
    t = np.asarray(triangles, dtype=np.int64)
    v = np.asarray(vertices, dtype=np.float64)
    edges = unique_pairs(np.sort(np.stack([t, t[:, [1, 2, 0]]], axis=2).reshape(-1, 2), axis=1))
    middle = 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])
    return np.vstack([middle, output_samples(v, t, n, seed)])


def output_samples_on(vertices, triangles, n: int = BACK_SAMPLES, seed: int = 0):
    """`output_samples` and a triangle each sample lies on (one around a vertex).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    >>> output_samples_on(v, np.array([[0, 1, 2], [2, 1, 3]]), n=2)[1].tolist()
    [0, 0, 0, 1, 1, 0]
    """
    samples, on, _ = _samples_in_order(vertices, triangles, n, seed)
    return samples, on


def _samples_in_order(vertices, triangles, n: int = BACK_SAMPLES, seed: int = 0, first=None):
    """`output_samples_on` and an order to measure them in (a permutation: the
    vertices, then the area samples by triangle), for `MeshDistanceIndex`'s ``order``;
    ``first``: only the first this many of the ``n`` area samples (the same points,
    a subset measured first).

    The area samples are `sample_mesh`'s (``rng=seed``) bit for bit: the same draws
    (`sample_draws`, made once per ``n`` and ``seed``, `_draws`) and points
    (`face_points`); each sample's triangle, `sample_mesh`'s inverse CDF of the
    cumulative areas, found by one pass over the sorted draws instead of a binary
    search each (a test compares the two)."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    is_used = np.zeros(v.shape[0], dtype=bool)
    is_used[t.reshape(-1)] = True
    used = np.flatnonzero(is_used)  # np.unique(t), without its sort
    around = np.zeros(v.shape[0], dtype=np.int64)
    # the first triangle around every vertex (reversed: the first write is the last)
    around[t[::-1].reshape(-1)] = np.repeat(np.arange(t.shape[0] - 1, -1, -1), 3)
    corners, on = v[used], around[used]
    a = v[t[:, 0]]
    double_area = np.linalg.norm(np.cross(v[t[:, 1]] - a, v[t[:, 2]] - a), axis=1)
    if t.shape[0] == 0 or not double_area.sum() > 0.0:
        return corners, on, np.arange(used.size)
    u, u_sorted, by_draw, weights = _draws(n, seed)
    cum = np.cumsum(double_area)
    if first is not None and first < n:
        face = np.searchsorted(cum, u[:first] * cum[-1], side="right")
        by_draw, weights = np.argsort(face, kind="stable"), weights[:, :first]
    else:
        # the triangle of the i-th smallest draw d: the number of cum[j] <= d, i.e.
        # of the j whose first draw not below cum[j] comes at or before i
        start = np.searchsorted(u_sorted * cum[-1], cum, side="left")
        face = np.empty(n, dtype=np.int64)
        face[by_draw] = np.cumsum(np.bincount(start, minlength=n + 1)[:n])
    # a draw rounded up to the total goes to the last positive-area triangle
    face = np.minimum(face, np.flatnonzero(double_area > 0)[-1])
    pts = face_points(v, t, face, weights)
    order = np.concatenate([np.arange(used.size), used.size + by_draw])
    return np.vstack([corners, pts]), np.concatenate([on, face]), order


@functools.lru_cache(maxsize=4)
def _draws(n: int, seed: int):
    """`sample_mesh`'s random numbers for ``n`` samples and ``rng=seed``, which do not
    depend on the mesh: the triangle draws in [0, 1), sorted, their order, and the
    barycentric weights (3, n) (read-only)."""
    u, weights = sample_draws(n, np.random.default_rng(seed))
    by_draw = np.argsort(u, kind="stable")
    out = (u, u[by_draw], by_draw, weights)
    for x in out:
        x.flags.writeable = False
    return out


def back_distances(out_v, out_t, in_v, in_t=None, *, within: float = 0.0) -> np.ndarray:
    """Distance of `output_samples` to the input: its triangles (or their
    `MeshDistanceIndex`), or its points' surface (a `PointSurface`: of
    `point_back_samples`, the edges' midpoints too; or the nearest point when
    ``in_v`` is an array); ``within``: as in `point_mesh_distance`,
    triangles only.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> spike = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 2.0]])
    >>> float(back_distances(spike, [[0, 1, 2]], v, [[0, 1, 2]]).max())
    2.0
    """
    if isinstance(in_v, PointSurface):
        return in_v.distance(point_back_samples(out_v, out_t))
    samples = output_samples(out_v, out_t)
    if isinstance(in_v, MeshDistanceIndex):
        return in_v.distance(samples, within=within)
    if in_t is None:
        return cKDTree(np.asarray(in_v, dtype=np.float64)).query(samples, workers=-1)[0]
    return point_mesh_distance(samples, in_v, np.asarray(in_t, dtype=np.int64), within=within)
