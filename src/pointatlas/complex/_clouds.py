"""Cloud sets and the cloud complex (thesis Defs 3-10, Prop. 1; docs/decisions/cloud_surfaces.md).

A cloud set is a list of index arrays into a point set. Membership is stored both
ways in CSR form (cloud -> points, point -> clouds). The cloud complex is the
downward closure of the distinct membership sets {clouds containing p : p in P}
(Def. 6): a set of clouds is a simplex iff the clouds share a point.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .._core import as_int, as_points, readonly

__all__ = [
    "CloudComplex",
    "cloud_complex",
    "complex_from_membership",
    "membership_csr",
    "unsupported_mask",
]


@dataclass(frozen=True, slots=True)
class CloudComplex:
    """A cloud set with its cloud complex K (Defs 3, 6) and cloud points (Def 9).

    Attributes
    ----------
    n_points, n_clouds : int
        Number of points and of clouds (empty clouds included).
    cloud_indptr, cloud_members : ndarray of int64
        Cloud -> points CSR: cloud c holds ``cloud_members[cloud_indptr[c]:cloud_indptr[c+1]]``
        (sorted, distinct).
    point_indptr, point_clouds : ndarray of int64
        Point -> clouds CSR (sorted, distinct).
    n_memberships : ndarray of shape (N,), int64
        Number of clouds containing each point (Example 2 colours 1, 2, 3).
    uncovered_points : ndarray of int64
        Points in no cloud (reported, never dropped).
    empty_clouds : ndarray of int64
        Clouds without points (no vertex of K).
    edges : ndarray of shape (E, 2), int64
        1-simplices (sorted pairs, sorted rows).
    triangles : ndarray of shape (F, 3), int64
        2-simplices (sorted triples, sorted rows).
    simplices_above_2 : tuple of tuple of int
        Inclusion-maximal simplices with four or more clouds (Fig. 1.3).
    dimension : int
        Prop. 1: the largest number of clouds sharing a point, minus one (-1 if none).
    cloud_points : ndarray of shape (C, 3), float64
        Realisation (Defs 9-10): one point per cloud (default the centroid of its
        points; NaN for empty clouds or without coordinates).
    """

    n_points: int
    n_clouds: int
    cloud_indptr: np.ndarray
    cloud_members: np.ndarray
    point_indptr: np.ndarray
    point_clouds: np.ndarray
    n_memberships: np.ndarray
    uncovered_points: np.ndarray
    empty_clouds: np.ndarray
    edges: np.ndarray
    triangles: np.ndarray
    simplices_above_2: tuple
    dimension: int
    cloud_points: np.ndarray

    def __post_init__(self):
        for name in (
            "cloud_indptr",
            "cloud_members",
            "point_indptr",
            "point_clouds",
            "n_memberships",
            "uncovered_points",
            "empty_clouds",
            "edges",
            "triangles",
            "cloud_points",
        ):
            readonly(getattr(self, name))

    def cloud(self, c: int) -> np.ndarray:
        """Point indices of cloud ``c`` (sorted int64)."""
        return self.cloud_members[self.cloud_indptr[c] : self.cloud_indptr[c + 1]]

    def clouds_of(self, p: int) -> np.ndarray:
        """Clouds containing point ``p`` (sorted int64)."""
        return self.point_clouds[self.point_indptr[p] : self.point_indptr[p + 1]]

    @property
    def cloud_sizes(self) -> np.ndarray:
        """Number of points per cloud, shape (C,)."""
        return np.diff(self.cloud_indptr)

    @property
    def n_vertices(self) -> int:
        """Number of non-empty clouds (0-simplices)."""
        return self.n_clouds - int(self.empty_clouds.size)


def membership_csr(cloud_indptr: np.ndarray, cloud_members: np.ndarray, n_points: int):
    """Point -> clouds CSR from cloud -> points CSR (both sorted, distinct)."""
    n_clouds = cloud_indptr.size - 1
    cloud_of = np.repeat(np.arange(n_clouds, dtype=np.int64), np.diff(cloud_indptr))
    order = np.lexsort((cloud_of, cloud_members))
    counts = np.bincount(cloud_members, minlength=n_points).astype(np.int64)
    indptr = np.zeros(n_points + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    return indptr, cloud_of[order]


def _padded(point_indptr, point_clouds, counts, width):
    """(N, width) int64 rows: each point's clouds ascending, then -1."""
    n = counts.size
    out = np.full((n, max(width, 1)), -1, dtype=np.int64)
    row = np.repeat(np.arange(n, dtype=np.int64), counts)
    col = np.arange(point_clouds.size, dtype=np.int64) - np.repeat(point_indptr[:-1], counts)
    out[row, col] = point_clouds
    return out


