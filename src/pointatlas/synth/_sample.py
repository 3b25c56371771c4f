"""Area-weighted uniform sampling of points on a triangle mesh."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import as_points, as_rng, readonly
from ._kernels import weighted_corners
from ._mesh import _as_faces, _face_cross

__all__ = ["MeshSample", "sample_mesh"]


@dataclass(frozen=True, slots=True)
class MeshSample:
    """Points sampled on a mesh (unpacks as ``points, normals, face_index``).

    Parameters
    ----------
    points : ndarray of shape (n, 3), float64
        Sampled positions.
    normals : ndarray of shape (n, 3), float64
        Unit normal of the triangle each point lies in.
    face_index : ndarray of shape (n,), int64
        The triangle each point lies in.
    """

    points: np.ndarray
    normals: np.ndarray
    face_index: np.ndarray

    def __post_init__(self):
        for name in ("points", "normals", "face_index"):
            object.__setattr__(self, name, readonly(np.asarray(getattr(self, name))))

    def __iter__(self):
        return iter((self.points, self.normals, self.face_index))


def sample_mesh(vertices, faces, n_points: int, *, rng=None) -> MeshSample:
    """Sample points uniformly by area on a triangle mesh, with the face normals.

    Parameters
    ----------
    vertices : array_like of shape (V, 3)
        Vertex coordinates.
    faces : array_like of shape (F, 3), int
        Triangles (counter-clockwise seen from outside gives outward normals).
    n_points : int
        Number of samples (>= 0).
    rng : None, int or numpy.random.Generator
        Randomness (``np.random.default_rng(rng)``); the same seed gives the same
        sample bit for bit.

    Returns
    -------
    sample : MeshSample
        ``points`` (n, 3), ``normals`` (n, 3) unit, ``face_index`` (n,) int64;
        unpacks as ``points, normals, face_index = sample_mesh(...)``.

    Raises
    ------
    ValueError, TypeError
        Bad shapes, indices or count, or a mesh of total area 0.

    Notes
    -----
    A triangle is drawn with probability proportional to its area (inverse CDF on
    the cumulative areas), then a point in it by ``p = (1 - sqrt r1) a +
    sqrt r1 (1 - r2) b + sqrt r1 r2 c`` with r1, r2 uniform, which is uniform on the
    triangle. Degenerate triangles are never drawn.

    Examples
    --------
    >>> v = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    >>> pts, nrm, face = sample_mesh(v, [[0, 1, 2]], 4, rng=0)
    >>> pts.shape, nrm[0].tolist(), face.tolist()
    ((4, 3), [0.0, 0.0, 1.0], [0, 0, 0, 0])
    """
    verts = as_points(vertices, name="vertices")
    tri = _as_faces(faces, verts.shape[0])
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer):
        raise TypeError(f"n_points must be an integer; got {type(n_points).__name__}")
    if n_points < 0:
        raise ValueError(f"n_points must be >= 0; got {n_points}")
    gen = as_rng(rng)
    cross = _face_cross(verts, tri)
    double_area = np.linalg.norm(cross, axis=1)
    cum = np.cumsum(double_area)
    if tri.shape[0] == 0 or not cum[-1] > 0:
        raise ValueError("faces must span a positive area; got a mesh of total area 0")
    u, weights = sample_draws(n_points, gen)
    face = np.searchsorted(cum, u * cum[-1], side="right")
    # cum[i-1] <= draw < cum[i] only for positive-area faces; a draw rounded up to
    # the total goes to the last positive-area face
    face = np.minimum(face, np.flatnonzero(double_area > 0)[-1])
    pts = face_points(verts, tri, face, weights)
    nrm = cross[face] / double_area[face, None]
    return MeshSample(pts, nrm, face.astype(np.int64))


def sample_draws(n: int, gen: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`sample_mesh`'s random numbers for ``n`` points, which do not depend on the mesh:
    ``(u, weights)``, the triangle draws in [0, 1) (scaled by the total area, then
    found in the cumulative areas) and the barycentric weights (3, n) of Osada et al.
    (``1 - sqrt r1``, ``sqrt r1 (1 - r2)``, ``sqrt r1 r2``), drawn from ``gen`` in that
    order. Shared with the simplification's back samples, which draw once for many
    meshes (`pointatlas.simplify._distance`)."""
    u = gen.random(n)
    r1, r2 = gen.random((2, n))
    s1 = np.sqrt(r1)
    return u, np.stack([1.0 - s1, s1 * (1.0 - r2), s1 * r2])


def face_points(verts, tri, face, weights) -> np.ndarray:
    """The points of barycentric ``weights`` (3, n) in triangles ``face`` (n,): ``wa a
    + wb b + wc c`` (one pass, `_kernels.weighted_corners`: the simplification draws
    20,000 of them for every level it measures, where numpy's three gathers and
    temporaries cost ten times as much)."""
    return weighted_corners(
        np.ascontiguousarray(verts, dtype=np.float64),
        np.ascontiguousarray(tri, dtype=np.int64),
        np.ascontiguousarray(face, dtype=np.int64),
        np.ascontiguousarray(weights, dtype=np.float64),
    )
