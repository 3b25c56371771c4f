"""The synthetic-mesh result type and small triangle-mesh helpers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import PointSet, as_normals, as_points, readonly

__all__ = ["SynthMesh", "face_areas"]


def _as_faces(faces, n_vertices: int, *, name: str = "faces") -> np.ndarray:
    """Validate a triangle index array against ``n_vertices``."""
    arr = np.asarray(faces)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (F, 3); got {arr.shape}")
    if arr.size and arr.dtype.kind not in "iu":
        if arr.dtype.kind == "f" and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr)):
            pass
        else:
            raise ValueError(f"{name} must hold integer vertex indices; got dtype {arr.dtype}")
    arr = arr.astype(np.int64, copy=True)
    if arr.size and (arr.min() < 0 or arr.max() >= n_vertices):
        raise ValueError(
            f"{name} must index vertices 0..{n_vertices - 1}; "
            f"got indices in [{int(arr.min())}, {int(arr.max())}]"
        )
    return arr


def _face_cross(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unnormalised face normals (twice the area times the unit normal); validated input."""
    a = vertices[faces[:, 0]]
    return np.cross(vertices[faces[:, 1]] - a, vertices[faces[:, 2]] - a)


def face_areas(vertices, faces) -> np.ndarray:
    """Area of every triangle.

    Parameters
    ----------
    vertices : array_like of shape (V, 3)
        Vertex coordinates.
    faces : array_like of shape (F, 3), int
        Triangles as vertex indices.

    Returns
    -------
    areas : ndarray of shape (F,), float64
        Triangle areas (0 for degenerate triangles).

    Raises
    ------
    ValueError
        Wrong shapes, non-finite coordinates or out-of-range indices.

    Examples
    --------
    >>> face_areas([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]).tolist()
    [0.5]
    """
    verts = as_points(vertices, name="vertices", min_points=0)
    tri = _as_faces(faces, verts.shape[0])
    return 0.5 * np.linalg.norm(_face_cross(verts, tri), axis=1)


def _vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals of the generated models' sharp vertices (private).

    The public function is `pointatlas.io.vertex_normals` (thesis 2.3, 4.4: the
    area-weighted vertex normal). This copy sums the face vectors corner by corner
    (``np.add.at``) where io sums them face by face (``np.bincount``); the two differ
    in the last bit (up to 3.3e-16). It stays only so that the stored normals of the
    generated models (the sharp vertices of `dodecahedron`, `cylinder`, ...), which
    feed the experiments, benchmarks and tests, keep their bits. Validated
    triangles; NaN where the sum has zero length.
    """
    cross = _face_cross(vertices, faces)
    acc = np.zeros_like(vertices)
    for c in range(3):
        np.add.at(acc, faces[:, c], cross)
    length = np.linalg.norm(acc, axis=1)
    out = np.full_like(acc, np.nan)
    ok = length > 0
    out[ok] = acc[ok] / length[ok, None]
    return out


@dataclass(frozen=True, slots=True)
class SynthMesh:
    """A synthetic triangle mesh with exact vertex normals and optional ground truth.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3), float64
        Vertex coordinates (also available as ``points``).
    faces : ndarray of shape (F, 3), int64
        Triangles, counter-clockwise seen from outside (outward normals).
    normals : ndarray of shape (V, 3), float64
        Unit vertex normals: the analytic surface normal where the surface is smooth
        at the vertex; the area-weighted vertex normal of the mesh at vertices on a
        sharp edge or corner (flagged by ``is_sharp``).
    labels : ndarray of shape (V,), int64, optional
        Ground-truth segment of every vertex for piecewise planar (or piecewise
        primitive) shapes: the smallest label among the segments the vertex lies on.
    face_labels : ndarray of shape (F,), int64, optional
        Ground-truth segment of every triangle.
    is_sharp : ndarray of shape (V,), bool, optional
        True for vertices on a sharp edge or corner (normal not analytic); all
        False when omitted.
    name : str
        Short name with the vertex count (``"cube_386"``).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(2)
    >>> m.n_vertices, m.n_faces, int(m.labels.max()) + 1
    (26, 48, 6)
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    labels: np.ndarray | None = None
    face_labels: np.ndarray | None = None
    is_sharp: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        verts = np.array(as_points(self.vertices, name="vertices", min_points=0), copy=True)
        n_v = verts.shape[0]
        object.__setattr__(self, "vertices", readonly(verts))
        tri = _as_faces(self.faces, n_v)
        object.__setattr__(self, "faces", readonly(tri))
        object.__setattr__(self, "normals", readonly(as_normals(self.normals, n_v)))
        if self.labels is not None:
            lab = np.asarray(self.labels)
            if lab.shape != (n_v,):
                raise ValueError(f"labels must have shape ({n_v},); got {lab.shape}")
            object.__setattr__(self, "labels", readonly(lab.astype(np.int64, copy=True)))
        if self.face_labels is not None:
            flab = np.asarray(self.face_labels)
            if flab.shape != (tri.shape[0],):
                raise ValueError(f"face_labels must have shape ({tri.shape[0]},); got {flab.shape}")
            object.__setattr__(self, "face_labels", readonly(flab.astype(np.int64, copy=True)))
        sharp = np.zeros(n_v, dtype=bool) if self.is_sharp is None else np.asarray(self.is_sharp)
        if sharp.shape != (n_v,):
            raise ValueError(f"is_sharp must have shape ({n_v},); got {sharp.shape}")
        object.__setattr__(self, "is_sharp", readonly(sharp.astype(bool, copy=True)))
        object.__setattr__(self, "name", str(self.name))

    @property
    def points(self) -> np.ndarray:
        """The vertices, for use as a point set (alias of ``vertices``)."""
        return self.vertices

    @property
    def n_vertices(self) -> int:
        """Number of vertices V."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of triangles F."""
        return int(self.faces.shape[0])

    def to_point_set(self) -> PointSet:
        """The vertex set with its exact normals as a `pointatlas._core.PointSet`.

        Returns
        -------
        point_set : PointSet
            Points = vertices, normals = exact normals; attributes ``is_sharp`` and,
            when known, ``labels`` (ground-truth segments).

        Examples
        --------
        >>> from pointatlas.synth import cube
        >>> ps = cube(2).to_point_set()
        >>> ps.n_points, sorted(ps.attributes)
        (26, ['is_sharp', 'labels'])
        """
        attrs = {"is_sharp": self.is_sharp}
        if self.labels is not None:
            attrs["labels"] = self.labels
        return PointSet(self.vertices, self.normals, attributes=attrs, name=self.name)