def _unique_rows(rows: np.ndarray, n_clouds: int) -> np.ndarray:
    """Distinct rows of a padded membership table, sorted lexicographically."""
    if rows.shape[0] == 0:
        return rows
    width = rows.shape[1]
    base = n_clouds + 1
    if width * np.log2(max(base, 2)) < 62:  # one int64 code per row
        code = np.zeros(rows.shape[0], dtype=np.int64)
        for j in range(width):
            code = code * base + (rows[:, j] + 1)
        _, first = np.unique(code, return_index=True)
        return rows[first]
    return np.unique(rows, axis=0)


def _subsets(sets: np.ndarray, counts: np.ndarray, size: int, n_clouds: int) -> np.ndarray:
    """All distinct ``size``-subsets of the padded sets, sorted rows."""
    width = sets.shape[1]
    parts = []
    for cols in combinations(range(width), size):
        sel = counts > cols[-1]
        if sel.any():
            parts.append(sets[sel][:, cols])
    if not parts:
        return np.zeros((0, size), dtype=np.int64)
    return _unique_rows(np.concatenate(parts), n_clouds)


def _maximal_above_2(sets: np.ndarray, counts: np.ndarray) -> tuple:
    sel = counts >= 4
    big = [frozenset(int(x) for x in r[:c]) for r, c in zip(sets[sel], counts[sel], strict=True)]
    big.sort(key=lambda s: (-len(s), sorted(s)))
    out: list[frozenset] = []
    for s in big:
        if not any(s <= t for t in out):
            out.append(s)
    return tuple(sorted(tuple(sorted(s)) for s in out))


def complex_from_membership(
    cloud_indptr: np.ndarray,
    cloud_members: np.ndarray,
    n_points: int,
    cloud_points: np.ndarray,
    point_csr: tuple | None = None,
) -> CloudComplex:
    """Build the `CloudComplex` from a validated cloud -> points CSR (sorted, distinct).

    ``point_csr`` (indptr, clouds), the same membership point -> clouds, skips its
    recomputation when the caller has it.
    """
    n_clouds = cloud_indptr.size - 1
    if point_csr is None:
        point_indptr, point_clouds = membership_csr(cloud_indptr, cloud_members, n_points)
    else:
        point_indptr, point_clouds = point_csr
    counts = np.diff(point_indptr)
    width = int(counts.max()) if counts.size else 0
    sets = _unique_rows(_padded(point_indptr, point_clouds, counts, width), n_clouds)
    set_counts = (sets >= 0).sum(axis=1)
    sets, set_counts = sets[set_counts > 0], set_counts[set_counts > 0]
    edges = _subsets(sets, set_counts, 2, n_clouds)
    triangles = _subsets(sets, set_counts, 3, n_clouds)
    return CloudComplex(
        n_points=int(n_points),
        n_clouds=int(n_clouds),
        cloud_indptr=cloud_indptr,
        cloud_members=cloud_members,
        point_indptr=point_indptr,
        point_clouds=point_clouds,
        n_memberships=counts,
        uncovered_points=np.flatnonzero(counts == 0),
        empty_clouds=np.flatnonzero(np.diff(cloud_indptr) == 0),
        edges=edges,
        triangles=triangles,
        simplices_above_2=_maximal_above_2(sets, set_counts),
        dimension=width - 1,
        cloud_points=cloud_points,
    )


def cloud_complex(clouds, points=None, *, n_points=None, cloud_points=None) -> CloudComplex:
    """Build the cloud complex of a cloud set (thesis Def. 6, Prop. 1).

    Parameters
    ----------
    clouds : sequence of array_like of int
        The cloud set: cloud c is an array of point indices (repeats ignored).
    points : array_like of shape (N, 3), float64, optional
        Coordinates; the cloud points default to the centroids of the clouds.
    n_points : int, optional
        Number of points N when ``points`` is not given (default: largest index + 1).
    cloud_points : array_like of shape (C, 3), float64, optional
        Realisation of the clouds (Def. 9); replaces the centroids.

    Returns
    -------
    complex : CloudComplex
        Membership both ways, the simplices of dimension 1 and 2, the maximal
        simplices of higher dimension, the dimension and the cloud points.

    Raises
    ------
    ValueError
        Indices outside [0, N), non-integer indices, bad ``points`` or
        ``cloud_points`` shapes, non-finite coordinates.
    TypeError
        ``clouds`` is not a sequence of integer arrays.

    Notes
    -----
    K is computed as the downward closure of the distinct membership sets
    (docs/decisions/cloud_surfaces.md), never by testing subsets of clouds. A point
    in several clouds witnesses one simplex and all its faces (Remark 3 ii). Use
    `surface_report` for the surface conditions and topology.

    Examples
    --------
    Three clouds on five points, all three sharing point 2 (one triangle):

    >>> K = cloud_complex([[0, 1, 2], [2, 3], [2, 4]], n_points=5)
    >>> K.triangles.tolist(), K.edges.tolist(), K.dimension
    ([[0, 1, 2]], [[0, 1], [0, 2], [1, 2]], 2)
    >>> K.n_memberships.tolist()
    [1, 1, 3, 1, 1]
    """
    if isinstance(clouds, str | bytes) or not hasattr(clouds, "__len__"):
        raise TypeError(f"clouds must be a sequence of index arrays; got {type(clouds).__name__}")
    arrays = []
    for c, cl in enumerate(clouds):
        arr = np.asarray(cl)
        if arr.size == 0:
            arr = np.zeros(0, dtype=np.int64)
        if arr.dtype.kind not in "iu":
            raise TypeError(f"clouds[{c}] must hold integer point indices; got dtype {arr.dtype}")
        if arr.ndim != 1:
            raise ValueError(f"clouds[{c}] must be a 1-D index array; got shape {arr.shape}")
        arrays.append(np.unique(arr.astype(np.int64)))
    pts = None
    if points is not None:
        pts = as_points(points, min_points=0)
        n = pts.shape[0]
    elif n_points is not None:
        n = as_int(n_points, "n_points", lo=0)
    else:
        n = max((int(a[-1]) + 1 for a in arrays if a.size), default=0)
    for c, arr in enumerate(arrays):
        if arr.size and (arr[0] < 0 or arr[-1] >= n):
            raise ValueError(
                f"clouds[{c}] must hold indices in [0, {n}); got {int(arr[0])}..{int(arr[-1])}"
            )
    sizes = np.array([a.size for a in arrays], dtype=np.int64)
    indptr = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=indptr[1:])
    members = np.concatenate(arrays) if arrays else np.zeros(0, np.int64)
    if cloud_points is not None:
        cp = as_points(cloud_points, name="cloud_points", min_points=0)
        if cp.shape[0] != sizes.size:
            raise ValueError(f"cloud_points must have shape ({sizes.size}, 3); got {cp.shape}")
        cp = cp.copy()
    elif pts is not None:
        cp = cloud_centroids(indptr, members, pts)
    else:
        cp = np.full((sizes.size, 3), np.nan)
    return complex_from_membership(indptr, members, n, cp)


def cloud_centroids(indptr: np.ndarray, members: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Centroid of every cloud's points (NaN for an empty cloud); validated input."""
    sizes = np.diff(indptr)
    cloud_of = np.repeat(np.arange(sizes.size), sizes)
    sums = np.zeros((sizes.size, 3))
    for j in range(3):
        sums[:, j] = np.bincount(cloud_of, weights=points[members, j], minlength=sizes.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / sizes[:, None]


def unsupported_mask(K: CloudComplex) -> np.ndarray:
    """Points whose clouds form no simplex on a triangle of ``K`` (validated input).

    True for a point in no cloud, in four or more clouds, in two clouds whose edge
    lies in no triangle, or in one cloud whose vertex lies in no triangle: exactly
    the points Algorithm 3 cannot route (degenerate frames aside). A cloud surface
    (Def. 8) has none but points in no cloud.
    """
    n_c = max(K.n_clouds, 1)
    counts = K.n_memberships
    first = K.point_indptr[:-1]
    bad = (counts == 0) | (counts >= 4)
    tri = K.triangles
    on_tri_v = np.zeros(n_c, dtype=bool)
    on_tri_v[tri.reshape(-1)] = True
    one = np.flatnonzero(counts == 1)
    bad[one] = ~on_tri_v[K.point_clouds[first[one]]]
    two = np.flatnonzero(counts == 2)
    if two.size:
        pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]])
        tri_codes = np.unique(pairs[:, 0] * n_c + pairs[:, 1])
        a, b = K.point_clouds[first[two]], K.point_clouds[first[two] + 1]
        bad[two] = ~np.isin(a * n_c + b, tri_codes)
    return bad