def _edges_of(faces: np.ndarray):
    """Unique undirected edges (E, 2) (smaller index first) and the (F, 3) edge id of
    each face side (side s joins corners s and s+1 mod 3)."""
    sides = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1)  # (F, 3, 2)
    key = np.sort(sides, axis=2).reshape(-1, 2)
    edges, inverse = np.unique(key, axis=0, return_inverse=True)
    return edges, inverse.reshape(faces.shape[0], 3)


def subdivide(vertices: np.ndarray, faces: np.ndarray, frequency: int):
    """Regular subdivision of every triangle into ``frequency**2`` triangles.

    Points shared by neighbouring triangles (on their common edge or vertex) are
    created once, so a closed manifold stays closed. Private helper; validated input.

    Returns
    -------
    vertices : ndarray of shape (V', 3)
    faces : ndarray of shape (F * frequency**2, 3), int64
    parent : ndarray of shape (F * frequency**2,), int64
        The input triangle each new triangle lies in.
    """
    f = int(frequency)
    n_v = vertices.shape[0]
    n_f = faces.shape[0]
    if f == 1:
        return vertices.copy(), faces.copy(), np.arange(n_f, dtype=np.int64)
    edges, side_edge = _edges_of(faces)
    n_e = edges.shape[0]
    # local barycentric grid: P(u, v) = ((f-u-v) a + u b + v c) / f
    uu, vv = np.meshgrid(np.arange(f + 1), np.arange(f + 1), indexing="ij")
    keep = uu + vv <= f
    u, v = uu[keep], vv[keep]
    w = f - u - v
    local = -np.ones((f + 1, f + 1), dtype=np.int64)
    local[u, v] = np.arange(u.size)
    n_int = (f - 1) * (f - 2) // 2
    interior = (u > 0) & (v > 0) & (w > 0)
    int_rank = np.cumsum(interior) - 1

    a, b, c = faces[:, 0:1], faces[:, 1:2], faces[:, 2:3]
    ids = np.empty((n_f, u.size), dtype=np.int64)
    ids[:] = n_v + n_e * (f - 1) + np.arange(n_f)[:, None] * n_int + int_rank[None, :]

    def edge_ids(p, q, side, steps_from_p, mask):
        # canonical position counted from the smaller vertex index
        pos = np.where(p < q, steps_from_p[None, :], f - steps_from_p[None, :])
        val = n_v + side_edge[:, side : side + 1] * (f - 1) + pos - 1
        ids[:, mask] = val[:, mask]

    on_ab = (v == 0) & (u > 0) & (w > 0)
    on_bc = (w == 0) & (u > 0) & (v > 0)
    on_ca = (u == 0) & (v > 0) & (w > 0)
    edge_ids(a, b, 0, u, on_ab)
    edge_ids(b, c, 1, v, on_bc)
    edge_ids(c, a, 2, w, on_ca)
    ids[:, (w == f)] = a
    ids[:, (u == f)] = b
    ids[:, (v == f)] = c

    n_total = n_v + n_e * (f - 1) + n_f * n_int
    out = np.empty((n_total, 3))
    out[:n_v] = vertices
    t = np.arange(1, f)[None, :, None] / f
    p0, p1 = vertices[edges[:, 0]][:, None, :], vertices[edges[:, 1]][:, None, :]
    out[n_v : n_v + n_e * (f - 1)] = ((1 - t) * p0 + t * p1).reshape(-1, 3)
    if n_int:
        bu, bv, bw = u[interior] / f, v[interior] / f, w[interior] / f
        va, vb, vc = (vertices[faces[:, i]][:, None, :] for i in range(3))
        pts = bw[None, :, None] * va + bu[None, :, None] * vb + bv[None, :, None] * vc
        out[n_v + n_e * (f - 1) :] = pts.reshape(-1, 3)

    # triangles of the local grid: up (u,v),(u+1,v),(u,v+1); down (u+1,v),(u+1,v+1),(u,v+1)
    gu, gv = np.meshgrid(np.arange(f), np.arange(f), indexing="ij")
    up = gu + gv <= f - 1
    dn = gu + gv <= f - 2
    tri_up = np.stack(
        [local[gu[up], gv[up]], local[gu[up] + 1, gv[up]], local[gu[up], gv[up] + 1]], axis=1
    )
    tri_dn = np.stack(
        [local[gu[dn] + 1, gv[dn]], local[gu[dn] + 1, gv[dn] + 1], local[gu[dn], gv[dn] + 1]],
        axis=1,
    )
    tri_local = np.concatenate([tri_up, tri_dn])  # (f*f, 3)
    new_faces = ids[:, tri_local].reshape(-1, 3)
    parent = np.repeat(np.arange(n_f, dtype=np.int64), tri_local.shape[0])
    return out, new_faces, parent
